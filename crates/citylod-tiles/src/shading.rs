//! Flat shading for the glb writer: clients shade with per-vertex normals, and a corner shared by a wall and a roof
//! (CityJSON models, simplified models) would get their average — a box drawn as a blob. Local ENU metres.
//! Invariant: same triangles and positions; vertices only duplicated, never moved; a mesh whose corners each lie on
//! one plane (citylod's prisms) comes back as it is.

use citylod_model::Mesh3d;
use std::borrow::Cow;
use std::collections::BTreeMap;

/// `mesh` with each vertex split per plane of the triangles around it: triangles whose unit normals agree to
/// within ~0.5° (components rounded to 1/128) keep sharing the vertex, others get their own copy, so vertex
/// normals are face normals. Borrowed unchanged when no vertex needs splitting and every index is in range;
/// triangles with an out-of-range index are dropped. Deterministic: copies follow triangle order.
pub(crate) fn split_by_face(mesh: &Mesh3d) -> Cow<'_, Mesh3d> {
    let n = mesh.positions.len();
    let keys: Vec<Option<[i32; 3]>> = mesh
        .triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| mesh.positions.get(i as usize).copied());
            Some(plane_key(p[0]?, p[1]?, p[2]?))
        })
        .collect();
    // Fast path: every vertex sees one plane.
    let mut first: Vec<Option<[i32; 3]>> = vec![None; n];
    let needs_split = mesh.triangles.iter().zip(&keys).any(|(t, k)| {
        let Some(k) = k else { return true };
        t.iter().any(|&i| {
            let slot = &mut first[i as usize];
            *slot.get_or_insert(*k) != *k
        })
    });
    if !needs_split {
        return Cow::Borrowed(mesh);
    }
    let mut out = Mesh3d::default();
    let mut index: BTreeMap<(u32, [i32; 3]), u32> = BTreeMap::new();
    for (t, k) in mesh.triangles.iter().zip(&keys) {
        let Some(k) = k else { continue };
        let tri = t.map(|i| {
            *index.entry((i, *k)).or_insert_with(|| {
                out.positions.push(mesh.positions[i as usize]);
                (out.positions.len() - 1) as u32
            })
        });
        out.triangles.push(tri);
    }
    Cow::Owned(out)
}

/// (b − a) × (c − a): the triangle's normal, twice its area long (counter-clockwise seen from its tip).
pub(crate) fn area_normal(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// The triangle's unit normal rounded to 1/128 per component; all zeros for a degenerate triangle.
fn plane_key(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [i32; 3] {
    let n = area_normal(a, b, c);
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if !(len > 0.0 && len.is_finite()) {
        return [0; 3];
    }
    n.map(|x| (x / len * 128.0).round() as i32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coplanar_triangles_keep_sharing_and_a_cube_gets_four_corners_per_face() {
        // A unit cube, 8 shared corners, 12 triangles: flat shading needs 6 faces × 4 corners.
        let p = |x: f64, y: f64, z: f64| [x, y, z];
        let positions = vec![
            p(0., 0., 0.),
            p(1., 0., 0.),
            p(1., 1., 0.),
            p(0., 1., 0.),
            p(0., 0., 1.),
            p(1., 0., 1.),
            p(1., 1., 1.),
            p(0., 1., 1.),
        ];
        let triangles = vec![
            [0, 2, 1],
            [0, 3, 2],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 5],
            [0, 5, 4],
            [1, 2, 6],
            [1, 6, 5],
            [2, 3, 7],
            [2, 7, 6],
            [3, 0, 4],
            [3, 4, 7],
        ];
        let cube = Mesh3d {
            positions,
            triangles,
        };
        let f = split_by_face(&cube).into_owned();
        assert_eq!(f.positions.len(), 24);
        assert_eq!(f.triangles.len(), 12);
        for (t, u) in cube.triangles.iter().zip(&f.triangles) {
            for k in 0..3 {
                assert_eq!(cube.positions[t[k] as usize], f.positions[u[k] as usize]);
            }
        }
        assert!(
            matches!(split_by_face(&f), Cow::Borrowed(_)),
            "a split mesh is borrowed as it is"
        );
    }

    #[test]
    fn bad_indices_and_degenerate_triangles_do_not_panic() {
        let m = Mesh3d {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            triangles: vec![[0, 1, 2], [0, 1, 9]],
        };
        let f = split_by_face(&m);
        assert_eq!(f.triangles.len(), 1);
    }

    #[test]
    fn a_corner_shared_by_two_planes_is_doubled() {
        // Two triangles folded along the x axis: one flat, one standing up.
        let m = Mesh3d {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            triangles: vec![[0, 1, 2], [1, 0, 3]],
        };
        let f = split_by_face(&m);
        assert_eq!(f.positions.len(), 6); // the shared edge's two corners are doubled
        assert_eq!(f.triangles.len(), 2);
    }
}
