//! The ingest report: every file read, every feature skipped or repaired (file, feature id, a
//! machine-readable reason and a human detail), and counts of height and ground sources.
//! Invariant: `features_read == buildings_written + skipped.len()`; a repaired feature is written.
//! 3D models (when asked) are extra: a building whose model is missing or broken is still written,
//! and its model's problems are listed apart (`mesh_issues`).

use serde::Serialize;
use std::collections::BTreeMap;

/// Machine-readable reason of a skip or a repair (serialized in snake_case).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum IssueReason {
    // --- skips ---
    /// The feature has no geometry (`"geometry": null`, or a CityJSON building without any).
    NoGeometry,
    /// The geometry is not polygonal (Point, LineString, …).
    UnsupportedGeometry,
    /// The geometry JSON is malformed (coordinates not arrays of numbers, vertex index out of range).
    MalformedGeometry,
    /// A polygonal geometry with no coordinates.
    EmptyGeometry,
    /// A coordinate is NaN or infinite.
    NonFiniteCoordinate,
    /// A coordinate is outside the valid range of its CRS (|lon| > 180 or |lat| > 90).
    CoordinateOutOfRange,
    /// The CRS transformation failed or gave a non-finite result.
    TransformFailed,
    /// No ring has at least 3 distinct points.
    TooFewPoints,
    /// The footprint area is below 0.01 m².
    ZeroArea,
    /// A CityJSON building whose geometry gives no footprint (no LoD0, ground surface or horizontal base).
    NoFootprint,
    /// Repairing an invalid polygon failed.
    RepairFailed,
    /// The footprint could not be turned into a mesh (reported by the mesh stage, after ingest).
    MeshFailed,
    /// The same id, footprint and heights as a building read before (a file given twice, overlapping
    /// extracts): written once. The detail names the attributes whose values differ (the first's are written).
    Duplicate,
    /// A Shapefile record its `.dbf` marks deleted (`*`): the shape and its attributes are not read, as GIS tools
    /// do not show them.
    DeletedRecord,
    /// A File Geodatabase row whose bytes cannot be read (the row index points outside the table, the row ends inside
    /// a field): skipped with its OBJECTID and what is wrong; the rows around it are read.
    UnreadableRow,
    /// A `--streets` line whose attributes say it is no street on the ground between buildings, so no barrier: in
    /// a tunnel, indoors, an area, or a road not yet or no longer built (OpenStreetMap's `tunnel`, `indoor`, `area`
    /// and `highway` tags, also as attributes of a GeoJSON, Shapefile, GeoPackage or geodatabase line, e.g.
    /// Geofabrik's `tunnel` = `T`). The detail names the attribute and its value.
    NotOnGround,
    // --- repairs ---
    /// A GeoJSON ring whose last point did not repeat the first was closed.
    RingClosed,
    /// Consecutive repeated points were removed.
    RepeatedPointsRemoved,
    /// A hole with fewer than 3 distinct points or no area was dropped.
    DegenerateHoleDropped,
    /// One polygon of a multi-polygon was degenerate (< 3 points or < 0.01 m²) and dropped.
    DegeneratePartDropped,
    /// A hole lying outside its shell was dropped.
    HoleOutsideShell,
    /// A self-touching or self-intersecting polygon was rebuilt into valid polygons.
    SelfIntersection,
    /// Overlapping or edge-sharing polygons of one multi-polygon were merged by union.
    OverlappingPartsMerged,
    /// A CityGML geometry (a `lod2Solid`, a thematic surface's `lod3MultiSurface`, …) that could not be read — an
    /// `xlink:href` to no element of its member, a `posList` whose count is no multiple of its dimension, a GML type
    /// the reader does not know — was left out; the building is built from its other geometries. The detail names
    /// the element, its line and why. A building with no geometry left is skipped (`malformed_geometry`).
    GeometryNotRead,
    /// Members of a GeoJSON GeometryCollection that are not polygonal (Point, LineString, …) were
    /// dropped; its polygons make the footprint.
    NonPolygonMemberDropped,
    /// GeoJSON `properties` that are not an object (an array, a string) were kept whole as one
    /// attribute, `properties`.
    PropertiesNotObject,
    /// A property holding a number beyond the range of a double (`1e400`, also inside an array or
    /// object) was kept as its JSON text.
    NumberKeptAsText,
    /// A GeoJSON property nested deeper than 127 levels of arrays and objects (more than the JSON
    /// parser reads) was dropped; the building and its other properties are kept. The detail names
    /// the key and its depth.
    PropertyTooDeepDropped,
    /// A key given more than once in a GeoJSON feature's `properties`, or a member the reader uses
    /// (`type`, `id`, `geometry`, `properties`) given more than once in the feature: the last value
    /// is kept, as most JSON readers do. The detail names the keys and whether their values differ.
    /// Also a key given more than once in a CityJSON building's `attributes` (the detail names the
    /// keys and how often each was given). Other CityJSON keys the reader uses given twice refuse a document, or
    /// skip the buildings of a CityJSONSeq line with this reason, the line and the key named.
    DuplicateKey,
    /// A GeoJSON property whose value JSON text holds but a JSON reader cannot decode (a `\u`
    /// escape of a lone UTF-16 surrogate, which is no character) was kept as its JSON text. Also a Shapefile `.dbf`
    /// cell that does not read as its field's type (a number `1,5`, a date `2011-02-30`, a logical `X`), kept as its
    /// text, or text with bytes its code page does not define, kept with U+FFFD in their place.
    UndecodableValueKeptAsText,
    /// A GeoJSON property key with a `\u` escape of a lone UTF-16 surrogate: the property is kept under the key's
    /// text with that escape written out (`caf\ud800`).
    UndecodableKeyKeptAsText,
    /// The geometry's vertices stand beyond 10 km above or below the datum (a wrong transform, a bad vertex) but the
    /// building has a usable ground attribute (`b3_h_maaiveld`): it stands on that, and none of the geometry's
    /// heights is used (its ground, its top for the height rule, its 3D model, which is listed as `model_invalid`).
    /// Without such an attribute the building is skipped (`coordinate_out_of_range`).
    GeometryHeightsIgnored,
    /// A GeoPackage geometry's circular arcs (CircularString, CompoundCurve, CurvePolygon rings), or a File
    /// Geodatabase polygon's curve segments (circular and elliptic arcs, Bézier curves), were approximated by
    /// straight segments, each spanning at most 4° of its circle (GDAL's default; a Bézier curve: 16 segments).
    CurvesApproximated,
    /// An OpenStreetMap building whose nodes or member ways are not in the file: the extract it comes from was cut
    /// at its edge through the building. The detail says how many are missing and names one.
    IncompleteInExtract,
    /// An OpenStreetMap building outline (`building=*`) with `building:part`s inside it: the parts are drawn in its
    /// place, as OSM's Simple 3D Buildings rule has it (a block of the outline would hide the lower parts). The detail
    /// names the parts. Its own tags (name, address) are not written.
    DrawnByParts,
    /// A building or part its attributes say lies wholly below the ground (OpenStreetMap's `location=underground`,
    /// Overture Maps' `is_underground=true`, in any format): not drawn, as nothing of it shows above the ground. The
    /// detail names the attribute.
    Underground,
    /// `--id-attr` names an attribute this feature has no value in: its id is the one its format's own rule gives
    /// (a GeoJSON `id`, a CityJSON object's key, `FILE#INDEX`).
    IdAttributeMissing,
    /// A height, storey, base or ground attribute the height rules reached held no usable value: not a number, a
    /// number whose only comma stands before three digits (`1,776`: thousands or decimals?), a value out of range,
    /// or a base (`min_height`, `building:min_level`) at or above the building's height, which then stands on the
    /// ground. The next rule gave the height; the detail names the attribute, its value and why.
    HeightValueRejected,
    // --- 3D models (building written, listed in `mesh_issues`) ---
    /// No Solid or surface geometry at the asked LoD or below: no mesh. When only one part lacks
    /// it, the mesh is built from the other parts.
    ModelMissing,
    /// The chosen 3D geometry is malformed (vertex index out of range, non-finite or
    /// untransformable vertex, boundaries not nested arrays) or no surface gave a triangle: no mesh.
    ModelInvalid,
    /// Surfaces with fewer than 3 distinct points or no area, or such holes, were left out of the
    /// mesh; the rest is kept.
    ModelSurfaceDropped,
    /// A closed model, or some of its parts, wound inside out (faces pointing inwards: a negative volume, or a
    /// positive one for the shell of a cavity; also what a mirroring transform makes) had those parts' triangles
    /// turned, so clients that cull back faces draw them. The detail says how many parts.
    ModelTurnedOutward,
    /// An OpenStreetMap roof tag that could not be taken as given: a value not usable for the roof (roof:height,
    /// roof:levels, roof:angle or roof:direction not a number, out of range; roof:orientation neither along nor
    /// across), whose next rule then shaped the roof; or a roof higher than the building (a roof:height over it, or
    /// a roof:angle too steep for the outline's width), lowered to leave 10 cm of wall. The detail names the tag,
    /// its value and what was done.
    RoofTagAdjusted,
}

impl IssueReason {
    /// The snake_case name used in the report maps.
    pub fn as_str(self) -> &'static str {
        use IssueReason::*;
        match self {
            NoGeometry => "no_geometry",
            UnsupportedGeometry => "unsupported_geometry",
            MalformedGeometry => "malformed_geometry",
            EmptyGeometry => "empty_geometry",
            NonFiniteCoordinate => "non_finite_coordinate",
            CoordinateOutOfRange => "coordinate_out_of_range",
            TransformFailed => "transform_failed",
            TooFewPoints => "too_few_points",
            ZeroArea => "zero_area",
            NoFootprint => "no_footprint",
            RepairFailed => "repair_failed",
            MeshFailed => "mesh_failed",
            Duplicate => "duplicate",
            DeletedRecord => "deleted_record",
            UnreadableRow => "unreadable_row",
            NotOnGround => "not_on_ground",
            GeometryNotRead => "geometry_not_read",
            RingClosed => "ring_closed",
            RepeatedPointsRemoved => "repeated_points_removed",
            DegenerateHoleDropped => "degenerate_hole_dropped",
            DegeneratePartDropped => "degenerate_part_dropped",
            HoleOutsideShell => "hole_outside_shell",
            SelfIntersection => "self_intersection",
            OverlappingPartsMerged => "overlapping_parts_merged",
            NonPolygonMemberDropped => "non_polygon_member_dropped",
            PropertiesNotObject => "properties_not_object",
            NumberKeptAsText => "number_kept_as_text",
            PropertyTooDeepDropped => "property_too_deep_dropped",
            DuplicateKey => "duplicate_key",
            UndecodableValueKeptAsText => "undecodable_value_kept_as_text",
            UndecodableKeyKeptAsText => "undecodable_key_kept_as_text",
            GeometryHeightsIgnored => "geometry_heights_ignored",
            CurvesApproximated => "curves_approximated",
            IncompleteInExtract => "incomplete_in_extract",
            DrawnByParts => "drawn_by_parts",
            Underground => "underground",
            IdAttributeMissing => "id_attribute_missing",
            HeightValueRejected => "height_value_rejected",
            ModelMissing => "model_missing",
            ModelInvalid => "model_invalid",
            ModelSurfaceDropped => "model_surface_dropped",
            ModelTurnedOutward => "model_turned_outward",
            RoofTagAdjusted => "roof_tag_adjusted",
        }
    }
}

/// One skipped or repaired feature.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FeatureIssue {
    /// The input file as given.
    pub file: String,
    /// The feature's source id (see `Building::source_id`).
    pub feature_id: String,
    pub reason: IssueReason,
    /// What was wrong or what was done, for a human.
    pub detail: String,
}

/// Input formats the ingest stage reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum InputFormat {
    GeoJson,
    CityJson,
    CityJsonSeq,
    Shapefile,
    GeoPackage,
    FileGeodatabase,
    OsmPbf,
    OsmXml,
    CityGml,
    GeoParquet,
}

/// What happened to one input file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FileReport {
    pub path: String,
    pub format: InputFormat,
    /// The CRS the coordinates were read in, e.g. `EPSG:28992` or `WGS84 lon/lat`.
    pub crs: String,
    /// Version string of a CityJSON file.
    pub cityjson_version: Option<String>,
    pub features_read: usize,
    pub buildings_written: usize,
    pub skipped: usize,
    /// CityJSON city objects that are not buildings (e.g. TINRelief), ignored.
    pub non_building_objects: usize,
    /// What concerns the file as a whole (a Shapefile's code page assumed for its text, fields not read); absent when there is nothing to say.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// Everything the ingest stage did, for the build report.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct IngestReport {
    pub files: Vec<FileReport>,
    /// Buildings (GeoJSON features, CityJSON Building objects) found in all files.
    pub features_read: usize,
    pub buildings_written: usize,
    /// Number of distinct written features that had at least one repair.
    pub features_repaired: usize,
    /// One entry per (feature, repair); a feature may have several.
    pub repaired: Vec<FeatureIssue>,
    /// One entry per skipped feature.
    pub skipped: Vec<FeatureIssue>,
    pub repaired_by_reason: BTreeMap<String, usize>,
    pub skipped_by_reason: BTreeMap<String, usize>,
    /// Written buildings per `HeightSource` (snake_case).
    pub height_sources: BTreeMap<String, usize>,
    /// Written buildings per ground-height source: `b3_h_maaiveld`, `geometry`, `zero`.
    pub ground_sources: BTreeMap<String, usize>,
    /// Height attribute values present but unusable (unparseable, under 0.1 m or over 1000 m above the base; a 3DBAG
    /// ground or roof that gives none), by attribute name.
    pub height_values_rejected: BTreeMap<String, usize>,
    /// Written GeoJSON features tagged `building:part` (OSM); kept as buildings of their own.
    pub building_parts: usize,
    /// Written buildings whose base was raised by an OSM `min_height`.
    pub min_height_bases: usize,
    /// Written buildings whose source id an earlier written building has, with another footprint or height
    /// (both kept; exact repeats are skipped as `duplicate`).
    pub duplicate_ids: usize,
    /// Rings whose winding was flipped to the ENU convention. Not a defect: RFC 7946 readers must
    /// accept either winding, and CityJSON ground surfaces face down.
    pub rings_reoriented: usize,
    /// How the local frame origin was chosen.
    pub frame_rule: String,
    /// The LoD asked for 3D models (`highest`, `2.2`, …); `None` when none were asked.
    pub mesh_lod_asked: Option<String>,
    /// Written buildings that carry a 3D model.
    pub buildings_with_mesh: usize,
    /// Triangles in all of those models.
    pub mesh_triangles: usize,
    /// Buildings with a model, per LoD used (as the source writes it; the lowest when parts differ).
    pub mesh_lods: BTreeMap<String, usize>,
    /// Buildings with a model where the building or a part lacked the target LoD (the asked one,
    /// or with `highest` the building's highest) and the highest LoD below it was used.
    pub mesh_lod_fallbacks: usize,
    /// Problems with the 3D models of written buildings (reasons `model_*`); a building may have
    /// several, and keeps its footprint whatever they are.
    pub mesh_issues: Vec<FeatureIssue>,
    pub mesh_issues_by_reason: BTreeMap<String, usize>,
}

impl IngestReport {
    /// Checks the report's own invariants; tests call it.
    pub fn check_invariants(&self) -> Result<(), String> {
        if self.features_read != self.buildings_written + self.skipped.len() {
            return Err(format!(
                "features_read {} != buildings_written {} + skipped {}",
                self.features_read,
                self.buildings_written,
                self.skipped.len()
            ));
        }
        let per_file: usize = self.files.iter().map(|f| f.features_read).sum();
        if per_file != self.features_read {
            return Err(format!(
                "files sum to {per_file} features, total says {}",
                self.features_read
            ));
        }
        let skip_sum: usize = self.skipped_by_reason.values().sum();
        let rep_sum: usize = self.repaired_by_reason.values().sum();
        if skip_sum != self.skipped.len() || rep_sum != self.repaired.len() {
            return Err("by-reason counts disagree with the issue lists".into());
        }
        let lods: usize = self.mesh_lods.values().sum();
        if lods != self.buildings_with_mesh
            || self.buildings_with_mesh > self.buildings_written
            || self.mesh_lod_fallbacks > self.buildings_with_mesh
        {
            return Err(format!(
                "{} buildings with a mesh, {lods} by LoD, {} fallbacks, {} written",
                self.buildings_with_mesh, self.mesh_lod_fallbacks, self.buildings_written
            ));
        }
        if self.mesh_issues_by_reason.values().sum::<usize>() != self.mesh_issues.len() {
            return Err("mesh issue counts disagree with the issue list".into());
        }
        let h: usize = self.height_sources.values().sum();
        if h != self.buildings_written {
            return Err(format!(
                "height sources count {h} buildings, {} written",
                self.buildings_written
            ));
        }
        Ok(())
    }
}
