//! citylod build on the real data sets: counts add up, nothing is lost, placement on the globe is right,
//! every glb passes glTF-Validator, every JSON file validates against `schemas/`, output is deterministic.

use crate::common::*;
use citylod_model::ecef_to_geodetic;
use citylod_tiles::read::{read_tileset, TilesetData};
use citylod_tiles::PropValue;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Skip reasons a build may give; anything else means a reason was invented without a test.
const KNOWN_SKIP_REASONS: &[&str] = &[
    "no_geometry",
    "unsupported_geometry",
    "malformed_geometry",
    "empty_geometry",
    "non_finite_coordinate",
    "coordinate_out_of_range",
    "transform_failed",
    "too_few_points",
    "zero_area",
    "no_footprint",
    "repair_failed",
    "mesh_failed",
    "incomplete_in_extract",
    "drawn_by_parts",
];

/// Builds `name` into `target/e2e/<name>` and runs every check that does not depend on the input format.
fn build_and_check(name: &str, inputs: &[&Path], extra: &[&str]) -> (Value, TilesetData) {
    let out = e2e_dir(name);
    let report = build(inputs, &out, extra);

    // Counts add up: every feature read is written or skipped with a reason.
    let c = &report["counts"];
    let (read, written, skipped) = (
        c["features_read"].as_u64().unwrap(),
        c["buildings_written"].as_u64().unwrap(),
        c["skipped"].as_u64().unwrap(),
    );
    assert!(written > 0);
    assert_eq!(
        read,
        written + skipped,
        "{name}: features read != written + skipped"
    );
    let skipped_list: Vec<&Value> = report["ingest"]["skipped"]
        .as_array()
        .unwrap()
        .iter()
        .chain(report["mesh_skipped"].as_array().unwrap())
        .collect();
    assert_eq!(
        skipped_list.len() as u64,
        skipped,
        "{name}: every skip is listed"
    );
    for s in &skipped_list {
        let reason = s["reason"].as_str().unwrap();
        assert!(
            KNOWN_SKIP_REASONS.contains(&reason),
            "{name}: unknown skip reason {reason}"
        );
        assert!(
            !s["feature_id"].as_str().unwrap().is_empty(),
            "{name}: skip without a feature id"
        );
    }

    // JSON files against their schemas.
    let ts_json = read_json(&out.join("tileset.json"));
    let errs = schema_errors("tileset.schema.json", &ts_json);
    assert!(
        errs.is_empty(),
        "{name}: tileset.json schema errors:\n{}",
        errs.join("\n")
    );
    let errs = schema_errors("build-report.schema.json", &report);
    assert!(
        errs.is_empty(),
        "{name}: build-report.json schema errors:\n{}",
        errs.join("\n")
    );

    // Khronos glTF-Validator: zero errors on every glb.
    let v = gltf_validator(&out);
    assert!(
        v["files"].as_u64().unwrap() > 0,
        "{name}: validator saw no glb"
    );
    assert_eq!(
        v["errors"].as_u64(),
        Some(0),
        "{name}: glTF-Validator errors: {:#}",
        v["messages"]
    );

    // Nothing lost: every building exactly once in the leaf tiles.
    let ts = read_tileset(&out.join("tileset.json")).expect("read back the tileset");
    let mut seen = vec![0u32; written as usize];
    for tile in ts.tiles.iter().filter(|t| t.children.is_empty()) {
        let content = tile.content.as_ref().expect("every leaf tile has content");
        for row in &content.features {
            match row.values.get("building_index") {
                Some(PropValue::Int(i)) => seen[*i as usize] += 1,
                Some(PropValue::Float(f)) => seen[*f as usize] += 1,
                other => panic!("{name}: building_index missing or mistyped: {other:?}"),
            }
        }
    }
    let missing = seen.iter().filter(|&&n| n == 0).count();
    let twice = seen.iter().filter(|&&n| n > 1).count();
    assert_eq!(
        (missing, twice),
        (0, 0),
        "{name}: buildings missing / present more than once in the leaves"
    );
    blocks_stay_within_their_tile_error(name, &report, &ts);
    no_tile_is_stored_that_cannot_be_drawn(name, &ts);
    glb_schemas_match_schemas_metadata_json(name, &out);
    assert!(
        glb_metadata_follows_the_extensions(name, &out) > 0,
        "{name}: no property table"
    );
    top_is_condensed(name, &report, &ts);
    (report, ts)
}

/// A tile that is its parent's only child, with the parent's error and children of its own, refines whenever the
/// parent does, so it is written without content; and every tile without content below the root has its parent's
/// box and error, so a client never draws it (nothing) in the parent's stead.
fn no_tile_is_stored_that_cannot_be_drawn(name: &str, ts: &TilesetData) {
    for t in &ts.tiles {
        for &c in &t.children {
            let child = &ts.tiles[c];
            if t.children.len() == 1
                && child.geometric_error_m == t.geometric_error_m
                && !child.children.is_empty()
            {
                assert!(
                    child.content.is_none(),
                    "{name}: tile {} can never be drawn but has content",
                    child.path_in_tree
                );
            }
            if child.content.is_none() {
                assert_eq!(
                    (child.bounding_box, child.geometric_error_m),
                    (t.bounding_box, t.geometric_error_m),
                    "{name}: tile {} has no content, and would be drawn as nothing",
                    child.path_in_tree
                );
            }
        }
    }
}

/// No chain of tiny tiles at the top of the tree: a root with a single child has a child too large to be worth
/// a request of its own (`hlod::MIN_SPLIT_TRIANGLES`); the build report gives errors exactly for the levels written
/// (those above the root or left out by `--level-ratio` report null).
fn top_is_condensed(name: &str, report: &Value, ts: &TilesetData) {
    let root = ts.tiles.first().expect("a root tile");
    if let [only] = root.children[..] {
        let child = ts.tiles[only]
            .content
            .as_ref()
            .map_or(0, |c| c.triangles.len());
        assert!(
            root.content.is_none() || child > citylod_tiles::hlod::MIN_SPLIT_TRIANGLES,
            "{name}: the root's only child holds {child} triangles, small enough to be the root"
        );
    }
    for l in report["lod"].as_array().unwrap() {
        let written = l["tiles"].as_u64().unwrap() > 0;
        assert_eq!(
            (
                l["geometric_error_min_m"].is_null(),
                l["geometric_error_max_m"].is_null()
            ),
            (!written, !written),
            "{name}: level {}: errors reported exactly when the level is written",
            l["level"]
        );
    }
}

/// Every glb's inline metadata schema agrees with `schemas/metadata.json`: the `cluster` class is the same, and
/// the `building` class holds the documented fixed properties with the same definitions (plus the attributes);
/// the descriptions stay in the document, not in every glb.
fn glb_schemas_match_schemas_metadata_json(name: &str, out: &Path) {
    let doc = read_json(&repo_root().join("schemas/metadata.json"));
    let mut glbs = 0;
    // A schema id names one set of class definitions: `citylod_` and 8 hex digits, one id per distinct set.
    let mut ids: std::collections::BTreeMap<String, Value> = Default::default();
    for (rel, bytes) in tree_bytes(out) {
        if !rel.ends_with(".glb") {
            continue;
        }
        glbs += 1;
        let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let gltf: Value = serde_json::from_slice(&bytes[20..20 + len]).unwrap();
        let schema = &gltf["extensions"]["EXT_structural_metadata"]["schema"];
        let id = schema["id"].as_str().unwrap();
        let hex = id.strip_prefix("citylod_").unwrap_or("");
        assert!(
            hex.len() == 8 && hex.bytes().all(|b| b.is_ascii_hexdigit()),
            "{name}: {rel}: schema id {id}"
        );
        let first = ids
            .entry(id.to_string())
            .or_insert(schema["classes"].clone());
        assert_eq!(
            *first, schema["classes"],
            "{name}: {rel}: another schema with id {id}"
        );
        let classes = schema["classes"].as_object().unwrap();
        assert!(!classes.is_empty(), "{name}: {rel} has no class");
        for (class, def) in classes {
            let documented = doc["classes"][class]["properties"]
                .as_object()
                .unwrap_or_else(|| {
                    panic!("{name}: {rel}: class {class} is not in schemas/metadata.json")
                });
            let props = def["properties"].as_object().unwrap();
            for (prop, d) in documented {
                let mut d = d.clone();
                d.as_object_mut().unwrap().remove("description");
                assert_eq!(props.get(prop), Some(&d), "{name}: {rel}: {class}.{prop}");
            }
            if class == "cluster" {
                assert_eq!(
                    props.len(),
                    documented.len(),
                    "{name}: {rel}: cluster properties"
                );
            }
        }
    }
    assert!(glbs > 0, "{name}: no glb");
    let distinct: std::collections::BTreeSet<String> =
        ids.values().map(|v| v.to_string()).collect();
    assert_eq!(
        distinct.len(),
        ids.len(),
        "{name}: one class set under two ids"
    );
}

/// Blocks are re-outlined within their tile's geometricError: every block's own error, recomputed from the Δh and
/// Δa its metadata reports, is at most its tile's, the reported error matches them, and the re-outlining took
/// triangles off the levels above the buildings.
fn blocks_stay_within_their_tile_error(name: &str, report: &Value, ts: &TilesetData) {
    let kappa = ts.extras.as_ref().unwrap()["citylod"]["kappa"]
        .as_f64()
        .unwrap();
    let f = |row: &citylod_tiles::FeatureRow, key: &str| match row.values.get(key) {
        Some(PropValue::Float(v)) => *v,
        Some(PropValue::Int(v)) => *v as f64,
        other => panic!("{name}: {key} missing or mistyped: {other:?}"),
    };
    let mut blocks = 0;
    for tile in &ts.tiles {
        let Some(content) = &tile.content else {
            continue;
        };
        // Each feature's lowest and highest drawn z.
        let mut z_range = vec![(f64::MAX, f64::MIN); content.features.len()];
        for (p, &fid) in content.positions_local.iter().zip(&content.feature_ids) {
            if let Some(r) = z_range.get_mut(fid as usize) {
                *r = (r.0.min(p[2]), r.1.max(p[2]));
            }
        }
        for (k, row) in content.features.iter().enumerate() {
            if row.class != "cluster" || row.values.get("landmark") == Some(&PropValue::Bool(true))
            {
                continue;
            }
            blocks += 1;
            // A block is drawn from its ground_z_m up by its height_m (vertices rounded to at most 1/16 of the
            // tile's error, so within half that; FLOAT32 values); one that fell back shows its buildings.
            let fell_back = row.values.get("fallback") == Some(&PropValue::Bool(true));
            let (lo, hi) = z_range[k];
            if !fell_back && lo <= hi {
                let ground = f(row, "ground_z_m");
                let top = ground + f(row, "height_m");
                let tol = tile.geometric_error_m / 32.0 + 0.011 + 1e-6 * top.abs();
                assert!(
                    (lo - ground).abs() <= tol && (hi - top).abs() <= tol,
                    "{name}: tile {} block {:?} drawn from {lo} to {hi} m, its metadata says {ground} + {} m",
                    tile.path_in_tree,
                    row.values.get("node_index"),
                    f(row, "height_m")
                );
            }
            let own = f(row, "dh_m").max(kappa * f(row, "da_m2").sqrt());
            // A block that fell back to its buildings' prisms also claims their distance from any 3D models.
            let reported = f(row, "geometric_error_m");
            assert!(
                (own - reported).abs() <= 1e-6 * own.max(1.0) || (fell_back && reported > own),
                "{name}: tile {} block {:?}: reported error {} != max(Δh, κ√Δa) {own}",
                tile.path_in_tree,
                row.values.get("node_index"),
                f(row, "geometric_error_m")
            );
            // The block's Δh, Δa and error are FLOAT32 properties: each is the f64 value rounded to the nearest
            // single, within a relative 2^-24 of it.
            assert!(
                reported.max(own) <= tile.geometric_error_m * (1.0 + f32::EPSILON as f64),
                "{name}: tile {} (error {} m) holds a block of error {own} m",
                tile.path_in_tree,
                tile.geometric_error_m
            );
        }
    }
    let levels = report["lod"].as_array().unwrap();
    if levels.len() > 1 {
        assert!(blocks > 0, "{name}: no block in an LOD tileset");
        let sum = |key: &str| -> u64 { levels[1..].iter().map(|l| l[key].as_u64().unwrap()).sum() };
        let (after, before) = (sum("triangles"), sum("triangles_as_generalized"));
        let refilled: u64 = sum("blocks_reoutlined");
        assert!(
            refilled > 0 && after < before,
            "{name}: re-outlining within the tile errors changed nothing ({refilled} blocks, {before} → {after} triangles)"
        );
        eprintln!("{name}: levels above the buildings {before} → {after} triangles, {refilled} blocks re-outlined");
    }
}

/// Buildings are written on a 2 cm grid: each corner of a bounding box moves at most 1 cm per axis (1.41 cm), plus
/// the flat-earth metres per degree used to compare (0.1 % of a centimetre-sized difference).
const PLACEMENT_TOLERANCE_M: f64 = 0.015;

/// Largest distance (m) between the lon/lat bounding box of each building's base read back from the tileset (root
/// transform × glb positions → ECEF → WGS84) and the bounding box of its input ring coordinates, over every
/// building the build report does not list as repaired (a repair may move a ring's points); with how many were
/// compared.
fn placement_error_m(geojson: &Path, ts: &TilesetData, report: &Value) -> (f64, usize) {
    let doc = read_json(geojson);
    let features = doc["features"].as_array().unwrap();
    let input_feature = input_feature_of(features);
    let repaired: BTreeSet<&str> = report["ingest"]["repaired"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["feature_id"].as_str().unwrap())
        .collect();
    let m = ts.root_transform;
    let mut worst = 0.0f64;
    let mut checked = 0;
    for tile in ts.tiles.iter().filter(|t| t.children.is_empty()) {
        let content = tile.content.as_ref().unwrap();
        // Each feature's lon/lat bounds at its base: walls rise along the frame's up, which leans from the local
        // vertical by the distance to the frame's origin over the earth's radius (a 91 m tower 3.6 km out: its roof
        // stands 5 cm off its footprint in lon/lat).
        let mut base_z = vec![f64::MAX; content.features.len()];
        for (v, p) in content.positions_local.iter().enumerate() {
            if let Some(z) = base_z.get_mut(content.feature_ids[v] as usize) {
                *z = z.min(p[2]);
            }
        }
        let mut bounds = vec![([f64::MAX; 2], [f64::MIN; 2]); content.features.len()];
        for (v, p) in content.positions_local.iter().enumerate() {
            let f = content.feature_ids[v] as usize;
            let Some(b) = bounds.get_mut(f).filter(|_| p[2] <= base_z[f] + 0.011) else {
                continue;
            };
            let e: [f64; 3] = std::array::from_fn(|r| {
                m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]
            });
            let g = ecef_to_geodetic(e);
            b.0 = [b.0[0].min(g[0]), b.0[1].min(g[1])];
            b.1 = [b.1[0].max(g[0]), b.1[1].max(g[1])];
        }
        for (row, (glo, ghi)) in content.features.iter().zip(bounds) {
            let Some(PropValue::Str(source_id)) = row.values.get("source_id") else {
                panic!("source_id missing")
            };
            if repaired.contains(source_id.as_str()) {
                continue;
            }
            let index = input_feature(source_id);
            let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
            collect_coords(&features[index]["geometry"]["coordinates"], &mut |x, y| {
                lo = [lo[0].min(x), lo[1].min(y)];
                hi = [hi[0].max(x), hi[1].max(y)];
            });
            let lat = (lo[1] + hi[1]).to_radians() / 2.0;
            let m_per_deg_lat = 111_132.0;
            let m_per_deg_lon = 111_320.0 * lat.cos();
            for (a, b) in [(lo, glo), (hi, ghi)] {
                let d = ((a[0] - b[0]) * m_per_deg_lon).hypot((a[1] - b[1]) * m_per_deg_lat);
                worst = worst.max(d);
            }
            checked += 1;
        }
    }
    (worst, checked)
}

/// The index of the GeoJSON feature a `source_id` read back from a tile names: its `id`, OSM's `osm_type/osm_id`
/// ("way/110"), or the generated `feature-N` / `file#N` of a feature without an id.
fn input_feature_of(features: &[Value]) -> impl Fn(&str) -> usize {
    let mut by_id: BTreeMap<String, usize> = BTreeMap::new();
    for (i, f) in features.iter().enumerate() {
        if let Some(id) = f.get("id").filter(|v| !v.is_null()) {
            by_id.insert(
                id.as_str()
                    .map(str::to_string)
                    .unwrap_or_else(|| id.to_string()),
                i,
            );
        }
        let p = &f["properties"];
        if let (Some(t), Some(n)) = (p["osm_type"].as_str(), p["osm_id"].as_i64()) {
            by_id.insert(format!("{t}/{n}"), i);
        }
    }
    move |source_id: &str| {
        by_id
            .get(source_id)
            .copied()
            .or_else(|| source_id.rsplit('#').next().and_then(|n| n.parse().ok()))
            .unwrap_or_else(|| panic!("cannot find input feature {source_id}"))
    }
}

/// Every input attribute of every building reads back from its leaf tile as it was: integers as integers (an
/// INT32 column), other numbers as doubles, text as text, null or empty text as no value; an attribute the
/// report lists as folded, as the same JSON value in the folded property's object. Returns the number of values
/// compared and how many of them were folded.
fn attributes_read_back(
    name: &str,
    geojson: &Path,
    report: &Value,
    ts: &TilesetData,
) -> (usize, usize) {
    let folded: Vec<&str> = report["attributes"]["folded"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    let folded_property = report["attributes"]["folded_property"].as_str();
    let mut n_folded = 0;
    let doc = read_json(geojson);
    let features = doc["features"].as_array().unwrap();
    let input_feature = input_feature_of(features);
    let mut compared = 0;
    for tile in ts.tiles.iter().filter(|t| t.children.is_empty()) {
        for row in &tile.content.as_ref().unwrap().features {
            let Some(PropValue::Str(source_id)) = row.values.get("source_id") else {
                panic!("{name}: source_id missing")
            };
            let props = features[input_feature(source_id)]["properties"]
                .as_object()
                .unwrap();
            for (key, v) in props {
                if folded.contains(&key.as_str()) {
                    // A null is no value: left out of the folded object (which is null when nothing is left).
                    if v.is_null() {
                        if let Some(PropValue::Str(text)) = row.values.get(folded_property.unwrap())
                        {
                            let object: Value = serde_json::from_str(text).unwrap();
                            assert!(
                                object.get(key).is_none(),
                                "{name}: {source_id}: null {key} folded"
                            );
                        }
                        compared += 1;
                        continue;
                    }
                    let Some(PropValue::Str(text)) = row.values.get(folded_property.unwrap())
                    else {
                        panic!("{name}: {source_id}: no folded attributes, {key} expected")
                    };
                    let object: Value = serde_json::from_str(text).unwrap();
                    let want = match v {
                        Value::Object(_) | Value::Array(_) => Value::String(v.to_string()),
                        other => other.clone(),
                    };
                    assert_eq!(
                        object[key], want,
                        "{name}: {source_id}: folded attribute {key}"
                    );
                    n_folded += 1;
                    compared += 1;
                    continue;
                }
                // Attribute names become property ids (`building:levels` → `building_levels`).
                let id: String = key
                    .chars()
                    .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                    .collect();
                let want = match v {
                    Value::Null => PropValue::Null,
                    Value::String(t) if t.is_empty() => PropValue::Null,
                    Value::String(t) => PropValue::Str(t.clone()),
                    Value::Number(n) => n
                        .as_i64()
                        .map_or_else(|| PropValue::Float(n.as_f64().unwrap()), PropValue::Int),
                    Value::Bool(b) => PropValue::Bool(*b),
                    other => PropValue::Str(other.to_string()),
                };
                let got = row.values.get(&id).unwrap_or(&PropValue::Null);
                assert_eq!(got, &want, "{name}: {source_id}: attribute {key}");
                compared += 1;
            }
        }
    }
    (compared, n_folded)
}

fn collect_coords(v: &Value, f: &mut impl FnMut(f64, f64)) {
    match v.as_array() {
        Some(a) if a.len() >= 2 && a[0].is_number() => {
            f(a[0].as_f64().unwrap(), a[1].as_f64().unwrap())
        }
        Some(a) => a.iter().for_each(|c| collect_coords(c, f)),
        None => {}
    }
}

#[test]
fn nyc_les_tileset_is_valid_complete_and_in_place() {
    // The bundled copy, so this runs on every clone.
    let input = repo_root().join("examples/nyc-les/les_buildings.geojson");
    let (report, ts) = build_and_check("nyc", &[&input], &[]);
    assert_eq!(report["counts"]["features_read"], 1416);
    // 13 outlines are drawn by their building:parts.
    assert_eq!(report["counts"]["buildings_written"], 1403);
    assert_eq!(report["ingest"]["skipped_by_reason"]["drawn_by_parts"], 13);
    // OSM heights are strings ("28"); most buildings have one.
    let from_attr = report["ingest"]["height_sources"]["known_attribute"]
        .as_u64()
        .unwrap_or(0);
    assert!(
        from_attr >= 1300,
        "expected string heights to parse, got {from_attr} from attributes"
    );
    let (err_m, n) = placement_error_m(&input, &ts, &report);
    assert!(n >= 1400, "placement checked on {n} buildings only");
    assert!(
        err_m < PLACEMENT_TOLERANCE_M,
        "placement error {err_m:.4} m"
    );
    // OSM tags are text, osm_id an integer; 1,403 buildings with osm_type and osm_id at least.
    // building:min_level, on 6 of the 1,403, is folded into other_attributes with the others under 1 %.
    let (compared, folded) = attributes_read_back("nyc", &input, &report, &ts);
    assert!(compared >= 2 * 1403);
    assert!(folded >= 6, "{folded} folded values");
    assert_eq!(report["attributes"]["folded_property"], "other_attributes");
    // A few rough level-1 blocks (a 10 m and a 57 m building merged by touching) would set the error of their
    // whole tile: they are drawn there as their buildings instead, level-0 features of the cluster class, and
    // `citylod check` (above) found every building of every cut exactly once.
    let demoted = report["lod"][1]["blocks_drawn_as_children"]
        .as_u64()
        .unwrap();
    let buildings_in_block_tiles = ts
        .tiles
        .iter()
        .filter(|t| !t.children.is_empty())
        .filter_map(|t| t.content.as_ref())
        .flat_map(|c| &c.features)
        .filter(|r| r.class == "cluster" && r.values.get("level") == Some(&PropValue::Int(0)))
        .count();
    assert!(
        demoted > 0 && buildings_in_block_tiles >= 2 * demoted as usize,
        "nyc: {demoted} level-1 blocks drawn as their buildings, {buildings_in_block_tiles} buildings in block tiles"
    );
    let (drawn, reoutlined) = demoted_buildings_reoutlined("nyc", &ts);
    assert!(
        reoutlined > 0 && drawn == buildings_in_block_tiles,
        "nyc: {reoutlined} of {drawn} buildings drawn for rough blocks re-outlined"
    );
}

/// Buildings drawn in a rough block's stead are re-outlined within the error of the tile that draws them, like
/// the blocks beside them: a row that claims added or cut area (Δa > 0) draws fewer triangles than the same
/// building in its leaf tile (its error against the tile's is checked with every block's). Returns how many
/// such buildings the block tiles draw and how many of them were re-outlined.
fn demoted_buildings_reoutlined(name: &str, ts: &TilesetData) -> (usize, usize) {
    let triangles_per_feature = |c: &citylod_tiles::read::GlbData| {
        let mut n = vec![0usize; c.features.len()];
        for t in &c.triangles {
            n[c.feature_ids[t[0] as usize] as usize] += 1;
        }
        n
    };
    let source_id = |row: &citylod_tiles::FeatureRow| match row.values.get("source_id") {
        Some(PropValue::Str(s)) => s.clone(),
        other => panic!("{name}: source_id {other:?}"),
    };
    let mut in_leaf: BTreeMap<String, usize> = BTreeMap::new();
    for c in ts
        .tiles
        .iter()
        .filter(|t| t.children.is_empty())
        .filter_map(|t| t.content.as_ref())
    {
        for (row, n) in c.features.iter().zip(triangles_per_feature(c)) {
            in_leaf.insert(source_id(row), n);
        }
    }
    let (mut drawn, mut reoutlined) = (0, 0);
    for c in ts
        .tiles
        .iter()
        .filter(|t| !t.children.is_empty())
        .filter_map(|t| t.content.as_ref())
    {
        for (row, n) in c.features.iter().zip(triangles_per_feature(c)) {
            if row.class != "cluster" || row.values.get("level") != Some(&PropValue::Int(0)) {
                continue;
            }
            drawn += 1;
            let Some(PropValue::Float(da)) = row.values.get("da_m2") else {
                panic!("{name}: da_m2 missing")
            };
            if *da > 0.0 {
                reoutlined += 1;
                let id = source_id(row);
                assert!(n < in_leaf[&id], "{name}: {id} re-outlined (Δa {da} m²) but drawn with {n} triangles, {} in its leaf", in_leaf[&id]);
            }
        }
    }
    (drawn, reoutlined)
}

#[test]
fn nyc_les_with_streets_is_valid_complete_and_reports_its_barriers() {
    let dir = repo_root().join("examples/nyc-les");
    let (buildings, roads) = (
        dir.join("les_buildings.geojson"),
        dir.join("les_roads.geojson"),
    );
    let (report, ts) = build_and_check(
        "nyc-les-streets",
        &[&buildings],
        &["--streets", roads.to_str().unwrap()],
    );
    let s = &report["streets"];
    assert_eq!(s["features_read"], 432, "{s}");
    assert_eq!(s["features_used"], 432, "{s}");
    assert!(s["length_m"].as_f64().unwrap() > 30_000.0, "{s}");
    let g = &report["generalize"]["streets"];
    assert!(g["barrier_level"].as_u64().unwrap() >= 2, "{g}");
    assert!(g["merges_across"].as_u64().unwrap() > 0, "{g}");
    top_is_condensed("nyc-les-streets", &report, &ts);
    blocks_stay_within_their_tile_error("nyc-les-streets", &report, &ts);
}

#[test]
fn nyc_les_with_its_streets_as_a_geopackage_tiles_as_with_them_as_geojson() {
    // The bundled road lines written as a GeoPackage line layer beside a building layer, as a city GIS team keeps them.
    use citylod_testdata::geopackage::{blob, write, Envelope, Layer, Row, Wkb};
    use rusqlite::types::Value as Sql;
    let dir = repo_root().join("examples/nyc-les");
    let (buildings, roads) = (
        dir.join("les_buildings.geojson"),
        dir.join("les_roads.geojson"),
    );
    let doc = read_json(&roads);
    let wkb = Wkb::default();
    let rows: Vec<Row> = doc["features"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let pts: Vec<[f64; 2]> = f["geometry"]["coordinates"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
                .collect();
            Row {
                fid: i as i64 + 1,
                geometry: Some(blob(4326, Envelope::Xy, false, &wkb.line(&pts))),
                values: vec![Sql::Text(
                    f["properties"]["name"].as_str().unwrap_or("").into(),
                )],
            }
        })
        .collect();
    let layer = |table: &str, geometry_type: &str, rows: Vec<Row>| Layer {
        table: table.into(),
        geometry_column: "geom".into(),
        geometry_type: geometry_type.into(),
        srs_id: 4326,
        columns: vec![("name".into(), "TEXT".into())],
        rows,
    };
    let scratch = scratch_dir("nyc-les-streets-gpkg");
    let gpkg = scratch.join("les.gpkg");
    let square = vec![
        [-73.99, 40.72],
        [-73.9899, 40.72],
        [-73.9899, 40.7201],
        [-73.99, 40.72],
    ];
    let building = Row {
        fid: 1,
        geometry: Some(blob(4326, Envelope::Xy, false, &wkb.polygon(&[square]))),
        values: vec![Sql::Text("b".into())],
    };
    write(
        &gpkg,
        &[],
        &[
            layer("buildings", "POLYGON", vec![building]),
            layer("roads", "LINESTRING", rows),
        ],
    );

    let (a, b) = (scratch.join("geojson"), scratch.join("gpkg"));
    let from_json = build(&[&buildings], &a, &["--streets", roads.to_str().unwrap()]);
    let from_gpkg = build(&[&buildings], &b, &["--streets", gpkg.to_str().unwrap()]);
    let s = &from_gpkg["streets"];
    assert_eq!(
        (s["features_read"].as_u64(), s["features_used"].as_u64()),
        (Some(432), Some(432)),
        "{s}"
    );
    assert!(s["crs"].as_str().unwrap().starts_with("EPSG:4326"), "{s}");
    assert_eq!(s["segments"], from_json["streets"]["segments"]);
    assert_eq!(
        from_gpkg["generalize"]["streets"],
        from_json["generalize"]["streets"]
    );
    assert!(
        from_gpkg["generalize"]["streets"]["merges_across"]
            .as_u64()
            .unwrap()
            > 0
    );
    // Every tile and tileset byte alike; only the report names the other street file.
    let tiles = |d: &Path| {
        tree_bytes(d)
            .into_iter()
            .filter(|(n, _)| n != "build-report.json")
            .collect::<Vec<_>>()
    };
    let (ta, tb) = (tiles(&a), tiles(&b));
    assert!(ta.len() > 10 && ta.len() == tb.len());
    for ((name, x), (other, y)) in ta.iter().zip(&tb) {
        assert!(
            name == other && x == y,
            "{name} differs between the GeoJSON and the GeoPackage streets"
        );
    }
}

#[test]
fn nyc_les_from_its_osm_pbf_is_valid_complete_and_keeps_its_streets() {
    // The OpenStreetMap file the bundled GeoJSON was converted from, as buildings and as streets.
    let pbf = repo_root().join("examples/nyc-les/ny-access-restriction.osm.pbf");
    let (report, ts) = build_and_check(
        "nyc-les-pbf",
        &[&pbf],
        &["--streets", pbf.to_str().unwrap()],
    );
    let file = &report["ingest"]["files"][0];
    assert_eq!(file["format"], "osm_pbf", "{file}");
    // The 1,403 buildings of the GeoJSON export, and 4 self-intersecting outlines the export dropped, repaired.
    assert_eq!(
        report["counts"]["buildings_written"], 1407,
        "{}",
        report["counts"]
    );
    assert_eq!(report["ingest"]["building_parts"], 132);
    let s = &report["streets"];
    assert!(s["features_used"].as_u64().unwrap() > 400, "{s}");
    assert!(s["length_m"].as_f64().unwrap() > 30_000.0, "{s}");
    assert!(
        report["generalize"]["streets"]["barrier_level"]
            .as_u64()
            .unwrap()
            >= 2,
        "{}",
        report["generalize"]["streets"]
    );
    top_is_condensed("nyc-les-pbf", &report, &ts);
}

#[test]
fn nyc_les_from_a_file_geodatabase_in_state_plane_feet_is_valid_and_complete() {
    // The bundled GeoJSON as GDAL's OpenFileGDB driver wrote it, in EPSG:2263 (US survey feet).
    let gdb = repo_root().join("crates/citylod-ingest/tests/fgdb/nyc-les-2263.gdb");
    let (report, ts) = build_and_check("nyc-les-gdb", &[&gdb], &["--layer", "buildings"]);
    let file = &report["ingest"]["files"][0];
    assert_eq!(file["format"], "file_geodatabase", "{file}");
    assert_eq!(file["crs"], "EPSG:2263", "{file}");
    // As from the GeoJSON: OSM's building:part, written building_part there, still draws outlines by their parts.
    assert_eq!(
        report["counts"]["buildings_written"], 1403,
        "{}",
        report["counts"]
    );
    assert_eq!(report["ingest"]["building_parts"], 132);
    top_is_condensed("nyc-les-gdb", &report, &ts);
}

#[test]
fn boston_tileset_is_valid_complete_and_in_place() {
    let Some(input) = shared_data("boston/boston_buildings.geojson") else {
        return;
    };
    let (report, ts) = build_and_check("boston", &[&input], &["--storey-height", "3.5"]);
    assert_eq!(report["counts"]["features_read"], 22186);
    let hs = &report["ingest"]["height_sources"];
    // 82 % have `stories`; the rest fall back to the default height, and both are counted.
    let storeys = hs["storeys"].as_u64().unwrap_or(0);
    let default = hs["default"].as_u64().unwrap_or(0);
    assert!(storeys > 15_000 && default > 2_000, "height sources: {hs}");
    let (err_m, n) = placement_error_m(&input, &ts, &report);
    assert!(n >= 22_000, "placement checked on {n} buildings only");
    assert!(
        err_m < PLACEMENT_TOLERANCE_M,
        "placement error {err_m:.4} m"
    );
    // Seven attributes each: `id` an integer, `stories` a double or null, the rest text.
    let written = report["counts"]["buildings_written"].as_u64().unwrap() as usize;
    assert_eq!(
        attributes_read_back("boston", &input, &report, &ts),
        (7 * written, 0)
    );
    // 1,885 buildings drawn for rough level-1 blocks (2026-11-22); most are re-outlined.
    let (drawn, reoutlined) = demoted_buildings_reoutlined("boston", &ts);
    assert!(
        reoutlined * 2 > drawn,
        "boston: {reoutlined} of {drawn} buildings drawn for rough blocks re-outlined"
    );
}

#[test]
fn delft_cityjsonseq_tileset_is_valid_and_complete() {
    let Some(input) = shared_data("delft-3dbag/delft.city.jsonl") else {
        return;
    };
    let (report, ts) = build_and_check("delft", &[&input], &[]);
    assert_eq!(report["counts"]["features_read"], 1115);
    assert!(
        report["ingest"]["height_sources"]["roof_minus_ground"]
            .as_u64()
            .unwrap_or(0)
            > 1000
    );
    // RD New (EPSG:28992) → WGS84: the tileset's origin lies in south Delft.
    let o = ecef_to_geodetic([
        ts.root_transform[12],
        ts.root_transform[13],
        ts.root_transform[14],
    ]);
    assert!(
        (4.33..4.40).contains(&o[0]) && (51.98..52.03).contains(&o[1]),
        "origin {o:?} is not in Delft"
    );
}

#[test]
fn same_input_gives_byte_identical_output() {
    let input = repo_root().join("examples/nyc-les/les_buildings.geojson");
    let d = scratch_dir("determinism");
    let (a, b, c) = (d.join("a"), d.join("b"), d.join("c"));
    build(&[&input], &a, &[]);
    build(&[&input], &b, &[]);
    assert_same_files(&a, &b, "the same input twice");
    // Nor does the number of threads change a byte: a user with more cores gets the same tileset.
    for threads in ["1", "3"] {
        let t = d.join(format!("threads-{threads}"));
        build_with_env(&[&input], &t, &[], &[("RAYON_NUM_THREADS", threads)]);
        assert_same_files(&a, &t, &format!("RAYON_NUM_THREADS={threads}"));
    }
    // Timings only on request, and then the only difference.
    let timed = build(&[&input], &c, &["--report-timings"]);
    assert!(
        timed["timings_ms"]["total"].as_u64().is_some(),
        "{}",
        timed["timings_ms"]
    );
    let plain = read_json(&a.join("build-report.json"));
    assert!(plain.get("timings_ms").is_none());
    let mut stripped = timed.clone();
    stripped.as_object_mut().unwrap().remove("timings_ms");
    stripped["options"]
        .as_object_mut()
        .unwrap()
        .remove("report_timings");
    let mut plain_opts = plain.clone();
    plain_opts["options"]
        .as_object_mut()
        .unwrap()
        .remove("report_timings");
    assert_eq!(stripped, plain_opts);
    let _ = std::fs::remove_dir_all(&d);
}

/// `--height-offset` raises the tileset's frame along its up axis and changes nothing else: every glb is
/// byte-identical, the root transform's origin moves by the offset, the report says so.
#[test]
fn height_offset_and_geoid_raise_the_frame_and_nothing_else() {
    let input = repo_root().join("examples/nyc-les/les_buildings.geojson");
    let d = scratch_dir("height-offset");
    let (plain, raised) = (d.join("plain"), d.join("raised"));
    const OFFSET_M: f64 = -33.25;
    let r0 = build(&[&input], &plain, &[]);
    let r1 = build(
        &[&input],
        &raised,
        &[&format!("--height-offset={OFFSET_M}")],
    );
    let (t0, t1) = (tree_bytes(&plain), tree_bytes(&raised));
    assert_eq!(t0.len(), t1.len());
    let mut glbs = 0;
    for ((n0, b0), (n1, b1)) in t0.iter().zip(&t1) {
        assert_eq!(n0, n1);
        if n0.ends_with(".glb") {
            assert!(b0 == b1, "{n0} changed with --height-offset");
            glbs += 1;
        }
    }
    assert!(glbs > 5);
    let h = |r: &Value| r["frame"]["origin_h_m"].as_f64().unwrap();
    assert!(
        (h(&r1) - h(&r0) - OFFSET_M).abs() < 1e-9,
        "{} vs {}",
        h(&r1),
        h(&r0)
    );
    assert_eq!(r1["options"]["height_offset_m"], OFFSET_M);
    assert!(r1["ingest"]["frame_rule"]
        .as_str()
        .unwrap()
        .contains("--height-offset"));
    // The root transform's origin (ECEF) moved by the offset along the ellipsoid normal at the origin.
    let origin = |dir: &Path| -> [f64; 3] {
        let m = &read_json(&dir.join("tileset.json"))["root"]["transform"];
        std::array::from_fn(|i| m[12 + i].as_f64().unwrap())
    };
    let (o0, o1) = (origin(&plain), origin(&raised));
    let (g0, g1) = (ecef_to_geodetic(o0), ecef_to_geodetic(o1));
    assert!(
        (g1[0] - g0[0]).abs() < 1e-9 && (g1[1] - g0[1]).abs() < 1e-9,
        "{g0:?} {g1:?}"
    );
    assert!((g1[2] - g0[2] - OFFSET_M).abs() < 1e-3, "{g0:?} {g1:?}");

    // --geoid egm96 adds EGM96's geoid height at the origin (New York: about −32.7 m), on top of --height-offset,
    // and nothing else changes.
    let above_sea = d.join("geoid");
    let r2 = build(
        &[&input],
        &above_sea,
        &["--geoid", "egm96", &format!("--height-offset={OFFSET_M}")],
    );
    let errors = schema_errors("build-report.schema.json", &r2);
    assert!(errors.is_empty(), "{errors:?}");
    let g = &r2["geoid"];
    let n = g["height_m"].as_f64().unwrap();
    assert!((-33.2..=-32.2).contains(&n), "{g}");
    assert!(
        (h(&r2) - h(&r0) - n - OFFSET_M).abs() < 1e-9,
        "{} vs {}",
        h(&r2),
        h(&r0)
    );
    let (lo, hi) = (g["min_m"].as_f64().unwrap(), g["max_m"].as_f64().unwrap());
    assert!(lo <= n + 0.005 && n - 0.005 <= hi && hi - lo < 0.2, "{g}");
    assert_eq!(r2["options"]["geoid"], "egm96");
    assert!(r2["ingest"]["frame_rule"]
        .as_str()
        .unwrap()
        .contains("--geoid egm96"));
    for ((n0, b0), (n2, b2)) in t0.iter().zip(&tree_bytes(&above_sea)) {
        assert_eq!(n0, n2);
        assert!(
            !n0.ends_with(".glb") || b0 == b2,
            "{n0} changed with --geoid"
        );
    }
    assert!(r0.get("geoid").is_none() && r1.get("geoid").is_none());
    let _ = std::fs::remove_dir_all(&d);
}

/// A square house of `d` degrees at (lon, lat), 12 m tall, as a GeoJSON feature.
fn house(id: &str, lon: f64, lat: f64, d: f64) -> Value {
    serde_json::json!({"type": "Feature", "id": id, "properties": {"height": 12.0}, "geometry": {"type": "Polygon",
        "coordinates": [[[lon, lat], [lon + d, lat], [lon + d, lat + d], [lon, lat + d], [lon, lat]]]}})
}

/// Houses on both sides of the antimeridian (and one across it, its ring jumping from 179.9999° to −179.9999°) are
/// placed where they are, standing upright: the frame is centred on the antimeridian, not on the far side of the
/// Earth. Buildings too far apart for one local frame are refused with the reason.
#[test]
fn antimeridian_data_is_placed_upright_and_too_wide_data_is_refused() {
    let d = scratch_dir("antimeridian");
    let mut features = Vec::new();
    for (i, lon) in [179.9990, 179.9995, -179.9999, -179.9993]
        .into_iter()
        .enumerate()
    {
        features.push(house(&format!("h{i}"), lon, -16.5, 0.0001));
    }
    let across = serde_json::json!({"type": "Feature", "id": "across", "properties": {"height": 12.0},
        "geometry": {"type": "Polygon", "coordinates": [[[179.99995, -16.5005], [-179.99995, -16.5005],
            [-179.99995, -16.5004], [179.99995, -16.5004], [179.99995, -16.5005]]]}});
    features.push(across);
    let input = d.join("fiji.geojson");
    std::fs::write(
        &input,
        serde_json::json!({"type": "FeatureCollection", "features": features}).to_string(),
    )
    .unwrap();
    let out = d.join("out");
    let report = build(&[&input], &out, &[]);
    assert_eq!(
        report["counts"]["buildings_written"], 5,
        "{}",
        report["ingest"]
    );
    let ts = read_tileset(&out.join("tileset.json")).unwrap();
    let m = ts.root_transform;
    let mut vertices = 0;
    for tile in ts.tiles.iter().filter(|t| t.children.is_empty()) {
        for p in &tile.content.as_ref().unwrap().positions_local {
            let e: [f64; 3] = std::array::from_fn(|r| {
                m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]
            });
            let g = ecef_to_geodetic(e);
            assert!(g[0].abs() > 179.998 && (g[1] + 16.5).abs() < 0.001, "{g:?}");
            // Ground at 0 m, roofs at 12 m: upright prisms on the ellipsoid (the 2 cm grid, Earth's curvature
            // over ~200 m well under it).
            assert!(g[2].abs() < 0.03 || (g[2] - 12.0).abs() < 0.03, "{g:?}");
            vertices += 1;
        }
    }
    assert!(vertices >= 5 * 8, "{vertices}");

    let nyc = repo_root().join("examples/nyc-les/les_buildings.geojson");
    let sydney = d.join("sydney.geojson");
    std::fs::write(
        &sydney,
        serde_json::json!({"type": "FeatureCollection", "features": [house("s", 151.2, -33.87, 0.0001)]}).to_string(),
    )
    .unwrap();
    let far_out = d.join("far");
    let args = [
        "build",
        nyc.to_str().unwrap(),
        sydney.to_str().unwrap(),
        "--out",
        far_out.to_str().unwrap(),
    ];
    let o = citylod(&args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("tile each region separately"), "{stderr}");
    // The stray one is named, with its file, among NYC's 1,416.
    assert!(
        stderr.contains("1 building(s) lie over 100 km")
            && stderr.contains("farthest: \"s\" in ")
            && stderr.contains("sydney.geojson at (151.2"),
        "{stderr}"
    );
    assert!(!far_out.exists());
    let _ = std::fs::remove_dir_all(&d);
}
