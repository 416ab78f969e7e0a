//! Ingest of the real data sets in ../shared/data (see its README): counts, skip reasons, heights
//! and placement on the globe. Each test skips with a message when the data folder is absent.

use citylod_ingest::{check_footprint, ingest, IngestOptions, IssueReason, MIN_AREA_M2};
use citylod_mesh::topology::signed_volume_m3;
use citylod_model::HeightSource;

use citylod_testdata::shared_data as data;

/// The lowest vertex height of a mesh (m).
fn lowest_z_m(mesh: &citylod_model::Mesh3d) -> f64 {
    mesh.positions
        .iter()
        .map(|p| p[2])
        .fold(f64::INFINITY, f64::min)
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
        // Square degrees to square metres at the ring's latitude (to 0.3 %, enough to tell 0.01 m² from 0.4 m²).
        let lat = ring[0].1.to_radians();
        let area_m2 = twice_area_deg2.abs() / 2.0 * 111_132.0 * 111_320.0 * lat.cos();
        match s.reason {
            IssueReason::TooFewPoints => assert!(distinct.len() < 3, "{s:?}"),
            IssueReason::ZeroArea => assert!(
                area_m2 < MIN_AREA_M2 * 1.01,
                "{s:?}: its ring has {area_m2} m², the rule skips below {MIN_AREA_M2} m²"
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
    // The 13 outlines with parts inside are drawn by their parts (Simple 3D Buildings), each listed with them.
    let drawn: Vec<&str> = r
        .skipped
        .iter()
        .filter(|s| s.reason == IssueReason::DrawnByParts)
        .map(|s| s.feature_id.as_str())
        .collect();
    assert_eq!(drawn.len(), 13, "{drawn:?}");
    assert_eq!(r.skipped.len(), 13);
    let tower = r
        .skipped
        .iter()
        .find(|s| s.feature_id == "way/471")
        .unwrap();
    assert!(
        tower
            .detail
            .contains("1 building:part(s) inside (way/1558)"),
        "{}",
        tower.detail
    );
    // Every part is written, and none of the outlines is.
    for id in &drawn {
        assert!(out.buildings.iter().all(|b| b.source_id != *id));
    }
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

// ---- 3D models (IngestOptions::lod) ----

/// How far the mesh's xy bounding box reaches beyond the footprint's (`.0`) and falls short of it
/// (`.1`), the largest over the four sides (m, ≥ 0).
fn box_excess_m(b: &citylod_model::Building) -> (f64, f64) {
    let grow =
        |bx: [f64; 4], x: f64, y: f64| [bx[0].min(x), bx[1].min(y), bx[2].max(x), bx[3].max(y)];
    let empty = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let m = b.mesh.as_ref().unwrap();
    let mesh = m
        .mesh
        .positions
        .iter()
        .fold(empty, |bx, p| grow(bx, p[0], p[1]));
    let fp = b
        .footprint
        .0
        .iter()
        .flat_map(|p| &p.exterior().0)
        .fold(empty, |bx, c| grow(bx, c.x, c.y));
    let beyond = [
        fp[0] - mesh[0],
        fp[1] - mesh[1],
        mesh[2] - fp[2],
        mesh[3] - fp[3],
    ];
    (
        beyond.iter().fold(0.0, |a, &d| a.max(d)),
        beyond.iter().fold(0.0, |a, &d| a.max(-d)),
    )
}

/// The share of values ≤ `limit`, and the largest value.
fn within(values: &[f64], limit: f64) -> (f64, f64) {
    let ok = values.iter().filter(|&&v| v <= limit).count();
    (
        ok as f64 / values.len().max(1) as f64,
        values.iter().fold(0.0, |a, &v| a.max(v)),
    )
}

/// Facts read straight from the 3DBAG source, per feature id.
struct DelftSource {
    /// The LoD 2.2 geometry (all parts together) is closed: every polygon edge, between vertices
    /// compared by their integer coordinates, is used exactly twice.
    closed: bool,
    /// Lowest z of the LoD 2.2 geometry minus `b3_h_maaiveld` (m).
    bottom_above_ground_m: f64,
}

/// Is the union of these Solids closed in the source: is every polygon edge, between vertices
/// compared by their stored (integer) coordinates, used exactly twice? Also their lowest stored z.
fn solids_closed(solids: &[&serde_json::Value], verts: &[serde_json::Value]) -> (bool, f64) {
    let key = |i: &serde_json::Value| verts[i.as_u64().unwrap() as usize].to_string();
    let mut min_z = f64::INFINITY;
    let mut edges: std::collections::BTreeMap<(String, String), usize> = Default::default();
    for g in solids {
        assert_eq!(g["type"], "Solid");
        for shell in g["boundaries"].as_array().unwrap() {
            for surface in shell.as_array().unwrap() {
                for ring in surface.as_array().unwrap() {
                    let r = ring.as_array().unwrap();
                    for i in r {
                        let z = verts[i.as_u64().unwrap() as usize][2].as_f64().unwrap();
                        min_z = min_z.min(z);
                    }
                    for k in 0..r.len() {
                        let (a, b) = (key(&r[k]), key(&r[(k + 1) % r.len()]));
                        if a != b {
                            *edges
                                .entry((a.clone().min(b.clone()), a.max(b)))
                                .or_default() += 1;
                        }
                    }
                }
            }
        }
    }
    (!edges.is_empty() && edges.values().all(|&c| c == 2), min_z)
}

fn delft_source(path: &std::path::Path) -> std::collections::BTreeMap<String, DelftSource> {
    use serde_json::Value;
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Value = serde_json::from_str(lines.next().unwrap()).unwrap();
    let (scale_z, translate_z) = (
        header["transform"]["scale"][2].as_f64().unwrap(),
        header["transform"]["translate"][2].as_f64().unwrap(),
    );
    let mut out = std::collections::BTreeMap::new();
    for line in lines {
        let f: Value = serde_json::from_str(line).unwrap();
        let id = f["id"].as_str().unwrap();
        let solids: Vec<&Value> = f["CityObjects"]
            .as_object()
            .unwrap()
            .values()
            .flat_map(|o| o["geometry"].as_array().into_iter().flatten())
            .filter(|g| g["lod"] == "2.2")
            .collect();
        let (closed, min_z) = solids_closed(&solids, f["vertices"].as_array().unwrap());
        let ground = f["CityObjects"][id]["attributes"]["b3_h_maaiveld"]
            .as_f64()
            .unwrap();
        out.insert(
            id.to_string(),
            DelftSource {
                closed,
                bottom_above_ground_m: min_z * scale_z + translate_z - ground,
            },
        );
    }
    out
}

#[test]
fn delft_every_building_gets_a_closed_outward_lod22_mesh_on_its_footprint() {
    let Some(path) = data("delft-3dbag/delft.city.jsonl") else {
        return;
    };
    let opts = IngestOptions {
        lod: Some("2.2".parse().unwrap()),
        ..Default::default()
    };
    let t = std::time::Instant::now();
    let out = ingest(std::slice::from_ref(&path), &opts).unwrap();
    let seconds = t.elapsed().as_secs_f64();
    let r = &out.report;
    r.check_invariants().unwrap();
    let t = std::time::Instant::now();
    let plain = ingest(std::slice::from_ref(&path), &IngestOptions::default()).unwrap();
    let seconds_plain = t.elapsed().as_secs_f64();
    assert_eq!(plain.buildings.len(), out.buildings.len());
    for (a, b) in plain.buildings.iter().zip(&out.buildings) {
        assert_eq!(
            (&a.footprint, a.base_z_m, a.height_m),
            (&b.footprint, b.base_z_m, b.height_m),
            "{}: the 2D result changed",
            a.source_id
        );
    }

    assert_eq!(
        r.buildings_with_mesh, r.buildings_written,
        "{:?}",
        r.mesh_issues
    );
    assert_eq!(r.mesh_lods.get("2.2"), Some(&r.buildings_written));
    assert_eq!(r.mesh_lod_fallbacks, 0);
    let source = delft_source(&path);
    let (mut closed, mut base_offsets_m, mut beyond_m, mut short_m) =
        (0, Vec::new(), Vec::new(), Vec::new());
    for b in &out.buildings {
        let m = b.mesh.as_ref().unwrap();
        m.check_invariants().unwrap();
        assert_eq!(m.surfaces.len(), m.mesh.triangles.len());
        let rep = citylod_mesh::topology::mesh_report(&m.mesh);
        let src = &source[&b.source_id];
        if src.closed {
            closed += 1;
            assert!(
                rep.watertight && rep.orientation_consistent,
                "{}: {rep:?}",
                b.source_id
            );
            let v = signed_volume_m3(&m.mesh);
            assert!(v > 0.0, "{}: volume {v} m³: inside out", b.source_id);
        }
        let (beyond, short) = box_excess_m(b);
        beyond_m.push(beyond);
        short_m.push(short);
        let min_z = lowest_z_m(&m.mesh);
        base_offsets_m.push(min_z - b.base_z_m);
        // The footprint stands on b3_h_maaiveld; the mesh keeps the solid's own z, in the same frame.
        // 3 cm: base_z_m is taken at the footprint's centre, and the Earth's curvature lowers a
        // building's far corners in ENU by ≈ r·Δr/R (1 cm at r = 700 m from the origin, Δr = 100 m).
        let d = min_z - b.base_z_m - src.bottom_above_ground_m;
        assert!(d.abs() < 0.03, "{}: mesh bottom off by {d} m", b.source_id);
        for k in [
            citylod_model::SurfaceKind::Roof,
            citylod_model::SurfaceKind::Wall,
            citylod_model::SurfaceKind::Ground,
        ] {
            assert!(
                m.surfaces.contains(&k),
                "{}: no {k:?} triangle",
                b.source_id
            );
        }
    }
    base_offsets_m.sort_by(f64::total_cmp);
    let n = base_offsets_m.len();
    let (lo, med, hi) = (
        base_offsets_m[0],
        base_offsets_m[n / 2],
        base_offsets_m[n - 1],
    );
    eprintln!(
        "delft 2.2: {} buildings with a mesh, {} triangles, {closed} closed in the source (all watertight here), \
         mesh issues {:?}, xy box beyond the footprint's ≤ 1 m: {:?}, short of it ≤ 1 m: {:?}, lowest mesh z − base_z_m: min {lo:.3} \
         median {med:.3} max {hi:.3} m, ingest {seconds:.2} s ({seconds_plain:.2} s without meshes)",
        r.buildings_with_mesh, r.mesh_triangles, r.mesh_issues_by_reason, within(&beyond_m, 1.0), within(&short_m, 1.0)
    );
    eprintln!("delft mesh issues: {:#?}", r.mesh_issues);
    assert!(
        closed * 10 >= n * 9,
        "only {closed} of {n} closed in the source"
    );
    // 3DBAG solids stand on b3_h_maaiveld (3 buildings reach lower, see above); the mesh is never
    // wider than the footprint, but may be narrower (3DBAG left part of an outline unreconstructed).
    let bottoms_on_ground = base_offsets_m.iter().filter(|d| d.abs() < 0.03).count();
    assert!(
        bottoms_on_ground + 3 >= n,
        "{bottoms_on_ground} of {n} bottoms on base_z_m"
    );
    assert_eq!(within(&beyond_m, 0.01).0, 1.0);
    assert!(within(&short_m, 1.0).0 > 0.98);
}

#[test]
fn delft_lod_choices_and_fallbacks_on_real_data() {
    let Some(path) = data("delft-3dbag/delft.city.jsonl") else {
        return;
    };
    let run = |lod: &str| {
        let opts = IngestOptions {
            lod: Some(lod.parse().unwrap()),
            ..Default::default()
        };
        ingest(std::slice::from_ref(&path), &opts).unwrap().report
    };
    let n = 1_115;
    let highest = run("highest");
    assert_eq!(highest.mesh_lods.get("2.2"), Some(&n));
    let lod13 = run("1.3");
    assert_eq!(
        (lod13.mesh_lods.get("1.3"), lod13.mesh_lod_fallbacks),
        (Some(&n), 0)
    );
    // 3DBAG has no LoD 2.0–2.1 nor 1.4+: asking 2.1 falls back to 1.3 everywhere, and says so.
    let lod21 = run("2.1");
    assert_eq!(
        (lod21.mesh_lods.get("1.3"), lod21.mesh_lod_fallbacks),
        (Some(&n), n)
    );
    let lod1 = run("1");
    assert_eq!(
        lod1.mesh_lods.get("1.3"),
        Some(&n),
        "'1' is the highest 1.x"
    );
}

#[test]
fn denhaag_cityjson_08_buildings_get_lod2_meshes() {
    let Some(path) = data("denhaag-lod2/DenHaag_01.json") else {
        return;
    };
    let opts = IngestOptions {
        crs: Some("EPSG:28992".into()),
        lod: Some(citylod_ingest::LodChoice::Highest),
        ..Default::default()
    };
    let out = ingest(std::slice::from_ref(&path), &opts).unwrap();
    let r = &out.report;
    r.check_invariants().unwrap();
    let again = ingest(std::slice::from_ref(&path), &opts).unwrap();
    assert!(
        out.buildings
            .iter()
            .zip(&again.buildings)
            .all(|(a, b)| a.mesh == b.mesh),
        "meshes differ between two runs"
    );
    // Closed in the source: each Building with all objects that name it as parent.
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let objects = doc["CityObjects"].as_object().unwrap();
    let closed_in_source = |id: &str| {
        let solids: Vec<&serde_json::Value> = objects
            .iter()
            .filter(|(k, o)| k.as_str() == id || o["parent"] == id)
            .flat_map(|(_, o)| o["geometry"].as_array().into_iter().flatten())
            .collect();
        solids_closed(&solids, doc["vertices"].as_array().unwrap()).0
    };
    let mut closed = 0;
    let (mut watertight, mut base_offsets_m, mut beyond_m, mut short_m) =
        (0, Vec::new(), Vec::new(), Vec::new());
    for b in &out.buildings {
        let Some(m) = &b.mesh else { continue };
        m.check_invariants().unwrap();
        let rep = citylod_mesh::topology::mesh_report(&m.mesh);
        if closed_in_source(&b.source_id) {
            closed += 1;
            assert!(
                rep.watertight && rep.orientation_consistent,
                "{}: {rep:?}",
                b.source_id
            );
        }
        if rep.watertight {
            watertight += 1;
            let v = signed_volume_m3(&m.mesh);
            assert!(v > 0.0, "{}: volume {v} m³: inside out", b.source_id);
        }
        let (beyond, short) = box_excess_m(b);
        beyond_m.push(beyond);
        short_m.push(short);
        base_offsets_m.push(lowest_z_m(&m.mesh) - b.base_z_m);
    }
    base_offsets_m.sort_by(f64::total_cmp);
    let n = base_offsets_m.len();
    eprintln!(
        "denhaag: {} of {} buildings with a mesh {:?}, {} triangles, {closed} closed in the source, {watertight} watertight, mesh issues {:?}, \
         xy box beyond the footprint's ≤ 1 m: {:?}, short of it ≤ 1 m: {:?}, lowest mesh z − base_z_m: min {:.3} median {:.3} max {:.3} m",
        r.buildings_with_mesh,
        r.buildings_written,
        r.mesh_lods,
        r.mesh_triangles,
        r.mesh_issues_by_reason,
        within(&beyond_m, 1.0),
        within(&short_m, 1.0),
        base_offsets_m[0],
        base_offsets_m[n / 2],
        base_offsets_m[n - 1]
    );
    assert_eq!(
        r.mesh_lods.get("2"),
        Some(&r.buildings_with_mesh),
        "CityJSON 0.8 writes lod 2"
    );
    assert_eq!(
        r.buildings_with_mesh, r.buildings_written,
        "{:?}",
        r.mesh_issues
    );
    // The footprint's base is the lowest footprint vertex, i.e. the lowest point of the solids.
    assert!(base_offsets_m[0] > -0.03 && base_offsets_m[n - 1] < 0.03);
    // Roofs overhang the ground surfaces by up to ~1.2 m; a mesh is never narrower than its footprint.
    assert!(within(&beyond_m, 1.0).0 > 0.99 && within(&beyond_m, 2.0).0 == 1.0);
    assert_eq!(within(&short_m, 0.01).0, 1.0);
}
