//! CityJSON and CityJSONSeq objects end to end through `ingest`, on the small files in `tests/cityjson/`
//! (each a 10 m × 10 m box at Delft in EPSG:7415 unless named otherwise): every Building is written or skipped
//! once, a part beside its building widens the footprint, a roof edge is no footprint, and what the reader
//! cannot read unambiguously is an error naming it (a document) or a skip naming it (a line of a sequence).

use citylod_ingest::{ingest, IngestError, IngestOptions, Ingested, IssueReason};
use geo::Area;
use std::path::PathBuf;

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/cityjson")
        .join(name)
}

fn read(name: &str) -> Result<Ingested, IngestError> {
    ingest(&[path(name)], &IngestOptions::default())
}

/// The written buildings' source ids and footprint areas (m²), by id.
fn written(out: &Ingested) -> Vec<(String, f64)> {
    assert_eq!(out.report.check_invariants(), Ok(()));
    let mut b: Vec<(String, f64)> = out
        .buildings
        .iter()
        .map(|b| (b.source_id.clone(), b.footprint.unsigned_area()))
        .collect();
    b.sort_by(|x, y| x.0.cmp(&y.0));
    b
}

fn assert_areas(out: &Ingested, expected: &[(&str, f64)]) {
    let got = written(out);
    assert_eq!(got.len(), expected.len(), "{got:?}");
    for ((id, area), (want_id, want_area)) in got.iter().zip(expected) {
        assert_eq!(id, want_id);
        assert!(
            (area - want_area).abs() < 0.5,
            "{id}: {area} m², not {want_area}"
        );
    }
}

#[test]
fn a_building_nested_in_another_or_in_a_cycle_is_a_building_of_its_own() {
    for name in ["nested-building.city.json", "building-cycle.city.json"] {
        let out = read(name).unwrap();
        assert_eq!(out.report.features_read, 2, "{name}");
        assert!(out.report.skipped.is_empty(), "{name}");
        assert_areas(&out, &[("B1", 100.0), ("B2", 100.0)]);
    }
}

#[test]
fn a_part_is_read_once_whatever_the_order_of_its_objects() {
    // P2 is a part of P1, P1 a part of a Building that is missing; P2 comes first in the file. P1 is the building,
    // P2 its part: before, P2 was also a building of its own, drawn twice.
    let out = read("orphan-part-child-first.city.json").unwrap();
    assert_eq!(out.report.features_read, 1);
    assert_areas(&out, &[("P1", 200.0)]);
    // A part listed by two buildings is read with the first of them only (else its footprint twice).
    let out = read("part-of-two-buildings.city.json").unwrap();
    assert_eq!(out.report.features_read, 2);
    assert_areas(&out, &[("A", 200.0), ("B", 100.0)]);
}

#[test]
fn a_part_beside_its_building_widens_the_footprint() {
    let out = read("annex-part.city.json").unwrap();
    assert_areas(&out, &[("B1", 200.0)]);
    // The building is 10 m high, its annex 4 m: the top over both.
    assert!((out.buildings[0].height_m - 10.0).abs() < 1e-6);
}

#[test]
fn a_lod0_roof_edge_is_not_the_footprint() {
    // The roof edge overhangs the 10 m box by 1 m on every side, at z = 10 m.
    for name in [
        "lod0-roof-edge.city.json",
        "lod0-ground-and-roof-edge.city.json",
    ] {
        let out = read(name).unwrap();
        assert_eq!(out.buildings.len(), 1, "{name}");
        assert!((out.buildings[0].footprint.unsigned_area() - 100.0).abs() < 0.5);
        assert!((out.buildings[0].height_m - 10.0).abs() < 1e-6, "{name}");
    }
}

#[test]
fn cityjson_before_1_1_needs_no_transform_and_1_1_does() {
    let out = read("v0.9-no-transform.city.json").unwrap();
    assert_areas(&out, &[("B1", 100.0), ("B2", 100.0)]);
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(path("v0.9-no-transform.city.json")).unwrap();
    let v11 = dir.path().join("v1.1.city.json");
    std::fs::write(
        &v11,
        text.replace(r#""version": "0.9""#, r#""version": "1.1""#),
    )
    .unwrap();
    let e = ingest(&[v11], &IngestOptions::default()).unwrap_err();
    assert!(matches!(e, IngestError::InvalidCityJson { .. }), "{e}");
    assert!(e.to_string().contains("transform"), "{e}");
}

#[test]
fn buildings_in_a_sequence_header_are_read_with_the_lines() {
    let out = read("header-objects.city.jsonl").unwrap();
    assert_eq!(out.report.features_read, 2);
    assert_areas(&out, &[("A", 100.0), ("H", 100.0)]);
}

#[test]
fn an_id_given_twice_in_a_sequence_line_skips_that_line_naming_it() {
    // Line 2 gives "A" twice (which is meant?); line 3's building is read.
    let out = read("repeated-id-in-a-line.city.jsonl").unwrap();
    assert_areas(&out, &[("B", 100.0)]);
    let [skip] = &out.report.skipped[..] else {
        panic!("{:?}", out.report.skipped)
    };
    assert_eq!(skip.feature_id, "A");
    assert_eq!(skip.reason, IssueReason::DuplicateKey);
    assert!(
        skip.detail.starts_with("line 2, ") && skip.detail.contains(r#"CityObjects id "A""#),
        "{}",
        skip.detail
    );
}

#[test]
fn a_member_given_twice_in_a_document_is_an_error_naming_it() {
    // B1's "type" is given twice ("Building", then "BuildingPart"): a JSON reader would keep the second unseen.
    let e = read("repeated-key-in-document.city.json").unwrap_err();
    let message = e.to_string();
    assert!(
        matches!(e, IngestError::InvalidCityJson { .. }),
        "{message}"
    );
    assert!(
        message.contains(r#"CityObjects "B1""#) && message.contains("duplicate field `type`"),
        "{message}"
    );
}
