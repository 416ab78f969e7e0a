//! The ingest stage (DESIGN.md §2): read building files (GeoJSON, Shapefile, GeoPackage, CityJSON, CityJSONSeq), convert
//! their CRS to WGS84 and then to one local east-north-up frame, resolve heights, repair or skip
//! every feature, and report each skip and repair. Never panics on bad data: a broken feature is
//! skipped with a reason, a broken file is an [`IngestError`]. With [`IngestOptions::lod`], CityJSON
//! buildings also carry their 3D model (`Building::mesh`, DESIGN.md §7) in the same frame.
//!
//! ```no_run
//! use citylod_ingest::{ingest, IngestOptions};
//! let out = ingest(&["boston_buildings.geojson".into()], &IngestOptions::default())?;
//! let r = &out.report;
//! assert_eq!(r.features_read, r.buildings_written + r.skipped.len());
//! # Ok::<(), citylod_ingest::IngestError>(())
//! ```
//!
//! ```no_run
//! use citylod_ingest::{ingest, IngestOptions, LodChoice};
//! let opts = IngestOptions { lod: Some(LodChoice::Exact("2.2".into())), ..Default::default() };
//! let out = ingest(&["delft.city.jsonl".into()], &opts)?;
//! for b in &out.buildings {
//!     if let Some(model) = &b.mesh {
//!         assert_eq!(model.surfaces.len(), model.mesh.triangles.len());
//!     }
//! }
//! println!("{} meshes, {:?}", out.report.buildings_with_mesh, out.report.mesh_issues_by_reason);
//! # Ok::<(), citylod_ingest::IngestError>(())
//! ```

mod citygml;
mod cityjson;
mod crs;
mod error;
mod feature;
mod fgdb;
mod geoid;
mod geojson;
mod geoparquet;
mod gpkg;
mod height;
mod lod;
mod model3d;
mod osm;
mod osm_pbf;
mod osm_xml;
mod parts;
mod place;
mod prj;
mod repair;
mod report;
mod roofs;
mod shp;
mod streets;
mod surface_model;
mod template;
mod valid;
mod zip;

pub use crs::{CoordError, Crs, CrsError};
pub use error::IngestError;
pub use geoid::geoid_height_m;
pub use height::{DEFAULT_STOREY_ATTRS, KNOWN_HEIGHT_ATTRS, MAX_HEIGHT_M, MIN_HEIGHT_M};
pub use lod::LodChoice;
pub use place::FRAME_RULE;
pub use repair::{check_footprint, MIN_AREA_M2};
pub use report::{FeatureIssue, FileReport, IngestReport, InputFormat, IssueReason};
pub use streets::{read_streets, Streets, StreetsReport};

use citylod_model::{AttrValue, Building, BuildingId, LocalFrame};
use crs::DeclaredCrs;
use feature::RawFeature;
use geo_types::{Coord, MultiPolygon};
use height::Heights;
use rayon::prelude::*;
use repair::Plane;
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};

/// How to read the input.
#[derive(Debug, Clone, PartialEq)]
pub struct IngestOptions {
    /// CRS of the input coordinates (`EPSG:28992`, an OGC URN/URL, `CRS84`, `+proj=…`). When set it
    /// overrides what the files declare; when not set, GeoJSON is RFC 7946 lon/lat and CityJSON
    /// must declare `metadata.referenceSystem`.
    pub crs: Option<String>,
    /// Attribute holding the building height (m), tried before the well-known names.
    pub height_attr: Option<String>,
    /// Metres per unit of a height attribute's number without a unit (`min_height` too): `None` for metres; 0.3048
    /// for feet, 1200/3937 for US survey feet (`--height-unit`). Storey counts and 3DBAG's heights are not affected.
    pub height_unit_m: Option<f64>,
    /// Attribute holding the storey count; default: [`DEFAULT_STOREY_ATTRS`].
    pub storey_attr: Option<String>,
    /// Height of one storey (m). Default 3.0.
    pub storey_height_m: f64,
    /// Height of a building with no height information (m). Default 10.0.
    pub default_height_m: f64,
    /// When set, every CityJSON building also gets its 3D model (`Building::mesh`) at this LoD,
    /// with its BuildingParts merged in; GeoJSON input is unaffected. Default `None`: footprints only.
    /// Footprints and heights are the same either way.
    pub lod: Option<LodChoice>,
    /// Attribute holding each building's id (`Building::source_id`), for every input format. A feature without a
    /// value there keeps the id the format's own rule gives it, reported as `id_attribute_missing`; an error when
    /// no feature has a value there (a misspelt name). Default `None`: the format's rule.
    pub id_attr: Option<String>,
    /// The feature table to read from each GeoPackage (`--layer`). Default `None`: a GeoPackage's only feature
    /// table; one with several is an error listing them. An error when no input is a GeoPackage.
    pub layer: Option<String>,
}

impl Default for IngestOptions {
    fn default() -> Self {
        IngestOptions {
            crs: None,
            height_attr: None,
            height_unit_m: None,
            storey_attr: None,
            storey_height_m: 3.0,
            default_height_m: 10.0,
            lod: None,
            id_attr: None,
            layer: None,
        }
    }
}

/// The ingested buildings, the frame their footprints are in, and the report.
#[derive(Debug, Clone)]
pub struct Ingested {
    /// `BuildingId(0..n)` in input order (files in the given order, features in file order).
    pub buildings: Vec<Building>,
    /// See [`FRAME_RULE`]; (0°, 0°, 0 m) when no building was written.
    pub frame: LocalFrame,
    pub report: IngestReport,
}

/// A file read and understood, with the CRS its coordinates are in.
struct LoadedFile {
    path: PathBuf,
    format: InputFormat,
    crs: Crs,
    version: Option<String>,
    non_building_objects: usize,
    features: Vec<RawFeature>,
    /// What concerns the file as a whole, for its report.
    notes: Vec<String>,
}

/// A feature ready for placement: its footprint in its own plane and its heights.
struct Prepared {
    /// The 3D model's vertices as (lon°, lat°, h m), when the feature has a model.
    model_lon_lat_h: Option<Result<Vec<[f64; 3]>, Skip>>,
    plane: Plane,
    footprint: MultiPolygon<f64>,
    heights: Heights,
    repairs: Vec<(IssueReason, String)>,
    rings_reoriented: usize,
    bbox: place::LonLatBox,
}

type Skip = (IssueReason, String);

/// Reads `paths` in order and returns every building in one local ENU frame.
///
/// Errors only for a whole file (unreadable, invalid JSON, unknown format, unknown CRS, CityJSON
/// without CRS and no `opts.crs`) or an option out of range (heights must be in (0, 1000] m, an
/// LoD must read as 1, 1.2, 2.2, …). Features are repaired or skipped; see [`IngestReport`]. With
/// `opts.lod`, a building whose 3D geometry is missing or broken keeps its footprint and the
/// problem is listed in `IngestReport::mesh_issues`.
/// An empty `paths` gives no buildings and the frame (0°, 0°, 0 m).
pub fn ingest(paths: &[PathBuf], opts: &IngestOptions) -> Result<Ingested, IngestError> {
    for (name, v) in [
        ("storey_height_m", opts.storey_height_m),
        ("default_height_m", opts.default_height_m),
    ] {
        if !(v.is_finite() && (MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&v)) {
            return Err(IngestError::InvalidOption {
                name,
                detail: format!("{v} is not a height in [{MIN_HEIGHT_M}, {MAX_HEIGHT_M}] m"),
            });
        }
    }
    let model_target = opts
        .lod
        .as_ref()
        .map(lod::Target::of)
        .transpose()
        .map_err(|detail| IngestError::InvalidOption {
            name: "lod",
            detail,
        })?;
    if let Some(layer) = &opts.layer {
        if !paths
            .iter()
            .any(|p| gpkg::is_geopackage(p) || fgdb::is_filegdb(p))
        {
            return Err(IngestError::InvalidOption {
                name: "--layer",
                detail: format!(
                    "{layer:?} names a GeoPackage feature table or a File Geodatabase feature class, and none of the \
                     inputs is a GeoPackage (.gpkg) or a File Geodatabase (.gdb folder)"
                ),
            });
        }
    }
    if let Some(c) = &opts.crs {
        Crs::parse(c).map_err(|e| IngestError::UnknownCrs {
            origin: "--crs".into(),
            crs: c.clone(),
            detail: e.0,
        })?;
    }
    let mut files: Vec<LoadedFile> = paths
        .par_iter()
        .map(|p| load(p, opts, model_target))
        .collect::<Result<Vec<Vec<LoadedFile>>, _>>()?
        .into_iter()
        .flatten()
        .collect();
    if let Some(name) = &opts.id_attr {
        ids_from_attribute(&mut files, name)?;
    }
    // OSM's building:part tag, in whatever format it comes (a GeoJSON property, a GeoPackage or .dbf column).
    for raw in files.iter_mut().flat_map(|f| f.features.iter_mut()) {
        let part = osm::exported_tag(&raw.attributes, "building:part");
        raw.is_building_part = match part {
            None | Some(AttrValue::Null | AttrValue::Bool(false)) => false,
            Some(AttrValue::String(v)) => osm::tag_set(v),
            Some(_) => true,
        };
    }

    let part_links = {
        let mut inputs: Vec<&mut Vec<RawFeature>> =
            files.iter_mut().map(|f| &mut f.features).collect();
        parts::linked_by_building_id(&mut inputs)
    };

    let outcomes: Vec<Vec<Result<Prepared, Skip>>> = files
        .iter()
        .map(|f| {
            f.features
                .par_iter()
                .map(|raw| prepare(raw, &f.crs, opts))
                .collect()
        })
        .collect();

    // OSM outlines drawn by their building:parts (Simple 3D Buildings) are not written, so they do not count for the
    // frame either: found in a provisional frame of every feature kept.
    let mut drawn_by_parts: Vec<BTreeMap<usize, Vec<String>>> = if files
        .iter()
        .any(|f| f.features.iter().any(|r| r.is_building_part))
    {
        let (b, g) = bounds(outcomes.iter().flatten().filter_map(|o| o.as_ref().ok()));
        let provisional = place::EnuMap::new(&place::frame_for(b, g));
        files
            .iter()
            .zip(&outcomes)
            .map(|(f, outs)| {
                let placed: Vec<Option<citylod_model::Footprint>> = outs
                    .par_iter()
                    .zip(&f.features)
                    .map(|(o, raw)| {
                        let p = o.as_ref().ok()?;
                        let relevant =
                            raw.is_building_part || raw.attributes.get("building").is_some();
                        relevant.then(|| place::to_enu(&provisional, &p.plane, &p.footprint, 0.0).0)
                    })
                    .collect();
                let refs: Vec<Option<&citylod_model::Footprint>> =
                    placed.iter().map(Option::as_ref).collect();
                parts::outlines_with_parts(&f.features, &refs)
                    .into_iter()
                    .map(|(o, ps)| {
                        (
                            o,
                            ps.iter()
                                .map(|&q| f.features[q].source_id.clone())
                                .collect(),
                        )
                    })
                    .collect()
            })
            .collect()
    } else {
        vec![BTreeMap::new(); files.len()]
    };
    // Buildings whose parts name them (Overture Maps), drawn by the parts that are written.
    let mut linked_outlines: HashSet<(usize, usize)> = HashSet::new();
    for ((pf, pi), (of, oi)) in part_links {
        if outcomes[pf][pi].is_ok() {
            drawn_by_parts[of]
                .entry(oi)
                .or_default()
                .push(files[pf].features[pi].source_id.clone());
            linked_outlines.insert((of, oi));
        }
    }
    let (bbox, min_ground) = bounds(outcomes.iter().enumerate().flat_map(|(fi, outs)| {
        let drawn = &drawn_by_parts[fi];
        outs.iter()
            .enumerate()
            .filter(move |(i, _)| !drawn.contains_key(i))
            .filter_map(|(_, o)| o.as_ref().ok())
    }));
    let frame = place::frame_for(bbox, min_ground);
    let enu_map = place::EnuMap::new(&frame);
    if let Some(b) = &bbox {
        place::check_extent(&frame, &enu_map, b)
            .map_err(|e| name_outliers(e, &files, &outcomes))?;
    }

    let mut report = IngestReport {
        frame_rule: FRAME_RULE.to_string(),
        mesh_lod_asked: opts.lod.as_ref().map(LodChoice::to_string),
        ..Default::default()
    };
    let mut buildings: Vec<Building> = Vec::new();
    // The file each written building came from.
    let mut file_of_building: Vec<u32> = Vec::new();
    // Every source id written so far, and the written buildings by `same_building_key`.
    let mut ids_written: HashSet<String> = HashSet::new();
    let mut by_key: HashMap<u64, Vec<usize>> = HashMap::new();
    let file_labels: Vec<String> = files.iter().map(|f| f.path.display().to_string()).collect();
    // Whether OpenStreetMap roof shapes are modelled (LoD 2 asked, or above it: then it is a fall-back).
    let roof_lod = model_target
        .and_then(|t| t.pick(&[lod::LodKey::TWO]))
        .map(|(_, fell_back)| fell_back);
    // A written feature's id and attributes move into its building.
    for (file_index, (file, outs)) in files.iter_mut().zip(&outcomes).enumerate() {
        let file_label = file.path.display().to_string();
        // A prepared feature placed in the frame: its footprint there (with the repairs placing it took), base, model.
        type Placed<'a> = (
            &'a Prepared,
            citylod_model::Footprint,
            Vec<(IssueReason, String)>,
            f64,
            model3d::Meshed,
        );
        let placed: Vec<Result<Placed, Skip>> = outs
            .par_iter()
            .zip(&file.features)
            .map(|(o, raw)| {
                let p = o.as_ref().map_err(Clone::clone)?;
                let base_h_m = p.heights.ground_m + p.heights.base_offset_m;
                let (footprint, base_z_m) =
                    place::to_enu(&enu_map, &p.plane, &p.footprint, base_h_m);
                let (footprint, placing_repairs) = repair::valid_in_frame(footprint)?;
                let mut meshed =
                    model3d::mesh(raw.model.as_ref(), p.model_lon_lat_h.as_ref(), &enu_map);
                if let (None, Some(fell_back)) = (&raw.model, roof_lod) {
                    roofs::roof_model(
                        &raw.attributes,
                        &footprint,
                        base_z_m,
                        p.heights.height_m,
                        opts,
                        fell_back,
                        &mut meshed,
                    );
                }
                Ok((p, footprint, placing_repairs, base_z_m, meshed))
            })
            .collect();
        let mut fr = FileReport {
            path: file_label.clone(),
            format: file.format,
            crs: file.crs.label.clone(),
            cityjson_version: file.version.clone(),
            features_read: file.features.len(),
            buildings_written: 0,
            skipped: 0,
            non_building_objects: file.non_building_objects,
            notes: file.notes.clone(),
        };
        for (index, (raw, placed)) in file.features.iter_mut().zip(placed).enumerate() {
            let issue = |reason: IssueReason, detail: &str| FeatureIssue {
                file: file_label.clone(),
                feature_id: raw.source_id.clone(),
                reason,
                detail: detail.to_string(),
            };
            if let Some(part_ids) = drawn_by_parts[file_index].get(&index) {
                let detail = if linked_outlines.contains(&(file_index, index)) {
                    format!(
                        "a building with {} part(s) naming it by building_id (Overture Maps' building parts: {}): \
                         the parts are drawn, not the building over them",
                        part_ids.len(),
                        geojson::listing(part_ids)
                    )
                } else {
                    format!(
                        "an OpenStreetMap building outline with {} building:part(s) inside ({}): the parts are \
                         drawn, as Simple 3D Buildings has it, not the outline over them",
                        part_ids.len(),
                        geojson::listing(part_ids)
                    )
                };
                report
                    .skipped
                    .push(issue(IssueReason::DrawnByParts, &detail));
                fr.skipped += 1;
                continue;
            }
            // A building is written once however often it is read: the same id, footprint and heights as any
            // building written before (every one, not only the first with that id: the same file given twice).
            let mut written_key = None;
            if let Ok((p, footprint, _, base_z_m, _)) = &placed {
                let same = |o: &Building| {
                    o.source_id == raw.source_id
                        && o.footprint == *footprint
                        && o.base_z_m == *base_z_m
                        && o.height_m == p.heights.height_m
                };
                let key =
                    same_building_key(&raw.source_id, footprint, *base_z_m, p.heights.height_m);
                let earlier = by_key
                    .get(&key)
                    .and_then(|bs| bs.iter().copied().find(|&b| same(&buildings[b])));
                if let Some(b) = earlier {
                    let o = &buildings[b];
                    let f = file_of_building[b] as usize;
                    let from = if f == file_index {
                        "earlier in this file".to_string()
                    } else {
                        format!("from {}", file_labels[f])
                    };
                    let differ = attributes_differing(&o.attributes, &raw.attributes);
                    let lost = if differ.is_empty() {
                        String::new()
                    } else {
                        format!(
                            "; its differing attributes are not written: {}",
                            geojson::listing(&differ)
                        )
                    };
                    report.skipped.push(issue(
                        IssueReason::Duplicate,
                        &format!("the same id, footprint and heights as a building read {from}: written once{lost}"),
                    ));
                    fr.skipped += 1;
                    continue;
                }
                if ids_written.contains(&raw.source_id) {
                    report.duplicate_ids += 1;
                }
                written_key = Some(key);
            }
            match placed {
                Ok((p, footprint, placing_repairs, base_z_m, meshed)) => {
                    debug_assert!(footprint.0.iter().all(|q| winding(q.exterior()) > 0.0));
                    if !p.repairs.is_empty()
                        || !placing_repairs.is_empty()
                        || !p.heights.rejected.is_empty()
                    {
                        report.features_repaired += 1;
                    }
                    for (reason, detail) in p.repairs.iter().chain(&placing_repairs) {
                        report.repaired.push(issue(*reason, detail));
                    }
                    for r in &p.heights.rejected {
                        report
                            .repaired
                            .push(issue(IssueReason::HeightValueRejected, &r.detail));
                        *report
                            .height_values_rejected
                            .entry(r.name.clone())
                            .or_default() += 1;
                    }
                    *report
                        .height_sources
                        .entry(height::height_source_key(p.heights.source).into())
                        .or_default() += 1;
                    *report
                        .ground_sources
                        .entry(p.heights.ground_source.as_str().into())
                        .or_default() += 1;
                    report.building_parts += usize::from(raw.is_building_part);
                    report.min_height_bases += usize::from(p.heights.base_offset_m > 0.0);
                    report.rings_reoriented += p.rings_reoriented;
                    for (reason, detail) in &meshed.issues {
                        report.mesh_issues.push(issue(*reason, detail));
                    }
                    if let Some(m) = &meshed.model {
                        report.buildings_with_mesh += 1;
                        report.mesh_triangles += m.mesh.triangles.len();
                        *report.mesh_lods.entry(m.lod.clone()).or_default() += 1;
                        report.mesh_lod_fallbacks += usize::from(meshed.fell_back);
                    }
                    if let Some(key) = written_key {
                        by_key.entry(key).or_default().push(buildings.len());
                    }
                    if !ids_written.contains(&raw.source_id) {
                        ids_written.insert(raw.source_id.clone());
                    }
                    file_of_building.push(file_index as u32);
                    buildings.push(Building {
                        id: BuildingId(buildings.len() as u32),
                        source_id: std::mem::take(&mut raw.source_id),
                        footprint,
                        base_z_m,
                        height_m: p.heights.height_m,
                        height_source: p.heights.source,
                        attributes: std::mem::take(&mut raw.attributes),
                        mesh: meshed.model,
                    });
                    fr.buildings_written += 1;
                }
                Err((reason, detail)) => {
                    report.skipped.push(issue(reason, &detail));
                    fr.skipped += 1;
                }
            }
        }
        report.features_read += fr.features_read;
        report.files.push(fr);
    }
    report.buildings_written = buildings.len();
    for i in &report.repaired {
        *report
            .repaired_by_reason
            .entry(i.reason.as_str().into())
            .or_default() += 1;
    }
    for i in &report.skipped {
        *report
            .skipped_by_reason
            .entry(i.reason.as_str().into())
            .or_default() += 1;
    }
    for i in &report.mesh_issues {
        *report
            .mesh_issues_by_reason
            .entry(i.reason.as_str().into())
            .or_default() += 1;
    }
    debug_assert_eq!(report.check_invariants(), Ok(()));
    // The parsed features (every attribute and coordinate read) are freed beside what comes next: on Boston
    // freeing them took ~25 ms with the other core idle.
    // Should no thread start, the closure, and what it holds, is dropped here instead.
    drop((ids_written, by_key, file_of_building));
    let parsed = (files, outcomes);
    let _ = std::thread::Builder::new()
        .name("citylod-free".into())
        .spawn(move || drop(parsed));
    Ok(Ingested {
        buildings,
        frame,
        report,
    })
}

/// The lon/lat box and the lowest ground of prepared features (`None` for none).
fn bounds<'a>(kept: impl Iterator<Item = &'a Prepared>) -> (Option<place::LonLatBox>, Option<f64>) {
    kept.fold((None, None), |(b, g), p| {
        (
            Some(b.map_or(p.bbox, |b: place::LonLatBox| b.union(p.bbox))),
            Some(g.map_or(p.heights.ground_m, |g: f64| g.min(p.heights.ground_m))),
        )
    })
}

/// Names of the attributes two buildings do not hold with equal values (one lacking it counts), sorted.
fn attributes_differing(
    a: &citylod_model::Attributes,
    b: &citylod_model::Attributes,
) -> Vec<String> {
    let names: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    names
        .into_iter()
        .filter(|k| a.get(k) != b.get(k))
        .cloned()
        .collect()
}

fn winding(r: &geo_types::LineString) -> f64 {
    r.0.windows(2)
        .map(|w| w[0].x * w[1].y - w[1].x * w[0].y)
        .sum()
}

/// A file's text without the byte-order mark some editors put first (JSON parsers reject it).
pub(crate) fn read_text(path: &Path) -> Result<String, IngestError> {
    let bytes = std::fs::read(path).map_err(|source| IngestError::Read {
        path: path.into(),
        source,
    })?;
    let mut text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        IngestError::Read {
            path: path.into(),
            source: std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "not UTF-8 text: byte {at} (line {line}) is 0x{:02X}; JSON is UTF-8 (RFC 8259), so save the \
                     file as UTF-8 (e.g. iconv -f latin1 -t utf-8, or ogr2ogr with -lco ENCODING=UTF-8)",
                    e.as_bytes()[at]
                ),
            ),
        }
    })?;
    if text.starts_with('\u{feff}') {
        text.drain(..'\u{feff}'.len_utf8());
    }
    Ok(text)
}

/// Sets every feature's source id from attribute `name` (`--id-attr`); a feature without a value there keeps its
/// own id, reported. An error when no feature of any file has a value there.
fn ids_from_attribute(files: &mut [LoadedFile], name: &str) -> Result<(), IngestError> {
    let text = |v: &AttrValue| match v {
        AttrValue::String(s) if !s.trim().is_empty() => Some(s.clone()),
        AttrValue::Int(i) => Some(i.to_string()),
        // A whole number stored as a double (a dBase N field with decimals, a JSON 1001234.0): its digits.
        AttrValue::Float(x)
            if x.is_finite() && x.fract() == 0.0 && x.abs() < 9.007_199_254_740_992e15 =>
        {
            Some(format!("{}", *x as i64))
        }
        AttrValue::Float(x) if x.is_finite() => Some(x.to_string()),
        _ => None,
    };
    let mut found = 0usize;
    for f in files.iter_mut() {
        for raw in &mut f.features {
            match raw.attributes.get(name).and_then(text) {
                Some(id) => {
                    raw.source_id = id;
                    found += 1;
                }
                None => raw.repairs.push((
                    IssueReason::IdAttributeMissing,
                    format!(
                        "no value in {name}; the id {} is the format's own",
                        raw.source_id
                    ),
                )),
            }
        }
    }
    let total: usize = files.iter().map(|f| f.features.len()).sum();
    if found == 0 && total > 0 {
        // Every feature's: an attribute only some have may be the one meant.
        let seen: BTreeSet<&str> = files
            .iter()
            .flat_map(|f| &f.features)
            .flat_map(|r| r.attributes.iter().map(|(k, _)| k.as_str()))
            .collect();
        let seen: Vec<String> = seen.into_iter().map(str::to_string).collect();
        return Err(IngestError::InvalidOption {
            name: "--id-attr",
            detail: format!(
                "no feature has a value in {name:?} (attributes found: {})",
                geojson::listing(&seen)
            ),
        });
    }
    Ok(())
}

/// Heights in a CRS in feet are often in feet too; metres are assumed unless --height-unit says otherwise (and
/// OpenStreetMap's are metres whatever the CRS the data was converted to): a note when a height attribute was read
/// as metres in such a CRS.
fn feet_note(crs: &Crs, features: &[RawFeature], opts: &IngestOptions) -> Option<String> {
    let unit = crs.linear_unit_m();
    if opts.height_unit_m.is_some() || (unit - 1.0).abs() <= 1e-9 || crs.is_lon_lat() {
        return None;
    }
    let k = features
        .iter()
        .filter(|f| f.attributes.get("osm_id").is_none())
        .find_map(|f| {
            opts.height_attr
                .iter()
                .map(String::as_str)
                .chain(KNOWN_HEIGHT_ATTRS.iter().copied())
                .find(|k| f.attributes.get(k).and_then(AttrValue::as_number).is_some())
        })?;
    let unit_name = if (unit - 1200.0 / 3937.0).abs() < 1e-12 {
        "US survey feet".to_string()
    } else if (unit - 0.3048).abs() < 1e-12 {
        "feet".to_string()
    } else {
        format!("units of {unit} m")
    };
    Some(format!(
        "the CRS is in {unit_name}, and the height attribute {k:?} was read in metres: if it is in feet too, \
         build again with --height-unit ft (or us-ft)"
    ))
}

/// A Shapefile or GeoPackage read: its CRS settled (`missing` when neither the file nor the user names one), then its
/// 3D surface models stood on the ground in that CRS's units.
fn vector_file(
    path: &Path,
    mut doc: feature::VectorDoc,
    opts: &IngestOptions,
    model_target: Option<lod::Target>,
    format: InputFormat,
    missing: IngestError,
) -> Result<LoadedFile, IngestError> {
    let (crs, crs_note) = match (&opts.crs, doc.declared_crs) {
        (None, None) => return Err(missing),
        (given, declared) => settle_crs(path, given, declared, format)?,
    };
    doc.notes.extend(crs_note);
    doc.notes.extend(feet_note(&crs, &doc.features, opts));
    doc.notes.extend(surface_model::stand(
        &mut doc.features,
        doc.surfaces,
        &crs,
        doc.z_unit_m,
        model_target.is_some(),
        match format {
            InputFormat::GeoPackage => "GeoPackage 3D",
            InputFormat::GeoParquet => "GeoParquet 3D",
            _ => "MultiPatch",
        },
    ));
    Ok(LoadedFile {
        path: path.into(),
        format,
        crs,
        version: None,
        non_building_objects: 0,
        features: doc.features,
        notes: doc.notes,
    })
}

/// The files an input holds: itself, or each CityGML file of a ZIP archive of them (as city models are downloaded,
/// tiles in one archive; each is reported as `ARCHIVE/MEMBER` with its own CRS). CityGML is told by its first
/// element before any other format (a geodatabase's test takes any .zip).
fn load(
    path: &Path,
    opts: &IngestOptions,
    model_target: Option<lod::Target>,
) -> Result<Vec<LoadedFile>, IngestError> {
    regular_input(path)?;
    if !citygml::is_citygml(path) {
        return load_one(path, opts, model_target).map(|f| vec![f]);
    }
    let invalid = |detail| IngestError::InvalidCityGml {
        path: path.into(),
        detail,
    };
    let crs = opts.crs.as_deref();
    if citygml::is_zip(path) {
        citygml::read_zip(path, model_target, crs)
            .map_err(invalid)?
            .into_iter()
            .map(|(name, gml)| citygml_file(&path.join(name), gml, opts))
            .collect()
    } else {
        let gml = citygml::read(path, model_target, crs).map_err(invalid)?;
        Ok(vec![citygml_file(path, gml, opts)?])
    }
}

/// A CityGML file read, its CRS settled and, in a projected CRS in feet, its heights taken in feet too.
fn citygml_file(
    path: &Path,
    gml: citygml::GmlDoc,
    opts: &IngestOptions,
) -> Result<LoadedFile, IngestError> {
    let mut doc = gml.doc;
    let mut notes = gml.notes;
    let (crs, crs_note) = settle_crs(
        path,
        &opts.crs,
        doc.declared_crs.take(),
        InputFormat::CityGml,
    )?;
    notes.extend(crs_note);
    // GML gives one CRS for all three coordinates: in a projected CRS in feet (a US State Plane), z is in feet too.
    let unit = crs.linear_unit_m();
    if !crs.is_lon_lat() && (unit - 1.0).abs() > 1e-9 {
        for f in &mut doc.features {
            f.footprint_min_z = f.footprint_min_z.map(|z| z * unit);
            f.top_z = f.top_z.map(|z| z * unit);
            if let Some(Ok(m)) = &mut f.model {
                for p in &mut m.positions_src {
                    p[2] *= unit;
                }
            }
        }
        notes.push(format!(
            "z is in the CRS's unit ({unit} m), as GML gives one CRS for x, y and z: heights were converted to metres"
        ));
    }
    notes.extend(feet_note(&crs, &doc.features, opts));
    Ok(LoadedFile {
        path: path.into(),
        format: InputFormat::CityGml,
        crs,
        version: None,
        non_building_objects: doc.non_building_objects,
        features: doc.features,
        notes,
    })
}

/// A coordinate as a message shows it: as read, or in scientific notation where that would run to many digits
/// (1e308, not a 1 and 308 zeros).
fn coordinate(x: f64) -> String {
    if x.is_finite() && x.abs() >= 1e15 {
        format!("{x:e}")
    } else {
        x.to_string()
    }
}

/// An error for an input that is neither a file nor a folder (a File Geodatabase): formats are told by a look at
/// the head of the file before it is read, and a pipe would be empty by then (a FIFO would wait forever).
pub(crate) fn regular_input(path: &Path) -> Result<(), IngestError> {
    match std::fs::metadata(path) {
        Ok(meta) if !meta.is_file() && !meta.is_dir() => Err(IngestError::Read {
            path: path.into(),
            source: std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "not a regular file (a pipe, socket or device): citylod looks at the head of an input before \
                 reading it, so save the data to a file first",
            ),
        }),
        _ => Ok(()),
    }
}

/// The formats citylod reads, for an input it cannot tell.
const FORMATS_READ: &str =
    "GeoJSON, CityJSON, CityJSONSeq, CityGML, OpenStreetMap (PBF or XML), shapefiles, \
                            GeoPackage, GeoParquet and File Geodatabases";

/// What a file named as CityGML (`.gml`, `.citygml`, gzip-compressed too) or as XML is instead, when it is not
/// CityGML (its head `head`; CityGML was looked for first): empty, not XML, or another root element. An `.xml` file
/// whose root is `osm` is OpenStreetMap XML: `None`.
fn named_but_not(path: &Path, head: &[u8]) -> Option<String> {
    let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    let gml = [".gml", ".citygml", ".gml.gz", ".citygml.gz"]
        .iter()
        .any(|e| name.ends_with(e));
    if !(gml || name.ends_with(".xml")) {
        return None;
    }
    let what = match citygml::root_element(head.to_vec()) {
        _ if head.is_empty() => "the file is empty".to_string(),
        Some(root) if root == "osm" && !gml => return None,
        Some(root) => format!(
            "its root element is <{root}>: neither CityGML (a CityModel, or a WFS FeatureCollection of CityGML \
             members) nor OpenStreetMap XML (<osm>)"
        ),
        None => "it does not read as XML (gzip-compressed or not)".to_string(),
    };
    Some(format!(
        "named as {}, but {what}",
        if gml { "CityGML" } else { "XML" }
    ))
}

/// The error for a folder given as an input that is no File Geodatabase: the files inside it are meant, shown with
/// the input extension most of them have (`*.geojson` when none has one).
fn a_folder(path: &Path) -> IngestError {
    const INPUT_EXTENSIONS: [&str; 13] = [
        "geojson", "json", "jsonl", "gml", "xml", "citygml", "shp", "gpkg", "parquet", "pbf",
        "osm", "gz", "zip",
    ];
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for entry in std::fs::read_dir(path).into_iter().flatten().flatten() {
        let p = entry.path();
        let e = p
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        if INPUT_EXTENSIONS.contains(&e.as_str()) && p.is_file() {
            *counts.entry(e).or_default() += 1;
        }
    }
    let extension = counts
        .iter()
        .max_by_key(|(_, n)| **n)
        .map(|(e, _)| e.as_str())
        .unwrap_or("geojson");
    IngestError::Read {
        path: path.into(),
        source: std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "{} is a folder; citylod reads files (or a File Geodatabase .gdb folder): give the files inside \
                 it, e.g. {}",
                path.display(),
                path.join(format!("*.{extension}")).display()
            ),
        ),
    }
}

/// What a binary file is whose head tells a container of no format citylod reads: an SQLite database that is not a
/// GeoPackage, or a ZIP archive holding neither a File Geodatabase nor CityGML (told before, by their content).
fn not_gdb_zip_or_sqlite(head: &[u8]) -> Option<String> {
    if head.starts_with(gpkg::SQLITE_MAGIC) {
        Some(
            "an SQLite database, but not a GeoPackage (no GeoPackage application_id, no gpkg_contents table); \
             export the buildings as a GeoPackage (e.g. ogr2ogr -f GPKG out.gpkg IN)"
                .into(),
        )
    } else if head.starts_with(zip::MEMBER_MAGIC) {
        Some(
            "a ZIP archive holding neither a File Geodatabase (a .gdb folder) nor CityGML files; unzip it and \
             give citylod the files in it"
                .into(),
        )
    } else {
        None
    }
}

/// What a file is that no reader took before JSON, when it cannot be JSON: empty, a glTF binary, UTF-16 text, or
/// binary. `None` for text (UTF-8 or not: [`read_text`] says where it is not).
fn not_text(head: &[u8]) -> Option<String> {
    if head.is_empty() {
        return Some(format!("the file is empty; inputs are {FORMATS_READ}"));
    }
    if head.starts_with(b"glTF") {
        return Some(
            "a glTF binary (.glb), such as a tile of a tileset: citylod reads buildings, and writes tiles".into(),
        );
    }
    if head.starts_with(&[0xff, 0xfe]) || head.starts_with(&[0xfe, 0xff]) {
        return Some(
            "UTF-16 text: JSON is read as UTF-8 (RFC 8259); convert it (e.g. iconv -f UTF-16 -t UTF-8)".into(),
        );
    }
    if head.contains(&0) {
        let begins: Vec<String> = head.iter().take(4).map(|b| format!("{b:02X}")).collect();
        return Some(format!(
            "a binary file (it begins {}) in no format citylod reads; inputs are {FORMATS_READ}",
            begins.join(" ")
        ));
    }
    None
}

/// The format a file's head tells on its own, whatever the file is named: an OSM PBF (its first blob `OSMHeader`),
/// gzip-compressed OpenStreetMap XML (inflating to an `<osm>` root), a GeoPackage (SQLite with a GeoPackage's
/// application_id or `gpkg_contents`), Parquet (`PAR1`), a ZIP archive holding a File Geodatabase. CityGML (also
/// zipped or gzip-compressed) is told before, by [`citygml::is_citygml`]; text formats after, by their first bytes.
fn told_by_content(path: &Path, head: &[u8]) -> Option<InputFormat> {
    if osm::is_pbf_head(head) {
        Some(InputFormat::OsmPbf)
    } else if head.starts_with(&[0x1f, 0x8b])
        && citygml::root_element(head.to_vec()).as_deref() == Some("osm")
    {
        Some(InputFormat::OsmXml)
    } else if head.starts_with(b"PAR1") {
        Some(InputFormat::GeoParquet)
    } else if gpkg::is_geopackage_content(path) == Some(true) {
        Some(InputFormat::GeoPackage)
    } else if head.starts_with(zip::MEMBER_MAGIC) && fgdb::zip_holds_filegdb(path) {
        Some(InputFormat::FileGeodatabase)
    } else {
        None
    }
}

/// Reads one file as `format`, one of those [`told_by_content`] tells or a name says (the text formats are read by
/// [`load_one`] itself).
fn read_as(
    format: InputFormat,
    path: &Path,
    opts: &IngestOptions,
    model_target: Option<lod::Target>,
) -> Result<LoadedFile, IngestError> {
    match format {
        InputFormat::Shapefile => {
            let doc = shp::read(path).map_err(|detail| IngestError::InvalidShapefile {
                path: path.into(),
                detail,
            })?;
            let missing = IngestError::MissingPrj { path: path.into() };
            vector_file(path, doc, opts, model_target, format, missing)
        }
        InputFormat::FileGeodatabase => {
            let doc = fgdb::read(path, opts.layer.as_deref(), feature::Want::Footprints).map_err(
                |detail| {
                    if path.is_file() && detail.starts_with("not a ZIP archive") {
                        // Nothing says it was meant as a geodatabase rather than zipped CityGML.
                        IngestError::UnknownFormat {
                            path: path.into(),
                            detail: format!(
                                "{detail}; a .zip input is read as a zipped File Geodatabase or CityGML files"
                            ),
                        }
                    } else if path.is_file()
                        && detail.starts_with("a ZIP archive cut short")
                        && !path
                            .to_string_lossy()
                            .to_ascii_lowercase()
                            .ends_with(".gdb.zip")
                    {
                        // Which kind of ZIP input it was meant to be cannot be told either (unless named .gdb.zip):
                        // the listing of its members is what was lost.
                        IngestError::Read {
                            path: path.into(),
                            source: std::io::Error::new(std::io::ErrorKind::InvalidData, detail),
                        }
                    } else {
                        IngestError::InvalidFileGdb {
                            path: path.into(),
                            detail,
                        }
                    }
                },
            )?;
            let missing = IngestError::FileGdbWithoutCrs { path: path.into() };
            vector_file(path, doc, opts, model_target, format, missing)
        }
        InputFormat::GeoPackage => {
            let doc = gpkg::read(path, opts.layer.as_deref(), feature::Want::Footprints).map_err(
                |detail| IngestError::InvalidGeoPackage {
                    path: path.into(),
                    detail,
                },
            )?;
            let missing = IngestError::GeoPackageWithoutCrs { path: path.into() };
            vector_file(path, doc, opts, model_target, format, missing)
        }
        InputFormat::GeoParquet => {
            let doc = geoparquet::read(path).map_err(|detail| IngestError::InvalidGeoParquet {
                path: path.into(),
                detail,
            })?;
            let missing = IngestError::GeoParquetWithoutCrs { path: path.into() };
            vector_file(path, doc, opts, model_target, format, missing)
        }
        InputFormat::OsmPbf | InputFormat::OsmXml => {
            let encoding = if format == InputFormat::OsmPbf {
                osm::Encoding::Pbf
            } else {
                osm::Encoding::Xml
            };
            let doc = osm::read(path).map_err(|detail| IngestError::InvalidOsm {
                path: path.into(),
                encoding: encoding.label(),
                detail,
            })?;
            let mut notes = doc.notes;
            if let Some(c) = &opts.crs {
                notes.push(format!(
                    "OpenStreetMap data is WGS84 lon/lat: --crs {c} applies to the other inputs, not to this file"
                ));
            }
            Ok(LoadedFile {
                path: path.into(),
                format,
                crs: Crs::wgs84(),
                version: None,
                non_building_objects: 0,
                features: doc.features,
                notes,
            })
        }
        _ => unreachable!("{format:?} is read by load_one"),
    }
}

/// Reads, detects and parses one file, and settles its CRS. The content is looked at first, and a format its head
/// tells is read whatever the name; the name only decides among what the head leaves open (a shapefile's parts, a
/// broken file named as one format, which that format's reader then refuses with what is wrong).
fn load_one(
    path: &Path,
    opts: &IngestOptions,
    model_target: Option<lod::Target>,
) -> Result<LoadedFile, IngestError> {
    let head = {
        let mut head = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| {
                std::io::Read::read_to_end(&mut std::io::Read::take(f, 64 * 1024), &mut head)
            })
            .map(|_| head)
    };
    if let Some(format) = head.as_ref().ok().and_then(|h| told_by_content(path, h)) {
        return read_as(format, path, opts, model_target);
    }
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if extension.as_deref() == Some("shp") {
        return read_as(InputFormat::Shapefile, path, opts, model_target);
    }
    if let Some((_, what)) = shp::SIDECARS
        .iter()
        .find(|(e, _)| extension.as_deref() == Some(*e))
    {
        return Err(IngestError::UnknownFormat {
            path: path.into(),
            detail: format!("this is a shapefile's {what}; give its .shp as the input"),
        });
    }
    if fgdb::is_filegdb(path) {
        return read_as(InputFormat::FileGeodatabase, path, opts, model_target);
    }
    if let Some((_, what)) = fgdb::MEMBERS
        .iter()
        .find(|(e, _)| extension.as_deref() == Some(*e))
    {
        return Err(IngestError::UnknownFormat {
            path: path.into(),
            detail: format!(
                "this is a File Geodatabase's {what}; give the .gdb folder that holds it as the input"
            ),
        });
    }
    if path.is_dir() {
        return Err(a_folder(path));
    }
    if gpkg::is_geopackage_name(path) {
        return read_as(InputFormat::GeoPackage, path, opts, model_target);
    }
    if let Some((_, what)) = gpkg::SIDECARS
        .iter()
        .find(|(e, _)| extension.as_deref() == Some(*e))
    {
        return Err(IngestError::UnknownFormat {
            path: path.into(),
            detail: format!(
                "this is SQLite's {what} beside a GeoPackage; give the .gpkg as the input"
            ),
        });
    }
    if geoparquet::is_parquet(path) {
        return read_as(InputFormat::GeoParquet, path, opts, model_target);
    }
    if let Some(detail) = head.as_ref().ok().and_then(|h| named_but_not(path, h)) {
        return Err(IngestError::UnknownFormat {
            path: path.into(),
            detail,
        });
    }
    if let Some(encoding) = osm::Encoding::of(path) {
        let format = match encoding {
            osm::Encoding::Pbf => InputFormat::OsmPbf,
            osm::Encoding::Xml => InputFormat::OsmXml,
        };
        return read_as(format, path, opts, model_target);
    }
    if let Some(detail) = head.as_ref().ok().and_then(|h| not_gdb_zip_or_sqlite(h)) {
        return Err(IngestError::UnknownFormat {
            path: path.into(),
            detail,
        });
    }
    if let Some(detail) = head.as_ref().ok().and_then(|h| not_text(h)) {
        return Err(IngestError::UnknownFormat {
            path: path.into(),
            detail,
        });
    }
    let text = read_text(path)?;
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let unknown = |detail: String| IngestError::UnknownFormat {
        path: path.into(),
        detail,
    };
    let invalid = |detail: String| IngestError::InvalidCityJson {
        path: path.into(),
        detail,
    };

    let is_jsonl = file_name.ends_with(".jsonl");
    let mut collection = geojson::read_sequence(&text, &file_name);
    let whole: Option<serde_json::Value> = if collection.is_some() {
        Some(serde_json::Value::Null)
    } else if is_jsonl {
        None
    } else {
        let parsed = geojson::read_features_text(&text, &file_name).and_then(|c| match c {
            Some(doc) => {
                collection = Some(doc);
                Ok(serde_json::Value::Null)
            }
            None => serde_json::from_str(&text),
        });
        match parsed {
            Ok(v) => Some(v),
            Err(e) => {
                // A CityJSONSeq without the .jsonl extension: the first line alone is a CityJSON header.
                let first = text.lines().next().unwrap_or("");
                let header: Option<serde_json::Value> = serde_json::from_str(first).ok();
                if header
                    .as_ref()
                    .and_then(|h| h.get("type"))
                    .and_then(|t| t.as_str())
                    != Some("CityJSON")
                {
                    return Err(IngestError::Json {
                        path: path.into(),
                        line: e.line(),
                        source: e,
                    });
                }
                None
            }
        }
    };
    let (format, declared, version, non_building_objects, features) = match whole {
        _ if collection.is_some() => {
            let doc = collection.take().expect("checked");
            (
                InputFormat::GeoJson,
                doc.declared_crs,
                None,
                0,
                doc.features,
            )
        }
        None => {
            let doc = cityjson::read_sequence(&text, model_target)
                .map_err(|(line, source)| IngestError::Json {
                    path: path.into(),
                    line,
                    source,
                })?
                .map_err(invalid)?;
            (
                InputFormat::CityJsonSeq,
                doc.declared_crs,
                doc.version,
                doc.non_building_objects,
                doc.features,
            )
        }
        Some(v) if v.get("type").and_then(|t| t.as_str()) == Some("CityJSON") => {
            let doc = cityjson::read_document_text(&text, &v, model_target).map_err(invalid)?;
            (
                InputFormat::CityJson,
                doc.declared_crs,
                doc.version,
                doc.non_building_objects,
                doc.features,
            )
        }
        Some(v) if v.get("type").and_then(|t| t.as_str()) == Some("CityJSONFeature") => {
            return Err(unknown(
                "a single CityJSONFeature without the CityJSONSeq header line".into(),
            ));
        }
        Some(v) if v.is_object() => {
            let doc = geojson::read(&v, &file_name).map_err(unknown)?;
            (
                InputFormat::GeoJson,
                doc.declared_crs,
                None,
                0,
                doc.features,
            )
        }
        Some(_) => return Err(unknown("the top-level JSON value is not an object".into())),
    };
    let (crs, crs_note) = settle_crs(path, &opts.crs, declared, format)?;
    let with_z = features.iter().filter(|f| f.z_ignored).count();
    let z_note = (with_z > 0).then(|| {
        format!(
            "{with_z} feature(s) have z values in their coordinates, which are not used: the buildings stand at 0 m \
             (GeoJSON gives no datum for them; use --height-offset for a common ground height) and their heights \
             come from the height rules"
        )
    });
    let notes = crs_note
        .into_iter()
        .chain(feet_note(&crs, &features, opts))
        .chain(z_note)
        .collect();
    Ok(LoadedFile {
        path: path.into(),
        format,
        crs,
        version,
        non_building_objects,
        features,
        notes,
    })
}

/// The CRS of a file: `--crs` when given, else what the file declares, else WGS84 lon/lat for GeoJSON (RFC 7946);
/// an error for a declaration that names no usable CRS, or for a CityJSON file that declares none. With it a note
/// when `--crs` replaced a declaration that names another CRS (or one citylod does not know).
fn settle_crs(
    path: &Path,
    given: &Option<String>,
    declared: Option<DeclaredCrs>,
    format: InputFormat,
) -> Result<(Crs, Option<String>), IngestError> {
    if let Some(c) = given {
        let crs = Crs::parse(c).map_err(|e| IngestError::UnknownCrs {
            origin: "--crs".into(),
            crs: c.clone(),
            detail: e.0,
        })?;
        let said = match &declared {
            Some(DeclaredCrs::Name(d)) => {
                let same = Crs::parse(d).is_ok_and(|k| k.label == crs.label);
                (!same).then(|| d.clone())
            }
            Some(DeclaredCrs::NotUnderstood { member, .. }) => Some(member.to_string()),
            None => None,
        };
        let note = said.map(|d| {
            format!(
                "the file declares {d}; --crs {c} ({}) was used instead, as it is for every input",
                crs.label
            )
        });
        return Ok((crs, note));
    }
    let crs = match &declared {
        Some(DeclaredCrs::Name(d)) => Crs::parse(d).map_err(|e| IngestError::UnknownCrs {
            origin: path.display().to_string(),
            crs: d.clone(),
            detail: e.0,
        })?,
        Some(DeclaredCrs::NotUnderstood { member, detail }) => {
            return Err(IngestError::CrsNotUnderstood {
                path: path.into(),
                member,
                detail: detail.clone(),
                option: "--crs",
            })
        }
        None if format == InputFormat::GeoJson => Crs::wgs84(),
        None => {
            return Err(IngestError::MissingCrs {
                path: path.into(),
                member: if format == InputFormat::CityGml {
                    "srsName on the model's gml:Envelope or on a geometry"
                } else {
                    "metadata.referenceSystem"
                },
            })
        }
    };
    Ok((crs, None))
}

/// Cleans, converts and repairs one feature and resolves its heights. `Err` = skip with reason.
fn prepare(raw: &RawFeature, crs: &Crs, opts: &IngestOptions) -> Result<Prepared, Skip> {
    if let Some(skip) = &raw.skip {
        return Err(skip.clone());
    }
    if let Some(why) = osm::underground(&raw.attributes) {
        return Err((IssueReason::Underground, why));
    }
    let mut repairs = raw.repairs.clone();
    let mut removed = 0;
    let mut polygons_lon_lat: Vec<Vec<Vec<(f64, f64)>>> = Vec::with_capacity(raw.polygons.len());
    for poly in &raw.polygons {
        let mut rings = Vec::with_capacity(poly.len());
        for ring in poly {
            let mut ring = ring.clone();
            if let Some(p) = ring
                .iter()
                .find(|p| !(p[0].is_finite() && p[1].is_finite()))
            {
                return Err((
                    IssueReason::NonFiniteCoordinate,
                    format!("coordinate ({}, {})", coordinate(p[0]), coordinate(p[1])),
                ));
            }
            removed += repair::drop_repeated_points(&mut ring);
            let converted = ring
                .iter()
                .map(|p| {
                    crs.to_lon_lat(p[0], p[1]).map_err(|e| {
                        let reason = match e {
                            CoordError::NonFinite => IssueReason::NonFiniteCoordinate,
                            CoordError::OutOfRange => IssueReason::CoordinateOutOfRange,
                            CoordError::TransformFailed => IssueReason::TransformFailed,
                        };
                        (
                            reason,
                            format!(
                                "coordinate ({}, {}) in {}",
                                coordinate(p[0]),
                                coordinate(p[1]),
                                crs.label
                            ),
                        )
                    })
                })
                .collect::<Result<Vec<_>, _>>()?;
            rings.push(converted);
        }
        polygons_lon_lat.push(rings);
    }
    if removed > 0 {
        repairs.push((
            IssueReason::RepeatedPointsRemoved,
            format!("{removed} repeated consecutive point(s) removed"),
        ));
    }
    let Some(&(lon0, lat0)) = polygons_lon_lat.iter().flatten().flatten().next() else {
        return Err((IssueReason::EmptyGeometry, "no coordinates".into()));
    };
    let plane = Plane::new(lon0, lat0);
    let plane_polys: Vec<Vec<Vec<Coord>>> = polygons_lon_lat
        .into_iter()
        .map(|rings| {
            rings
                .into_iter()
                .map(|r| {
                    r.into_iter()
                        .map(|(lon, lat)| plane.to_xy(lon, lat))
                        .collect()
                })
                .collect()
        })
        .collect();
    // The geometry's own ground (CityJSON vertices): one off the globe (a wrong transform, a bad vertex) would place
    // the whole tileset's frame there. (A top that high only fails the height rule: the building keeps another.)
    // With a usable ground attribute the building stands on that instead, and none of the geometry's heights is
    // used: not its ground, not its top, not its 3D model.
    let mut footprint_min_z = raw.footprint_min_z;
    let mut top_z = raw.top_z;
    let mut model_lost = None;
    if let Some(z) = raw
        .footprint_min_z
        .filter(|z| !(z.is_finite() && z.abs() < height::MAX_GROUND_M))
    {
        let shown = if z.abs() < 1e9 {
            format!("{z:.1}")
        } else {
            format!("{z:.3e}")
        };
        let beyond = format!(
            "the geometry's ground lies at {shown} m, beyond the {} km above or below the datum any building \
             stands on",
            height::MAX_GROUND_M / 1000.0
        );
        let Some(ground) = height::ground_attribute(&raw.attributes) else {
            return Err((IssueReason::CoordinateOutOfRange, beyond));
        };
        let detail = format!(
            "{beyond}: the building stands on {} = {ground} m, its geometry's heights (ground, top{}) not used",
            height::GROUND_ATTR,
            if raw.model.is_some() { ", 3D model" } else { "" }
        );
        if matches!(raw.model, Some(Ok(_))) {
            model_lost = Some((IssueReason::ModelInvalid, detail.clone()));
        }
        repairs.push((IssueReason::GeometryHeightsIgnored, detail));
        footprint_min_z = None;
        top_z = None;
    }
    let fixed = repair::repair(plane_polys, raw.assemble)?;
    repairs.extend(fixed.issues);
    let heights = height::resolve(&raw.attributes, footprint_min_z, top_z, opts);
    let bbox = place::lon_lat_box(&plane, &fixed.footprint);
    let model_lon_lat_h = match (&raw.model, model_lost) {
        (Some(Ok(_)), Some(lost)) => Some(Err(lost)),
        (Some(Ok(m)), None) => Some(model3d::geolocate(m, crs)),
        _ => None,
    };
    Ok(Prepared {
        model_lon_lat_h,
        plane,
        footprint: fixed.footprint,
        heights,
        repairs,
        rings_reoriented: fixed.rings_reoriented,
        bbox,
    })
}

/// A hash of what makes two read buildings the same one: the id, every footprint coordinate, base and height
/// (−0.0 hashed as 0.0, since the comparison takes them as equal). The key only places a building in the map:
/// which earlier building a read one repeats is decided by comparing them, whatever the hash.
fn same_building_key(
    source_id: &str,
    footprint: &MultiPolygon,
    base_z_m: f64,
    height_m: f64,
) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    source_id.hash(&mut h);
    let mut bits = |v: f64| (v + 0.0).to_bits().hash(&mut h);
    for poly in &footprint.0 {
        for ring in std::iter::once(poly.exterior()).chain(poly.interiors()) {
            for c in &ring.0 {
                bits(c.x);
                bits(c.y);
            }
            bits(f64::NAN);
        }
    }
    bits(base_z_m);
    bits(height_m);
    h.finish()
}

/// How many of the buildings farthest from the others a too-wide error names.
const OUTLIERS_NAMED: usize = 3;

/// A building whose own box is wider than this (m, corner to corner) is named in a too-wide error by the box it
/// spans rather than by its centre (its polygons far apart: a part, a ring or a vertex astray).
const NAMED_BY_SPAN_M: f64 = 10_000.0;

/// A too-wide error with the buildings that make it so named: those reaching farthest from the median longitude
/// and latitude of all (a stray feature at 0°, 0° among a city's; one feature with a polygon or a vertex far from
/// its others), with their file, id and place.
fn name_outliers(
    e: IngestError,
    files: &[LoadedFile],
    outcomes: &[Vec<Result<Prepared, Skip>>],
) -> IngestError {
    let IngestError::TooWide { detail } = e else {
        return e;
    };
    let kept: Vec<(&Path, &str, place::LonLatBox)> = files
        .iter()
        .zip(outcomes)
        .flat_map(|(f, outs)| {
            f.features.iter().zip(outs).filter_map(move |(raw, o)| {
                let p = o.as_ref().ok()?;
                Some((f.path.as_path(), raw.source_id.as_str(), p.bbox))
            })
        })
        .collect();
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (lon0, lat0) = (
        median(kept.iter().map(|k| k.2.centre().0).collect()),
        median(kept.iter().map(|k| k.2.centre().1).collect()),
    );
    // How far each building reaches from there: its centre's distance, or more for a building spread wide.
    let mut far: Vec<(f64, usize)> = kept
        .iter()
        .enumerate()
        .map(|(i, k)| (k.2.reach_m((lon0, lat0)), i))
        .collect();
    // Farthest first; the input order among equals.
    far.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let beyond = far
        .iter()
        .filter(|(d, _)| *d > place::MAX_DISTANCE_FROM_ORIGIN_M)
        .count();
    let named: Vec<String> = far
        .iter()
        .take(OUTLIERS_NAMED.min(beyond.max(1)))
        .map(|&(d, i)| {
            let (file, id, b) = kept[i];
            let n = b.narrow();
            let across = place::great_circle_m((n[0], n[1]), (n[2], n[3]));
            let place = if across > NAMED_BY_SPAN_M {
                format!(
                    "spanning longitudes {:.4}..{:.4} and latitudes {:.4}..{:.4} ({:.0} km across), reaching",
                    repair::wrap_lon(n[0]),
                    repair::wrap_lon(n[2]),
                    n[1],
                    n[3],
                    across / 1000.0
                )
            } else {
                let (lon, lat) = b.centre();
                format!("at ({lon:.4}, {lat:.4}),")
            };
            format!("{id:?} in {} {place} {:.0} km away", file.display(), d / 1000.0)
        })
        .collect();
    IngestError::TooWide {
        detail: format!(
            "{detail}. {beyond} building(s) lie over {:.0} km from the median position ({lon0:.4}, {lat0:.4}); \
             farthest: {}",
            place::MAX_DISTANCE_FROM_ORIGIN_M / 1000.0,
            named.join("; ")
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x0: f64, y0: f64, d: f64) -> Vec<[f64; 2]> {
        vec![[x0, y0], [x0 + d, y0], [x0 + d, y0 + d], [x0, y0 + d]]
    }

    #[test]
    fn non_finite_coordinates_are_skipped_not_panicking() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut ring = square(4.0, 52.0, 0.001);
            ring[2][1] = bad;
            let raw = RawFeature {
                source_id: "x".into(),
                polygons: vec![vec![ring]],
                ..Default::default()
            };
            let e = prepare(&raw, &Crs::wgs84(), &IngestOptions::default())
                .err()
                .unwrap();
            assert_eq!(e.0, IssueReason::NonFiniteCoordinate);
        }
    }

    #[test]
    fn projected_coordinates_that_cannot_transform_are_skipped() {
        let raw = RawFeature {
            source_id: "x".into(),
            polygons: vec![vec![square(1e300, 1e300, 1e299)]],
            ..Default::default()
        };
        let e = prepare(
            &raw,
            &Crs::parse("EPSG:28992").unwrap(),
            &IngestOptions::default(),
        )
        .err()
        .unwrap();
        assert_eq!(e.0, IssueReason::TransformFailed);
    }

    #[test]
    fn a_prepared_square_has_metric_area() {
        // 0.0001° × 0.0001° at 52°N ≈ 6.86 m × 11.13 m.
        let raw = RawFeature {
            source_id: "x".into(),
            polygons: vec![vec![square(4.0, 52.0, 0.0001)]],
            ..Default::default()
        };
        let p = prepare(&raw, &Crs::wgs84(), &IngestOptions::default())
            .ok()
            .unwrap();
        let a = geo::Area::unsigned_area(&p.footprint);
        assert!((a - 6.86 * 11.13).abs() < 0.5, "{a}");
    }
}
