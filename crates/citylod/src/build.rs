//! `citylod build`: ingest → mesh → tiles, then the build report; everything lands atomically in `--out`.

use anyhow::{bail, Context, Result};
use citylod_ingest::{ingest, IngestOptions};
use citylod_ingest::{FeatureIssue, IssueReason};
use citylod_tiles::{write_tileset_with, Compression, Staging, WriteOptions};
use clap::{Args, ValueEnum};
use serde::Serialize;
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use crate::progress::Progress;
use crate::shown;

#[derive(Args, Debug)]
// A negative number is a value (`--storey-height -1` is refused by its range check, naming the flag).
#[command(allow_negative_numbers = true)]
pub struct BuildArgs {
    /// Input files: GeoJSON (.geojson, .json), Esri Shapefile (.shp, read with the .dbf beside it), GeoPackage
    /// (.gpkg, one feature table: see --layer), Esri File Geodatabase (a .gdb folder or a .zip holding one, one
    /// feature class: see --layer), GeoParquet (.parquet, .geoparquet: Overture Maps' buildings; WKB or GeoArrow
    /// polygons), OpenStreetMap PBF or XML (.osm.pbf, .osm, .osm.gz: ways and multipolygon relations tagged building
    /// or building:part, their tags as attributes), CityJSON (.city.json, .json) or CityJSONSeq (.city.jsonl,
    /// .jsonl), CityGML 1.0, 2.0 or 3.0 (.gml, .xml, .citygml, gzip-compressed, or a .zip of such tiles:
    /// Buildings with their BuildingParts, their solids, surfaces and thematic surfaces, attributes and generic
    /// attributes).
    #[arg(required = true, value_name = "INPUT", help_heading = "Input")]
    pub inputs: Vec<PathBuf>,

    /// CRS of the input coordinates, e.g. EPSG:28992. Default: WGS84 lon/lat for GeoJSON (RFC 7946), the .prj's
    /// CRS for a Shapefile (its EPSG code, or the EPSG CRS matching an Esri .prj's parameters), the layer's spatial
    /// reference system for a GeoPackage, the geometry field's spatial reference for a File Geodatabase (identified
    /// as a .prj's), the file's `referenceSystem` for CityJSON, the envelope's `srsName` for CityGML (EPSG codes and
    /// URNs, compound URNs, the AdV's urn:adv:crs names, CH1903; a geographic CRS's coordinates latitude first, as EPSG
    /// orders them), the geo metadata's PROJJSON id for GeoParquet (none: lon/lat). OpenStreetMap data is always WGS84
    /// lon/lat.
    #[arg(long, value_name = "EPSG:CODE", help_heading = "Input")]
    pub crs: Option<String>,

    /// Attribute holding each building's id (for every format; e.g. BIN, BLDG_ID). Default: GeoJSON's `id` (or
    /// `id`, `@id`, OSM's type/id in its properties), a CityJSON object's key, a CityGML object's gml:id, a Shapefile's `id` field, else
    /// FILE#INDEX. Features without a value there keep that default id, listed as repairs.
    #[arg(long, value_name = "NAME", help_heading = "Input")]
    pub id_attr: Option<String>,

    /// The feature table to read from a GeoPackage (e.g. lod12_2d of a 3DBAG download), or the feature class to read
    /// from a File Geodatabase (its name in ArcGIS, in any case, alone or after its feature dataset's:
    /// Dataset/Class). Default: the only one (of a geodatabase: the only polygon or MultiPatch class); a file
    /// holding several is refused with their names. Default ids: an `id` field's value, else FILE#FID, or for a
    /// geodatabase FOLDER.gdb#OBJECTID.
    #[arg(long, value_name = "TABLE", help_heading = "Input")]
    pub layer: Option<String>,

    /// Attribute holding the building height above ground, in metres (strings such as "28 m" are accepted).
    /// Default: the first of height, building:height, measuredHeight, … that a feature has.
    #[arg(long, value_name = "NAME", help_heading = "Input")]
    pub height_attr: Option<String>,

    /// Unit of height attributes given as bare numbers (the height attribute and OSM's min_height): `m` (default),
    /// `ft` (international foot, 0.3048 m) or `us-ft` (US survey foot, 1200/3937 m), as US city data in a State
    /// Plane CRS in feet often has them (e.g. NYC's HEIGHTROOF). Text with its own unit ("28 m", "92 ft", 16'4") is
    /// read in that unit; storey counts, --storey-height and --default-height are not affected.
    #[arg(long, value_enum, value_name = "UNIT", help_heading = "Input")]
    pub height_unit: Option<HeightUnitArg>,

    /// Attribute holding the number of storeys, used when no height attribute is present.
    /// Default: the first of stories, storeys, building:levels, b3_bouwlagen, … that a feature has.
    #[arg(long, value_name = "NAME", help_heading = "Input")]
    pub storey_attr: Option<String>,

    /// Height of one storey in metres, used with the storey count.
    #[arg(long, value_name = "M", default_value_t = 3.0, help_heading = "Input")]
    pub storey_height: f64,

    /// Height in metres for buildings with no height information (counted in the build report).
    #[arg(long, value_name = "M", default_value_t = 10.0, help_heading = "Input")]
    pub default_height: f64,

    /// Metres added to every height on output (the tileset's frame is raised by it). 3D Tiles places content by
    /// ellipsoidal (WGS84) height, while data heights are usually above a geoid or local datum (NAP, NAVD88, …):
    /// give the geoid's height where the data lies (tens of metres, positive in most of Europe, negative in most of
    /// North America) so the buildings stand on a globe's terrain, not above or below it, or use --geoid egm96 and
    /// give here only what your datum differs from it. Footprints without ground heights stand at 0 m; this lifts
    /// them too. Default 0: heights are used as ellipsoidal heights.
    #[arg(
        long,
        value_name = "M",
        default_value_t = 0.0,
        allow_negative_numbers = true,
        help_heading = "Input"
    )]
    pub height_offset: f64,

    /// What the input heights are measured from. `none` (default): they are used as heights above the WGS84
    /// ellipsoid. `egm96`: they are above mean sea level, as NAP, NAVD88 and most national datums are to within
    /// about a metre; the tileset's frame is raised by EGM96's geoid height at its origin (+43 m at Delft, −29 m at
    /// Boston; NGA's 15′ grid, built in), so the buildings stand on a globe's terrain (on a globe without terrain,
    /// whose surface is the ellipsoid, leave it out). The build report records the geoid height used and its range
    /// over the data. Adds to --height-offset.
    #[arg(long, value_enum, default_value_t = GeoidArg::None, help_heading = "Input")]
    pub geoid: GeoidArg,

    /// Read the 3D geometry of CityJSON and CityGML buildings at this LoD (`2.2`, `2`, `1.3`, … or `highest`) and give every
    /// building a chain of detail below its footprint prism: the full model (error 0), a simplified model and the
    /// prism, each with its measured error (sampled two-sided Hausdorff distance to the full model, metres).
    /// `2` means the highest 2.x a building has; a building without the LoD asked uses its highest LoD below it, one
    /// with none at or below it stays a prism (the console and the build report's `mesh_lods` and
    /// `mesh_lod_fallbacks` say how many). Without it, buildings are prisms of their footprints. A GeoPackage layer
    /// of 3D surface models (PolyhedralSurface, TIN, or MultiPolygon Z with walls, as 3DBAG's 3D layers) has one
    /// model per row, a shapefile or File Geodatabase one per MultiPatch: any value takes it (counted as
    /// `GeoPackage 3D`, `MultiPatch`). A building tagged as OpenStreetMap does (an .osm/.osm.pbf file, or its
    /// export to GeoJSON, GeoPackage or Shapefile) with roof:shape skillion, gabled, gambrel, round, half-hipped,
    /// hipped, mansard, pyramidal, cone (as a pyramid), dome or onion (as a dome) gets, at `2`, a 2.x or `highest`,
    /// an LoD 2 model of its roof (roof:height, else roof:levels × --storey-height, else roof:angle — the mean slope
    /// of a two-slope roof — else a 30° slope — a dome or round roof as high as wide — up to half its height;
    /// roof:direction, roof:orientation; a hipped or mansard roof over any outline and its courtyards is its straight
    /// skeleton); other shapes, and pyramids and domes on outlines that are not convex or have courtyards, stay
    /// prisms, listed with the reason. Other polygons ignore it.
    #[arg(long, value_name = "LOD", help_heading = "3D buildings")]
    pub lod: Option<String>,

    /// How the 3D models are simplified: `topo-qem` (QEM that keeps touching parts together, IJGI 2021),
    /// `profile` (horizontal profiles, Zhao and Wang 2014) or `qem` (plain QEM, for comparison only).
    #[arg(
        long,
        value_enum,
        default_value_t = SimplifierArg::TopoQem,
        help_heading = "3D buildings",
        requires = "lod"
    )]
    pub building_simplifier: SimplifierArg,

    /// Share of a model's triangles the simplified level removes, strictly between 0 and 1 (the IJGI 2021 paper used
    /// 0.5, 0.6 and 0.8).
    #[arg(
        long,
        value_name = "RATE",
        default_value_t = 0.6,
        help_heading = "3D buildings",
        requires = "lod"
    )]
    pub building_rate: f64,

    /// Basic cost ratio `a` of topo-qem for vertices where parts touch (≥ 1; the IJGI 2021 paper suggests 1–3 for
    /// simple and 2–8 for complex models).
    #[arg(
        long,
        value_name = "A",
        default_value_t = citylod_mesh::simplify::DEFAULT_TOPO_QEM_A,
        help_heading = "3D buildings",
        requires = "lod"
    )]
    pub topo_qem_a: f64,

    /// Weight λ of the side orientation in the adjacent distance d = d_min·(1 − N·λ), 0–1.
    #[arg(
        long,
        value_name = "λ",
        default_value_t = citylod_generalize::ADJACENT_LAMBDA,
        help_heading = "Generalization"
    )]
    pub lambda_adjacent: f64,

    /// Levels above the buildings: L = max(1, ⌊log₂ n / DIV⌋) before balancing (more levels for smaller DIV).
    #[arg(
        long,
        value_name = "DIV",
        default_value_t = 1.5,
        help_heading = "Generalization"
    )]
    pub depth_divisor: f64,

    /// Simplification removes concave notches smaller than δa = (mean child footprint area) / λa (m²).
    #[arg(
        long,
        value_name = "λa",
        default_value_t = 50.0,
        help_heading = "Generalization"
    )]
    pub lambda_area: f64,

    /// Simplification drops vertices whose angle exceeds this many degrees (nearly straight).
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 175.0,
        help_heading = "Generalization"
    )]
    pub collinear_angle: f64,

    /// A building at least this many metres taller than the rest of its block (their area-weighted mean
    /// height) is a landmark: drawn at full detail on top of the block and left out of the block's height
    /// and Δh, at every level where it still stands out and where that lowers the block's error
    /// max(Δh, κ·√Δa) (on coarse levels, whose error is Δa-bound, the tower is averaged in). `inf` turns
    /// landmarks off.
    #[arg(
        long,
        value_name = "M",
        default_value_t = 20.0,
        help_heading = "Generalization"
    )]
    pub landmark_min_excess: f64,

    /// At most this fraction of a block's buildings are landmarks (tallest first), from 0 (none) up to but not
    /// including 1.
    #[arg(
        long,
        value_name = "SHARE",
        default_value_t = 0.5,
        help_heading = "Generalization"
    )]
    pub landmark_max_share: f64,

    /// Street centre lines (GeoJSON LineString / MultiLineString, Shapefile PolyLines, a GeoPackage's or File
    /// Geodatabase's lines, a GeoParquet file's WKB lines, or an OpenStreetMap file's highway ways: the buildings' own .osm.pbf or .osm serves) as
    /// barriers: the first levels do not join buildings on opposite sides of a street (Zhang et al. 2014). A line
    /// whose attributes say it is not on the ground (OpenStreetMap's tags, in any format: tunnel=yes or T,
    /// indoor=yes, area=yes, highway=construction/proposed/…; Overture's road_flags is_tunnel, is_indoor,
    /// is_under_construction or is_abandoned for a whole segment, or level_rules below the ground) is no barrier. The build report says up to which
    /// level, and lists every street feature not used, with its reason. A file none of whose lines comes within 1 km
    /// of the buildings is refused (usually a CRS mix-up).
    #[arg(long, value_name = "FILE", help_heading = "Generalization")]
    pub streets: Option<PathBuf>,

    /// CRS of the --streets coordinates. Default: the CRS the streets file declares (GeoJSON crs member, .prj,
    /// GeoPackage layer, geodatabase class), else --crs, else lon/lat for GeoJSON.
    #[arg(long, value_name = "EPSG:CODE", help_heading = "Generalization")]
    pub streets_crs: Option<String>,

    /// The layer of a --streets GeoPackage or File Geodatabase to read. Default: its only layer of lines.
    #[arg(long, value_name = "NAME", help_heading = "Generalization")]
    pub streets_layer: Option<String>,

    /// With --streets: metres added to the distance of two buildings a street separates, so blocks join across
    /// a street only after the gaps of up to this width within street blocks.
    #[arg(
        long,
        value_name = "M",
        default_value_t = 30.0,
        help_heading = "Generalization",
        requires = "streets"
    )]
    pub street_penalty: f64,

    /// No generalization: only the buildings, in leaf tiles (for comparisons; coarse views then load everything).
    #[arg(long, help_heading = "Generalization")]
    pub leaves_only: bool,

    /// Also write each level as GeoJSON (WGS84) and PNG into this folder, and levels.png of them all side by side,
    /// for QGIS or a quick look.
    #[arg(long, value_name = "DIR", help_heading = "Generalization")]
    pub dump_levels: Option<PathBuf>,

    /// Height tolerance δH in screen pixels: a block is drawn only while its height spread Δh appears smaller.
    #[arg(
        long,
        value_name = "PX",
        default_value_t = 20.0,
        help_heading = "Level of detail"
    )]
    pub dh_px: f64,

    /// Area tolerance δA in screen pixels²: a block is drawn only while the ground it adds, Δa, appears smaller.
    /// Tile geometricError = max(Δh, √Δa · δH/√δA) metres, so a client refining at SSE = δH honours both.
    #[arg(
        long,
        value_name = "PX²",
        default_value_t = 200.0,
        help_heading = "Level of detail"
    )]
    pub da_px: f64,

    /// Most features (buildings or blocks) in one tile.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 2000,
        value_parser = |s: &str| whole_number(s, "features", 2000),
        help_heading = "Tiles"
    )]
    pub tile_max_features: usize,

    /// Most triangles in one tile (a single larger feature gets a tile of its own).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 200_000,
        value_parser = |s: &str| whole_number(s, "triangles", 200_000),
        help_heading = "Tiles"
    )]
    pub tile_max_triangles: usize,

    /// Write a level of the hierarchy only when it has at most this share of the triangles of the last level
    /// written below it, both counted as generalized (before blocks are re-outlined within their tile's error);
    /// 1 = every level. A level that removes little is barely coarser either, so a client would use it over a
    /// short range of distances while every closer view loads it on the way down; but a low value makes clients
    /// jump further between levels, so views load more: on Boston 0.25 stores 1.03× the bytes of --leaves-only,
    /// and `citylod check`'s views load 4.2× the bytes of the default (measurements: docs/coarse-bytes.md).
    #[arg(
        long,
        value_name = "R",
        default_value_t = 0.8,
        help_heading = "Tiles",
        conflicts_with = "leaves_only"
    )]
    pub level_ratio: f64,

    /// Geometry compression of the glb content.
    #[arg(long, value_enum, default_value_t = CompressionArg::Meshopt, help_heading = "Tiles")]
    pub compression: CompressionArg,

    /// Largest tileset.json in bytes; larger trees are split into external tilesets (tiles/<path>.json), each
    /// within the same limit.
    #[arg(
        long,
        value_name = "BYTES",
        default_value_t = 4_000_000,
        value_parser = |s: &str| whole_number(s, "bytes", 4_000_000),
        help_heading = "Tiles"
    )]
    pub max_tileset_json_bytes: usize,

    /// Output folder; replaced atomically when the build succeeds. It must not exist yet, be empty or hold a
    /// tileset citylod wrote (its tileset.json, build-report.json and tiles/, nothing else): any other folder is
    /// refused unless --force, since all of it is replaced.
    #[arg(long, short, value_name = "DIR", help_heading = "Output")]
    pub out: PathBuf,

    /// Replace the output folder even when it holds files that are not a tileset citylod wrote.
    #[arg(long, help_heading = "Output")]
    pub force: bool,

    /// Record each stage's time in build-report.json (`timings_ms`). Without it the report, like the tiles, is
    /// byte-identical for the same input and options.
    #[arg(long, help_heading = "Output")]
    pub report_timings: bool,

    /// No progress output.
    #[arg(long, short, help_heading = "Output")]
    pub quiet: bool,
}

/// Parses a count flag (`--tile-max-features`, `--max-tileset-json-bytes`, …), saying the form expected when the
/// value is not one: clap then prints "invalid value '4MB' for '--max-tileset-json-bytes <BYTES>': a whole number
/// of bytes, e.g. 4000000" rather than Rust's "invalid digit found in string".
fn whole_number(s: &str, of: &str, example: usize) -> Result<usize, String> {
    s.trim()
        .parse::<usize>()
        .map_err(|_| format!("a whole number of {of}, e.g. {example}"))
}

/// A size as a user reads it: kB below 1 MB (a small tileset is not "0.0 MB"), MB above.
fn size_shown(bytes: u64) -> String {
    if bytes < 1_000_000 {
        format!("{:.1} kB", bytes as f64 / 1e3)
    } else {
        format!("{:.1} MB", bytes as f64 / 1e6)
    }
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum CompressionArg {
    /// EXT_meshopt_compression, required (smallest files; default; clients need a meshopt decoder, as CesiumJS and
    /// three.js have)
    Meshopt,
    /// Quantized geometry without compression
    None,
    /// KHR_draco_mesh_compression (lossless on the quantized geometry; clients need a Draco decoder)
    Draco,
}

/// `--height-unit`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum HeightUnitArg {
    /// Metres
    M,
    /// International feet (0.3048 m)
    Ft,
    /// US survey feet (1200/3937 m)
    UsFt,
}

impl HeightUnitArg {
    pub fn metres(self) -> f64 {
        match self {
            HeightUnitArg::M => 1.0,
            HeightUnitArg::Ft => 0.3048,
            HeightUnitArg::UsFt => 1200.0 / 3937.0,
        }
    }
}

/// `--geoid`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum GeoidArg {
    /// Heights are ellipsoidal heights (default)
    None,
    /// Heights are above the EGM96 geoid (mean sea level)
    Egm96,
}

/// `--building-simplifier`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SimplifierArg {
    /// IJGI 2021: QEM half-edge collapse that keeps touching parts of a building together (default)
    TopoQem,
    /// Zhao and Wang 2014: horizontal profiles every 1 m, a new profile kept where the outline moves by over 0.5 m
    Profile,
    /// Plain QEM (meshoptimizer), for comparison: may tear parts apart
    Qem,
}

impl SimplifierArg {
    pub fn to_simplifier(self, a: f64) -> citylod_mesh::simplify::Simplifier {
        use citylod_mesh::simplify::Simplifier;
        match self {
            SimplifierArg::TopoQem => Simplifier::TopoQem { a },
            SimplifierArg::Profile => Simplifier::Profile {
                step_m: 1.0,
                threshold_m: 0.5,
            },
            SimplifierArg::Qem => Simplifier::Qem,
        }
    }
}

#[derive(Serialize)]
struct BuildReport<'a> {
    citylod_version: &'static str,
    inputs: Vec<String>,
    options: serde_json::Value,
    frame: &'a citylod_model::LocalFrame,
    /// With `--geoid egm96`: the geoid height added to the frame and its range over the buildings.
    #[serde(skip_serializing_if = "Option::is_none")]
    geoid: Option<GeoidUsed>,
    counts: Counts,
    /// Which input attributes have a column of their own, which are folded into one JSON text.
    attributes: crate::features::AttributeSummary,
    ingest: &'a citylod_ingest::IngestReport,
    /// The street lines read with `--streets`: segments, length, every feature not used.
    #[serde(skip_serializing_if = "Option::is_none")]
    streets: Option<citylod_ingest::StreetsReport>,
    mesh_skipped: Vec<FeatureIssue>,
    /// The generalization report without its timings (those go to `timings_ms`, so the rest is deterministic).
    #[serde(skip_serializing_if = "Option::is_none")]
    generalize: Option<serde_json::Value>,
    lod: Vec<LevelSummary>,
    /// The 3D models' chain (with `--lod`): triangles, rates reached, measured errors.
    #[serde(skip_serializing_if = "Option::is_none")]
    models: Option<&'a crate::lod::ModelSummary>,
    tiles: &'a citylod_tiles::WriteStats,
    /// Only with --report-timings.
    #[serde(skip_serializing_if = "Option::is_none")]
    timings_ms: Option<Timings>,
}

/// The geoid height `--geoid` added to the frame's origin, and how far it varies under the buildings (the frame
/// is raised by one value, so buildings far from the origin are off by the difference).
#[derive(Serialize, Debug, Clone, Copy)]
struct GeoidUsed {
    model: &'static str,
    /// At the frame's origin, added to its height.
    height_m: f64,
    /// Lowest and highest over the buildings' bounding box (its corners, edge midpoints and centre).
    min_m: f64,
    max_m: f64,
}

/// EGM96's geoid height at the frame's origin and its range over the buildings' extent. The geoid is smooth over
/// a city (a few centimetres per kilometre), so nine points of the bounding box give its range.
fn geoid_over(
    frame: &citylod_model::LocalFrame,
    buildings: &[citylod_model::Building],
) -> GeoidUsed {
    use geo::BoundingRect;
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for r in buildings
        .iter()
        .filter_map(|bd| bd.footprint.bounding_rect())
    {
        b = [
            b[0].min(r.min().x),
            b[1].min(r.min().y),
            b[2].max(r.max().x),
            b[3].max(r.max().y),
        ];
    }
    let at = |x: f64, y: f64| {
        let [lon, lat, _] = frame.enu_to_geodetic([x, y, 0.0]);
        // The frame's origin and the buildings are finite (ingest refuses the rest), so the lookup answers.
        citylod_ingest::geoid_height_m(lat, lon).unwrap_or(0.0)
    };
    let height_m = at(0.0, 0.0);
    let (mut min_m, mut max_m) = (height_m, height_m);
    for x in [b[0], 0.5 * (b[0] + b[2]), b[2]] {
        for y in [b[1], 0.5 * (b[1] + b[3]), b[3]] {
            let n = at(x, y);
            min_m = min_m.min(n);
            max_m = max_m.max(n);
        }
    }
    let cm = |v: f64| (v * 100.0).round() / 100.0;
    GeoidUsed {
        model: "egm96",
        height_m,
        min_m: cm(min_m),
        max_m: cm(max_m),
    }
}

#[derive(Serialize)]
struct Counts {
    features_read: usize,
    buildings_written: usize,
    repaired: usize,
    skipped: usize,
}

/// One level of the written tree: its nodes, tiles and the spread of their geometric errors.
#[derive(Serialize)]
pub struct LevelSummary {
    pub level: usize,
    pub nodes: usize,
    pub tiles: usize,
    /// The triangles of the level's nodes as written (re-outlined blocks included), one count per node whatever
    /// the tiles draw: a block drawn as its children still counts here (`citylod inspect` reads what tiles hold).
    pub triangles: usize,
    /// The level's triangles as generalized, before its blocks were re-outlined within their tile's error
    /// (equal to `triangles` for the buildings and for levels not written).
    pub triangles_as_generalized: usize,
    /// Blocks whose outline was simplified within their tile's error.
    pub blocks_reoutlined: usize,
    /// Blocks too rough for their tile, drawn there as their children (the buildings, for level 1).
    pub blocks_drawn_as_children: usize,
    /// Smallest and largest geometric error of the level's tiles (m); `None` (null) for a level not written.
    pub geometric_error_min_m: Option<f64>,
    pub geometric_error_max_m: Option<f64>,
    /// Blocks whose merged footprint could not be extruded and that show their buildings instead.
    pub mesh_fallbacks: usize,
}

#[derive(Serialize, Default)]
struct Timings {
    ingest: u64,
    generalize: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    generalize_phases: Option<serde_json::Value>,
    mesh: u64,
    tiles: u64,
    total: u64,
}

/// Lowest storey or default height accepted: lower prisms vanish on the leaves' 2 cm grid (the ingest's limit on
/// any height).
const MIN_HEIGHT_M: f64 = citylod_ingest::MIN_HEIGHT_M;

/// Tallest storey or default height accepted (m): the ingest's limit on any height.
const MAX_HEIGHT_M: f64 = citylod_ingest::MAX_HEIGHT_M;

/// Largest `--dh-px` accepted (px; `--da-px` up to its square): a tolerance larger than any screen.
const MAX_DH_PX: f64 = 10_000.0;

/// Largest `--height-offset` accepted (m): geoid heights stay within ±110 m, local datums closer still.
const MAX_HEIGHT_OFFSET_M: f64 = 1000.0;

pub fn run(args: BuildArgs) -> Result<ExitCode> {
    for (name, v) in [
        ("--storey-height", args.storey_height),
        ("--default-height", args.default_height),
    ] {
        if !(v.is_finite() && (MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&v)) {
            bail!(
                "{name} must be a number of metres from {MIN_HEIGHT_M} to {MAX_HEIGHT_M}, got {}",
                shown(v)
            );
        }
    }
    if !(args.height_offset.is_finite() && args.height_offset.abs() <= MAX_HEIGHT_OFFSET_M) {
        bail!(
            "--height-offset must be a number of metres between -{MAX_HEIGHT_OFFSET_M} and {MAX_HEIGHT_OFFSET_M}, got {}",
            shown(args.height_offset)
        );
    }
    if !(args.collinear_angle > 90.0 && args.collinear_angle <= 180.0) {
        bail!(
            "--collinear-angle must be over 90 and at most 180 degrees, got {}",
            shown(args.collinear_angle)
        );
    }
    for (name, v, max) in [
        ("--dh-px", args.dh_px, MAX_DH_PX),
        ("--da-px", args.da_px, MAX_DH_PX * MAX_DH_PX),
    ] {
        if !(v.is_finite() && v > 0.0 && v <= max) {
            bail!(
                "{name} must be a positive number up to {max}, got {}",
                shown(v)
            );
        }
    }
    if !(args.lambda_area.is_finite() && args.lambda_area > 0.0) {
        bail!(
            "--lambda-area must be a positive number, got {}",
            shown(args.lambda_area)
        );
    }
    if !(args.building_rate > 0.0 && args.building_rate < 1.0) {
        bail!(
            "--building-rate must be in (0, 1), got {}",
            shown(args.building_rate)
        );
    }
    if !(args.topo_qem_a >= 1.0 && args.topo_qem_a.is_finite()) {
        bail!(
            "--topo-qem-a must be at least 1, got {}",
            shown(args.topo_qem_a)
        );
    }
    if !(args.street_penalty.is_finite() && args.street_penalty >= 0.0) {
        bail!(
            "--street-penalty must be a non-negative number of metres, got {}",
            shown(args.street_penalty)
        );
    }
    if !(args.level_ratio > 0.0 && args.level_ratio <= 1.0) {
        bail!(
            "--level-ratio must be in (0, 1], got {}",
            shown(args.level_ratio)
        );
    }
    if args.tile_max_features == 0 || args.tile_max_triangles == 0 {
        bail!("--tile-max-features and --tile-max-triangles must be at least 1");
    }
    if !(0.0..=1.0).contains(&args.lambda_adjacent) {
        bail!(
            "--lambda-adjacent must be in [0, 1], got {}",
            shown(args.lambda_adjacent)
        );
    }
    if !(args.depth_divisor > 0.0 && args.depth_divisor.is_finite()) {
        bail!(
            "--depth-divisor must be a positive number, got {}",
            shown(args.depth_divisor)
        );
    }
    if args.landmark_min_excess.is_nan() || args.landmark_min_excess < 0.0 {
        bail!(
            "--landmark-min-excess must be a non-negative number of metres (inf: no landmarks), got {}",
            shown(args.landmark_min_excess)
        );
    }
    if !(0.0..1.0).contains(&args.landmark_max_share) {
        bail!(
            "--landmark-max-share must be in [0, 1), got {}",
            shown(args.landmark_max_share)
        );
    }
    if args.streets_crs.is_some() && args.streets.is_none() {
        bail!("--streets-crs is the CRS of --streets, which is not given");
    }
    if args.streets_layer.is_some() && args.streets.is_none() {
        bail!("--streets-layer is a layer of --streets, which is not given");
    }
    if args.leaves_only {
        for (given, flag) in [
            (args.streets.is_some(), "--streets shapes"),
            (args.dump_levels.is_some(), "--dump-levels draws"),
        ] {
            if given {
                bail!("{flag} the generalization, which --leaves-only leaves out");
            }
        }
    }
    check_output_folder(&args)?;
    let t_all = Instant::now();
    let progress = Progress::new(args.quiet);
    let mut timings = Timings::default();

    progress.stage("reading input");
    let t = Instant::now();
    let opts = IngestOptions {
        crs: args.crs.clone(),
        height_attr: args.height_attr.clone(),
        height_unit_m: args.height_unit.map(HeightUnitArg::metres),
        id_attr: args.id_attr.clone(),
        layer: args.layer.clone(),
        storey_attr: args.storey_attr.clone(),
        storey_height_m: args.storey_height,
        default_height_m: args.default_height,
        lod: args
            .lod
            .as_deref()
            .map(str::parse::<citylod_ingest::LodChoice>)
            .transpose()
            .map_err(|e| anyhow::anyhow!("--lod: {e}"))?,
    };
    let mut ingested = ingest(&args.inputs, &opts).context("reading the input")?;
    // Positions are relative to the frame's origin, so raising the origin raises everything.
    let geoid = match args.geoid {
        GeoidArg::Egm96 if !ingested.buildings.is_empty() => {
            let g = geoid_over(&ingested.frame, &ingested.buildings);
            ingested.frame.origin_h_m += g.height_m;
            ingested.report.frame_rule = format!(
                "{}; then raised by EGM96's geoid height there, {:.2} m (--geoid egm96)",
                ingested.report.frame_rule, g.height_m
            );
            Some(g)
        }
        _ => None,
    };
    if args.height_offset != 0.0 && !ingested.buildings.is_empty() {
        ingested.frame.origin_h_m += args.height_offset;
        ingested.report.frame_rule = format!(
            "{}; then raised by --height-offset {} m",
            ingested.report.frame_rule, args.height_offset
        );
    }
    timings.ingest = t.elapsed().as_millis() as u64;
    for (flag, name) in [
        ("--height-attr", &args.height_attr),
        ("--storey-attr", &args.storey_attr),
    ] {
        if let Some(name) = name {
            named_attribute_is_present(flag, name, &ingested.buildings)?;
        }
    }
    if ingested.buildings.is_empty() {
        let skipped = &ingested.report.skipped;
        let mut why: String = skipped
            .iter()
            .take(SKIPS_SHOWN)
            .map(|i| {
                format!(
                    "\n  {} in {}: {} ({})",
                    i.feature_id,
                    i.file,
                    i.reason.as_str(),
                    i.detail
                )
            })
            .collect();
        if skipped.len() > SKIPS_SHOWN {
            why += &format!("\n  … and {} more", skipped.len() - SKIPS_SHOWN);
        }
        // Most features lost the same way: coordinates read in the wrong CRS.
        let most = |reason: &str| {
            2 * skipped
                .iter()
                .filter(|i| i.reason.as_str() == reason)
                .count()
                > skipped.len()
        };
        if most("coordinate_out_of_range") && args.crs.is_none() {
            why += "\n  hint: the coordinates are not longitude/latitude degrees; if the file is in a projected CRS it \
                    does not declare, give it with --crs (e.g. --crs EPSG:28992)";
        } else if most("zero_area") {
            if let Some(crs) = &args.crs {
                why += &format!(
                    "\n  hint: the footprints have almost no area in {crs}'s units; are the coordinates longitude/\
                     latitude degrees? then leave --crs out (GeoJSON is lon/lat by RFC 7946)"
                );
            } else if let Some(f) = ingested
                .report
                .files
                .iter()
                .find(|f| f.crs.starts_with("EPSG:") && f.crs != "EPSG:4326")
            {
                // The file declared (or its .prj was identified as) a projected CRS its coordinates do not fit.
                why += &format!(
                    "\n  hint: the footprints have almost no area in {} (the CRS {} declares); are the coordinates \
                     longitude/latitude degrees? then give --crs EPSG:4326",
                    f.crs, f.path
                );
            }
        }
        let others: usize = ingested
            .report
            .files
            .iter()
            .map(|f| f.non_building_objects)
            .sum();
        if others > 0 {
            why += &format!(
                "\n  the input holds {others} city object(s) that are not buildings (terrain, roads, vegetation, …): \
                 citylod reads Building and BuildingPart objects only"
            );
        }
        bail!(
            "no building could be read from the input ({} features read, {} skipped){}{why}",
            ingested.report.features_read,
            skipped.len(),
            if skipped.is_empty() { "" } else { ":" }
        );
    }

    let mut generalized = None;
    let mut streets_report = None;
    if !args.leaves_only {
        progress.stage("generalizing");
        let t = Instant::now();
        let opts = citylod_generalize::GeneralizeOptions {
            lambda_adjacent: args.lambda_adjacent,
            depth_divisor: args.depth_divisor,
            lambda_area: args.lambda_area,
            collinear_angle_deg: args.collinear_angle,
            landmark_min_excess_m: args.landmark_min_excess,
            landmark_max_share: args.landmark_max_share,
            error_kappa: args.dh_px / args.da_px.sqrt(),
            street_penalty_m: args.street_penalty,
            ..Default::default()
        };
        let segments = match &args.streets {
            Some(path) => {
                let s = citylod_ingest::read_streets(
                    path,
                    args.streets_crs.as_deref(),
                    args.streets_layer.as_deref(),
                    args.crs.as_deref(),
                    &ingested.frame,
                )
                .context("reading the streets")?;
                streets_near_buildings(&s.segments, &ingested.buildings).with_context(|| {
                    format!("--streets {}: read in {}", path.display(), s.report.crs)
                })?;
                let segments = s.segments;
                streets_report = Some(s.report);
                segments
            }
            None => Vec::new(),
        };
        let g = citylod_generalize::generalize_with_streets(&ingested.buildings, &opts, &segments)
            .context("generalizing the footprints")?;
        timings.generalize = t.elapsed().as_millis() as u64;
        if let Some(dir) = &args.dump_levels {
            citylod_generalize::dump_levels(
                dir,
                &g.hierarchy,
                &ingested.buildings,
                &ingested.frame,
            )
            .with_context(|| format!("writing the level pictures to {}", dir.display()))?;
        }
        generalized = Some(g);
    }

    progress.stage("meshing");
    let t = Instant::now();
    let kappa = args.dh_px / args.da_px.sqrt();
    let models = crate::lod::ModelOptions {
        simplifier: args.building_simplifier.to_simplifier(args.topo_qem_a),
        rate: args.building_rate,
    };
    let lod = crate::lod::LodTree::build(
        &ingested.buildings,
        generalized.as_ref().map(|g| &g.hierarchy),
        kappa,
        args.collinear_angle,
        &models,
    );
    timings.mesh = t.elapsed().as_millis() as u64;
    let file_of = |b: usize| file_of_building(&ingested.report.files, b);
    let mesh_skipped: Vec<FeatureIssue> = lod
        .failed_buildings
        .iter()
        .map(|(b, e)| FeatureIssue {
            file: file_of(b.0 as usize),
            feature_id: ingested.buildings[b.0 as usize].source_id.clone(),
            reason: IssueReason::MeshFailed,
            detail: e.clone(),
        })
        .collect();

    progress.stage("writing tiles");
    let t = Instant::now();
    let written = ingested.buildings.len() - mesh_skipped.len();
    let budget = citylod_tiles::hlod::TileBudget {
        max_features: args.tile_max_features,
        max_triangles: args.tile_max_triangles,
    };
    let (plan, root, lod_summary) = lod.tiles(budget, args.level_ratio);
    let write_opts = WriteOptions {
        compression: match args.compression {
            CompressionArg::Meshopt => Compression::Meshopt,
            CompressionArg::None => Compression::None,
            CompressionArg::Draco => Compression::Draco,
        },
        max_tileset_json_bytes: args.max_tileset_json_bytes,
        // The pixel tolerances the errors were made for, so `citylod check` can read them back.
        extras: Some(serde_json::json!({"citylod": {
            "dh_px": args.dh_px, "da_px": args.da_px, "kappa": kappa, "version": env!("CARGO_PKG_VERSION"),
        }})),
        ..Default::default()
    };
    let staging =
        Staging::create(&args.out).with_context(|| format!("preparing {}", args.out.display()))?;
    // Each tile's features are made as the writer reaches it and dropped once its glb is written.
    let stats = write_tileset_with(
        &staging,
        &root,
        &ingested.frame,
        &crate::features::schema(&lod.building_table),
        &write_opts,
        &|r| Cow::Owned(plan.features(r)),
    )
    .with_context(|| format!("writing the tileset to {}", args.out.display()))?;
    timings.tiles = t.elapsed().as_millis() as u64;
    timings.total = t_all.elapsed().as_millis() as u64;
    let mut generalize_report = generalized
        .as_ref()
        .map(|g| serde_json::to_value(&g.report))
        .transpose()?;
    timings.generalize_phases = generalize_report
        .as_mut()
        .and_then(|v| v.as_object_mut()?.remove("timings"));
    let r = &ingested.report;
    let report = BuildReport {
        citylod_version: env!("CARGO_PKG_VERSION"),
        inputs: args
            .inputs
            .iter()
            .map(|p| p.display().to_string())
            .collect(),
        options: serde_json::json!({
            "crs": args.crs, "height_attr": args.height_attr, "height_unit": args.height_unit, "storey_attr": args.storey_attr,
            "storey_height_m": args.storey_height, "default_height_m": args.default_height,
            "height_offset_m": args.height_offset, "geoid": args.geoid,
            "tile_max_features": args.tile_max_features, "tile_max_triangles": args.tile_max_triangles,
            "lod": args.lod, "building_simplifier": args.building_simplifier, "building_rate": args.building_rate,
            "topo_qem_a": args.topo_qem_a,
            "level_ratio": args.level_ratio,
            "lambda_adjacent": args.lambda_adjacent, "depth_divisor": args.depth_divisor,
            "lambda_area": args.lambda_area, "collinear_angle_deg": args.collinear_angle,
            "landmark_min_excess_m": args.landmark_min_excess, "landmark_max_share": args.landmark_max_share,
            "leaves_only": args.leaves_only, "streets": args.streets, "streets_crs": args.streets_crs, "streets_layer": args.streets_layer, "street_penalty_m": args.street_penalty, "dh_px": args.dh_px, "da_px": args.da_px,
            "compression": format!("{:?}", args.compression).to_lowercase(),
            "max_tileset_json_bytes": args.max_tileset_json_bytes,
        }),
        frame: &ingested.frame,
        geoid,
        counts: Counts {
            features_read: r.features_read,
            buildings_written: written,
            repaired: r.repaired.len(),
            skipped: r.skipped.len() + mesh_skipped.len(),
        },
        attributes: lod.building_table.summary(),
        ingest: r,
        streets: streets_report,
        mesh_skipped,
        generalize: generalize_report,
        lod: lod_summary,
        models: lod.model_summary.as_ref(),
        tiles: &stats,
        timings_ms: args.report_timings.then_some(timings),
    };
    let mut bytes = serde_json::to_vec_pretty(&report)?;
    bytes.push(b'\n');
    staging.write_file("build-report.json", &bytes)?;
    let left_behind = staging
        .commit()
        .with_context(|| format!("moving the tileset into {}", args.out.display()))?;
    if let Some(l) = left_behind {
        eprintln!(
            "warning: the previous tileset, moved to {}, could not be deleted ({}); delete it yourself",
            l.path.display(),
            l.error
        );
    }
    progress.finish();

    if !args.quiet {
        eprintln!(
            "citylod: {} of {} features written as buildings ({} repaired, {} skipped) into {} {}, {}, in {:.2} s",
            written,
            r.features_read,
            r.features_repaired,
            report.counts.skipped,
            stats.tiles,
            if stats.tiles == 1 { "tile" } else { "tiles" },
            size_shown(stats.glb_bytes as u64),
            t_all.elapsed().as_secs_f64()
        );
        for (reason, n) in &r.skipped_by_reason {
            eprintln!("  skipped {n:>6} × {reason}");
        }
        // Repairs by reason, as skips (a feature may have more than one repair, so these may sum above the total).
        for (reason, n) in &r.repaired_by_reason {
            eprintln!("  repaired {n:>5} × {reason}");
        }
        // Heights the data gave and citylod did not use change what is drawn: say so here, not only in the report.
        let rejected = citylod_ingest::IssueReason::HeightValueRejected.as_str();
        if let Some(n) = r.repaired_by_reason.get(rejected) {
            eprintln!(
                "  {n} height value(s) not used (not a number, out of range, an ambiguous comma, a base above the \
                 height): listed as {rejected} in build-report.json with each feature's id and value"
            );
        }
        // What concerns a file as a whole (a shapefile's code page assumed, fields not read).
        for f in &r.files {
            for note in &f.notes {
                eprintln!("  {}: {note}", f.path);
            }
        }
        // Buildings left without a model are prisms: say how many, or `--lod` may seem to have done nothing.
        if args.lod.is_some() {
            let with = lod.model_summary.as_ref().map_or(0, |m| m.buildings);
            let prisms = written.saturating_sub(with);
            // Which LoDs were read: a building without the one asked uses its highest below it.
            let lods: Vec<String> = r
                .mesh_lods
                .iter()
                .map(|(l, n)| format!("{n} at LoD {l}"))
                .collect();
            eprintln!(
                "  3D models: {with} of {written} buildings{}{}{}",
                if lods.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", lods.join(", "))
                },
                if r.mesh_lod_fallbacks > 0 {
                    format!(
                        "; {} had no LoD {} and use their highest below it",
                        r.mesh_lod_fallbacks,
                        args.lod.as_deref().unwrap_or_default()
                    )
                } else {
                    String::new()
                },
                if prisms > 0 {
                    format!("; {prisms} without one are prisms")
                } else {
                    String::new()
                }
            );
        }
        // The simplified level: how much it removed against --building-rate, so a level that is nearly the full
        // models (the error bound stopped the simplifier) does not pass unseen.
        if let Some(m) = lod.model_summary.as_ref().filter(|m| m.triangles_full > 0) {
            let removed = 1.0 - m.triangles_simplified as f64 / m.triangles_full as f64;
            eprintln!(
                "  simplified models: {} of {} triangles ({:.0} % removed, --building-rate {:.0} %){}",
                m.triangles_simplified,
                m.triangles_full,
                100.0 * removed,
                100.0 * m.rate_target,
                if m.short_of_target > 0 {
                    format!(
                        "; {} of {} stopped short of the rate, where a further step would move a surface more than \
                         the bound (build-report.json: models.short_of_target)",
                        m.short_of_target, m.buildings
                    )
                } else {
                    String::new()
                }
            );
        }
        for (reason, n) in &r.mesh_issues_by_reason {
            eprintln!("  3D model {n:>5} × {reason}");
        }
        if r.duplicate_ids > 0 {
            eprintln!(
                "  {} {} id with an earlier one (another footprint or height: both written)",
                plural(r.duplicate_ids, "building"),
                if r.duplicate_ids == 1 {
                    "shares its"
                } else {
                    "share their"
                }
            );
        }
        if let Some(s) = &report.streets {
            let barrier = generalized.as_ref().and_then(|g| g.report.streets.as_ref());
            eprintln!(
                "  streets: {} of {} features used ({:.1} km); no block joins across a street up to level {}",
                s.features_used,
                s.features_read,
                s.length_m / 1e3,
                barrier.map_or(0, |b| b.barrier_level)
            );
        }
        eprintln!("  tileset: {}", args.out.join("tileset.json").display());
        eprintln!(
            "  report:  {}",
            args.out.join("build-report.json").display()
        );
    }
    // The command ends here and the process with it: freeing the buildings, the hierarchy and the meshes one
    // allocation at a time would only delay the exit (~30 ms on Boston, seconds on a million buildings).
    std::mem::forget(lod);
    std::mem::forget(generalized);
    std::mem::forget(ingested);
    Ok(ExitCode::SUCCESS)
}

/// The file building `b` (an index into the written buildings) was read from: buildings come file by file, in the
/// order of the ingest report's files. Empty past the last.
fn file_of_building(files: &[citylod_ingest::FileReport], b: usize) -> String {
    let mut end = 0;
    files
        .iter()
        .find(|f| {
            end += f.buildings_written;
            b < end
        })
        .map_or(String::new(), |f| f.path.clone())
}

/// "1 building", "2 buildings".
pub(crate) fn plural(n: usize, noun: &str) -> String {
    format!("{n} {noun}{}", if n == 1 { "" } else { "s" })
}

/// Skipped features listed when none could be read (the report is not written then).
const SKIPS_SHOWN: usize = 10;

/// The first of `path` and its ancestors that exists and is not a folder (a file there makes creating `path` as
/// a folder fail), if any.
fn existing_non_folder(path: &Path) -> Option<PathBuf> {
    path.ancestors()
        .filter(|a| !a.as_os_str().is_empty())
        .find(|a| std::fs::symlink_metadata(a).is_ok())
        .filter(|a| !a.is_dir())
        .map(Path::to_path_buf)
}

/// Refuses an output path whose replacement would destroy something that citylod did not write: a file, a symbolic
/// link, a folder holding an input (or the level dumps), a non-empty folder without a `tileset.json` that citylod
/// wrote or with entries besides those it writes (these two unless `--force`), or one holding a previous tileset
/// that a stopped build saved there. First puts back what stopped builds left ([`Staging::recover`]), saying so.
fn check_output_folder(args: &BuildArgs) -> Result<()> {
    let out = &args.out;
    // First what builds stopped while writing here left: a previous tileset they had moved aside goes back.
    let notes = Staging::recover(out)
        .with_context(|| format!("recovering what a stopped build left of {}", out.display()))?;
    for note in notes {
        eprintln!("{note}");
    }
    // Inside `out` as written, or once symbolic links are resolved (only when `out` exists).
    let out_real = std::fs::canonicalize(out).ok();
    let inside = |p: &Path| {
        let lexical = matches!(
            (lexically_absolute(p), lexically_absolute(out)),
            (Some(p), Some(o)) if p.starts_with(&o)
        );
        let resolved = out_real
            .as_ref()
            .is_some_and(|o| std::fs::canonicalize(p).is_ok_and(|p| p.starts_with(o)));
        lexical || resolved
    };
    if let Some(d) = args.dump_levels.as_deref().filter(|d| inside(d)) {
        bail!(
            "--dump-levels {} is inside the output folder {}, which the build replaces as a whole",
            d.display(),
            out.display()
        );
    }
    if let Some(dir) = args.dump_levels.as_deref() {
        // A dump writes and removes level-<k>.geojson / .png and levels.png in its folder: never an input.
        let dir_real = std::fs::canonicalize(dir).ok();
        let clobbered = args
            .inputs
            .iter()
            .map(PathBuf::as_path)
            .chain(args.streets.as_deref())
            .find(|p| {
                // The path as given (a link named like a dump's file is written through) and the file it is.
                let given = lexically_absolute(p);
                [given, std::fs::canonicalize(p).ok()]
                    .into_iter()
                    .flatten()
                    .any(|f| {
                        let named = f.file_name().is_some_and(|n| {
                            citylod_generalize::is_dump_file_name(&n.to_string_lossy())
                        });
                        let parent = f.parent().and_then(|d| std::fs::canonicalize(d).ok());
                        named && dir_real.is_some() && parent == dir_real
                    })
            });
        if let Some(p) = clobbered {
            bail!(
                "input {} would be overwritten by --dump-levels {}, which writes level-<k>.geojson, level-<k>.png \
                 and levels.png there (and removes those of an earlier dump); rename the input or dump elsewhere",
                p.display(),
                dir.display()
            );
        }
    }
    if let Some(dir) = args.dump_levels.as_deref() {
        if let Some(file) = existing_non_folder(dir) {
            bail!(
                "--dump-levels {}: {} is a file, not a folder; the level dumps are written into a folder (made \
                 when missing): give another path",
                dir.display(),
                file.display()
            );
        }
    }
    // The build stages beside `out`, in its parent folder (made when missing): one that cannot be is said now,
    // not after the build.
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if let Some(file) = existing_non_folder(parent) {
        bail!(
            "cannot create the output folder {}: {} {} is not a folder; choose another --out",
            out.display(),
            if file == parent {
                "its parent"
            } else {
                "on its path,"
            },
            file.display()
        );
    }
    if !out.is_dir() {
        let mut holder = parent;
        while !holder.exists() {
            match holder.parent().filter(|p| !p.as_os_str().is_empty()) {
                Some(p) => holder = p,
                None => {
                    holder = Path::new(".");
                    break;
                }
            }
        }
        let probe = holder.join(format!(".citylod-probe-{}", std::process::id()));
        match std::fs::create_dir(&probe) {
            Ok(()) => {
                let _ = std::fs::remove_dir(&probe);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => bail!(
                "cannot create the output folder {}: {} is not writable ({}); choose another --out",
                out.display(),
                holder.display(),
                e.kind()
            ),
        }
    }
    let Ok(meta) = std::fs::symlink_metadata(out) else {
        return Ok(()); // nothing there yet
    };
    if meta.file_type().is_symlink() {
        bail!(
            "--out {} is a symbolic link; the build would replace it with a folder. Give the folder it points to",
            out.display()
        );
    }
    if !meta.is_dir() {
        bail!(
            "--out {} is a file, not a folder; the build writes a folder there and would replace the file",
            out.display()
        );
    }
    let ours = args
        .inputs
        .iter()
        .map(PathBuf::as_path)
        .chain(args.streets.as_deref());
    if let Some(p) = ours.into_iter().find(|p| inside(p)) {
        bail!(
            "input {} is inside the output folder {}, which the build replaces as a whole; write the tileset \
             elsewhere",
            p.display(),
            out.display()
        );
    }
    if std::env::current_dir().is_ok_and(|here| inside(&here)) {
        bail!(
            "--out {} is the folder you are in, or holds it; the build replaces the whole folder and would leave \
             you in a deleted one. Run from another folder or write the tileset elsewhere",
            out.display()
        );
    }
    // What citylod wrote is replaced; anything else in the folder is refused (unless --force), named.
    // (Its own staging folders `.citylod-…`, where it stages inside the output folder, do not count.)
    if let Some(old) = Staging::saved_inside(out).first() {
        let folder = old.parent().unwrap_or(old);
        bail!(
            "--out {} holds {}: the previous tileset, saved there by a build that was stopped while replacing it and \
             that may still be running. If no build is, move the entries of {} back into {} and delete {}; then \
             build again",
            out.display(),
            old.display(),
            old.display(),
            out.display(),
            folder.display()
        );
    }
    let mut entries: Vec<String> = std::fs::read_dir(out)
        .with_context(|| format!("reading {}", out.display()))?
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let dir = e.file_type().is_ok_and(|t| t.is_dir());
            (!name.starts_with(citylod_tiles::STAGING_INSIDE_PREFIX)).then(|| {
                if dir {
                    format!("{name}/")
                } else {
                    name
                }
            })
        })
        .collect();
    entries.sort();
    if entries.is_empty() || args.force {
        return Ok(());
    }
    let replace =
        "Give a new or empty folder, or pass --force to replace the folder with everything in it";
    let tileset = out.join("tileset.json");
    if !std::fs::symlink_metadata(&tileset).is_ok_and(|m| m.is_file()) {
        bail!(
            "--out {} holds files but no tileset.json ({}); the build replaces the whole folder. {replace}",
            out.display(),
            listed(&entries)
        );
    }
    if let Some(why) = not_written_by_citylod(&tileset) {
        bail!(
            "--out {} holds a tileset.json that citylod did not write ({why}); the build replaces the whole \
             folder. {replace}",
            out.display()
        );
    }
    let foreign = foreign_entries(out)?;
    if !foreign.is_empty() {
        bail!(
            "--out {} holds a tileset citylod wrote and {} it did not write: {}; the build replaces the whole \
             folder, these included. Move them elsewhere, give another folder, or pass --force to replace the \
             folder with everything in it",
            out.display(),
            if foreign.len() == 1 { "an entry" } else { "entries" },
            listed(&foreign)
        );
    }
    Ok(())
}

/// The first names of `names`, "and N more".
fn listed(names: &[String]) -> String {
    const SHOWN: usize = 6;
    let mut s = names
        .iter()
        .take(SHOWN)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if names.len() > SHOWN {
        s += &format!(" and {} more", names.len() - SHOWN);
    }
    s
}

/// Why the `tileset.json` at `path` is not one citylod wrote (its `asset.generator` says "citylod <version>"), or
/// `None` when it is.
fn not_written_by_citylod(path: &Path) -> Option<String> {
    #[derive(serde::Deserialize)]
    struct Head {
        asset: Option<Asset>,
    }
    #[derive(serde::Deserialize)]
    struct Asset {
        generator: Option<serde_json::Value>,
    }
    let file = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) => return Some(format!("it cannot be read: {e}")),
    };
    match serde_json::from_reader::<_, Head>(std::io::BufReader::new(file)) {
        Err(e) if e.is_syntax() || e.is_eof() => Some(format!("it is not JSON: {e}")),
        Err(e) => Some(format!("it is not a tileset: {e}")),
        Ok(Head {
            asset:
                Some(Asset {
                    generator: Some(serde_json::Value::String(g)),
                }),
        }) if citylod_tiles::written_by_citylod(&g) => None,
        Ok(Head {
            asset: Some(Asset { generator: Some(g) }),
        }) => Some(format!("its asset.generator is {g}")),
        Ok(_) => Some("it names no asset.generator".into()),
    }
}

/// The entries of the folder `out` that a build does not write, as paths relative to it (a folder with a trailing
/// `/`): a build writes `tileset.json`, `build-report.json` and `tiles/` with folders, `.glb` and `.json` files in
/// it; symbolic links never. Its staging folders (`.citylod-…`) are left out.
fn foreign_entries(out: &Path) -> Result<Vec<String>> {
    fn sorted(dir: &Path) -> Result<Vec<(String, std::fs::Metadata, PathBuf)>> {
        let mut v = Vec::new();
        for e in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
            let e = e.with_context(|| format!("reading {}", dir.display()))?;
            let meta = std::fs::symlink_metadata(e.path())
                .with_context(|| format!("reading {}", e.path().display()))?;
            v.push((e.file_name().to_string_lossy().into_owned(), meta, e.path()));
        }
        v.sort_by(|a, b| a.0.cmp(&b.0));
        Ok(v)
    }
    fn tiles(dir: &Path, rel: &str, found: &mut Vec<String>) -> Result<()> {
        for (name, meta, path) in sorted(dir)? {
            if meta.is_dir() {
                tiles(&path, &format!("{rel}{name}/"), found)?;
            } else if !(meta.is_file() && (name.ends_with(".glb") || name.ends_with(".json"))) {
                found.push(format!("{rel}{name}"));
            }
        }
        Ok(())
    }
    let mut found = Vec::new();
    for (name, meta, path) in sorted(out)? {
        match name.as_str() {
            _ if name.starts_with(citylod_tiles::STAGING_INSIDE_PREFIX) => {}
            "tileset.json" | "build-report.json" if meta.is_file() => {}
            "tiles" if meta.is_dir() => tiles(&path, "tiles/", &mut found)?,
            _ if meta.is_dir() => found.push(format!("{name}/")),
            _ => found.push(name),
        }
    }
    Ok(found)
}

/// `p` made absolute with its `..` steps taken as written (`std::path::absolute` keeps them, so `out/../x` would
/// seem to lie inside `out`); symbolic links are the canonical check's part.
fn lexically_absolute(p: &Path) -> Option<PathBuf> {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in std::path::absolute(p).ok()?.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    Some(out)
}

/// Farthest a street line may lie from every building for the streets file to be taken (m).
const STREETS_REACH_M: f64 = 1000.0;

/// An error unless some street segment comes within [`STREETS_REACH_M`] of the buildings' bounding rectangle:
/// streets read in the wrong CRS land far away (or all on a point) and would silently bar nothing.
fn streets_near_buildings(
    segments: &[[[f64; 2]; 2]],
    buildings: &[citylod_model::Building],
) -> Result<()> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for b in buildings {
        for p in &b.footprint.0 {
            for c in &p.exterior().0 {
                lo = [lo[0].min(c.x), lo[1].min(c.y)];
                hi = [hi[0].max(c.x), hi[1].max(c.y)];
            }
        }
    }
    let near = segments.iter().any(|[a, b]| {
        (0..2).all(|k| {
            a[k].max(b[k]) >= lo[k] - STREETS_REACH_M && a[k].min(b[k]) <= hi[k] + STREETS_REACH_M
        })
    });
    if segments.is_empty() && !buildings.is_empty() {
        bail!(
            "it holds no usable street line (a line of at least two distinct points); \
             every feature of it was set aside"
        );
    }
    if !near && !buildings.is_empty() {
        bail!(
            "none of its {} street segments comes within {STREETS_REACH_M} m of the buildings; are they in another \
             CRS? (give it with --streets-crs)",
            segments.len()
        );
    }
    Ok(())
}

/// An error when a height or storey attribute the user named is held by no written building (a misspelt name
/// would otherwise give every building the next rule's height, silently).
fn named_attribute_is_present(
    flag: &str,
    name: &str,
    buildings: &[citylod_model::Building],
) -> Result<()> {
    if buildings.is_empty() {
        return Ok(());
    }
    let present = buildings.iter().any(|b| {
        b.attributes
            .iter()
            .any(|(k, v)| k == name && *v != citylod_model::AttrValue::Null)
    });
    if !present {
        let mut seen: Vec<&str> = buildings
            .iter()
            .flat_map(|b| b.attributes.iter().map(|(k, _)| k.as_str()))
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        let more = seen.len().saturating_sub(20);
        seen.truncate(20);
        bail!(
            "{flag} {name}: no building has this attribute; attributes seen: {}{}",
            if seen.is_empty() {
                "none".to_string()
            } else {
                seen.join(", ")
            },
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_building_is_placed_in_its_file_by_the_counts_written_before_it() {
        let file = |path: &str, buildings_written: usize| citylod_ingest::FileReport {
            path: path.into(),
            format: citylod_ingest::InputFormat::GeoJson,
            crs: String::new(),
            cityjson_version: None,
            features_read: buildings_written,
            buildings_written,
            skipped: 0,
            non_building_objects: 0,
            notes: Vec::new(),
        };
        // A file whose features were all skipped holds no building index.
        let files = [file("a", 2), file("empty", 0), file("b", 3)];
        let of: Vec<String> = (0..6).map(|b| file_of_building(&files, b)).collect();
        assert_eq!(of, ["a", "a", "b", "b", "b", ""]);
    }
}
