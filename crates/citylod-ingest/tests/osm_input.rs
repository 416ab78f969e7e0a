//! OpenStreetMap input. PBF: the bundled Lower East Side file against the GeoJSON exported from it, and files written
//! by the test writer in every encoding the format allows, with broken buildings, broken files and mutations. XML:
//! the same extract as libosmium writes it against the PBF, and what JOSM and the Overpass API write.

use citylod_ingest::{ingest, read_streets, IngestError, IngestOptions, Ingested, IssueReason};
use citylod_model::{AttrValue, LocalFrame};
use citylod_testdata::osm_pbf::{tags, write_pbf, Node, OsmData, PbfOptions, Relation, Way};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A scratch folder under the build's own temporary folder (target/tmp), emptied first: one per test name, so
/// repeated runs leave nothing behind in the system's /tmp.
fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("citylod-osm-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn read(path: &Path) -> Result<Ingested, IngestError> {
    ingest(&[path.to_path_buf()], &IngestOptions::default())
}

/// (lon°, lat°) of every footprint vertex of a building (closing points left out), sorted.
fn vertices(out: &Ingested, b: &citylod_model::Building) -> Vec<[f64; 2]> {
    let mut v: Vec<[f64; 2]> = b
        .footprint
        .0
        .iter()
        .flat_map(|p| std::iter::once(p.exterior()).chain(p.interiors()))
        .flat_map(|r| r.0[1..].iter())
        .map(|c| {
            let g = out.frame.enu_to_geodetic([c.x, c.y, b.base_z_m]);
            [g[0], g[1]]
        })
        .collect();
    v.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    v
}

fn area_m2(b: &citylod_model::Building) -> f64 {
    use geo::Area;
    b.footprint.unsigned_area()
}

#[test]
fn the_lower_east_side_file_gives_the_buildings_of_its_geojson_export() {
    let dir = repo_root().join("examples/nyc-les");
    let pbf = read(&dir.join("ny-access-restriction.osm.pbf")).unwrap();
    let geojson = read(&dir.join("les_buildings.geojson")).unwrap();
    let r = &pbf.report;
    r.check_invariants().unwrap();
    assert_eq!(r.files[0].format, citylod_ingest::InputFormat::OsmPbf);
    let from_pbf: BTreeMap<&str, &citylod_model::Building> = pbf
        .buildings
        .iter()
        .map(|b| (b.source_id.as_str(), b))
        .collect();
    assert_eq!(from_pbf.len(), pbf.buildings.len(), "ids are unique");
    // Every building of the export, with its tags, heights and outline.
    for g in &geojson.buildings {
        let p = from_pbf
            .get(g.source_id.as_str())
            .unwrap_or_else(|| panic!("{} is not read from the PBF", g.source_id));
        // The export kept a selection of the tags (building, heights, levels, roof shape, name): each as here.
        for (k, v) in g.attributes.iter() {
            assert_eq!(p.attributes.get(k), Some(v), "{}: {k}", g.source_id);
        }
        assert_eq!(
            (p.height_m, p.height_source),
            (g.height_m, g.height_source),
            "{}",
            g.source_id
        );
        // The base (a frame's curvature drop) within a micrometre: the two frames are 1,403 and 1,407 buildings'.
        assert!((p.base_z_m - g.base_z_m).abs() < 1e-6, "{}", g.source_id);
        let (a, b) = (vertices(&pbf, p), vertices(&geojson, g));
        assert_eq!(a.len(), b.len(), "{}", g.source_id);
        for (a, b) in a.iter().zip(&b) {
            assert!(
                (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9,
                "{}: {a:?} against {b:?}",
                g.source_id
            );
        }
        let (pa, ga) = (area_m2(p), area_m2(g));
        assert!(
            (pa - ga).abs() <= 1e-6 * ga,
            "{}: {pa} m² against {ga} m²",
            g.source_id
        );
        assert_eq!(
            p.footprint
                .0
                .iter()
                .map(|q| q.interiors().len())
                .collect::<Vec<_>>(),
            g.footprint
                .0
                .iter()
                .map(|q| q.interiors().len())
                .collect::<Vec<_>>(),
            "{}",
            g.source_id
        );
    }
    // The export left out four self-intersecting outlines (osmium makes no area of them): here they are repaired.
    let extra: Vec<&str> = from_pbf
        .keys()
        .copied()
        .filter(|id| !geojson.buildings.iter().any(|g| g.source_id == *id))
        .collect();
    assert_eq!(extra, ["way/1216", "way/264", "way/328", "way/847"]);
    for id in &extra {
        assert!(
            r.repaired
                .iter()
                .any(|i| i.feature_id == *id && i.reason == IssueReason::SelfIntersection),
            "{id}"
        );
    }
    assert_eq!(r.building_parts, geojson.report.building_parts);
    // Everything else tagged as a building is listed with its reason: ways the extract cut open or down to a few
    // nodes, one building mapped as a point, a relation whose member way was cut to 2 nodes.
    assert_eq!(r.features_read, 1499);
    assert_eq!(r.features_read, r.buildings_written + r.skipped.len());
    let by_reason = |reason| r.skipped.iter().filter(|s| s.reason == reason).count();
    assert_eq!(by_reason(IssueReason::MalformedGeometry), 45);
    assert_eq!(by_reason(IssueReason::TooFewPoints), 33);
    assert_eq!(by_reason(IssueReason::UnsupportedGeometry), 1);
    // The outlines with building:parts inside, as in the export's.
    assert_eq!(by_reason(IssueReason::DrawnByParts), 13);
    assert!(r.skipped.iter().all(|s| s.feature_id.starts_with("way/")
        || s.feature_id == "node/11192"
        || s.feature_id == "relation/29"));
    // A multipolygon relation keeps its holes.
    let courtyard = from_pbf["relation/35"];
    assert_eq!(courtyard.footprint.0[0].interiors().len(), 2);
}

#[test]
fn the_lower_east_side_streets_are_its_highway_ways() {
    let pbf = repo_root().join("examples/nyc-les/ny-access-restriction.osm.pbf");
    let frame = LocalFrame::new(-73.99, 40.72, 0.0);
    let s = read_streets(&pbf, None, None, None, &frame).unwrap();
    let r = &s.report;
    assert_eq!(r.features_read, r.features_used + r.skipped.len());
    assert_eq!((r.features_read, r.features_used), (463, 430));
    // The skipped ones are ways the extract cut down to one node.
    assert!(r
        .skipped
        .iter()
        .all(|i| i.reason == IssueReason::TooFewPoints && i.feature_id.starts_with("way/")));
    // The GeoJSON export of the same area's roads: 32.7 km.
    assert!((30_000.0..33_000.0).contains(&r.length_m), "{}", r.length_m);
    let roads = repo_root().join("examples/nyc-les/les_roads.geojson");
    let g = read_streets(&roads, None, None, None, &frame).unwrap();
    // Nearly every road segment of the export lies on a PBF street: its midpoint within 1 m of one.
    let near = |m: [f64; 2]| {
        s.segments.iter().any(|[a, b]| {
            let (d, e) = ([b[0] - a[0], b[1] - a[1]], [m[0] - a[0], m[1] - a[1]]);
            let t = ((d[0] * e[0] + d[1] * e[1]) / (d[0] * d[0] + d[1] * d[1]).max(1e-12))
                .clamp(0.0, 1.0);
            (e[0] - t * d[0]).hypot(e[1] - t * d[1]) < 1.0
        })
    };
    let on = g
        .segments
        .iter()
        .filter(|[a, b]| near([(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0]))
        .count();
    assert!(
        on * 100 >= g.segments.len() * 95,
        "{on} of {}",
        g.segments.len()
    );
    assert!(matches!(
        read_streets(&pbf, Some("EPSG:2263"), None, None, &frame),
        Err(IngestError::InvalidOption {
            name: "--streets-crs",
            ..
        })
    ));
}

/// A small town: a square house (way 10), a house with a courtyard as a multipolygon whose outer ring is two open
/// ways (relation 100: ways 20 + 21 outer, way 22 inner) and an island in the courtyard (way 23, role "outer"), a
/// building:part (way 11), a building node (node 90), a way not closed (12), a way with a node not in the file (13),
/// a multipolygon with a member way not in the file (101), a type=building relation (102), a multipolygon whose
/// ways do not close (103), an untagged way (14) and a street (way 30).
fn town() -> OsmData {
    let mut nodes = Vec::new();
    let mut node = |id: i64, lon: f64, lat: f64| {
        nodes.push(Node {
            id,
            lon,
            lat,
            tags: vec![],
        })
    };
    let (x, y) = (4.35, 52.01);
    let d = 0.0002;
    // The square house.
    node(1, x, y);
    node(2, x + d, y);
    node(3, x + d, y + d);
    node(4, x, y + d);
    // The courtyard house: outer 5..8, inner 9..12, island 13..16.
    let (cx, cy) = (x + 0.001, y);
    node(5, cx, cy);
    node(6, cx + 4.0 * d, cy);
    node(7, cx + 4.0 * d, cy + 4.0 * d);
    node(8, cx, cy + 4.0 * d);
    node(9, cx + d, cy + d);
    node(10, cx + 3.0 * d, cy + d);
    node(11, cx + 3.0 * d, cy + 3.0 * d);
    node(12, cx + d, cy + 3.0 * d);
    node(13, cx + 1.5 * d, cy + 1.5 * d);
    node(14, cx + 2.5 * d, cy + 1.5 * d);
    node(15, cx + 2.5 * d, cy + 2.5 * d);
    node(16, cx + 1.5 * d, cy + 2.5 * d);
    // The part, the open way, the way with a missing node.
    let (px, py) = (x, y + 0.001);
    node(17, px, py);
    node(18, px + d, py);
    node(19, px + d, py + d);
    node(20, px, py + d);
    // The street.
    node(21, x - d, y - d);
    node(22, x + 0.002, y - d);
    let mut d = OsmData {
        nodes,
        ..Default::default()
    };
    d.nodes.push(Node {
        id: 90,
        lon: x - d_of(),
        lat: y,
        tags: tags(&[("building", "yes"), ("name", "Kiosk")]),
    });
    let way = |id, refs: &[i64], t: &[(&str, &str)]| Way {
        id,
        refs: refs.to_vec(),
        tags: tags(t),
    };
    d.ways = vec![
        way(
            10,
            &[1, 2, 3, 4, 1],
            &[("building", "house"), ("height", "9"), ("name", "Huis")],
        ),
        way(
            11,
            &[17, 18, 19, 20, 17],
            &[("building:part", "yes"), ("building:levels", "3")],
        ),
        way(12, &[1, 2, 3], &[("building", "yes")]),
        way(13, &[17, 18, 999, 17], &[("building", "yes")]),
        way(14, &[1, 2, 3, 1], &[]),
        way(20, &[5, 6, 7], &[]),
        way(21, &[8, 7], &[]),
        way(22, &[9, 10, 11, 12, 9], &[]),
        way(23, &[13, 14, 15, 16, 13], &[]),
        way(24, &[5, 8], &[]),
        way(25, &[9, 10, 11], &[]),
        way(
            30,
            &[21, 22],
            &[("highway", "residential"), ("name", "Dorpsstraat")],
        ),
        way(31, &[21, 1], &[("highway", "proposed")]),
        way(32, &[22, 2], &[("highway", "service"), ("tunnel", "yes")]),
    ];
    let member = |t: char, id: i64, role: &str| (t, id, role.to_string());
    d.relations = vec![
        Relation {
            id: 100,
            members: vec![
                member('w', 20, "outer"),
                member('w', 21, "outer"),
                member('w', 24, "outer"),
                member('w', 22, "inner"),
                member('w', 23, "outer"),
                member('n', 1, "label"),
            ],
            tags: tags(&[
                ("type", "multipolygon"),
                ("building", "school"),
                ("roof:height", "2"),
            ]),
        },
        Relation {
            id: 101,
            members: vec![member('w', 20, "outer"), member('w', 777, "outer")],
            tags: tags(&[("type", "multipolygon"), ("building", "yes")]),
        },
        Relation {
            id: 102,
            members: vec![member('w', 10, "outline"), member('w', 11, "part")],
            tags: tags(&[("type", "building"), ("building", "yes")]),
        },
        Relation {
            id: 103,
            members: vec![member('w', 25, "outer")],
            tags: tags(&[("type", "multipolygon"), ("building", "yes")]),
        },
    ];
    d
}

fn d_of() -> f64 {
    0.0002
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// (id, area m², holes per polygon) of every building, and (id, reason) of every skip.
type Outcome = (Vec<(String, i64, Vec<usize>)>, Vec<(String, IssueReason)>);

fn outcome(out: &Ingested) -> Outcome {
    (
        out.buildings
            .iter()
            .map(|b| {
                (
                    b.source_id.clone(),
                    area_m2(b).round() as i64,
                    b.footprint.0.iter().map(|p| p.interiors().len()).collect(),
                )
            })
            .collect(),
        out.report
            .skipped
            .iter()
            .map(|s| (s.feature_id.clone(), s.reason))
            .collect(),
    )
}

#[test]
fn every_encoding_gives_the_same_buildings_and_skips() {
    let dir = scratch("encodings");
    let data = town();
    let plain = write(
        &dir,
        "town.osm.pbf",
        &write_pbf(&data, &PbfOptions::default()),
    );
    let out = read(&plain).unwrap();
    let (buildings, skips) = outcome(&out);
    let ids: Vec<&str> = buildings.iter().map(|b| b.0.as_str()).collect();
    assert_eq!(ids, ["way/10", "way/11", "relation/100"]);
    // The courtyard house: one polygon with its courtyard, and the island in it as a polygon of its own.
    let school = &buildings[2];
    let mut holes = school.2.clone();
    holes.sort();
    assert_eq!(holes, [0, 1], "{school:?}");
    let side = 4.0 * 0.0002 * 111_320.0;
    let expected = side * side * 52.01f64.to_radians().cos() * (1.0 - 0.25 + 0.0625);
    assert!(
        (school.1 as f64 - expected).abs() < 0.01 * expected,
        "{} against {expected}",
        school.1
    );
    assert_eq!(
        skips,
        [
            ("node/90".to_string(), IssueReason::UnsupportedGeometry),
            ("way/12".to_string(), IssueReason::MalformedGeometry),
            ("way/13".to_string(), IssueReason::IncompleteInExtract),
            ("relation/101".to_string(), IssueReason::IncompleteInExtract),
            ("relation/102".to_string(), IssueReason::UnsupportedGeometry),
            ("relation/103".to_string(), IssueReason::MalformedGeometry),
        ]
    );
    let detail = |id: &str| {
        out.report
            .skipped
            .iter()
            .find(|s| s.feature_id == id)
            .map(|s| s.detail.clone())
            .unwrap()
    };
    assert!(
        detail("way/13").contains("node 999"),
        "{}",
        detail("way/13")
    );
    assert!(
        detail("relation/101").contains("way 777"),
        "{}",
        detail("relation/101")
    );
    assert!(
        detail("way/12").contains("not closed"),
        "{}",
        detail("way/12")
    );
    // Tags are attributes, with the object's type and id; heights from them.
    let house = &out.buildings[0];
    assert_eq!(
        house.attributes.get("name"),
        Some(&AttrValue::String("Huis".into()))
    );
    assert_eq!(house.attributes.get("osm_id"), Some(&AttrValue::Int(10)));
    assert_eq!(house.height_m, 9.0);
    assert_eq!(out.buildings[1].height_m, 9.0, "3 levels of 3 m");
    assert_eq!(out.report.building_parts, 1);
    assert!(out.report.repaired.iter().any(
        |i| i.feature_id == "relation/100" && i.reason == IssueReason::NonPolygonMemberDropped
    ));

    for (name, o) in [
        (
            "plain nodes",
            PbfOptions {
                plain_nodes: true,
                ..Default::default()
            },
        ),
        (
            "raw blobs",
            PbfOptions {
                raw_blobs: true,
                ..Default::default()
            },
        ),
        (
            "unpacked",
            PbfOptions {
                unpacked: true,
                plain_nodes: true,
                ..Default::default()
            },
        ),
    ] {
        let p = write(&dir, &format!("{name}.osm.pbf"), &write_pbf(&data, &o));
        assert_eq!(
            outcome(&read(&p).unwrap()),
            (buildings.clone(), skips.clone()),
            "{name}"
        );
    }
    // The same data as OpenStreetMap XML, as the API writes it.
    let mut xml = Vec::new();
    citylod_testdata::osm_xml::write_xml(&data, &mut xml).unwrap();
    let p = write(&dir, "town.osm", &xml);
    assert_eq!(
        outcome(&read(&p).unwrap()),
        (buildings.clone(), skips.clone()),
        "XML"
    );
    // Locations on the ways and no node blob (the node building is then not in the file); the missing node is
    // an undefined location.
    let o = PbfOptions {
        locations_on_ways: true,
        ..Default::default()
    };
    let p = write(&dir, "on-ways.osm.pbf", &write_pbf(&data, &o));
    let on_ways = read(&p).unwrap();
    assert_eq!(outcome(&on_ways), (buildings.clone(), skips[1..].to_vec()));
    assert!(on_ways.report.files[0]
        .notes
        .iter()
        .any(|n| n.contains("LocationsOnWays")));

    // Streets: the residential street; the proposed one and the one in a tunnel are not streets.
    let frame = LocalFrame::new(4.35, 52.01, 0.0);
    let s = read_streets(&plain, None, None, None, &frame).unwrap();
    assert_eq!(
        (
            s.report.features_read,
            s.report.features_used,
            s.segments.len()
        ),
        (1, 1, 1)
    );
    assert!((s.report.length_m - 0.0022 * 111_320.0 * 52.01f64.to_radians().cos()).abs() < 1.0);
}

#[test]
fn broken_files_are_refused_with_the_reason() {
    let dir = scratch("broken");
    let good = write_pbf(&town(), &PbfOptions::default());
    let err = |name: &str, bytes: &[u8]| match read(&write(&dir, name, bytes)) {
        Err(IngestError::InvalidOsm { detail, .. }) => detail,
        other => panic!("{name}: {:?}", other.map(|o| o.report.buildings_written)),
    };
    assert!(
        err("json.pbf", b"{\"type\": \"FeatureCollection\"}").contains("not an OpenStreetMap PBF")
    );
    assert!(err("empty.osm.pbf", b"").contains("no OSMHeader"));
    assert!(err("cut.osm.pbf", &good[..good.len() - 7]).contains("cut short"));
    let history = PbfOptions {
        required_features: vec!["OsmSchema-V0.6".into(), "HistoricalInformation".into()],
        ..Default::default()
    };
    assert!(err("history.osm.pbf", &write_pbf(&town(), &history)).contains("history file"));
    let future = PbfOptions {
        required_features: vec!["OsmSchema-V0.7".into()],
        ..Default::default()
    };
    assert!(err("future.osm.pbf", &write_pbf(&town(), &future)).contains("\"OsmSchema-V0.7\""));
    // Corrupt compressed data.
    let mut bad = good.clone();
    let n = bad.len();
    for b in &mut bad[n - 40..n - 10] {
        *b ^= 0x5a;
    }
    let e = err("corrupt.osm.pbf", &bad);
    assert!(e.contains("blob"), "{e}");
}

/// SplitMix64, so a failing mutation names a seed that reproduces it.
fn next(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[test]
fn mutated_files_give_an_error_or_buildings_never_a_panic() {
    let dir = scratch("mutations");
    let frame = LocalFrame::new(4.35, 52.01, 0.0);
    let mut written = 0;
    for (k, o) in [
        PbfOptions {
            raw_blobs: true,
            ..Default::default()
        },
        PbfOptions {
            raw_blobs: true,
            plain_nodes: true,
            unpacked: true,
            ..Default::default()
        },
        PbfOptions {
            raw_blobs: true,
            locations_on_ways: true,
            ..Default::default()
        },
    ]
    .into_iter()
    .enumerate()
    {
        let good = write_pbf(&town(), &o);
        for seed in 0..400u64 {
            let mut state = seed * 7 + k as u64;
            let mut bytes = good.clone();
            for _ in 0..1 + next(&mut state) % 4 {
                let at = (next(&mut state) % bytes.len() as u64) as usize;
                match next(&mut state) % 3 {
                    0 => bytes[at] = next(&mut state) as u8,
                    1 => bytes[at] ^= 1 << (next(&mut state) % 8),
                    _ => bytes.truncate(at.max(1)),
                }
            }
            let p = write(&dir, "m.osm.pbf", &bytes);
            let got = std::panic::catch_unwind(|| {
                let r = read(&p);
                let s = read_streets(&p, None, None, None, &frame);
                (r.map(|o| o.report.buildings_written), s.is_ok())
            });
            match got {
                Ok((Ok(n), _)) => written += usize::from(n > 0),
                Ok((Err(_), _)) => {}
                Err(_) => panic!("options {k}, seed {seed}: panicked"),
            }
        }
    }
    // Many mutations land in coordinates or tags and still give buildings.
    assert!(written > 100, "{written}");
}

/// What a building is: id, outline, base, height, attributes.
#[test]
fn mutated_xml_gives_an_error_or_buildings_never_a_panic() {
    let dir = scratch("xml-mutations");
    let frame = LocalFrame::new(4.35, 52.01, 0.0);
    let mut written = 0;
    for (k, good) in [JOSM, OVERPASS].into_iter().enumerate() {
        for seed in 0..300u64 {
            let mut state = seed * 5 + k as u64;
            let mut bytes = good.as_bytes().to_vec();
            for _ in 0..1 + next(&mut state) % 4 {
                let at = (next(&mut state) % bytes.len() as u64) as usize;
                match next(&mut state) % 4 {
                    0 => bytes[at] = b"<>/='\"&; x0"[(next(&mut state) % 11) as usize],
                    1 => bytes[at] ^= 1 << (next(&mut state) % 8),
                    2 => {
                        let from = (next(&mut state) % bytes.len() as u64) as usize;
                        let piece = bytes[from..(from + 20).min(bytes.len())].to_vec();
                        bytes.splice(at..at, piece);
                    }
                    _ => bytes.truncate(at.max(1)),
                }
            }
            let p = write(&dir, "m.osm", &bytes);
            let got = std::panic::catch_unwind(|| {
                let r = read(&p);
                let s = read_streets(&p, None, None, None, &frame);
                (r.map(|o| o.report.buildings_written), s.is_ok())
            });
            match got {
                Ok((Ok(n), _)) => written += usize::from(n > 0),
                Ok((Err(_), _)) => {}
                Err(_) => panic!("file {k}, seed {seed}: panicked"),
            }
        }
    }
    // Some mutations land in coordinates, tags or whitespace and still give buildings (74 of 600 when written):
    // the mutated files reach the assembly, not only the XML checks.
    assert!(written >= 50, "{written}");
}

fn same(
    o: &Ingested,
) -> Vec<(
    &str,
    &citylod_model::Footprint,
    f64,
    f64,
    &citylod_model::Attributes,
)> {
    o.buildings
        .iter()
        .map(|b| {
            (
                b.source_id.as_str(),
                &b.footprint,
                b.base_z_m,
                b.height_m,
                &b.attributes,
            )
        })
        .collect()
}

#[test]
fn the_lower_east_side_as_libosmium_xml_gives_what_its_pbf_gives() {
    let pbf = read(&repo_root().join("examples/nyc-les/ny-access-restriction.osm.pbf")).unwrap();
    let gz = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/osm/les_osmium.osm.gz");
    let xml = read(&gz).unwrap();
    assert_eq!(
        xml.report.files[0].format,
        citylod_ingest::InputFormat::OsmXml
    );
    assert_eq!(xml.buildings.len(), 1407);
    // The same buildings, outlines to the bit, the same frame and the same skips.
    assert_eq!(same(&xml), same(&pbf));
    assert_eq!(xml.frame, pbf.frame);
    let skips = |o: &Ingested| -> Vec<(String, IssueReason, String)> {
        o.report
            .skipped
            .iter()
            .map(|s| (s.feature_id.clone(), s.reason, s.detail.clone()))
            .collect()
    };
    assert_eq!(skips(&xml), skips(&pbf));
    // Uncompressed too, and its streets.
    let dir = scratch("xml");
    let mut text = Vec::new();
    std::io::Read::read_to_end(
        &mut flate2::read::GzDecoder::new(std::fs::File::open(&gz).unwrap()),
        &mut text,
    )
    .unwrap();
    let plain = write(&dir, "les.osm", &text);
    assert_eq!(same(&read(&plain).unwrap()), same(&pbf));
    let frame = LocalFrame::new(-73.99, 40.72, 0.0);
    let (a, b) = (
        read_streets(&plain, None, None, None, &frame).unwrap(),
        read_streets(
            &repo_root().join("examples/nyc-les/ny-access-restriction.osm.pbf"),
            None,
            None,
            None,
            &frame,
        )
        .unwrap(),
    );
    assert_eq!(a.segments, b.segments);
    assert_eq!(a.report.features_used, 430);
}

const JOSM: &str = r#"<?xml version='1.0' encoding='UTF-8'?>
<osm version='0.6' upload='false' generator='JOSM'>
  <bounds minlat='52.0' minlon='4.3' maxlat='52.1' maxlon='4.4' origin='OpenStreetMap server' />
  <node id='-1' action='modify' lat='52.01' lon='4.35' />
  <node id='-2' action='modify' lat='52.01' lon='4.3502' />
  <node id='-3' action='modify' lat='52.0102' lon='4.3502' />
  <node id='-4' action='modify' lat='52.0102' lon='4.35' />
  <node id='5' lat='52.02' lon='4.36' />
  <node id='6' lat='52.02' lon='4.3602' />
  <node id='7' lat='52.0202' lon='4.36' />
  <node id='8' action='delete' lat='52.0202' lon='4.3602' />
  <way id='-10' action='modify'>
    <nd ref='-1' /><nd ref='-2' /><nd ref='-3' /><nd ref='-4' /><nd ref='-1' />
    <tag k='building' v='house' />
    <tag k='name' v='Caf&#233; &amp; bar' />
  </way>
  <way id='11' action='delete'>
    <nd ref='5' /><nd ref='6' /><nd ref='7' /><nd ref='5' />
    <tag k='building' v='yes' />
  </way>
  <way id='12' visible='false'>
    <nd ref='5' /><nd ref='6' /><nd ref='7' /><nd ref='5' />
    <tag k='building' v='yes' />
  </way>
  <way id='13'>
    <nd ref='5' /><nd ref='6' /><nd ref='8' /><nd ref='7' /><nd ref='5' />
    <tag k='building' v='yes' />
  </way>
</osm>
"#;

/// Overpass `out geom;`: every reference carries its location, and no node is in the answer; a remark says the
/// query ran out of time.
const OVERPASS: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<osm version="0.6" generator="Overpass API 0.7.62">
<note>The data included in this document is from www.openstreetmap.org.</note>
<meta osm_base="2026-11-27T10:00:00Z"/>
  <way id="100">
    <bounds minlat="40.7" minlon="-74.0" maxlat="40.71" maxlon="-73.99"/>
    <nd ref="1" lat="40.7000000" lon="-74.0000000"/>
    <nd ref="2" lat="40.7000000" lon="-73.9998000"/>
    <nd ref="3" lat="40.7002000" lon="-73.9998000"/>
    <nd ref="1" lat="40.7000000" lon="-74.0000000"/>
    <tag k="building" v="yes"/>
    <tag k="height" v="12"/>
  </way>
<remark> runtime error: Query timed out in &quot;query&quot; at line 3 after 26 seconds. </remark>
</osm>
"#;

#[test]
fn josm_and_overpass_files_read_as_their_writers_mean() {
    let dir = scratch("xml-writers");
    let josm = read(&write(&dir, "edit.osm", JOSM.as_bytes())).unwrap();
    // The new way (negative id) is a building; the deleted and invisible ones are not there; a way using a deleted
    // node is cut.
    let ids: Vec<&str> = josm
        .buildings
        .iter()
        .map(|b| b.source_id.as_str())
        .collect();
    assert_eq!(ids, ["way/-10"]);
    assert_eq!(
        josm.buildings[0].attributes.get("name"),
        Some(&AttrValue::String("Café & bar".into()))
    );
    let skipped: Vec<(&str, IssueReason)> = josm
        .report
        .skipped
        .iter()
        .map(|s| (s.feature_id.as_str(), s.reason))
        .collect();
    assert_eq!(skipped, [("way/13", IssueReason::IncompleteInExtract)]);

    let overpass = read(&write(&dir, "query.osm", OVERPASS.as_bytes())).unwrap();
    assert_eq!(overpass.buildings.len(), 1);
    assert_eq!(overpass.buildings[0].height_m, 12.0);
    let side = 0.0002 * 111_320.0;
    let a = area_m2(&overpass.buildings[0]);
    let expected = side * side * 40.7f64.to_radians().cos() / 2.0;
    assert!(
        (a - expected).abs() < 0.01 * expected,
        "{a} against {expected}"
    );
    let notes = &overpass.report.files[0].notes;
    assert!(
        notes
            .iter()
            .any(|n| n.ends_with("Query timed out in \"query\" at line 3 after 26 seconds.")),
        "{notes:?}"
    );
}

#[test]
fn broken_xml_is_refused_with_the_reason() {
    let dir = scratch("xml-broken");
    let err = |name: &str, text: &[u8]| match read(&write(&dir, name, text)) {
        Err(IngestError::InvalidOsm {
            encoding, detail, ..
        }) => {
            assert_eq!(encoding, "XML");
            detail
        }
        other => panic!("{name}: {:?}", other.map(|o| o.report.buildings_written)),
    };
    assert!(err("cut.osm", &JOSM.as_bytes()[..600]).contains("not well-formed XML"));
    // Cut between elements: the stream ends inside <osm>.
    let cut = &JOSM[..JOSM.find("  <way id='11'").unwrap()];
    assert!(err("cut2.osm", cut.as_bytes()).contains("the file is cut short"));
    assert!(err("empty.osm", b"").contains("no element"));
    assert!(err("two.osm", b"<osm/>\n<osm/>").contains("line 2): a second root element <osm>"));
    let e = err(
        "mismatch.osm",
        b"<osm>\n<way id='1'><nd ref='1'/></wya></osm>",
    );
    assert!(e.contains("line 2") && e.contains("</wya>"), "{e}");
    let e = err(
        "entity.osm",
        b"<osm>\n<way id='1'><nd ref='1'/><tag k='building' v='&yes;'/></way></osm>",
    );
    assert!(e.contains("line 2") && e.contains("yes"), "{e}");
    let e = err(
        "twice.osm",
        b"<osm>\n\n<node id='1' lat='1' lon='1' lat='2'/></osm>",
    );
    assert!(
        e.contains("line 3") && e.contains("duplicated attribute"),
        "{e}"
    );
    assert!(err("other.osm", b"<gpx version='1.1'/>").contains("the document is <gpx>, not <osm>"));
    assert!(err(
        "latin1.osm",
        b"<osm><node id='1' lat='1' lon='1'><tag k='name' v='caf\xe9'/></node></osm>"
    )
    .contains("not UTF-8"));
    let e = err(
        "noid.osm",
        b"<osm>\n<way id='x'><nd ref='1'/><tag k='building' v='yes'/></way></osm>",
    );
    assert!(
        e.contains("line 2") && e.contains("<way> without a whole-number id"),
        "{e}"
    );
    // An object without an id keeps its place among its kind when versions are sorted out (the two versions of way
    // 10 below): it is the one refused.
    let e = err(
        "noid-history.osm",
        b"<osm>\n<way><nd ref='1'/><tag k='building' v='yes'/></way>\n<way id='10' version='1'><nd ref='1'/></way>\n<way id='10' version='2'><nd ref='1'/></way></osm>",
    );
    assert!(
        e.contains("line 2") && e.contains("<way> without a whole-number id"),
        "{e}"
    );
    // An entity bomb is refused, not expanded: the reader takes no DTD.
    let bomb = b"<?xml version='1.0'?><!DOCTYPE osm [<!ENTITY a 'aaaaaaaaaa'><!ENTITY b '&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;'>]><osm><node id='1' lat='1' lon='1'><tag k='building' v='&b;'/></node></osm>";
    assert!(err("bomb.osm", bomb).contains("a DOCTYPE"));
    // Gzip and bzip2 by their magic numbers, whatever the name.
    assert!(err("bad.osm.gz", b"\x1f\x8b not gzip").contains("gzip"));
    assert!(err("extract.osm.bz2", b"BZh91AY&SY").contains("bzip2"));
    // Nesting deep enough to exhaust a recursive parser's stack is refused before parsing (as one input and as
    // one of two, where the parse runs on a worker thread).
    let deep = format!(
        "<osm>{}{}</osm>",
        "<a>".repeat(20_000),
        "</a>".repeat(20_000)
    );
    assert!(err("deep.osm", deep.as_bytes()).contains("nested more than 64 deep"));
    let two = [
        write(&dir, "deep2.osm", deep.as_bytes()),
        write(&dir, "fine.osm", JOSM.as_bytes()),
    ];
    assert!(matches!(
        ingest(&two, &IngestOptions::default()),
        Err(IngestError::InvalidOsm { .. })
    ));
}

#[test]
fn xml_versions_inline_geometry_and_names_read_as_written() {
    let dir = scratch("xml-more");
    // The API's history: the highest version stands; an object whose last version is invisible is gone.
    let history = r#"<osm version="0.6">
  <node id="1" version="1" lat="52.0" lon="4.3"/><node id="2" version="1" lat="52.0" lon="4.3002"/>
  <node id="3" version="1" lat="52.0002" lon="4.3002"/><node id="4" version="1" lat="52.0002" lon="4.3"/>
  <way id="10" version="1"><nd ref="1"/><nd ref="2"/><nd ref="3"/><nd ref="1"/><tag k="building" v="yes"/></way>
  <way id="10" version="2"><nd ref="1"/><nd ref="2"/><nd ref="3"/><nd ref="4"/><nd ref="1"/><tag k="building" v="yes"/></way>
  <way id="11" version="1"><nd ref="1"/><nd ref="2"/><nd ref="3"/><nd ref="4"/><nd ref="1"/><tag k="building" v="yes"/></way>
  <way id="11" version="2" visible="false"/>
</osm>"#;
    let out = read(&write(&dir, "history.osm", history.as_bytes())).unwrap();
    let ids: Vec<&str> = out.buildings.iter().map(|b| b.source_id.as_str()).collect();
    assert_eq!(ids, ["way/10"]);
    assert!(
        out.buildings[0].footprint.0[0].exterior().0.len() == 5,
        "version 2's four corners"
    );
    assert!(out.report.files[0]
        .notes
        .iter()
        .any(|n| n.contains("higher version")));
    // Overpass `out geom`: a relation's member ways inline, and a way cut by the query's box.
    let geom = r#"<osm version="0.6" generator="Overpass API">
  <relation id="5">
    <member type="way" ref="20" role="outer">
      <nd lat="52.0" lon="4.3"/><nd lat="52.0" lon="4.3004"/><nd lat="52.0004" lon="4.3004"/>
    </member>
    <member type="way" ref="21" role="outer">
      <nd lat="52.0004" lon="4.3004"/><nd lat="52.0004" lon="4.3"/><nd lat="52.0" lon="4.3"/>
    </member>
    <tag k="type" v="multipolygon"/><tag k="building" v="yes"/>
  </relation>
  <way id="8">
    <nd ref="1" lat="52.01" lon="4.31"/><nd ref="2"/><nd ref="3" lat="52.0102" lon="4.3102"/><nd ref="4"/>
    <nd ref="1" lat="52.01" lon="4.31"/>
    <tag k="building" v="yes"/>
  </way>
</osm>"#;
    // Saved without an extension, as a browser saves an Overpass answer: read as XML by its first byte.
    let out = read(&write(&dir, "interpreter", geom.as_bytes())).unwrap();
    assert_eq!(
        out.report.files[0].format,
        citylod_ingest::InputFormat::OsmXml
    );
    assert_eq!(out.buildings.len(), 1);
    assert_eq!(out.buildings[0].source_id, "relation/5");
    let skip = &out.report.skipped[0];
    assert_eq!(
        (skip.feature_id.as_str(), skip.reason),
        ("way/8", IssueReason::IncompleteInExtract)
    );
    assert!(
        skip.detail.starts_with("2 of its 5 node(s)"),
        "{}",
        skip.detail
    );
}

fn node(id: i64, lon: f64, lat: f64) -> Node {
    Node {
        id,
        lon,
        lat,
        tags: vec![],
    }
}

/// Nodes of a square of side `d` degrees at (x, y), ids from `first`, counter-clockwise from the south-west corner.
fn square_nodes(first: i64, x: f64, y: f64, d: f64) -> Vec<Node> {
    [(x, y), (x + d, y), (x + d, y + d), (x, y + d)]
        .iter()
        .enumerate()
        .map(|(i, &(lon, lat))| node(first + i as i64, lon, lat))
        .collect()
}

fn way(id: i64, refs: &[i64], t: &[(&str, &str)]) -> Way {
    Way {
        id,
        refs: refs.to_vec(),
        tags: tags(t),
    }
}

fn multipolygon(id: i64, ways: &[(i64, &str)]) -> Relation {
    Relation {
        id,
        members: ways
            .iter()
            .map(|&(w, role)| ('w', w, role.to_string()))
            .collect(),
        tags: tags(&[("type", "multipolygon"), ("building", "yes")]),
    }
}

#[test]
fn relation_rings_join_where_they_meet_and_nest_exactly() {
    let dir = scratch("rings");
    let d = 0.0004;
    let (x, y) = (4.35, 52.01);
    // Two squares sharing their corner node 3 (the first's north-east, the second's south-west), drawn as two open
    // ways each, so joining passes node 3 twice; the second has a courtyard.
    let mut nodes = square_nodes(1, x, y, d); // 1..4, node 3 at (x+d, y+d)
    nodes.extend(square_nodes(10, x + d, y + d, d)); // 10..13, node 10 at (x+d, y+d): replaced by node 3 below
    nodes.retain(|n| n.id != 10);
    // The courtyard.
    nodes.extend(square_nodes(20, x + 1.25 * d, y + 1.25 * d, 0.5 * d));
    // A house whose courtyard's first corner lies on its east wall, another on its west wall.
    let (hx, hy) = (x + 0.01, y);
    nodes.extend(square_nodes(30, hx, hy, d));
    nodes.extend([
        node(40, hx + d, hy + 0.5 * d),
        node(41, hx + 0.5 * d, hy + 0.25 * d),
        node(42, hx + 0.5 * d, hy + 0.75 * d),
    ]);
    let (wx, wy) = (x + 0.02, y);
    nodes.extend(square_nodes(50, wx, wy, d));
    nodes.extend([
        node(60, wx, wy + 0.5 * d),
        node(61, wx + 0.5 * d, wy + 0.75 * d),
        node(62, wx + 0.5 * d, wy + 0.25 * d),
    ]);
    // A way closed by another node at its first node's location, and a relation whose two ways meet at such nodes.
    let (cx, cy) = (x + 0.03, y);
    nodes.extend(square_nodes(70, cx, cy, d));
    nodes.push(node(74, cx, cy));
    let (rx, ry) = (x + 0.04, y);
    nodes.extend(square_nodes(80, rx, ry, d));
    nodes.push(node(84, rx, ry));
    nodes.push(node(85, rx + d, ry + d));
    let data = OsmData {
        nodes,
        ways: vec![
            way(100, &[1, 2, 3], &[]),
            way(101, &[3, 4, 1], &[]),
            way(102, &[3, 11, 12], &[]),
            way(103, &[12, 13, 3], &[]),
            way(104, &[20, 21, 22, 23, 20], &[]),
            way(110, &[30, 31, 32, 33, 30], &[]),
            way(111, &[40, 42, 41, 40], &[]),
            way(120, &[50, 51, 52, 53, 50], &[]),
            way(121, &[60, 61, 62, 60], &[]),
            way(130, &[70, 71, 72, 73, 74], &[("building", "yes")]),
            way(140, &[80, 81, 82], &[]),
            way(141, &[85, 83, 84], &[]),
        ],
        relations: vec![
            multipolygon(
                1,
                &[
                    (100, "outer"),
                    (102, "outer"),
                    (101, "outer"),
                    (103, "outer"),
                    (104, "inner"),
                ],
            ),
            multipolygon(2, &[(110, "outer"), (111, "inner")]),
            multipolygon(3, &[(120, "outer"), (121, "inner")]),
            // Listed twice: taken once.
            multipolygon(4, &[(140, "outer"), (141, "outer"), (140, "outer")]),
        ],
    };
    let p = write(
        &dir,
        "rings.osm.pbf",
        &write_pbf(&data, &PbfOptions::default()),
    );
    let out = read(&p).unwrap();
    let r = &out.report;
    assert!(r.skipped.is_empty(), "{:?}", r.skipped);
    let by_id = |id: &str| out.buildings.iter().find(|b| b.source_id == id).unwrap();
    let holes = |id: &str| {
        let mut h: Vec<usize> = by_id(id)
            .footprint
            .0
            .iter()
            .map(|p| p.interiors().len())
            .collect();
        h.sort();
        h
    };
    // Two squares touching at a corner, the courtyard kept in the second; nothing to repair.
    assert_eq!(holes("relation/1"), [0, 1]);
    let sq = area_m2(by_id("way/130"));
    let a = area_m2(by_id("relation/1"));
    assert!(
        (a - sq * (2.0 - 0.25)).abs() < 0.01 * sq,
        "{a} against {}",
        sq * 1.75
    );
    assert!(
        !r.repaired.iter().any(|i| i.feature_id == "relation/1"),
        "{:?}",
        r.repaired
    );
    // A courtyard touching the wall, east or west: a hole either way.
    for id in ["relation/2", "relation/3"] {
        assert_eq!(holes(id), [1], "{id}");
        let a = area_m2(by_id(id));
        assert!((a - sq * 0.875).abs() < 0.01 * sq, "{id}: {a}");
    }
    // Closed at the same location by another node.
    assert!((area_m2(by_id("way/130")) - area_m2(by_id("relation/4"))).abs() < 0.01 * sq);
    assert!(r.repaired.iter().any(|i| i.feature_id == "relation/4"
        && i.reason == IssueReason::NonPolygonMemberDropped
        && i.detail.contains("listed more than once")));
}

#[test]
fn hostile_sizes_are_refused_per_building_not_by_memory() {
    let dir = scratch("sizes");
    let (x, y) = (4.35, 52.01);
    let mut nodes = square_nodes(1, x, y, 0.0004);
    nodes.extend(square_nodes(5, x + 0.001, y, 0.0004));
    // A way of 150,000 references to four nodes, and a relation listing one way 40,000 times.
    let mut refs: Vec<i64> = (0..150_000).map(|i| 1 + (i % 4)).collect();
    refs.push(1);
    let data = OsmData {
        nodes,
        ways: vec![
            way(10, &refs, &[("building", "yes")]),
            way(11, &[5, 6, 7, 8, 5], &[]),
            way(12, &[5, 6, 7, 8, 5], &[("building", "yes")]),
        ],
        relations: vec![Relation {
            id: 20,
            members: (0..40_000)
                .map(|_| ('w', 11, "outer".to_string()))
                .collect(),
            tags: tags(&[("type", "multipolygon"), ("building", "yes")]),
        }],
    };
    let p = write(
        &dir,
        "sizes.osm.pbf",
        &write_pbf(&data, &PbfOptions::default()),
    );
    let out = read(&p).unwrap();
    let skipped: Vec<(&str, IssueReason, &str)> = out
        .report
        .skipped
        .iter()
        .map(|s| (s.feature_id.as_str(), s.reason, s.detail.as_str()))
        .collect();
    assert_eq!(out.buildings.len(), 1);
    assert_eq!(skipped.len(), 2, "{skipped:?}");
    assert_eq!(
        (skipped[0].0, skipped[0].1),
        ("way/10", IssueReason::MalformedGeometry)
    );
    assert!(skipped[0].2.contains("150001 nodes"), "{}", skipped[0].2);
    assert_eq!(
        (skipped[1].0, skipped[1].1),
        ("relation/20", IssueReason::MalformedGeometry)
    );
    assert!(skipped[1].2.contains("40000 members"), "{}", skipped[1].2);
}

#[test]
fn boston_as_openstreetmap_xml_gives_the_buildings_of_its_geojson() {
    let Some(path) = citylod_testdata::shared_data("boston/boston_buildings.geojson") else {
        return;
    };
    let opts = IngestOptions {
        storey_height_m: 3.5,
        ..IngestOptions::default()
    };
    let geojson = ingest(std::slice::from_ref(&path), &opts).unwrap();
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let mut xml = Vec::new();
    citylod_testdata::osm_xml::write_xml(
        &citylod_testdata::osm_xml::from_geojson(&doc, 1, 0.0),
        &mut xml,
    )
    .unwrap();
    let p = write(&scratch("boston-xml"), "boston.osm", &xml);
    let osm = ingest(&[p], &opts).unwrap();
    assert_eq!(osm.buildings.len(), geojson.buildings.len());
    assert_eq!(osm.buildings.len(), 22_186 - geojson.report.skipped.len());
    // Ways first, then the 47 courtyard buildings as multipolygon relations; each with the storeys of its feature,
    // and an outline within the 7 decimals OSM keeps (1 cm).
    let key = |o: &Ingested, b: &citylod_model::Building| {
        let area = area_m2(b);
        (
            (area * 10.0).round() as i64,
            (b.height_m * 100.0).round() as i64,
            vertices(o, b).len(),
        )
    };
    let mut a: Vec<_> = geojson.buildings.iter().map(|b| key(&geojson, b)).collect();
    let mut b: Vec<_> = osm.buildings.iter().map(|b| key(&osm, b)).collect();
    a.sort();
    b.sort();
    let total = |o: &Ingested| o.buildings.iter().map(area_m2).sum::<f64>();
    assert!(
        (total(&osm) - total(&geojson)).abs() < 1e-5 * total(&geojson),
        "{} against {}",
        total(&osm),
        total(&geojson)
    );
    // The same areas to 0.1 m², heights to 1 cm and vertex counts, building by building.
    assert!(
        a == b,
        "{} of {} differ",
        a.iter().zip(&b).filter(|(x, y)| x != y).count(),
        a.len()
    );
    let relations = osm
        .buildings
        .iter()
        .filter(|b| b.source_id.starts_with("relation/"))
        .count();
    assert_eq!(relations, 47);
}
