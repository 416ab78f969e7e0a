//! "No panic on any input file" for the JSON family (GeoJSON, newline-delimited GeoJSON, CityJSON, CityJSONSeq), on
//! the footprint path and the 3D model path (`--lod`: CityJSON solids and surfaces, geometry templates, OpenStreetMap
//! roof shapes). Small valid inputs are parsed into a `serde_json::Value`, mutated structurally with a seeded
//! SplitMix64 (a node replaced by null, a huge number or index, an empty or deeply nested array; a member deleted or
//! renamed; an array element duplicated, an array truncated or reversed; a transform scale of 0; …), sometimes also
//! as text after serializing (cut short, one byte changed), and ingested with and without an LoD. Each case must
//! give an error or buildings and skips whose counts add up, never a panic or a hang; a failing case names its
//! input, seed and mutations (rerun one with `JSON_MUTATIONS_ONLY=<input>:<seed>`). Counts of the outcomes make sure
//! the mutations reach the readers: some cases give buildings, some skips, some errors, some 3D models.

mod harness;

use citylod_ingest::{ingest, IngestError, IngestOptions, LodChoice};
use citylod_testdata::{fnv1a as fnv, SplitMix64};
use harness::{check, guarded, Outcome};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

// ---------------------------------------------------------------------------------------------------------------
// Inputs

/// A valid input: a JSON document, or the lines of a sequence (CityJSONSeq: header first; GeoJSON: one Feature each).
struct Input {
    /// The file name it is written under (its extension matters: `.jsonl` is read as CityJSONSeq).
    name: &'static str,
    lines: Vec<Value>,
    /// Written one value per line (a sequence) rather than as one document.
    sequence: bool,
    /// An attribute its buildings have, for `--id-attr` now and then.
    id_attr: Option<&'static str>,
    /// Whether the valid input carries 3D models (CityJSON solids, OSM roof shapes) with an LoD.
    has_models: bool,
    /// A valid file near it, of the other family, read before it now and then (`None`: a valid copy of itself).
    companion: Option<PathBuf>,
}

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/cityjson")
        .join(name)
}

/// The first 24 buildings of the Lower East Side extract (OpenStreetMap tags: heights, levels, a building:part) and
/// the first six further ones with a `roof:shape` other than flat, at most two of a shape (gabled, pyramidal, onion,
/// dome), so that `--lod 2` builds roofs.
fn lower_east_side() -> Input {
    let mut doc = read_json(&repo_root().join("examples/nyc-les/les_buildings.geojson"));
    let all = doc["features"].as_array().expect("features").clone();
    let mut picked: Vec<Value> = all.iter().take(24).cloned().collect();
    let mut shapes_seen: Vec<String> = Vec::new();
    for f in &all[24..] {
        let Some(shape) = f["properties"]["roof:shape"].as_str() else {
            continue;
        };
        let n = shapes_seen.iter().filter(|s| *s == shape).count();
        if shape != "flat" && n < 2 && picked.len() < 30 {
            shapes_seen.push(shape.to_string());
            picked.push(f.clone());
        }
    }
    assert_eq!(picked.len(), 30, "{shapes_seen:?}");
    doc["features"] = Value::Array(picked);
    Input {
        name: "les30.geojson",
        lines: vec![doc],
        sequence: false,
        id_attr: Some("osm_id"),
        has_models: true,
        companion: None,
    }
}

/// The nine made-up houses of `examples/roofs`, one per roof shape citylod models.
fn roofs() -> Input {
    Input {
        name: "roofs.geojson",
        lines: vec![read_json(&repo_root().join("examples/roofs/roofs.geojson"))],
        sequence: false,
        id_attr: Some("name"),
        has_models: true,
        companion: Some(fixture("annex-part.city.json")),
    }
}

/// The same houses as newline-delimited GeoJSON (one Feature a line).
fn roofs_lines() -> Input {
    let doc = read_json(&repo_root().join("examples/roofs/roofs.geojson"));
    Input {
        name: "roofs.geojsonl",
        lines: doc["features"].as_array().unwrap().clone(),
        sequence: true,
        id_attr: Some("name"),
        has_models: true,
        companion: Some(fixture("annex-part.city.json")),
    }
}

/// A bare GeometryCollection (RFC 7946 allows a geometry as the whole document) of the houses' outlines: a
/// Polygon, a nested collection with a Point beside a Polygon, a MultiPolygon of two.
fn bare_geometry() -> Input {
    let doc = read_json(&repo_root().join("examples/roofs/roofs.geojson"));
    let g = |i: usize| doc["features"][i]["geometry"].clone();
    let coords = |i: usize| g(i)["coordinates"].clone();
    let collection = json!({"type": "GeometryCollection", "geometries": [
        g(0),
        {"type": "GeometryCollection", "geometries": [g(1), {"type": "Point", "coordinates": [4.0, 52.0]}]},
        {"type": "MultiPolygon", "coordinates": [coords(2), coords(3)]}
    ]});
    Input {
        name: "bare-geometry.geojson",
        lines: vec![collection],
        sequence: false,
        id_attr: Some("name"),
        has_models: false,
        companion: Some(fixture("annex-part.city.json")),
    }
}

/// One Feature as the whole document: the L-shaped hipped house, with a legacy `crs` member naming CRS84 and a hole
/// cut into it.
fn single_feature() -> Input {
    let doc = read_json(&repo_root().join("examples/roofs/roofs.geojson"));
    let mut f = doc["features"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["properties"]["roof:shape"] == "hipped")
        .expect("a hipped house")
        .clone();
    // A small square hole near the first corner, inside the outline.
    let ring = f["geometry"]["coordinates"][0].clone();
    let (x, y) = (ring[0][0].as_f64().unwrap(), ring[0][1].as_f64().unwrap());
    let (dx, dy) = (1.5e-5, 1.0e-5);
    let hole = json!([
        [x + dx, y + dy],
        [x + dx, y + 2.0 * dy],
        [x + 2.0 * dx, y + 2.0 * dy],
        [x + 2.0 * dx, y + dy],
        [x + dx, y + dy]
    ]);
    f["geometry"]["coordinates"]
        .as_array_mut()
        .unwrap()
        .push(hole);
    f["crs"] = json!({"type": "name", "properties": {"name": "urn:ogc:def:crs:OGC:1.3:CRS84"}});
    Input {
        name: "single-feature.geojson",
        lines: vec![f],
        sequence: false,
        id_attr: Some("name"),
        has_models: true,
        companion: Some(fixture("annex-part.city.json")),
    }
}

fn cityjson_fixture(name: &'static str) -> Input {
    let path = fixture(name);
    let sequence = name.ends_with(".jsonl");
    let lines = if sequence {
        std::fs::read_to_string(&path)
            .unwrap()
            .lines()
            .filter(|l| !l.trim().is_empty())
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    } else {
        vec![read_json(&path)]
    };
    Input {
        name,
        lines,
        sequence,
        id_attr: (name == "v0.9-no-transform.city.json").then_some("h"),
        has_models: true,
        companion: Some(repo_root().join("examples/roofs/roofs.geojson")),
    }
}

/// A box Solid over 8 vertices from `first` (ground 0..3 counter-clockwise from above, top 4..7), faces outward.
fn box_solid(first: u64, lod: Value) -> Value {
    let b = |i: [u64; 4]| json!([i.map(|i| i + first)]);
    json!({"type": "Solid", "lod": lod, "boundaries": [[
        b([0, 3, 2, 1]), b([4, 5, 6, 7]), b([0, 1, 5, 4]), b([1, 2, 6, 5]), b([2, 3, 7, 6]), b([3, 0, 4, 7])
    ]], "semantics": {"surfaces": [{"type": "GroundSurface"}, {"type": "RoofSurface"}, {"type": "WallSurface"}],
        "values": [[0, 1, 2, 2, 2, 2]]}})
}

/// A gabled house 10 m × 8 m (eaves 5 m, ridge 8 m along x) over vertices `first`..`first + 9`, at LoD 2.2 with
/// semantic surfaces.
fn gabled_solid(first: u64) -> Value {
    let r = |i: &[u64]| json!([i.iter().map(|i| i + first).collect::<Vec<_>>()]);
    json!({"type": "Solid", "lod": "2.2", "boundaries": [[
        r(&[0, 3, 2, 1]), r(&[0, 1, 5, 4]), r(&[1, 2, 6, 9, 5]), r(&[2, 3, 7, 6]), r(&[3, 0, 4, 8, 7]),
        r(&[4, 5, 9, 8]), r(&[6, 7, 8, 9])
    ]], "semantics": {"surfaces": [{"type": "GroundSurface"}, {"type": "WallSurface"}, {"type": "RoofSurface"}],
        "values": [[0, 1, 1, 1, 1, 2, 2]]}})
}

/// mm coordinates of the gabled house at (`x`, `y`) m (10 vertices, see [`gabled_solid`]).
fn gabled_vertices(x: i64, y: i64) -> Vec<Value> {
    let (x, y) = (x * 1000, y * 1000);
    [
        [0, 0, 0],
        [10, 0, 0],
        [10, 8, 0],
        [0, 8, 0],
        [0, 0, 5],
        [10, 0, 5],
        [10, 8, 5],
        [0, 8, 5],
        [0, 4, 8],
        [10, 4, 8],
    ]
    .iter()
    .map(|[a, b, c]| json!([x + a * 1000, y + b * 1000, c * 1000]))
    .collect()
}

/// mm coordinates of a box [x0, x1] × [y0, y1] × [0, h] m (8 vertices, see [`box_solid`]).
fn box_vertices(x0: i64, y0: i64, x1: i64, y1: i64, h: i64) -> Vec<Value> {
    let m = |v: i64| v * 1000;
    [
        [x0, y0, 0],
        [x1, y0, 0],
        [x1, y1, 0],
        [x0, y1, 0],
        [x0, y0, h],
        [x1, y0, h],
        [x1, y1, h],
        [x0, y1, h],
    ]
    .iter()
    .map(|[a, b, c]| json!([m(*a), m(*b), m(*c)]))
    .collect()
}

/// Two geometry templates in real coordinates (CityJSON 2.0 §"Geometry templates"): 0, a shed 3 m × 2 m × 2.5 m as
/// an LoD 2.2 Solid; 1, a chimney's two crossed faces as an LoD 2 MultiSurface.
fn geometry_templates() -> Value {
    json!({
        "templates": [
            box_solid(0, json!("2.2")),
            {"type": "MultiSurface", "lod": "2", "boundaries": [[[8, 9, 10, 11]], [[12, 13, 14, 15]]],
             "semantics": {"surfaces": [{"type": "WallSurface"}], "values": [0, 0]}}
        ],
        "vertices-templates": [
            [0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 2.0, 0.0], [0.0, 2.0, 0.0],
            [0.0, 0.0, 2.5], [3.0, 0.0, 2.5], [3.0, 2.0, 2.5], [0.0, 2.0, 2.5],
            [-0.5, 0.0, 0.0], [0.5, 0.0, 0.0], [0.5, 0.0, 1.5], [-0.5, 0.0, 1.5],
            [0.0, -0.5, 0.0], [0.0, 0.5, 0.0], [0.0, 0.5, 1.5], [0.0, -0.5, 1.5]
        ]
    })
}

fn instance(template: u64, reference: u64, matrix: [f64; 16]) -> Value {
    json!({"type": "GeometryInstance", "template": template, "boundaries": [reference],
        "transformationMatrix": matrix})
}

const IDENTITY: [f64; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];
/// 90° about z, then lifted 0.5 m.
const TURNED: [f64; 16] = [
    0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.5, 0.0, 0.0, 0.0, 1.0,
];

/// A CityJSON 2.0 document written for this test (none in the repository has LoD 2 or templates): a gabled house
/// with LoD 0, 1.2 and 2.2 (semantic surfaces) and an LoD 2.2 annex as its BuildingPart, a chimney installation and a
/// shed given as GeometryInstances of templates, a tree (not a building) instancing a template too.
fn lod2_templates() -> Input {
    let mut vertices = gabled_vertices(0, 0); // 0..9
    vertices.extend(box_vertices(10, 0, 14, 4, 3)); // 10..17 annex
    vertices.push(json!([20000, 0, 0])); // 18: the shed's reference point
    vertices.push(json!([2000, 6000, 6500])); // 19: the chimney's
    vertices.push(json!([-5000, -5000, 0])); // 20: the tree's
    let doc = json!({
        "type": "CityJSON",
        "version": "2.0",
        "transform": {"scale": [0.001, 0.001, 0.001], "translate": [85000.0, 446000.0, 0.0]},
        "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/7415"},
        "CityObjects": {
            "house": {
                "type": "Building",
                "attributes": {"identificatie": "house", "roofType": "gabled", "measuredHeight": 8.0,
                    "storeysAboveGround": 2, "b3_h_maaiveld": 0.0},
                "children": ["house-annex", "house-chimney"],
                "geometry": [
                    {"type": "MultiSurface", "lod": "0", "boundaries": [[[0, 1, 2, 3]]],
                     "semantics": {"surfaces": [{"type": "GroundSurface"}], "values": [0]}},
                    box_solid(0, json!("1.2")),
                    gabled_solid(0)
                ]
            },
            "house-annex": {
                "type": "BuildingPart",
                "parents": ["house"],
                "attributes": {"identificatie": "annex"},
                "geometry": [box_solid(10, json!(2.2))]
            },
            "house-chimney": {
                "type": "BuildingInstallation",
                "parents": ["house"],
                "geometry": [instance(1, 19, IDENTITY)]
            },
            "shed": {
                "type": "Building",
                "attributes": {"identificatie": "shed", "function": "storage"},
                "geometry": [instance(0, 18, TURNED)]
            },
            "tree": {
                "type": "SolitaryVegetationObject",
                "geometry": [instance(1, 20, IDENTITY)]
            }
        },
        "geometry-templates": geometry_templates(),
        "vertices": vertices
    });
    Input {
        name: "lod2-templates.city.json",
        lines: vec![doc],
        sequence: false,
        id_attr: Some("identificatie"),
        has_models: true,
        companion: Some(repo_root().join("examples/roofs/roofs.geojson")),
    }
}

/// A CityJSONSeq written for this test after 3DBAG's (a header with the transform and templates, then one
/// CityJSONFeature a line): a Building with its LoD 0 footprint and a BuildingPart at LoD 1.2 and 2.2, as 3DBAG
/// has them; a gabled house; a shed as a GeometryInstance of the header's template.
fn lod2_sequence() -> Input {
    let header = json!({
        "type": "CityJSON",
        "version": "2.0",
        "transform": {"scale": [0.001, 0.001, 0.001], "translate": [85000.0, 446000.0, 0.5]},
        "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/7415", "title": "mutations"},
        "CityObjects": {},
        "vertices": [],
        "geometry-templates": geometry_templates()
    });
    let bag = |id: &str, x: i64, h: i64| {
        let part = format!("{id}-0");
        let mut vertices = box_vertices(x, 0, x + 6, 9, h);
        vertices.extend(box_vertices(x, 0, x + 6, 9, h - 1));
        json!({
            "type": "CityJSONFeature",
            "id": id,
            "CityObjects": {
                id: {
                    "type": "Building",
                    "attributes": {"identificatie": id, "b3_h_maaiveld": 0.5, "b3_h_dak_70p": h as f64 + 0.3,
                        "b3_dak_type": "horizontal", "b3_bouwlagen": 2},
                    "geometry": [{"type": "MultiSurface", "lod": "0", "boundaries": [[[0, 1, 2, 3]]]}],
                    "children": [part]
                },
                part.as_str(): {
                    "type": "BuildingPart",
                    "parents": [id],
                    "geometry": [box_solid(8, json!("1.2")), box_solid(0, json!("2.2"))]
                }
            },
            "vertices": vertices
        })
    };
    let mut house_vertices = gabled_vertices(0, 20);
    house_vertices.push(json!([20000, 20000, 0]));
    let house = json!({
        "type": "CityJSONFeature",
        "id": "house",
        "CityObjects": {
            "house": {"type": "Building", "attributes": {"identificatie": "house"},
                "geometry": [box_solid(0, json!("1.2")), gabled_solid(0)]},
            "shed": {"type": "Building", "attributes": {"identificatie": "shed"},
                "geometry": [instance(0, 10, TURNED)]}
        },
        "vertices": house_vertices
    });
    Input {
        name: "3dbag-like.city.jsonl",
        lines: vec![header, bag("NL.1", 0, 6), house, bag("NL.2", 30, 9)],
        sequence: true,
        id_attr: Some("identificatie"),
        has_models: true,
        companion: Some(repo_root().join("examples/roofs/roofs.geojson")),
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Mutations

#[derive(Clone, Debug)]
enum Seg {
    Key(String),
    Index(usize),
}

/// Every node's path below `v` (`v` itself included, as the empty path), in document order.
fn paths(v: &Value, at: &mut Vec<Seg>, out: &mut Vec<Vec<Seg>>) {
    out.push(at.clone());
    match v {
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                at.push(Seg::Index(i));
                paths(x, at, out);
                at.pop();
            }
        }
        Value::Object(m) => {
            for (k, x) in m {
                at.push(Seg::Key(k.clone()));
                paths(x, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

fn node_mut<'a>(mut v: &'a mut Value, path: &[Seg]) -> &'a mut Value {
    for s in path {
        v = match s {
            Seg::Key(k) => v.get_mut(k.as_str()).expect("path exists"),
            Seg::Index(i) => v.get_mut(*i).expect("path exists"),
        };
    }
    v
}

fn node<'a>(mut v: &'a Value, path: &[Seg]) -> &'a Value {
    for s in path {
        v = match s {
            Seg::Key(k) => &v[k.as_str()],
            Seg::Index(i) => &v[*i],
        };
    }
    v
}

fn show(path: &[Seg]) -> String {
    if path.is_empty() {
        return "/".into();
    }
    path.iter()
        .map(|s| match s {
            Seg::Key(k) => format!("/{k}"),
            Seg::Index(i) => format!("/{i}"),
        })
        .collect()
}

/// Members the readers look at: a node under one of these is picked more often.
#[rustfmt::skip]
const USED_KEYS: &[&str] = &[
    "type", "features", "geometry", "coordinates", "geometries", "properties", "id", "crs", "height", "min_height",
    "building", "building:part", "building:levels", "roof:shape", "roof:height", "roof:levels", "CityObjects",
    "vertices", "transform", "scale", "translate", "metadata", "referenceSystem", "version", "lod", "boundaries",
    "semantics", "surfaces", "values", "children", "parents", "attributes", "geometry-templates", "templates",
    "vertices-templates", "template", "transformationMatrix", "b3_h_maaiveld", "b3_h_dak_70p", "measuredHeight",
];

/// A value to put in a node's place, and how to show it.
type Replacement = (fn() -> Value, &'static str);

/// Values a replaced node may become.
fn scalar(rng: &mut SplitMix64) -> (Value, &'static str) {
    let all: [Replacement; 24] = [
        (|| Value::Null, "null"),
        (|| json!(true), "true"),
        (|| json!(false), "false"),
        (|| json!("x"), "\"x\""),
        (|| json!(""), "\"\""),
        (|| json!(0), "0"),
        (|| json!(-1), "-1"),
        (|| json!(0.5), "0.5"),
        (|| json!(1e308), "1e308"),
        (|| json!(-1e308), "-1e308"),
        (|| json!(4294967296u64), "4294967296"),
        (|| json!(u64::MAX), "u64::MAX"),
        (|| json!(i64::MIN), "i64::MIN"),
        (|| json!(1e-320), "1e-320"),
        (|| json!(2.2), "2.2"),
        (|| json!("2.2"), "\"2.2\""),
        (|| json!("1.2"), "\"1.2\""),
        (|| json!("0"), "\"0\""),
        (|| json!([]), "[]"),
        (|| json!({}), "{}"),
        (|| json!([[]]), "[[]]"),
        (|| json!([[[[]]]]), "[[[[]]]]"),
        (|| json!([0, 0, 0]), "[0, 0, 0]"),
        (|| json!({"type": "Building"}), "{\"type\": \"Building\"}"),
    ];
    let (f, name) = rng.pick(&all);
    (f(), name)
}

fn nested(depth: usize) -> Value {
    let mut v = json!(0);
    for _ in 0..depth {
        v = Value::Array(vec![v]);
    }
    v
}

#[rustfmt::skip]
const TYPES: &[&str] = &[
    "Feature", "FeatureCollection", "Polygon", "MultiPolygon", "GeometryCollection", "Point", "LineString",
    "CityJSON", "CityJSONFeature", "Building", "BuildingPart", "BuildingInstallation", "TINRelief", "Solid",
    "MultiSolid", "CompositeSolid", "MultiSurface", "CompositeSurface", "GeometryInstance", "GroundSurface",
    "RoofSurface", "WallSurface",
];

/// One random structural mutation of `doc`, described.
fn mutate(doc: &mut Value, rng: &mut SplitMix64) -> String {
    let mut all = Vec::new();
    paths(doc, &mut Vec::new(), &mut all);
    let under_used = |p: &Vec<Seg>| {
        p.iter()
            .any(|s| matches!(s, Seg::Key(k) if USED_KEYS.contains(&k.as_str())))
    };
    // Most nodes are coordinates: a quarter of the time any node, else one under a member the readers use, an array
    // or object, or the value of such a member itself.
    let pool: Vec<&Vec<Seg>> = match rng.next_u64() % 4 {
        0 => all.iter().filter(|p| under_used(p)).collect(),
        1 => all
            .iter()
            .filter(|p| matches!(node(doc, p), Value::Array(_) | Value::Object(_)))
            .collect(),
        2 => all
            .iter()
            .filter(|p| matches!(p.last(), Some(Seg::Key(k)) if USED_KEYS.contains(&k.as_str())))
            .collect(),
        _ => all.iter().collect(),
    };
    let pool = if pool.is_empty() {
        all.iter().collect()
    } else {
        pool
    };
    let path = (*rng.pick(&pool)).clone();
    let at = show(&path);
    let vertex_count = doc
        .get("vertices")
        .and_then(Value::as_array)
        .map_or(0, Vec::len);
    let donor = (*rng.pick(&all)).clone();
    let donor_value = node(doc, &donor).clone();
    let target = node_mut(doc, &path);
    match rng.next_u64() % 20 {
        0..=3 => {
            let (v, name) = scalar(rng);
            *target = v;
            format!("{at} := {name}")
        }
        4 => {
            let depth = *rng.pick(&[100usize, 126, 200]);
            *target = nested(depth);
            format!("{at} := array nested {depth} deep")
        }
        5 => {
            // A huge or just-out-of-range index (into `vertices` where the node is a vertex index).
            let v = *rng.pick(&[
                vertex_count as u64,
                vertex_count as u64 + 1,
                u32::MAX as u64,
                u32::MAX as u64 + 1,
                1 << 53,
                u64::MAX,
            ]);
            *target = json!(v);
            format!("{at} := {v} (an index past the {vertex_count} vertices)")
        }
        6 => match target {
            Value::Number(n) => {
                let s = n.to_string();
                *target = Value::String(s.clone());
                format!("{at} := \"{s}\" (a number as a string)")
            }
            Value::String(s) => {
                let n = s
                    .trim()
                    .parse::<f64>()
                    .ok()
                    .and_then(serde_json::Number::from_f64);
                let d = format!("{at} := {n:?} (a string as a number)");
                *target = n.map_or(json!(7), Value::Number);
                d
            }
            _ => {
                *target = json!("12");
                format!("{at} := \"12\"")
            }
        },
        7 => match target {
            Value::Object(m) if !m.is_empty() => {
                let k = m
                    .keys()
                    .nth((rng.next_u64() % m.len() as u64) as usize)
                    .unwrap()
                    .clone();
                m.shift_remove(&k);
                format!("{at}: member {k:?} deleted")
            }
            Value::Array(a) if !a.is_empty() => {
                let i = (rng.next_u64() % a.len() as u64) as usize;
                a.remove(i);
                format!("{at}: element {i} deleted")
            }
            _ => {
                *target = Value::Null;
                format!("{at} := null")
            }
        },
        8 => match target {
            Value::Array(a) if !a.is_empty() => {
                let i = (rng.next_u64() % a.len() as u64) as usize;
                let j = (rng.next_u64() % (a.len() as u64 + 1)) as usize;
                let x = a[i].clone();
                a.insert(j, x);
                format!("{at}: element {i} duplicated at {j}")
            }
            Value::Object(m) if !m.is_empty() => {
                // An object's member given again under another key (a second Building with the same geometry).
                let (k, v) = m
                    .iter()
                    .nth((rng.next_u64() % m.len() as u64) as usize)
                    .map(|(k, v)| (k.clone(), v.clone()))
                    .unwrap();
                m.insert(format!("{k}-copy"), v);
                format!("{at}: member {k:?} copied to \"{k}-copy\"")
            }
            _ => {
                *target = Value::Array(vec![target.clone(), target.clone()]);
                format!("{at} := [it, it]")
            }
        },
        9 => match target {
            Value::Array(a) if !a.is_empty() => {
                let n = (rng.next_u64() % a.len() as u64) as usize;
                a.truncate(n);
                format!("{at}: truncated to {n} elements")
            }
            _ => {
                *target = json!([]);
                format!("{at} := []")
            }
        },
        10 => match target {
            Value::Array(a) => {
                a.reverse();
                format!("{at}: reversed")
            }
            _ => {
                *target = json!([target.clone()]);
                format!("{at} := [it]")
            }
        },
        11 => match target {
            Value::Array(a) if a.len() >= 2 => {
                let i = (rng.next_u64() % a.len() as u64) as usize;
                let j = (rng.next_u64() % a.len() as u64) as usize;
                a.swap(i, j);
                format!("{at}: elements {i} and {j} swapped")
            }
            Value::Array(a) if !a.is_empty() => {
                // Every element the same: a ring of one repeated point.
                let x = a[0].clone();
                a.extend(std::iter::repeat_n(x, 3));
                format!("{at}: first element repeated")
            }
            _ => {
                *target = json!(-0.0);
                format!("{at} := -0.0")
            }
        },
        12 => {
            *target = donor_value;
            format!("{at} := the value at {}", show(&donor))
        }
        13 => match target {
            Value::Number(n) => {
                let f = n.as_f64().unwrap_or(0.0);
                let k = *rng.pick(&[-1.0, 1e-9, 1e9, 1e15, 1e300, 1.0 + 1e-12]);
                let v = serde_json::Number::from_f64(f * k).map_or(Value::Null, Value::Number);
                let d = format!("{at} := {v} ({f} × {k})");
                *target = v;
                d
            }
            Value::Array(a) if a.iter().all(Value::is_array) && a.len() >= 2 => {
                // A ring with all points equal to its first, or its closing point dropped or doubled.
                match rng.next_u64() % 3 {
                    0 => {
                        let x = a[0].clone();
                        a.iter_mut().for_each(|p| *p = x.clone());
                        format!("{at}: every element made the first")
                    }
                    1 => {
                        a.pop();
                        format!("{at}: last element dropped")
                    }
                    _ => {
                        let x = a[0].clone();
                        a.push(x);
                        format!("{at}: first element appended")
                    }
                }
            }
            _ => {
                *target = json!(1e15);
                format!("{at} := 1e15")
            }
        },
        14 => {
            let t = *rng.pick(TYPES);
            *target = json!(t);
            format!("{at} := {t:?}")
        }
        15 => match target {
            Value::Object(m) if !m.is_empty() => {
                // A member renamed: to another member the readers use, or to one they do not know.
                let k = m
                    .keys()
                    .nth((rng.next_u64() % m.len() as u64) as usize)
                    .unwrap()
                    .clone();
                let to = if rng.chance(0.7) {
                    rng.pick(USED_KEYS).to_string()
                } else {
                    format!("{k}_")
                };
                let v = m.shift_remove(&k).unwrap();
                m.insert(to.clone(), v);
                format!("{at}: member {k:?} renamed {to:?}")
            }
            _ => {
                *target = json!({"type": "x"});
                format!("{at} := {{\"type\": \"x\"}}")
            }
        },
        16 => match target {
            Value::Object(m) => {
                // A member the readers use added with the value of another node.
                let k = rng.pick(USED_KEYS).to_string();
                m.insert(k.clone(), donor_value);
                format!("{at}: member {k:?} set to the value at {}", show(&donor))
            }
            _ => {
                let (v, name) = scalar(rng);
                *target = v;
                format!("{at} := {name}")
            }
        },
        17 => match target {
            Value::String(s) => {
                let v = rng.pick(&[
                    "",
                    " ",
                    "2.2",
                    "0",
                    "-5",
                    "1e400",
                    "NaN",
                    "yes",
                    "flat",
                    "gabled",
                    "dome",
                    "pyramidal",
                    "skillion",
                    "hipped",
                    "onion",
                    "EPSG:4326",
                    "EPSG:7415",
                    "urn:ogc:def:crs:EPSG::28992",
                    "highest",
                    "é\u{0}\u{feff}",
                    "99999999999999999999",
                ]);
                *s = v.to_string();
                format!("{at} := {v:?}")
            }
            _ => {
                let v = *rng.pick(&[0.0, -0.0, 1e-300, -5.0, 1e10, 123456789.0, 0.001]);
                *target = json!(v);
                format!("{at} := {v}")
            }
        },
        _ => {
            // Two mutations in one place: an empty object, then a member.
            *target = json!({});
            let k = rng.pick(USED_KEYS).to_string();
            target[&k] = donor_value;
            format!("{at} := {{{k:?}: the value at {}}}", show(&donor))
        }
    }
}

/// CRS names a file may declare (or `--crs` give): EPSG codes of other kinds of projection, codes not in the
/// table, and proj strings with parameters at the edges of their domains.
#[rustfmt::skip]
const CRS_NAMES: &[&str] = &[
    "EPSG:4326", "EPSG:4258", "EPSG:3857", "EPSG:2263", "EPSG:32631", "EPSG:3413", "EPSG:3031", "EPSG:27700",
    "EPSG:2154", "EPSG:3035", "EPSG:5514", "EPSG:21781", "EPSG:4978", "EPSG:7415", "EPSG:0", "EPSG:99999",
    "EPSG:4294967297", "urn:ogc:def:crs:EPSG::28992", "https://www.opengis.net/def/crs/EPSG/0/28992", "CRS84", "",
    "+proj=longlat +datum=WGS84", "+proj=longlat +a=0", "+proj=longlat +ellps=WGS84 +pm=1e308", "+proj=tmerc +k=0",
    "+proj=tmerc +lat_0=90 +k=1e-300", "+proj=utm +zone=0", "+proj=utm +zone=61", "+proj=utm +zone=-5 +south",
    "+proj=merc +lat_ts=90", "+proj=stere +lat_0=90 +lat_ts=90", "+proj=stere +lat_0=45",
    "+proj=lcc +lat_1=0 +lat_2=0", "+proj=lcc +lat_1=45 +lat_2=-45", "+proj=aea +lat_1=10 +lat_2=-10",
    "+proj=laea +lat_0=1e308", "+proj=geos +h=0", "+proj=geos +h=35785831", "+proj=ortho +lat_0=90",
    "+proj=somerc +lat_0=90", "+proj=krovak", "+proj=eqc +lat_ts=90", "+proj=cea +lat_ts=90", "+proj=etmerc +k=0",
    "+proj=sterea +lat_0=90 +k=0", "+proj=tmerc +units=ft +to_meter=0", "+proj=tmerc +to_meter=-1",
    "+proj=tmerc +towgs84=1e308,0,0", "+proj=tmerc +towgs84=0,0,0,0,0,0,-1000000", "+proj=tmerc +rf=0",
    "+proj=tmerc +a=-1", "+proj=tmerc +b=0", "+proj=nonsense", "+", "+proj", "+proj=", "+proj=tmerc +lon_0=x",
    "+proj=tmerc +nadgrids=@null", "+proj=tmerc +axis=wsu", "+proj=tmerc +axis=",
];

/// Attributes the height, roof, part and id rules read (OpenStreetMap tags, 3DBAG's and CityJSON's).
#[rustfmt::skip]
const ATTRIBUTES: &[&str] = &[
    "height", "min_height", "building", "building:part", "building:levels", "building:min_level", "building_id",
    "location", "is_underground", "roof:shape", "roof:height", "roof:levels", "roof:angle", "roof:direction",
    "roof:orientation", "osm_id", "name", "identificatie", "measuredHeight", "storeysAboveGround", "b3_h_maaiveld",
    "b3_h_dak_70p", "b3_bouwlagen",
];

/// Values for [`ATTRIBUTES`]: numbers at and past the ends of their ranges, text numbers with units, shapes,
/// compass points.
#[rustfmt::skip]
const ATTRIBUTE_VALUES: &[fn() -> Value] = &[
    || json!(0), || json!(-0.0), || json!(-3), || json!(1e-300), || json!(0.05), || json!(89), || json!(90),
    || json!(999.99), || json!(1000), || json!(1e308), || json!(u64::MAX), || json!(null), || json!(true),
    || json!([1, 2]), || json!({"a": 1}), || json!("5"), || json!("12 m"), || json!("40'"), || json!("12'6\""),
    || json!("1,776"), || json!("1e400"), || json!("NaN"), || json!("inf"), || json!("  "), || json!("yes"),
    || json!("no"), || json!("underground"), || json!("across"), || json!("NNE"), || json!("gabled"),
    || json!("hipped"), || json!("half-hipped"), || json!("mansard"), || json!("gambrel"), || json!("round"),
    || json!("dome"), || json!("onion"), || json!("skillion"), || json!("pyramidal"), || json!("cone"),
    || json!("saltbox"), || json!("flat"), || json!("way/110"),
];

/// A mutation aimed at what the generic ones rarely reach: `transform` (scale 0, negative or subnormal; translate
/// huge), a vertex, an `lod`, a template or its matrix, a city object's parents, children or type, an attribute the
/// height and roof rules read, the CRS declared, a vertex index in `boundaries`. `None` when the document has no
/// such member.
fn mutate_targeted(doc: &mut Value, rng: &mut SplitMix64) -> Option<String> {
    match rng.next_u64() % 9 {
        0 => {
            let t = doc.get_mut("transform")?.as_object_mut()?;
            let (member, values): (&str, &[f64]) = if rng.chance(0.6) {
                ("scale", &[0.0, -0.001, 1e-320, 1e-300, 1e308, -1.0])
            } else {
                ("translate", &[1e308, -1e308, 1e15, -85000.0])
            };
            let k = (rng.next_u64() % 3) as usize;
            let v = *rng.pick(values);
            let slot = t.get_mut(member)?.get_mut(k)?;
            *slot = json!(v);
            Some(format!("/transform/{member}/{k} := {v}"))
        }
        1 => {
            let n = doc.get("vertices")?.as_array()?.len();
            if n == 0 {
                return None;
            }
            let i = (rng.next_u64() % n as u64) as usize;
            let k = (rng.next_u64() % 3) as usize;
            let v = *rng.pick(&[i64::MAX, i64::MIN, 1 << 40, -(1 << 40), 0]);
            *doc.get_mut("vertices")?.get_mut(i)?.get_mut(k)? = json!(v);
            Some(format!("/vertices/{i}/{k} := {v}"))
        }
        2 => {
            let mut all = Vec::new();
            paths(doc, &mut Vec::new(), &mut all);
            let lods: Vec<&Vec<Seg>> = all
                .iter()
                .filter(|p| matches!(p.last(), Some(Seg::Key(k)) if k == "lod" || k == "template" || k == "transformationMatrix"))
                .collect();
            if lods.is_empty() {
                return None;
            }
            let p = (*rng.pick(&lods)).clone();
            let v = rng
                .pick(&[
                    json!("0"),
                    json!(0),
                    json!("1"),
                    json!("2"),
                    json!(2),
                    json!("2.2"),
                    json!("3"),
                    json!("1.3"),
                    json!("255.255"),
                    json!("256"),
                    json!("-1"),
                    json!(1e308),
                    json!(7),
                    json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0]),
                    json!([1e308, 0, 0, 0, 0, 1e308, 0, 0, 0, 0, 1e308, 0, 0, 0, 0, 1]),
                    json!([0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1]),
                ])
                .clone();
            let d = format!("{} := {v}", show(&p));
            *node_mut(doc, &p) = v;
            Some(d)
        }
        3 => {
            // parents / children naming another object, itself, or one that is not there.
            let objects = doc.get_mut("CityObjects")?.as_object_mut()?;
            if objects.is_empty() {
                return None;
            }
            let ids: Vec<String> = objects.keys().cloned().collect();
            let me = ids[(rng.next_u64() % ids.len() as u64) as usize].clone();
            let other = ids[(rng.next_u64() % ids.len() as u64) as usize].clone();
            let link = *rng.pick(&["parents", "children", "parent"]);
            let to = match rng.next_u64() % 3 {
                0 => json!([other]),
                1 => json!([me]),
                _ => json!(["gone", other]),
            };
            let d = format!("/CityObjects/{me}/{link} := {to}");
            objects
                .get_mut(&me)?
                .as_object_mut()?
                .insert(link.into(), to);
            Some(d)
        }
        4 => {
            // A city object's type changed (a part becomes a building, a building a part, …).
            let objects = doc.get_mut("CityObjects")?.as_object_mut()?;
            let n = objects.len();
            if n == 0 {
                return None;
            }
            let (id, o) = objects
                .iter_mut()
                .nth((rng.next_u64() % n as u64) as usize)?;
            let t = *rng.pick(&[
                "Building",
                "BuildingPart",
                "BuildingInstallation",
                "TINRelief",
                "Bridge",
            ]);
            o.as_object_mut()?.insert("type".into(), json!(t));
            Some(format!("/CityObjects/{id}/type := {t:?}"))
        }
        5 | 6 => {
            // An attribute the height, roof or id rules read, set to a value they must refuse or take.
            let mut all = Vec::new();
            paths(doc, &mut Vec::new(), &mut all);
            let holders: Vec<&Vec<Seg>> = all
                .iter()
                .filter(|p| matches!(p.last(), Some(Seg::Key(k)) if k == "properties" || k == "attributes"))
                .filter(|p| node(doc, p).is_object())
                .collect();
            if holders.is_empty() {
                return None;
            }
            let p = (*rng.pick(&holders)).clone();
            let name = *rng.pick(ATTRIBUTES);
            let v = rng.pick(ATTRIBUTE_VALUES)();
            let d = format!("{}/{name} := {v}", show(&p));
            node_mut(doc, &p)[name] = v;
            Some(d)
        }
        7 => {
            // The CRS the file declares: another EPSG code, a proj string with odd parameters, no CRS at all.
            let name = *rng.pick(CRS_NAMES);
            let is_cityjson = doc.get("type").and_then(Value::as_str) == Some("CityJSON");
            let o = doc.as_object_mut()?;
            if is_cityjson {
                let m = o.entry("metadata").or_insert_with(|| json!({}));
                m.as_object_mut()?
                    .insert("referenceSystem".into(), json!(name));
                Some(format!("/metadata/referenceSystem := {name:?}"))
            } else {
                o.insert(
                    "crs".into(),
                    json!({"type": "name", "properties": {"name": name}}),
                );
                Some(format!("/crs := name {name:?}"))
            }
        }
        _ => {
            // A vertex index in `boundaries` (of a geometry, a template, an instance) past the vertices, or huge.
            let mut all = Vec::new();
            paths(doc, &mut Vec::new(), &mut all);
            let indices: Vec<&Vec<Seg>> = all
                .iter()
                .filter(|p| node(doc, p).is_number())
                .filter(|p| {
                    p.iter()
                        .any(|s| matches!(s, Seg::Key(k) if k == "boundaries"))
                })
                .collect();
            if indices.is_empty() {
                return None;
            }
            let n = doc
                .get("vertices")
                .and_then(Value::as_array)
                .map_or(0, Vec::len) as u64;
            let v = *rng.pick(&[
                n,
                n + 1,
                u64::from(u32::MAX),
                u64::from(u32::MAX) + 1,
                1 << 53,
                u64::MAX,
            ]);
            let p = (*rng.pick(&indices)).clone();
            *node_mut(doc, &p) = json!(v);
            Some(format!(
                "{} := {v} (an index past the {n} vertices)",
                show(&p)
            ))
        }
    }
}

/// Whether `v` is a point: two or three numbers (a GeoJSON position, a CityJSON vertex; also a ring of three
/// indices, which is fine to move too).
fn is_point(v: &Value) -> bool {
    matches!(v, Value::Array(a) if (2..=3).contains(&a.len()) && a.iter().all(Value::is_number))
}

/// A mutation of the geometry that keeps it well-formed JSON of the right shape, for the repair, roof and
/// triangulation code behind the readers: a point moved onto, between or beyond others (spikes, self-intersections,
/// collinear and repeated points), or a ring added again as a hole or another polygon, shrunk, grown or turned.
fn mutate_geometry(doc: &mut Value, rng: &mut SplitMix64) -> Option<String> {
    let mut all = Vec::new();
    paths(doc, &mut Vec::new(), &mut all);
    let points: Vec<&Vec<Seg>> = all.iter().filter(|p| is_point(node(doc, p))).collect();
    let rings: Vec<&Vec<Seg>> = all
        .iter()
        .filter(
            |p| matches!(node(doc, p), Value::Array(a) if a.len() >= 3 && a.iter().all(is_point)),
        )
        .collect();
    let coords = |v: &Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_f64().unwrap_or(0.0))
            .collect()
    };
    let to_value = |c: &[f64]| -> Value {
        Value::Array(
            c.iter()
                .map(|x| serde_json::Number::from_f64(*x).map_or(Value::Null, Value::Number))
                .collect(),
        )
    };
    // Integer vertices stay integers (CityJSON's transform makes them so).
    let integral = |v: &Value| {
        v.as_array()
            .unwrap()
            .iter()
            .all(|c| c.is_i64() || c.is_u64())
    };
    if rings.is_empty() || rng.chance(0.6) {
        if points.len() < 2 {
            return None;
        }
        let p = (*rng.pick(&points)).clone();
        let q = (*rng.pick(&points)).clone();
        let (a, b) = (node(doc, &p).clone(), node(doc, &q).clone());
        let (ca, cb) = (coords(&a), coords(&b));
        let n = ca.len().min(cb.len());
        let (t, what) = match rng.next_u64() % 5 {
            0 => (1.0, "onto"),
            1 => (0.5, "halfway to"),
            2 => (rng.range(-1.0, 2.0), "along the line to"),
            3 => (1.0 + 1e-9, "just past"),
            _ => (1e-9, "a hair towards"),
        };
        let mut moved: Vec<f64> = (0..ca.len())
            .map(|k| {
                if k < n {
                    ca[k] + (cb[k] - ca[k]) * t
                } else {
                    ca[k]
                }
            })
            .collect();
        if integral(&a) {
            moved.iter_mut().for_each(|x| *x = x.round());
            *node_mut(doc, &p) = Value::Array(moved.iter().map(|x| json!(*x as i64)).collect());
        } else {
            *node_mut(doc, &p) = to_value(&moved);
        }
        return Some(format!(
            "point {} moved {what} {} (t = {t})",
            show(&p),
            show(&q)
        ));
    }
    let r = (*rng.pick(&rings)).clone();
    let ring = node(doc, &r).clone();
    let pts: Vec<Vec<f64>> = ring.as_array().unwrap().iter().map(coords).collect();
    let first = pts[0].clone();
    let about = |f: f64| -> Value {
        Value::Array(
            pts.iter()
                .map(|p| {
                    let c: Vec<f64> = p.iter().zip(&first).map(|(x, o)| o + (x - o) * f).collect();
                    if integral(&ring[0]) {
                        Value::Array(c.iter().map(|x| json!(x.round() as i64)).collect())
                    } else {
                        to_value(&c)
                    }
                })
                .collect(),
        )
    };
    let parent_path = &r[..r.len() - 1];
    match rng.next_u64() % 6 {
        0 | 1 => {
            // The ring again beside itself: a hole equal to the shell, or shrunk (a proper hole), or grown.
            let f = *rng.pick(&[1.0, 0.5, 2.0, -1.0]);
            let extra = about(f);
            let Value::Array(parent) = node_mut(doc, parent_path) else {
                return None;
            };
            parent.push(extra);
            Some(format!(
                "{}: ring scaled by {f} about its first point added after it",
                show(&r)
            ))
        }
        2 => {
            // A spike: a far point inserted between two of the ring's.
            let Value::Array(a) = node_mut(doc, &r) else {
                return None;
            };
            let i = 1 + (rng.next_u64() % (a.len() as u64 - 1)) as usize;
            let prev = coords(&a[i - 1]);
            let far: Vec<f64> = prev
                .iter()
                .zip(&first)
                .map(|(x, o)| x + (x - o) * 5.0 + 1e-4)
                .collect();
            let v = if integral(&ring[0]) {
                Value::Array(far.iter().map(|x| json!(x.round() as i64)).collect())
            } else {
                to_value(&far)
            };
            a.insert(i, v);
            Some(format!("{}: a spike inserted at {i}", show(&r)))
        }
        3 => {
            // Its start turned (a GeoJSON ring then no longer closes).
            let Value::Array(a) = node_mut(doc, &r) else {
                return None;
            };
            let k = 1 + (rng.next_u64() % (a.len() as u64 - 1)) as usize;
            a.rotate_left(k);
            Some(format!("{}: rotated by {k}", show(&r)))
        }
        4 => {
            // Its points in another order: a bow tie.
            let Value::Array(a) = node_mut(doc, &r) else {
                return None;
            };
            let n = a.len();
            let (i, j) = (
                1 + (rng.next_u64() % (n as u64 - 1)) as usize,
                1 + (rng.next_u64() % (n as u64 - 1)) as usize,
            );
            a.swap(i, j);
            Some(format!("{}: points {i} and {j} swapped", show(&r)))
        }
        _ => {
            // The ring moved, its shape kept, onto an edge of the lon/lat globe: across the antimeridian, onto a
            // pole, next to one (a GeoJSON outline's degrees; CityJSON's vertices then lie far off their CRS).
            let (x0, y0) = (first[0], first.get(1).copied().unwrap_or(0.0));
            let (to_x, to_y, what) = *rng.pick(&[
                (179.99995, y0, "across the antimeridian"),
                (-180.0, y0, "onto lon -180"),
                (x0, 89.99995, "next to the north pole"),
                (x0, 90.0, "onto the north pole"),
                (x0, -89.9999999, "next to the south pole"),
                (0.0, 0.0, "onto 0°, 0°"),
            ]);
            let moved: Vec<Value> = pts
                .iter()
                .map(|p| {
                    let mut c = p.clone();
                    c[0] = to_x + (p[0] - x0);
                    if c.len() > 1 {
                        c[1] = to_y + (p[1] - y0);
                    }
                    to_value(&c)
                })
                .collect();
            *node_mut(doc, &r) = Value::Array(moved);
            Some(format!("{}: moved {what}", show(&r)))
        }
    }
}

/// Text mutations after serializing: cut short, one byte changed, one deleted, a line repeated.
fn mutate_text(text: &mut Vec<u8>, rng: &mut SplitMix64) -> String {
    if text.is_empty() {
        return "no text to change".into();
    }
    let at = (rng.next_u64() % text.len().max(1) as u64) as usize;
    match rng.next_u64() % 5 {
        0 => {
            text.truncate(at);
            format!("text cut at byte {at}")
        }
        1 => {
            let b = *rng.pick(b"{}[],:\"0-.e\n x\\\x1e");
            text[at] = b;
            format!("byte {at} := {:?}", b as char)
        }
        2 => {
            text.remove(at);
            format!("byte {at} deleted")
        }
        3 => {
            text[at] = 0xFF;
            format!("byte {at} := 0xFF (not UTF-8)")
        }
        _ => {
            let lines: Vec<&[u8]> = text.split(|&b| b == b'\n').collect();
            let i = (rng.next_u64() % lines.len() as u64) as usize;
            let mut out = Vec::with_capacity(text.len() * 2);
            for (k, l) in lines.iter().enumerate() {
                out.extend_from_slice(l);
                out.push(b'\n');
                if k == i {
                    out.extend_from_slice(l);
                    out.push(b'\n');
                }
            }
            *text = out;
            format!("line {} repeated", i + 1)
        }
    }
}

/// The mutated text of case `seed` of `input`, and what was done.
fn mutated(input: &Input, seed: u64) -> (Vec<u8>, Vec<String>) {
    let mut rng = SplitMix64(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ fnv(input.name));
    let mut lines = input.lines.clone();
    let mut done = Vec::new();
    for _ in 0..1 + rng.next_u64() % 3 {
        // In a sequence, the header 30 % of the time, else one of the lines after it.
        let li = if lines.len() > 1 && !rng.chance(0.3) {
            1 + (rng.next_u64() % (lines.len() as u64 - 1)) as usize
        } else {
            0
        };
        let what = match rng.next_u64() % 8 {
            0 | 1 => mutate_targeted(&mut lines[li], &mut rng),
            2..=4 => mutate_geometry(&mut lines[li], &mut rng),
            _ => None,
        };
        let what = what.unwrap_or_else(|| mutate(&mut lines[li], &mut rng));
        done.push(if input.sequence {
            format!("line {}: {what}", li + 1)
        } else {
            what
        });
    }
    let mut text = if input.sequence {
        let mut t = String::new();
        for l in &lines {
            t.push_str(&l.to_string());
            t.push('\n');
        }
        t.into_bytes()
    } else if rng.chance(0.5) {
        serde_json::to_vec_pretty(&lines[0]).unwrap()
    } else {
        serde_json::to_vec(&lines[0]).unwrap()
    };
    if rng.chance(0.12) {
        done.push(mutate_text(&mut text, &mut rng));
    }
    (text, done)
}

// ---------------------------------------------------------------------------------------------------------------
// Running the cases

/// A case not answered after this is a hang, and one that took a quarter of it a failure too (each input is a few
/// kB: a case takes milliseconds).
const HANG: Duration = Duration::from_secs(60);

#[derive(Default)]
struct Tally {
    cases: usize,
    ingests: usize,
    errors: usize,
    with_buildings: usize,
    with_skips: usize,
    with_repairs: usize,
    with_models: usize,
    with_mesh_issues: usize,
    /// The longest a case took, and which.
    slowest: (Duration, String),
    failures: Vec<String>,
}

fn options(input: &Input, rng: &mut SplitMix64) -> Vec<(String, IngestOptions)> {
    let lod = *rng.pick(&["2.2", "1.2", "2", "highest", "1", "3"]);
    let mut with_lod = IngestOptions {
        lod: Some(lod.parse::<LodChoice>().unwrap()),
        ..Default::default()
    };
    let mut plain = IngestOptions::default();
    if rng.chance(0.1) {
        with_lod.id_attr = input.id_attr.map(str::to_string);
    }
    if rng.chance(0.05) {
        with_lod.crs = Some(rng.pick(CRS_NAMES).to_string());
    }
    if rng.chance(0.1) {
        plain.height_attr = Some("roof:height".into());
        plain.height_unit_m = Some(0.3048);
    }
    vec![("no lod".into(), plain), (format!("lod {lod}"), with_lod)]
}

/// One line saying what a case gave: the error, or the counts and the reasons of skips and model issues.
fn outcome_line(got: &Outcome) -> String {
    match got {
        Outcome::Panicked(said) => format!("PANIC {said}"),
        Outcome::Failed(e) => {
            let mut text = e.to_string();
            let mut source = std::error::Error::source(e);
            while let Some(s) = source {
                text.push_str(&format!(": {s}"));
                source = s.source();
            }
            format!("error: {text}")
        }
        Outcome::Read(out) => {
            let r = &out.report;
            let issues = |list: &[citylod_ingest::FeatureIssue]| {
                list.iter()
                    .map(|i| format!("{} {}: {}", i.feature_id, i.reason.as_str(), i.detail))
                    .collect::<Vec<_>>()
                    .join(" | ")
            };
            format!(
                "{} read, {} written, {} with a model; skipped: [{}]; model issues: [{}]",
                r.features_read,
                r.buildings_written,
                r.buildings_with_mesh,
                issues(&r.skipped),
                issues(&r.mesh_issues)
            )
        }
    }
}

/// Runs `cases` mutated cases of `input` (or only the one `JSON_MUTATIONS_ONLY=<name>:<seed>` names).
fn run(input: &Input, cases: u64) -> Tally {
    // `Some(None)`: another input is asked for, so none of this one's cases run.
    let only: Option<Option<u64>> = std::env::var("JSON_MUTATIONS_ONLY").ok().map(|v| {
        let (name, seed) = v.split_once(':').unwrap_or((&v, ""));
        (name == input.name).then(|| seed.parse().expect("JSON_MUTATIONS_ONLY=<input>:<seed>"))
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(input.name);
    let mut tally = Tally::default();

    // The valid input itself: buildings, and 3D models with an LoD.
    std::fs::write(&path, valid_text(input)).unwrap();
    let out = ingest(std::slice::from_ref(&path), &IngestOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", input.name));
    check(&out).unwrap();
    assert!(out.report.buildings_written > 0, "{}", input.name);
    if input.has_models {
        let opts = IngestOptions {
            lod: Some(LodChoice::Highest),
            ..Default::default()
        };
        let out = ingest(std::slice::from_ref(&path), &opts).unwrap();
        check(&out).unwrap();
        assert!(
            out.report.buildings_with_mesh > 0,
            "{}: {:?}",
            input.name,
            out.report.mesh_issues
        );
    }
    // A valid file read with the mutated one now and then: the input itself (every building a duplicate, unless
    // mutated) or a file of the other family near it.
    let companion = input.companion.clone().unwrap_or_else(|| {
        let p = dir.path().join(format!("valid-{}", input.name));
        std::fs::write(&p, valid_text(input)).unwrap();
        p
    });

    // Every case and what it gave, for reading the messages: JSON_MUTATIONS_VERBOSE=1.
    let verbose = std::env::var("JSON_MUTATIONS_VERBOSE").is_ok();
    let seeds: Vec<u64> = match only {
        Some(Some(s)) => vec![s],
        Some(None) => Vec::new(),
        None => (0..cases).collect(),
    };
    for seed in seeds {
        let (text, done) = mutated(input, seed);
        std::fs::write(&path, &text).unwrap();
        let mut rng = SplitMix64(seed ^ 0x5eed);
        let mut paths = vec![path.clone()];
        let with = if rng.chance(0.04) {
            paths.push(path.clone());
            " + itself"
        } else if rng.chance(0.06) {
            paths.insert(0, companion.clone());
            " after a valid file"
        } else {
            ""
        };
        tally.cases += 1;
        for (label, opts) in options(input, &mut rng) {
            let case = format!(
                "{} seed {seed} ({label}{with}): {}",
                input.name,
                done.join("; ")
            );
            if only.is_some() {
                eprintln!("{case}");
                // The case's file, to look at: JSON_MUTATIONS_KEEP=<file> (with JSON_MUTATIONS_ONLY).
                if let Ok(keep) = std::env::var("JSON_MUTATIONS_KEEP") {
                    std::fs::write(keep, &text).unwrap();
                }
            }
            tally.ingests += 1;
            let started = Instant::now();
            let ps = paths.clone();
            let got = guarded(HANG, only.is_none(), move || ingest(&ps, &opts))
                .unwrap_or_else(|waited| panic!("{case}: no answer after {waited:?} (a hang?)"));
            if started.elapsed() > tally.slowest.0 {
                tally.slowest = (started.elapsed(), case.clone());
            }
            if started.elapsed() > HANG / 4 {
                tally
                    .failures
                    .push(format!("{case}: took {:?}", started.elapsed()));
            }
            if verbose {
                eprintln!("{case}\n    -> {}", outcome_line(&got));
            }
            match got {
                Outcome::Panicked(said) => tally.failures.push(format!("{case}: PANIC: {said}")),
                Outcome::Failed(e) => {
                    tally.errors += 1;
                    if let Some(f) = bad_error(&e, &paths) {
                        tally.failures.push(format!("{case}: {f}"));
                    }
                }
                Outcome::Read(out) => {
                    if let Err(e) = check(&out) {
                        tally.failures.push(format!("{case}: {e}"));
                    }
                    let r = &out.report;
                    tally.with_buildings += usize::from(r.buildings_written > 0);
                    tally.with_skips += usize::from(!r.skipped.is_empty());
                    tally.with_repairs += usize::from(!r.repaired.is_empty());
                    tally.with_models += usize::from(r.buildings_with_mesh > 0);
                    tally.with_mesh_issues += usize::from(!r.mesh_issues.is_empty());
                }
            }
        }
    }
    tally
}

/// The valid input's text.
fn valid_text(input: &Input) -> Vec<u8> {
    if input.sequence {
        let mut t = String::new();
        for l in &input.lines {
            t.push_str(&l.to_string());
            t.push('\n');
        }
        t.into_bytes()
    } else {
        serde_json::to_vec(&input.lines[0]).unwrap()
    }
}

/// An error must name the file (one of `paths`) or the option at fault.
fn bad_error(e: &IngestError, paths: &[PathBuf]) -> Option<String> {
    let text = e.to_string();
    let names_a_file = paths
        .iter()
        .any(|p| text.contains(&*p.file_name().unwrap().to_string_lossy()));
    let names_an_option =
        matches!(e, IngestError::InvalidOption { .. }) || text.starts_with("--crs: ");
    (!(names_a_file || names_an_option) || text.contains("panicked"))
        .then(|| format!("an error naming no file nor option: {text:?}"))
}

/// Runs every input for `cases` cases each and asserts no failure and that each outcome was reached.
fn run_all(inputs: &[Input], cases: u64) {
    let started = Instant::now();
    let mut total = Tally::default();
    // More cases for a longer hunt: JSON_MUTATIONS_CASES=20000.
    let cases = std::env::var("JSON_MUTATIONS_CASES")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(cases);
    for input in inputs {
        let t = run(input, cases);
        let counts = format!(
            "{} cases, {} ingests: {} errors, {} with buildings, {} with skips, {} with repairs, {} with models, {} \
             with model issues; slowest {:?}: {}",
            t.cases,
            t.ingests,
            t.errors,
            t.with_buildings,
            t.with_skips,
            t.with_repairs,
            t.with_models,
            t.with_mesh_issues,
            t.slowest.0,
            t.slowest.1
        );
        eprintln!("{}: {counts}", input.name);
        // Each input reaches its reader's structure, not only the JSON parser: some cases give buildings, some
        // skip features, some are refused, and (with an LoD) some give 3D models.
        if std::env::var("JSON_MUTATIONS_ONLY").is_err() {
            assert!(
                t.with_buildings > 0 && t.errors > 0 && t.with_skips > 0,
                "{}: {counts}",
                input.name
            );
            assert!(
                !input.has_models || t.with_models > 0,
                "{}: {counts}",
                input.name
            );
        }
        total.cases += t.cases;
        total.ingests += t.ingests;
        total.errors += t.errors;
        total.with_buildings += t.with_buildings;
        total.with_skips += t.with_skips;
        total.with_repairs += t.with_repairs;
        total.with_models += t.with_models;
        total.with_mesh_issues += t.with_mesh_issues;
        total.failures.extend(t.failures);
    }
    eprintln!(
        "{} cases, {} ingests in {:?}: {} errors, {} with buildings, {} with skips, {} with repairs, {} with models, \
         {} with model issues",
        total.cases,
        total.ingests,
        started.elapsed(),
        total.errors,
        total.with_buildings,
        total.with_skips,
        total.with_repairs,
        total.with_models,
        total.with_mesh_issues
    );
    assert!(
        total.failures.is_empty(),
        "{} of {} ingests failed:\n{}",
        total.failures.len(),
        total.ingests,
        total
            .failures
            .iter()
            .take(40)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
fn mutated_geojson_gives_an_error_or_buildings_never_a_panic() {
    run_all(
        &[
            lower_east_side(),
            roofs(),
            roofs_lines(),
            bare_geometry(),
            single_feature(),
        ],
        400,
    );
}

#[test]
fn mutated_cityjson_gives_an_error_or_buildings_never_a_panic() {
    run_all(
        &[
            lod2_templates(),
            cityjson_fixture("annex-part.city.json"),
            cityjson_fixture("part-of-two-buildings.city.json"),
            cityjson_fixture("lod0-ground-and-roof-edge.city.json"),
            cityjson_fixture("v0.9-no-transform.city.json"),
        ],
        400,
    );
}

#[test]
fn mutated_cityjson_sequences_give_an_error_or_buildings_never_a_panic() {
    run_all(
        &[
            lod2_sequence(),
            cityjson_fixture("header-objects.city.jsonl"),
        ],
        400,
    );
}

#[test]
fn the_handmade_inputs_are_what_they_say() {
    // Both read whole at LoD 2.2, templates expanded: every building written with its model, none falling back.
    let dir = tempfile::tempdir().unwrap();
    for input in [lod2_templates(), lod2_sequence()] {
        let path = dir.path().join(input.name);
        std::fs::write(&path, valid_text(&input)).unwrap();
        let opts = IngestOptions {
            lod: Some(LodChoice::Exact("2.2".into())),
            ..Default::default()
        };
        let out = ingest(&[path], &opts).unwrap();
        check(&out).unwrap();
        let r = &out.report;
        assert!(r.skipped.is_empty(), "{}: {:?}", input.name, r.skipped);
        assert_eq!(
            r.buildings_with_mesh, r.buildings_written,
            "{}: {:?}",
            input.name, r.mesh_issues
        );
        assert_eq!(r.mesh_lod_fallbacks, 0, "{}", input.name);
        let ids: Vec<&str> = out.buildings.iter().map(|b| b.source_id.as_str()).collect();
        if input.sequence {
            assert_eq!(ids, ["NL.1", "house", "shed", "NL.2"]);
        } else {
            assert_eq!(ids, ["house", "shed"]);
            let others: usize = r.files.iter().map(|f| f.non_building_objects).sum();
            assert_eq!(others, 2, "the chimney and the tree");
        }
        // The gabled roof: a ridge 8 m over the ground, roof triangles among the model's.
        let house = out
            .buildings
            .iter()
            .find(|b| b.source_id == "house")
            .unwrap();
        let m = house.mesh.as_ref().unwrap();
        let (lo, hi) = m
            .mesh
            .positions
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), p| (l.min(p[2]), h.max(p[2])));
        assert!((hi - lo - 8.0).abs() < 0.01, "{lo} {hi}");
        assert!(m.surfaces.contains(&citylod_model::SurfaceKind::Roof));
        // The shed, a template 3 m × 2 m placed turned: its footprint and its model.
        let shed = out
            .buildings
            .iter()
            .find(|b| b.source_id == "shed")
            .unwrap();
        assert!((shed.area_m2() - 6.0).abs() < 0.05, "{}", shed.area_m2());
        assert_eq!(shed.mesh.as_ref().unwrap().surfaces.len(), 12, "6 faces");
    }
    // The house's footprint is its LoD 0 (10 m × 8 m), which stands for the whole building as 3DBAG's does (the
    // annex has no LoD 0 of its own); its model has the annex too, 14 m long in all (in east metres, the RD grid
    // turned about a degree from them there).
    let path = dir.path().join("house.city.json");
    std::fs::write(&path, valid_text(&lod2_templates())).unwrap();
    let opts = IngestOptions {
        lod: Some(LodChoice::Highest),
        ..Default::default()
    };
    let out = ingest(&[path], &opts).unwrap();
    let house = &out.buildings[0];
    assert!((house.area_m2() - 80.0).abs() < 0.1, "{}", house.area_m2());
    let xs = house
        .mesh
        .as_ref()
        .unwrap()
        .mesh
        .positions
        .iter()
        .map(|p| p[0]);
    let (lo, hi) = xs.fold((f64::MAX, f64::MIN), |(l, h), x| (l.min(x), h.max(x)));
    assert!((hi - lo - 14.0).abs() < 0.2, "{lo} {hi}");
}

#[test]
fn a_panic_or_a_hang_in_a_case_is_caught_and_said() {
    // A panic on a rayon worker, as one inside `ingest` would be: caught with what it said and where.
    let got = guarded(HANG, true, || {
        use rayon::prelude::*;
        (0..64u32)
            .into_par_iter()
            .for_each(|i| assert!(i != 37, "boom at {i}"));
        unreachable!()
    });
    match got {
        Ok(Outcome::Panicked(said)) => assert!(
            said.contains("boom at 37") && said.contains("json_mutations.rs"),
            "{said}"
        ),
        _ => panic!("the panic was not caught"),
    }
    let got = guarded(HANG, true, || ingest(&[], &IngestOptions::default()));
    assert!(matches!(got, Ok(Outcome::Read(_))));
}

/// Found by the mutations (`bare-geometry.geojson` seed 13: one polygon of a building moved onto longitude -180):
/// a too-wide error said "0 building(s) lie over 100 km from the median position" and named the building as 0 km
/// away, because a building was placed by its centre. One building whose own polygons lie far apart is named by
/// the span it covers, alone or among others.
#[test]
fn a_building_spread_over_the_globe_is_named_in_the_too_wide_error() {
    let square = |lon: f64, lat: f64| {
        let d = 0.0001;
        json!([[
            [lon, lat],
            [lon + d, lat],
            [lon + d, lat + d],
            [lon, lat + d],
            [lon, lat]
        ]])
    };
    let house = |id: &str, geometry: Value| json!({"type": "Feature", "id": id, "properties": {"height": 9}, "geometry": geometry});
    let wide = house(
        "wide",
        json!({"type": "MultiPolygon", "coordinates": [square(4.0, 52.0), square(-179.9998, 52.0)]}),
    );
    let dir = tempfile::tempdir().unwrap();
    for others in [0, 3] {
        let mut features = vec![wide.clone()];
        for k in 0..others {
            let g = json!({"type": "Polygon", "coordinates": square(4.0 + k as f64 * 0.001, 52.0)});
            features.push(house(&format!("h{k}"), g));
        }
        let path = dir.path().join(format!("wide-{others}.geojson"));
        std::fs::write(
            &path,
            json!({"type": "FeatureCollection", "features": features}).to_string(),
        )
        .unwrap();
        let e = ingest(&[path], &IngestOptions::default()).expect_err("too wide");
        let text = e.to_string();
        assert!(matches!(e, IngestError::TooWide { .. }), "{text}");
        assert!(
            text.contains("1 building(s) lie over 100 km")
                && text.contains("farthest: \"wide\" in ")
                && text.contains(
                    "spanning longitudes 4.0000..-179.9997 and latitudes 52.0000..52.0001"
                ),
            "{others} others: {text}"
        );
        assert!(!text.contains(" 0 km away"), "{text}");
    }
}

/// Found by the mutations (`v0.9-no-transform.city.json` seeds 664 and 4795): a footprint valid in the plane it is
/// repaired in crossed itself, or turned over as a sliver under 0.01 m², once placed in the local frame (the two bend
/// straight lines apart by micrometres over a building's length), and was written so. Now it is repaired there once
/// more, or skipped saying why.
#[test]
fn a_footprint_a_hair_from_crossing_itself_is_valid_where_it_is_placed() {
    let dir = tempfile::tempdir().unwrap();
    // Seed 664: B2's ground (8, 11, 10, 9) comes to run (0, 0) → (10, 10) → (10, 0) → (100, 0.0001) m from its
    // first corner, its last edge passing 10 µm over its third corner.
    let crossing = {
        let mut d = read_json(&fixture("v0.9-no-transform.city.json"));
        let v = d["vertices"].as_array_mut().unwrap();
        v.insert(
            9,
            json!([85000.0 + 20.0 + 100.0 + 1e-4, 446000.0 + 1e-4, 1e-4]),
        );
        d
    };
    // Seed 4795: B2's ground a sliver 180 m long and 0.1 mm wide.
    let sliver = {
        let mut d = read_json(&fixture("v0.9-no-transform.city.json"));
        d["vertices"][7] = json!([85005.0, 446010.0, 10.0]);
        d["CityObjects"]["B2"]["geometry"][0]["boundaries"][0][0][0][1] = json!(0);
        let spike = json!([85000.0 + 30.0 + 150.0 + 1e-4, 446000.0 + 1e-4, 1e-4]);
        d["vertices"].as_array_mut().unwrap().insert(10, spike);
        d
    };
    for (name, doc) in [("crossing", crossing), ("sliver", sliver)] {
        let path = dir.path().join(format!("{name}.city.json"));
        std::fs::write(&path, doc.to_string()).unwrap();
        let out = ingest(&[path], &IngestOptions::default()).unwrap();
        check(&out).unwrap_or_else(|e| panic!("{name}: {e}"));
        let r = &out.report;
        let said: Vec<&citylod_ingest::FeatureIssue> = r
            .repaired
            .iter()
            .chain(&r.skipped)
            .filter(|i| i.feature_id == "B2")
            .collect();
        assert!(
            said.iter()
                .any(|i| i.detail.starts_with("as placed in the local frame")),
            "{name}: {said:?}"
        );
    }
}
