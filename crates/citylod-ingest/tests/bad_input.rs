//! Bad and edge-case inputs, written to a temporary directory: every file-level problem is an
//! `IngestError`, every feature-level problem a skip or repair with the right reason, no panics.

use citylod_ingest::{ingest, IngestError, IngestOptions, IssueReason};
use citylod_model::HeightSource;
use std::path::PathBuf;

fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn feature(id: &str, props: &str, coords: &str) -> String {
    format!(
        r#"{{"type":"Feature","id":"{id}","properties":{props},"geometry":{{"type":"Polygon","coordinates":{coords}}}}}"#
    )
}

fn collection(features: &[String]) -> String {
    format!(
        r#"{{"type":"FeatureCollection","features":[{}]}}"#,
        features.join(",")
    )
}

/// A 0.0001° square near Delft (≈ 7 m × 11 m).
const SQUARE: &str = "[[[4.36,52.0],[4.3601,52.0],[4.3601,52.0001],[4.36,52.0001],[4.36,52.0]]]";

/// [`SQUARE`] moved 0.01° (≈ 690 m) east.
fn square_further_east() -> String {
    SQUARE
        .replace("4.36,", "4.37,")
        .replace("4.3601,", "4.3701,")
}

fn reason_of(out: &citylod_ingest::Ingested, id: &str) -> Option<IssueReason> {
    out.report
        .skipped
        .iter()
        .find(|s| s.feature_id == id)
        .map(|s| s.reason)
}

#[test]
fn truncated_json_is_a_file_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let full = collection(&[feature("a", "{}", SQUARE)]);
    let p = write(&dir, "trunc.geojson", &full[..full.len() / 2]);
    let e = ingest(std::slice::from_ref(&p), &IngestOptions::default()).unwrap_err();
    assert!(matches!(e, IngestError::Json { .. }), "{e}");
    assert!(e.to_string().contains("trunc.geojson"), "{e}");
}

#[test]
fn a_byte_order_mark_is_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!("\u{feff}{}", collection(&[feature("a", "{}", SQUARE)]));
    let out = ingest(
        &[write(&dir, "bom.geojson", &text)],
        &IngestOptions::default(),
    )
    .unwrap();
    assert_eq!(out.buildings.len(), 1);
}

#[test]
fn degenerate_and_out_of_range_features_are_skipped_with_their_reason() {
    let dir = tempfile::tempdir().unwrap();
    let text = collection(&[
        feature("ok", "{}", SQUARE),
        feature("two_points", "{}", "[[[4.36,52.0],[4.3601,52.0]]]"),
        feature("line", "{}", "[[[4.36,52.0],[4.3601,52.0],[4.3602,52.0],[4.36,52.0]]]"),
        feature("lon500", "{}", "[[[500,52.0],[500.0001,52.0],[500.0001,52.0001],[500,52.0]]]"),
        feature("lon1e308", "{}", "[[[1e308,52.0],[4.3601,52.0],[4.3601,52.0001],[1e308,52.0]]]"),
        feature("tiny", "{}", "[[[4.36,52.0],[4.36000001,52.0],[4.36000001,52.00000001],[4.36,52.0]]]"),
        r#"{"type":"Feature","id":"pt","properties":{},"geometry":{"type":"Point","coordinates":[4.36,52.0]}}"#.into(),
        r#"{"type":"Feature","id":"null","properties":{},"geometry":null}"#.into(),
        r#"{"type":"Feature","id":"notype","properties":{},"geometry":{"coordinates":[[[4.36,52.0],[4.3601,52.0],[4.3601,52.0001],[4.36,52.0]]]}}"#.into(),
    ]);
    let out = ingest(
        &[write(&dir, "bad.geojson", &text)],
        &IngestOptions::default(),
    )
    .unwrap();
    out.report.check_invariants().unwrap();
    assert_eq!(out.report.features_read, 9);
    assert_eq!(
        reason_of(&out, "notype"),
        Some(IssueReason::MalformedGeometry)
    );
    assert_eq!(out.buildings.len(), 1);
    // A huge coordinate is shown as a number one can read, not 309 digits.
    let huge = out
        .report
        .skipped
        .iter()
        .find(|s| s.feature_id == "lon1e308")
        .unwrap();
    assert_eq!(huge.reason, IssueReason::CoordinateOutOfRange);
    assert!(
        huge.detail.starts_with("coordinate (1e308, 52)"),
        "{}",
        huge.detail
    );
    assert_eq!(
        reason_of(&out, "two_points"),
        Some(IssueReason::TooFewPoints)
    );
    assert_eq!(reason_of(&out, "line"), Some(IssueReason::ZeroArea));
    assert_eq!(
        reason_of(&out, "lon500"),
        Some(IssueReason::CoordinateOutOfRange)
    );
    assert_eq!(reason_of(&out, "tiny"), Some(IssueReason::ZeroArea));
    assert_eq!(
        reason_of(&out, "pt"),
        Some(IssueReason::UnsupportedGeometry)
    );
    assert_eq!(reason_of(&out, "null"), Some(IssueReason::NoGeometry));
    assert_eq!(out.report.skipped_by_reason["zero_area"], 2);
    assert!(out
        .report
        .skipped
        .iter()
        .all(|s| s.file.ends_with("bad.geojson") && !s.detail.is_empty()));
}

#[test]
fn numbers_beyond_f64_skip_the_feature_not_the_file() {
    // JSON has no NaN; 1e999 overflows f64. In a FeatureCollection only that feature is skipped.
    // Non-finite coordinates inside the pipeline are covered by the unit test in lib.rs.
    let dir = tempfile::tempdir().unwrap();
    let text = collection(&[
        feature(
            "inf",
            "{}",
            "[[[1e999,52.0],[4.3601,52.0],[4.3601,52.0001],[1e999,52.0]]]",
        ),
        feature("ok", "{}", SQUARE),
    ]);
    let out = ingest(
        &[write(&dir, "inf.geojson", &text)],
        &IngestOptions::default(),
    )
    .unwrap();
    assert_eq!(out.buildings.len(), 1);
    assert_eq!(
        out.report.skipped[0].reason,
        IssueReason::NonFiniteCoordinate
    );
    // Named by its own id: the rest of the feature is read.
    assert_eq!(out.report.skipped[0].feature_id, "inf");
}

#[test]
fn bowtie_is_repaired_into_one_building_of_two_parts() {
    let dir = tempfile::tempdir().unwrap();
    let bowtie = "[[[4.36,52.0],[4.3601,52.0001],[4.3601,52.0],[4.36,52.0001],[4.36,52.0]]]";
    let out = ingest(
        &[write(
            &dir,
            "bowtie.geojson",
            &collection(&[feature("bow", "{}", bowtie)]),
        )],
        &IngestOptions::default(),
    )
    .unwrap();
    assert_eq!(out.buildings.len(), 1);
    assert_eq!(out.buildings[0].footprint.0.len(), 2);
    citylod_ingest::check_footprint(&out.buildings[0].footprint).unwrap();
    assert_eq!(out.report.repaired[0].reason, IssueReason::SelfIntersection);
    assert_eq!(out.report.repaired[0].feature_id, "bow");
    assert_eq!(out.report.features_repaired, 1);
}

#[test]
fn unclosed_ring_and_repeated_points_are_repaired_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let open = "[[[4.36,52.0],[4.3601,52.0],[4.3601,52.0],[4.3601,52.0001],[4.36,52.0001]]]";
    let out = ingest(
        &[write(
            &dir,
            "open.geojson",
            &collection(&[feature("o", "{}", open)]),
        )],
        &IngestOptions::default(),
    )
    .unwrap();
    assert_eq!(out.buildings.len(), 1);
    let reasons: Vec<_> = out.report.repaired.iter().map(|r| r.reason).collect();
    assert_eq!(
        reasons,
        vec![IssueReason::RingClosed, IssueReason::RepeatedPointsRemoved]
    );
    assert_eq!(out.buildings[0].footprint.0[0].exterior().0.len(), 5);
}

#[test]
fn heights_missing_string_and_storeys_resolve_and_are_counted() {
    let dir = tempfile::tempdir().unwrap();
    let text = collection(&[
        feature("none", "{}", SQUARE),
        feature("str", r#"{"height":"28 m"}"#, SQUARE),
        feature("comma", r#"{"building:height":"12,5"}"#, SQUARE),
        feature("levels", r#"{"building:levels":"4"}"#, SQUARE),
        feature("custom", r#"{"hoogte": 7}"#, SQUARE),
    ]);
    let opts = IngestOptions {
        height_attr: Some("hoogte".into()),
        storey_height_m: 3.5,
        default_height_m: 9.0,
        ..Default::default()
    };
    let out = ingest(&[write(&dir, "h.geojson", &text)], &opts).unwrap();
    let h: Vec<_> = out
        .buildings
        .iter()
        .map(|b| (b.height_m, b.height_source))
        .collect();
    assert_eq!(
        h,
        vec![
            (9.0, HeightSource::Default),
            (28.0, HeightSource::KnownAttribute),
            (12.5, HeightSource::KnownAttribute),
            (14.0, HeightSource::Storeys),
            (7.0, HeightSource::NamedAttribute),
        ]
    );
    let s = &out.report.height_sources;
    assert_eq!(
        (
            s["default"],
            s["known_attribute"],
            s["storeys"],
            s["named_attribute"]
        ),
        (1, 2, 1, 1)
    );
}

#[test]
fn rejected_heights_are_listed_per_feature_with_their_values() {
    // A US height column with a thousands separator, a base above its height, and a height of 0: each building is
    // listed with what it held (the report used to give a count per attribute only), and none is a made-up box
    // floating above a contradictory base.
    let dir = tempfile::tempdir().unwrap();
    let text = collection(&[
        feature("wtc", r#"{"height":"1,776"}"#, SQUARE),
        feature("floating", r#"{"height":"20","min_height":"30"}"#, SQUARE),
        feature("shed", r#"{"height":0}"#, SQUARE),
        feature("fine", r#"{"height":"12,5"}"#, SQUARE),
    ]);
    let out = ingest(
        &[write(&dir, "h.geojson", &text)],
        &IngestOptions::default(),
    )
    .unwrap();
    let listed: Vec<(&str, &str)> = out
        .report
        .repaired
        .iter()
        .filter(|r| r.reason == IssueReason::HeightValueRejected)
        .map(|r| (r.feature_id.as_str(), r.detail.as_str()))
        .collect();
    assert_eq!(listed.len(), 3, "{listed:?}");
    assert!(
        listed[0].0 == "wtc"
            && listed[0]
                .1
                .contains("\"1,776\": a comma before three digits")
    );
    assert!(
        listed[1].0 == "floating" && listed[1].1.contains("min_height = \"30\": a base of 30 m")
    );
    assert!(listed[2].0 == "shed" && listed[2].1.contains("height = 0: 0 m, not a height"));
    let b = |id: &str| out.buildings.iter().find(|b| b.source_id == id).unwrap();
    assert_eq!(b("wtc").height_source, HeightSource::Default);
    assert_eq!(
        (b("floating").height_m, b("floating").base_z_m),
        (20.0, 0.0)
    );
    assert_eq!(b("fine").height_m, 12.5);
    assert_eq!(out.report.features_repaired, 3);
}

#[test]
fn a_geojson_in_feet_says_when_its_heights_were_read_as_metres() {
    // GeoJSON (2008) with a crs member naming NY Long Island in US feet, as NYC exports are: the note Shapefile,
    // GeoPackage and File Geodatabase input already had.
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::2263"}},
        "features":[{"type":"Feature","id":"b","properties":{"HEIGHTROOF":120},"geometry":{"type":"Polygon",
        "coordinates":[[[987000,203000],[987050,203000],[987050,203050],[987000,203050],[987000,203000]]]}}]}"#;
    let path = write(&dir, "ft.geojson", text);
    let mut opts = IngestOptions {
        height_attr: Some("HEIGHTROOF".into()),
        ..Default::default()
    };
    let out = ingest(std::slice::from_ref(&path), &opts).unwrap();
    assert_eq!(out.buildings[0].height_m, 120.0);
    assert!(
        out.report.files[0].notes.iter().any(|n| n
            .contains("the CRS is in US survey feet, and the height attribute \"HEIGHTROOF\" was read in metres")),
        "{:?}",
        out.report.files[0].notes
    );
    opts.height_unit_m = Some(1200.0 / 3937.0);
    let out = ingest(&[path], &opts).unwrap();
    assert!((out.buildings[0].height_m - 36.576).abs() < 1e-3);
    assert!(out.report.files[0].notes.is_empty());
}

#[test]
fn unknown_crs_codes_are_file_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        &dir,
        "a.geojson",
        &collection(&[feature("a", "{}", SQUARE)]),
    );
    let opts = IngestOptions {
        crs: Some("EPSG:999999".into()),
        ..Default::default()
    };
    let e = ingest(&[p], &opts).unwrap_err();
    assert!(matches!(e, IngestError::UnknownCrs { .. }), "{e}");
    assert!(e.to_string().contains("999999"));
    // A CRS declared inside the file that the EPSG table lacks names the file.
    let text = r#"{"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::999999"}},"features":[]}"#;
    let e = ingest(&[write(&dir, "b.geojson", text)], &IngestOptions::default()).unwrap_err();
    assert!(
        matches!(&e, IngestError::UnknownCrs { origin, .. } if origin.ends_with("b.geojson")),
        "{e}"
    );
}

#[test]
fn a_latin1_file_is_refused_with_where_and_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = collection(&[feature("a", r#"{"name":"Stra"}"#, SQUARE)]).into_bytes();
    let at = bytes.windows(4).position(|w| w == b"Stra").unwrap() + 4;
    bytes.splice(at..at, [0xDF, b'e']); // "Straße" in Latin-1
    let p = dir.path().join("latin1.geojson");
    std::fs::write(&p, &bytes).unwrap();
    let err = ingest(&[p], &IngestOptions::default()).unwrap_err();
    let e = format!(
        "{err}: {}",
        std::error::Error::source(&err)
            .map(|s| s.to_string())
            .unwrap_or_default()
    );
    assert!(
        e.contains(&format!("byte {at} (line 1) is 0xDF")) && e.contains("save the file as UTF-8"),
        "{e}"
    );
}

#[test]
fn other_file_level_problems_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.geojson");
    assert!(matches!(
        ingest(&[missing], &IngestOptions::default()),
        Err(IngestError::Read { .. })
    ));
    let bad_default = IngestOptions {
        default_height_m: 0.0,
        ..Default::default()
    };
    assert!(matches!(
        ingest(&[], &bad_default),
        Err(IngestError::InvalidOption { .. })
    ));
    let e = ingest(
        &[write(&dir, "arr.json", "[1,2,3]")],
        &IngestOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, IngestError::UnknownFormat { .. }), "{e}");
    let e = ingest(
        &[write(&dir, "kml.json", r#"{"type":"Topology"}"#)],
        &IngestOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, IngestError::UnknownFormat { .. }), "{e}");
    let cj = r#"{"type":"CityJSON","version":"1.0","CityObjects":{},"vertices":[]}"#;
    let e = ingest(&[write(&dir, "nocrs.json", cj)], &IngestOptions::default()).unwrap_err();
    assert!(matches!(e, IngestError::MissingCrs { .. }), "{e}");
    assert!(e.to_string().contains("--crs") && e.to_string().contains("metadata.referenceSystem"));
    let seq = "{\"type\":\"CityJSON\",\"version\":\"2.0\",\"transform\":{\"scale\":[1,1,1],\"translate\":[0,0,0]},\
               \"metadata\":{\"referenceSystem\":\"https://www.opengis.net/def/crs/EPSG/0/7415\"},\"CityObjects\":{},\"vertices\":[]}\n\
               {\"type\":\"CityJSONFeature\",\"id\":\"x\",\"CityObjects\":{},\"vertices\":[]}\n{\"type\":\"CityJSONFea";
    let e = ingest(
        &[write(&dir, "broken.city.jsonl", seq)],
        &IngestOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, IngestError::Json { line: 3, .. }), "{e}");
}

/// The error's text, with its causes.
fn full_text(e: &IngestError) -> String {
    let mut text = e.to_string();
    let mut cause = std::error::Error::source(e);
    while let Some(c) = cause {
        text.push_str(&format!(": {c}"));
        cause = c.source();
    }
    text
}

#[test]
fn files_no_reader_takes_are_told_for_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = |name: &str, b: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, b).unwrap();
        p
    };
    let mut utf16 = vec![0xff, 0xfe];
    utf16.extend(
        "{\"type\":\"FeatureCollection\"}"
            .encode_utf16()
            .flat_map(u16::to_le_bytes),
    );
    let cases: Vec<(PathBuf, &str)> = vec![
        (bytes("empty.geojson", b""), "the file is empty"),
        (
            bytes("empty.gml", b""),
            "named as CityGML, but the file is empty",
        ),
        (
            bytes("noise.gml", &[0xd9, 0xfa, 0xd2, 0x23, 0x00, 0x17]),
            "named as CityGML, but it does not read as XML",
        ),
        (
            bytes("other.gml", b"<?xml version=\"1.0\"?><foo/>"),
            "its root element is <foo>",
        ),
        (
            bytes("other.xml", b"<kml><Document/></kml>"),
            "named as XML, but its root element is <kml>",
        ),
        (bytes("tile.glb", b"glTF\x02\x00\x00\x00"), "a glTF binary"),
        (bytes("wide.geojson", &utf16), "UTF-16 text"),
        (
            bytes("blob.dat", &[0x50, 0x4b, 0x00, 0x07, 0x00]),
            "a binary file (it begins 50 4B 00 07)",
        ),
        (
            bytes("noise.osm.gz", &[0xd9, 0xfa]),
            "not gzip- or bzip2-compressed",
        ),
        (
            bytes("noise.zip", &[0xd9, 0xfa]),
            "not a ZIP archive (no end of central directory record); a .zip input is read as a zipped File \
             Geodatabase or CityGML",
        ),
    ];
    for (path, expect) in cases {
        let e = ingest(std::slice::from_ref(&path), &IngestOptions::default()).unwrap_err();
        let text = full_text(&e);
        assert!(text.contains(expect), "{}: {text}", path.display());
        assert!(
            !text.contains("iconv -f latin1"),
            "{}: {text}",
            path.display()
        );
    }
    // OpenStreetMap XML named .xml is still read as such.
    let osm = bytes(
        "map.xml",
        b"<osm version=\"0.6\"><node id=\"1\" lat=\"0\" lon=\"0\"/></osm>",
    );
    let e = ingest(&[osm], &IngestOptions::default())
        .map(|_| ())
        .map_err(|e| full_text(&e));
    assert!(
        !e.as_ref().is_err_and(|t| t.contains("named as XML")),
        "{e:?}"
    );
}

/// A pipe is refused before anything is read from it (a FIFO no one writes to would otherwise wait forever; data
/// piped in would be half read by the look at its head).
#[cfg(unix)]
#[test]
fn a_pipe_is_refused_as_not_a_regular_file() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("in.geojson");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    let e = ingest(&[fifo], &IngestOptions::default()).unwrap_err();
    assert!(
        full_text(&e).contains("not a regular file"),
        "{}",
        full_text(&e)
    );
}

#[test]
fn ids_follow_input_order_across_files_and_fall_back_to_file_index() {
    let dir = tempfile::tempdir().unwrap();
    let anon = square_further_east();
    let a = write(
        &dir,
        "a.geojson",
        &collection(&[feature("a0", "{}", SQUARE)]),
    );
    let b_text = format!(
        r#"{{"type":"FeatureCollection","features":[{{"type":"Feature","properties":{{}},"geometry":{{"type":"Polygon","coordinates":{anon}}}}}]}}"#
    );
    let b = write(&dir, "b.geojson", &b_text);
    let out = ingest(&[a, b], &IngestOptions::default()).unwrap();
    let ids: Vec<_> = out
        .buildings
        .iter()
        .map(|b| (b.id.0, b.source_id.as_str()))
        .collect();
    assert_eq!(ids, vec![(0, "a0"), (1, "b.geojson#0")]);
    assert_eq!(out.report.files.len(), 2);
    // The frame origin is the centre of both buildings' extent.
    assert!(
        (out.frame.origin_lon_deg - 4.36505).abs() < 1e-9,
        "{}",
        out.frame.origin_lon_deg
    );
}

#[test]
fn an_id_attribute_no_feature_has_is_refused_listing_every_attribute_seen() {
    let dir = tempfile::tempdir().unwrap();
    // An attribute only the 150th feature has is listed too.
    let features: Vec<String> = (0..200)
        .map(|i| {
            let props = if i == 150 {
                r#"{"BIN":"7"}"#
            } else {
                r#"{"name":"x"}"#
            };
            feature(&format!("f{i}"), props, SQUARE)
        })
        .collect();
    let p = write(&dir, "many.geojson", &collection(&features));
    let opts = IngestOptions {
        id_attr: Some("nope".into()),
        ..Default::default()
    };
    let e = ingest(&[p], &opts).unwrap_err();
    assert!(matches!(e, IngestError::InvalidOption { .. }), "{e}");
    assert!(e.to_string().contains("attributes found: BIN, name"), "{e}");
}

#[test]
fn the_same_input_gives_identical_output() {
    let dir = tempfile::tempdir().unwrap();
    let text = collection(
        &(0..200)
            .map(|i| {
                let x = 4.36 + i as f64 * 0.0002;
                feature(
                    &i.to_string(),
                    &format!(r#"{{"height":{i}}}"#),
                    &format!(
                        "[[[{x},52.0],[{},52.0],[{},52.0001],[{x},52.0]]]",
                        x + 0.0001,
                        x + 0.0001
                    ),
                )
            })
            .collect::<Vec<_>>(),
    );
    let p = write(&dir, "many.geojson", &text);
    let a = ingest(std::slice::from_ref(&p), &IngestOptions::default()).unwrap();
    let b = ingest(&[p], &IngestOptions::default()).unwrap();
    assert_eq!(
        serde_json::to_string(&a.report).unwrap(),
        serde_json::to_string(&b.report).unwrap()
    );
    assert_eq!(a.frame, b.frame);
    for (x, y) in a.buildings.iter().zip(&b.buildings) {
        assert_eq!(
            (&x.source_id, &x.footprint, x.height_m),
            (&y.source_id, &y.footprint, y.height_m)
        );
    }
}

#[test]
fn repeated_buildings_are_written_once_and_reused_ids_are_counted() {
    let dir = tempfile::tempdir().unwrap();
    let moved = square_further_east();
    let a = write(
        &dir,
        "a.geojson",
        &collection(&[
            feature("same", r#"{"height":10}"#, SQUARE),
            feature("same", r#"{"height":10}"#, SQUARE),
            feature("taller", r#"{"height":10}"#, SQUARE),
            feature("moved", r#"{"height":10}"#, SQUARE),
        ]),
    );
    let b = write(
        &dir,
        "b.geojson",
        &collection(&[
            feature("same", r#"{"height":10}"#, SQUARE),
            feature("taller", r#"{"height":25}"#, SQUARE),
            feature("moved", r#"{"height":10}"#, &moved),
        ]),
    );
    let out = ingest(&[a, b.clone()], &IngestOptions::default()).unwrap();
    let r = &out.report;
    // The exact repeats of "same" (in its own file and in b) are skipped, named and counted.
    let dups: Vec<_> = r
        .skipped
        .iter()
        .filter(|s| s.reason == IssueReason::Duplicate)
        .collect();
    assert_eq!(dups.len(), 2, "{dups:?}");
    assert!(dups.iter().all(|s| s.feature_id == "same"));
    assert!(
        dups[0].detail.contains("earlier in this file"),
        "{}",
        dups[0].detail
    );
    assert!(dups[1].detail.contains("a.geojson"), "{}", dups[1].detail);
    assert_eq!(r.skipped_by_reason.get("duplicate"), Some(&2));
    // Same id, other height or place: both kept, counted.
    assert_eq!(r.duplicate_ids, 2);
    assert_eq!(out.buildings.len(), 5);
    assert_eq!(r.check_invariants(), Ok(()));
    // The same file twice: the second copy adds nothing.
    let twice = ingest(&[b.clone(), b], &IngestOptions::default()).unwrap();
    assert_eq!(twice.buildings.len(), 3);
    assert_eq!(twice.report.skipped_by_reason.get("duplicate"), Some(&3));
    // Two buildings that share an id, their file given twice: each second copy repeats the building with its own
    // footprint, not only the first one of that id.
    let c = write(
        &dir,
        "c.geojson",
        &collection(&[
            feature("x", r#"{"height":10}"#, SQUARE),
            feature("x", r#"{"height":10}"#, &moved),
        ]),
    );
    let twice = ingest(&[c.clone(), c], &IngestOptions::default()).unwrap();
    assert_eq!(twice.buildings.len(), 2);
    assert_eq!(twice.report.skipped_by_reason.get("duplicate"), Some(&2));
    assert_eq!(twice.report.duplicate_ids, 1);
    assert_eq!(twice.report.check_invariants(), Ok(()));
}

#[test]
fn deep_or_repeated_properties_cost_only_themselves_and_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let deep = format!("{}{}", "[".repeat(100_000), "]".repeat(100_000));
    let text = collection(&[
        feature("deep", &format!(r#"{{"height":12,"a":{deep}}}"#), SQUARE),
        feature(
            "twice",
            r#"{"height":10,"height":20}"#,
            &square_further_east(),
        ),
    ]);
    let out = ingest(
        &[write(&dir, "props.geojson", &text)],
        &IngestOptions::default(),
    )
    .unwrap();
    let r = &out.report;
    r.check_invariants().unwrap();
    assert_eq!(out.buildings.len(), 2, "{:?}", r.skipped);
    assert_eq!(out.buildings[0].height_m, 12.0);
    assert_eq!(out.buildings[1].height_m, 20.0, "the last value");
    assert_eq!(r.repaired_by_reason["property_too_deep_dropped"], 1);
    assert_eq!(r.repaired_by_reason["duplicate_key"], 1);
    let named: Vec<(&str, IssueReason)> = r
        .repaired
        .iter()
        .map(|i| (i.feature_id.as_str(), i.reason))
        .collect();
    assert_eq!(
        named,
        [
            ("deep", IssueReason::PropertyTooDeepDropped),
            ("twice", IssueReason::DuplicateKey)
        ]
    );
    assert!(r.repaired[1].detail.contains("height"), "{:?}", r.repaired);
}

#[test]
fn a_numeric_and_a_text_id_are_one_id() {
    let dir = tempfile::tempdir().unwrap();
    let moved = square_further_east();
    let feature_num = |id: u32, props: &str, coords: &str| {
        feature(&id.to_string(), props, coords)
            .replace(&format!(r#""id":"{id}""#), &format!(r#""id":{id}"#))
    };
    let text = collection(&[
        feature_num(1, r#"{"height":10}"#, SQUARE),
        feature("1", r#"{"height":10}"#, &moved),
        feature_num(2, r#"{"height":10,"name":"a"}"#, SQUARE),
        feature("2", r#"{"height":10,"name":"b","roof":"flat"}"#, SQUARE),
    ]);
    assert!(text.contains(r#""id":1,"#) && text.contains(r#""id":"1","#));
    let out = ingest(
        &[write(&dir, "ids.geojson", &text)],
        &IngestOptions::default(),
    )
    .unwrap();
    let r = &out.report;
    // Other footprints: both written, the shared id counted.
    let ids: Vec<&str> = out.buildings.iter().map(|b| b.source_id.as_str()).collect();
    assert_eq!(ids, ["1", "1", "2"]);
    assert_eq!(r.duplicate_ids, 1);
    // The same footprint and height: written once, and the attributes not written are named.
    assert_eq!(r.skipped.len(), 1);
    assert_eq!(
        (r.skipped[0].feature_id.as_str(), r.skipped[0].reason),
        ("2", IssueReason::Duplicate)
    );
    assert!(
        r.skipped[0]
            .detail
            .ends_with("written once; its differing attributes are not written: name, roof"),
        "{}",
        r.skipped[0].detail
    );
}

#[test]
fn a_crs_member_not_understood_is_an_error_unless_crs_is_given() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        r#"{{"type":"FeatureCollection","crs":{{"type":"link","properties":{{"href":"http://e/4326.wkt","type":"ogcwkt"}}}},"features":[{}]}}"#,
        feature("a", "{}", SQUARE)
    );
    let p = write(&dir, "link.geojson", &text);
    let e = ingest(std::slice::from_ref(&p), &IngestOptions::default()).unwrap_err();
    assert!(
        matches!(&e, IngestError::CrsNotUnderstood { path, member: "crs", .. } if path.ends_with("link.geojson")),
        "{e}"
    );
    assert!(e.to_string().contains("--crs"), "{e}");
    // The user's CRS replaces whatever the file declares.
    let opts = IngestOptions {
        crs: Some("EPSG:4326".into()),
        ..Default::default()
    };
    let out = ingest(&[p], &opts).unwrap();
    assert_eq!(out.report.buildings_written, 1);
    assert_eq!(out.report.files[0].crs, "EPSG:4326");
    // ... and says so: a declaration --crs overrode is in the file's notes.
    assert!(
        out.report.files[0]
            .notes
            .iter()
            .any(|n| n.starts_with("the file declares crs; --crs EPSG:4326")),
        "{:?}",
        out.report.files[0].notes
    );
}

#[test]
fn geojson_text_sequences_and_newline_delimited_geojson_are_read() {
    // ogr2ogr -f GeoJSONSeq writes RFC 8142 (an RS before each feature); many tools write one feature a line.
    let dir = tempfile::tempdir().unwrap();
    let a = feature("a", r#"{"height":12}"#, SQUARE);
    let b = feature("b", "{}", &square_further_east());
    let broken = r#"{"type":"Feature","id":"c","geometry":"#;
    for (name, text) in [
        ("lines.geojsonl", format!("{a}\n\n{b}\n{broken}\n")),
        (
            "rs.geojsons",
            format!("\u{1e}{a}\n\u{1e}{b}\n\u{1e}{broken}\n"),
        ),
        ("lines.jsonl", format!("{a}\n{b}\n{broken}")),
    ] {
        let out = ingest(&[write(&dir, name, &text)], &IngestOptions::default()).unwrap();
        let ids: Vec<&str> = out.buildings.iter().map(|b| b.source_id.as_str()).collect();
        assert_eq!(ids, ["a", "b"], "{name}");
        assert_eq!(out.buildings[0].height_m, 12.0, "{name}");
        assert_eq!(out.report.features_read, 3, "{name}");
        assert_eq!(out.report.skipped.len(), 1, "{name}");
        assert!(
            out.report.skipped[0].feature_id.ends_with("#2"),
            "{name}: {:?}",
            out.report.skipped
        );
    }
}

#[test]
fn z_values_in_geojson_coordinates_are_noted_as_not_used() {
    let dir = tempfile::tempdir().unwrap();
    let with_z = SQUARE.replace("4.36,52.0]", "4.36,52.0,5.5]");
    let zero_z = SQUARE.replace("4.36,52.0]", "4.36,52.0,0]");
    let text = collection(&[
        feature("z", "{}", &with_z),
        feature("zero", "{}", &zero_z),
        feature("flat", "{}", SQUARE),
    ]);
    let out = ingest(
        &[write(&dir, "z.geojson", &text)],
        &IngestOptions::default(),
    )
    .unwrap();
    assert_eq!(out.report.buildings_written, 3);
    assert!(out.buildings.iter().all(|b| b.base_z_m == 0.0));
    let notes = &out.report.files[0].notes;
    assert!(
        notes.len() == 1
            && notes[0]
                .starts_with("1 feature(s) have z values in their coordinates, which are not used"),
        "{notes:?}"
    );
    let text = collection(&[feature("flat", "{}", SQUARE)]);
    let out = ingest(
        &[write(&dir, "flat.geojson", &text)],
        &IngestOptions::default(),
    )
    .unwrap();
    assert!(out.report.files[0].notes.is_empty());
}

#[test]
fn crs_over_a_declared_crs_is_noted_unless_they_agree() {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"{"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::28992"}},
        "features":[{"type":"Feature","id":"b","properties":{},"geometry":{"type":"Polygon",
        "coordinates":[[[85000,446000],[85010,446000],[85010,446010],[85000,446010],[85000,446000]]]}}]}"#;
    let p = write(&dir, "rd.geojson", text);
    let with = |crs: &str| {
        let opts = IngestOptions {
            crs: Some(crs.into()),
            ..Default::default()
        };
        ingest(std::slice::from_ref(&p), &opts)
            .unwrap()
            .report
            .files[0]
            .notes
            .clone()
    };
    assert!(with("EPSG:28992").is_empty());
    let notes = with("EPSG:2263");
    assert!(
        notes
            .iter()
            .any(|n| n.contains("the file declares urn:ogc:def:crs:EPSG::28992; --crs EPSG:2263")),
        "{notes:?}"
    );
}

#[test]
fn buildings_below_the_ground_are_skipped_as_underground() {
    let dir = tempfile::tempdir().unwrap();
    let east = square_further_east();
    let text = collection(&[
        feature(
            "car_park",
            r#"{"building":"parking","location":"underground"}"#,
            SQUARE,
        ),
        feature("overture", r#"{"is_underground":true,"height":6}"#, SQUARE),
        feature("gdal", r#"{"is_underground":"True"}"#, SQUARE),
        feature("above", r#"{"is_underground":false,"height":6}"#, &east),
        feature("street", r#"{"location":"Underground Lane 3"}"#, &east),
    ]);
    let out = ingest(
        &[write(&dir, "below.geojson", &text)],
        &IngestOptions::default(),
    )
    .unwrap();
    out.report.check_invariants().unwrap();
    let written: Vec<&str> = out.buildings.iter().map(|b| b.source_id.as_str()).collect();
    assert_eq!(written, ["above", "street"]);
    for id in ["car_park", "overture", "gdal"] {
        assert_eq!(reason_of(&out, id), Some(IssueReason::Underground), "{id}");
    }
    assert_eq!(out.report.skipped_by_reason["underground"], 3);
    // Nothing below the ground sets the frame: it is placed over what is drawn.
    assert!(
        (out.frame.origin_lon_deg - 4.37005).abs() < 1e-4,
        "{:?}",
        out.frame
    );
}

/// Test data of the format tests, under `crates/citylod-ingest/tests`.
fn fixture(rel: &str) -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join(rel)
}

/// The format a file copied under `name` is read as, with `opts`.
fn read_renamed(
    from: &std::path::Path,
    name: &str,
    opts: &IngestOptions,
) -> Result<citylod_ingest::InputFormat, IngestError> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::copy(from, &p).unwrap();
    ingest(std::slice::from_ref(&p), opts).map(|out| out.report.files[0].format)
}

#[test]
fn formats_are_told_by_content_without_their_extension() {
    use citylod_ingest::InputFormat;
    let none = IngestOptions::default();
    // A PBF built by the test data generator, renamed as a download is.
    let pbf = {
        use citylod_testdata::osm_pbf::{tags, write_pbf, Node, OsmData, PbfOptions, Way};
        let dir = tempfile::tempdir().unwrap();
        let named = dir.path().join("named.osm.pbf");
        let corners = [
            (4.36, 52.0),
            (4.3601, 52.0),
            (4.3601, 52.0001),
            (4.36, 52.0001),
        ];
        let data = OsmData {
            nodes: (1..)
                .zip(corners)
                .map(|(id, (lon, lat))| Node {
                    id,
                    lon,
                    lat,
                    tags: vec![],
                })
                .collect(),
            ways: vec![Way {
                id: 10,
                refs: vec![1, 2, 3, 4, 1],
                tags: tags(&[("building", "yes")]),
            }],
            relations: vec![],
        };
        std::fs::write(&named, write_pbf(&data, &PbfOptions::default())).unwrap();
        read_renamed(&named, "download", &none)
    };
    assert_eq!(pbf.unwrap(), InputFormat::OsmPbf);
    assert_eq!(
        read_renamed(&fixture("osm/les_osmium.osm.gz"), "extract.gz", &none).unwrap(),
        InputFormat::OsmXml
    );
    let layer = IngestOptions {
        layer: Some("buildings".into()),
        ..Default::default()
    };
    assert_eq!(
        read_renamed(&fixture("geopackage/les_gdal.gpkg"), "one.sqlite", &layer).unwrap(),
        InputFormat::GeoPackage
    );
    assert_eq!(
        read_renamed(&fixture("fgdb/nyc-les-2263.gdb.zip"), "gdbzip_noext", &none).unwrap(),
        InputFormat::FileGeodatabase
    );
    // Named as they are, they read as before.
    assert_eq!(
        read_renamed(&fixture("geopackage/les_gdal.gpkg"), "les.gpkg", &layer).unwrap(),
        InputFormat::GeoPackage
    );
    assert_eq!(
        read_renamed(&fixture("osm/les_osmium.osm.gz"), "les.osm.gz", &none).unwrap(),
        InputFormat::OsmXml
    );
}

#[test]
fn an_sqlite_database_or_zip_of_no_format_read_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("plain.sqlite");
    let conn = rusqlite::Connection::open(&db).unwrap();
    conn.execute_batch("CREATE TABLE t (a INTEGER); INSERT INTO t VALUES (1);")
        .unwrap();
    drop(conn);
    match ingest(&[db], &IngestOptions::default()) {
        Err(IngestError::UnknownFormat { detail, .. }) => {
            assert!(
                detail.contains("an SQLite database, but not a GeoPackage"),
                "{detail}"
            )
        }
        other => panic!("{other:?}"),
    }
    let zip = dir.path().join("archive");
    std::fs::copy(fixture("fgdb/none.zip"), &zip).unwrap();
    let err = ingest(&[zip], &IngestOptions::default()).unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(err, IngestError::UnknownFormat { .. })
            && text.contains("a ZIP archive holding neither a File Geodatabase"),
        "{text}"
    );
}

#[test]
fn an_ordinary_folder_as_input_says_to_give_the_files_inside_it() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("tiles");
    std::fs::create_dir(&folder).unwrap();
    std::fs::write(folder.join("a.gml"), "<x/>").unwrap();
    std::fs::write(folder.join("b.gml"), "<x/>").unwrap();
    std::fs::write(folder.join("c.json"), "{}").unwrap();
    match ingest(std::slice::from_ref(&folder), &IngestOptions::default()) {
        Err(IngestError::Read { source, .. }) => {
            let text = source.to_string();
            assert!(
                text.contains(
                    "is a folder; citylod reads files (or a File Geodatabase .gdb folder)"
                ) && text.ends_with(&format!("e.g. {}", folder.join("*.gml").display())),
                "{text}"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_sound_geopackage_that_needs_a_layer_is_not_called_invalid() {
    let gpkg = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/geopackage/les_gdal.gpkg");
    // Two feature tables and no --layer: what to do, not "invalid GeoPackage".
    let e = ingest(std::slice::from_ref(&gpkg), &IngestOptions::default()).unwrap_err();
    let text = full_text(&e);
    assert!(
        text.contains(
            "les_gdal.gpkg: it holds 2 feature tables; name the one to read with --layer (feature tables: \
             buildings (MULTIPOLYGON), roads (LINESTRING))"
        ),
        "{text}"
    );
    assert!(!text.contains("invalid GeoPackage"), "{text}");
    // A layer that is not there.
    let opts = IngestOptions {
        layer: Some("nope".into()),
        ..IngestOptions::default()
    };
    let text = full_text(&ingest(std::slice::from_ref(&gpkg), &opts).unwrap_err());
    assert!(
        text.contains("les_gdal.gpkg: no feature table \"nope\" (its feature tables: buildings"),
        "{text}"
    );
    assert!(!text.contains("invalid GeoPackage"), "{text}");
    // A damaged file still is.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("damaged.gpkg");
    std::fs::write(&p, b"SQLite format 3\0\x10\x00").unwrap();
    let text = full_text(&ingest(std::slice::from_ref(&p), &IngestOptions::default()).unwrap_err());
    assert!(
        text.contains("damaged.gpkg: invalid GeoPackage: "),
        "{text}"
    );
}

#[test]
fn a_streets_layer_for_a_file_without_layers_names_both_formats_that_have_them() {
    let dir = tempfile::tempdir().unwrap();
    let roads = write(
        &dir,
        "roads.geojson",
        r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"LineString","coordinates":[[4.36,52.0],[4.361,52.0]]}}]}"#,
    );
    let frame = citylod_model::LocalFrame::new(4.36, 52.0, 0.0);
    let e = citylod_ingest::read_streets(&roads, None, Some("foo"), None, &frame).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains(
            "which has no layers (a GeoPackage's feature tables and a File Geodatabase's feature classes are \
             chosen with it)"
        ),
        "{text}"
    );
}

#[test]
fn a_zip_archive_cut_short_is_called_so_not_no_zip() {
    let dir = tempfile::tempdir().unwrap();
    // A stored member, then nothing: the local header is there, the central directory is not.
    let mut cut = b"PK\x03\x04\x14\x00\x00\x00\x00\x00".to_vec();
    cut.extend(std::iter::repeat_n(0u8, 200));
    for name in ["cut.zip", "cut.gdb.zip"] {
        let p = dir.path().join(name);
        std::fs::write(&p, &cut).unwrap();
        let text =
            full_text(&ingest(std::slice::from_ref(&p), &IngestOptions::default()).unwrap_err());
        assert!(
            text.contains(
                "a ZIP archive cut short or damaged: it begins as one, but the central directory at its end is \
                 missing"
            ),
            "{name}: {text}"
        );
        assert!(!text.contains("not a ZIP archive"), "{name}: {text}");
    }
}
