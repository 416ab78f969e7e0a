//! Shapefile input. On real data: the bundled Lower East Side written as a shapefile (outer rings clockwise, holes
//! counter-clockwise, a dBase table, a `.prj`) ingests into the same buildings as the same features written as
//! GeoJSON. On byte-level fixtures (`citylod_testdata::shapefile` writes exactly the bytes a test chooses): every
//! way a shapefile can lose or garble a building silently — deleted records, tables of another length, cells that do
//! not read as their type, rings wound against the rule, islands in courtyards, code pages, sidecar names — is an
//! error, a skip with its reason, or a repair in the report.

use citylod_ingest::{ingest, IngestError, IngestOptions, Ingested};
use citylod_model::AttrValue;
use citylod_testdata::shapefile::{num, text, write, Field, Shape, Table};
use serde_json::Value;
use std::path::{Path, PathBuf};

const WGS84_PRJ: &str = r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#;

fn nyc() -> Value {
    let p =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/nyc-les/les_buildings.geojson");
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn twice_area(r: &[[f64; 2]]) -> f64 {
    (0..r.len())
        .map(|i| {
            let (a, b) = (r[i], r[(i + 1) % r.len()]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

/// A ring wound clockwise (`cw`) or counter-clockwise, its closing point kept.
fn wound(mut r: Vec<[f64; 2]>, cw: bool) -> Vec<[f64; 2]> {
    if (twice_area(&r) < 0.0) != cw {
        r.reverse();
    }
    r
}

/// Writes the NYC features as `dir/les.shp` (+ .shx, .dbf, .prj) and as `dir/les.geojson` with the same attributes.
fn write_both(dir: &Path) -> (PathBuf, PathBuf) {
    let doc = nyc();
    let mut table = Table::new(vec![
        Field::new("osm_type", b'C', 10, 0),
        Field::new("osm_id", b'N', 20, 0),
        Field::new("height", b'C', 20, 0),
    ]);
    let (mut shapes, mut geojson) = (Vec::new(), Vec::new());
    for f in doc["features"].as_array().unwrap() {
        let g = &f["geometry"];
        let polygons: Vec<&Value> = match g["type"].as_str() {
            Some("Polygon") => vec![&g["coordinates"]],
            Some("MultiPolygon") => g["coordinates"].as_array().unwrap().iter().collect(),
            _ => continue,
        };
        let mut rings = Vec::new();
        for p in &polygons {
            for (k, r) in p.as_array().unwrap().iter().enumerate() {
                let points: Vec<[f64; 2]> = r
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|c| [c[0].as_f64().unwrap(), c[1].as_f64().unwrap()])
                    .collect();
                rings.push(wound(points, k == 0));
            }
        }
        shapes.push(Shape::Polygon(rings));
        let props = &f["properties"];
        let cell = |v: &Value| match v {
            Value::String(s) => text(s),
            Value::Number(n) => num(n),
            _ => Vec::new(),
        };
        table.push([
            cell(&props["osm_type"]),
            cell(&props["osm_id"]),
            cell(&props["height"]),
        ]);
        geojson.push(serde_json::json!({
            "type": "Feature",
            "properties": {"osm_type": props["osm_type"], "osm_id": props["osm_id"], "height": props["height"]},
            "geometry": g,
        }));
    }
    let shp = write(dir, "les", &shapes, &table, Some(WGS84_PRJ), None);
    let json = dir.join("les.geojson");
    let fc = serde_json::json!({"type": "FeatureCollection", "features": geojson});
    std::fs::write(&json, fc.to_string()).unwrap();
    (shp, json)
}

#[test]
fn a_shapefile_ingests_into_the_buildings_its_geojson_gives() {
    let dir = tempfile::tempdir().unwrap();
    let (shp, json) = write_both(dir.path());
    let from_shp = ingest(&[shp], &IngestOptions::default()).unwrap();
    let from_json = ingest(&[json], &IngestOptions::default()).unwrap();
    assert!(
        from_json.buildings.len() > 1300,
        "{}",
        from_json.buildings.len()
    );
    assert_eq!(from_shp.buildings.len(), from_json.buildings.len());
    assert_eq!(
        from_shp.report.skipped.len(),
        from_json.report.skipped.len()
    );
    assert_eq!(from_shp.frame, from_json.frame);
    let file = &from_shp.report.files[0];
    assert_eq!(
        (
            serde_json::to_value(file.format).unwrap(),
            file.crs.as_str()
        ),
        (Value::from("shapefile"), "EPSG:4326")
    );
    // Rings wound as a shapefile's rule says are not repairs; the text is ASCII, so no code page is assumed.
    assert_eq!(from_shp.report.rings_reoriented, 0);
    assert!(file.notes.is_empty(), "{:?}", file.notes);
    for (a, b) in from_shp.buildings.iter().zip(&from_json.buildings) {
        assert_eq!(a.source_id, b.source_id);
        assert!(
            a.source_id.starts_with("way/") || a.source_id.starts_with("relation/"),
            "{}",
            a.source_id
        );
        assert_eq!(a.attributes, b.attributes, "{}", a.source_id);
        assert_eq!(
            (a.height_m, a.base_z_m),
            (b.height_m, b.base_z_m),
            "{}",
            a.source_id
        );
        // The same outline, holes and all.
        assert_eq!(a.footprint.0.len(), b.footprint.0.len(), "{}", a.source_id);
        let holes = |x: &citylod_model::Building| {
            x.footprint
                .0
                .iter()
                .map(|p| p.interiors().len())
                .sum::<usize>()
        };
        assert_eq!(holes(a), holes(b), "{}", a.source_id);
        let (aa, ab) = (a.area_m2(), b.area_m2());
        assert!(
            (aa - ab).abs() <= 1e-9 * ab.max(1.0),
            "{}: {aa} m² against {ab} m²",
            a.source_id
        );
    }
    // The Lower East Side has buildings with courtyards: the comparison saw holes.
    assert!(from_shp.buildings.iter().any(|b| b
        .footprint
        .0
        .iter()
        .any(|p| !p.interiors().is_empty())));
}

/// A 10 m square (clockwise, closed) at `x` metres east of a point in Manhattan, in lon/lat.
fn square_at(x: f64, size: f64) -> Vec<[f64; 2]> {
    let (lon0, lat0) = (-73.99, 40.72);
    let (dlon, dlat) = (1.0 / 84_300.0, 1.0 / 111_000.0);
    let p = |e: f64, n: f64| [lon0 + e * dlon, lat0 + n * dlat];
    vec![
        p(x, 0.0),
        p(x, size),
        p(x + size, size),
        p(x + size, 0.0),
        p(x, 0.0),
    ]
}

fn ccw(mut r: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    r.reverse();
    r
}

fn ids(r: &Ingested) -> Vec<String> {
    r.buildings.iter().map(|b| b.source_id.clone()).collect()
}

fn skips(r: &Ingested) -> Vec<(String, String)> {
    r.report
        .skipped
        .iter()
        .map(|s| (s.feature_id.clone(), s.reason.as_str().to_string()))
        .collect()
}

fn repairs(r: &Ingested) -> Vec<(String, String, String)> {
    r.report
        .repaired
        .iter()
        .map(|s| {
            (
                s.feature_id.clone(),
                s.reason.as_str().to_string(),
                s.detail.clone(),
            )
        })
        .collect()
}

fn id_table() -> Table {
    Table::new(vec![
        Field::new("id", b'C', 8, 0),
        Field::new("HEIGHT", b'N', 8, 2),
    ])
}

#[test]
fn deleted_records_are_skipped_without_shifting_the_attributes_after_them() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = id_table();
    t.push([text("a"), num("12.00")]);
    t.push_deleted([text("b"), num("15.00")]);
    t.push([text("c"), num("18.50")]);
    let shapes: Vec<Shape> = (0..3)
        .map(|k| Shape::Polygon(vec![square_at(20.0 * k as f64, 10.0)]))
        .collect();
    let shp = write(dir.path(), "d", &shapes, &t, Some(WGS84_PRJ), None);
    let opts = IngestOptions {
        height_attr: Some("HEIGHT".into()),
        ..Default::default()
    };
    let r = ingest(&[shp], &opts).unwrap();
    assert_eq!(ids(&r), ["a", "c"]);
    assert_eq!(skips(&r), [("b".to_string(), "deleted_record".to_string())]);
    // The third shape keeps the third record's height (18.5 m), not the deleted one's.
    assert_eq!(r.buildings[1].height_m, 18.5);
    assert_eq!(r.buildings[1].attributes["HEIGHT"], AttrValue::Float(18.5));
    let west = |k: usize| {
        r.buildings[k].footprint.0[0]
            .exterior()
            .0
            .iter()
            .map(|c| c.x)
            .fold(f64::INFINITY, f64::min)
    };
    let gap = west(1) - west(0);
    assert!((gap - 40.0).abs() < 0.5, "{gap}");
}

#[test]
fn a_dbf_and_a_shp_of_different_lengths_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = id_table();
    t.push([text("a"), num("12")]);
    let shapes = vec![
        Shape::Polygon(vec![square_at(0.0, 10.0)]),
        Shape::Polygon(vec![square_at(20.0, 10.0)]),
    ];
    let shp = write(dir.path(), "n", &shapes, &t, Some(WGS84_PRJ), None);
    let e = ingest(std::slice::from_ref(&shp), &IngestOptions::default()).unwrap_err();
    assert!(
        e.to_string()
            .contains("holds 2 shape(s) and its .dbf 1 record(s)"),
        "{e}"
    );
    // A .dbf whose header counts more records than its bytes hold.
    t.push([text("b"), num("12")]);
    write(dir.path(), "n", &shapes, &t, Some(WGS84_PRJ), None);
    let dbf = dir.path().join("n.dbf");
    let bytes = std::fs::read(&dbf).unwrap();
    std::fs::write(&dbf, &bytes[..bytes.len() - 10]).unwrap();
    let e = ingest(std::slice::from_ref(&shp), &IngestOptions::default()).unwrap_err();
    assert!(
        e.to_string()
            .contains("gives 2 records of 17 bytes, the file holds 1"),
        "{e}"
    );
    // A .shp cut inside its second record.
    write(dir.path(), "n", &shapes, &t, Some(WGS84_PRJ), None);
    let bytes = std::fs::read(&shp).unwrap();
    std::fs::write(&shp, &bytes[..bytes.len() - 20]).unwrap();
    let e = ingest(std::slice::from_ref(&shp), &IngestOptions::default()).unwrap_err();
    assert!(matches!(e, IngestError::InvalidShapefile { .. }), "{e}");
    assert!(e.to_string().contains("cut short"), "{e}");
}

#[test]
fn cells_that_do_not_read_as_their_type_are_kept_as_text_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Table::new(vec![
        Field::new("id", b'C', 4, 0),
        Field::new("levels", b'N', 6, 0),
        Field::new("ratio", b'F', 19, 11),
        Field::new("built", b'D', 8, 0),
        Field::new("listed", b'L', 1, 0),
        Field::new("area", b'N', 8, 2),
    ]);
    t.push([
        text("ok"),
        num(4),
        num("1.23456789012"),
        text("20110307"),
        text("T"),
        num("12.00"),
    ]);
    // A null date as many writers write it, a blank number and a '?' logical: no values, nothing to report.
    t.push([
        text("null"),
        text(""),
        text(""),
        text("00000000"),
        text("?"),
        num("******"),
    ]);
    // A decimal comma, a date that is none, a logical that is none.
    t.push([
        text("bad"),
        num("1,5"),
        num("2.5"),
        text("20111345"),
        text("X"),
        num("7"),
    ]);
    let shapes: Vec<Shape> = (0..3)
        .map(|k| Shape::Polygon(vec![square_at(20.0 * k as f64, 10.0)]))
        .collect();
    let shp = write(dir.path(), "c", &shapes, &t, Some(WGS84_PRJ), None);
    let r = ingest(&[shp], &IngestOptions::default()).unwrap();
    assert_eq!(ids(&r), ["ok", "null", "bad"]);
    let a = |k: usize, name: &str| r.buildings[k].attributes[name].clone();
    assert_eq!(a(0, "levels"), AttrValue::Int(4));
    // An F field is read as a double from its text (a 32-bit float would give 1.2345679).
    assert_eq!(a(0, "ratio"), AttrValue::Float(1.234_567_890_12));
    assert_eq!(a(0, "built"), AttrValue::String("2011-03-07".into()));
    assert_eq!(a(0, "listed"), AttrValue::Bool(true));
    // A field with decimals is a number with decimals, whole or not.
    assert_eq!(a(0, "area"), AttrValue::Float(12.0));
    for f in ["levels", "ratio", "built", "listed", "area"] {
        assert_eq!(a(1, f), AttrValue::Null, "{f}");
    }
    assert_eq!(a(2, "levels"), AttrValue::String("1,5".into()));
    assert_eq!(a(2, "built"), AttrValue::String("20111345".into()));
    assert_eq!(a(2, "listed"), AttrValue::String("X".into()));
    let rep: Vec<(String, String)> = repairs(&r)
        .into_iter()
        .filter(|(_, reason, _)| reason == "undecodable_value_kept_as_text")
        .map(|(id, _, detail)| (id, detail.split(':').next().unwrap().to_string()))
        .collect();
    assert_eq!(
        rep,
        [
            ("bad".to_string(), "field levels".to_string()),
            ("bad".to_string(), "field built".to_string()),
            ("bad".to_string(), "field listed".to_string()),
        ]
    );
}

#[test]
fn rings_are_grouped_by_containment_whatever_their_order_and_winding() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Table::new(vec![Field::new("id", b'C', 12, 0)]);
    // A 60 m block with a 40 m courtyard holding a 10 m island, rings listed island first.
    let block = square_at(0.0, 60.0);
    let court = {
        let r = square_at(10.0, 40.0);
        let lift = |p: [f64; 2]| [p[0], p[1] + 10.0 / 111_000.0];
        ccw(r.into_iter().map(lift).collect())
    };
    let island = {
        let r = square_at(25.0, 10.0);
        r.into_iter()
            .map(|p| [p[0], p[1] + 25.0 / 111_000.0])
            .collect::<Vec<_>>()
    };
    t.push([text("courtyard")]);
    // An outline wound counter-clockwise (against the rule) with nothing around it: kept, and counted as reoriented.
    t.push([text("backwards")]);
    let shapes = vec![
        Shape::Polygon(vec![island.clone(), court.clone(), block.clone()]),
        Shape::Polygon(vec![ccw(square_at(100.0, 10.0))]),
    ];
    let shp = write(dir.path(), "r", &shapes, &t, Some(WGS84_PRJ), None);
    let r = ingest(&[shp], &IngestOptions::default()).unwrap();
    assert_eq!(ids(&r), ["courtyard", "backwards"]);
    let fp = &r.buildings[0].footprint;
    // The block with its courtyard, and the island as a polygon of its own.
    assert_eq!(fp.0.len(), 2, "{fp:?}");
    let mut holes: Vec<usize> = fp.0.iter().map(|p| p.interiors().len()).collect();
    holes.sort();
    assert_eq!(holes, [0, 1]);
    // Block less courtyard plus island: 36 − 16 + 1 of the lone 10 m square's area.
    let (area, unit) = (r.buildings[0].area_m2(), r.buildings[1].area_m2());
    assert!((unit - 100.0).abs() < 1.0, "{unit}");
    assert!((area / unit - 21.0).abs() < 0.01, "{area} {unit}");
    assert_eq!(r.report.rings_reoriented, 1);
}

#[test]
fn shapes_that_are_no_footprint_are_skipped_with_their_type() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Table::new(vec![Field::new("id", b'C', 8, 0)]);
    for id in [
        "null", "point", "line", "patch", "counts", "zpoly", "mpoly", "open",
    ] {
        t.push([text(id)]);
    }
    let z: Vec<[f64; 3]> = square_at(0.0, 10.0)
        .into_iter()
        .map(|p| [p[0], p[1], 7.0])
        .collect();
    let mut open = square_at(60.0, 10.0);
    open.pop();
    // A polygon record claiming a million points in a few bytes.
    let mut counts = Vec::new();
    counts.extend_from_slice(&[0u8; 32]);
    counts.extend_from_slice(&1i32.to_le_bytes());
    counts.extend_from_slice(&1_000_000i32.to_le_bytes());
    counts.extend_from_slice(&0i32.to_le_bytes());
    let shapes = vec![
        Shape::Null,
        Shape::Point(square_at(0.0, 1.0)[0]),
        Shape::PolyLine(vec![square_at(0.0, 10.0)]),
        Shape::Raw {
            shape_type: 31,
            content: vec![0; 40],
        },
        Shape::Raw {
            shape_type: 5,
            content: counts,
        },
        Shape::PolygonZ(vec![z]),
        Shape::PolygonM(vec![square_at(30.0, 10.0)]),
        Shape::Polygon(vec![open]),
    ];
    let shp = write(dir.path(), "s", &shapes, &t, Some(WGS84_PRJ), None);
    let r = ingest(&[shp], &IngestOptions::default()).unwrap();
    assert_eq!(ids(&r), ["zpoly", "mpoly", "open"]);
    let s = skips(&r);
    let reason = |id: &str| s.iter().find(|(i, _)| i == id).map(|(_, r)| r.as_str());
    assert_eq!(reason("null"), Some("no_geometry"));
    assert_eq!(reason("point"), Some("unsupported_geometry"));
    assert_eq!(reason("line"), Some("unsupported_geometry"));
    assert_eq!(reason("patch"), Some("malformed_geometry"));
    assert_eq!(reason("counts"), Some("malformed_geometry"));
    let detail = |id: &str| {
        r.report
            .skipped
            .iter()
            .find(|x| x.feature_id == id)
            .unwrap()
            .detail
            .clone()
    };
    assert!(detail("line").contains("PolyLine"), "{}", detail("line"));
    assert!(
        detail("patch").contains("MultiPatch"),
        "{}",
        detail("patch")
    );
    assert!(
        detail("counts").contains("1000000 points"),
        "{}",
        detail("counts")
    );
    assert!(repairs(&r)
        .iter()
        .any(|(id, reason, _)| id == "open" && reason == "ring_closed"));
}

#[test]
fn text_is_decoded_in_the_code_page_the_files_name() {
    let dir = tempfile::tempdir().unwrap();
    let one = vec![Shape::Polygon(vec![square_at(0.0, 10.0)])];
    let name = |r: &Ingested| r.buildings[0].attributes["name"].clone();
    let with = |bytes: &[u8], ldid: u8, cpg: Option<&str>| {
        let mut t = Table::new(vec![Field::new("name", b'C', 16, 0)]);
        t.ldid = ldid;
        t.push([bytes]);
        let stem = format!("t{}", std::fs::read_dir(dir.path()).unwrap().count());
        let shp = write(dir.path(), &stem, &one, &t, Some(WGS84_PRJ), cpg);
        ingest(&[shp], &IngestOptions::default())
    };
    // Windows-1252 with nothing naming it: not UTF-8, so read as Windows-1252, and the report says so.
    let r = with(b"Caf\xe9 \x80", 0, None).unwrap();
    assert_eq!(name(&r), AttrValue::String("Café €".into()));
    assert!(
        r.report.files[0].notes[0].contains("Windows-1252"),
        "{:?}",
        r.report.files[0].notes
    );
    // UTF-8 with nothing naming it.
    let r = with("Café".as_bytes(), 0, None).unwrap();
    assert_eq!(name(&r), AttrValue::String("Café".into()));
    assert!(r.report.files[0].notes.is_empty());
    // A .cpg LATIN1 (which GDAL writes) and one naming Windows-1251; the language driver byte of Windows-1251.
    assert_eq!(
        name(&with(b"Caf\xe9", 0, Some("LATIN1")).unwrap()),
        AttrValue::String("Café".into())
    );
    let moscow = "\u{41c}\u{43e}\u{441}\u{43a}\u{432}\u{430}";
    assert_eq!(
        name(&with(b"\xcc\xee\xf1\xea\xe2\xe0", 0, Some("1251")).unwrap()),
        AttrValue::String(moscow.into())
    );
    assert_eq!(
        name(&with(b"\xcc\xee\xf1\xea\xe2\xe0", 0xC9, None).unwrap()),
        AttrValue::String(moscow.into())
    );
    // A .cpg saying UTF-8 over bytes that are not: kept with U+FFFD, and reported.
    let r = with(b"Caf\xe9", 0, Some("UTF-8")).unwrap();
    assert_eq!(name(&r), AttrValue::String("Caf\u{fffd}".into()));
    assert!(repairs(&r)
        .iter()
        .any(|(_, reason, d)| reason == "undecodable_value_kept_as_text" && d.contains("U+FFFD")));
    // A code page citylod cannot read.
    let e = with(b"abc", 0, Some("EBCDIC-US")).unwrap_err();
    assert!(e.to_string().contains("EBCDIC-US"), "{e}");
}

#[test]
fn sidecars_are_found_in_any_case_and_refused_as_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = id_table();
    t.push([text("a"), num("9")]);
    let one = vec![Shape::Polygon(vec![square_at(0.0, 10.0)])];
    write(dir.path(), "bld", &one, &t, Some(WGS84_PRJ), None);
    for ext in ["shp", "shx", "dbf", "prj"] {
        std::fs::rename(
            dir.path().join(format!("bld.{ext}")),
            dir.path().join(format!("BLD.{}", ext.to_uppercase())),
        )
        .unwrap();
    }
    let r = ingest(&[dir.path().join("BLD.SHP")], &IngestOptions::default()).unwrap();
    assert_eq!(
        (ids(&r), r.report.files[0].crs.as_str()),
        (vec!["a".to_string()], "EPSG:4326")
    );
    let e = ingest(&[dir.path().join("BLD.DBF")], &IngestOptions::default()).unwrap_err();
    assert!(
        e.to_string().contains("attribute table; give its .shp"),
        "{e}"
    );
}

#[test]
fn missing_or_unreadable_companions_say_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    let (shp, _) = write_both(dir.path());
    let opts = IngestOptions::default();
    // A .prj without an EPSG code in a projection citylod does not identify: the user gives the CRS.
    let esri = r#"PROJCS["NAD_1983_Polyconic",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Polyconic"],PARAMETER["False_Easting",0.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-74.0],PARAMETER["Latitude_Of_Origin",40.0],UNIT["Meter",1.0]]"#;
    std::fs::write(dir.path().join("les.prj"), esri).unwrap();
    let e = ingest(std::slice::from_ref(&shp), &opts).unwrap_err();
    assert!(
        matches!(e, IngestError::CrsNotUnderstood { member: ".prj", .. }),
        "{e}"
    );
    assert!(e.to_string().contains("--crs"), "{e}");
    // --crs overrides the .prj (here the true one, WGS84).
    let with_crs = IngestOptions {
        crs: Some("EPSG:4326".into()),
        ..Default::default()
    };
    assert!(
        ingest(std::slice::from_ref(&shp), &with_crs)
            .unwrap()
            .buildings
            .len()
            > 1300
    );
    // No .prj at all.
    std::fs::remove_file(dir.path().join("les.prj")).unwrap();
    let e = ingest(std::slice::from_ref(&shp), &opts).unwrap_err();
    assert!(matches!(e, IngestError::MissingPrj { .. }), "{e}");
    // No .dbf: the attribute table is half of a shapefile.
    std::fs::remove_file(dir.path().join("les.dbf")).unwrap();
    let e = ingest(std::slice::from_ref(&shp), &with_crs).unwrap_err();
    assert!(e.to_string().contains(".dbf"), "{e}");
    // A .shp that is not one.
    let bad = dir.path().join("bad.shp");
    std::fs::write(&bad, b"not a shapefile at all, just text").unwrap();
    let e = ingest(&[bad], &with_crs).unwrap_err();
    assert!(matches!(e, IngestError::InvalidShapefile { .. }), "{e}");
}

/// Every truncation and many corruptions of a small shapefile: an error or buildings, never a panic.
#[test]
fn broken_bytes_give_errors_or_skips_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Table::new(vec![
        Field::new("id", b'C', 6, 0),
        Field::new("n", b'N', 5, 0),
        Field::new("d", b'D', 8, 0),
    ]);
    t.push([text("a"), num(3), text("20200101")]);
    t.push([text("b"), num(4), text("20200102")]);
    let block = square_at(0.0, 60.0);
    let shapes = vec![
        Shape::Polygon(vec![block, ccw(square_at(20.0, 10.0))]),
        Shape::PolygonZ(vec![square_at(80.0, 10.0)
            .into_iter()
            .map(|p| [p[0], p[1], 1.0])
            .collect()]),
    ];
    let shp = write(dir.path(), "f", &shapes, &t, Some(WGS84_PRJ), None);
    let (shp_bytes, dbf_bytes) = (
        std::fs::read(&shp).unwrap(),
        std::fs::read(dir.path().join("f.dbf")).unwrap(),
    );
    let opts = IngestOptions::default();
    let mut outcomes = [0usize; 2];
    let mut run = |s: &[u8], d: &[u8]| {
        std::fs::write(&shp, s).unwrap();
        std::fs::write(dir.path().join("f.dbf"), d).unwrap();
        outcomes[ingest(std::slice::from_ref(&shp), &opts).is_ok() as usize] += 1;
    };
    for cut in 0..shp_bytes.len() {
        run(&shp_bytes[..cut], &dbf_bytes);
    }
    for cut in 0..dbf_bytes.len() {
        run(&shp_bytes, &dbf_bytes[..cut]);
    }
    // Each byte set to 0x00, 0x7f and 0xff in turn.
    for at in 0..shp_bytes.len().max(dbf_bytes.len()) {
        for v in [0x00, 0x7f, 0xff] {
            if at < shp_bytes.len() {
                let mut s = shp_bytes.clone();
                s[at] = v;
                run(&s, &dbf_bytes);
            }
            if at < dbf_bytes.len() {
                let mut d = dbf_bytes.clone();
                d[at] = v;
                run(&shp_bytes, &d);
            }
        }
    }
    // Both outcomes happen: most corruptions of point bytes still read, truncations are refused.
    assert!(outcomes[0] > 100 && outcomes[1] > 100, "{outcomes:?}");
}

/// An Esri .prj, as ArcGIS writes it, names no EPSG code: it is identified by its projection, parameters, unit and
/// ellipsoid, and the report says so. Here New York's Long Island State Plane in US feet (EPSG:2263).
#[test]
fn an_esri_prj_without_a_code_is_identified() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = id_table();
    t.push([text("a"), num("10.00")]);
    // A 30 × 30 ft square at 985,000 ft east, 200,000 ft north: the Lower East Side.
    let (x, y) = (985_000.0, 200_000.0);
    let ring = vec![
        [x, y],
        [x, y + 30.0],
        [x + 30.0, y + 30.0],
        [x + 30.0, y],
        [x, y],
    ];
    let esri = r#"PROJCS["NAD_1983_StatePlane_New_York_Long_Island_FIPS_3104_Feet",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],PARAMETER["False_Easting",984250.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-74.0],PARAMETER["Standard_Parallel_1",40.66666666666666],PARAMETER["Standard_Parallel_2",41.03333333333333],PARAMETER["Latitude_Of_Origin",40.16666666666666],UNIT["Foot_US",0.3048006096012192]]"#;
    let shp = write(
        dir.path(),
        "ny",
        &[Shape::Polygon(vec![ring])],
        &t,
        Some(esri),
        None,
    );
    let r = ingest(std::slice::from_ref(&shp), &IngestOptions::default()).unwrap();
    let file = &r.report.files[0];
    assert_eq!(file.crs, "EPSG:2263");
    assert!(
        file.notes
            .iter()
            .any(|n| n.contains("EPSG:2263") && n.contains("identified")),
        "{:?}",
        file.notes
    );
    // The same as naming the CRS: the square is ~83.6 m² (900 ft²) in Manhattan.
    let named = ingest(
        &[shp],
        &IngestOptions {
            crs: Some("EPSG:2263".into()),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(r.frame, named.frame);
    let f = &r.frame;
    assert!(
        (f.origin_lon_deg + 73.99).abs() < 0.02 && (f.origin_lat_deg - 40.72).abs() < 0.02,
        "{f:?}"
    );
    assert!(
        (r.buildings[0].area_m2() - 83.6).abs() < 0.5,
        "{}",
        r.buildings[0].area_m2()
    );
}

/// What a review of real writers' files found: text fields over 255 bytes (FoxPro and shapelib keep the high byte of
/// the width in the decimals byte), bytes after a NUL, whole numbers beyond 64 bits, 30 February, field names in a
/// code page nothing names, `.cpg` files saying `SYSTEM` or nothing, a stale `.shp` header length, rings wound as
/// GeoJSON winds them, a UTF-16 `.prj`.
#[test]
fn what_real_writers_leave_in_their_files_is_read_or_reported() {
    let dir = tempfile::tempdir().unwrap();
    let one = vec![Shape::Polygon(vec![square_at(0.0, 10.0)])];
    // A 300-byte text field, then a height: by hand, since the widths do not fit the writer's byte.
    let wide = {
        let mut d = vec![0x03, 126, 1, 1];
        d.extend_from_slice(&1u32.to_le_bytes());
        d.extend_from_slice(&(32u16 + 64 + 1).to_le_bytes());
        d.extend_from_slice(&(1u16 + 300 + 6).to_le_bytes());
        d.extend_from_slice(&[0; 20]);
        let field = |name: &[u8], kind: u8, len: u8, dec: u8| {
            let mut f = name.to_vec();
            f.resize(11, 0);
            f.push(kind);
            f.extend_from_slice(&[0; 4]);
            f.extend_from_slice(&[len, dec]);
            f.extend_from_slice(&[0; 14]);
            f
        };
        d.extend(field(b"note", b'C', 44, 1));
        d.extend(field(b"HEIGHT", b'N', 6, 1));
        d.push(0x0D);
        d.push(b' ');
        let mut note = b"long".to_vec();
        note.resize(300, b' ');
        d.extend(note);
        d.extend_from_slice(b"  22.5");
        d.push(0x1A);
        d
    };
    let mut t = id_table();
    t.push([text("x"), num("1")]);
    let shp = write(dir.path(), "wide", &one, &t, Some(WGS84_PRJ), None);
    std::fs::write(dir.path().join("wide.dbf"), wide).unwrap();
    let opts = IngestOptions {
        height_attr: Some("HEIGHT".into()),
        ..Default::default()
    };
    let r = ingest(std::slice::from_ref(&shp), &opts).unwrap();
    assert_eq!(
        r.buildings[0].attributes["note"],
        AttrValue::String("long".into())
    );
    assert_eq!(r.buildings[0].height_m, 22.5);

    // Cells: text after a NUL, a 20-digit identifier, a date that does not exist.
    let mut t = Table::new(vec![
        Field::new("id", b'C', 12, 0),
        Field::new("big", b'N', 20, 0),
        Field::new("day", b'D', 8, 0),
    ]);
    t.push([
        b"abc\0\0old".to_vec(),
        num("12345678901234567891"),
        text("20110230"),
    ]);
    let shp = write(dir.path(), "cells", &one, &t, Some(WGS84_PRJ), None);
    let r = ingest(&[shp], &IngestOptions::default()).unwrap();
    let a = &r.buildings[0].attributes;
    assert_eq!(r.buildings[0].source_id, "abc");
    assert_eq!(a["big"], AttrValue::String("12345678901234567891".into()));
    assert_eq!(a["day"], AttrValue::String("20110230".into()));
    assert_eq!(repairs(&r).len(), 2, "{:?}", repairs(&r));

    // A field name in Windows-1252 (HÖHE), nothing naming the code page, the values all ASCII.
    let mut t = Table::new(vec![Field::new("HxHE", b'N', 6, 1)]);
    t.push([num("12.0")]);
    let shp = write(dir.path(), "names", &one, &t, Some(WGS84_PRJ), None);
    let dbf = dir.path().join("names.dbf");
    let mut bytes = std::fs::read(&dbf).unwrap();
    assert_eq!(bytes[32 + 1], b'x');
    bytes[32 + 1] = 0xD6;
    std::fs::write(&dbf, bytes).unwrap();
    let r = ingest(std::slice::from_ref(&shp), &IngestOptions::default()).unwrap();
    assert_eq!(
        r.buildings[0].attributes["H\u{d6}HE"],
        AttrValue::Float(12.0)
    );
    assert!(r.report.files[0].notes[0].contains("Windows-1252"));
    // .cpg files saying nothing, or the writer's system code page: read as with no .cpg, and said.
    for (cpg, said) in [("", false), ("SYSTEM", true)] {
        let shp = write(
            dir.path(),
            "cpg",
            &one[..1],
            &{
                let mut t1 = Table::new(vec![Field::new("name", b'C', 8, 0)]);
                t1.push([b"Caf\xe9".to_vec()]);
                t1
            },
            Some(WGS84_PRJ),
            Some(cpg),
        );
        let r = ingest(&[shp], &IngestOptions::default()).unwrap();
        assert_eq!(
            r.buildings[0].attributes["name"],
            AttrValue::String("Café".into()),
            "{cpg:?}"
        );
        assert_eq!(
            r.report.files[0].notes.iter().any(|n| n.contains("SYSTEM")),
            said,
            "{cpg:?}"
        );
    }

    // A .shp header giving fewer bytes than its records take (a stale header after an append): all read, and said.
    let mut t = id_table();
    t.push([text("a"), num("1")]);
    t.push([text("b"), num("1")]);
    let two = vec![
        Shape::Polygon(vec![square_at(0.0, 10.0)]),
        Shape::Polygon(vec![square_at(20.0, 10.0)]),
    ];
    let shp = write(dir.path(), "stale", &two, &t, Some(WGS84_PRJ), None);
    let mut bytes = std::fs::read(&shp).unwrap();
    let first_end = 100 + 8 + 2 * u32::from_be_bytes(bytes[104..108].try_into().unwrap()) as usize;
    bytes[24..28].copy_from_slice(&((first_end / 2) as u32).to_be_bytes());
    std::fs::write(&shp, &bytes).unwrap();
    let r = ingest(std::slice::from_ref(&shp), &IngestOptions::default()).unwrap();
    assert_eq!(ids(&r), ["a", "b"]);
    assert!(
        r.report.files[0]
            .notes
            .iter()
            .any(|n| n.contains("header gives")),
        "{:?}",
        r.report.files[0].notes
    );
    // Zero bytes of padding after the length the header gives are not records.
    let words = (bytes.len() / 2) as u32;
    bytes[24..28].copy_from_slice(&words.to_be_bytes());
    bytes.extend_from_slice(&[0; 64]);
    std::fs::write(&shp, &bytes).unwrap();
    assert_eq!(
        ids(&ingest(std::slice::from_ref(&shp), &IngestOptions::default()).unwrap()),
        ["a", "b"]
    );

    // GeoJSON's winding copied into a shapefile: the courtyard stays a courtyard.
    let mut t = Table::new(vec![Field::new("id", b'C', 8, 0)]);
    t.push([text("court")]);
    let inner: Vec<[f64; 2]> = square_at(10.0, 20.0)
        .into_iter()
        .map(|p| [p[0], p[1] + 10.0 / 111_000.0])
        .collect();
    let rings = vec![ccw(square_at(0.0, 40.0)), inner];
    let utf16: Vec<u8> = [0xFF, 0xFE]
        .into_iter()
        .chain(WGS84_PRJ.encode_utf16().flat_map(|u| u.to_le_bytes()))
        .collect();
    let shp = write(
        dir.path(),
        "geojsonwound",
        &[Shape::Polygon(rings)],
        &t,
        None,
        None,
    );
    std::fs::write(dir.path().join("geojsonwound.prj"), utf16).unwrap();
    let r = ingest(&[shp], &IngestOptions::default()).unwrap();
    assert_eq!(r.report.files[0].crs, "EPSG:4326");
    assert_eq!(r.buildings[0].footprint.0.len(), 1);
    assert_eq!(r.buildings[0].footprint.0[0].interiors().len(), 1);
    assert_eq!(r.report.rings_reoriented, 2);
}

/// Field names given more than once are all kept, the later ones renamed, in one note.
#[test]
fn repeated_field_names_are_renamed_in_one_note() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Table::new((0..300).map(|_| Field::new("A", b'N', 3, 0)).collect());
    t.push((0..300).map(num));
    let shp = write(
        dir.path(),
        "dup",
        &[Shape::Polygon(vec![square_at(0.0, 10.0)])],
        &t,
        Some(WGS84_PRJ),
        None,
    );
    let r = ingest(&[shp], &IngestOptions::default()).unwrap();
    let a = &r.buildings[0].attributes;
    assert_eq!(
        (a["A"].clone(), a["A_2"].clone(), a["A_300"].clone()),
        (AttrValue::Int(0), AttrValue::Int(1), AttrValue::Int(299))
    );
    let notes = &r.report.files[0].notes;
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].contains("A → A_2") && notes[0].contains("and 289 more"),
        "{notes:?}"
    );
}

/// `--id-attr` takes each building's id from a field (NYC's BIN here; whole numbers stored with decimals as their
/// digits); a record without a value keeps the default id, reported; a name no feature has is an error naming the
/// fields there are. The same for GeoJSON, on the bundled Lower East Side (its `osm_id`).
#[test]
fn ids_come_from_the_attribute_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Table::new(vec![
        Field::new("BIN", b'N', 12, 1),
        Field::new("name", b'C', 8, 0),
    ]);
    t.push([num("1001234.0"), text("a")]);
    t.push([text(""), text("b")]);
    t.push([num("1001236.0"), text("c")]);
    let shapes: Vec<Shape> = (0..3)
        .map(|k| Shape::Polygon(vec![square_at(20.0 * k as f64, 10.0)]))
        .collect();
    let shp = write(dir.path(), "bin", &shapes, &t, Some(WGS84_PRJ), None);
    let opts = |name: &str| IngestOptions {
        id_attr: Some(name.into()),
        ..Default::default()
    };
    let r = ingest(std::slice::from_ref(&shp), &opts("BIN")).unwrap();
    assert_eq!(ids(&r), ["1001234", "bin.shp#1", "1001236"]);
    assert_eq!(
        repairs(&r)
            .iter()
            .map(|(id, reason, _)| (id.as_str(), reason.as_str()))
            .collect::<Vec<_>>(),
        [("bin.shp#1", "id_attribute_missing")]
    );
    let e = ingest(std::slice::from_ref(&shp), &opts("BINN")).unwrap_err();
    assert!(
        e.to_string().contains("\"BINN\"") && e.to_string().contains("BIN, name"),
        "{e}"
    );
    // GeoJSON: the Lower East Side's OSM ids, without their type.
    let les =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/nyc-les/les_buildings.geojson");
    let by_default = ingest(std::slice::from_ref(&les), &IngestOptions::default()).unwrap();
    let by_osm_id = ingest(&[les], &opts("osm_id")).unwrap();
    assert_eq!(by_default.buildings.len(), by_osm_id.buildings.len());
    for (a, b) in by_default.buildings.iter().zip(&by_osm_id.buildings) {
        assert_eq!(a.source_id.split('/').nth(1), Some(b.source_id.as_str()));
    }
}

/// A MultiPatch box on the closed ring `r` from `z0` to `z1`, as ArcGIS writes one: the walls one triangle strip
/// around it, the roof a fan; with `floor`, the floor an outer ring.
fn patch_box(r: &[[f64; 2]], z0: f64, z1: f64, floor: bool) -> Vec<(i32, Vec<[f64; 3]>)> {
    let strip: Vec<[f64; 3]> = r
        .iter()
        .flat_map(|p| [[p[0], p[1], z0], [p[0], p[1], z1]])
        .collect();
    let roof: Vec<[f64; 3]> = r[..r.len() - 1].iter().map(|p| [p[0], p[1], z1]).collect();
    let mut parts = vec![(0, strip), (1, roof)];
    if floor {
        parts.push((2, r.iter().rev().map(|p| [p[0], p[1], z0]).collect()));
    }
    parts
}

#[test]
fn multipatch_records_stand_on_their_floors_or_under_their_roofs() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Table::new(vec![Field::new("id", b'C', 12, 0)]);
    for id in [
        "box",
        "floored",
        "courtyard",
        "triangles",
        "flat",
        "sloped",
        "basement",
    ] {
        t.push([text(id)]);
    }
    // A roof with a courtyard: a first ring and a ring after it, over walls (a strip) reaching 2 m.
    let outer = square_at(60.0, 20.0);
    let inner: Vec<[f64; 2]> = square_at(66.0, 8.0)
        .iter()
        .map(|p| [p[0], p[1] + 6.0 / 111_000.0])
        .collect();
    let mut courtyard = patch_box(&outer, 2.0, 14.0, false);
    courtyard.truncate(1);
    courtyard.push((4, outer.iter().map(|p| [p[0], p[1], 14.0]).collect()));
    courtyard.push((5, inner.iter().rev().map(|p| [p[0], p[1], 14.0]).collect()));
    // The same box as separate triangles (part type 6): its roof's two only, over nothing.
    let s = square_at(100.0, 10.0);
    let tri = vec![(
        6,
        [s[0], s[1], s[2], s[0], s[2], s[3]]
            .iter()
            .map(|p| [p[0], p[1], 5.0])
            .collect(),
    )];
    // A strip folded onto itself: no triangle has area.
    let flat = vec![(
        0,
        vec![
            [s[0][0], s[0][1], 0.0],
            [s[1][0], s[1][1], 0.0],
            [s[0][0], s[0][1], 0.0],
        ],
    )];
    // A box whose floor is two triangles following the terrain 10 cm down across it.
    let q = square_at(140.0, 10.0);
    let mut sloped = patch_box(&q, 0.0, 9.0, false);
    let z = |p: [f64; 2]| if p[0] > q[0][0] { -0.1 } else { 0.0 };
    let fl = |i: usize| [q[i][0], q[i][1], z(q[i])];
    sloped.push((6, vec![fl(0), fl(2), fl(1), fl(0), fl(3), fl(2)]));
    // A 10 m box from 0 to 10 m over a 3 m cellar of 3 × 3 m (its floor at −3 m): it stands on the cellar's floor
    // and its footprint is the whole box's, not the cellar's.
    let mut basement = patch_box(&square_at(160.0, 10.0), 0.0, 10.0, true);
    basement.extend(patch_box(&square_at(163.0, 3.0), -3.0, 0.0, true));
    let shapes = vec![
        Shape::MultiPatch(patch_box(&square_at(0.0, 10.0), 0.0, 9.0, false)),
        Shape::MultiPatch(patch_box(&square_at(20.0, 10.0), 1.0, 9.0, true)),
        Shape::MultiPatch(courtyard),
        Shape::MultiPatch(tri),
        Shape::MultiPatch(flat),
        Shape::MultiPatch(sloped),
        Shape::MultiPatch(basement),
    ];
    let shp = write(dir.path(), "patches", &shapes, &t, Some(WGS84_PRJ), None);
    let r = ingest(std::slice::from_ref(&shp), &IngestOptions::default()).unwrap();
    assert_eq!(
        ids(&r),
        [
            "box",
            "floored",
            "courtyard",
            "triangles",
            "sloped",
            "basement"
        ]
    );
    assert_eq!(
        r.report
            .skipped
            .iter()
            .map(|s| (s.feature_id.as_str(), s.reason.as_str(), s.detail.as_str()))
            .collect::<Vec<_>>(),
        [(
            "flat",
            "empty_geometry",
            "record 5 (FID 4): MultiPatch whose parts have no area"
        )]
    );
    let b = |id: &str| r.buildings.iter().find(|b| b.source_id == id).unwrap();
    let area = |id: &str| b(id).area_m2();
    assert!((area("box") - 100.0).abs() < 1.0, "{}", area("box"));
    assert!((area("floored") - 100.0).abs() < 1.0, "{}", area("floored"));
    assert!(
        (area("courtyard") - 336.0).abs() < 2.0,
        "{}",
        area("courtyard")
    );
    assert_eq!(b("courtyard").footprint.0[0].interiors().len(), 1);
    assert!(
        (area("triangles") - 100.0).abs() < 1.0,
        "{}",
        area("triangles")
    );
    assert!((area("sloped") - 100.0).abs() < 1.0, "{}", area("sloped"));
    assert!(
        (area("basement") - 100.0).abs() < 1.0,
        "{}",
        area("basement")
    );
    assert!(
        (b("sloped").height_m - 9.1).abs() < 1e-9,
        "{}",
        b("sloped").height_m
    );
    assert!(
        (b("basement").height_m - 13.0).abs() < 1e-9,
        "{}",
        b("basement").height_m
    );
    // Outlines run counter-clockwise already (floors facing down are no misoriented rings).
    assert_eq!(r.report.rings_reoriented, 0);
    let heights: Vec<f64> = ["box", "floored", "courtyard", "triangles"]
        .iter()
        .map(|i| b(i).height_m)
        .collect();
    // The triangles alone are a flat roof at 5 m: no height from the geometry, the default.
    assert_eq!(heights, [9.0, 8.0, 12.0, 10.0]);
    assert_eq!(r.report.height_sources.get("geometry").copied(), Some(5));

    // With --lod the patches are the buildings' models.
    let r = ingest(
        &[shp],
        &IngestOptions {
            lod: Some(citylod_ingest::LodChoice::Highest),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(
        r.report.mesh_lods.get("MultiPatch").copied(),
        Some(5),
        "{:?}",
        r.report.mesh_lods
    );
    // The flat roof plate is no model: said.
    let flat: Vec<_> = r
        .report
        .mesh_issues
        .iter()
        .map(|m| (m.feature_id.as_str(), m.reason.as_str()))
        .collect();
    assert_eq!(flat, [("triangles", "model_invalid")]);
    use citylod_model::SurfaceKind::{Ground, Roof, Wall};
    let kinds = |id: &str| {
        let m = r
            .buildings
            .iter()
            .find(|b| b.source_id == id)
            .unwrap()
            .mesh
            .as_ref()
            .unwrap();
        [Ground, Wall, Roof].map(|k| m.surfaces.iter().filter(|s| **s == k).count())
    };
    assert_eq!(kinds("box"), [0, 8, 2]);
    assert_eq!(kinds("floored"), [2, 8, 2]);
}

#[test]
fn a_multipatch_shapefile_written_by_gdal_gives_the_models_of_its_cityjson() {
    let shp = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/multipatch/delft_multipatch.shp");
    let opts = IngestOptions {
        lod: Some(citylod_ingest::LodChoice::Exact("2.2".into())),
        id_attr: Some("identifica".into()),
        ..Default::default()
    };
    let r = ingest(std::slice::from_ref(&shp), &opts).unwrap();
    assert_eq!(r.buildings.len(), 12);
    assert_eq!(r.report.files[0].crs, "EPSG:28992");
    assert_eq!(r.report.buildings_with_mesh, 12);
    // Heights from the faces: from the lowest vertex to the highest (sheds of under 3 m to houses of 40).
    assert_eq!(r.report.height_sources.get("geometry").copied(), Some(12));
    for b in &r.buildings {
        assert!(
            (2.0..40.0).contains(&b.height_m),
            "{}: {}",
            b.source_id,
            b.height_m
        );
        assert!(b.source_id.starts_with("NL.IMBAG.Pand."), "{}", b.source_id);
    }
    // Against the CityJSON the faces came from: the same triangles and, from the floors, the LoD0 outline's area.
    let Some(jsonl) = citylod_testdata::shared_data("delft-3dbag/delft.city.jsonl") else {
        return;
    };
    let city = ingest(
        &[jsonl],
        &IngestOptions {
            id_attr: None,
            ..opts
        },
    )
    .unwrap();
    for b in &r.buildings {
        let c = city
            .buildings
            .iter()
            .find(|c| c.source_id == b.source_id)
            .unwrap();
        let tris =
            |x: &citylod_model::Building| x.mesh.as_ref().unwrap().mesh.triangles.len() as i64;
        assert!(
            (tris(b) - tris(c)).abs() <= 2,
            "{}: {} / {}",
            b.source_id,
            tris(b),
            tris(c)
        );
        let (ab, ac) = (b.area_m2(), c.area_m2());
        assert!(
            (ab - ac).abs() <= 0.05 * ac,
            "{}: {ab} / {ac} m²",
            b.source_id
        );
        // The model's top is the building's: its highest vertex stands at the height the footprint prism reaches.
        let top = b
            .mesh
            .as_ref()
            .unwrap()
            .mesh
            .positions
            .iter()
            .map(|p| p[2])
            .fold(f64::MIN, f64::max);
        assert!(
            (top - (b.base_z_m + b.height_m)).abs() < 0.01,
            "{}: {top}",
            b.source_id
        );
    }
}

#[test]
fn a_vertcs_in_the_prj_gives_the_unit_of_z() {
    // The Long Island State Plane in feet, as ArcGIS writes it, with a vertical CRS in metres after it: a box 30 units
    // high is 30 m high; without the VERTCS its z would be feet, as the CRS's linear unit.
    let esri_2263 = r#"PROJCS["NAD_1983_StatePlane_New_York_Long_Island_FIPS_3104_Feet",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],PARAMETER["False_Easting",984250.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-74.0],PARAMETER["Standard_Parallel_1",40.66666666666666],PARAMETER["Standard_Parallel_2",41.03333333333333],PARAMETER["Latitude_Of_Origin",40.16666666666666],UNIT["Foot_US",0.3048006096012192]]"#;
    let vertcs = r#",VERTCS["NAVD_1988",VDATUM["North_American_Vertical_Datum_1988"],PARAMETER["Vertical_Shift",0.0],PARAMETER["Direction",1.0],UNIT["Meter",1.0]]"#;
    let (x0, y0) = (987_000.0, 201_000.0);
    let ring = vec![
        [x0, y0],
        [x0, y0 + 100.0],
        [x0 + 100.0, y0 + 100.0],
        [x0 + 100.0, y0],
        [x0, y0],
    ];
    let mut t = Table::new(vec![Field::new("id", b'C', 8, 0)]);
    t.push([text("tower")]);
    let shapes = vec![Shape::MultiPatch(patch_box(&ring, 0.0, 30.0, true))];
    let dir = tempfile::tempdir().unwrap();
    // A vertical unit no length has (a damaged .prj: 10,000 km) is said and z read as without a VERTCS.
    let far = vertcs.replace("UNIT[\"Meter\",1.0]", "UNIT[\"Far\",1e7]");
    for (name, prj, want) in [
        ("metres", format!("{esri_2263}{vertcs}"), 30.0),
        ("feet", esri_2263.to_string(), 30.0 * 0.3048006096012192),
        (
            "far",
            format!("{esri_2263}{far}"),
            30.0 * 0.3048006096012192,
        ),
    ] {
        let shp = write(dir.path(), name, &shapes, &t, Some(&prj), None);
        let r = ingest(&[shp], &IngestOptions::default()).unwrap();
        assert_eq!(r.report.files[0].crs, "EPSG:2263", "{name}");
        assert!(
            (r.buildings[0].height_m - want).abs() < 1e-9,
            "{name}: {}",
            r.buildings[0].height_m
        );
        let said = r.report.files[0].notes.iter().any(|n| {
            n.contains("its vertical CRS gives 10000000 m per unit of z, which is no length unit")
        });
        assert_eq!(said, name == "far", "{name}: {:?}", r.report.files[0].notes);
    }
}
