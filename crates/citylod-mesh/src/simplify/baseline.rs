//! Baseline for comparison: plain QEM simplification by meshoptimizer (`meshopt::simplify`, no topology
//! constraints beyond its own). Positions go to f32 relative to the mesh's first vertex, so local metres
//! keep sub-millimetre precision; the result references input vertices (unused ones are dropped).

use citylod_model::Mesh3d;

use super::{compact, rate, rate_note, unchanged, SimplifyResult};

pub(crate) fn simplify_meshopt(mesh: &Mesh3d, target_rate: f64) -> SimplifyResult {
    let origin = mesh.positions[0];
    let mut bytes: Vec<u8> = Vec::with_capacity(mesh.positions.len() * 12);
    for p in &mesh.positions {
        for k in 0..3 {
            bytes.extend_from_slice(&((p[k] - origin[k]) as f32).to_le_bytes());
        }
    }
    let Ok(adapter) = meshopt::VertexDataAdapter::new(&bytes, 12, 0) else {
        return unchanged(
            mesh,
            "meshopt rejected the vertex buffer: returned unchanged",
        );
    };
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let n_tris = mesh.triangles.len();
    let keep_tris = n_tris - ((target_rate * n_tris as f64).round() as usize).min(n_tris);
    // Relative error 1.0 = the whole mesh extent: let the triangle budget alone decide.
    let out = meshopt::simplify(
        &indices,
        &adapter,
        keep_tris * 3,
        1.0,
        meshopt::SimplifyOptions::None,
        None,
    );
    let tris: Vec<[u32; 3]> = out.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let (m, kept) = compact(&mesh.positions, &tris);
    let reached = rate(n_tris, m.triangles.len());
    let n_out = m.triangles.len();
    SimplifyResult {
        note: rate_note(
            target_rate,
            reached,
            "meshoptimizer found no further collapse within its rules",
            n_tris,
        ),
        rate_reached: reached,
        mesh: m,
        source_vertex: kept.into_iter().map(Some).collect(),
        source_triangle: vec![None; n_out],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::halfedge::tests::subdivided_box;

    #[test]
    fn meshopt_halves_a_subdivided_box_from_input_vertices() {
        let m = subdivided_box([10.0, 10.0, 10.0], 4);
        let out = simplify_meshopt(&m, 0.5);
        assert!(out.mesh.triangles.len() <= m.triangles.len() / 2 + 1);
        for (i, src) in out.source_vertex.iter().enumerate() {
            assert_eq!(out.mesh.positions[i], m.positions[src.unwrap() as usize]);
        }
    }
}
