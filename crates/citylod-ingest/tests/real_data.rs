//! Ingest of the real data sets in ../shared/data (see its README): counts, skip reasons, heights
//! and placement on the globe. Each test skips with a message when the data folder is absent.

use citylod_ingest::{check_footprint, ingest, IngestOptions, IssueReason};
use citylod_model::HeightSource;
use std::path::PathBuf;

fn data(rel: &str) -> Option<PathBuf> {
    let p = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/"
    ))
    .join(rel);
    if p.exists() {
        Some(p)
    } else {
        eprintln!(
            "skipping: {} not found (real data lives in ../shared/data)",
            p.display()
        );
        None
    }
}

fn lon_lat_of(out: &citylod_ingest::Ingested, b: &citylod_model::Building) -> (f64, f64) {
    let c = &b.footprint.0[0].exterior().0[0];
    let g = out.frame.enu_to_geodetic([c.x, c.y, b.base_z_m]);
    (g[0], g[1])
}

#[test]
fn boston_every_feature_is_written_or_skipped_with_a_real_reason() {
    let Some(path) = data("boston/boston_buildings.geojson") else {
        return;
    };
    let opts = IngestOptions {
        storey_height_m: 3.5,
        ..Default::default()
    };
    let out = ingest(std::slice::from_ref(&path), &opts).unwrap();
    let r = &out.report;
    eprintln!(
        "boston: {}",
        serde_json::to_string_pretty(&(
            &r.skipped_by_reason,
            &r.repaired_by_reason,
            &r.height_sources,
            r.rings_reoriented
        ))
        .unwrap()
    );
    assert_eq!(r.features_read, 22_186);
    r.check_invariants().unwrap();
    assert_eq!(out.buildings.len(), r.buildings_written);
    for (i, b) in out.buildings.iter().enumerate() {
        assert_eq!(b.id.0 as usize, i);
        check_footprint(&b.footprint).unwrap_or_else(|e| panic!("{}: {e}", b.source_id));
        assert!(b.height_m > 0.0 && b.height_m <= 1000.0);
    }
    // Boston has `stories` for most buildings and nothing else.
    assert!(
        r.height_sources["storeys"] > 15_000,
        "{:?}",
        r.height_sources
    );
    assert!(r.height_sources["default"] > 1_000);
    // The README says 8 polygons are self-touching: they must show up as repaired, not lost.
    assert!(
        r.repaired_by_reason
            .get("self_intersection")
            .copied()
            .unwrap_or(0)
            >= 8,
        "{:?}",
        r.repaired_by_reason
    );
    // Every skip is backed by the source: read the feature back and show it is degenerate.
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    // Polygons with holes keep them (47 features in the file; a rebuilt self-touching ring may add one).
    let in_file = doc["features"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["geometry"]["coordinates"].as_array().unwrap().len() > 1)
        .count();
    let with_holes = out
        .buildings
        .iter()
        .filter(|b| b.footprint.0.iter().any(|p| !p.interiors().is_empty()))
        .count();
    assert!(
        in_file > 40 && with_holes >= in_file,
        "{with_holes} buildings with holes, {in_file} in the file"
    );
    let by_id: std::collections::HashMap<String, &serde_json::Value> = doc["features"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| (f["id"].to_string(), f))
        .collect();
    for s in &r.skipped {
        let f = by_id[&s.feature_id];
        let ring: Vec<(f64, f64)> = f["geometry"]["coordinates"][0]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| (p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
            .collect();
        let mut distinct = ring.clone();
        distinct.sort_by(|a, b| a.partial_cmp(b).unwrap());
        distinct.dedup();
        let twice_area_deg2: f64 = ring
            .windows(2)
            .map(|w| w[0].0 * w[1].1 - w[1].0 * w[0].1)
            .sum();
        // 0.01 m² ≈ 1.5e-12 deg² at 42°N; allow the multi-part/hole case a generous margin.
        match s.reason {
            IssueReason::TooFewPoints => assert!(distinct.len() < 3, "{s:?}"),
            IssueReason::ZeroArea => assert!(
                twice_area_deg2.abs() / 2.0 < 1e-10,
                "{s:?} area {twice_area_deg2}"
            ),
            other => panic!("unexpected skip reason {other:?} for {s:?}"),
        }
    }
}

#[test]
fn boston_building_round_trips_lon_lat_to_enu_within_a_centimetre() {
    let Some(path) = data("boston/boston_buildings.geojson") else {
        return;
    };
    let out = ingest(&[path], &IngestOptions::default()).unwrap();
    // Feature id 0, first vertex (-71.066721, 42.35798) as written in the file.
    let b = out.buildings.iter().find(|b| b.source_id == "0").unwrap();
    let (lon0, lat0) = (-71.066721, 42.35798);
    let best_m = b.footprint.0[0]
        .exterior()
        .0
        .iter()
        .map(|c| {
            let g = out.frame.enu_to_geodetic([c.x, c.y, b.base_z_m]);
            let dn = (g[1] - lat0) * 111_100.0;
            let de = (g[0] - lon0) * 111_100.0 * lat0.to_radians().cos();
            (dn * dn + de * de).sqrt()
        })
        .fold(f64::INFINITY, f64::min);
    assert!(best_m < 0.01, "closest vertex {best_m} m away");
    // The frame is at the centre of Boston's extent and all of it is within ~5 km.
    assert!(
        (out.frame.origin_lon_deg + 71.07).abs() < 0.05
            && (out.frame.origin_lat_deg - 42.35).abs() < 0.05
    );
    assert!(out
        .buildings
        .iter()
        .all(|b| b.footprint.0[0].exterior().0[0].x.abs() < 6000.0));
}

#[test]
fn nyc_osm_features_keep_parts_and_parse_string_heights() {
    let Some(path) = data("nyc-les/les_buildings.geojson") else {
        return;
    };
    let out = ingest(&[path], &IngestOptions::default()).unwrap();
    let r = &out.report;
    eprintln!(
        "nyc: {}",
        serde_json::to_string_pretty(&(
            &r.skipped,
            &r.repaired_by_reason,
            &r.height_sources,
            r.building_parts,
            r.min_height_bases,
            &r.height_values_rejected
        ))
        .unwrap()
    );
    assert_eq!(r.features_read, 1_416);
    r.check_invariants().unwrap();
    // building:part features are kept as buildings and counted.
    assert!(
        r.building_parts >= 120 && r.building_parts <= 132,
        "{}",
        r.building_parts
    );
    assert!(
        r.height_sources["known_attribute"] >= 1_300,
        "{:?}",
        r.height_sources
    );
    let holiday_inn = out
        .buildings
        .iter()
        .find(|b| b.source_id == "way/110")
        .unwrap();
    assert_eq!(
        (holiday_inn.height_m, holiday_inn.height_source),
        (28.0, HeightSource::KnownAttribute)
    );
    assert!(r.min_height_bases > 0);
    let (lon, lat) = lon_lat_of(&out, holiday_inn);
    assert!(
        (lon + 73.986).abs() < 0.001 && (lat - 40.718).abs() < 0.001,
        "{lon} {lat}"
    );
}

#[test]
fn delft_3dbag_sequence_gives_every_building_in_delft() {
    let Some(path) = data("delft-3dbag/delft.city.jsonl") else {
        return;
    };
    let out = ingest(&[path], &IngestOptions::default()).unwrap();
    let r = &out.report;
    eprintln!(
        "delft: {}",
        serde_json::to_string_pretty(&(
            &r.skipped,
            &r.repaired_by_reason,
            &r.height_sources,
            &r.ground_sources,
            &r.files
        ))
        .unwrap()
    );
    assert_eq!(r.features_read, 1_115, "BuildingParts are not buildings");
    r.check_invariants().unwrap();
    assert!(r.files[0].crs.contains("28992"));
    // 3DBAG roof − ground for (almost) all; ground from b3_h_maaiveld.
    assert!(
        r.height_sources
            .get("roof_minus_ground")
            .copied()
            .unwrap_or(0)
            >= 1_000,
        "{:?}",
        r.height_sources
    );
    assert!(r.ground_sources["b3_h_maaiveld"] >= 1_000);
    for b in &out.buildings {
        check_footprint(&b.footprint).unwrap_or_else(|e| panic!("{}: {e}", b.source_id));
        let (lon, lat) = lon_lat_of(&out, b);
        assert!(
            (4.33..4.39).contains(&lon) && (51.98..52.03).contains(&lat),
            "{} at {lon} {lat}",
            b.source_id
        );
    }
    // Frame origin at the lowest maaiveld, which in Delft is around NAP −1 … −4 m.
    assert!(
        out.frame.origin_h_m < 0.0 && out.frame.origin_h_m > -10.0,
        "{}",
        out.frame.origin_h_m
    );
}

#[test]
fn denhaag_cityjson_08_needs_a_crs_then_gives_part_unions() {
    let Some(path) = data("denhaag-lod2/DenHaag_01.json") else {
        return;
    };
    let err = ingest(std::slice::from_ref(&path), &IngestOptions::default()).unwrap_err();
    assert!(
        matches!(err, citylod_ingest::IngestError::MissingCrs { .. }),
        "{err}"
    );
    let opts = IngestOptions {
        crs: Some("EPSG:28992".into()),
        ..Default::default()
    };
    let out = ingest(&[path], &opts).unwrap();
    let r = &out.report;
    eprintln!(
        "denhaag: {}",
        serde_json::to_string_pretty(&(
            &r.skipped_by_reason,
            &r.repaired_by_reason,
            &r.height_sources,
            &r.files
        ))
        .unwrap()
    );
    assert_eq!(r.features_read, 844);
    r.check_invariants().unwrap();
    assert!(r.buildings_written >= 800, "{}", r.buildings_written);
    assert!(
        r.height_sources["geometry"] >= 800,
        "{:?}",
        r.height_sources
    );
    for b in &out.buildings {
        check_footprint(&b.footprint).unwrap_or_else(|e| panic!("{}: {e}", b.source_id));
        let (lon, lat) = lon_lat_of(&out, b);
        // RD x 78 248–79 036, y 457 605–458 276: the north-west of Den Haag, ≈ 4.27E 52.10N.
        assert!(
            (4.25..4.32).contains(&lon) && (52.07..52.12).contains(&lat),
            "{} at {lon} {lat}",
            b.source_id
        );
    }
}

/// Boston's self-intersecting outlines are rebuilt by boolean operations whose output order varies from run to
/// run; the repaired footprints must still come out identical every time.
#[test]
fn boston_repairs_are_identical_across_runs() {
    let Some(path) = data("boston/boston_buildings.geojson") else {
        return;
    };
    let opts = IngestOptions {
        storey_height_m: 3.5,
        ..Default::default()
    };
    let first = ingest(std::slice::from_ref(&path), &opts).unwrap();
    assert!(
        first
            .report
            .repaired_by_reason
            .get("self_intersection")
            .copied()
            .unwrap_or(0)
            >= 8
    );
    for _ in 0..3 {
        let again = ingest(std::slice::from_ref(&path), &opts).unwrap();
        let differing: Vec<&str> = first
            .buildings
            .iter()
            .zip(&again.buildings)
            .filter(|(a, b)| a.footprint != b.footprint)
            .map(|(a, _)| a.source_id.as_str())
            .collect();
        assert!(
            differing.is_empty(),
            "footprints differ between two runs: {differing:?}"
        );
    }
}
