//! `--streets` from a Shapefile and a GeoPackage, as city GIS teams keep their street centre lines. On real data:
//! the bundled Lower East Side roads (432 OpenStreetMap lines) and, when ../shared/data is beside the clone, Boston's
//! street centre lines (1,987), each written as a Shapefile of PolyLines and as a GeoPackage line layer beside a
//! building layer, give exactly the segments their GeoJSON gives. On fixtures written byte by byte: every record or
//! row that cannot be a street is listed with its id and reason, curves are read, the CRS comes from the file or the
//! options in the documented order, and a GeoPackage's line layer is chosen or asked for.

use citylod_ingest::{read_streets, IngestError, IssueReason, Streets};
use citylod_model::LocalFrame;
use citylod_testdata::geopackage::{self as gpkg, blob, Envelope, Layer, Row, Srs, Wkb};
use citylod_testdata::shapefile::{self as shp, num, text, Field, Shape, Table};
use rusqlite::types::Value as Sql;
use serde_json::Value;
use std::path::{Path, PathBuf};

const WGS84_PRJ: &str = r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#;

fn bundled_roads() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/nyc-les/les_roads.geojson")
}

/// The lines of a GeoJSON FeatureCollection of LineStrings, in its order, with each feature's name.
fn lines_of(geojson: &Path) -> Vec<(String, Vec<[f64; 2]>)> {
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(geojson).unwrap()).unwrap();
    doc["features"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            assert_eq!(f["geometry"]["type"], "LineString", "{f}");
            let name = ["name", "ST_LABEL"]
                .iter()
                .find_map(|k| f["properties"][k].as_str())
                .unwrap_or("")
                .to_string();
            let pts = f["geometry"]["coordinates"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
                .collect();
            (name, pts)
        })
        .collect()
}

fn line_layer(table: &str, srs_id: i64, rows: Vec<Row>) -> Layer {
    Layer {
        table: table.into(),
        geometry_column: "geom".into(),
        geometry_type: "LINESTRING".into(),
        srs_id,
        columns: vec![("name".into(), "TEXT".into())],
        rows,
    }
}

fn row(fid: i64, wkb: Option<Vec<u8>>, name: &str) -> Row {
    Row {
        fid,
        geometry: wkb.map(|w| blob(4326, Envelope::Xy, false, &w)),
        values: vec![Sql::Text(name.into())],
    }
}

/// A building layer of one square, so that a street GeoPackage holds more than its lines.
fn building_layer(at: [f64; 2]) -> Layer {
    let s = 0.0001;
    let ring = vec![
        at,
        [at[0] + s, at[1]],
        [at[0] + s, at[1] + s],
        [at[0], at[1] + s],
        at,
    ];
    Layer {
        table: "buildings".into(),
        geometry_column: "geom".into(),
        geometry_type: "MULTIPOLYGON".into(),
        srs_id: 4326,
        columns: vec![("name".into(), "TEXT".into())],
        rows: vec![Row {
            fid: 1,
            geometry: Some(blob(
                4326,
                Envelope::Xy,
                false,
                &Wkb::default().multipolygon(&[vec![ring]]),
            )),
            values: vec![Sql::Text("a building".into())],
        }],
    }
}

/// `lines` written as `dir/stem.shp` (PolyLines, with a name field and a WGS84 `.prj`).
fn write_shapefile(dir: &Path, stem: &str, lines: &[(String, Vec<[f64; 2]>)]) -> PathBuf {
    let mut table = Table::new(vec![Field::new("name", b'C', 80, 0)]);
    let shapes: Vec<Shape> = lines
        .iter()
        .map(|(name, pts)| {
            table.push([text(name)]);
            Shape::PolyLine(vec![pts.clone()])
        })
        .collect();
    shp::write(dir, stem, &shapes, &table, Some(WGS84_PRJ), None)
}

fn frame_at(lines: &[(String, Vec<[f64; 2]>)]) -> LocalFrame {
    let p = lines[0].1[0];
    LocalFrame::new(p[0], p[1], 0.0)
}

/// The street file `geojson` written as a Shapefile and as a GeoPackage (every other line a MultiLineString of it),
/// each read as --streets must give the same segments, lengths and counts.
fn reads_alike(geojson: &Path, expected_lines: usize) {
    let dir = tempfile::tempdir().unwrap();
    let lines = lines_of(geojson);
    assert_eq!(lines.len(), expected_lines);
    let frame = frame_at(&lines);

    let shapefile = write_shapefile(dir.path(), "streets", &lines);

    let wkb = Wkb::default();
    let rows = lines
        .iter()
        .enumerate()
        .map(|(i, (name, pts))| {
            let g = if i % 2 == 0 {
                wkb.line(pts)
            } else {
                wkb.of_members(5, &[wkb.line(pts)])
            };
            row(i as i64 + 1, Some(g), name)
        })
        .collect();
    let geopackage = dir.path().join("streets.gpkg");
    // Beside a building layer, the only layer of lines is the one read.
    let mut roads = line_layer("roads", 4326, rows);
    roads.geometry_type = "MULTILINESTRING".into();
    gpkg::write(&geopackage, &[], &[building_layer(lines[0].1[0]), roads]);

    let from_json = read_streets(geojson, None, None, None, &frame).unwrap();
    assert_eq!(from_json.report.features_read, lines.len());
    assert!(
        from_json.segments.len() > lines.len(),
        "{:?}",
        from_json.report
    );
    for (what, path) in [("Shapefile", &shapefile), ("GeoPackage", &geopackage)] {
        let s =
            read_streets(path, None, None, None, &frame).unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(s.segments, from_json.segments, "{what}");
        assert_eq!(
            s.report.features_read, from_json.report.features_read,
            "{what}"
        );
        assert_eq!(
            s.report.features_used, from_json.report.features_used,
            "{what}"
        );
        assert_eq!(
            s.report.skipped.len(),
            from_json.report.skipped.len(),
            "{what}"
        );
        assert!(
            (s.report.length_m - from_json.report.length_m).abs() < 1e-6,
            "{what}"
        );
        assert!(
            s.report.crs.starts_with("EPSG:4326") && s.report.crs.contains(path.to_str().unwrap()),
            "{what}: the CRS is the file's own: {}",
            s.report.crs
        );
    }
}

#[test]
fn the_lower_east_side_roads_read_alike_as_geojson_shapefile_and_geopackage() {
    reads_alike(&bundled_roads(), 432);
}

#[test]
fn bostons_street_centre_lines_read_alike_as_geojson_shapefile_and_geopackage() {
    if let Some(p) = citylod_testdata::shared_data("boston/boston_streets.geojson") {
        reads_alike(&p, 1987);
    }
}

fn skipped(s: &Streets) -> Vec<(String, IssueReason, String)> {
    s.report
        .skipped
        .iter()
        .map(|i| (i.feature_id.clone(), i.reason, i.detail.clone()))
        .collect()
}

const AT: [f64; 2] = [-73.99, 40.72];

fn near(dx_m: f64, dy_m: f64) -> [f64; 2] {
    // About a metre per 1e-5 degree here; exact values do not matter, only that they are distinct and nearby.
    [AT[0] + dx_m * 1.3e-5, AT[1] + dy_m * 0.9e-5]
}

#[test]
fn every_shapefile_record_that_is_not_a_street_is_listed_with_its_reason() {
    let dir = tempfile::tempdir().unwrap();
    let frame = LocalFrame::new(AT[0], AT[1], 0.0);
    let square = vec![
        near(0., 0.),
        near(0., 9.),
        near(9., 9.),
        near(9., 0.),
        near(0., 0.),
    ];
    let shapes = vec![
        // 0: two parts, one of a single repeated point: the other part's one segment is kept.
        Shape::PolyLine(vec![
            vec![near(0., 0.), near(0., 0.)],
            vec![near(0., 0.), near(50., 0.)],
        ]),
        // 1: no geometry.
        Shape::Null,
        // 2: a polygon, not a line.
        Shape::Polygon(vec![square]),
        // 3: a PolyLine whose counts do not fit its record.
        Shape::Raw {
            shape_type: 3,
            content: {
                let mut c = vec![0u8; 32];
                c.extend(1i32.to_le_bytes());
                c.extend(1000i32.to_le_bytes());
                c.extend(0i32.to_le_bytes());
                c
            },
        },
        // 4: a line of one point only.
        Shape::PolyLine(vec![vec![near(5., 5.), near(5., 5.)]]),
        // 5: deleted in the table.
        Shape::PolyLine(vec![vec![near(0., 10.), near(50., 10.)]]),
        // 6: a plain line of three points.
        Shape::PolyLine(vec![vec![near(0., 20.), near(25., 20.), near(50., 20.)]]),
    ];
    let mut table = Table::new(vec![Field::new("id", b'N', 9, 0)]);
    for i in 0..shapes.len() {
        if i == 5 {
            table.push_deleted([num(i)]);
        } else {
            table.push([num(i)]);
        }
    }
    let path = shp::write(dir.path(), "odd", &shapes, &table, Some(WGS84_PRJ), None);
    let s = read_streets(&path, None, None, None, &frame).unwrap();
    assert_eq!(s.report.features_read, 7);
    assert_eq!(s.report.features_used, 2);
    assert_eq!(s.segments.len(), 3, "{:?}", s.segments);
    let got = skipped(&s);
    let reasons: Vec<(&str, IssueReason)> =
        got.iter().map(|(id, r, _)| (id.as_str(), *r)).collect();
    assert_eq!(
        reasons,
        [
            ("1", IssueReason::NoGeometry),
            ("2", IssueReason::UnsupportedGeometry),
            ("3", IssueReason::MalformedGeometry),
            ("4", IssueReason::TooFewPoints),
            ("5", IssueReason::DeletedRecord),
        ]
    );
    assert!(got[1].2.contains("not a street line"), "{:?}", got[1]);
    assert!(got[2].2.contains("record 4"), "{:?}", got[2]);
}

#[test]
fn a_geopackage_line_layer_is_chosen_or_asked_for_and_its_curves_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let frame = LocalFrame::new(AT[0], AT[1], 0.0);
    let w = Wkb::default();
    let arc = w.circular_string(&[near(0., 0.), near(50., 50.), near(100., 0.)]);
    let compound = w.of_members(
        9,
        &[
            w.line(&[near(0., 30.), near(40., 30.)]),
            w.line(&[near(40., 30.), near(40., 60.)]),
        ],
    );
    let rows = vec![
        row(
            1,
            Some(w.line(&[near(0., -20.), near(100., -20.)])),
            "straight",
        ),
        row(2, Some(arc.clone()), "arc"),
        row(3, Some(compound), "compound"),
        row(
            4,
            Some(w.of_members(11, &[arc, w.line(&[near(0., 80.), near(10., 80.)])])),
            "multicurve",
        ),
        row(5, None, "null"),
        row(6, Some(w.point(near(1., 1.))), "point"),
        row(
            7,
            Some(w.polygon(&[vec![near(0., 0.), near(0., 9.), near(9., 9.), near(0., 0.)]])),
            "polygon",
        ),
        row(
            8,
            Some(w.of_members(5, &[w.point(near(1., 1.))])),
            "multilinestring of a point",
        ),
    ];
    let gpkg_path = dir.path().join("two.gpkg");
    let other = line_layer(
        "paths",
        4326,
        vec![row(
            1,
            Some(w.line(&[near(0., 200.), near(9., 200.)])),
            "path",
        )],
    );
    gpkg::write(
        &gpkg_path,
        &[],
        &[line_layer("roads", 4326, rows), other, building_layer(AT)],
    );

    // Two line layers: which one is for the user to say.
    match read_streets(&gpkg_path, None, None, None, &frame) {
        Err(e @ IngestError::InvalidGeoPackage { .. }) => {
            let m = e.to_string();
            assert!(
                m.contains("--streets-layer")
                    && m.contains("roads (LINESTRING)")
                    && m.contains("paths (LINESTRING)"),
                "{m}"
            );
        }
        other => panic!("{other:?}"),
    }
    let s = read_streets(&gpkg_path, None, Some("roads"), None, &frame).unwrap();
    assert_eq!(s.report.features_read, 8);
    assert_eq!(s.report.features_used, 4, "{:?}", s.report.skipped);
    let got = skipped(&s);
    let ids: Vec<&str> = got.iter().map(|(id, _, _)| id.as_str()).collect();
    assert_eq!(
        ids,
        ["two.gpkg#5", "two.gpkg#6", "two.gpkg#7", "two.gpkg#8"]
    );
    assert_eq!(got[0].1, IssueReason::NoGeometry);
    assert_eq!(got[1].1, IssueReason::UnsupportedGeometry);
    assert!(got[2].2.contains("not a street line"), "{:?}", got[2]);
    assert_eq!(got[3].1, IssueReason::MalformedGeometry, "{:?}", got[3]);
    // The arc (read twice: alone and in the MultiCurve) is approximated by many short segments.
    assert!(s.segments.len() > 1 + 2 + 1 + 2 * 8, "{}", s.segments.len());
    // About 110 m straight, 75 m of compound line, 11 m of line and twice a half circle of ~160 m.
    assert!(
        s.report.length_m > 450.0 && s.report.length_m < 600.0,
        "{}",
        s.report.length_m
    );

    // The other layer by name, and a layer asked of a format without layers.
    let p = read_streets(&gpkg_path, None, Some("paths"), None, &frame).unwrap();
    assert_eq!((p.report.features_used, p.segments.len()), (1, 1));
    // A GeoPackage of buildings only is no street file.
    let buildings = dir.path().join("buildings.gpkg");
    gpkg::write(&buildings, &[], &[building_layer(AT)]);
    match read_streets(&buildings, None, None, None, &frame) {
        Err(e @ IngestError::InvalidGeoPackage { .. }) => {
            assert!(e.to_string().contains("no table of lines"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    match read_streets(&bundled_roads(), None, Some("roads"), None, &frame) {
        Err(IngestError::InvalidOption {
            name: "--streets-layer",
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_street_files_crs_is_its_own_else_the_options() {
    let dir = tempfile::tempdir().unwrap();
    let frame = LocalFrame::new(AT[0], AT[1], 0.0);
    let mut table = Table::new(vec![Field::new("id", b'N', 9, 0)]);
    table.push([num(1)]);
    let line = Shape::PolyLine(vec![vec![near(0., 0.), near(50., 0.)]]);
    let bare = shp::write(
        dir.path(),
        "bare",
        std::slice::from_ref(&line),
        &table,
        None,
        None,
    );
    match read_streets(&bare, None, None, None, &frame) {
        Err(e @ IngestError::StreetsWithoutCrs { .. }) => {
            assert!(e.to_string().contains("--streets-crs"), "{e}")
        }
        other => panic!("{other:?}"),
    }
    let by_crs = read_streets(&bare, None, None, Some("EPSG:4326"), &frame).unwrap();
    assert!(
        by_crs.report.crs.ends_with("(from --crs)"),
        "{}",
        by_crs.report.crs
    );
    let by_streets_crs =
        read_streets(&bare, Some("EPSG:4326"), None, Some("EPSG:2263"), &frame).unwrap();
    assert!(
        by_streets_crs.report.crs.ends_with("(from --streets-crs)"),
        "{}",
        by_streets_crs.report.crs
    );
    assert_eq!(by_crs.segments, by_streets_crs.segments);
    // The file's own CRS comes before --crs.
    let with_prj = shp::write(dir.path(), "prj", &[line], &table, Some(WGS84_PRJ), None);
    let own = read_streets(&with_prj, None, None, Some("EPSG:2263"), &frame).unwrap();
    assert_eq!(own.segments, by_crs.segments);

    // A GeoPackage in a projected CRS reads as the same coordinates in a GeoJSON declaring that CRS.
    let xy = [
        [236_000.0, 900_000.0],
        [236_080.0, 900_030.0],
        [236_100.0, 900_100.0],
    ];
    let w = Wkb::default();
    let g = dir.path().join("massachusetts.gpkg");
    gpkg::write(
        &g,
        &[Srs::epsg(26986)],
        &[line_layer(
            "streets",
            26986,
            vec![Row {
                fid: 1,
                geometry: Some(blob(26986, Envelope::Xy, false, &w.line(&xy))),
                values: vec![Sql::Text("x".into())],
            }],
        )],
    );
    let j = dir.path().join("massachusetts.geojson");
    std::fs::write(
        &j,
        serde_json::json!({"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::26986"}},
            "features": [{"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": xy}}]})
        .to_string(),
    )
    .unwrap();
    let boston = LocalFrame::new(-71.06, 42.36, 0.0);
    let (a, b) = (
        read_streets(&g, None, None, None, &boston).unwrap(),
        read_streets(&j, None, None, None, &boston).unwrap(),
    );
    assert!(a.report.crs.starts_with("EPSG:26986"), "{}", a.report.crs);
    assert_eq!(a.segments, b.segments);
    assert!(
        (a.report.length_m - (85.44 + 72.80)).abs() < 0.5,
        "{}",
        a.report.length_m
    );
}

fn fgdb_fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fgdb")
        .join(name)
}

#[test]
fn a_file_geodatabase_written_by_gdal_gives_its_line_class_as_streets() {
    // kinds.gdb (tests/fgdb/make_fixtures.py, GDAL's OpenFileGDB driver): blocks, curved and 3D buildings, a table,
    // and one line class, `roads`: Main Street, 1,200 m along UTM 18N.
    let gdb = fgdb_fixture("kinds.gdb");
    let frame = LocalFrame::new(-74.0, 40.72, 0.0);
    let s = read_streets(&gdb, None, None, None, &frame).unwrap();
    assert!(s.report.crs.starts_with("EPSG:32618"), "{}", s.report.crs);
    assert_eq!(
        (
            s.report.features_read,
            s.report.features_used,
            s.segments.len()
        ),
        (1, 1, 1)
    );
    // UTM's scale factor here is about 0.9996–1.0000: the grid's 1,200 m are that many metres on the ground.
    assert!(
        (s.report.length_m - 1200.0).abs() < 1.0,
        "{}",
        s.report.length_m
    );
    // An east-west street on the grid: east on the ground but for the grid's convergence (~0.65° here).
    let [a, b] = s.segments[0];
    let heading = (b[1] - a[1]).atan2(b[0] - a[0]).to_degrees();
    assert!(
        heading.abs() < 1.0 && heading.abs() > 0.3,
        "{a:?} {b:?}: {heading}°"
    );
    // The same class by name; a polygon class asked for is refused with what street lines are.
    let named = read_streets(&gdb, None, Some("roads"), None, &frame).unwrap();
    assert_eq!(named.segments, s.segments);
    match read_streets(&gdb, None, Some("blocks"), None, &frame) {
        Err(e @ IngestError::InvalidFileGdb { .. }) => {
            let m = e.to_string();
            assert!(
                m.contains("\"blocks\" holds polygons; street lines are lines"),
                "{m}"
            );
        }
        other => panic!("{other:?}"),
    }
    // A geodatabase without line classes says so.
    match read_streets(&fgdb_fixture("nyc-les-2263.gdb"), None, None, None, &frame) {
        Err(e @ IngestError::InvalidFileGdb { .. }) => {
            assert!(e.to_string().contains("no line feature class"), "{e}")
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_lower_east_side_roads_written_by_gdal_as_a_geodatabase_in_feet_read_as_their_geojson() {
    // nyc-les-roads-2263.gdb: the bundled roads projected by PROJ to New York's State Plane (US survey feet) and
    // written by GDAL's OpenFileGDB driver: read back through this reader and proj4rs, every point lands within a
    // centimetre of the GeoJSON's.
    let geojson = bundled_roads();
    let frame = frame_at(&lines_of(&geojson));
    let from_json = read_streets(&geojson, None, None, None, &frame).unwrap();
    let s = read_streets(
        &fgdb_fixture("nyc-les-roads-2263.gdb"),
        None,
        None,
        None,
        &frame,
    )
    .unwrap();
    assert!(s.report.crs.starts_with("EPSG:2263"), "{}", s.report.crs);
    assert_eq!(s.report.features_read, 432);
    assert_eq!(s.report.features_used, from_json.report.features_used);
    assert_eq!(s.segments.len(), from_json.segments.len());
    let worst = s
        .segments
        .iter()
        .flatten()
        .zip(from_json.segments.iter().flatten())
        .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
        .fold(0.0, f64::max);
    assert!(worst < 0.01, "{worst} m");
    assert!((s.report.length_m - from_json.report.length_m).abs() < 0.1);
}

/// Copies the folder `from` into `to`.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, to.join(p.file_name().unwrap())).unwrap();
    }
}

#[test]
fn broken_street_files_give_errors_or_skips_never_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let frame = LocalFrame::new(AT[0], AT[1], 0.0);
    // Whatever happens, every feature read is used or listed.
    let accounted = |s: &Streets| {
        assert_eq!(
            s.report.features_read,
            s.report.features_used + s.report.skipped.len()
        );
    };

    // A GeoPackage row of every line type, each cut short at every byte and each byte flipped.
    let w = Wkb::default();
    let arc = w.circular_string(&[near(0., 0.), near(50., 50.), near(100., 0.)]);
    let compound = w.of_members(9, &[w.line(&[near(-40., 0.), near(0., 0.)]), arc.clone()]);
    let whole = w.of_members(
        11,
        &[arc, compound, w.line(&[near(0., 80.), near(10., 80.)])],
    );
    let mut rows = vec![row(1, Some(whole.clone()), "whole")];
    for n in 0..whole.len() {
        rows.push(row(rows.len() as i64 + 1, Some(whole[..n].to_vec()), "cut"));
        let mut b = whole.clone();
        b[n] ^= 0xFF;
        rows.push(row(rows.len() as i64 + 1, Some(b), "flip"));
    }
    let p = dir.path().join("broken.gpkg");
    gpkg::write(&p, &[], &[line_layer("roads", 4326, rows)]);
    let s = read_streets(&p, None, None, None, &frame).unwrap();
    accounted(&s);
    assert_eq!(s.report.features_read, 1 + 2 * whole.len());
    assert!(
        s.report
            .skipped
            .iter()
            .all(|i| i.feature_id != "broken.gpkg#1"),
        "the whole row is a street"
    );
    assert!(
        s.report.features_used > 0 && s.report.skipped.len() > whole.len(),
        "{} used, {} skipped of {}",
        s.report.features_used,
        s.report.skipped.len(),
        s.report.features_read
    );

    // The geodatabase's line table and the shapefile's .shp cut and garbled: an error naming the file, or streets.
    let gdb = fgdb_fixture("nyc-les-roads-2263.gdb");
    let table = std::fs::read(gdb.join("a00000009.gdbtable")).unwrap();
    let lines = lines_of(&bundled_roads());
    let shp_path = write_shapefile(dir.path(), "roads", &lines);
    let shp_bytes = std::fs::read(&shp_path).unwrap();
    let frame = frame_at(&lines);
    for (k, (original, target)) in (0..2 * 61)
        .map(|k| {
            if k % 2 == 0 {
                (&table, "gdb")
            } else {
                (&shp_bytes, "shp")
            }
        })
        .enumerate()
    {
        let mut b = original.clone();
        let at = (k / 2) * b.len() / 61;
        if k % 4 < 2 {
            b.truncate(at.max(1));
        } else {
            for x in &mut b[at..(at + 256).min(original.len())] {
                *x = x.wrapping_mul(29).wrapping_add(11);
            }
        }
        let path = if target == "gdb" {
            let copy = dir.path().join(format!("broken-{k}.gdb"));
            copy_dir(&gdb, &copy);
            std::fs::write(copy.join("a00000009.gdbtable"), &b).unwrap();
            copy
        } else {
            std::fs::write(&shp_path, &b).unwrap();
            shp_path.clone()
        };
        match read_streets(&path, None, None, None, &frame) {
            Ok(s) => accounted(&s),
            Err(e) => assert!(
                e.to_string()
                    .contains(path.file_name().unwrap().to_str().unwrap()),
                "{e}"
            ),
        }
    }
}

/// The bundled roads with tags on a few lines, as an OpenStreetMap export or Geofabrik's shapefiles write them:
/// (line index, attribute, value as GeoJSON writes it, whether the line is still a street).
const GROUND_TAGS: [(usize, &str, &str, bool); 10] = [
    (3, "tunnel", r#""yes""#, false),
    (40, "tunnel", r#""T""#, false),
    (41, "tunnel", r#""F""#, true),
    (77, "tunnel", r#""building_passage""#, false),
    (78, "tunnel", r#""no""#, true),
    (120, "TUNNEL", "true", false),
    (121, "tunnel", "0", true),
    (200, "highway", r#""construction""#, false),
    (201, "indoor", r#""yes""#, false),
    (310, "area", r#""yes""#, false),
];

#[test]
fn street_lines_in_tunnels_or_not_built_are_listed_and_not_barriers_in_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let lines = lines_of(&bundled_roads());
    let frame = frame_at(&lines);
    let tags_of = |i: usize| GROUND_TAGS.iter().filter(move |t| t.0 == i);
    let kept: Vec<usize> = (0..lines.len())
        .filter(|&i| tags_of(i).all(|t| t.3))
        .collect();
    assert_eq!(kept.len(), lines.len() - 7);

    // GeoJSON: each line with its name and the tag, the values typed as given (a string, a boolean, a number).
    let feature = |i: usize| {
        let mut properties = serde_json::json!({ "name": lines[i].0 });
        for (_, k, v, _) in tags_of(i) {
            properties[*k] = serde_json::from_str(v).unwrap();
        }
        serde_json::json!({
            "type": "Feature", "id": format!("road-{i}"), "properties": properties,
            "geometry": { "type": "LineString", "coordinates": lines[i].1 },
        })
    };
    let collection = |indices: &[usize]| {
        serde_json::json!({ "type": "FeatureCollection",
            "features": indices.iter().map(|&i| feature(i)).collect::<Vec<_>>() })
        .to_string()
    };
    let tagged = dir.path().join("tagged.geojson");
    std::fs::write(&tagged, collection(&(0..lines.len()).collect::<Vec<_>>())).unwrap();
    let only_kept = dir.path().join("kept.geojson");
    std::fs::write(&only_kept, collection(&kept)).unwrap();
    let expected = read_streets(&only_kept, None, None, None, &frame).unwrap();
    assert!(expected.report.skipped.is_empty());

    // Shapefile: text fields, as Geofabrik writes `tunnel` (T / F) and OSM exports the others.
    let fields = ["tunnel", "highway", "indoor", "area"];
    let mut table = Table::new(
        std::iter::once(Field::new("name", b'C', 80, 0))
            .chain(fields.iter().map(|f| Field::new(f, b'C', 20, 0)))
            .collect(),
    );
    let value_of = |i: usize, field: &str| {
        tags_of(i)
            .find(|t| t.1.eq_ignore_ascii_case(field))
            .map(|t| t.2.trim_matches('"').to_string())
            .unwrap_or_default()
    };
    let shapes: Vec<Shape> = (0..lines.len())
        .map(|i| {
            table.push(
                std::iter::once(text(&lines[i].0))
                    .chain(fields.iter().map(|f| text(&value_of(i, f)))),
            );
            Shape::PolyLine(vec![lines[i].1.clone()])
        })
        .collect();
    let shapefile = shp::write(dir.path(), "roads", &shapes, &table, Some(WGS84_PRJ), None);

    // GeoPackage: `tunnel` a BOOLEAN column (0 / 1, NULL where untagged), the others text.
    let wkb = Wkb::default();
    let mut layer = line_layer(
        "roads",
        4326,
        (0..lines.len())
            .map(|i| {
                let mut r = row(i as i64 + 1, Some(wkb.line(&lines[i].1)), &lines[i].0);
                let tunnel = match value_of(i, "tunnel").as_str() {
                    "" => Sql::Null,
                    "yes" | "T" | "true" | "building_passage" => Sql::Integer(1),
                    _ => Sql::Integer(0),
                };
                r.values.push(tunnel);
                for f in &fields[1..] {
                    r.values.push(match value_of(i, f) {
                        v if v.is_empty() => Sql::Null,
                        v => Sql::Text(v),
                    });
                }
                r
            })
            .collect(),
    );
    layer.columns.push(("tunnel".into(), "BOOLEAN".into()));
    for f in &fields[1..] {
        layer.columns.push((f.to_string(), "TEXT".into()));
    }
    let geopackage = dir.path().join("roads.gpkg");
    gpkg::write(&geopackage, &[], &[layer]);

    for (what, path) in [
        ("GeoJSON", &tagged),
        ("Shapefile", &shapefile),
        ("GeoPackage", &geopackage),
    ] {
        let s = read_streets(path, None, None, None, &frame).unwrap();
        assert_eq!(s.segments, expected.segments, "{what}");
        assert_eq!(s.report.features_read, lines.len(), "{what}");
        assert_eq!(s.report.features_used, kept.len(), "{what}");
        let skips = skipped(&s);
        assert_eq!(skips.len(), 7, "{what}: {skips:?}");
        for (id, reason, detail) in &skips {
            assert_eq!(*reason, IssueReason::NotOnGround, "{what}: {id}: {detail}");
        }
        // Each names the attribute and its value as the format keeps it (a GeoJSON or GeoPackage boolean as yes).
        let tunnel_true = match what {
            "GeoJSON" => "TUNNEL=yes",
            "Shapefile" => "tunnel=true",
            _ => "tunnel=yes",
        };
        let (tunnel_t, passage) = match what {
            "GeoPackage" => ("tunnel=yes", "tunnel=yes"),
            _ => ("tunnel=T", "tunnel=building_passage"),
        };
        let names = [
            "tunnel=yes",
            tunnel_t,
            passage,
            tunnel_true,
            "highway=construction",
            "indoor=yes",
            "area=yes",
        ];
        for ((id, _, detail), name) in skips.iter().zip(names) {
            assert!(
                detail.contains(&format!("({name})")) || detail.starts_with(&format!("{name}:")),
                "{what}: {id}: {detail:?} should name {name}"
            );
        }
        // Ids as each format gives them: the GeoJSON `id`, the record number, the row's fid.
        let ids: Vec<&str> = skips.iter().map(|s| s.0.as_str()).collect();
        let expected_ids: Vec<String> = GROUND_TAGS
            .iter()
            .filter(|t| !t.3)
            .map(|t| match what {
                "GeoJSON" => format!("road-{}", t.0),
                "Shapefile" => format!("roads.shp#{}", t.0),
                _ => format!("roads.gpkg#{}", t.0 + 1),
            })
            .collect();
        assert_eq!(ids, expected_ids, "{what}");
    }
}
