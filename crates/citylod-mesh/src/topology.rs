//! Topology checks for simplified building meshes (seed 003 §1, DESIGN.md §7): which components touch
//! (within a tolerance, metres) and whether they still touch after simplification; watertightness (every
//! edge on exactly two triangles), orientation consistency, degenerate and flipped triangles.
//! Components are matched through the input vertex each output vertex came from.

use std::collections::BTreeMap;

use citylod_model::Mesh3d;

use crate::simplify::components::{components, Components};
use crate::simplify::geom::{
    closest_point_on_triangle, dist2, dot, norm, normalize, tri_normal2, triangle_triangle_dist2,
    Aabb, V3,
};
use crate::simplify::SimplifyResult;

/// A triangle is degenerate when its height over its longest edge is below this (m): 0.1 mm.
pub const DEGENERATE_HEIGHT_M: f64 = 1e-4;

/// Default distance (m) under which two components count as touching.
pub const TOUCH_TOLERANCE_M: f64 = 0.01;

/// Signed volume (m³) enclosed by a closed mesh: positive when its triangles wind counter-clockwise seen from
/// outside, negative when it is inside out (divergence theorem over the triangles' tetrahedra with the origin).
/// Meaningless for an open mesh; triangles with an out-of-range index are skipped.
///
/// ```
/// use citylod_model::Mesh3d;
/// // A right tetrahedron with unit legs, faces outward: volume 1/6 m³.
/// let m = Mesh3d { positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
///                  triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]] };
/// assert!((citylod_mesh::topology::signed_volume_m3(&m) - 1.0 / 6.0).abs() < 1e-12);
/// ```
pub fn signed_volume_m3(mesh: &Mesh3d) -> f64 {
    mesh.triangles
        .iter()
        .filter_map(|t| {
            let p = t.map(|i| mesh.positions.get(i as usize).copied());
            Some(cone_volume_m3([p[0]?, p[1]?, p[2]?], [0.0; 3]))
        })
        .sum()
}

/// Signed volume (m³) of each connected part of a mesh (`parts`, from [`crate::simplify::components::components`]
/// of this mesh), each summed from the part's own first vertex: well conditioned however far the coordinates' origin
/// is (the frame's origin can be 100 km away). Meaningless for an open part; the indices must be in range.
pub fn part_volumes_m3(mesh: &Mesh3d, parts: &crate::simplify::components::Components) -> Vec<f64> {
    let mut volume = vec![0.0f64; parts.count];
    let mut apex: Vec<Option<V3>> = vec![None; parts.count];
    for (t, &c) in mesh.triangles.iter().zip(&parts.of_triangle) {
        let o = *apex[c as usize].get_or_insert(mesh.positions[t[0] as usize]);
        volume[c as usize] += cone_volume_m3(t.map(|i| mesh.positions[i as usize]), o);
    }
    volume
}

/// Signed volume (m³) of the tetrahedron from `o` to the triangle: positive when the triangle faces away from `o`.
fn cone_volume_m3(t: [V3; 3], o: V3) -> f64 {
    let [a, b, c] = t.map(|p| [p[0] - o[0], p[1] - o[1], p[2] - o[2]]);
    (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0]))
        / 6.0
}

/// Whether triangle abc is degenerate: repeated corners or a height below [`DEGENERATE_HEIGHT_M`].
pub fn is_degenerate(a: V3, b: V3, c: V3) -> bool {
    let longest2 = dist2(a, b).max(dist2(b, c)).max(dist2(c, a));
    if longest2 <= 0.0 {
        return true;
    }
    // height = 2·area / longest edge
    norm(tri_normal2(a, b, c)) / longest2.sqrt() < DEGENERATE_HEIGHT_M
}

/// Structural facts about one mesh.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MeshReport {
    pub triangles: usize,
    /// Every edge is on exactly two triangles (and no triangle repeats a corner).
    pub watertight: bool,
    /// Edges on one triangle only.
    pub border_edges: usize,
    /// Edges on three or more triangles.
    pub non_manifold_edges: usize,
    /// No directed edge is used twice, i.e. neighbouring triangles agree on their orientation.
    pub orientation_consistent: bool,
    /// Triangles that are degenerate ([`is_degenerate`]) or reference a missing vertex.
    pub degenerate: usize,
}

/// Checks one mesh; never panics on bad indices (they count as degenerate).
pub fn mesh_report(mesh: &Mesh3d) -> MeshReport {
    let n = mesh.positions.len();
    let mut undirected: BTreeMap<(u32, u32), u32> = BTreeMap::new();
    let mut directed: BTreeMap<(u32, u32), u32> = BTreeMap::new();
    let mut degenerate = 0;
    let mut repeated = false;
    for t in &mesh.triangles {
        if t.iter().any(|&i| i as usize >= n) {
            degenerate += 1;
            continue;
        }
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            repeated = true;
        }
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        if is_degenerate(a, b, c) {
            degenerate += 1;
        }
        for k in 0..3 {
            let (x, y) = (t[k], t[(k + 1) % 3]);
            *undirected.entry((x.min(y), x.max(y))).or_default() += 1;
            *directed.entry((x, y)).or_default() += 1;
        }
    }
    let border_edges = undirected.values().filter(|&&c| c == 1).count();
    let non_manifold_edges = undirected.values().filter(|&&c| c > 2).count();
    MeshReport {
        triangles: mesh.triangles.len(),
        watertight: !mesh.triangles.is_empty()
            && !repeated
            && border_edges == 0
            && non_manifold_edges == 0,
        border_edges,
        non_manifold_edges,
        orientation_consistent: directed.values().all(|&c| c == 1),
        degenerate,
    }
}

/// Pairs `(a, b)`, `a < b`, of components whose surfaces come within `tolerance_m` of each other.
pub fn touching_pairs(mesh: &Mesh3d, comps: &Components, tolerance_m: f64) -> Vec<(u32, u32)> {
    let groups = triangles_by_component(mesh, &comps.of_triangle, comps.count);
    touching_pairs_of_groups(mesh, &groups, tolerance_m)
}

/// Triangle index lists per component.
fn triangles_by_component(mesh: &Mesh3d, of_triangle: &[u32], count: usize) -> Vec<Vec<u32>> {
    let mut groups = vec![Vec::new(); count];
    for (t, &c) in of_triangle.iter().enumerate().take(mesh.triangles.len()) {
        if (c as usize) < count {
            groups[c as usize].push(t as u32);
        }
    }
    groups
}

fn tri_points(mesh: &Mesh3d, t: u32) -> [V3; 3] {
    mesh.triangles[t as usize].map(|i| mesh.positions[i as usize])
}

fn touching_pairs_of_groups(
    mesh: &Mesh3d,
    groups: &[Vec<u32>],
    tolerance_m: f64,
) -> Vec<(u32, u32)> {
    let boxes: Vec<Aabb> = groups
        .iter()
        .map(|g| Aabb::of(g.iter().flat_map(|&t| tri_points(mesh, t))))
        .collect();
    let mut out = Vec::new();
    for a in 0..groups.len() {
        for b in a + 1..groups.len() {
            if groups[a].is_empty() || groups[b].is_empty() {
                continue;
            }
            if !boxes[a].expanded(tolerance_m).overlaps(&boxes[b]) {
                continue;
            }
            if groups_touch(
                mesh,
                &groups[a],
                &groups[b],
                &boxes[a],
                &boxes[b],
                tolerance_m,
            ) {
                out.push((a as u32, b as u32));
            }
        }
    }
    out
}

fn groups_touch(mesh: &Mesh3d, ga: &[u32], gb: &[u32], _ba: &Aabb, _bb: &Aabb, tol: f64) -> bool {
    let pa: Vec<[V3; 3]> = ga.iter().map(|&t| tri_points(mesh, t)).collect();
    let pb: Vec<[V3; 3]> = gb.iter().map(|&t| tri_points(mesh, t)).collect();
    triangle_sets_touch(&pa, &pb, tol)
}

/// Whether two triangle sets come within `tol` (m) of each other (AABB pre-filter, exact triangle
/// distances).
pub(crate) fn triangle_sets_touch(a: &[[V3; 3]], b: &[[V3; 3]], tol: f64) -> bool {
    let ba = Aabb::of(a.iter().flatten().copied());
    let bb = Aabb::of(b.iter().flatten().copied());
    if !ba.expanded(tol).overlaps(&bb) {
        return false;
    }
    let near = |g: &[[V3; 3]], other: &Aabb| -> Vec<(usize, Aabb)> {
        let ob = other.expanded(tol);
        g.iter()
            .enumerate()
            .map(|(i, t)| (i, Aabb::of(*t)))
            .filter(|(_, b)| b.overlaps(&ob))
            .collect()
    };
    let na = near(a, &bb);
    let nb = near(b, &ba);
    let tol2 = tol * tol;
    for (ia, boxa) in &na {
        let boxa = boxa.expanded(tol);
        for (ib, boxb) in &nb {
            if boxa.overlaps(boxb) && triangle_triangle_dist2(a[*ia], b[*ib]) <= tol2 {
                return true;
            }
        }
    }
    false
}

/// Component contacts of an original mesh and what became of them in a simplification.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ContactReport {
    /// Components of the original mesh.
    pub components: usize,
    /// Original component pairs that touched.
    pub touching_before: Vec<(u32, u32)>,
    /// Of those, the pairs that no longer touch (or whose component vanished) after simplification.
    pub lost: Vec<(u32, u32)>,
}

/// Original component of each output triangle: through `source_vertex` when known, else the component of
/// the nearest original triangle to the triangle's centroid.
fn output_components(original: &Mesh3d, comps: &Components, result: &SimplifyResult) -> Vec<u32> {
    let bvh = crate::hausdorff::MeshBvh::new(original);
    result
        .mesh
        .triangles
        .iter()
        .map(|t| {
            for &i in t {
                if let Some(Some(src)) = result.source_vertex.get(i as usize) {
                    if let Some(&c) = comps.of_vertex.get(*src as usize) {
                        if c != u32::MAX {
                            return c;
                        }
                    }
                }
            }
            let p = t.map(|i| result.mesh.positions[i as usize]);
            let centroid = [0, 1, 2].map(|k| (p[0][k] + p[1][k] + p[2][k]) / 3.0);
            bvh.closest(centroid)
                .map_or(u32::MAX, |(_, tri)| comps.of_triangle[tri as usize])
        })
        .collect()
}

/// Which originally touching component pairs (within `tolerance_m`) still touch after simplification.
pub fn contact_report(
    original: &Mesh3d,
    result: &SimplifyResult,
    tolerance_m: f64,
) -> ContactReport {
    let comps = components(original.positions.len(), &original.triangles);
    let touching_before = touching_pairs(original, &comps, tolerance_m);
    if touching_before.is_empty() {
        return ContactReport {
            components: comps.count,
            touching_before,
            lost: Vec::new(),
        };
    }
    let out_comp = output_components(original, &comps, result);
    let groups = triangles_by_component(&result.mesh, &out_comp, comps.count);
    let boxes: Vec<Aabb> = groups
        .iter()
        .map(|g| Aabb::of(g.iter().flat_map(|&t| tri_points(&result.mesh, t))))
        .collect();
    let lost = touching_before
        .iter()
        .copied()
        .filter(|&(a, b)| {
            let (ga, gb) = (&groups[a as usize], &groups[b as usize]);
            ga.is_empty()
                || gb.is_empty()
                || !boxes[a as usize]
                    .expanded(tolerance_m)
                    .overlaps(&boxes[b as usize])
                || !groups_touch(
                    &result.mesh,
                    ga,
                    gb,
                    &boxes[a as usize],
                    &boxes[b as usize],
                    tolerance_m,
                )
        })
        .collect();
    ContactReport {
        components: comps.count,
        touching_before,
        lost,
    }
}

/// Output triangles whose normal points against their source triangle's (when the result records it),
/// else against every original triangle of the same component lying within 1 mm of the nearest one to
/// the output triangle's centroid.
pub fn flipped_triangles(original: &Mesh3d, result: &SimplifyResult) -> usize {
    let comps = components(original.positions.len(), &original.triangles);
    let out_comp = output_components(original, &comps, result);
    let groups = triangles_by_component(original, &comps.of_triangle, comps.count);
    let mut flipped = 0;
    for (t, tri) in result.mesh.triangles.iter().enumerate() {
        let p = tri.map(|i| result.mesh.positions[i as usize]);
        let n = normalize(tri_normal2(p[0], p[1], p[2]));
        if n == [0.0; 3] {
            continue;
        }
        if let Some(Some(src)) = result.source_triangle.get(t) {
            if let Some(tri) = original.triangles.get(*src as usize) {
                let q = tri.map(|i| original.positions[i as usize]);
                if dot(normalize(tri_normal2(q[0], q[1], q[2])), n) <= 0.0 {
                    flipped += 1;
                }
                continue;
            }
        }
        let c = [0, 1, 2].map(|k| (p[0][k] + p[1][k] + p[2][k]) / 3.0);
        let Some(group) = groups.get(out_comp[t] as usize) else {
            continue;
        };
        let d: Vec<(f64, V3)> = group
            .iter()
            .map(|&s| {
                let q = tri_points(original, s);
                (
                    dist2(c, closest_point_on_triangle(c, q[0], q[1], q[2])).sqrt(),
                    normalize(tri_normal2(q[0], q[1], q[2])),
                )
            })
            .collect();
        let best = d.iter().map(|x| x.0).fold(f64::INFINITY, f64::min);
        let agrees = d
            .iter()
            .filter(|x| x.0 <= best + 1e-3)
            .any(|x| dot(x.1, n) > 0.0 || x.1 == [0.0; 3]);
        if !agrees {
            flipped += 1;
        }
    }
    flipped
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::halfedge::tests::subdivided_box;

    fn shifted(m: &Mesh3d, by: V3) -> Mesh3d {
        Mesh3d {
            positions: m
                .positions
                .iter()
                .map(|p| [p[0] + by[0], p[1] + by[1], p[2] + by[2]])
                .collect(),
            triangles: m.triangles.clone(),
        }
    }

    fn union(a: &Mesh3d, b: &Mesh3d) -> Mesh3d {
        let off = a.positions.len() as u32;
        let mut m = a.clone();
        m.positions.extend(&b.positions);
        m.triangles
            .extend(b.triangles.iter().map(|t| t.map(|i| i + off)));
        m
    }

    #[test]
    fn a_box_is_watertight_and_consistent_and_an_open_one_is_not() {
        let b = subdivided_box([3.0, 2.0, 1.0], 2);
        let r = mesh_report(&b);
        assert!(
            r.watertight && r.orientation_consistent && r.degenerate == 0,
            "{r:?}"
        );
        let mut open = b.clone();
        open.triangles.pop();
        assert!(!mesh_report(&open).watertight);
    }

    #[test]
    fn stacked_boxes_touch_and_lose_contact_when_one_is_lifted() {
        let a = subdivided_box([4.0, 4.0, 3.0], 1);
        let roof = shifted(&subdivided_box([4.0, 4.0, 1.0], 1), [0.0, 0.0, 3.0]);
        let house = union(&a, &roof);
        let comps = components(house.positions.len(), &house.triangles);
        assert_eq!(
            touching_pairs(&house, &comps, TOUCH_TOLERANCE_M),
            vec![(0, 1)]
        );
        let floating = union(&a, &shifted(&roof, [0.0, 0.0, 0.5]));
        let result = SimplifyResult {
            mesh: floating,
            rate_reached: 0.0,
            note: None,
            source_vertex: (0..house.positions.len() as u32).map(Some).collect(),
            source_triangle: Vec::new(),
        };
        let report = contact_report(&house, &result, TOUCH_TOLERANCE_M);
        assert_eq!(report.lost, vec![(0, 1)]);
    }

    #[test]
    fn a_reversed_triangle_counts_as_flipped() {
        let b = subdivided_box([3.0, 3.0, 3.0], 2);
        let mut m = b.clone();
        m.triangles[0].swap(1, 2);
        let result = SimplifyResult {
            mesh: m,
            rate_reached: 0.0,
            note: None,
            source_vertex: (0..b.positions.len() as u32).map(Some).collect(),
            source_triangle: Vec::new(),
        };
        assert_eq!(flipped_triangles(&b, &result), 1);
        assert!(!mesh_report(&result.mesh).orientation_consistent);
    }
}
