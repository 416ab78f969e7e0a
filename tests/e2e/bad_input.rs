//! Broken inputs give a documented error (exit 2) or a recorded skip or repair, never a panic, and a failed
//! build never touches an existing output folder.

use crate::common::*;
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
    ]});
    let input = write(&d, "broken.geojson", &fc.to_string());
    let report = build(&[&input], &d.join("out"), &[]);
    let c = &report["counts"];
    assert_eq!(c["features_read"], 9);
    assert_eq!(
        c["buildings_written"], 4,
        "good, no-height, bowtie and unclosed are written: {report:#}"
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
    let hs = &report["ingest"]["height_sources"];
    assert_eq!(
        hs["default"], 1,
        "the building without height falls back to the default: {hs}"
    );
    assert_eq!(
        hs["known_attribute"], 3,
        "'28 m', 12 and '9' are read from attributes: {hs}"
    );
}

#[test]
fn unreadable_inputs_exit_2_with_a_clear_message() {
    let d = scratch_dir("unreadable");
    let good = repo_root().join("examples/nyc-les/les_buildings.geojson");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec![write(&d, "truncated.geojson", r#"{"type":"FeatureCollection","features":[{"type":"Fea"#).display().to_string()], "truncated.geojson"),
        (vec![write(&d, "nan.geojson", r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[[NaN,1],[2,2],[3,1],[NaN,1]]]}}]}"#).display().to_string()], "nan.geojson"),
        (vec![d.join("does-not-exist.geojson").display().to_string()], "does-not-exist.geojson"),
        (vec![good.display().to_string(), "--crs".into(), "EPSG:999999".into()], "EPSG:999999"),
        (vec![write(&d, "empty.geojson", r#"{"type":"FeatureCollection","features":[]}"#).display().to_string()], "no building"),
        (vec![good.display().to_string(), "--storey-height=-1".into()], "--storey-height"),
        (vec![good.display().to_string(), "--streets".into(), write(&d, "streets.geojson", r#"{"type":"FeatureCollection","features":["#).display().to_string()], "streets.geojson"),
        (vec![good.display().to_string(), "--streets".into(), d.join("no-streets.geojson").display().to_string()], "no-streets.geojson"),
        (vec![good.display().to_string(), "--streets".into(), good.display().to_string(), "--leaves-only".into()], "--leaves-only"),
        (vec![good.display().to_string(), "--street-penalty=-5".into()], "--street-penalty"),
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
