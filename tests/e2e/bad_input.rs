//! Broken inputs give a documented error (exit 2) or a recorded skip or repair, never a panic, and a failed
//! build never touches an existing output folder.

use crate::common::*;
// Seeded, so a failure names a case that reproduces.
use citylod_testdata::SplitMix64 as Rng;
use serde_json::{json, Value};
use std::path::Path;

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn stderr_of(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn assert_no_panic(o: &std::process::Output) {
    let e = stderr_of(o);
    assert!(
        !e.contains("panicked") && o.status.code() != Some(101),
        "citylod panicked:\n{e}"
    );
}

fn square(lon: f64, lat: f64, d: f64) -> Value {
    json!([[
        [lon, lat],
        [lon + d, lat],
        [lon + d, lat + d],
        [lon, lat + d],
        [lon, lat]
    ]])
}

fn feature(id: &str, props: Value, geometry: Value) -> Value {
    json!({"type": "Feature", "id": id, "properties": props, "geometry": geometry})
}

/// A traced outline of 3,000 points (a wavy circle about 60 m across) around (lon, lat) with two neighbouring
/// points swapped: one small bow tie in a large footprint.
fn traced_twist(lon: f64, lat: f64) -> Value {
    let n = 3_000;
    let mut ring: Vec<Value> = (0..n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            let r = 0.0003 * (1.0 + 0.03 * (25.0 * a).sin());
            json!([lon + r * a.cos(), lat + r * a.sin()])
        })
        .collect();
    ring.swap(1_000, 1_001);
    ring.push(ring[0].clone());
    Value::Array(ring)
}

/// A ring of 400 points whose every other point lies across the centre: it crosses itself ~40,000 times.
fn scribble(lon: f64, lat: f64) -> Value {
    let n = 400;
    let mut ring: Vec<Value> = (0..n)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU * 0.37;
            let r = if i % 2 == 0 { 0.0003 } else { 0.0001 };
            json!([lon + r * a.cos(), lat + r * a.sin()])
        })
        .collect();
    ring.push(ring[0].clone());
    Value::Array(ring)
}

#[test]
fn broken_features_are_skipped_or_repaired_with_reasons() {
    let d = scratch_dir("broken-features");
    let (lon, lat) = (-73.99, 40.72);
    let fc = json!({"type": "FeatureCollection", "features": [
        feature("good", json!({"height": "28 m"}), json!({"type": "Polygon", "coordinates": square(lon, lat, 0.0002)})),
        feature("no-height", json!({"name": "x"}), json!({"type": "Polygon", "coordinates": square(lon + 0.001, lat, 0.0002)})),
        feature("two-points", json!({}), json!({"type": "Polygon", "coordinates": [[[lon, lat], [lon + 0.0001, lat], [lon, lat]]]})),
        feature("bowtie", json!({"height": 12}), json!({"type": "Polygon", "coordinates": [[
            [lon + 0.002, lat], [lon + 0.0022, lat + 0.0002], [lon + 0.0022, lat], [lon + 0.002, lat + 0.0002], [lon + 0.002, lat]]]})),
        feature("far-away", json!({}), json!({"type": "Polygon", "coordinates": square(400.0, lat, 0.0002)})),
        feature("flat", json!({}), json!({"type": "Polygon", "coordinates": [[[lon, lat], [lon + 0.0001, lat], [lon + 0.0002, lat], [lon, lat]]]})),
        feature("a-point", json!({}), json!({"type": "Point", "coordinates": [lon, lat]})),
        feature("no-geometry", json!({}), Value::Null),
        feature("unclosed", json!({"building:height": "9"}), json!({"type": "Polygon", "coordinates": [[
            [lon + 0.003, lat], [lon + 0.0032, lat], [lon + 0.0032, lat + 0.0002], [lon + 0.003, lat + 0.0002]]]})),
        feature("traced-twist", json!({"height": 30}), json!({"type": "Polygon", "coordinates": [traced_twist(lon + 0.005, lat)]})),
        feature("scribble", json!({"height": 30}), json!({"type": "Polygon", "coordinates": [scribble(lon + 0.008, lat)]})),
    ]});
    let input = write(&d, "broken.geojson", &fc.to_string());
    let report = build(&[&input], &d.join("out"), &[]);
    let c = &report["counts"];
    assert_eq!(c["features_read"], 11);
    assert_eq!(
        c["buildings_written"], 5,
        "good, no-height, bowtie, unclosed and traced-twist are written: {report:#}"
    );
    let reason_of = |list: &str, id: &str| -> Vec<String> {
        report["ingest"][list]
            .as_array()
            .unwrap()
            .iter()
            .filter(|i| i["feature_id"] == id)
            .map(|i| i["reason"].as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(reason_of("skipped", "two-points"), ["too_few_points"]);
    assert_eq!(
        reason_of("skipped", "far-away"),
        ["coordinate_out_of_range"]
    );
    assert_eq!(reason_of("skipped", "flat"), ["zero_area"]);
    assert_eq!(reason_of("skipped", "a-point"), ["unsupported_geometry"]);
    assert_eq!(reason_of("skipped", "no-geometry"), ["no_geometry"]);
    assert!(
        !reason_of("repaired", "bowtie").is_empty(),
        "the bowtie is repaired and reported"
    );
    assert!(
        !reason_of("repaired", "unclosed").is_empty(),
        "the unclosed ring is closed and reported"
    );
    // A large outline with one crossing is rebuilt, not skipped; a ring crossing itself thousands of times is.
    assert_eq!(reason_of("repaired", "traced-twist"), ["self_intersection"]);
    assert_eq!(reason_of("skipped", "scribble"), ["repair_failed"]);
    let hs = &report["ingest"]["height_sources"];
    assert_eq!(
        hs["default"], 1,
        "the building without height falls back to the default: {hs}"
    );
    assert_eq!(
        hs["known_attribute"], 4,
        "'28 m', 12, '9' and 30 are read from attributes: {hs}"
    );
}

#[test]
fn unreadable_inputs_exit_2_with_a_clear_message() {
    let d = scratch_dir("unreadable");
    let good = repo_root().join("examples/nyc-les/les_buildings.geojson");
    let roads = repo_root().join("examples/nyc-les/les_roads.geojson");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec![write(&d, "truncated.geojson", r#"{"type":"FeatureCollection","features":[{"type":"Fea"#).display().to_string()], "truncated.geojson"),
        (vec![write(&d, "nan.geojson", r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[[NaN,1],[2,2],[3,1],[NaN,1]]]}}]}"#).display().to_string()], "nan.geojson"),
        (vec![d.join("does-not-exist.geojson").display().to_string()], "does-not-exist.geojson"),
        (vec![good.display().to_string(), "--crs".into(), "EPSG:999999".into()], "EPSG:999999"),
        (vec![write(&d, "empty.geojson", r#"{"type":"FeatureCollection","features":[]}"#).display().to_string()], "no building"),
        // Every feature skipped: the message lists them, since no report is written.
        (vec![write(&d, "all-skipped.geojson", r#"{"type":"FeatureCollection","features":[{"type":"Feature","id":"b1","properties":{},"geometry":null}]}"#).display().to_string()], "b1 in "),
        (vec![good.display().to_string(), "--storey-height=-1".into()], "--storey-height"),
        (vec![good.display().to_string(), "--default-height=1e-300".into()], "--default-height"),
        (vec![good.display().to_string(), "--collinear-angle=NaN".into()], "--collinear-angle"),
        (vec![good.display().to_string(), "--collinear-angle=360".into()], "--collinear-angle"),
        (vec![good.display().to_string(), "--streets".into(), write(&d, "streets.geojson", r#"{"type":"FeatureCollection","features":["#).display().to_string()], "streets.geojson"),
        (vec![good.display().to_string(), "--streets".into(), d.join("no-streets.geojson").display().to_string()], "no-streets.geojson"),
        (vec![good.display().to_string(), "--streets".into(), good.display().to_string(), "--leaves-only".into()], "--leaves-only"),
        (vec![good.display().to_string(), "--streets".into(), good.display().to_string(), "--street-penalty=-5".into()], "--street-penalty must be"),
        // Options of a feature not asked for are refused, not silently ignored.
        (vec![good.display().to_string(), "--street-penalty=50".into()], "--streets <FILE>"),
        (vec![good.display().to_string(), "--building-rate=0.5".into()], "--lod <LOD>"),
        (vec![good.display().to_string(), "--leaves-only".into(), "--level-ratio=0.5".into()], "cannot be used with"),
        (vec![good.display().to_string(), "--height-offset=NaN".into()], "--height-offset"),
        // A misspelt attribute name would give every building the next rule's height.
        (vec![good.display().to_string(), "--storey-attr".into(), "storys".into()], "--storey-attr storys: no building has this attribute"),
        (vec![good.display().to_string(), "--height-attr".into(), "hieght".into()], "--height-attr hieght: no building has this attribute"),
        // Streets read in the wrong CRS land nowhere near the buildings and would bar nothing.
        (vec![good.display().to_string(), "--streets".into(), roads.display().to_string(), "--streets-crs".into(), "EPSG:28992".into()], "street segments comes within 1000 m"),
        // A streets file with nothing usable says so, not that its lines lie far away.
        (vec![good.display().to_string(), "--streets".into(), write(&d, "points.geojson", r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[-73.99,40.72]}}]}"#).display().to_string()], "holds no usable street line"),
        (vec![good.display().to_string(), "--streets-crs".into(), "EPSG:28992".into()], "--streets-crs"),
        (vec![good.display().to_string(), "--streets-layer".into(), "roads".into()], "--streets-layer is a layer of --streets"),
        (vec![good.display().to_string(), "--streets".into(), roads.display().to_string(), "--streets-layer".into(), "roads".into()], "has no layers"),
        (vec![good.display().to_string(), "--dh-px=1e308".into()], "got 1e308"),
        (vec![good.display().to_string(), "--storey-height=1e308".into()], "--storey-height must be a number of metres from 0.1 to 1000, got 1e308"),
        (vec![good.display().to_string(), "--height-offset=-5000".into()], "--height-offset"),
        // A negative number given as the next argument is the flag's value, refused by its range (clap took it
        // for a flag and suggested `-- -1`, which failed too).
        (vec![good.display().to_string(), "--storey-height".into(), "-1".into()], "--storey-height must be a number of metres from 0.1 to 1000, got -1"),
        (vec![good.display().to_string(), "--dh-px".into(), "-2".into()], "--dh-px must be a positive number"),
        (vec![good.display().to_string(), "--level-ratio".into(), "-0.5".into()], "--level-ratio must be in (0, 1], got -0.5"),
        (vec![good.display().to_string(), "--tile-max-features".into(), "-5".into()], "'-5' for '--tile-max-features"),
        // Coordinates read in the wrong CRS: every footprint lost the same way, and the message says what to try.
        (vec![good.display().to_string(), "--crs".into(), "EPSG:2263".into()], "are the coordinates longitude/latitude degrees? then leave --crs out"),
        // A CityJSON holding terrain and no building says what it did hold.
        (vec![write(&d, "terrain.city.json", r#"{"type":"CityJSON","version":"2.0","transform":{"scale":[1,1,1],"translate":[0,0,0]},"metadata":{"referenceSystem":"https://www.opengis.net/def/crs/EPSG/0/28992"},"CityObjects":{"t":{"type":"TINRelief","geometry":[]}},"vertices":[]}"#).display().to_string()], "holds 1 city object(s) that are not buildings"),
        (vec![write(&d, "projected.geojson", r#"{"type":"FeatureCollection","features":[{"type":"Feature","id":"p1","properties":{},"geometry":{"type":"Polygon","coordinates":[[[85000,446000],[85010,446000],[85010,446010],[85000,446000]]]}}]}"#).display().to_string()], "give it with --crs"),
    ];
    for (inputs, expect) in cases {
        let out = d.join("out");
        let mut args = vec!["build".to_string()];
        args.extend(inputs);
        args.extend(["--out".into(), out.display().to_string()]);
        let o = citylod(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert_no_panic(&o);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{args:?} should exit 2; stderr:\n{}",
            stderr_of(&o)
        );
        assert!(
            stderr_of(&o).contains(expect),
            "stderr should mention {expect}:\n{}",
            stderr_of(&o)
        );
        assert!(
            !out.exists(),
            "a failed build must not leave {}",
            out.display()
        );
    }
    let o = citylod(&["build"]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "missing arguments are a usage error"
    );
}

/// A shapefile builds like any input: footprints and heights from its .dbf, the CRS from its .prj (here an OGC WKT
/// naming EPSG:26986, Massachusetts State Plane in metres), and the report names the format; a record the .dbf marks
/// deleted is listed as skipped, and the table's code page, named by nothing, is said in the report.
#[test]
fn a_shapefile_builds_with_its_prj_and_dbf() {
    use citylod_testdata::shapefile::{num, write, Field, Shape, Table};
    let d = scratch_dir("shapefile");
    let mut table = Table::new(vec![
        Field::new("name", b'C', 20, 0),
        Field::new("HEIGHT", b'N', 10, 1),
    ]);
    // Four 20 m squares 30 m apart near Boston's State House, clockwise as shapefiles have them; the third deleted.
    let mut shapes = Vec::new();
    for k in 0..4 {
        let (x, y) = (236_000.0 + 30.0 * k as f64, 900_000.0);
        shapes.push(Shape::Polygon(vec![vec![
            [x, y],
            [x, y + 20.0],
            [x + 20.0, y + 20.0],
            [x + 20.0, y],
            [x, y],
        ]]));
        // "Café k" in Windows-1252.
        let name = [&b"Caf\xe9 "[..], k.to_string().as_bytes()].concat();
        let cells = [name, num(format!("{:.1}", 12.5 + k as f64))];
        if k == 2 {
            table.push_deleted(cells);
        } else {
            table.push(cells);
        }
    }
    let prj = r#"PROJCS["NAD83 / Massachusetts Mainland",GEOGCS["NAD83",DATUM["North_American_Datum_1983",SPHEROID["GRS 1980",6378137,298.257222101]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic_2SP"],UNIT["metre",1],AUTHORITY["EPSG","26986"]]"#;
    let shp = write(&d, "blocks", &shapes, &table, Some(prj), None);
    let out = d.join("tiles");
    let report = build(&[&shp], &out, &["--height-attr", "HEIGHT"]);
    let errors = schema_errors("build-report.schema.json", &report);
    assert!(errors.is_empty(), "{}", errors.join("\n"));
    let file = &report["ingest"]["files"][0];
    assert_eq!(
        (file["format"].as_str(), file["crs"].as_str()),
        (Some("shapefile"), Some("EPSG:26986"))
    );
    assert!(
        file["notes"][0].as_str().unwrap().contains("Windows-1252"),
        "{file}"
    );
    assert_eq!(report["counts"]["buildings_written"], 3);
    assert_eq!(report["ingest"]["height_sources"]["named_attribute"], 3);
    assert_eq!(report["ingest"]["skipped_by_reason"]["deleted_record"], 1);
    // Outer rings run clockwise in a shapefile: that is its rule, not a ring to repair.
    assert_eq!(report["ingest"]["rings_reoriented"], 0);
    // The frame's origin is the squares' centre, in Boston (EPSG:26986 read, not taken as lon/lat).
    let (lon, lat) = (
        report["frame"]["origin_lon_deg"].as_f64().unwrap(),
        report["frame"]["origin_lat_deg"].as_f64().unwrap(),
    );
    assert!(
        (lon + 71.06).abs() < 0.05 && (lat - 42.36).abs() < 0.05,
        "{lon}, {lat}"
    );
    // Ids from a field: a misspelt name is a usage error naming the fields there are.
    let o = citylod(&[
        "build",
        shp.to_str().unwrap(),
        "--out",
        d.join("tiles2").to_str().unwrap(),
        "--id-attr",
        "NAME",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("\"NAME\"") && err.contains("HEIGHT, name"),
        "{err}"
    );
}

#[test]
fn a_geopackage_builds_from_the_layer_named() {
    // GDAL's GeoPackage of 203 Lower East Side buildings in EPSG:2263, beside 20 roads in a second layer.
    let gpkg = repo_root().join("crates/citylod-ingest/tests/geopackage/les_gdal.gpkg");
    let d = scratch_dir("geopackage");
    let o = citylod(&[
        "build",
        gpkg.to_str().unwrap(),
        "--out",
        d.join("refused").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--layer") && err.contains("buildings (MULTIPOLYGON), roads (LINESTRING)"),
        "{err}"
    );
    assert!(!d.join("refused").exists());
    let out = d.join("tiles");
    let report = build(&[&gpkg], &out, &["--layer", "buildings"]);
    let errors = schema_errors("build-report.schema.json", &report);
    assert!(errors.is_empty(), "{}", errors.join("\n"));
    let file = &report["ingest"]["files"][0];
    assert_eq!(
        (
            file["format"].as_str(),
            file["crs"].as_str(),
            file["features_read"].as_u64()
        ),
        (Some("geo_package"), Some("EPSG:2263"), Some(203))
    );
    assert_eq!(
        file["notes"][0].as_str(),
        Some("layer \"buildings\" read, of 2 feature tables (buildings, roads)")
    );
    let written = report["counts"]["buildings_written"].as_u64().unwrap();
    let skipped = report["counts"]["skipped"].as_u64().unwrap();
    assert!(written > 190, "{written}");
    assert_eq!(written + skipped, 203);
    // In Manhattan: the feet of EPSG:2263 read as such.
    let (lon, lat) = (
        report["frame"]["origin_lon_deg"].as_f64().unwrap(),
        report["frame"]["origin_lat_deg"].as_f64().unwrap(),
    );
    assert!(
        (lon + 73.99).abs() < 0.02 && (lat - 40.72).abs() < 0.02,
        "{lon}, {lat}"
    );
}

#[test]
fn a_geopackage_in_wal_mode_in_a_read_only_folder_is_read() {
    // QGIS leaves the GeoPackages it edits in WAL mode; SQLite then needs to create a -shm file beside one, which a
    // user who may not write to the folder cannot: citylod reads it as immutable, as GDAL does, and says so. Run as
    // an unprivileged user (root writes anywhere), which needs root and setpriv; CI runs as root.
    use std::os::unix::fs::PermissionsExt;
    let root =
        std::fs::metadata("/proc/self").map(|m| std::os::unix::fs::MetadataExt::uid(&m) == 0);
    let setpriv = std::path::Path::new("/usr/bin/setpriv");
    if !matches!(root, Ok(true)) || !setpriv.exists() {
        eprintln!("SKIP: needs root and /usr/bin/setpriv to run citylod as another user");
        return;
    }
    // Everything in a folder under the system's temp folder, the binary copied there: the other user may not reach
    // this clone's folders.
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path().to_path_buf();
    let bin = d.join("citylod");
    std::fs::copy(env!("CARGO_BIN_EXE_citylod"), &bin).unwrap();
    let data = d.join("data");
    std::fs::create_dir_all(&data).unwrap();
    let gpkg = data.join("edited.gpkg");
    std::fs::copy(
        repo_root().join("crates/citylod-ingest/tests/geopackage/les_gdal.gpkg"),
        &gpkg,
    )
    .unwrap();
    let db = rusqlite::Connection::open(&gpkg).unwrap();
    let mode: String = db
        .query_row("PRAGMA journal_mode = WAL", [], |r| r.get(0))
        .unwrap();
    assert_eq!(mode, "wal");
    drop(db);
    for p in [&data, &gpkg] {
        let mode = if p.is_dir() { 0o555 } else { 0o444 };
        std::fs::set_permissions(p, std::fs::Permissions::from_mode(mode)).unwrap();
    }
    std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o777)).unwrap();
    std::fs::set_permissions(&bin, std::fs::Permissions::from_mode(0o755)).unwrap();
    let out = d.join("tiles");
    let o = std::process::Command::new(setpriv)
        .args(["--reuid=65534", "--regid=65534", "--clear-groups"])
        .arg(env!("CARGO_BIN_EXE_citylod"))
        .args([
            "build",
            gpkg.to_str().unwrap(),
            "--layer",
            "buildings",
            "--out",
            out.to_str().unwrap(),
            "-q",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = read_json(&out.join("build-report.json"));
    assert!(report["counts"]["buildings_written"].as_u64().unwrap() > 190);
    let notes = report["ingest"]["files"][0]["notes"].to_string();
    assert!(notes.contains("read as an immutable file"), "{notes}");
}

#[test]
fn failed_build_leaves_existing_output_untouched() {
    let d = scratch_dir("atomic");
    let out = d.join("tiles");
    build(
        &[&repo_root().join("examples/nyc-les/les_buildings.geojson")],
        &out,
        &[],
    );
    let before = tree_bytes(&out);
    let bad = write(&d, "bad.geojson", "{ not json");
    let o = citylod(&[
        "build",
        bad.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        before == tree_bytes(&out),
        "the previous tileset must survive a failed build"
    );
    let leftovers: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("tmp"))
        .collect();
    assert!(
        leftovers.is_empty(),
        "temporary folders left behind: {leftovers:?}"
    );
}

#[test]
fn output_paths_that_are_not_tilesets_are_refused() {
    let d = scratch_dir("refused-out");
    let user = d.join("user");
    std::fs::create_dir_all(&user).unwrap();
    let input = user.join("in.geojson");
    std::fs::copy(
        repo_root().join("examples/nyc-les/les_buildings.geojson"),
        &input,
    )
    .unwrap();
    std::fs::write(user.join("notes.txt"), "keep me").unwrap();
    let other = d.join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("a.txt"), "mine").unwrap();
    // An input named as a level dump's file, in the folder the levels are dumped to (dump, edit in QGIS, rebuild).
    let dumps = d.join("dumps");
    std::fs::create_dir_all(&dumps).unwrap();
    let level0 = dumps.join("level-0.geojson");
    std::fs::copy(&input, &level0).unwrap();
    let before = tree_bytes(&d);
    let (i, u, o) = (
        input.to_str().unwrap(),
        user.to_str().unwrap(),
        other.to_str().unwrap(),
    );
    let notes = user.join("notes.txt");
    let (new_out, new_levels) = (d.join("new"), d.join("new/levels"));
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec![i, "--out", u], "is inside the output folder"),
        (vec![i, "--out", i], "is a file"),
        (vec![i, "--out", notes.to_str().unwrap()], "is a file"),
        (vec![i, "--out", o], "--force"),
        (
            vec![
                i,
                "--out",
                new_out.to_str().unwrap(),
                "--dump-levels",
                new_levels.to_str().unwrap(),
            ],
            "--dump-levels",
        ),
        (
            vec![
                level0.to_str().unwrap(),
                "--out",
                new_out.to_str().unwrap(),
                "--dump-levels",
                dumps.to_str().unwrap(),
            ],
            "would be overwritten by --dump-levels",
        ),
        (
            vec![
                i,
                "--out",
                new_out.to_str().unwrap(),
                "--leaves-only",
                "--dump-levels",
                new_levels.to_str().unwrap(),
            ],
            "--dump-levels draws the generalization, which --leaves-only leaves out",
        ),
        // Out of range, named by the flag, the number as a user reads it, before any input is read.
        (
            vec![
                i,
                "--out",
                new_out.to_str().unwrap(),
                "--lambda-adjacent",
                "1e300",
            ],
            "--lambda-adjacent must be in [0, 1], got 1e300",
        ),
        (
            vec![
                i,
                "--out",
                new_out.to_str().unwrap(),
                "--landmark-max-share",
                "1",
            ],
            "--landmark-max-share must be in [0, 1), got 1",
        ),
    ];
    for (args, expect) in cases {
        let mut all = vec!["build"];
        all.extend(&args);
        let out = citylod(&all);
        assert_no_panic(&out);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{args:?} should be refused:\n{}",
            stderr_of(&out)
        );
        assert!(
            stderr_of(&out).contains(expect),
            "{args:?}: stderr should mention {expect}:\n{}",
            stderr_of(&out)
        );
        assert!(
            before == tree_bytes(&d),
            "{args:?} changed files it must not touch"
        );
    }
    // With --force the non-tileset folder is replaced; from then on it holds a tileset and is replaced freely.
    let forced = citylod(&["build", i, "--out", o, "--force"]);
    assert_eq!(forced.status.code(), Some(0), "{}", stderr_of(&forced));
    assert!(other.join("tileset.json").is_file() && !other.join("a.txt").exists());
    let again = citylod(&["build", i, "--out", o]);
    assert_eq!(again.status.code(), Some(0), "{}", stderr_of(&again));
    assert_eq!(std::fs::read_to_string(&notes).unwrap(), "keep me");
    // Paths with `..` are taken as they lead: out of the output folder is not inside it, and back into it is.
    let via_out = other.join("../user/in.geojson");
    let ok = citylod(&["build", via_out.to_str().unwrap(), "--out", o]);
    assert_eq!(ok.status.code(), Some(0), "{}", stderr_of(&ok));
    let back_in = user.join("../user/in.geojson");
    let refused = citylod(&["build", back_in.to_str().unwrap(), "--out", u]);
    assert_eq!(refused.status.code(), Some(2), "{}", stderr_of(&refused));
    assert!(stderr_of(&refused).contains("is inside the output folder"));
    assert_eq!(std::fs::read_to_string(&notes).unwrap(), "keep me");
    // Run from inside a tileset folder, `--out .` (or the folder above) would leave the shell in a deleted folder.
    std::fs::create_dir_all(other.join("tiles/sub")).unwrap();
    for (cwd, out) in [(other.clone(), "."), (other.join("tiles/sub"), "../..")] {
        let here = std::process::Command::new(env!("CARGO_BIN_EXE_citylod"))
            .args(["build", i, "--out", out])
            .current_dir(&cwd)
            .output()
            .unwrap();
        assert_eq!(here.status.code(), Some(2), "{}", stderr_of(&here));
        assert!(
            stderr_of(&here).contains("is the folder you are in"),
            "{}",
            stderr_of(&here)
        );
    }
    assert!(other.join("tileset.json").is_file());
    // From inside it, `tileset.json` alone names it (its parent is "", the current folder).
    let inspect = std::process::Command::new(env!("CARGO_BIN_EXE_citylod"))
        .args(["inspect", "tileset.json"])
        .current_dir(&other)
        .output()
        .unwrap();
    assert!(inspect.status.success(), "{}", stderr_of(&inspect));
}

/// The names in `dir`, sorted.
fn names_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A pid no process has (above the kernel's largest, 2^22 - 1): that of a build that was killed. (Whether a build
/// still runs is told by the lock on its staging folder's marker, which the system releases when it dies.)
const KILLED_PID: u32 = 4194303;

/// A staging folder as a killed build leaves it: citylod's marker (unlocked) in a folder named for `pid`.
fn killed_staging(folder: &Path) {
    std::fs::create_dir_all(folder).unwrap();
    std::fs::write(folder.join(".citylod-staging"), "citylod staging folder").unwrap();
}

/// Only a folder citylod wrote is replaced without --force: a `tileset.json` that is not citylod's (not JSON,
/// another generator's) and anything beside citylod's own entries (a page, assets, a file in tiles/) are refused,
/// named, and left as they were.
#[test]
fn only_what_citylod_wrote_is_replaced_without_force() {
    let d = scratch_dir("foreign-out");
    let input = repo_root().join("examples/nyc-les/les_buildings.geojson");
    let i = input.to_str().unwrap();
    // A project folder with a file that happens to be called tileset.json.
    let proj = d.join("proj");
    std::fs::create_dir_all(proj.join("data")).unwrap();
    std::fs::write(proj.join("tileset.json"), "not json at all\n").unwrap();
    std::fs::write(proj.join("data/survey.csv"), "precious\n").unwrap();
    // Another tool's tileset.
    let other = d.join("other-tool");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(
        other.join("tileset.json"),
        r#"{"asset":{"version":"1.1","generator":"py3dtiles"},"geometricError":1,"root":{"geometricError":0}}"#,
    )
    .unwrap();
    // citylod's tileset with a viewer page, its assets and a note put beside and into it.
    let tiles = d.join("tiles");
    build(&[&input], &tiles, &[]);
    std::fs::write(tiles.join("index.html"), "<html>").unwrap();
    std::fs::create_dir_all(tiles.join("assets")).unwrap();
    std::fs::write(tiles.join("assets/app.js"), "app").unwrap();
    std::fs::write(tiles.join("tiles/notes.txt"), "notes").unwrap();
    let before = tree_bytes(&d);
    let cases = [
        (&proj, "holds a tileset.json that citylod did not write (it is not JSON"),
        (&other, r#"holds a tileset.json that citylod did not write (its asset.generator is "py3dtiles")"#),
        (
            &tiles,
            "holds a tileset citylod wrote and entries it did not write: assets/, index.html, tiles/notes.txt; \
             the build replaces the whole folder",
        ),
    ];
    for (out, expect) in cases {
        let o = citylod(&["build", i, "--out", out.to_str().unwrap(), "-q"]);
        assert_no_panic(&o);
        assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
        let e = stderr_of(&o);
        assert!(e.contains(expect) && e.contains("--force"), "{e}");
        assert!(before == tree_bytes(&d), "{out:?}: files changed");
    }
    // A symbolic link citylod did not make is refused too (and never followed).
    #[cfg(unix)]
    {
        std::fs::remove_file(tiles.join("index.html")).unwrap();
        std::fs::remove_dir_all(tiles.join("assets")).unwrap();
        std::fs::remove_file(tiles.join("tiles/notes.txt")).unwrap();
        std::os::unix::fs::symlink(&proj, tiles.join("tiles/linked")).unwrap();
        let o = citylod(&["build", i, "--out", tiles.to_str().unwrap(), "-q"]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
        assert!(
            stderr_of(&o).contains("it did not write: tiles/linked;"),
            "{}",
            stderr_of(&o)
        );
        std::fs::remove_file(tiles.join("tiles/linked")).unwrap();
    }
    // Without them it is replaced; with --force the other folders are too.
    let o = citylod(&["build", i, "--out", tiles.to_str().unwrap(), "-q"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr_of(&o));
    for out in [&proj, &other] {
        let o = citylod(&["build", i, "--out", out.to_str().unwrap(), "-q", "--force"]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr_of(&o));
        assert_eq!(
            names_in(out),
            ["build-report.json", "tiles", "tileset.json"]
        );
    }
}

/// Folders beside the output named like a build's leftovers are a user's unless they are demonstrably citylod's
/// (its staging folder's name and marker): a `tiles.old-2024` backup is kept; a killed build's unfinished output
/// is removed, with a note.
#[test]
fn only_citylods_own_leftovers_beside_the_output_are_removed() {
    let d = scratch_dir("leftovers");
    let tiles = d.join("tiles");
    let input = repo_root().join("examples/nyc-les/les_buildings.geojson");
    build(&[&input], &tiles, &[]);
    let users = [
        "tiles.old-2024".to_string(),
        format!("tiles.old-{KILLED_PID}"),
        format!("tiles.tmp-{KILLED_PID}"),
        format!("tiles.citylod-tmp-{}", KILLED_PID - 1), // no marker
    ];
    for u in &users {
        std::fs::create_dir_all(d.join(u)).unwrap();
        std::fs::write(d.join(u).join("tileset.json"), "backup").unwrap();
    }
    // Killed (Ctrl-C, SIGKILL) while writing its tiles.
    let unfinished = d.join(format!("tiles.citylod-tmp-{KILLED_PID}"));
    killed_staging(&unfinished);
    std::fs::create_dir_all(unfinished.join("new/tiles")).unwrap();
    std::fs::write(unfinished.join("new/tiles/0.glb"), "half").unwrap();
    let o = citylod(&[
        "build",
        input.to_str().unwrap(),
        "--out",
        tiles.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr_of(&o));
    assert!(
        stderr_of(&o).contains(&format!(
            "note: removed {}: the unfinished output of a build (pid {KILLED_PID}) that was stopped",
            unfinished.display()
        )),
        "{}",
        stderr_of(&o)
    );
    let mut expected = users.to_vec();
    expected.push("tiles".into());
    expected.sort();
    assert_eq!(names_in(&d), expected);
    for u in &users {
        assert_eq!(
            std::fs::read_to_string(d.join(u).join("tileset.json")).unwrap(),
            "backup"
        );
    }
}

/// A build killed between its two renames (the previous tileset moved aside, the new one not yet in place) leaves
/// no `--out`: the next build puts the previous tileset back and says so, before anything else (here its input is
/// broken, so the restored tileset is what remains).
#[test]
fn a_build_killed_between_the_renames_gets_the_previous_tileset_back() {
    let d = scratch_dir("killed-swap");
    let tiles = d.join("tiles");
    build(
        &[&repo_root().join("examples/nyc-les/les_buildings.geojson")],
        &tiles,
        &[],
    );
    let before = tree_bytes(&tiles);
    let folder = d.join(format!("tiles.citylod-tmp-{KILLED_PID}"));
    killed_staging(&folder);
    std::fs::rename(&tiles, folder.join("old")).unwrap();
    std::fs::create_dir_all(folder.join("new/tiles")).unwrap();
    std::fs::write(folder.join("new/tileset.json"), "the killed build's").unwrap();
    let bad = write(&d, "bad.geojson", "{ not json");
    let o = citylod(&[
        "build",
        bad.to_str().unwrap(),
        "--out",
        tiles.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
    assert!(
        stderr_of(&o).contains(&format!(
            "note: restored {} from {}, where a build (pid {KILLED_PID}) that was stopped while replacing it had \
             moved it",
            tiles.display(),
            folder.join("old").display()
        )),
        "{}",
        stderr_of(&o)
    );
    assert!(
        before == tree_bytes(&tiles),
        "the previous tileset must come back whole"
    );
    assert_eq!(names_in(&d), ["bad.geojson", "tiles"]);
}

/// Where the tileset is swapped entry by entry inside `--out` (a mount point), a build killed mid-swap is undone by
/// the next one; a previous tileset saved there by a build that may still run is named in the refusal, even with
/// --force, and never deleted.
#[test]
fn a_build_killed_while_swapping_inside_the_output_folder_is_undone() {
    let d = scratch_dir("killed-swap-inside");
    let tiles = d.join("tiles");
    build(
        &[&repo_root().join("examples/nyc-les/les_buildings.geojson")],
        &tiles,
        &[],
    );
    let before = tree_bytes(&tiles);
    let bad = write(&d, "bad.geojson", "{ not json");
    let (b, t) = (bad.to_str().unwrap(), tiles.to_str().unwrap());
    // Killed while moving its entries in: the previous ones all in `old`, its tiles/ and report moved in, its
    // tileset.json (always last) not.
    let folder = tiles.join(format!(".citylod-tmp-{KILLED_PID}"));
    killed_staging(&folder);
    std::fs::create_dir_all(folder.join("old")).unwrap();
    std::fs::create_dir_all(folder.join("new")).unwrap();
    for n in ["build-report.json", "tiles", "tileset.json"] {
        std::fs::rename(tiles.join(n), folder.join("old").join(n)).unwrap();
    }
    std::fs::create_dir_all(tiles.join("tiles")).unwrap();
    std::fs::write(tiles.join("tiles/0.glb"), "the killed build's").unwrap();
    std::fs::write(tiles.join("build-report.json"), "the killed build's").unwrap();
    std::fs::write(folder.join("new/tileset.json"), "the killed build's").unwrap();
    std::fs::write(
        folder.join("swapping"),
        "build-report.json\ntiles\ntileset.json\n",
    )
    .unwrap();
    let o = citylod(&["build", b, "--out", t]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
    assert!(
        stderr_of(&o).contains(&format!(
            "note: restored the previous content of {t} from {}",
            folder.join("old").display()
        )),
        "{}",
        stderr_of(&o)
    );
    assert!(
        before == tree_bytes(&tiles),
        "the previous tileset must come back whole"
    );
    assert_eq!(
        names_in(&tiles),
        ["build-report.json", "tiles", "tileset.json"]
    );
    // Its build may still run (it holds the lock: here this test does): left alone, named, refused.
    let live = tiles.join(".citylod-tmp-4194300");
    killed_staging(&live);
    std::fs::create_dir_all(live.join("old")).unwrap();
    for n in ["tiles", "tileset.json"] {
        std::fs::rename(tiles.join(n), live.join("old").join(n)).unwrap();
    }
    let lock = std::fs::File::open(live.join(".citylod-staging")).unwrap();
    lock.try_lock().unwrap();
    let input = repo_root().join("examples/nyc-les/les_buildings.geojson");
    for force in [false, true] {
        let mut args = vec!["build", input.to_str().unwrap(), "--out", t];
        if force {
            args.push("--force");
        }
        let o = citylod(&args);
        assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
        let e = stderr_of(&o);
        assert!(
            e.contains(&format!(
                "holds {}: the previous tileset, saved there by a build that was stopped while replacing it",
                live.join("old").display()
            )) && e.contains("move the entries of"),
            "{e}"
        );
    }
    assert!(live.join("old/tileset.json").is_file());
    // Once it has ended, the next build puts the tileset back (and here, its input broken, stops).
    drop(lock);
    let o = citylod(&["build", b, "--out", t]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr_of(&o));
    assert!(stderr_of(&o).contains("note: restored the previous content of"));
    assert!(
        before == tree_bytes(&tiles),
        "the previous tileset must come back whole"
    );
}

/// A ring of a hostile kind around (x, y) metres: ordinary rectangles (some a hair wide), stars, bowties, spikes,
/// repeated and collinear points, random scribbles; closed or not.
fn hostile_ring(r: &mut Rng, x: f64, y: f64) -> Vec<[f64; 2]> {
    let mut pts: Vec<[f64; 2]> = match *r.pick(&[0, 0, 0, 0, 0, 1, 2, 3, 4, 5, 6]) {
        0 => {
            let (w, h) = (r.range(1e-7, 60.0), r.range(1e-7, 60.0));
            vec![[x, y], [x + w, y], [x + w, y + h], [x, y + h]]
        }
        1 => {
            let n = 3 + (r.next_u64() % 38) as usize;
            (0..n)
                .map(|i| {
                    let a = std::f64::consts::TAU * i as f64 / n as f64;
                    let d = r.range(0.1, 30.0);
                    [x + d * a.cos(), y + d * a.sin()]
                })
                .collect()
        }
        2 => vec![[x, y], [x + 10.0, y + 10.0], [x + 10.0, y], [x, y + 10.0]],
        3 => vec![
            [x, y],
            [x + 10.0, y],
            [x + 10.0, y + 10.0],
            [x + 5.0, y + 10.0],
            [x + 5.0, y + 1000.0],
            [x + 5.0, y + 10.0],
            [x, y + 10.0],
        ],
        4 => vec![
            [x, y],
            [x, y],
            [x, y],
            [x + 5.0, y],
            [x + 5.0, y],
            [x + 5.0, y + 5.0],
        ],
        5 => (0..10)
            .map(|i| [x + i as f64, y])
            .chain([[x, y + 1e-9]])
            .collect(),
        _ => (0..(r.next_u64() % 13))
            .map(|_| [x + r.range(-20.0, 20.0), y + r.range(-20.0, 20.0)])
            .collect(),
    };
    if r.unit() < 0.8 && !pts.is_empty() {
        pts.push(pts[0]);
    }
    pts
}

/// A FeatureCollection of up to 60 hostile features in lon/lat near Manhattan: polygons with hostile rings and
/// holes, multipolygons, points, lines, null geometry; heights that are text, negative, zero, huge, missing.
/// `footprintless`: only points, lines and null geometry.
fn hostile_collection(r: &mut Rng, footprintless: bool) -> Value {
    let deg = |p: [f64; 2]| json!([-73.99 + p[0] / 84_000.0, 40.72 + p[1] / 111_000.0]);
    let ring_deg = |ring: Vec<[f64; 2]>| Value::Array(ring.into_iter().map(deg).collect());
    let n = 1 + (r.next_u64() % 60) as usize;
    let features: Vec<Value> = (0..n)
        .map(|i| {
            let (x, y) = (
                *r.pick(&[0.0, 5.0, 10.0, 100.0]) + r.range(-30.0, 30.0),
                r.range(-30.0, 30.0),
            );
            let mut rings = vec![ring_deg(hostile_ring(r, x, y))];
            if r.unit() < 0.2 {
                rings.push(ring_deg(hostile_ring(r, x + 2.0, y + 2.0)));
            }
            let kinds: &[u8] = if footprintless {
                &[2, 3, 4]
            } else {
                &[0, 0, 0, 0, 0, 0, 0, 1, 2, 3, 4]
            };
            let geometry = match *r.pick(kinds) {
                0 => json!({"type": "Polygon", "coordinates": rings}),
                1 => json!({"type": "MultiPolygon", "coordinates": [rings, [ring_deg(hostile_ring(r, x + 40.0, y))]]}),
                2 => json!({"type": "Point", "coordinates": deg([x, y])}),
                3 => json!({"type": "LineString", "coordinates": rings[0]}),
                _ => Value::Null,
            };
            let height = r
                .pick(&[
                    json!(10),
                    json!(25.5),
                    json!(0),
                    json!(-5),
                    json!(1e-9),
                    json!(1e6),
                    json!("12 m"),
                    Value::Null,
                    json!("abc"),
                    json!(3000),
                ])
                .clone();
            let id = r
                .pick(&[json!(format!("b{i}")), json!(i), Value::Null, json!(""), json!(format!("b{}", i % 3))])
                .clone();
            let mut props = json!({"id": id, "height": height});
            if r.unit() < 0.2 {
                props["building:levels"] = r.pick(&[json!(3), json!("4"), json!(-1), Value::Null]).clone();
            }
            json!({"type": "Feature", "properties": props, "geometry": geometry})
        })
        .collect();
    json!({"type": "FeatureCollection", "features": features})
}

#[test]
fn hostile_random_files_never_panic_and_lose_nothing() {
    use citylod_tiles::read::read_tileset;
    use citylod_tiles::PropValue;
    let d = scratch_dir("hostile");
    let option_sets: [&[&str]; 6] = [
        &[],
        &[],
        &["--leaves-only"],
        &["--compression", "draco"],
        &["--level-ratio", "1"],
        &["--tile-max-features", "1"],
    ];
    let (mut built, mut refused) = (0, 0);
    for case in 0..40u64 {
        let mut r = Rng(0xC17_10D ^ case);
        let input = write(
            &d,
            &format!("case-{case}.geojson"),
            &hostile_collection(&mut r, case % 8 == 7).to_string(),
        );
        let out = d.join(format!("out-{case}"));
        let mut args = vec!["build".to_string(), input.display().to_string()];
        args.extend(r.pick(&option_sets).iter().map(|s| s.to_string()));
        args.extend(["--out".into(), out.display().to_string(), "--quiet".into()]);
        let o = citylod(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert_no_panic(&o);
        match o.status.code() {
            // Nothing readable: a clear error and no output.
            Some(2) => {
                refused += 1;
                assert!(
                    stderr_of(&o).contains("no building"),
                    "case {case} {args:?}:\n{}",
                    stderr_of(&o)
                );
                assert!(
                    !out.exists(),
                    "case {case}: a failed build left {}",
                    out.display()
                );
            }
            Some(0) => {
                built += 1;
                let report = read_json(&out.join("build-report.json"));
                let c = &report["counts"];
                let (read, written, skipped) = (
                    c["features_read"].as_u64().unwrap(),
                    c["buildings_written"].as_u64().unwrap(),
                    c["skipped"].as_u64().unwrap(),
                );
                assert_eq!(
                    read,
                    written + skipped,
                    "case {case}: read != written + skipped"
                );
                let listed = report["ingest"]["skipped"].as_array().unwrap().len()
                    + report["mesh_skipped"].as_array().unwrap().len();
                assert_eq!(listed as u64, skipped, "case {case}: every skip is listed");
                // Every building written is in exactly one leaf tile.
                let ts = read_tileset(&out.join("tileset.json")).expect("read back the tileset");
                let mut seen = vec![0u32; written as usize];
                for tile in ts.tiles.iter().filter(|t| t.children.is_empty()) {
                    for row in tile.content.iter().flat_map(|c| &c.features) {
                        match row.values.get("building_index") {
                            Some(PropValue::Int(i)) => seen[*i as usize] += 1,
                            other => panic!("case {case}: building_index {other:?}"),
                        }
                    }
                }
                assert!(seen.iter().all(|&n| n == 1), "case {case}: {seen:?}");
                // Odd attribute names and values (keys of every kind, mixed types) still make metadata that
                // follows the extensions.
                glb_metadata_follows_the_extensions(&format!("case {case}"), &out);
            }
            other => panic!("case {case} {args:?} exited {other:?}:\n{}", stderr_of(&o)),
        }
    }
    // The generator makes both outcomes, so both branches above are exercised.
    assert!(
        built >= 20 && refused >= 1,
        "built {built}, refused {refused}"
    );
}

/// The reviewed gaps of the readers: collections, properties, legacy CRS members, templates and non-numeric
/// vertices are read and reported, or refused with the file and what in it was not understood.
#[test]
fn odd_but_readable_inputs_are_kept_and_unreadable_ones_named() {
    let d = scratch_dir("reader-gaps");
    let (lon, lat) = (-73.99, 40.72);
    let gc = |members: Value| json!({"type": "GeometryCollection", "geometries": members});
    let point = json!({"type": "Point", "coordinates": [lon, lat]});
    let lonlat = json!({"type": "FeatureCollection", "features": [
        feature("nested", json!({"height": 12}), gc(json!([gc(json!([point])), {"type": "Polygon", "coordinates": square(lon, lat, 0.0002)}]))),
        feature("array-props", json!([1, 2, 3]), json!({"type": "Polygon", "coordinates": square(lon + 0.001, lat, 0.0002)})),
    ]});
    // NY Long Island state plane (US feet), the same neighbourhood, declared the GeoJSON 2008 way.
    let feet = json!({"type": "FeatureCollection", "crs": {"type": "EPSG", "properties": {"code": 2263}},
        "features": [feature("feet", json!({"height": 12}), json!({"type": "Polygon", "coordinates":
            [[[987000, 203000], [987060, 203000], [987060, 203060], [987000, 203060], [987000, 203000]]]}))]});
    let a = write(&d, "lonlat.geojson", &lonlat.to_string());
    let b = write(&d, "feet.geojson", &feet.to_string());
    let report = build(&[&a, &b], &d.join("out"), &[]);
    assert_eq!(
        schema_errors("build-report.schema.json", &report),
        Vec::<String>::new()
    );
    assert_eq!(report["counts"]["buildings_written"], 3, "{report:#}");
    assert_eq!(report["ingest"]["files"][1]["crs"], "EPSG:2263");
    let repaired: Vec<(&str, &str)> = report["ingest"]["repaired"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| {
            (
                i["feature_id"].as_str().unwrap(),
                i["reason"].as_str().unwrap(),
            )
        })
        .collect();
    assert!(
        repaired.contains(&("nested", "non_polygon_member_dropped")),
        "{repaired:?}"
    );
    assert!(
        repaired.contains(&("array-props", "properties_not_object")),
        "{repaired:?}"
    );

    // A building given as an instance of a geometry template (a 10 m cube at vertex 0).
    let city = |reference_system: Value, vertices: Value| {
        json!({"type": "CityJSON", "version": "2.0",
            "transform": {"scale": [1, 1, 1], "translate": [85000, 446000, 0]},
            "metadata": {"referenceSystem": reference_system},
            "geometry-templates": {"templates": [{"type": "Solid", "lod": "2", "boundaries": [[
                [[0, 3, 2, 1]], [[4, 5, 6, 7]], [[0, 1, 5, 4]], [[1, 2, 6, 5]], [[2, 3, 7, 6]], [[3, 0, 4, 7]]]]}],
                "vertices-templates": [[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0], [0, 0, 10], [10, 0, 10], [10, 10, 10], [0, 10, 10]]},
            "CityObjects": {"tpl": {"type": "Building", "geometry": [{"type": "GeometryInstance", "template": 0,
                "boundaries": [0], "transformationMatrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}]}},
            "vertices": vertices})
        .to_string()
    };
    let rd = json!({"authority": "EPSG", "code": 7415});
    let t = write(
        &d,
        "template.city.json",
        &city(rd.clone(), json!([[0, 0, 0]])),
    );
    let report = build(&[&t], &d.join("out-template"), &[]);
    assert_eq!(report["counts"]["buildings_written"], 1, "{report:#}");
    assert_eq!(
        report["ingest"]["height_sources"]["geometry"], 1,
        "the template's 10 m: {report:#}"
    );

    let refused = [
        (
            write(&d, "link.geojson", &json!({"type": "FeatureCollection", "features": [],
                "crs": {"type": "link", "properties": {"href": "http://e/2263.proj4", "type": "proj4"}}}).to_string()),
            "the crs member is not understood",
        ),
        (
            write(&d, "shifted.city.json", &city(rd.clone(), json!([[0, null, 0, 0]]))),
            "vertex 0 is not three numbers",
        ),
        (
            write(&d, "named.city.json", &city(json!({"name": "RD"}), json!([[0, 0, 0]]))),
            "metadata.referenceSystem member is not understood",
        ),
    ];
    for (input, says) in refused {
        let out = d.join("refused");
        let o = citylod(&[
            "build",
            &input.display().to_string(),
            "--out",
            &out.display().to_string(),
        ]);
        assert_no_panic(&o);
        let e = stderr_of(&o);
        assert_eq!(o.status.code(), Some(2), "{}: {e}", input.display());
        let name = input.file_name().unwrap().to_string_lossy();
        assert!(
            e.contains(says) && e.contains(name.as_ref()),
            "{name} should say {says}:\n{e}"
        );
    }
}

#[test]
fn a_height_too_small_to_mesh_is_named_and_the_building_kept() {
    // A height of 1e-300 m gave a roof not above its base once placed, and the mesher refused the building
    // (mesh_skipped). Heights under 0.1 m now fall to the next rule like absurd ones, and are counted; the mesher's
    // refusal stays as a guard no valid input reaches (its file attribution: `build::file_of_building`'s test).
    let d = scratch_dir("mesh_skip_file");
    let polygon = |lon: f64| json!({"type": "Polygon", "coordinates": square(lon, 52.0, 0.0001)});
    let collection =
        |features: Vec<Value>| json!({"type": "FeatureCollection", "features": features});
    let a = write(
        &d,
        "a.geojson",
        &collection(vec![
            feature("a1", json!({"height": 10}), polygon(4.36)),
            feature("a2", json!({"height": 10}), polygon(4.3603)),
        ])
        .to_string(),
    );
    let b = write(
        &d,
        "b.geojson",
        &collection(vec![
            feature("b1", json!({"height": 10}), polygon(4.3606)),
            feature("b2", json!({"height": 1e-300}), polygon(4.3609)),
        ])
        .to_string(),
    );
    let report = build(&[&a, &b], &d.join("out"), &[]);
    let skipped = report["mesh_skipped"].as_array().unwrap();
    assert!(skipped.is_empty(), "{skipped:?}");
    assert_eq!(report["counts"]["buildings_written"], 4);
    let ingest = &report["ingest"];
    assert_eq!(ingest["height_values_rejected"], json!({"height": 1}));
    assert_eq!(ingest["height_sources"]["default"], 1, "{ingest:#}");
}

#[test]
fn output_and_dump_paths_that_cannot_be_folders_are_refused_up_front() {
    let d = scratch_dir("out-parent-file");
    let good = repo_root().join("examples/nyc-les/les_buildings.geojson");
    let file = write(&d, "afile.txt", "x");
    let out = file.join("sub");
    let o = citylod(&[
        "build",
        &good.display().to_string(),
        "--out",
        &out.display().to_string(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr_of(&o);
    assert!(
        err.contains(&format!(
            "cannot create the output folder {}: its parent {} is not a folder; choose another --out",
            out.display(),
            file.display()
        )),
        "{err}"
    );
    // --dump-levels naming an existing file: refused before the build, not after it.
    let out = d.join("tiles");
    let o = citylod(&[
        "build",
        &good.display().to_string(),
        "--out",
        &out.display().to_string(),
        "--dump-levels",
        &file.display().to_string(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr_of(&o);
    assert!(
        err.contains(&format!(
            "--dump-levels {0}: {0} is a file, not a folder",
            file.display()
        )),
        "{err}"
    );
    assert!(!out.exists(), "nothing is built");
    // An unwritable parent (not testable as root, who may write anywhere).
    let locked = d.join("locked");
    std::fs::create_dir(&locked).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    if std::fs::create_dir(locked.join("probe")).is_err() {
        let out = locked.join("tiles");
        let o = citylod(&[
            "build",
            &good.display().to_string(),
            "--out",
            &out.display().to_string(),
        ]);
        let err = stderr_of(&o);
        assert!(
            err.contains(&format!("{} is not writable", locked.display()))
                && err.contains("choose another --out"),
            "{err}"
        );
    }
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn an_ordinary_folder_as_input_names_the_files_to_give() {
    let d = scratch_dir("folder-input");
    let folder = d.join("buildings");
    std::fs::create_dir(&folder).unwrap();
    std::fs::copy(
        repo_root().join("examples/nyc-les/les_buildings.geojson"),
        folder.join("les.geojson"),
    )
    .unwrap();
    let o = citylod(&[
        "build",
        &folder.display().to_string(),
        "--out",
        &d.join("out").display().to_string(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr_of(&o);
    assert!(
        err.contains(&format!(
            "{} is a folder; citylod reads files (or a File Geodatabase .gdb folder): give the files inside it, e.g. {}",
            folder.display(),
            folder.join("*.geojson").display()
        )),
        "{err}"
    );
}

#[test]
fn inspect_of_a_folder_without_a_tileset_says_what_to_give() {
    let d = scratch_dir("inspect-empty");
    let o = citylod(&["inspect", &d.display().to_string()]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr_of(&o);
    assert!(
        err.contains(&format!(
            "{}: no such tileset; give the folder holding tileset.json, or the file",
            d.display()
        )),
        "{err}"
    );
}

#[test]
fn renamed_inputs_build_by_their_content() {
    let d = scratch_dir("renamed-inputs");
    let tests = repo_root().join("crates/citylod-ingest/tests");
    for (from, name, extra) in [
        ("osm/les_osmium.osm.gz", "extract.gz", vec![]),
        (
            "geopackage/les_gdal.gpkg",
            "one.sqlite",
            vec!["--layer", "buildings"],
        ),
        ("fgdb/nyc-les-2263.gdb.zip", "gdbzip_noext", vec![]),
    ] {
        let p = d.join(name);
        std::fs::copy(tests.join(from), &p).unwrap();
        let out = d.join(format!("out-{name}"));
        let mut args = vec![
            "build".to_string(),
            p.display().to_string(),
            "--out".into(),
            out.display().to_string(),
        ];
        args.extend(extra.iter().map(|s| s.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = citylod(&args);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr_of(&o));
        assert!(out.join("tileset.json").is_file(), "{name}");
    }
}

#[test]
fn a_single_dash_out_is_refused_with_the_flag_to_write() {
    let d = scratch_dir("single-dash-out");
    let (lon, lat) = (-73.99, 40.72);
    let fc = json!({"type": "FeatureCollection", "features": [
        feature("a", json!({"height": 10}), json!({"type": "Polygon", "coordinates": square(lon, lat, 0.0002)})),
    ]});
    let input = write(&d, "one.geojson", &fc.to_string());
    let tiles = d.join("tiles");
    for args in [
        vec![
            "build".to_string(),
            input.display().to_string(),
            "-out".into(),
            tiles.display().to_string(),
        ],
        vec![
            "build".to_string(),
            input.display().to_string(),
            format!("-out={}", tiles.display()),
        ],
    ] {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = citylod(&a);
        assert_no_panic(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let err = stderr_of(&o);
        assert!(
            err.contains("error: -out is read as -o ut; write --out DIR (or -o DIR)"),
            "{args:?}: {err}"
        );
        assert!(!tiles.exists() && !Path::new("ut").exists(), "{args:?}");
    }
}

#[test]
fn count_flags_that_are_not_whole_numbers_say_the_form_expected() {
    let d = scratch_dir("count-flags");
    let input = write(
        &d,
        "one.geojson",
        r#"{"type":"FeatureCollection","features":[]}"#,
    );
    for (flag, value, says) in [
        (
            "--max-tileset-json-bytes",
            "4MB",
            "a whole number of bytes, e.g. 4000000",
        ),
        (
            "--tile-max-features",
            "-1",
            "a whole number of features, e.g. 2000",
        ),
        (
            "--tile-max-triangles",
            "1.5",
            "a whole number of triangles, e.g. 200000",
        ),
    ] {
        let out = d.join("out");
        let o = citylod(&[
            "build",
            input.to_str().unwrap(),
            flag,
            value,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}");
        let err = stderr_of(&o);
        assert!(
            err.contains(&format!("invalid value '{value}' for '{flag}")) && err.contains(says),
            "{flag} {value}: {err}"
        );
        assert!(!err.contains("invalid digit"), "{err}");
    }
}

#[test]
fn the_summary_breaks_repairs_down_by_reason_and_gives_small_sizes_in_kb() {
    let d = scratch_dir("summary-repairs");
    let (lon, lat) = (-73.99, 40.72);
    let fc = json!({"type": "FeatureCollection", "features": [
        feature("good", json!({"height": 10}), json!({"type": "Polygon", "coordinates": square(lon, lat, 0.0002)})),
        feature("unclosed", json!({"height": 9}), json!({"type": "Polygon", "coordinates": [[
            [lon + 0.003, lat], [lon + 0.0032, lat], [lon + 0.0032, lat + 0.0002], [lon + 0.003, lat + 0.0002]]]})),
        feature("a-point", json!({}), json!({"type": "Point", "coordinates": [lon, lat]})),
    ]});
    let input = write(&d, "repairs.geojson", &fc.to_string());
    let out = d.join("out");
    let o = citylod(&[
        "build",
        input.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = stderr_of(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("(1 repaired, 1 skipped)"), "{err}");
    assert!(
        err.contains("\n  skipped      1 × unsupported_geometry\n"),
        "{err}"
    );
    assert!(err.contains("\n  repaired     1 × ring_closed\n"), "{err}");
    let summary = err.lines().find(|l| l.starts_with("citylod: ")).unwrap();
    assert!(
        summary.contains(" kB, in ") && !summary.contains(" MB"),
        "{summary}"
    );
}
