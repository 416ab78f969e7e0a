//! One tile's glb: features grouped into glTF nodes by the grid their positions are rounded to (and into
//! spatial chunks whose coordinates fit 16 bits on it), within a node every feature of a class merged into
//! one TRIANGLES primitive (so each primitive has one feature-id set; one property table per class for the
//! whole glb), positions (east, up, −north) quantized to UNSIGNED_SHORT (SHORT with Draco) with one uniform
//! scale, the grid step, and a translation on the grid (KHR_mesh_quantization), BYTE-normalized normals,
//! feature ids as a FLOAT `_FEATURE_ID_0` (EXT_mesh_features) — the three interleaved in one vertex buffer
//! view unless Draco compresses them —, triangles in vertex-cache order and vertices in the order they are first used, property tables
//! (EXT_structural_metadata), optionally EXT_meshopt_compression.

use crate::draco::{self, DracoEncoded, DracoValues};
use crate::glb::{write_glb, BinBuilder};
use crate::gltf_json::*;
use crate::metadata::{encode_column, schema_json};
use crate::shading::split_by_face;
use crate::spec::{ContentFeature, MetadataSchema};
use crate::{Compression, TilesError};
use std::borrow::Cow;
use std::collections::BTreeMap;

/// Largest quantized coordinate magnitude.
const Q_MAX: f64 = 32767.0;

/// Most features of one primitive whose ids fit an UNSIGNED_SHORT attribute (Draco content; above
/// it the ids are FLOAT, exact up to 2^24).
const FEATURE_IDS_U16: usize = 1 << 16;

/// How [`encode_content`] encodes a tile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ContentOptions {
    pub compression: Compression,
    pub normals: bool,
    /// Finest grid positions are rounded to (m); see [`crate::WriteOptions::quantization_step_m`].
    pub quantization_step_m: f64,
}

/// Splits `members` (feature indices, ascending) into spatial chunks whose bounds are at most `max_half` (m) from
/// their centre on every axis: recursive median cuts across the longest axis of the feature centres, ties by
/// index. A single feature always fits (its grid was chosen so). Members keep their order within a chunk.
fn chunk_to_fit(
    members: Vec<usize>,
    feature_bounds: &[Option<([f64; 3], [f64; 3])>],
    max_half: f64,
    out: &mut Vec<Vec<usize>>,
) {
    let fb = |i: usize| feature_bounds[i].expect("features with vertices");
    let (lo, hi) = members
        .iter()
        .fold(([f64::MAX; 3], [f64::MIN; 3]), |(lo, hi), &i| {
            let (a, b) = fb(i);
            (
                std::array::from_fn(|k| lo[k].min(a[k])),
                std::array::from_fn(|k| hi[k].max(b[k])),
            )
        });
    let half = (0..3).map(|k| (hi[k] - lo[k]) / 2.0).fold(0.0, f64::max);
    if members.len() <= 1 || half <= max_half {
        out.push(members);
        return;
    }
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .expect("three axes");
    let centre = |i: usize| {
        let (a, b) = fb(i);
        (a[axis] + b[axis]) / 2.0
    };
    let mut sorted = members;
    sorted.sort_by(|&a, &b| centre(a).total_cmp(&centre(b)).then(a.cmp(&b)));
    let right = sorted.split_off(sorted.len() / 2);
    for mut part in [sorted, right] {
        part.sort_unstable();
        chunk_to_fit(part, feature_bounds, max_half, out);
    }
}

/// The coarsest grid (m) a feature that may move `max_rounding_m` per axis can be rounded to: the largest
/// power-of-two multiple of the finest grid `base` with half a step ≤ `max_rounding_m` (so every such grid's
/// points are on the finer ones: blocks in neighbouring tiles round alike), `base` when that is none.
fn tolerated_grid(max_rounding_m: f64, base: f64) -> f64 {
    let mut step = base;
    if max_rounding_m.is_finite() {
        while step * 2.0 <= 2.0 * max_rounding_m && step < 1e9 {
            step *= 2.0;
        }
    }
    step
}

/// A tile's encoded glb and what is in it.
pub(crate) struct EncodedContent {
    pub glb: Vec<u8>,
    pub triangles: u64,
    pub vertices: u64,
    /// Triangles whose corners fell on one line (or point) after quantization, left out.
    pub dropped_triangles: u64,
    /// Features with triangles of which none is left (smaller than the tile's grid); their rows stay.
    pub collapsed_features: u64,
    /// Bounds (min, max) of the dequantized positions in local ENU metres: what clients draw.
    pub bounds_enu: ([f64; 3], [f64; 3]),
}

/// Whether a triangle's corners, rounded to the grid, lie on one line (two of them on one point, or the third on
/// the line through the others): it has no area to draw. Exact, in integers.
fn flat_on_the_grid(c: [&[i16]; 3]) -> bool {
    let d =
        |a: &[i16], b: &[i16]| -> [i64; 3] { std::array::from_fn(|i| b[i] as i64 - a[i] as i64) };
    let (u, v) = (d(c[0], c[1]), d(c[0], c[2]));
    u[1] * v[2] == u[2] * v[1] && u[2] * v[0] == u[0] * v[2] && u[0] * v[1] == u[1] * v[0]
}

/// ENU (x east, y north, z up) → glTF y-up (east, up, −north).
pub(crate) fn enu_to_yup(p: [f64; 3]) -> [f64; 3] {
    [p[0], p[2], -p[1]]
}

/// Axis-aligned bounds (min corner, max corner).
pub type Bounds = ([f64; 3], [f64; 3]);

/// Axis-aligned bounds (min, max) of points, `None` when there are none.
pub fn bounds(points: impl Iterator<Item = [f64; 3]>) -> Option<Bounds> {
    points.fold(None, |acc, p| {
        let (lo, hi) = acc.unwrap_or((p, p));
        Some((
            std::array::from_fn(|i| lo[i].min(p[i])),
            std::array::from_fn(|i| hi[i].max(p[i])),
        ))
    })
}

/// Checks a feature against the schema and its own indices; the message says what is wrong.
fn check_feature(f: &ContentFeature, schema: &MetadataSchema) -> Result<(), String> {
    let class = schema
        .classes
        .get(f.class)
        .ok_or_else(|| format!("class {} not in the schema", f.class))?;
    if f.values.len() != class.properties.len() {
        return Err(format!(
            "{} values for the {} properties of class {}",
            f.values.len(),
            class.properties.len(),
            class.id
        ));
    }
    if f.mesh.positions.iter().flatten().any(|c| !c.is_finite()) {
        return Err("non-finite vertex position".into());
    }
    let n = f.mesh.positions.len();
    if f.mesh.triangles.iter().flatten().any(|&i| i as usize >= n) {
        return Err(format!("triangle index out of range ({n} vertices)"));
    }
    Ok(())
}

/// Encodes the features of one tile (`tile` names it in errors). `Ok(None)` when the features have
/// no triangles at all (no content to write); a class without triangles gets no primitive.
pub(crate) fn encode_content(
    tile: &str,
    features: &[ContentFeature],
    schema: &MetadataSchema,
    opts: &ContentOptions,
    generator: &str,
) -> Result<Option<EncodedContent>, TilesError> {
    let (compression, normals) = (opts.compression, opts.normals);
    for (i, f) in features.iter().enumerate() {
        check_feature(f, schema).map_err(|msg| TilesError::Feature {
            tile: tile.to_string(),
            feature: i,
            msg,
        })?;
    }
    // Each feature's bounds (glTF y-up); features without vertices draw nothing.
    let feature_bounds: Vec<Option<([f64; 3], [f64; 3])>> = features
        .iter()
        .map(|f| bounds(f.mesh.positions.iter().map(|&p| enu_to_yup(p))))
        .collect();
    if feature_bounds.iter().all(Option::is_none) {
        return Ok(None);
    }
    // A feature's grid: the finest one (`quantization_step_m`), coarser as far as its rounding tolerance allows,
    // and never so fine that the feature alone would not fit 16 bits (one step of margin for the rounded
    // translation).
    let grid_of = |i: usize| -> f64 {
        let tolerated = tolerated_grid(features[i].max_rounding_m, opts.quantization_step_m);
        let half = feature_bounds[i].map_or(0.0, |(lo, hi)| {
            (0..3).map(|k| (hi[k] - lo[k]) / 2.0).fold(0.0, f64::max)
        });
        tolerated.max(half / (Q_MAX - 1.0))
    };

    // Features grouped by class, classes in schema order, features in input order; a feature's row in its
    // class's property table is its place in that order.
    let mut by_class: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    let mut row = vec![0usize; features.len()];
    for (i, f) in features.iter().enumerate() {
        let members = by_class.entry(f.class).or_default();
        row[i] = members.len();
        members.push(i);
    }
    // One node per grid (finest first) and per spatial chunk of features whose coordinates fit 16 bits on it,
    // each with one primitive per class.
    let mut by_grid: BTreeMap<u64, Vec<usize>> = BTreeMap::new();
    for i in (0..features.len()).filter(|&i| feature_bounds[i].is_some()) {
        // Positive floats order like their bits: finest grid first.
        by_grid.entry(grid_of(i).to_bits()).or_default().push(i);
    }
    let mut chunks: Vec<(f64, BTreeMap<usize, Vec<usize>>)> = Vec::new();
    for (bits, members) in by_grid {
        let step = f64::from_bits(bits);
        let mut parts = Vec::new();
        chunk_to_fit(members, &feature_bounds, (Q_MAX - 1.0) * step, &mut parts);
        for part in parts {
            let mut classes: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
            for fi in part {
                classes.entry(features[fi].class).or_default().push(fi);
            }
            chunks.push((step, classes));
        }
    }

    let meshopt = compression == Compression::Meshopt;
    let mut doc = Gltf {
        asset: Asset {
            version: "2.0".into(),
            generator: Some(generator.into()),
        },
        scene: Some(0),
        scenes: vec![Scene { nodes: vec![] }],
        materials: vec![Material {
            pbr_metallic_roughness: Pbr {
                base_color_factor: [0.8, 0.8, 0.8, 1.0],
                metallic_factor: 0.0,
                roughness_factor: 1.0,
            },
            double_sided: false,
        }],
        ..Default::default()
    };
    let mut bin = BinBuilder::default();
    let mut fallback = BinBuilder::default();
    // (class, primitive) per node; the property table indices are filled in once the tables are known.
    let mut nodes: Vec<(Node, Vec<(usize, Primitive)>)> = Vec::new();
    let (mut triangles, mut vertices, mut dropped, mut collapsed) = (0u64, 0u64, 0u64, 0u64);
    let mut drawn_bounds: Option<([f64; 3], [f64; 3])> = None;

    for (step, classes) in &chunks {
        let step = *step;
        let corners = classes
            .values()
            .flatten()
            .filter_map(|&fi| feature_bounds[fi])
            .flat_map(|(a, b)| [a, b]);
        let (glo, ghi) = bounds(corners).expect("features with vertices");
        // On the grid itself, so features on the same grid in neighbouring tiles round alike (no cracks).
        let centre_steps: [f64; 3] =
            std::array::from_fn(|i| ((glo[i] + ghi[i]) / 2.0 / step).round());
        let translation: [f64; 3] = std::array::from_fn(|i| centre_steps[i] * step);
        // One scale for all axes: normals then need no correction for the node's scale (a non-uniform
        // scale would bend them through the inverse transpose).
        let scale = [step; 3];
        let quantize_yup = |g: [f64; 3]| -> [i16; 3] {
            std::array::from_fn(|i| {
                ((g[i] - translation[i]) / scale[i])
                    .round()
                    .clamp(-Q_MAX, Q_MAX) as i16
            })
        };
        let quantize = |p: [f64; 3]| quantize_yup(enu_to_yup(p));
        // Without Draco, positions are stored UNSIGNED_SHORT from the chunk's lowest grid point (the node's
        // translation moves there): the codec's byte lanes then see no sign flips of the high bytes where
        // coordinates cross the centre (roofs and ground of a coarse tile, −8 … 9 steps). Rounding is monotone,
        // so no vertex quantizes below the chunk's lower corner. Boston: 1.3 % fewer bytes.
        let origin: [i16; 3] = if compression == Compression::Draco {
            [0; 3]
        } else {
            quantize_yup(glo)
        };
        let stored = |q: i16, i: usize| (q as i32 - origin[i] as i32) as u16;
        let mut primitives = Vec::new();
        let (mut quantized_lo, mut quantized_hi) = ([i16::MAX; 3], [i16::MIN; 3]);
        for (&class, members) in classes {
            let mut pos: Vec<[i16; 4]> = Vec::new();
            let mut fid: Vec<f32> = Vec::new();
            let mut nor: Vec<[f64; 3]> = Vec::new();
            let mut idx: Vec<u32> = Vec::new();
            for &fi in members.iter() {
                let k = row[fi];
                // Vertex normals are written: corners shared by several planes are split so they are face normals.
                let m = if normals {
                    split_by_face(&features[fi].mesh)
                } else {
                    Cow::Borrowed(&features[fi].mesh)
                };
                let m = m.as_ref();
                let v0 = pos.len() as u32;
                for &p in &m.positions {
                    let q = quantize(p);
                    pos.push([q[0], q[1], q[2], 0]);
                    fid.push(k as f32);
                }
                if normals {
                    nor.extend(vertex_normals_yup(m));
                }
                let kept_before = idx.len();
                for t in &m.triangles {
                    let c = t.map(|i| &pos[(v0 + i) as usize][..3]);
                    if flat_on_the_grid(c) {
                        dropped += 1;
                        continue;
                    }
                    idx.extend(t.map(|i| v0 + i));
                }
                if idx.len() == kept_before && !m.triangles.is_empty() {
                    collapsed += 1;
                }
            }
            if idx.is_empty() {
                continue; // features without triangles: nothing to draw or pick
            }
            let (pos, fid, nor, idx) = reorder_for_fetch(pos, fid, nor, idx);
            let class_rows = by_class[&class].len();
            if pos.len() > u32::MAX as usize || class_rows > 1 << 24 {
                return Err(TilesError::Tile {
                    tile: tile.into(),
                    msg: "too many vertices or features for one glb".into(),
                });
            }
            // The ids index the class's one property table (CesiumJS picks through a single table per glb),
            // so every primitive of the class counts all its rows: ids stay below featureCount.
            let feature_count = class_rows;
            triangles += idx.len() as u64 / 3;
            for p in &pos {
                for i in 0..3 {
                    quantized_lo[i] = quantized_lo[i].min(p[i]);
                    quantized_hi[i] = quantized_hi[i].max(p[i]);
                }
            }
            vertices += pos.len() as u64;
            let n = pos.len();
            let lo_q: Vec<f64> = (0..3)
                .map(|i| pos.iter().map(|p| p[i]).min().unwrap() as f64)
                .collect();
            let hi_q: Vec<f64> = (0..3)
                .map(|i| pos.iter().map(|p| p[i]).max().unwrap() as f64)
                .collect();
            let acc = doc.accessors.len();
            let mut draco_ext = None;
            let with_normals;
            if compression == Compression::Draco {
                with_normals = normals;
                let enc = encode_draco(&pos, &nor, &fid, &idx, class_rows).map_err(|msg| {
                    TilesError::Tile {
                        tile: tile.into(),
                        msg,
                    }
                })?;
                doc.buffer_views.push(BufferView {
                    buffer: 0,
                    byte_offset: bin.push(&enc.bytes),
                    byte_length: enc.bytes.len(),
                    ..Default::default()
                });
                let m = enc.decoded_vertices;
                let unbuffered = |component_type, count, ty: &str| Accessor {
                    component_type,
                    count,
                    r#type: ty.into(),
                    ..Default::default()
                };
                doc.accessors.push(Accessor {
                    min: Some(enc.first_min.clone()),
                    max: Some(enc.first_max.clone()),
                    ..unbuffered(SHORT, m, "VEC3")
                });
                let fid_type = if class_rows <= FEATURE_IDS_U16 {
                    UNSIGNED_SHORT
                } else {
                    FLOAT
                };
                doc.accessors.push(unbuffered(fid_type, m, "SCALAR"));
                let idx_type = if m > u16::MAX as usize {
                    UNSIGNED_INT
                } else {
                    UNSIGNED_SHORT
                };
                doc.accessors
                    .push(unbuffered(idx_type, enc.decoded_indices, "SCALAR"));
                if normals {
                    doc.accessors.push(Accessor {
                        normalized: true,
                        ..unbuffered(BYTE, m, "VEC3")
                    });
                }
                let names = ["POSITION", "_FEATURE_ID_0", "NORMAL"];
                draco_ext = Some(DracoPrimitive {
                    buffer_view: doc.buffer_views.len() - 1,
                    attributes: names.iter().map(|s| s.to_string()).zip(enc.ids).collect(),
                });
            } else {
                let wide = n > u16::MAX as usize;
                let idx_bytes: Vec<u8> = if wide {
                    idx.iter().flat_map(|i| i.to_le_bytes()).collect()
                } else {
                    idx.iter().flat_map(|&i| (i as u16).to_le_bytes()).collect()
                };
                let idx_stride = if wide { 4 } else { 2 };
                // One interleaved vertex view — position (UNSIGNED_SHORT ×3 + pad), normal (BYTE ×3 + pad),
                // feature id (FLOAT) — instead of one per attribute: the same meshopt bytes (the codec works byte lane by
                // byte lane), two views less of JSON per primitive (~420 bytes; on Boston 190 kB over the
                // tileset's 450 primitives).
                let stride = if normals { 16 } else { 12 };
                let mut vertex_bytes = Vec::with_capacity(n * stride);
                for (v, p) in pos.iter().enumerate() {
                    for (i, &c) in p[..3].iter().enumerate() {
                        vertex_bytes.extend(stored(c, i).to_le_bytes());
                    }
                    vertex_bytes.extend([0, 0]);
                    if normals {
                        let q = nor[v].map(|c| ((c * 127.0).round() as i8) as u8);
                        vertex_bytes.extend([q[0], q[1], q[2], 0]);
                    }
                    vertex_bytes.extend(fid[v].to_le_bytes());
                }

                let mut view =
                    |raw: Vec<u8>, stride: usize, count: usize, target: u32, mode: &str| {
                        let byte_stride = (target == ARRAY_BUFFER).then_some(stride);
                        let bv =
                            if meshopt {
                                let encoded = encode_meshopt(&raw, stride, count, mode, n)
                                    .map_err(|e| TilesError::Tile {
                                        tile: tile.into(),
                                        msg: format!("meshopt encoding failed: {e:?}"),
                                    })?;
                                BufferView {
                                    buffer: 1,
                                    byte_offset: fallback.reserve(raw.len()),
                                    byte_length: raw.len(),
                                    byte_stride,
                                    target: Some(target),
                                    extensions: Some(BufferViewExtensions {
                                        meshopt: Some(MeshoptView {
                                            buffer: 0,
                                            byte_offset: bin.push(&encoded),
                                            byte_length: encoded.len(),
                                            byte_stride: stride,
                                            count,
                                            mode: mode.into(),
                                            filter: None,
                                        }),
                                    }),
                                }
                            } else {
                                BufferView {
                                    buffer: 0,
                                    byte_offset: bin.push(&raw),
                                    byte_length: raw.len(),
                                    byte_stride,
                                    target: Some(target),
                                    extensions: None,
                                }
                            };
                        doc.buffer_views.push(bv);
                        Ok::<usize, TilesError>(doc.buffer_views.len() - 1)
                    };
                let vertex_view = view(vertex_bytes, stride, n, ARRAY_BUFFER, "ATTRIBUTES")?;
                let idx_view = view(
                    idx_bytes,
                    idx_stride,
                    idx.len(),
                    ELEMENT_ARRAY_BUFFER,
                    "TRIANGLES",
                )?;

                let unsigned = |q: Vec<f64>| (0..3).map(|i| q[i] - origin[i] as f64).collect();
                doc.accessors.push(Accessor {
                    buffer_view: Some(vertex_view),
                    component_type: UNSIGNED_SHORT,
                    count: n,
                    r#type: "VEC3".into(),
                    min: Some(unsigned(lo_q)),
                    max: Some(unsigned(hi_q)),
                    ..Default::default()
                });
                doc.accessors.push(Accessor {
                    buffer_view: Some(vertex_view),
                    byte_offset: stride - 4,
                    component_type: FLOAT,
                    count: n,
                    r#type: "SCALAR".into(),
                    ..Default::default()
                });
                doc.accessors.push(Accessor {
                    buffer_view: Some(idx_view),
                    component_type: if wide { UNSIGNED_INT } else { UNSIGNED_SHORT },
                    count: idx.len(),
                    r#type: "SCALAR".into(),
                    ..Default::default()
                });
                if normals {
                    doc.accessors.push(Accessor {
                        buffer_view: Some(vertex_view),
                        byte_offset: 8,
                        component_type: BYTE,
                        normalized: true,
                        count: n,
                        r#type: "VEC3".into(),
                        ..Default::default()
                    });
                }
                with_normals = normals;
            }

            primitives.push((
                class,
                Primitive {
                    attributes: with_normals
                        .then(|| ("NORMAL".to_string(), acc + 3))
                        .into_iter()
                        .chain([("POSITION".into(), acc), ("_FEATURE_ID_0".into(), acc + 1)])
                        .collect(),
                    indices: Some(acc + 2),
                    material: Some(0),
                    mode: Some(MODE_TRIANGLES),
                    extensions: Some(PrimitiveExtensions {
                        mesh_features: Some(MeshFeatures {
                            feature_ids: vec![FeatureId {
                                feature_count,
                                attribute: Some(0),
                                property_table: None, // set below
                                null_feature_id: None,
                                ..Default::default()
                            }],
                        }),
                        draco: draco_ext,
                    }),
                },
            ));
        }
        if primitives.is_empty() {
            continue;
        }
        // Dequantized bounds: the quantized extremes mapped back through the node transform, y-up → ENU.
        let corner = |q: [i16; 3]| -> [f64; 3] {
            let g: [f64; 3] = std::array::from_fn(|i| translation[i] + scale[i] * q[i] as f64);
            [g[0], -g[2], g[1]]
        };
        let (a, b) = (corner(quantized_lo), corner(quantized_hi));
        let prev = drawn_bounds.map(|(l, h)| [l, h]).unwrap_or([a, b]);
        drawn_bounds = bounds([a, b, prev[0], prev[1]].into_iter());
        nodes.push((
            Node {
                mesh: Some(nodes.len()),
                // The stored positions count from `origin`, on the same grid.
                translation: Some(std::array::from_fn(|i| {
                    (centre_steps[i] + origin[i] as f64) * step
                })),
                scale: Some(scale),
                ..Default::default()
            },
            primitives,
        ));
    }
    let Some(bounds_enu) = drawn_bounds else {
        return Ok(None);
    };

    // One property table per class drawn, rows in the class's feature order.
    let mut table_of: BTreeMap<usize, usize> = BTreeMap::new();
    let mut tables = Vec::new();
    for (&class, members) in &by_class {
        let drawn = nodes
            .iter()
            .any(|(_, prims)| prims.iter().any(|(c, _)| *c == class));
        if !drawn {
            continue;
        }
        let class_def = &schema.classes[class];
        let mut properties = BTreeMap::new();
        for (pi, p) in class_def.properties.iter().enumerate() {
            let col = encode_column(p, members.iter().map(|&fi| &features[fi].values[pi]))
                .map_err(|(k, msg)| TilesError::Feature {
                    tile: tile.into(),
                    feature: members[k.min(members.len() - 1)],
                    msg: format!("property {}: {msg}", p.name),
                })?;
            // A string column that is empty (null) in every row would need a zero-length buffer view, which
            // glTF forbids; the table leaves the property out instead, which means "no value" for all rows.
            if col.values.is_empty() && col.string_offsets.is_some() {
                continue;
            }
            let mut plain = |data: &[u8]| {
                doc.buffer_views.push(BufferView {
                    buffer: 0,
                    byte_offset: bin.push(data),
                    byte_length: data.len(),
                    ..Default::default()
                });
                doc.buffer_views.len() - 1
            };
            let values = plain(&col.values);
            let string_offsets = col
                .string_offsets
                .as_ref()
                .map(|(bytes, ty)| (plain(bytes), *ty));
            properties.insert(
                p.name.clone(),
                PropertyTableProperty {
                    values,
                    string_offsets: string_offsets.map(|(view, _)| view),
                    string_offset_type: string_offsets.map(|(_, ty)| ty.into()),
                    ..Default::default()
                },
            );
        }
        table_of.insert(class, tables.len());
        tables.push(PropertyTable {
            class: class_def.id.clone(),
            count: members.len(),
            properties,
        });
    }
    for (node, prims) in nodes {
        doc.scenes[0].nodes.push(doc.nodes.len());
        doc.nodes.push(node);
        let primitives = prims
            .into_iter()
            .map(|(class, mut prim)| {
                if let Some(ext) = prim
                    .extensions
                    .as_mut()
                    .and_then(|e| e.mesh_features.as_mut())
                {
                    ext.feature_ids[0].property_table = Some(table_of[&class]);
                }
                prim
            })
            .collect();
        doc.meshes.push(Mesh { primitives });
    }
    let used: Vec<&str> = tables.iter().map(|t| t.class.as_str()).collect();
    doc.extensions = Some(RootExtensions {
        structural_metadata: Some(StructuralMetadata {
            schema: Some(schema_json(schema, &used, false)),
            property_tables: tables,
        }),
        ..Default::default()
    });
    doc.buffers.push(Buffer {
        byte_length: bin.padded_len(),
        ..Default::default()
    });
    let mut used = vec![EXT_MESH_FEATURES, EXT_STRUCTURAL_METADATA, KHR_QUANTIZATION];
    let mut required = vec![KHR_QUANTIZATION];
    if meshopt {
        // The fallback buffer has no data (no uri, not the GLB chunk), so the extension is required.
        doc.buffers.push(Buffer {
            byte_length: fallback.padded_len(),
            uri: None,
            extensions: Some(BufferExtensions {
                meshopt: Some(MeshoptBuffer { fallback: true }),
            }),
        });
        used.push(EXT_MESHOPT);
        required.push(EXT_MESHOPT);
    }
    if compression == Compression::Draco {
        // No uncompressed copy of the geometry is written.
        used.push(KHR_DRACO);
        required.push(KHR_DRACO);
    }
    used.sort_unstable();
    required.sort_unstable();
    doc.extensions_used = used.into_iter().map(String::from).collect();
    doc.extensions_required = required.into_iter().map(String::from).collect();

    bin.bytes.resize(bin.padded_len(), 0);
    let json = serde_json::to_vec(&doc).expect("glTF structs always serialize");
    Ok(Some(EncodedContent {
        glb: write_glb(&json, &bin.bytes),
        triangles,
        vertices,
        dropped_triangles: dropped,
        collapsed_features: collapsed,
        bounds_enu,
    }))
}

/// Unit vertex normals in glTF y-up axes: the area-weighted sum of the incident triangles' normals (after
/// [`split_by_face`], the face normal). Unused vertices point up.
fn vertex_normals_yup(m: &citylod_model::Mesh3d) -> Vec<[f64; 3]> {
    let mut acc = vec![[0.0f64; 3]; m.positions.len()];
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let n = crate::shading::area_normal(a, b, c);
        for &i in t {
            (0..3).for_each(|k| acc[i as usize][k] += n[k]);
        }
    }
    acc.into_iter()
        .map(|n| {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if len > 0.0 && len.is_finite() {
                enu_to_yup(n.map(|c| c / len))
            } else {
                [0.0, 1.0, 0.0]
            }
        })
        .collect()
}

/// A primitive before encoding: quantized positions (padded), feature ids, normals (empty without), indices.
type Streams = (Vec<[i16; 4]>, Vec<f32>, Vec<[f64; 3]>, Vec<u32>);

/// Triangles in vertex-cache order along strips and vertices in the order the triangles first use them
/// (meshoptimizer's `optimizeVertexCacheStrip`, then first use): the index codec then mostly refers to
/// recent vertices (on Boston's tiles 15 % fewer index bytes; the vertex codec gains nothing, the prisms' vertices
/// already come in order), a GPU fetches fewer vertices, and vertices only a dropped degenerate triangle used are
/// gone. Each triangle keeps its winding.
fn reorder_for_fetch(
    pos: Vec<[i16; 4]>,
    fid: Vec<f32>,
    nor: Vec<[f64; 3]>,
    idx: Vec<u32>,
) -> Streams {
    let idx = meshopt::optimize_vertex_cache_strip(&idx, pos.len());
    // New index of each vertex, by first use (the crate's fetch remap drops the entries of unused vertices).
    let mut remap = vec![u32::MAX; pos.len()];
    let mut used = 0;
    for &i in &idx {
        if remap[i as usize] == u32::MAX {
            remap[i as usize] = used as u32;
            used += 1;
        }
    }
    // The old index of each new vertex.
    let mut order = vec![0usize; used];
    for (old, &r) in remap.iter().enumerate().filter(|(_, &r)| r != u32::MAX) {
        order[r as usize] = old;
    }
    let idx = idx.iter().map(|&i| remap[i as usize]).collect();
    (
        order.iter().map(|&o| pos[o]).collect(),
        order.iter().map(|&o| fid[o]).collect(),
        order
            .iter()
            .filter(|_| !nor.is_empty())
            .map(|&o| nor[o])
            .collect(),
        idx,
    )
}

/// Compresses one primitive with KHR_draco_mesh_compression: attributes in the order POSITION,
/// _FEATURE_ID_0, NORMAL (when `nor` is not empty), normals as BYTE like the uncompressed layout.
fn encode_draco(
    pos: &[[i16; 4]],
    nor: &[[f64; 3]],
    fid: &[f32],
    idx: &[u32],
    features: usize,
) -> Result<DracoEncoded, String> {
    use draco_core::GeometryAttributeType as Kind;
    let pos3: Vec<[i16; 3]> = pos.iter().map(|p| [p[0], p[1], p[2]]).collect();
    let nor8: Vec<[i8; 3]> = nor
        .iter()
        .map(|v| v.map(|c| (c * 127.0).round() as i8))
        .collect();
    let fid16: Vec<u16> = fid.iter().map(|&k| k as u16).collect();
    let mut attributes = vec![(Kind::Position, DracoValues::I16x3(&pos3))];
    attributes.push(if features <= FEATURE_IDS_U16 {
        (Kind::Generic, DracoValues::U16(&fid16))
    } else {
        (Kind::Generic, DracoValues::F32(fid))
    });
    if !nor.is_empty() {
        attributes.push((Kind::Normal, DracoValues::I8x3(&nor8)));
    }
    draco::encode(&attributes, idx)
}

/// Compresses one buffer view (`count` elements of `stride` bytes) with the EXT_meshopt_compression
/// codecs: attributes with vertex codec version 0 (the only one that extension allows), triangles
/// with the index codec (version 1, header 0xe1, as the extension specifies).
fn encode_meshopt(
    raw: &[u8],
    stride: usize,
    count: usize,
    mode: &str,
    vertex_count: usize,
) -> Result<Vec<u8>, meshopt::Error> {
    debug_assert_eq!(raw.len(), stride * count);
    let out = match (mode, stride) {
        ("TRIANGLES", 2) => {
            let idx: Vec<u32> = raw
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]) as u32)
                .collect();
            meshopt::encode_index_buffer(&idx, vertex_count)?
        }
        ("TRIANGLES", _) => {
            let idx: Vec<u32> = raw
                .chunks_exact(4)
                .map(|b| u32::from_le_bytes(b.try_into().unwrap()))
                .collect();
            meshopt::encode_index_buffer(&idx, vertex_count)?
        }
        (_, 12) => {
            let v: Vec<[u8; 12]> = raw
                .chunks_exact(12)
                .map(|b| b.try_into().unwrap())
                .collect();
            meshopt::encode_vertex_buffer_level(&v, 2, Some(0))?
        }
        _ => {
            debug_assert_eq!(stride, 16);
            let v: Vec<[u8; 16]> = raw
                .chunks_exact(16)
                .map(|b| b.try_into().unwrap())
                .collect();
            meshopt::encode_vertex_buffer_level(&v, 2, Some(0))?
        }
    };
    debug_assert!(mode == "TRIANGLES" || out.first() == Some(&0xa0));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangles_flat_on_the_grid_are_told_exactly() {
        let t = |a: [i16; 3], b: [i16; 3], c: [i16; 3]| flat_on_the_grid([&a[..], &b[..], &c[..]]);
        // Two corners on one point; three on a line in 3D; one step off the line.
        assert!(t([0, 0, 0], [0, 0, 0], [5, 1, 2]));
        assert!(t([0, 0, 0], [2, 4, -6], [3, 6, -9]));
        assert!(t([-32767, 0, 5], [0, 10, 5], [32767, 20, 5]));
        assert!(!t([0, 0, 0], [2, 4, -6], [3, 6, -8]));
        assert!(!t([-32767, 0, 5], [0, 10, 5], [32767, 21, 5]));
        assert!(!t([0, 0, 0], [1, 0, 0], [0, 0, 1]));
    }

    /// A grid of `n` × `n` quads (two triangles each), triangles in a scattered order, plus one vertex no triangle uses.
    fn scattered_grid(n: u32) -> Streams {
        let w = n + 1;
        let mut pos: Vec<[i16; 4]> = (0..w * w)
            .map(|k| [(k % w) as i16, 0, (k / w) as i16, 0])
            .collect();
        pos.push([1000, 1000, 1000, 0]);
        let fid: Vec<f32> = (0..pos.len()).map(|k| (k % 7) as f32).collect();
        let nor: Vec<[f64; 3]> = (0..pos.len()).map(|k| [0.0, 1.0, k as f64]).collect();
        let mut tris: Vec<[u32; 3]> = Vec::new();
        for y in 0..n {
            for x in 0..n {
                let a = y * w + x;
                tris.push([a, a + w, a + 1]);
                tris.push([a + 1, a + w, a + w + 1]);
            }
        }
        // A fixed scatter: stride through the list by a step coprime with its length.
        let m = tris.len();
        let idx = (0..m).flat_map(|k| tris[(k * 37) % m]).collect();
        (pos, fid, nor, idx)
    }

    /// A triangle corner: position, feature id bits, normal bits.
    type Corner = ([i16; 4], u32, [u64; 3]);

    /// Each triangle as its three (position, feature id, normal) corners, rotated to start at its smallest.
    fn corners(pos: &[[i16; 4]], fid: &[f32], nor: &[[f64; 3]], idx: &[u32]) -> Vec<[Corner; 3]> {
        let mut out: Vec<_> = idx
            .chunks(3)
            .map(|t| {
                let c: [Corner; 3] = std::array::from_fn(|k| {
                    let i = t[k] as usize;
                    (pos[i], fid[i].to_bits(), nor[i].map(f64::to_bits))
                });
                let r = (0..3).min_by_key(|&k| c[k]).unwrap();
                std::array::from_fn(|k| c[(r + k) % 3])
            })
            .collect();
        out.sort();
        out
    }

    #[test]
    fn reordering_keeps_every_triangle_and_its_winding_and_drops_unused_vertices() {
        let (pos, fid, nor, idx) = scattered_grid(12);
        let before = corners(&pos, &fid, &nor, &idx);
        let (p2, f2, n2, i2) =
            reorder_for_fetch(pos.clone(), fid.clone(), nor.clone(), idx.clone());
        assert_eq!(corners(&p2, &f2, &n2, &i2), before);
        // The unused vertex is gone; vertices come in the order triangles first use them.
        assert_eq!(p2.len(), pos.len() - 1);
        let mut next = 0;
        for &i in &i2 {
            assert!(i <= next, "vertex {i} used before vertex {next}");
            next = next.max(i + 1);
        }
        // Without normals the normals stay empty.
        let (_, _, n3, _) = reorder_for_fetch(pos, fid, Vec::new(), idx);
        assert!(n3.is_empty());
    }

    #[test]
    fn reordering_makes_the_index_codec_smaller() {
        let (pos, fid, nor, idx) = scattered_grid(40);
        let (_, _, _, i2) = reorder_for_fetch(pos.clone(), fid, nor, idx.clone());
        let before = meshopt::encode_index_buffer(&idx, pos.len()).unwrap().len();
        let after = meshopt::encode_index_buffer(&i2, pos.len() - 1)
            .unwrap()
            .len();
        assert!(
            (after as f64) < 0.8 * before as f64,
            "{after} bytes after reordering, {before} before"
        );
    }
}
