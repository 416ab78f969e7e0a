//! 3D buildings (issue 6, DESIGN.md §7): the Delft LoD2.2 tileset built with `--lod 2.2` is valid, complete,
//! carries every building's chain (prism → simplified → full model) with measured errors that shrink down the
//! chain, and passes `citylod check`.

use crate::common::{
    assert_same_files, build, build_with_env, citylod, e2e_dir, gltf_validator, read_json,
    repo_root, schema_errors, shared_data, tree_bytes,
};
use citylod_tiles::read::read_tileset;
use citylod_tiles::PropValue;
use serde_json::Value;
use std::collections::BTreeMap;

#[test]
fn delft_lod22_tileset_has_the_model_chain_and_passes_check() {
    let Some(input) = shared_data("delft-3dbag/delft.city.jsonl") else {
        return;
    };
    let out = e2e_dir("delft-lod22");
    // A low landmark threshold puts a few towers (6 on Delft) at full detail on top of their blocks, so the error
    // of a landmark's prism against its model is exercised too.
    let report = build(
        &[&input],
        &out,
        &["--lod", "2.2", "--landmark-min-excess", "5"],
    );
    assert_eq!(report["counts"]["buildings_written"], 1115);
    let models = &report["models"];
    assert_eq!(models["buildings"], 1115, "every building has a 3D model");
    let full = models["triangles_full"].as_u64().unwrap();
    let simplified = models["triangles_simplified"].as_u64().unwrap();
    assert!(
        full > 100_000,
        "Delft LoD2.2 has ~109k triangles, got {full}"
    );
    // topo-qem stops where a further collapse would move the surface over 0.5 m (about 49 % removed on Delft
    // at a 60 % target); each building short of the target is counted with its reason.
    assert!(
        (simplified as f64) < 0.6 * full as f64,
        "the simplified level should remove about half the triangles: {simplified} of {full}"
    );
    assert!(
        models["short_of_target"].as_u64().unwrap() == 0
            || !models["short_of_target_examples"]
                .as_array()
                .unwrap()
                .is_empty(),
        "buildings short of the target rate come with their reasons"
    );
    assert!(models["simplified_error_median_m"].as_f64().unwrap() > 0.0);
    assert!(
        models["simplified_error_median_m"].as_f64().unwrap()
            <= models["prism_error_median_m"].as_f64().unwrap(),
        "the simplified model should sit closer to the full model than the prism: {models:#}"
    );
    let errs = schema_errors("build-report.schema.json", &report);
    assert!(errs.is_empty(), "build report: {}", errs.join("\n"));
    let ts_json = read_json(&out.join("tileset.json"));
    let errs = schema_errors("tileset.schema.json", &ts_json);
    assert!(errs.is_empty(), "tileset.json: {}", errs.join("\n"));
    let v = gltf_validator(&out);
    assert_eq!(
        v["errors"].as_u64(),
        Some(0),
        "glTF-Validator: {:#}",
        v["messages"]
    );

    // Every building appears three times below the clusters — prism, simplified, full — and exactly once in
    // the leaves (the full models), whose error is 0; the tiles above them have positive errors.
    let ts = read_tileset(&out.join("tileset.json")).expect("read back");
    let mut per_building: BTreeMap<i64, Vec<(usize, bool)>> = BTreeMap::new();
    for (i, tile) in ts.tiles.iter().enumerate() {
        let Some(content) = &tile.content else {
            continue;
        };
        for row in &content.features {
            let id = match row.values.get("building_index") {
                Some(PropValue::Int(i)) => *i,
                Some(PropValue::Float(f)) => *f as i64,
                _ => continue,
            };
            per_building
                .entry(id)
                .or_default()
                .push((i, tile.children.is_empty()));
        }
    }
    assert_eq!(per_building.len(), 1115);
    let with_simplified = per_building.values().filter(|t| t.len() >= 3).count();
    assert!(
        with_simplified > 1000,
        "only {with_simplified} of 1115 buildings have the simplified level"
    );
    for (b, tiles) in &per_building {
        let leaves = tiles.iter().filter(|t| t.1).count();
        assert_eq!(leaves, 1, "building {b} in {leaves} leaf tiles");
        assert!(
            tiles.len() >= 3,
            "building {b} in only {} tiles",
            tiles.len()
        );
        let leaf = tiles.iter().find(|t| t.1).unwrap().0;
        assert_eq!(ts.tiles[leaf].geometric_error_m, 0.0);
    }

    // A landmark is its building's prism, not its model: its row and its tile claim the prism's distance from the
    // model (they claimed 0, as for footprint input, before 2026-11-22).
    let mut landmarks = 0;
    for tile in &ts.tiles {
        let Some(content) = &tile.content else {
            continue;
        };
        for row in &content.features {
            if row.values.get("landmark") != Some(&PropValue::Bool(true)) {
                continue;
            }
            landmarks += 1;
            let Some(PropValue::Float(e)) = row.values.get("geometric_error_m") else {
                panic!("landmark without geometric_error_m: {row:?}");
            };
            assert!(
                *e > 0.0 && *e <= tile.geometric_error_m * (1.0 + f32::EPSILON as f64),
                "tile {} (error {} m): landmark {:?} claims {e} m",
                tile.path_in_tree,
                tile.geometric_error_m,
                row.values.get("source_id")
            );
        }
    }
    assert!(landmarks > 0, "no landmark with --landmark-min-excess 5");

    // A prism far from its model (a church's spire over its roof) is drawn as the simplified model instead, so it
    // does not set the error of its prism tile and of every block tile above it (78.9 m on Delft before).
    let rough: Vec<&str> = models["prisms_drawn_as_simplified"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    let (roughest, worst_m) = (
        models["prism_error_largest"][0][0].as_str().unwrap(),
        models["prism_error_max_m"].as_f64().unwrap(),
    );
    assert!(rough.contains(&roughest), "{roughest} not in {rough:?}");
    let prism_tiles_max_m = ts
        .tiles
        .iter()
        .filter(|t| !t.children.is_empty())
        .filter(|t| {
            t.content.as_ref().is_some_and(|c| {
                // Building rows only (a cluster row has a node index).
                c.features
                    .iter()
                    .all(|r| !r.values.contains_key("node_index"))
            })
        })
        .map(|t| t.geometric_error_m)
        .fold(0.0, f64::max);
    assert!(
        prism_tiles_max_m > 0.0 && prism_tiles_max_m < worst_m / 2.0,
        "the prism tiles claim up to {prism_tiles_max_m} m, the roughest prism is {worst_m} m"
    );

    // citylod check: every built-in view passes.
    let check_out = e2e_dir("delft-lod22-check");
    let o = citylod(&[
        "check",
        &out.display().to_string(),
        "--out",
        &check_out.display().to_string(),
        "--quiet",
    ]);
    let check = read_json(&check_out.join("report.json"));
    assert_eq!(
        o.status.code(),
        Some(0),
        "citylod check failed on Delft LoD2.2: {:#}",
        check["summary"]
    );

    // The models are simplified in parallel; on one thread every byte is the same.
    let serial = e2e_dir("delft-lod22-one-thread");
    build_with_env(
        &[&input],
        &serial,
        &["--lod", "2.2", "--landmark-min-excess", "5"],
        &[("RAYON_NUM_THREADS", "1")],
    );
    assert_same_files(&out, &serial, "RAYON_NUM_THREADS=1");
}

/// Delft built with `--lod <lod>` into `e2e/<name>`: the console's text and the build report; `None` without data.
fn delft_at_lod(lod: &str, name: &str) -> Option<(String, serde_json::Value)> {
    let input = shared_data("delft-3dbag/delft.city.jsonl")?;
    let out = e2e_dir(name);
    let o = citylod(&[
        "build",
        input.to_str().unwrap(),
        "--lod",
        lod,
        "--out",
        out.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{e}");
    Some((e, read_json(&out.join("build-report.json"))))
}

/// `--lod` at a level no building has (Delft's solids are LoD 1.2 and up) writes prisms, and says so on the
/// console as well as in the report (found by fuzzing: 1,115 prisms were announced as "0 repaired, 0 skipped").
#[test]
fn a_lod_no_building_has_says_how_many_prisms_were_written() {
    let Some((e, report)) = delft_at_lod("1.1", "delft-lod11") else {
        return;
    };
    assert!(
        e.contains("3D models: 0 of 1115 buildings; 1115 without one are prisms"),
        "{e}"
    );
    assert!(e.contains("1115 × model_missing"), "{e}");
    assert_eq!(
        report["ingest"]["mesh_issues_by_reason"]["model_missing"],
        1115
    );
}

/// `--lod` above what the buildings have reads their highest LoD below it, and the console says so (a `--lod 2.1`
/// that quietly gave LoD 1.3 models looked like what was asked).
#[test]
fn a_lod_the_buildings_lack_says_which_lod_was_read_instead() {
    let Some((e, report)) = delft_at_lod("2.1", "delft-lod21") else {
        return;
    };
    assert!(
        e.contains("3D models: 1115 of 1115 buildings (1115 at LoD 1.3); 1115 had no LoD 2.1 and use their highest below it"),
        "{e}"
    );
    assert_eq!(report["ingest"]["mesh_lod_fallbacks"], 1115);
    assert_eq!(report["ingest"]["mesh_lods"]["1.3"], 1115);
}

#[test]
fn a_multipatch_shapefile_builds_with_its_models() {
    // GDAL's MultiPatch shapefile of 12 Delft buildings (every LoD 2.2 face an outer-ring part), in EPSG:28992.
    let input = repo_root().join("crates/citylod-ingest/tests/multipatch/delft_multipatch.shp");
    let out = e2e_dir("multipatch");
    let report = build(&[&input], &out, &["--lod", "2.2"]);
    let errs = schema_errors("build-report.schema.json", &report);
    assert!(errs.is_empty(), "build report: {}", errs.join("\n"));
    assert_eq!(report["counts"]["buildings_written"], 12);
    assert_eq!(report["models"]["buildings"], 12, "{:#}", report["models"]);
    assert_eq!(report["ingest"]["mesh_lods"]["MultiPatch"], 12);
    let ts_json = read_json(&out.join("tileset.json"));
    let errs = schema_errors("tileset.schema.json", &ts_json);
    assert!(errs.is_empty(), "tileset.json: {}", errs.join("\n"));
    let v = gltf_validator(&out);
    assert_eq!(
        v["errors"].as_u64(),
        Some(0),
        "glTF-Validator: {:#}",
        v["messages"]
    );
}

/// OpenStreetMap roof shapes (`roof:shape` with `roof:height`) become LoD 2 models with `--lod 2`: on the bundled
/// Lower East Side extract 26 building parts have a gabled, skillion, pyramidal, dome or onion roof (a church's
/// gables, spire, onion domes; a tower's skillion). Their leaf tiles draw the roofs (corners at the eaves and the
/// ridge, not only at ground and top), the prism above each claims the roof's height as its error, and the
/// tileset is valid and passes `citylod check`.
/// The roof shapes of the Lower East Side extract, all modelled.
const ROOFED: [&str; 5] = ["gabled", "skillion", "pyramidal", "dome", "onion"];

#[test]
fn osm_roof_shapes_become_lod2_models_on_the_lower_east_side() {
    let input = repo_root().join("examples/nyc-les/ny-access-restriction.osm.pbf");
    let out = e2e_dir("les-osm-roofs");
    let report = build(&[&input], &out, &["--lod", "2"]);
    let errs = schema_errors("build-report.schema.json", &report);
    assert!(errs.is_empty(), "build report: {}", errs.join("\n"));
    assert_eq!(
        report["ingest"]["mesh_lods"],
        serde_json::json!({ "2": 26 })
    );
    assert_eq!(report["models"]["buildings"], 26, "{:#}", report["models"]);
    assert_eq!(
        report["ingest"]["mesh_issues"],
        serde_json::json!([]),
        "every roof shape of the extract is modelled"
    );
    // Twelve of the gabled parts are 9 m houses with roof:height 1.1: the prism stands 1.1 m off its model.
    let median = report["models"]["prism_error_median_m"].as_f64().unwrap();
    assert!((median - 1.1).abs() < 0.01, "{median}");
    let ts_json = read_json(&out.join("tileset.json"));
    let errs = schema_errors("tileset.schema.json", &ts_json);
    assert!(errs.is_empty(), "tileset.json: {}", errs.join("\n"));
    let v = gltf_validator(&out);
    assert_eq!(
        v["errors"].as_u64(),
        Some(0),
        "glTF-Validator: {:#}",
        v["messages"]
    );

    // In the leaf tiles: every building once; a roofed one has corners at three or more heights (ground, eaves,
    // ridge), a flat one at two.
    let ts = read_tileset(&out.join("tileset.json")).expect("read back");
    let mut leaves: BTreeMap<String, usize> = BTreeMap::new();
    let (mut roofed, mut flat) = (0, 0);
    for tile in ts.tiles.iter().filter(|t| t.children.is_empty()) {
        let Some(c) = &tile.content else { continue };
        let mut heights: Vec<std::collections::BTreeSet<i64>> =
            vec![Default::default(); c.features.len()];
        for (p, &f) in c.positions_local.iter().zip(&c.feature_ids) {
            if let Some(h) = heights.get_mut(f as usize) {
                h.insert((p[2] * 20.0).round() as i64);
            }
        }
        for (row, h) in c.features.iter().zip(&heights) {
            let Some(PropValue::Str(id)) = row.values.get("source_id") else {
                panic!("a leaf row without source_id: {row:?}");
            };
            *leaves.entry(id.clone()).or_default() += 1;
            let shape = match row.values.get("roof_shape") {
                Some(PropValue::Str(s)) => s.as_str(),
                _ => "",
            };
            if ROOFED.contains(&shape) {
                roofed += 1;
                assert!(h.len() >= 3, "{id} ({shape}): corners at {h:?} (×5 cm)");
            } else if shape.is_empty() || shape == "flat" {
                flat += 1;
                assert_eq!(h.len(), 2, "{id}: corners at {h:?} (×5 cm)");
            }
        }
    }
    assert_eq!(roofed, 26);
    assert!(flat > 1300, "{flat}");
    assert_eq!(
        leaves.len(),
        report["counts"]["buildings_written"].as_u64().unwrap() as usize
    );
    assert!(leaves.values().all(|&n| n == 1));

    // Below the blocks (tiles of building rows only): a roofed building in its prism's, its simplified model's and
    // its model's tiles; one without a roof once, its prism in a leaf beside the roofed ones' tile rather than
    // repeated in each tile of their chain (which made this tileset 1.26 instead of 0.83 MB).
    let mut below_blocks: BTreeMap<String, (usize, bool)> = BTreeMap::new();
    for tile in &ts.tiles {
        let Some(c) = &tile.content else { continue };
        if c.features
            .iter()
            .any(|r| r.values.contains_key("node_index"))
        {
            continue;
        }
        for row in &c.features {
            let Some(PropValue::Str(id)) = row.values.get("source_id") else {
                continue;
            };
            let roofed = matches!(row.values.get("roof_shape"), Some(PropValue::Str(s)) if ROOFED.contains(&s.as_str()));
            let e = below_blocks.entry(id.clone()).or_insert((0, roofed));
            e.0 += 1;
        }
    }
    let roofed_counts: Vec<usize> = below_blocks.values().filter(|v| v.1).map(|v| v.0).collect();
    assert_eq!(roofed_counts.len(), 26);
    assert!(roofed_counts.iter().all(|&n| n == 3), "{roofed_counts:?}");
    assert_eq!(below_blocks.len(), leaves.len());
    assert!(below_blocks.values().filter(|v| !v.1).all(|v| v.0 == 1));
    // Those leaves: tiles of error 0 beside a tile of the roofed buildings' prisms, under the same block tile.
    let prism_leaves = ts
        .tiles
        .iter()
        .filter(|t| t.children.is_empty() && t.geometric_error_m == 0.0)
        .filter(|t| {
            t.content.as_ref().is_some_and(|c| {
                c.features.iter().all(|r| {
                    !r.values.contains_key("node_index")
                        && !matches!(r.values.get("roof_shape"),
                            Some(PropValue::Str(s)) if ROOFED.contains(&s.as_str()))
                })
            })
        })
        .count();
    assert!(prism_leaves >= 1, "no leaf of modelless prisms");

    let check_out = e2e_dir("les-osm-roofs-check");
    let o = citylod(&[
        "check",
        &out.display().to_string(),
        "--out",
        &check_out.display().to_string(),
        "--quiet",
    ]);
    let check = read_json(&check_out.join("report.json"));
    assert_eq!(o.status.code(), Some(0), "{:#}", check["summary"]);
}

/// CityGML becomes the same kind of tileset as CityJSON: Zürich's LoD 2 buildings of thematic surfaces and
/// BuildingParts (CityGML 1.0, CH1903) with `--lod 2` get the model chain, valid glbs and a passing check; Delft's
/// 3dfier LoD 1 tile (CityGML 2.0) builds as prisms of its footprints.
#[test]
fn citygml_files_build_valid_tilesets() {
    let dir = repo_root().join("crates/citylod-ingest/tests/citygml");
    let out = e2e_dir("zurich-citygml");
    let report = build(
        &[&dir.join("zurich-lod2-citygml1.xml")],
        &out,
        &["--lod", "2"],
    );
    let errs = schema_errors("build-report.schema.json", &report);
    assert!(errs.is_empty(), "build report: {}", errs.join("\n"));
    assert_eq!(report["ingest"]["files"][0]["format"], "city_gml");
    assert_eq!(report["counts"]["buildings_written"], 4);
    assert_eq!(report["ingest"]["mesh_lods"], serde_json::json!({ "2": 4 }));
    assert_eq!(report["models"]["buildings"], 4, "{:#}", report["models"]);
    let ts_json = read_json(&out.join("tileset.json"));
    let errs = schema_errors("tileset.schema.json", &ts_json);
    assert!(errs.is_empty(), "tileset.json: {}", errs.join("\n"));
    let v = gltf_validator(&out);
    assert_eq!(
        v["errors"].as_u64(),
        Some(0),
        "glTF-Validator: {:#}",
        v["messages"]
    );
    let check_out = e2e_dir("zurich-citygml-check");
    let o = citylod(&[
        "check",
        &out.display().to_string(),
        "--out",
        &check_out.display().to_string(),
        "--quiet",
    ]);
    let check = read_json(&check_out.join("report.json"));
    assert_eq!(o.status.code(), Some(0), "{:#}", check["summary"]);

    let out = e2e_dir("delft-citygml");
    let report = build(&[&dir.join("delft-citygml2.xml")], &out, &[]);
    assert_eq!(report["counts"]["buildings_written"], 3);
    assert_eq!(
        report["ingest"]["height_sources"],
        serde_json::json!({ "known_attribute": 3 })
    );
    let v = gltf_validator(&out);
    assert_eq!(
        v["errors"].as_u64(),
        Some(0),
        "glTF-Validator: {:#}",
        v["messages"]
    );
}

#[test]
fn geoparquet_builds_valid_tilesets_whose_buildings_keep_overture_attributes() {
    let dir = repo_root().join("crates/citylod-ingest/tests/geoparquet");
    let out = e2e_dir("les-geoparquet");
    let report = build(&[&dir.join("les_overture.parquet")], &out, &["--lod", "2"]);
    let errs = schema_errors("build-report.schema.json", &report);
    assert!(errs.is_empty(), "build report: {}", errs.join("\n"));
    assert_eq!(report["ingest"]["files"][0]["format"], "geo_parquet");
    assert_eq!(report["counts"]["buildings_written"], 1403);
    assert_eq!(report["models"]["buildings"], 26, "{:#}", report["models"]);
    let ts_json = read_json(&out.join("tileset.json"));
    let errs = schema_errors("tileset.schema.json", &ts_json);
    assert!(errs.is_empty(), "tileset.json: {}", errs.join("\n"));
    let v = gltf_validator(&out);
    assert_eq!(
        v["errors"].as_u64(),
        Some(0),
        "glTF-Validator: {:#}",
        v["messages"]
    );
    // The leaf tiles' metadata carries Overture's columns as the building class's properties (a struct's field
    // as `names.primary`, named as a metadata id allows).
    let mut leaf_classes = 0;
    for (rel, bytes) in tree_bytes(&out) {
        if !rel.ends_with(".glb") {
            continue;
        }
        let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let gltf: Value = serde_json::from_slice(&bytes[20..20 + len]).unwrap();
        let classes = &gltf["extensions"]["EXT_structural_metadata"]["schema"]["classes"];
        if let Some(props) = classes["building"]["properties"].as_object() {
            leaf_classes += 1;
            for column in ["names_primary", "num_floors", "sources", "roof_shape"] {
                assert!(props.contains_key(column), "{rel}: {:?}", props.keys());
            }
        }
    }
    assert!(leaf_classes > 0);
    let check_out = e2e_dir("les-geoparquet-check");
    let o = citylod(&[
        "check",
        &out.display().to_string(),
        "--out",
        &check_out.display().to_string(),
        "--quiet",
    ]);
    let check = read_json(&check_out.join("report.json"));
    assert_eq!(o.status.code(), Some(0), "{:#}", check["summary"]);
}
