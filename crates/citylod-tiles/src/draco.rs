//! KHR_draco_mesh_compression for one primitive, with the pure-Rust `draco-core` codec. The attributes
//! given to Draco are already quantized (SHORT positions of KHR_mesh_quantization, BYTE-normalized
//! normals, integer feature ids), so Draco stores them as integers, losslessly: decoded values equal
//! the quantized ones, and the glTF accessors keep their component types. Connectivity: edgebreaker.
//! Invariant: `decode(encode(x))` has the same triangles over the same attribute values (reordered).

use draco_core::{
    DataType, DecoderBuffer, EncoderBuffer, EncoderOptions, GeometryAttributeType, Mesh,
    MeshDecoder, MeshEncoder, PointAttribute, PointIndex,
};

/// One attribute handed to Draco: its glTF name, components per vertex and values.
pub(crate) enum DracoValues<'a> {
    I16x3(&'a [[i16; 3]]),
    I8x3(&'a [[i8; 3]]),
    U16(&'a [u16]),
    F32(&'a [f32]),
}

/// A compressed primitive: the Draco bytes, the Draco unique id of each attribute (in input order)
/// and what a decoder gets back (vertex count and per-component min/max of the first attribute).
pub(crate) struct DracoEncoded {
    pub bytes: Vec<u8>,
    pub ids: Vec<u32>,
    pub decoded_vertices: usize,
    pub decoded_indices: usize,
    pub first_min: Vec<f64>,
    pub first_max: Vec<f64>,
}

/// Compresses `triangles` over `attributes` (each with one value per vertex; the first is the
/// position). Errors carry the codec's message. Deterministic: the codec runs on one thread.
pub(crate) fn encode(
    attributes: &[(GeometryAttributeType, DracoValues<'_>)],
    triangles: &[u32],
) -> Result<DracoEncoded, String> {
    debug_assert!(triangles.len().is_multiple_of(3));
    let n = match attributes.first() {
        Some((_, v)) => v.len(),
        None => return Err("no attributes".into()),
    };
    let mut mesh = Mesh::new();
    mesh.set_num_points(n);
    let mut ids = Vec::with_capacity(attributes.len());
    for (kind, values) in attributes {
        if values.len() != n {
            return Err("attributes differ in length".into());
        }
        let (components, data_type, normalized, bytes) = values.raw();
        let mut att = PointAttribute::new();
        att.try_init(*kind, components, data_type, normalized, n)
            .map_err(|e| format!("{e:?}"))?;
        att.buffer_mut().write(0, &bytes);
        let id = mesh.add_attribute(att);
        ids.push(mesh.attribute(id).unique_id());
    }
    mesh.set_num_faces(triangles.len() / 3);
    mesh.set_faces_from_flat_indices(triangles);
    let mut options = EncoderOptions::new();
    options.set_global_int("encoding_method", 1); // edgebreaker
    let mut encoder = MeshEncoder::new();
    encoder.set_mesh(mesh);
    let mut buffer = EncoderBuffer::new();
    encoder
        .encode(&options, &mut buffer)
        .map_err(|e| format!("Draco encoding failed: {e:?}"))?;
    let bytes = buffer.data().to_vec();
    // Decode once: the vertex count and bounds a client will see (edgebreaker may split or drop
    // vertices), and a check that the stream is whole.
    let back = decode(&bytes, &ids)?;
    let first = &back.attributes[0];
    let comps = attributes[0].1.components();
    let mut first_min = vec![f64::INFINITY; comps];
    let mut first_max = vec![f64::NEG_INFINITY; comps];
    for v in first.chunks_exact(comps) {
        for c in 0..comps {
            first_min[c] = first_min[c].min(v[c] as f64);
            first_max[c] = first_max[c].max(v[c] as f64);
        }
    }
    Ok(DracoEncoded {
        bytes,
        ids,
        decoded_vertices: back.vertices,
        decoded_indices: back.indices.len(),
        first_min,
        first_max,
    })
}

/// A decoded primitive: per requested attribute id its values (components flattened, as stored,
/// not normalized), and the triangle indices.
pub(crate) struct DracoDecoded {
    pub vertices: usize,
    pub attributes: Vec<Vec<f32>>,
    pub indices: Vec<u32>,
}

/// Decodes a Draco mesh and reads the attributes with the given unique ids.
pub(crate) fn decode(bytes: &[u8], ids: &[u32]) -> Result<DracoDecoded, String> {
    let mut mesh = Mesh::new();
    MeshDecoder::new()
        .decode(&mut DecoderBuffer::new(bytes), &mut mesh)
        .map_err(|e| format!("Draco decoding failed: {e:?}"))?;
    let vertices = mesh.num_points();
    let mut attributes = Vec::with_capacity(ids.len());
    for &id in ids {
        let att = mesh
            .attribute_by_unique_id(id)
            .ok_or_else(|| format!("Draco attribute {id} missing"))?;
        let comps = att.num_components() as usize;
        // Every point must map to a stored value, or read_f32s would fill in zeros.
        if (0..vertices).any(|p| att.mapped_index(PointIndex(p as u32)).0 as usize >= att.size()) {
            return Err(format!("Draco attribute {id} maps a point to no value"));
        }
        attributes.push(att.read_f32s(vertices, comps));
    }
    let mut indices = Vec::with_capacity(mesh.num_faces() * 3);
    for f in mesh.faces() {
        for p in f {
            if p.0 as usize >= vertices {
                return Err("Draco face index out of range".into());
            }
            indices.push(p.0);
        }
    }
    Ok(DracoDecoded {
        vertices,
        attributes,
        indices,
    })
}

impl DracoValues<'_> {
    fn len(&self) -> usize {
        match self {
            DracoValues::I16x3(v) => v.len(),
            DracoValues::I8x3(v) => v.len(),
            DracoValues::U16(v) => v.len(),
            DracoValues::F32(v) => v.len(),
        }
    }

    fn components(&self) -> usize {
        match self {
            DracoValues::I16x3(_) | DracoValues::I8x3(_) => 3,
            DracoValues::U16(_) | DracoValues::F32(_) => 1,
        }
    }

    /// Components, Draco type, normalized flag and little-endian bytes.
    fn raw(&self) -> (u8, DataType, bool, Vec<u8>) {
        match self {
            DracoValues::I16x3(v) => (
                3,
                DataType::Int16,
                false,
                v.iter().flatten().flat_map(|c| c.to_le_bytes()).collect(),
            ),
            DracoValues::I8x3(v) => (
                3,
                DataType::Int8,
                true,
                v.iter().flatten().map(|&c| c as u8).collect(),
            ),
            DracoValues::U16(v) => (
                1,
                DataType::Uint16,
                false,
                v.iter().flat_map(|c| c.to_le_bytes()).collect(),
            ),
            DracoValues::F32(v) => (
                1,
                DataType::Float32,
                false,
                v.iter().flat_map(|c| c.to_le_bytes()).collect(),
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_attributes_survive_draco_exactly() {
        // Two quads of a box corner, flat shaded: shared positions with different normals.
        let pos: Vec<[i16; 3]> = vec![
            [0, 0, 0],
            [100, 0, 0],
            [100, 50, 0],
            [0, 50, 0],
            [100, 0, 0],
            [100, 0, -80],
            [100, 50, -80],
            [100, 50, 0],
        ];
        let nor: Vec<[i8; 3]> = [[0, 0, 127]; 4]
            .into_iter()
            .chain([[127, 0, 0]; 4])
            .collect();
        let fid: Vec<u16> = vec![0, 0, 0, 0, 1, 1, 1, 1];
        let tris = [0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7];
        let enc = encode(
            &[
                (GeometryAttributeType::Position, DracoValues::I16x3(&pos)),
                (GeometryAttributeType::Normal, DracoValues::I8x3(&nor)),
                (GeometryAttributeType::Generic, DracoValues::U16(&fid)),
            ],
            &tris,
        )
        .unwrap();
        assert_eq!(enc.first_min, vec![0.0, 0.0, -80.0]);
        assert_eq!(enc.first_max, vec![100.0, 50.0, 0.0]);
        let dec = decode(&enc.bytes, &enc.ids).unwrap();
        assert_eq!(dec.vertices, enc.decoded_vertices);
        let corner = |i: u32| -> ([f32; 3], [f32; 3], f32) {
            let (a, i) = (&dec.attributes, i as usize);
            let v3 = |k: usize| [a[k][3 * i], a[k][3 * i + 1], a[k][3 * i + 2]];
            (v3(0), v3(1), a[2][i])
        };
        let mut got: Vec<_> = dec
            .indices
            .chunks_exact(3)
            .map(|t| {
                let mut c: Vec<_> = t.iter().map(|&i| format!("{:?}", corner(i))).collect();
                c.sort();
                c
            })
            .collect();
        let mut want: Vec<_> = tris
            .chunks_exact(3)
            .map(|t| {
                let mut c: Vec<_> = t
                    .iter()
                    .map(|&i| {
                        let i = i as usize;
                        format!(
                            "{:?}",
                            (
                                pos[i].map(|c| c as f32),
                                nor[i].map(|c| c as f32),
                                fid[i] as f32
                            )
                        )
                    })
                    .collect();
                c.sort();
                c
            })
            .collect();
        got.sort();
        want.sort();
        assert_eq!(got, want);
        assert!(decode(&enc.bytes[..enc.bytes.len() / 2], &enc.ids).is_err());
    }
}
