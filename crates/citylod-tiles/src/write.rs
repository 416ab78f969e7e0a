//! The tileset writer: one glb per tile with features (encoded in parallel, files and order
//! deterministic) and `tileset.json` (3D Tiles 1.1, REPLACE, root `transform` = ENU→ECEF, `box`
//! volumes in the root's ENU frame enclosing each tile's content and all its descendants').
//! Tile paths: the root is `0`, child k of tile `p` is `p/k`; content goes to `tiles/<path>.glb`.

use crate::content::{bounds, encode_content, Bounds, ContentOptions};
use crate::external::split_external;
use crate::spec::{ContentFeature, MetadataSchema, TileSpec};
use crate::staging::Staging;
use crate::tileset_json as tj;
use crate::TilesError;
use citylod_model::LocalFrame;
use rayon::prelude::*;
use std::borrow::Cow;

/// What citylod writes as the `asset.generator` of its tileset.json and glb files: "citylod <version>".
pub fn generator() -> String {
    format!("citylod {}", env!("CARGO_PKG_VERSION"))
}

/// Whether an `asset.generator` is one [`generator`] wrote (of any version).
pub fn written_by_citylod(generator: &str) -> bool {
    generator == "citylod" || generator.starts_with("citylod ")
}

/// How vertex and index data are stored in the glb.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    /// EXT_meshopt_compression (required extension; the fallback buffer holds no data).
    #[default]
    Meshopt,
    /// Plain quantized buffers.
    None,
    /// KHR_draco_mesh_compression (required extension, no uncompressed copy): the quantized
    /// positions, normals and feature ids are Draco integer attributes (lossless), edgebreaker
    /// connectivity. Property tables stay plain buffer views.
    Draco,
}

/// Writer options.
#[derive(Debug, Clone)]
pub struct WriteOptions {
    pub compression: Compression,
    /// Leave out vertex normals (BYTE normalized, 4 bytes per vertex before compression). The glTF
    /// spec asks clients to compute flat normals when they are missing, but CesiumJS draws such
    /// primitives unlit (CesiumGS/cesium#6506, #10237), so normals are written unless this is set.
    pub omit_normals: bool,
    /// Grid exact vertex positions are rounded to (m, > 0; default 0.02: within 1 cm of the input on every
    /// axis), whatever the tile's size: a tile wider than 65,534 steps is split into several glTF nodes whose
    /// coordinates each fit 16 bits (KHR_mesh_quantization SHORT); only a single feature that wide gets a
    /// coarser grid. Features with a rounding tolerance ([`crate::ContentFeature::max_rounding_m`]) may get a
    /// power-of-two multiple of it. Grids are anchored at the local origin, so the same vertex in two tiles on
    /// the same grid rounds to the same point.
    pub quantization_step_m: f64,
    /// `tileset.geometricError` (m). Default: the larger of the root's geometric error and the root
    /// box diagonal, so the root is considered as soon as the city spans a few pixels. Never less than
    /// the root's geometric error.
    pub tileset_geometric_error_m: Option<f64>,
    /// Largest `tileset.json` (bytes); subtrees beyond it go to external tilesets
    /// `tiles/<path>.json`, each also within it. Default 4 MB. Too small to fit one tile with
    /// stubs for all its children → an error.
    pub max_tileset_json_bytes: usize,
    /// Written as the top-level `extras` of `tileset.json` (an object, per the schema), read back
    /// as `TilesetData::extras`.
    pub extras: Option<serde_json::Value>,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            compression: Compression::default(),
            omit_normals: false,
            quantization_step_m: 0.02,
            tileset_geometric_error_m: None,
            max_tileset_json_bytes: 4_000_000,
            extras: None,
        }
    }
}

/// What was written.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct WriteStats {
    /// All tiles, with and without content.
    pub tiles: usize,
    /// Tiles with a glb.
    pub content_tiles: usize,
    pub glb_bytes: u64,
    /// Size of the main `tileset.json`.
    pub tileset_json_bytes: u64,
    /// External tileset files written (0 when `tileset.json` fits the limit).
    pub external_tilesets: u64,
    pub triangles: u64,
    pub vertices: u64,
    pub features: u64,
    /// Triangles left out because quantization put their corners on one line (or point).
    pub dropped_triangles: u64,
    /// Features none of whose triangles is left after quantization: a block or building smaller than its tile's
    /// grid (under a pixel where the tile is drawn). Their rows stay in the property table.
    pub collapsed_features: u64,
}

/// Smallest half-size of a box axis (m), so no box is flat.
const MIN_HALF_M: f64 = 0.005;

/// Writes `tileset.json` and `tiles/**.glb` for the tree `root` into the staging directory `out`
/// (commit it afterwards, see [`Staging`]). Meshes are in local ENU metres of `frame`; `schema`
/// gives the classes and properties of the features' values.
///
/// Errors: invalid schema ids, a feature whose class, values or indices do not fit, non-finite
/// positions or geometric errors, I/O. Tiles whose features have no vertices get no content.
/// The same input gives byte-identical files.
pub fn write_tileset(
    out: &Staging,
    root: &TileSpec,
    frame: &LocalFrame,
    schema: &MetadataSchema,
    opts: &WriteOptions,
) -> Result<WriteStats, TilesError> {
    write_tileset_with(out, root, frame, schema, opts, &|f: &Vec<
        ContentFeature,
    >| {
        Cow::Borrowed(f.as_slice())
    })
}

/// [`write_tileset`] for a tree whose tiles describe their content (`C`) instead of holding it: `content` makes a
/// tile's features when the writer encodes that tile, and they are dropped once its glb is written, so only the
/// features of the tiles being encoded (one per thread) are in memory at once, not every mesh of the city twice.
/// The output is the same as [`write_tileset`]'s for a tree holding what `content` makes.
pub fn write_tileset_with<C: Sync>(
    out: &Staging,
    root: &TileSpec<C>,
    frame: &LocalFrame,
    schema: &MetadataSchema,
    opts: &WriteOptions,
    content: &(dyn for<'a> Fn(&'a C) -> Cow<'a, [ContentFeature]> + Sync),
) -> Result<WriteStats, TilesError> {
    schema.validate()?;
    if !(opts.quantization_step_m > 0.0 && opts.quantization_step_m.is_finite()) {
        return Err(TilesError::Tile {
            tile: "0".into(),
            msg: format!(
                "quantization step {} m is not finite and > 0",
                opts.quantization_step_m
            ),
        });
    }
    let mut flat: Vec<(String, &TileSpec<C>)> = Vec::with_capacity(root.count_tiles());
    flatten(root, "0".into(), &mut flat);
    for (path, t) in &flat {
        if !(t.geometric_error_m.is_finite() && t.geometric_error_m >= 0.0) {
            return Err(TilesError::Tile {
                tile: path.clone(),
                msg: format!(
                    "geometric error {} m is not finite and ≥ 0",
                    t.geometric_error_m
                ),
            });
        }
    }
    let generator = generator();
    let content_opts = ContentOptions {
        compression: opts.compression,
        normals: !opts.omit_normals,
        quantization_step_m: opts.quantization_step_m,
    };
    let encoded: Vec<Result<TileOut, TilesError>> = flat
        .par_iter()
        .map(|(path, t)| {
            let features = content(&t.features);
            let encoded = encode_content(path, &features, schema, &content_opts, &generator)?;
            let Some(c) = encoded else {
                return Ok(TileOut {
                    bounds: None,
                    uri: None,
                    stats: WriteStats::default(),
                });
            };
            let uri = format!("tiles/{path}.glb");
            out.write_file(&uri, &c.glb)?;
            let stats = WriteStats {
                content_tiles: 1,
                glb_bytes: c.glb.len() as u64,
                triangles: c.triangles,
                vertices: c.vertices,
                features: features.len() as u64,
                dropped_triangles: c.dropped_triangles,
                collapsed_features: c.collapsed_features,
                ..Default::default()
            };
            // Exact input bounds and the drawn (dequantized) ones, so the box holds both.
            let exact = bounds(
                features
                    .iter()
                    .flat_map(|f| f.mesh.positions.iter().copied()),
            );
            Ok(TileOut {
                bounds: union(exact, Some(c.bounds_enu)),
                uri: Some(uri),
                stats,
            })
        })
        .collect();
    let mut outs = Vec::with_capacity(encoded.len());
    let mut stats = WriteStats {
        tiles: flat.len(),
        ..Default::default()
    };
    for r in encoded {
        let o = r?;
        stats.content_tiles += o.stats.content_tiles;
        stats.glb_bytes += o.stats.glb_bytes;
        stats.triangles += o.stats.triangles;
        stats.vertices += o.stats.vertices;
        stats.features += o.stats.features;
        stats.dropped_triangles += o.stats.dropped_triangles;
        stats.collapsed_features += o.stats.collapsed_features;
        outs.push(o);
    }

    let mut next = 0;
    let (mut root_json, root_bounds) = build_tile(root, &outs, &mut next);
    debug_assert_eq!(next, outs.len());
    empty_tiles_take_parent_boxes(&mut root_json);
    root_json.transform = Some(frame.enu_to_ecef_column_major());
    root_json.refine = Some("REPLACE".into());
    let diagonal = root_bounds.map_or(0.0, |(lo, hi)| dist(lo, hi));
    let tileset_error_m = opts
        .tileset_geometric_error_m
        .unwrap_or(diagonal)
        .max(root.geometric_error_m);
    if opts.extras.as_ref().is_some_and(|e| !e.is_object()) {
        return Err(TilesError::Tile {
            tile: "0".into(),
            msg: "tileset extras must be a JSON object".into(),
        });
    }
    // The main file carries the tileset's error and the extras; an external one its root's error.
    let wrap = |root: tj::Tile, main: bool| tj::Tileset {
        asset: tj::Asset {
            version: "1.1".into(),
            generator: Some(generator.clone()),
            gltf_up_axis: None,
        },
        geometric_error: if main {
            tileset_error_m
        } else {
            root.geometric_error
        },
        extras: if main { opts.extras.clone() } else { None },
        root,
    };
    let externals = split_external(&mut root_json, opts.max_tileset_json_bytes, &wrap)?;
    for (file, bytes) in &externals {
        out.write_file(file, bytes)?;
    }
    stats.external_tilesets = externals.len() as u64;
    let json =
        serde_json::to_vec(&wrap(root_json, true)).expect("tileset structs always serialize");
    stats.tileset_json_bytes = json.len() as u64;
    out.write_file("tileset.json", &json)?;
    Ok(stats)
}

struct TileOut {
    bounds: Option<Bounds>,
    uri: Option<String>,
    stats: WriteStats,
}

/// Gives every tile below the root that has no content and its parent's error its parent's box (which holds the
/// tile's subtree too), so that a client, whose screen-space error counts the distance to the box, refines it
/// whenever it refines the parent: an empty tile is never chosen to draw in its parent's stead (see
/// `hlod::assemble`). An empty tile of lower error keeps its own box: the parent's would not make it refine with the
/// parent, and would keep a client from culling its subtree — the inner tiles of a buildings-only tree, given the
/// root's box, were drawn (as nothing) wherever their children were out of view, and `citylod check` failed there.
fn empty_tiles_take_parent_boxes(t: &mut tj::Tile) {
    for c in &mut t.children {
        if c.content.is_none() && c.geometric_error >= t.geometric_error {
            c.bounding_volume = t.bounding_volume.clone();
        }
        empty_tiles_take_parent_boxes(c);
    }
}

fn flatten<'a, C>(t: &'a TileSpec<C>, path: String, out: &mut Vec<(String, &'a TileSpec<C>)>) {
    out.push((path.clone(), t));
    for (k, c) in t.children.iter().enumerate() {
        flatten(c, format!("{path}/{k}"), out);
    }
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

/// The JSON of a tile (pre-order index `*next` into `outs`) and the bounds of it and its subtree.
fn build_tile<C>(
    t: &TileSpec<C>,
    outs: &[TileOut],
    next: &mut usize,
) -> (tj::Tile, Option<Bounds>) {
    let me = &outs[*next];
    *next += 1;
    let mut b = me.bounds;
    let mut children = Vec::with_capacity(t.children.len());
    for c in &t.children {
        let (cj, cb) = build_tile(c, outs, next);
        b = union(b, cb);
        children.push(cj);
    }
    let (lo, hi) = b.unwrap_or(([0.0; 3], [0.0; 3]));
    let c: [f64; 3] = std::array::from_fn(|i| (lo[i] + hi[i]) / 2.0);
    let h: [f64; 3] = std::array::from_fn(|i| ((hi[i] - lo[i]) / 2.0).max(MIN_HALF_M));
    let tile = tj::Tile {
        transform: None,
        bounding_volume: tj::BoundingVolume {
            r#box: Some([
                c[0], c[1], c[2], h[0], 0.0, 0.0, 0.0, h[1], 0.0, 0.0, 0.0, h[2],
            ]),
            region: None,
            sphere: None,
        },
        geometric_error: t.geometric_error_m,
        refine: None,
        content: me.uri.clone().map(|uri| tj::Content { uri }),
        contents: Vec::new(),
        children,
        implicit_tiling: None,
        extensions: None,
    };
    (tile, b)
}

fn union(a: Option<Bounds>, b: Option<Bounds>) -> Option<Bounds> {
    match (a, b) {
        (Some((alo, ahi)), Some((blo, bhi))) => Some((
            std::array::from_fn(|i| alo[i].min(blo[i])),
            std::array::from_fn(|i| ahi[i].max(bhi[i])),
        )),
        (x, None) | (None, x) => x,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::{read_tileset, TilesetData};
    use crate::spec::{ClassDef, ContentFeature, PropValue, PropertyDef, PropertyKind};
    use crate::tile_spatially;
    use citylod_model::Mesh3d;
    use std::path::Path;

    /// A flat-shaded box: four walls and a roof, each face with its own four vertices.
    pub(crate) fn box_mesh(x: f64, y: f64, w: f64, d: f64, z0: f64, h: f64) -> Mesh3d {
        let c = [[x, y], [x + w, y], [x + w, y + d], [x, y + d]];
        let mut m = Mesh3d::default();
        let mut quad = |q: [[f64; 3]; 4]| {
            let v = m.positions.len() as u32;
            m.positions.extend_from_slice(&q);
            m.triangles
                .extend_from_slice(&[[v, v + 1, v + 2], [v, v + 2, v + 3]]);
        };
        for i in 0..4 {
            let (a, b) = (c[i], c[(i + 1) % 4]);
            quad([
                [a[0], a[1], z0],
                [b[0], b[1], z0],
                [b[0], b[1], z0 + h],
                [a[0], a[1], z0 + h],
            ]);
        }
        quad(c.map(|p| [p[0], p[1], z0 + h]));
        m
    }

    pub(crate) fn schema() -> MetadataSchema {
        let p = |name: &str, kind| PropertyDef {
            name: name.into(),
            kind,
            description: Some(format!("the {name}")),
            nullable: true,
            string_no_data: None,
            input_name: None,
        };
        MetadataSchema {
            id: "citylod".into(),
            classes: vec![
                ClassDef {
                    id: "building".into(),
                    properties: vec![
                        p("source_id", PropertyKind::String),
                        p("height_m", PropertyKind::Float64),
                        p("storeys", PropertyKind::Int64),
                        p("code", PropertyKind::UInt32),
                        p("listed", PropertyKind::Boolean),
                    ],
                },
                ClassDef {
                    id: "cluster".into(),
                    properties: vec![
                        p("member_count", PropertyKind::UInt32),
                        p("dh_m", PropertyKind::Float64),
                    ],
                },
            ],
        }
    }

    fn building(i: usize) -> ContentFeature {
        let (x, y) = ((i % 8) as f64 * 25.0 - 90.0, (i / 8) as f64 * 30.0 - 70.0);
        let h = 6.0 + (i * 7 % 23) as f64;
        let name = match i % 4 {
            0 => PropValue::Str(format!("bâtiment-{i} 東京")),
            1 => PropValue::Null,
            _ => PropValue::Str(format!("b{i}")),
        };
        ContentFeature {
            mesh: box_mesh(x, y, 12.0 + (i % 3) as f64, 9.5, (i % 5) as f64 * 0.37, h),
            class: 0,
            values: vec![
                name,
                if i % 6 == 5 {
                    PropValue::Null
                } else {
                    PropValue::Float(h + 0.125)
                },
                if i % 7 == 3 {
                    PropValue::Null
                } else {
                    PropValue::Int(i as i64 - 20)
                },
                if i % 9 == 4 {
                    PropValue::Null
                } else {
                    PropValue::Int(i as i64 * 1000)
                },
                PropValue::Bool(i.is_multiple_of(3)),
            ],
            max_rounding_m: 0.0,
        }
    }

    fn cluster(x: f64, y: f64, n: i64) -> ContentFeature {
        ContentFeature {
            mesh: box_mesh(x, y, 80.0, 60.0, 0.0, 11.0),
            class: 1,
            values: vec![PropValue::Int(n), PropValue::Float(n as f64 * 0.5)],
            max_rounding_m: 0.0,
        }
    }

    /// 40 buildings in leaves, two clusters at the root (content at an inner level), and one leaf
    /// holding features of both classes.
    fn city() -> TileSpec {
        let mut root = tile_spatially((0..40).map(building).collect(), 7, 10_000);
        root.features = vec![cluster(-95.0, -75.0, 20), cluster(5.0, -75.0, 20)];
        let mut leaf = &mut root;
        while !leaf.children.is_empty() {
            leaf = &mut leaf.children[0];
        }
        leaf.features.push(cluster(-90.0, -70.0, 3));
        // A pyramid with an off-centre apex: slanted faces at odd angles.
        let mut pyramid = building(41);
        let base = [
            [0.0, 0.0, 20.0],
            [13.0, 0.0, 20.0],
            [13.0, 9.0, 20.0],
            [0.0, 9.0, 20.0],
        ];
        let apex = [3.7, 5.1, 27.3];
        pyramid.mesh = Mesh3d::default();
        for i in 0..4 {
            let v = pyramid.mesh.positions.len() as u32;
            pyramid
                .mesh
                .positions
                .extend_from_slice(&[base[i], base[(i + 1) % 4], apex]);
            pyramid.mesh.triangles.push([v, v + 1, v + 2]);
        }
        leaf.features.push(pyramid);
        root
    }

    fn frame() -> LocalFrame {
        LocalFrame::new(-71.06, 42.35, 12.0)
    }

    fn write(
        dir: &Path,
        root: &TileSpec,
        compression: Compression,
    ) -> Result<WriteStats, TilesError> {
        let out = Staging::create(dir)?;
        let opts = WriteOptions {
            compression,
            ..Default::default()
        };
        let stats = write_tileset(&out, root, &frame(), &schema(), &opts)?;
        out.commit()?;
        Ok(stats)
    }

    /// The spec tree flattened in the writer's pre-order, paired with the read tiles.
    fn spec_preorder<'a>(t: &'a TileSpec, out: &mut Vec<&'a TileSpec>) {
        out.push(t);
        t.children.iter().for_each(|c| spec_preorder(c, out));
    }

    /// What a value reads back as, per the null rules (bool null → false).
    fn expected(v: &PropValue, kind: PropertyKind) -> PropValue {
        match (v, kind) {
            (PropValue::Null, PropertyKind::Boolean) => PropValue::Bool(false),
            (PropValue::Int(k), PropertyKind::Float64) => PropValue::Float(*k as f64),
            _ => v.clone(),
        }
    }

    fn check_round_trip(root: &TileSpec, back: &TilesetData) {
        let schema = schema();
        let mut specs = Vec::new();
        spec_preorder(root, &mut specs);
        assert_eq!(specs.len(), back.tiles.len());
        for (spec, tile) in specs.iter().zip(&back.tiles) {
            assert_eq!(tile.geometric_error_m, spec.geometric_error_m);
            let Some(glb) = &tile.content else {
                assert!(
                    spec.features.is_empty(),
                    "tile {} lost its content",
                    tile.path_in_tree
                );
                continue;
            };
            // Features in the glb: grouped by class (schema order), input order within a class.
            let mut order: Vec<&ContentFeature> = spec.features.iter().collect();
            order.sort_by_key(|f| f.class);
            assert_eq!(glb.features.len(), order.len());
            // Exact features are on the default 2 cm grid whatever the tile's extent (a tile too wide for 16 bits
            // gets several nodes): within 1 cm of their input on every axis.
            let step = WriteOptions::default().quantization_step_m;
            let tol = [step / 2.0 + 1e-9; 3];
            let (mut v, mut t) = (0usize, 0usize);
            for (k, f) in order.iter().enumerate() {
                let class = &schema.classes[f.class];
                assert_eq!(glb.features[k].class, class.id);
                for (p, val) in class.properties.iter().zip(&f.values) {
                    assert_eq!(
                        glb.features[k].values[&p.name],
                        expected(val, p.kind),
                        "{}",
                        p.name
                    );
                }
                let k_in_class = order[..k].iter().filter(|g| g.class == f.class).count();
                let table_start = k - k_in_class;
                for tri in &f.mesh.triangles {
                    let got = glb.triangles[t];
                    let want = tri.map(|i| (v + i as usize) as u32);
                    assert_eq!(got, want);
                    t += 1;
                    // Each corner's normal is the face normal (flat-shaded input).
                    let [a, b, c] = tri.map(|i| f.mesh.positions[i as usize]);
                    let (u, w) = (
                        [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                        [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
                    );
                    let n = [
                        u[1] * w[2] - u[2] * w[1],
                        u[2] * w[0] - u[0] * w[2],
                        u[0] * w[1] - u[1] * w[0],
                    ];
                    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                    for &i in &want {
                        let m = glb.normals_local[i as usize];
                        let cos = (0..3).map(|k| m[k] * n[k] / len).sum::<f64>();
                        assert!(cos > 0.999, "normal {m:?} vs face {n:?}");
                    }
                }
                for p in &f.mesh.positions {
                    let q = glb.positions_local[v];
                    for i in 0..3 {
                        assert!(
                            (q[i] - p[i]).abs() <= tol[i],
                            "{q:?} vs {p:?} (tol {tol:?})"
                        );
                    }
                    assert_eq!(glb.feature_ids[v] as usize, table_start + k_in_class);
                    v += 1;
                }
            }
            assert_eq!((v, t), (glb.positions_local.len(), glb.triangles.len()));
        }
    }

    /// Writes `root` (a single tile, meshopt) and returns its glb's glTF JSON and decoded content.
    fn write_one_tile(root: &TileSpec) -> (crate::gltf_json::Gltf, crate::read::GlbData) {
        let dir = tempfile::tempdir().unwrap();
        write(&dir.path().join("out"), root, Compression::Meshopt).unwrap();
        let bytes = std::fs::read(dir.path().join("out/tiles/0.glb")).unwrap();
        let (json, _) = crate::glb::parse_glb(&bytes).unwrap();
        let doc = serde_json::from_slice(json).unwrap();
        let glb = crate::read::read_glb(&bytes, std::path::Path::new("0.glb")).unwrap();
        (doc, glb)
    }

    #[test]
    fn a_tile_wider_than_16_bits_on_the_grid_keeps_every_vertex_within_half_a_step() {
        // Two buildings 5 km apart: one node would need a 7.6 cm grid; each gets its own node on the 2 cm grid.
        let mut a = building(0);
        let mut b = building(1);
        a.mesh = box_mesh(-2500.0, 0.0, 12.3, 9.7, 0.37, 20.0);
        b.mesh = box_mesh(2500.0, 10.0, 8.1, 7.9, 1.13, 9.0);
        let root = TileSpec {
            features: vec![a.clone(), b.clone()],
            ..Default::default()
        };
        let (doc, glb) = write_one_tile(&root);
        assert_eq!(doc.nodes.len(), 2);
        assert!(doc.nodes.iter().all(|n| n.scale == Some([0.02; 3])));
        let mut worst: f64 = 0.0;
        for f in [&a, &b] {
            for p in &f.mesh.positions {
                let nearest = glb
                    .positions_local
                    .iter()
                    .map(|q| (0..3).map(|k| (q[k] - p[k]).abs()).fold(0.0, f64::max))
                    .fold(f64::MAX, f64::min);
                worst = worst.max(nearest);
            }
        }
        assert!(worst <= 0.01 + 1e-9, "a vertex moved {worst} m");
        // Both nodes' primitives index the one property table: every vertex has its feature's row.
        assert_eq!(glb.features.len(), 2);
        let half = glb.positions_local.len() / 2;
        assert!(glb.feature_ids[..half].iter().all(|&f| f == 0));
        assert!(glb.feature_ids[half..].iter().all(|&f| f == 1));
    }

    #[test]
    fn a_block_may_be_rounded_coarser_than_an_exact_feature_of_its_class() {
        // A block that may move 0.3 m per axis, between two exact features of the same class.
        let exact = |x: f64| ContentFeature {
            mesh: box_mesh(x, 0.0, 10.3, 7.7, 0.0, 30.0),
            ..cluster(x, 0.0, 1)
        };
        let block = ContentFeature {
            max_rounding_m: 0.3,
            ..cluster(0.0, 40.0, 9)
        };
        let root = TileSpec {
            features: vec![exact(-100.0), block.clone(), exact(100.0)],
            ..Default::default()
        };
        let (doc, glb) = write_one_tile(&root);
        // The exact features on the 2 cm grid, the block on 0.32 m (2 cm × 2⁴, half a step ≤ 0.3 m).
        let scales: Vec<f64> = doc.nodes.iter().map(|n| n.scale.unwrap()[0]).collect();
        assert_eq!(scales, vec![0.02, 0.32]);
        assert_eq!(glb.features.len(), 3);
        for (v, p) in glb.positions_local.iter().enumerate() {
            let f = glb.feature_ids[v] as usize;
            let tol = if f == 1 { 0.16 } else { 0.01 } + 1e-9;
            let nearest = root.features[f]
                .mesh
                .positions
                .iter()
                .map(|q| (0..3).map(|k| (q[k] - p[k]).abs()).fold(0.0, f64::max))
                .fold(f64::MAX, f64::min);
            assert!(nearest <= tol, "feature {f}: a vertex moved {nearest} m");
        }
    }

    #[test]
    fn a_block_smaller_than_its_grid_keeps_its_row_and_is_counted() {
        // Blocks that may move 5 m per axis are rounded to a 10.24 m grid (2 cm × 2⁹): a block of 0.5 m there
        // collapses onto one grid point, its 10 triangles left out; the 80 m one keeps its box.
        let coarse = |f: ContentFeature| ContentFeature {
            max_rounding_m: 5.0,
            ..f
        };
        let tiny = ContentFeature {
            mesh: box_mesh(20.0, 20.0, 0.5, 0.5, 0.0, 0.5),
            ..coarse(cluster(0.0, 0.0, 2))
        };
        let root = TileSpec {
            features: vec![coarse(cluster(0.0, 0.0, 9)), tiny],
            ..Default::default()
        };
        let dir = tempfile::tempdir().unwrap();
        let stats = write(&dir.path().join("out"), &root, Compression::Meshopt).unwrap();
        assert_eq!(
            (
                stats.features,
                stats.collapsed_features,
                stats.dropped_triangles
            ),
            (2, 1, 10)
        );
        let back = read_tileset(&dir.path().join("out/tileset.json")).unwrap();
        let glb = back.tiles[0].content.as_ref().unwrap();
        assert_eq!(glb.features.len(), 2, "both rows stay");
        assert!(
            glb.feature_ids.iter().all(|&f| f == 0),
            "only the large block is drawn"
        );
    }

    #[test]
    fn round_trip_keeps_positions_ids_and_properties() {
        let root = city();
        for compression in [Compression::Meshopt, Compression::None] {
            let dir = tempfile::tempdir().unwrap();
            let stats = write(&dir.path().join("out"), &root, compression).unwrap();
            let back = read_tileset(&dir.path().join("out/tileset.json")).unwrap();
            assert_eq!(back.root_transform, frame().enu_to_ecef_column_major());
            assert!(back.geometric_error_m >= root.geometric_error_m);
            check_round_trip(&root, &back);
            assert_eq!(stats.features, 44);
            assert_eq!(stats.triangles, 43 * 10 + 4);
            assert_eq!(stats.dropped_triangles, 0);
        }
    }

    /// A tile's triangles as comparable keys: per corner the position, normal and feature id bits,
    /// rotated to start at the smallest corner (orientation kept), sorted. Vertex order free.
    fn triangle_keys(glb: &crate::read::GlbData) -> Vec<[(Vec<u64>, u32); 3]> {
        let corner = |i: u32| {
            let i = i as usize;
            // Positions to the nanometre: Draco stores SHORT positions about the chunk's centre, the other
            // encodings UNSIGNED_SHORT from its corner, so the same grid point comes back through another
            // node translation and may differ in the last bit of the f64.
            let mut bits: Vec<u64> = glb.positions_local[i]
                .iter()
                .map(|c| (c * 1e9).round() as i64 as u64)
                .collect();
            bits.extend(
                glb.normals_local
                    .get(i)
                    .into_iter()
                    .flatten()
                    .map(|c| c.to_bits()),
            );
            (bits, glb.feature_ids[i])
        };
        let mut keys: Vec<[(Vec<u64>, u32); 3]> = glb
            .triangles
            .iter()
            .map(|t| {
                let c = t.map(corner);
                let k = (0..3).min_by(|&a, &b| c[a].cmp(&c[b])).unwrap();
                std::array::from_fn(|j| c[(k + j) % 3].clone())
            })
            .collect();
        keys.sort();
        keys
    }

    #[test]
    fn draco_round_trip_equals_the_uncompressed_tiles() {
        let root = city();
        let dir = tempfile::tempdir().unwrap();
        let plain = write(&dir.path().join("plain"), &root, Compression::None).unwrap();
        let draco = write(&dir.path().join("draco"), &root, Compression::Draco).unwrap();
        assert!(
            draco.glb_bytes < plain.glb_bytes,
            "{} vs {}",
            draco.glb_bytes,
            plain.glb_bytes
        );
        assert_eq!(
            (draco.triangles, draco.features),
            (plain.triangles, plain.features)
        );
        let a = read_tileset(&dir.path().join("plain/tileset.json")).unwrap();
        let b = read_tileset(&dir.path().join("draco/tileset.json")).unwrap();
        assert_eq!(a.tiles.len(), b.tiles.len());
        let mut compared = 0;
        for (ta, tb) in a.tiles.iter().zip(&b.tiles) {
            assert_eq!(ta.bounding_box, tb.bounding_box);
            let (Some(ga), Some(gb)) = (&ta.content, &tb.content) else {
                assert_eq!(ta.content.is_some(), tb.content.is_some());
                continue;
            };
            assert_eq!(ga.features, gb.features);
            assert!(!gb.normals_local.is_empty());
            assert_eq!(
                triangle_keys(ga),
                triangle_keys(gb),
                "tile {}",
                ta.path_in_tree
            );
            compared += 1;
        }
        assert!(compared >= 5);
        let glb = std::fs::read(dir.path().join("draco/tiles/0.glb")).unwrap();
        let (json, _) = crate::glb::parse_glb(&glb).unwrap();
        let doc: crate::gltf_json::Gltf = serde_json::from_slice(json).unwrap();
        assert_eq!(
            doc.extensions_required,
            ["KHR_draco_mesh_compression", "KHR_mesh_quantization"]
        );
        for prim in &doc.meshes[0].primitives {
            let ext = prim.extensions.as_ref().unwrap();
            let d = ext.draco.as_ref().unwrap();
            assert_eq!(d.attributes.len(), prim.attributes.len());
            assert!(ext.mesh_features.is_some(), "feature ids stay an attribute");
            for &acc in prim.attributes.values().chain(&prim.indices) {
                assert_eq!(
                    doc.accessors[acc].buffer_view, None,
                    "Draco accessors have no view"
                );
            }
            let pos = &doc.accessors[prim.attributes["POSITION"]];
            assert!(pos.min.is_some() && pos.max.is_some());
        }
    }

    fn json_files(d: &Path, out: &mut Vec<(std::path::PathBuf, Vec<u8>)>) {
        let mut entries: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for e in entries {
            if e.is_dir() {
                json_files(&e, out);
            } else if e.extension().is_some_and(|x| x == "json") {
                out.push((e.clone(), std::fs::read(&e).unwrap()));
            }
        }
    }

    #[test]
    fn external_tilesets_keep_every_tile_and_stay_under_the_limit() {
        let root = city();
        let dir = tempfile::tempdir().unwrap();
        let whole = write(&dir.path().join("whole"), &root, Compression::Meshopt).unwrap();
        assert_eq!(whole.external_tilesets, 0);
        let extras =
            serde_json::json!({"citylod": {"dh_px": 20.0, "da_px": 200.0, "version": "x"}});
        let opts = WriteOptions {
            max_tileset_json_bytes: 1200,
            extras: Some(extras.clone()),
            ..Default::default()
        };
        let split_into = |name: &str| {
            let out = Staging::create(&dir.path().join(name)).unwrap();
            let stats = write_tileset(&out, &root, &frame(), &schema(), &opts).unwrap();
            out.commit().unwrap();
            stats
        };
        let stats = split_into("split");
        split_into("again");
        assert!(
            whole.tileset_json_bytes > 2 * 1200,
            "the test needs a tileset over the limit"
        );
        assert!(stats.external_tilesets >= 2, "{stats:?}");
        let (mut files, mut again) = (Vec::new(), Vec::new());
        json_files(&dir.path().join("split"), &mut files);
        json_files(&dir.path().join("again"), &mut again);
        assert_eq!(files.len() as u64, 1 + stats.external_tilesets);
        let strip =
            |v: &[(std::path::PathBuf, Vec<u8>)], d: &str| -> Vec<(std::path::PathBuf, Vec<u8>)> {
                v.iter()
                    .map(|(p, b)| {
                        (
                            p.strip_prefix(dir.path().join(d)).unwrap().to_path_buf(),
                            b.clone(),
                        )
                    })
                    .collect()
            };
        assert_eq!(
            strip(&files, "split"),
            strip(&again, "again"),
            "deterministic"
        );
        for (path, bytes) in &files {
            assert!(
                bytes.len() <= 1200,
                "{} has {} bytes",
                path.display(),
                bytes.len()
            );
            let ts: crate::tileset_json::Tileset = serde_json::from_slice(bytes).unwrap();
            assert_eq!(ts.asset.version, "1.1");
            assert_eq!(ts.root.refine.as_deref(), Some("REPLACE"));
            let main = path.ends_with("split/tileset.json");
            assert_eq!(
                ts.root.transform.is_some(),
                main,
                "only the main root has a transform"
            );
            assert_eq!(ts.extras.is_some(), main);
            if !main {
                assert_eq!(ts.geometric_error, ts.root.geometric_error);
                // A subtree's root keeps its glb (if it has one); uris stay inside the file's folder.
                assert!(ts.root.content.iter().all(|c| c.uri.ends_with(".glb")));
            }
            let text = String::from_utf8_lossy(bytes);
            assert!(!text.contains(".."), "{text}");
        }
        let a = read_tileset(&dir.path().join("whole/tileset.json")).unwrap();
        let b = read_tileset(&dir.path().join("split/tileset.json")).unwrap();
        assert_eq!(b.extras, Some(extras));
        assert_eq!(a.extras, None);
        assert_eq!(a.geometric_error_m, b.geometric_error_m);
        let links: Vec<&crate::read::TileData> = b
            .tiles
            .iter()
            .filter(|t| t.content_uri.as_ref().is_some_and(|u| u.ends_with(".json")))
            .collect();
        assert_eq!(links.len() as u64, stats.external_tilesets);
        for l in &links {
            // The referencing tile is a content-less copy of the subtree root it points to.
            let sub = &b.tiles[l.children[0]];
            assert_eq!(l.children.len(), 1);
            assert_eq!(
                (l.bounding_box, l.geometric_error_m),
                (sub.bounding_box, sub.geometric_error_m)
            );
            assert!(l.content.is_none(), "a link has no glb");
        }
        let kept: Vec<&crate::read::TileData> = b
            .tiles
            .iter()
            .filter(|t| !t.content_uri.as_ref().is_some_and(|u| u.ends_with(".json")))
            .collect();
        assert_eq!(kept.len(), a.tiles.len());
        for (x, y) in a.tiles.iter().zip(kept) {
            assert_eq!(x.geometric_error_m, y.geometric_error_m);
            assert_eq!(x.bounding_box, y.bounding_box);
            assert_eq!(
                x.content, y.content,
                "tile {} vs {}",
                x.path_in_tree, y.path_in_tree
            );
            assert_eq!(x.children.len(), y.children.len());
        }
        // A limit no single tile can meet is an error, and the previous output stays.
        let out = Staging::create(&dir.path().join("split")).unwrap();
        let tiny = WriteOptions {
            max_tileset_json_bytes: 300,
            ..Default::default()
        };
        let err = write_tileset(&out, &root, &frame(), &schema(), &tiny).unwrap_err();
        assert!(err.to_string().contains("300"), "{err}");
        drop(out);
        read_tileset(&dir.path().join("split/tileset.json")).unwrap();
    }

    #[test]
    fn extras_must_be_an_object() {
        let out = Staging::create(&tempfile::tempdir().unwrap().path().join("x")).unwrap();
        let opts = WriteOptions {
            extras: Some(serde_json::json!([1])),
            ..Default::default()
        };
        assert!(write_tileset(&out, &city(), &frame(), &schema(), &opts).is_err());
    }

    #[test]
    fn meshopt_is_smaller_and_uses_codec_version_0() {
        let root = tile_spatially((0..40).map(building).collect(), 100, 100_000);
        let dir = tempfile::tempdir().unwrap();
        let plain = write(&dir.path().join("plain"), &root, Compression::None).unwrap();
        let packed = write(&dir.path().join("packed"), &root, Compression::Meshopt).unwrap();
        assert!(
            packed.glb_bytes < plain.glb_bytes,
            "{} vs {}",
            packed.glb_bytes,
            plain.glb_bytes
        );
        let glb = std::fs::read(dir.path().join("packed/tiles/0.glb")).unwrap();
        let (json, bin) = crate::glb::parse_glb(&glb).unwrap();
        let doc: crate::gltf_json::Gltf = serde_json::from_slice(json).unwrap();
        assert!(doc
            .extensions_required
            .contains(&"EXT_meshopt_compression".to_string()));
        let mut modes = Vec::new();
        for bv in &doc.buffer_views {
            if let Some(mo) = bv.extensions.as_ref().and_then(|e| e.meshopt.as_ref()) {
                let header = bin[mo.byte_offset];
                assert_eq!(
                    header,
                    if mo.mode == "ATTRIBUTES" { 0xa0 } else { 0xe1 },
                    "{}",
                    mo.mode
                );
                assert_eq!(mo.byte_offset % 4, 0);
                modes.push(mo.mode.clone());
            }
        }
        // One interleaved vertex view (position, normal, feature id) and the indices.
        assert_eq!(modes, ["ATTRIBUTES", "TRIANGLES"]);
        let prim = &doc.meshes[0].primitives[0];
        let layout: Vec<(usize, usize, Option<usize>)> = ["POSITION", "NORMAL", "_FEATURE_ID_0"]
            .iter()
            .map(|k| {
                let a = &doc.accessors[prim.attributes[*k]];
                let bv = a.buffer_view.unwrap();
                (bv, a.byte_offset, doc.buffer_views[bv].byte_stride)
            })
            .collect();
        let v = layout[0].0;
        assert_eq!(
            layout,
            [(v, 0, Some(16)), (v, 8, Some(16)), (v, 12, Some(16))]
        );
        // Property-table views are 8-byte aligned (EXT_structural_metadata).
        assert!(doc.buffer_views.iter().all(|bv| bv.byte_offset % 8 == 0));
    }

    #[test]
    fn same_input_gives_byte_identical_files() {
        let root = city();
        let dir = tempfile::tempdir().unwrap();
        write(&dir.path().join("a"), &root, Compression::Meshopt).unwrap();
        write(&dir.path().join("b"), &root, Compression::Meshopt).unwrap();
        write(&dir.path().join("a/draco"), &root, Compression::Draco).unwrap();
        write(&dir.path().join("b/draco"), &root, Compression::Draco).unwrap();
        let (a, b) = (
            files_in(&dir.path().join("a")),
            files_in(&dir.path().join("b")),
        );
        assert!(a.len() > 5);
        assert_eq!(a, b);
    }

    /// Every file under `d` (path relative to `d`, bytes), sorted by path.
    fn files_in(d: &Path) -> Vec<(std::path::PathBuf, Vec<u8>)> {
        let mut v = Vec::new();
        let mut stack = vec![d.to_path_buf()];
        while let Some(p) = stack.pop() {
            for e in std::fs::read_dir(&p).unwrap() {
                let e = e.unwrap().path();
                if e.is_dir() {
                    stack.push(e);
                } else {
                    v.push((
                        e.strip_prefix(d).unwrap().to_path_buf(),
                        std::fs::read(&e).unwrap(),
                    ));
                }
            }
        }
        v.sort();
        v
    }

    #[test]
    fn content_made_per_tile_gives_the_same_files_and_is_made_once_per_tile() {
        // The tree with each tile's features replaced by an index into a list of them, made on demand.
        fn index<'a>(t: &'a TileSpec, held: &mut Vec<&'a [ContentFeature]>) -> TileSpec<usize> {
            held.push(&t.features);
            TileSpec {
                features: held.len() - 1,
                children: t.children.iter().map(|c| index(c, held)).collect(),
                geometric_error_m: t.geometric_error_m,
            }
        }
        let root = city();
        let mut held = Vec::new();
        let lazy = index(&root, &mut held);
        let made = std::sync::Mutex::new(vec![0usize; held.len()]);
        let dir = tempfile::tempdir().unwrap();
        for compression in [Compression::Meshopt, Compression::Draco] {
            write(&dir.path().join("held"), &root, compression).unwrap();
            let out = Staging::create(&dir.path().join("made")).unwrap();
            let opts = WriteOptions {
                compression,
                ..Default::default()
            };
            let stats = write_tileset_with(&out, &lazy, &frame(), &schema(), &opts, &|i| {
                made.lock().unwrap()[*i] += 1;
                Cow::Owned(held[*i].to_vec())
            })
            .unwrap();
            out.commit().unwrap();
            let (a, b) = (
                files_in(&dir.path().join("held")),
                files_in(&dir.path().join("made")),
            );
            assert!(a.len() > 5, "{compression:?}");
            assert_eq!(a, b, "{compression:?}");
            assert_eq!(stats.tiles, held.len());
        }
        assert!(
            made.into_inner().unwrap().iter().all(|&n| n == 2),
            "each tile's content made once per write"
        );
    }

    #[test]
    fn boxes_enclose_content_and_descendants() {
        let root = city();
        let dir = tempfile::tempdir().unwrap();
        write(&dir.path().join("out"), &root, Compression::Meshopt).unwrap();
        let back = read_tileset(&dir.path().join("out/tileset.json")).unwrap();
        let inside =
            |b: &[f64; 12], p: [f64; 3]| (0..3).all(|i| (p[i] - b[i]).abs() <= b[3 + 4 * i] + 1e-6);
        for t in &back.tiles {
            let b = t.bounding_box.unwrap();
            assert_eq!(
                [b[4], b[5], b[6], b[8], b[9], b[10]],
                [0.0; 6],
                "axis-aligned in ENU"
            );
            for &p in t.content.iter().flat_map(|c| &c.positions_local) {
                assert!(
                    inside(&b, p),
                    "tile {}: {p:?} outside {b:?}",
                    t.path_in_tree
                );
            }
            for &c in &t.children {
                let cb = back.tiles[c].bounding_box.unwrap();
                for corner in 0..8 {
                    let p: [f64; 3] = std::array::from_fn(|i| {
                        cb[i] + if corner >> i & 1 == 1 { 1.0 } else { -1.0 } * cb[3 + 4 * i]
                    });
                    assert!(
                        inside(&b, p),
                        "child {} pokes out of {}",
                        back.tiles[c].path_in_tree,
                        t.path_in_tree
                    );
                }
            }
        }
    }

    #[test]
    fn a_tile_without_content_has_its_parents_box() {
        let leaf = |i| TileSpec {
            features: vec![building(i)],
            children: vec![],
            geometric_error_m: 0.0,
        };
        let root = TileSpec {
            features: vec![building(0), building(30)],
            children: vec![TileSpec {
                features: vec![],
                children: vec![leaf(0)],
                geometric_error_m: 2.0,
            }],
            geometric_error_m: 2.0,
        };
        let dir = tempfile::tempdir().unwrap();
        write(&dir.path().join("out"), &root, Compression::Meshopt).unwrap();
        let back = read_tileset(&dir.path().join("out/tileset.json")).unwrap();
        let tile = |path: &str| back.tiles.iter().find(|t| t.path_in_tree == path).unwrap();
        let (top, empty, below) = (tile("0"), tile("0/0"), tile("0/0/0"));
        assert!(empty.content.is_none() && top.content.is_some() && below.content.is_some());
        // The parent's box, which is larger than what lies below the empty tile.
        assert_eq!(empty.bounding_box, top.bounding_box);
        assert_ne!(empty.bounding_box, below.bounding_box);
    }

    #[test]
    fn a_tile_without_content_below_its_parents_error_keeps_its_own_box() {
        // The inner tiles of a buildings-only tree: no content, errors falling towards the leaves.
        let leaf = |i| TileSpec {
            features: vec![building(i)],
            children: vec![],
            geometric_error_m: 0.0,
        };
        let inner = |children| TileSpec {
            features: vec![],
            children,
            geometric_error_m: 50.0,
        };
        let root = TileSpec {
            features: vec![],
            children: vec![inner(vec![leaf(0)]), inner(vec![leaf(30)])],
            geometric_error_m: 100.0,
        };
        let dir = tempfile::tempdir().unwrap();
        write(&dir.path().join("out"), &root, Compression::Meshopt).unwrap();
        let back = read_tileset(&dir.path().join("out/tileset.json")).unwrap();
        let tile = |path: &str| back.tiles.iter().find(|t| t.path_in_tree == path).unwrap();
        for (inner, below) in [("0/0", "0/0/0"), ("0/1", "0/1/0")] {
            assert!(tile(inner).content.is_none());
            assert_eq!(tile(inner).bounding_box, tile(below).bounding_box);
            assert_ne!(tile(inner).bounding_box, tile("0").bounding_box);
        }
    }

    #[test]
    fn tileset_json_has_transform_replace_and_tree_uris() {
        let root = city();
        let dir = tempfile::tempdir().unwrap();
        let stats = write(&dir.path().join("out"), &root, Compression::Meshopt).unwrap();
        let text = std::fs::read_to_string(dir.path().join("out/tileset.json")).unwrap();
        assert_eq!(text.len() as u64, stats.tileset_json_bytes);
        let ts: crate::tileset_json::Tileset = serde_json::from_str(&text).unwrap();
        assert_eq!(ts.asset.version, "1.1");
        assert!(ts
            .asset
            .generator
            .as_deref()
            .unwrap()
            .starts_with("citylod "));
        assert_eq!(ts.root.refine.as_deref(), Some("REPLACE"));
        assert_eq!(ts.root.content.as_ref().unwrap().uri, "tiles/0.glb");
        assert_eq!(ts.root.children[1].children[0].children.len(), 2);
        let back = read_tileset(&dir.path().join("out/tileset.json")).unwrap();
        for t in &back.tiles {
            if let Some(uri) = &t.content_uri {
                assert_eq!(uri, &format!("tiles/{}.glb", t.path_in_tree));
                assert!(dir.path().join("out").join(uri).is_file());
            }
            for &c in &t.children {
                assert!(back.tiles[c].geometric_error_m <= t.geometric_error_m);
            }
        }
        assert_eq!(stats.tiles, back.tiles.len());
    }

    #[test]
    fn failed_write_leaves_the_previous_tileset_whole() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("out");
        write(&dest, &city(), Compression::Meshopt).unwrap();
        let before = std::fs::read(dest.join("tileset.json")).unwrap();
        let mut bad = city();
        bad.children[1].features.push(ContentFeature {
            mesh: box_mesh(0.0, 0.0, 1.0, 1.0, 0.0, 1.0),
            class: 7,
            values: vec![],
            max_rounding_m: 0.0,
        });
        let err = write(&dest, &bad, Compression::Meshopt).unwrap_err();
        assert!(err.to_string().contains("class 7"), "{err}");
        let mut nan = city();
        nan.features[0].mesh.positions[0][2] = f64::NAN;
        assert!(write(&dest, &nan, Compression::None).is_err());
        assert_eq!(std::fs::read(dest.join("tileset.json")).unwrap(), before);
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no staging directory left"
        );
        read_tileset(&dest.join("tileset.json")).unwrap();
    }

    /// Runs the Khronos glTF-Validator (npm `gltf-validator`, installed by `npm ci` at the repo root)
    /// on every glb of the synthetic city, both compressions. Skips when node or the package is absent.
    #[test]
    fn glbs_pass_the_khronos_validator() {
        let validator = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../node_modules/gltf-validator"
        );
        if !Path::new(validator).is_dir() {
            eprintln!("skipped: {validator} not found (run `npm ci` at the repository root)");
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let mut glbs = Vec::new();
        for (name, c) in [
            ("meshopt", Compression::Meshopt),
            ("plain", Compression::None),
            ("draco", Compression::Draco),
        ] {
            let out = dir.path().join(name);
            write(&out, &city(), c).unwrap();
            let back = read_tileset(&out.join("tileset.json")).unwrap();
            glbs.extend(
                back.tiles
                    .iter()
                    .filter_map(|t| t.content_uri.as_ref().map(|u| out.join(u))),
            );
        }
        const SCRIPT: &str = r#"
            const v = require(process.argv[1]);
            const fs = require('fs');
            (async () => {
              let errors = 0;
              for (const f of process.argv.slice(2)) {
                const r = await v.validateBytes(new Uint8Array(fs.readFileSync(f)), { uri: f });
                errors += r.issues.numErrors;
                for (const m of r.issues.messages.filter(m => m.severity <= 1))
                  console.log(`${f}: ${m.severity === 0 ? 'error' : 'warning'} ${m.code} ${m.pointer || ''} ${m.message}`);
              }
              console.log(`errors: ${errors}`);
            })();
        "#;
        let out = match std::process::Command::new("node")
            .arg("-e")
            .arg(SCRIPT)
            .arg(validator)
            .args(&glbs)
            .output()
        {
            Ok(o) => o,
            Err(e) => {
                eprintln!("skipped: cannot run node: {e}");
                return;
            }
        };
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{text}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(text.contains("errors: 0"), "{text}");
        assert!(!text.contains("warning"), "{text}");
        assert!(glbs.len() >= 10);
    }

    /// Decodes every EXT_meshopt_compression stream with the JavaScript decoder browsers use (npm
    /// `meshoptimizer`) and compares it byte for byte with the same tile written uncompressed.
    /// Skips when node or the package is absent.
    #[test]
    fn meshopt_streams_decode_identically_in_the_js_decoder() {
        let decoder = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../node_modules/meshoptimizer/index.js"
        );
        if !Path::new(decoder).is_file() {
            eprintln!("skipped: {decoder} not found (run `npm ci` at the repository root)");
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let root = city();
        write(&dir.path().join("meshopt"), &root, Compression::Meshopt).unwrap();
        write(&dir.path().join("plain"), &root, Compression::None).unwrap();
        const SCRIPT: &str = r#"
            const [decoderPath, dir] = process.argv.slice(1);
            const fs = require('fs'), path = require('path');
            const parse = f => {
              const b = fs.readFileSync(f), jl = b.readUInt32LE(12);
              return { json: JSON.parse(b.subarray(20, 20 + jl).toString()), bin: b.subarray(28 + jl) };
            };
            const walk = d => fs.readdirSync(d, { withFileTypes: true }).flatMap(e =>
              e.isDirectory() ? walk(path.join(d, e.name)) : [path.join(d, e.name)]);
            import(decoderPath).then(async ({ MeshoptDecoder }) => {
              await MeshoptDecoder.ready;
              let views = 0, mismatches = 0;
              for (const f of walk(path.join(dir, 'meshopt', 'tiles'))) {
                const m = parse(f), p = parse(f.replace(path.join(dir, 'meshopt'), path.join(dir, 'plain')));
                m.json.bufferViews.forEach((bv, i) => {
                  const e = bv.extensions && bv.extensions.EXT_meshopt_compression;
                  if (!e) return;
                  const out = new Uint8Array(e.count * e.byteStride);
                  MeshoptDecoder.decodeGltfBuffer(out, e.count, e.byteStride,
                    m.bin.subarray(e.byteOffset, e.byteOffset + e.byteLength), e.mode, e.filter || 'NONE');
                  const pv = p.json.bufferViews[i];
                  views++;
                  if (Buffer.compare(Buffer.from(out), p.bin.subarray(pv.byteOffset, pv.byteOffset + pv.byteLength)) !== 0) {
                    mismatches++;
                    console.log(`mismatch ${f} bufferView ${i}`);
                  }
                });
              }
              console.log(`views: ${views} mismatches: ${mismatches}`);
            });
        "#;
        let out = match std::process::Command::new("node")
            .arg("-e")
            .arg(SCRIPT)
            .arg(decoder)
            .arg(dir.path())
            .output()
        {
            Ok(o) => o,
            Err(e) => {
                eprintln!("skipped: cannot run node: {e}");
                return;
            }
        };
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{text}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(text.contains(" mismatches: 0"), "{text}");
        assert!(!text.contains("views: 0 "), "{text}");
    }

    #[test]
    fn tiles_over_65535_vertices_use_32_bit_indices() {
        // 3,300 buildings 20 m apart within 1.2 km, so one node on the 2 cm grid holds them all.
        let root = TileSpec {
            features: (0..3300)
                .map(|i| ContentFeature {
                    mesh: box_mesh(
                        (i % 60) as f64 * 20.0 - 600.0,
                        (i / 60) as f64 * 20.0 - 550.0,
                        12.0,
                        9.5,
                        0.0,
                        10.0,
                    ),
                    ..building(i)
                })
                .collect(),
            ..Default::default()
        };
        for compression in [Compression::Meshopt, Compression::None, Compression::Draco] {
            let dir = tempfile::tempdir().unwrap();
            write(&dir.path().join("out"), &root, compression).unwrap();
            let glb = std::fs::read(dir.path().join("out/tiles/0.glb")).unwrap();
            let (json, _) = crate::glb::parse_glb(&glb).unwrap();
            let doc: crate::gltf_json::Gltf = serde_json::from_slice(json).unwrap();
            assert_eq!(
                doc.accessors[2].component_type,
                crate::gltf_json::UNSIGNED_INT
            );
            assert_eq!(doc.accessors[0].count, 3300 * 20);
            let back = read_tileset(&dir.path().join("out/tileset.json")).unwrap();
            if compression == Compression::Draco {
                // Vertex order differs; draco_round_trip_equals_the_uncompressed_tiles checks values.
                assert_eq!(
                    back.tiles[0].content.as_ref().unwrap().triangles.len(),
                    3300 * 10
                );
                write(&dir.path().join("again"), &root, compression).unwrap();
                let again = std::fs::read(dir.path().join("again/tiles/0.glb")).unwrap();
                assert!(
                    glb == again,
                    "a large Draco tile is byte-identical on a second write"
                );
            } else {
                check_round_trip(&root, &back);
            }
        }
    }

    #[test]
    fn reader_follows_external_tilesets_and_their_transforms() {
        let dir = tempfile::tempdir().unwrap();
        write(&dir.path().join("inner"), &city(), Compression::Meshopt).unwrap();
        let o = frame().origin_ecef();
        let outer = crate::tileset_json::Tileset {
            asset: crate::tileset_json::Asset {
                version: "1.1".into(),
                generator: None,
                gltf_up_axis: None,
            },
            geometric_error: 1e5,
            extras: None,
            root: crate::tileset_json::Tile {
                transform: None,
                bounding_volume: crate::tileset_json::BoundingVolume {
                    r#box: Some([
                        o[0], o[1], o[2], 1e4, 0.0, 0.0, 0.0, 1e4, 0.0, 0.0, 0.0, 1e4,
                    ]),
                    region: None,
                    sphere: None,
                },
                geometric_error: 1e5,
                refine: Some("REPLACE".into()),
                content: Some(crate::tileset_json::Content {
                    uri: "inner/tileset.json".into(),
                }),
                contents: vec![],
                children: vec![],
                implicit_tiling: None,
                extensions: None,
            },
        };
        std::fs::write(
            dir.path().join("tileset.json"),
            serde_json::to_vec(&outer).unwrap(),
        )
        .unwrap();
        let inner = read_tileset(&dir.path().join("inner/tileset.json")).unwrap();
        let both = read_tileset(&dir.path().join("tileset.json")).unwrap();
        assert_eq!(both.tiles.len(), inner.tiles.len() + 1);
        assert_eq!(both.tiles[0].children, vec![1]);
        for (a, b) in inner.tiles.iter().zip(&both.tiles[1..]) {
            assert_eq!(b.path_in_tree, a.path_in_tree.replacen('0', "0/ext", 1));
            assert_eq!(a.content.is_some(), b.content.is_some());
            let (Some(ca), Some(cb)) = (&a.content, &b.content) else {
                continue;
            };
            assert_eq!(ca.features, cb.features);
            assert_eq!(ca.triangles, cb.triangles);
            for (p, q) in ca.positions_local.iter().zip(&cb.positions_local) {
                let want = frame().enu_to_ecef(*p);
                assert!(
                    (0..3).all(|i| (want[i] - q[i]).abs() < 1e-6),
                    "{want:?} vs {q:?}"
                );
            }
        }
    }

    #[test]
    fn omit_normals_writes_no_normal_attribute() {
        let root = tile_spatially((0..10).map(building).collect(), 100, 100_000);
        let dir = tempfile::tempdir().unwrap();
        let out = Staging::create(&dir.path().join("out")).unwrap();
        let opts = WriteOptions {
            omit_normals: true,
            ..Default::default()
        };
        let lean = write_tileset(&out, &root, &frame(), &schema(), &opts).unwrap();
        out.commit().unwrap();
        let back = read_tileset(&dir.path().join("out/tileset.json")).unwrap();
        let glb = back.tiles[0].content.as_ref().unwrap();
        assert!(glb.normals_local.is_empty() && !glb.positions_local.is_empty());
        let full = write(&dir.path().join("full"), &root, Compression::Meshopt).unwrap();
        assert!(lean.glb_bytes < full.glb_bytes);
    }

    #[test]
    fn features_without_triangles_give_no_content() {
        let mut lone = building(0);
        lone.mesh.triangles.clear();
        let mut flat = building(1);
        flat.mesh
            .positions
            .iter_mut()
            .for_each(|p| *p = [1.0, 2.0, 3.0]); // all corners coincide
        let root = TileSpec {
            features: vec![lone, flat],
            children: vec![TileSpec {
                features: vec![building(2)],
                ..Default::default()
            }],
            geometric_error_m: 5.0,
        };
        let dir = tempfile::tempdir().unwrap();
        let stats = write(&dir.path().join("out"), &root, Compression::Meshopt).unwrap();
        assert_eq!(
            (stats.tiles, stats.content_tiles, stats.features),
            (2, 1, 1)
        );
        let back = read_tileset(&dir.path().join("out/tileset.json")).unwrap();
        assert!(back.tiles[0].content.is_none() && back.tiles[1].content.is_some());
    }
}
