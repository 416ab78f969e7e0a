//! Street centre lines (GeoJSON LineString / MultiLineString features, Shapefile PolyLines, GeoPackage and File
//! Geodatabase lines and curves, OpenStreetMap highway ways) mapped into the buildings' local frame, for the generalization's street
//! barriers (DESIGN.md §3.9, seed 002 §3.2.1: buildings on opposite sides of a street are not aggregated). Every
//! feature is used or listed as skipped with its id and reason.

use crate::crs::{CoordError, Crs, DeclaredCrs};
use crate::report::{FeatureIssue, IssueReason};
use crate::IngestError;
use citylod_model::LocalFrame;
use serde::Serialize;
use serde_json::Value;
use std::path::Path;

/// Street segments in the local frame (east, north metres) and what reading them did.
#[derive(Debug, Clone, PartialEq)]
pub struct Streets {
    pub segments: Vec<[[f64; 2]; 2]>,
    pub report: StreetsReport,
}

/// What was read from a street file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StreetsReport {
    pub file: String,
    /// The CRS the coordinates were read in, and where that came from (`--streets-crs`, the file, `--crs`, the
    /// RFC 7946 default), e.g. `EPSG:28992 (from --crs)`.
    pub crs: String,
    pub features_read: usize,
    /// Features that gave at least one segment.
    pub features_used: usize,
    pub segments: usize,
    /// Total length of the segments (m).
    pub length_m: f64,
    /// Features without a usable line: `features_read == features_used + skipped.len()`.
    pub skipped: Vec<FeatureIssue>,
}

/// How a street file is read, from its extension or first bytes.
enum Format {
    Osm(crate::osm::Encoding),
    Shapefile,
    GeoPackage,
    FileGdb,
    GeoParquet,
    GeoJson,
    /// A format `--streets` does not read: a phrase for the error.
    Other(&'static str),
}

fn format(path: &Path) -> Format {
    if let Some(encoding) = crate::osm::Encoding::of(path) {
        return Format::Osm(encoding);
    }
    if crate::fgdb::is_filegdb(path) {
        return Format::FileGdb;
    }
    if crate::geoparquet::is_parquet(path) {
        return Format::GeoParquet;
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("shp") => return Format::Shapefile,
        Some("shx" | "dbf") => return Format::Other("a part of a Shapefile other than its .shp"),
        Some("gpkg") => return Format::GeoPackage,
        _ if path.is_dir() => return Format::Other("a folder"),
        _ => {}
    }
    let mut head = [0u8; 16];
    let n = std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
        .unwrap_or(0);
    if head[..n].starts_with(crate::gpkg::SQLITE_MAGIC) {
        Format::GeoPackage
    } else if head[..n].starts_with(crate::zip::MEMBER_MAGIC) {
        Format::Other("a ZIP archive")
    } else {
        Format::GeoJson
    }
}

/// The CRS the street coordinates are read in, with where it came from: `given` (`--streets-crs`), else the one the
/// file declares, else `fallback` (the buildings' `--crs`), else `default` (GeoJSON's RFC 7946 lon/lat; none for
/// the formats that declare their CRS, which are refused without one).
fn street_crs(
    path: &Path,
    given: Option<&str>,
    declared: Option<DeclaredCrs>,
    fallback: Option<&str>,
    default: Option<Crs>,
) -> Result<(Crs, String), IngestError> {
    let declared = match declared {
        Some(DeclaredCrs::Name(n)) => Some(n),
        // One that names no usable CRS is an error unless --streets-crs says which.
        Some(DeclaredCrs::NotUnderstood { member, detail }) if given.is_none() => {
            return Err(IngestError::CrsNotUnderstood {
                path: path.into(),
                member,
                detail,
                option: "--streets-crs",
            })
        }
        _ => None,
    };
    let (name, origin) = match (given, declared.as_deref(), fallback) {
        (Some(c), _, _) => (c, "--streets-crs".to_string()),
        (None, Some(d), _) => (d, path.display().to_string()),
        (None, None, Some(c)) => (c, "--crs".to_string()),
        (None, None, None) => {
            return match default {
                Some(crs) => Ok((crs, "RFC 7946 default".into())),
                None => Err(IngestError::StreetsWithoutCrs { path: path.into() }),
            }
        }
    };
    let crs = Crs::parse(name).map_err(|e| IngestError::UnknownCrs {
        origin: origin.clone(),
        crs: name.into(),
        detail: e.0,
    })?;
    Ok((crs, origin))
}

/// Reads the street lines of a file and maps them into `frame`: a GeoJSON file (a FeatureCollection, a Feature or
/// a bare LineString / MultiLineString), a Shapefile of PolyLines, a GeoPackage's or File Geodatabase's line layer
/// (`layer`, or the only one of lines), or an OpenStreetMap file's highway ways. Coordinates are in `crs` when
/// given (`--streets-crs`), else in the CRS the file declares (a GeoJSON legacy `crs` member, a `.prj`, the layer's
/// spatial reference system), else in `fallback_crs` (the buildings' `--crs`), else, for GeoJSON, RFC 7946 lon/lat.
/// Features without a line geometry, or with fewer than two distinct points, or with a coordinate that cannot be
/// placed, are skipped and listed in the report; so are lines whose attributes say they are not on the ground (a
/// tunnel, …: `osm::off_ground`), which are no barriers.
///
/// Errors for the whole file: unreadable, not of a format read here, not valid as its format, no CRS or an unknown
/// one, or `layer` given for a format without layers.
pub fn read_streets(
    path: &Path,
    crs: Option<&str>,
    layer: Option<&str>,
    fallback_crs: Option<&str>,
    frame: &LocalFrame,
) -> Result<Streets, IngestError> {
    crate::regular_input(path)?;
    let format = format(path);
    if let (Some(l), Format::Osm(_) | Format::Shapefile | Format::GeoJson | Format::GeoParquet) =
        (layer, &format)
    {
        return Err(IngestError::InvalidOption {
            name: "--streets-layer",
            detail: format!(
                "{l} given for {}, which has no layers (a GeoPackage's feature tables and a File Geodatabase's \
                 feature classes are chosen with it)",
                path.display()
            ),
        });
    }
    let doc = match format {
        Format::Osm(encoding) => return osm_streets(path, encoding, crs, frame),
        Format::Other(kind) => {
            return Err(IngestError::UnknownFormat {
                path: path.into(),
                detail: format!(
                    "--streets reads GeoJSON, Shapefile (.shp), GeoPackage (.gpkg), File Geodatabase (.gdb, .gdb.zip), \
                     GeoParquet (WKB lines) or OpenStreetMap (.osm, .osm.pbf) street lines, and this is {kind}: convert its lines to one of them first (e.g. `ogr2ogr -f \
                     GPKG streets.gpkg {}`)",
                    path.display()
                ),
            })
        }
        Format::FileGdb => crate::fgdb::read(path, layer, crate::feature::Want::Lines).map_err(
            |detail| IngestError::InvalidFileGdb {
                path: path.into(),
                detail,
            },
        )?,
        Format::Shapefile => {
            crate::shp::read(path).map_err(|detail| IngestError::InvalidShapefile {
                path: path.into(),
                detail,
            })?
        }
        Format::GeoPackage => crate::gpkg::read(path, layer, crate::feature::Want::Lines).map_err(
            |detail| IngestError::InvalidGeoPackage {
                path: path.into(),
                detail,
            },
        )?,
        Format::GeoParquet => {
            crate::geoparquet::read(path).map_err(|detail| IngestError::InvalidGeoParquet {
                path: path.into(),
                detail,
            })?
        }
        Format::GeoJson => return geojson_streets(path, crs, fallback_crs, frame),
    };
    let (crs, origin) = street_crs(path, crs, doc.declared_crs, fallback_crs, None)?;
    let mut out = Streets::new(
        path,
        format!("{} (from {origin})", crs.label),
        doc.features.len(),
    );
    for f in doc.features {
        let segments = if f.lines.is_empty() {
            Err(f.skip.unwrap_or_else(|| {
                (
                    IssueReason::UnsupportedGeometry,
                    "a polygon or surface, not a street line".into(),
                )
            }))
        } else {
            lines_segments(
                f.lines
                    .iter()
                    .map(|l| l.iter().map(|p| to_lon_lat(&crs, p[0], p[1]))),
                frame,
            )
            .and_then(|segments| on_ground(&f.attributes, segments))
        };
        out.take(f.source_id, segments);
    }
    Ok(out)
}

/// The streets of a GeoJSON file (see `read_streets`).
fn geojson_streets(
    path: &Path,
    crs: Option<&str>,
    fallback_crs: Option<&str>,
    frame: &LocalFrame,
) -> Result<Streets, IngestError> {
    let text = crate::read_text(path)?;
    let doc: Value = serde_json::from_str(&text).map_err(|source| IngestError::Json {
        path: path.into(),
        line: source.line(),
        source,
    })?;
    // The file's own `crs` member, read like the buildings' (name, EPSG code or OGC URN).
    let declared = doc.get("crs").and_then(DeclaredCrs::from_geojson);
    let (crs, origin) = street_crs(path, crs, declared, fallback_crs, Some(Crs::wgs84()))?;
    let unknown = |detail: &str| IngestError::UnknownFormat {
        path: path.into(),
        detail: detail.into(),
    };
    let features: Vec<(String, Option<&Value>)> =
        match doc.get("type").and_then(Value::as_str).unwrap_or("") {
            "FeatureCollection" => doc
                .get("features")
                .and_then(Value::as_array)
                .ok_or_else(|| unknown("a FeatureCollection without a \"features\" array"))?
                .iter()
                .enumerate()
                .map(|(i, f)| (feature_id(f, i), Some(f)))
                .collect(),
            "Feature" => vec![(feature_id(&doc, 0), Some(&doc))],
            "LineString" | "MultiLineString" => vec![("#0".into(), None)],
            "" => return Err(unknown("no top-level \"type\" member")),
            other => {
                return Err(unknown(&format!(
                    "top-level type {other:?} is not a GeoJSON FeatureCollection, Feature or line"
                )))
            }
        };
    let mut out = Streets::new(
        path,
        format!("{} (from {origin})", crs.label),
        features.len(),
    );
    for (id, feature) in features {
        let segments = match feature {
            Some(f) => feature_segments(f.get("geometry"), &crs, frame).and_then(|segments| {
                let properties = crate::feature::attributes(f.get("properties"));
                on_ground(&properties, segments)
            }),
            // A bare geometry.
            None => feature_segments(Some(&doc), &crs, frame),
        };
        out.take(id, segments);
    }
    Ok(out)
}

/// The streets of an OpenStreetMap file (PBF or XML): its `highway` ways on the ground (see `osm::read_streets`), in WGS84
/// lon/lat whatever the buildings' CRS; `--streets-crs` cannot apply.
fn osm_streets(
    path: &Path,
    encoding: crate::osm::Encoding,
    crs: Option<&str>,
    frame: &LocalFrame,
) -> Result<Streets, IngestError> {
    if let Some(c) = crs {
        return Err(IngestError::InvalidOption {
            name: "--streets-crs",
            detail: format!(
                "{c} given for {}, an OpenStreetMap file, whose coordinates are always WGS84 lon/lat",
                path.display()
            ),
        });
    }
    let lines = crate::osm::read_streets(path).map_err(|detail| IngestError::InvalidOsm {
        path: path.into(),
        encoding: encoding.label(),
        detail,
    })?;
    let crs = format!("{} (OpenStreetMap)", Crs::wgs84().label);
    let mut out = Streets::new(path, crs, lines.len());
    for line in lines {
        let segments = line
            .points
            .and_then(|p| line_segments(p.iter().map(|q| Ok((q[0], q[1]))), frame));
        out.take(line.id, segments);
    }
    Ok(out)
}

impl Streets {
    /// No streets yet, of `features` to read from `path`, in `crs` (where it came from said).
    fn new(path: &Path, crs: String, features: usize) -> Streets {
        Streets {
            segments: Vec::new(),
            report: StreetsReport {
                file: path.display().to_string(),
                crs,
                features_read: features,
                features_used: 0,
                segments: 0,
                length_m: 0.0,
                skipped: Vec::new(),
            },
        }
    }

    /// Takes the segments of feature `id`, or lists it as skipped with the reason.
    fn take(&mut self, id: String, segments: Result<Vec<[[f64; 2]; 2]>, Skip>) {
        match segments {
            Ok(segs) => {
                self.report.features_used += 1;
                self.report.length_m += segs
                    .iter()
                    .map(|[a, b]| (b[0] - a[0]).hypot(b[1] - a[1]))
                    .sum::<f64>();
                self.segments.extend(segs);
                self.report.segments = self.segments.len();
            }
            Err((reason, detail)) => self.report.skipped.push(FeatureIssue {
                file: self.report.file.clone(),
                feature_id: id,
                reason,
                detail,
            }),
        }
    }
}

/// A feature's id: its GeoJSON `id`, else `#index` (0-based) with its `name` property when it has one.
fn feature_id(f: &Value, index: usize) -> String {
    match f.get("id") {
        Some(Value::String(s)) => s.clone(),
        Some(Value::Number(n)) => n.to_string(),
        _ => match f.pointer("/properties/name").and_then(Value::as_str) {
            Some(name) => format!("#{index} ({name})"),
            None => format!("#{index}"),
        },
    }
}

type Skip = (IssueReason, String);

/// The attributes a street line is judged by (`osm::off_ground`), as text: a flag `true` / `false` as `yes` / `no`.
const GROUND_KEYS: [&str; 4] = ["tunnel", "indoor", "area", "highway"];

fn ground_key(key: &str) -> bool {
    GROUND_KEYS.iter().any(|k| key.eq_ignore_ascii_case(k))
}

fn attribute_tags(attributes: &citylod_model::Attributes) -> Vec<(String, String)> {
    use citylod_model::AttrValue;
    attributes
        .iter()
        .filter(|(k, _)| ground_key(k))
        .filter_map(|(k, v)| {
            let text = match v {
                AttrValue::Null => return None,
                AttrValue::Bool(b) => (if *b { "yes" } else { "no" }).to_string(),
                AttrValue::Int(i) => i.to_string(),
                AttrValue::Float(f) => f.to_string(),
                AttrValue::String(s) => s.clone(),
            };
            Some((k.clone(), text))
        })
        .collect()
}

/// `segments`, unless the line's attributes say it is no street on the ground (a tunnel, …): OpenStreetMap's tags,
/// or Overture Maps' flags.
fn on_ground(
    attributes: &citylod_model::Attributes,
    segments: Vec<[[f64; 2]; 2]>,
) -> Result<Vec<[[f64; 2]; 2]>, Skip> {
    match crate::osm::off_ground(&attribute_tags(attributes))
        .or_else(|| overture_off_ground(attributes))
    {
        Some(why) => Err((IssueReason::NotOnGround, why)),
        None => Ok(segments),
    }
}

/// Why an Overture Maps transportation segment is no street on the ground, if it is not: a road flag that holds for
/// the whole segment (`road_flags` entries whose `between` is null: `is_tunnel`, `is_indoor`,
/// `is_under_construction`, `is_abandoned`), or a level below the ground for the whole segment (`level_rules`).
/// Flags for a stretch of the segment leave it a barrier.
fn overture_off_ground(attributes: &citylod_model::Attributes) -> Option<String> {
    use citylod_model::AttrValue;
    let rules = |name: &str| -> Vec<Value> {
        match attributes.get(name) {
            Some(AttrValue::String(text)) => match serde_json::from_str(text) {
                Ok(Value::Array(rules)) => rules,
                _ => Vec::new(),
            },
            _ => Vec::new(),
        }
    };
    let whole = |r: &Value| r.get("between").is_none_or(Value::is_null);
    for r in rules("road_flags").iter().filter(|r| whole(r)) {
        for flag in r["values"].as_array().into_iter().flatten() {
            let why = match flag.as_str() {
                Some("is_tunnel") => "in a tunnel",
                Some("is_indoor") => "indoors",
                Some("is_under_construction") => "under construction",
                Some("is_abandoned") => "abandoned",
                _ => continue,
            };
            return Some(format!(
                "{why} (Overture road_flags {}): no barrier between buildings",
                flag.as_str().unwrap_or("")
            ));
        }
    }
    rules("level_rules")
        .iter()
        .filter(|r| whole(r))
        .find_map(|r| r["value"].as_i64().filter(|&l| l < 0))
        .map(|l| {
            format!(
                "below the ground (Overture level_rules value {l}): no barrier between buildings"
            )
        })
}

/// The segments of one feature's line geometry in the local frame, consecutive repeated points dropped.
fn feature_segments(
    geometry: Option<&Value>,
    crs: &Crs,
    frame: &LocalFrame,
) -> Result<Vec<[[f64; 2]; 2]>, Skip> {
    let g = match geometry {
        None | Some(Value::Null) => return Err((IssueReason::NoGeometry, "no geometry".into())),
        Some(g) => g,
    };
    let kind = g.get("type").and_then(Value::as_str).unwrap_or("");
    let coords = g.get("coordinates");
    let lines: Vec<&Value> = match kind {
        "LineString" => coords.into_iter().collect(),
        "MultiLineString" => coords
            .and_then(Value::as_array)
            .ok_or((
                IssueReason::MalformedGeometry,
                "MultiLineString coordinates are not an array".to_string(),
            ))?
            .iter()
            .collect(),
        other => {
            return Err((
                IssueReason::UnsupportedGeometry,
                format!("a street must be a LineString or MultiLineString, not {other:?}"),
            ))
        }
    };
    let lines = lines
        .into_iter()
        .map(|line| {
            line.as_array().ok_or((
                IssueReason::MalformedGeometry,
                "line coordinates are not an array".to_string(),
            ))
        })
        .collect::<Result<Vec<_>, Skip>>()?;
    lines_segments(
        lines.into_iter().map(|pts| {
            pts.iter().map(|p| {
                let (x, y) = p
                    .as_array()
                    .filter(|a| a.len() >= 2)
                    .and_then(|a| Some((a[0].as_f64()?, a[1].as_f64()?)))
                    .ok_or((
                        IssueReason::MalformedGeometry,
                        format!("position {p} is not [x, y]"),
                    ))?;
                to_lon_lat(crs, x, y)
            })
        }),
        frame,
    )
}

/// A position in `crs` as lon/lat, or why it cannot be placed.
fn to_lon_lat(crs: &Crs, x: f64, y: f64) -> Result<(f64, f64), Skip> {
    let at = || format!("position ({x}, {y})");
    crs.to_lon_lat(x, y).map_err(|e| match e {
        CoordError::NonFinite => (IssueReason::NonFiniteCoordinate, at()),
        CoordError::OutOfRange => (IssueReason::CoordinateOutOfRange, at()),
        CoordError::TransformFailed => (IssueReason::TransformFailed, at()),
    })
}

/// The segments of one feature's lines (each its points in lon/lat) in the local frame: lines without two distinct
/// points left out, `TooFewPoints` when none has them.
fn lines_segments<L, P>(lines: L, frame: &LocalFrame) -> Result<Vec<[[f64; 2]; 2]>, Skip>
where
    L: Iterator<Item = P>,
    P: Iterator<Item = Result<(f64, f64), Skip>>,
{
    let mut segments = Vec::new();
    for lon_lat in lines {
        match line_segments(lon_lat, frame) {
            Ok(s) => segments.extend(s),
            Err((IssueReason::TooFewPoints, _)) => {}
            Err(e) => return Err(e),
        }
    }
    if segments.is_empty() {
        return Err((
            IssueReason::TooFewPoints,
            "no line with two distinct points".into(),
        ));
    }
    Ok(segments)
}

/// One line's segments in the local frame, from its points in lon/lat; consecutive repeated points dropped.
/// `TooFewPoints` when it has no two distinct points.
fn line_segments(
    lon_lat: impl Iterator<Item = Result<(f64, f64), Skip>>,
    frame: &LocalFrame,
) -> Result<Vec<[[f64; 2]; 2]>, Skip> {
    let mut placed: Vec<[f64; 2]> = Vec::new();
    for p in lon_lat {
        let (lon, lat) = p?;
        if !(lon.abs() <= 180.0 && lat.abs() <= 90.0) {
            return Err((
                IssueReason::CoordinateOutOfRange,
                format!("position ({lon}, {lat})"),
            ));
        }
        let e = frame.geodetic_to_enu(lon, lat, frame.origin_h_m);
        if placed.last() != Some(&[e[0], e[1]]) {
            placed.push([e[0], e[1]]);
        }
    }
    if placed.len() < 2 {
        return Err((
            IssueReason::TooFewPoints,
            "no line with two distinct points".into(),
        ));
    }
    Ok(placed.windows(2).map(|w| [w[0], w[1]]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `text` written as `name` in a new temporary folder (removed when the first element is dropped).
    fn write(name: &str, text: &str) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        (dir, p)
    }

    #[test]
    fn lines_are_placed_and_every_other_feature_is_listed() {
        let (_dir, p) = write(
            "mixed.geojson",
            r#"{"type": "FeatureCollection", "features": [
              {"type": "Feature", "id": "a", "geometry": {"type": "LineString", "coordinates": [[4.0, 52.0], [4.001, 52.0], [4.001, 52.0]]}},
              {"type": "Feature", "properties": {"name": "Main St"}, "geometry": {"type": "MultiLineString", "coordinates": [[[4.0, 52.0], [4.0, 52.001]], [[4.0, 52.0]]]}},
              {"type": "Feature", "id": 7, "geometry": {"type": "Point", "coordinates": [4.0, 52.0]}},
              {"type": "Feature", "id": "n", "geometry": null},
              {"type": "Feature", "id": "one", "geometry": {"type": "LineString", "coordinates": [[4.0, 52.0], [4.0, 52.0]]}},
              {"type": "Feature", "id": "bad", "geometry": {"type": "LineString", "coordinates": [[4.0, 52.0], [4.0, 95.0]]}}
            ]}"#,
        );
        let frame = LocalFrame::new(4.0, 52.0, 0.0);
        let s = read_streets(&p, None, None, None, &frame).unwrap();
        let r = &s.report;
        assert_eq!((r.features_read, r.features_used, r.segments), (6, 2, 2));
        assert_eq!(r.features_read, r.features_used + r.skipped.len());
        let skipped: Vec<(&str, IssueReason)> = r
            .skipped
            .iter()
            .map(|i| (i.feature_id.as_str(), i.reason))
            .collect();
        assert_eq!(
            skipped,
            [
                ("7", IssueReason::UnsupportedGeometry),
                ("n", IssueReason::NoGeometry),
                ("one", IssueReason::TooFewPoints),
                ("bad", IssueReason::CoordinateOutOfRange),
            ]
        );
        // 0.001° of longitude at 52° N is about 68.6 m east; 0.001° of latitude about 111.3 m north.
        let [a, b] = s.segments[0];
        assert!(a[0].abs() < 1e-6 && a[1].abs() < 1e-6, "{a:?}");
        assert!((b[0] - 68.6).abs() < 0.2 && b[1].abs() < 0.1, "{b:?}");
        let [c, d] = s.segments[1];
        assert!(
            c[0].abs() < 1e-6 && (d[1] - 111.3).abs() < 0.2,
            "{c:?} {d:?}"
        );
        assert!((r.length_m - (68.6 + 111.3)).abs() < 0.5, "{}", r.length_m);
    }

    #[test]
    fn the_files_own_crs_comes_before_the_buildings_and_streets_crs_before_both() {
        // A 100 m line in Delft, in RD New (EPSG:28992), declared in the legacy EPSG-code form.
        let frame = LocalFrame::new(4.3571, 52.0116, 0.0);
        let rd = r#"{"type": "FeatureCollection", "crs": {"type": "EPSG", "properties": {"code": 28992}},
            "features": [{"type": "Feature", "properties": {}, "geometry": {"type": "LineString",
            "coordinates": [[84600, 447000], [84700, 447000]]}}]}"#;
        let (_dir, p) = write("rd.geojson", rd);
        // The declaration wins over the buildings' --crs (here lon/lat, which would read 84600° as nonsense).
        let s = read_streets(&p, None, None, Some("EPSG:4326"), &frame).unwrap();
        assert_eq!(s.report.features_used, 1, "{:?}", s.report.skipped);
        assert!(
            (s.report.length_m - 100.0).abs() < 0.5,
            "{}",
            s.report.length_m
        );
        let [a, _] = s.segments[0];
        assert!(a[0].hypot(a[1]) < 2000.0, "{a:?}: not near Delft");
        assert!(s.report.crs.contains("rd.geojson"), "{}", s.report.crs);
        // --streets-crs wins over the declaration: the same numbers read in EPSG:2263 (US feet) land elsewhere.
        let s = read_streets(&p, Some("EPSG:2263"), None, None, &frame).unwrap();
        assert_eq!(s.report.crs, "EPSG:2263 (from --streets-crs)");
        let [a, _] = s.segments[0];
        assert!(a[0].hypot(a[1]) > 1e6, "{a:?}");
        // A declaration that names no usable CRS is an error, unless --streets-crs says which.
        let link = rd.replace(
            r#"{"type": "EPSG", "properties": {"code": 28992}}"#,
            r#"{"type": "link", "properties": {"href": "http://example.com/crs"}}"#,
        );
        let (_dir, p) = write("link.geojson", &link);
        match read_streets(&p, None, None, None, &frame) {
            Err(e @ IngestError::CrsNotUnderstood { .. }) => {
                assert!(e.to_string().contains("with --streets-crs, e.g."), "{e}")
            }
            other => panic!("{other:?}"),
        }
        assert!(read_streets(&p, Some("EPSG:28992"), None, None, &frame).is_ok());
    }

    #[test]
    fn broken_files_are_errors_naming_the_file() {
        let frame = LocalFrame::new(0.0, 0.0, 0.0);
        let (_dir, p) = write(
            "broken.geojson",
            r#"{"type": "FeatureCollection", "features": ["#,
        );
        assert!(matches!(
            read_streets(&p, None, None, None, &frame),
            Err(IngestError::Json { .. })
        ));
        let (_dir, p) = write("polygon.geojson", r#"{"type": "Topology"}"#);
        let e = read_streets(&p, None, None, None, &frame).unwrap_err();
        assert!(e.to_string().contains("polygon.geojson"), "{e}");
        let (_dir, p) = write(
            "crs.geojson",
            r#"{"type": "FeatureCollection", "features": []}"#,
        );
        assert!(matches!(
            read_streets(&p, Some("EPSG:999999"), None, None, &frame),
            Err(IngestError::UnknownCrs { .. })
        ));
        assert!(matches!(
            read_streets(
                Path::new("/nonexistent/streets.geojson"),
                None,
                None,
                None,
                &frame
            ),
            Err(IngestError::Read { .. })
        ));
    }

    #[test]
    fn formats_streets_do_not_read_are_named_and_broken_ones_refused_as_their_format() {
        // A Shapefile's or GeoPackage's bytes used to give "stream did not contain valid UTF-8".
        let frame = LocalFrame::new(0.0, 0.0, 0.0);
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        std::fs::create_dir_all(dir.join("roads.gdb")).unwrap();
        std::fs::create_dir_all(dir.join("roads")).unwrap();
        // (file, its bytes, what the error says, whether it is a format not read, with a conversion hint)
        for (name, bytes, says, other) in [
            (
                "roads.shp",
                &b"\x00\x00\x27\x0a\xff"[..],
                "invalid shapefile",
                false,
            ),
            (
                "roads.gpkg",
                b"SQLite format 3\0\x10\x00",
                "invalid GeoPackage",
                false,
            ),
            (
                "roads.sqlite",
                b"SQLite format 3\0\x10\x00",
                "invalid GeoPackage",
                false,
            ),
            (
                "roads.zip",
                b"PK\x03\x04\x14\x00",
                "File Geodatabase",
                false,
            ),
            ("roads.gdb", b"", "File Geodatabase", false),
            ("roads.kmz", b"PK\x03\x04\x14\x00", "a ZIP archive", true),
            ("roads.dbf", b"\x03\x7e", "other than its .shp", true),
            ("roads", b"", "a folder", true),
        ] {
            let p = dir.join(name);
            if !p.is_dir() {
                std::fs::write(&p, bytes).unwrap();
            }
            let e = read_streets(&p, None, None, None, &frame)
                .unwrap_err()
                .to_string();
            assert!(e.contains(says) && e.contains(name), "{e}");
            assert_eq!(e.contains("ogr2ogr -f GPKG"), other, "{e}");
        }
    }
}
