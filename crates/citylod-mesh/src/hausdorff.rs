//! Measured geometric error of a simplified mesh: the two-sided Hausdorff distance (metres), sampled.
//! Samples are every vertex plus a stratified barycentric pattern on each triangle (sub-triangle
//! centroids, about `samples_per_m2` per m²); each sample's distance to the other mesh comes from a BVH.
//! Deterministic; a lower bound of the true Hausdorff distance that tightens as the density grows.

mod bvh;

pub use bvh::{MeshBvh, Recent};

use citylod_model::Mesh3d;

use crate::simplify::geom::{tri_area, Reach, V3};

/// Default sample density (samples per m² of surface).
pub const DEFAULT_SAMPLES_PER_M2: f64 = 4.0;

/// Most samples on one triangle side: a triangle gets at most `MAX_SUBDIVISIONS²` samples.
const MAX_SUBDIVISIONS: usize = 48;

/// Coordinate resolution of the inputs (3DBAG and Den Haag store millimetres): the error reported by
/// [`measured_error_m`] for a mesh that changed but whose sampled distance is below it.
pub const RESOLUTION_M: f64 = 0.001;

/// Deterministic sample points on a mesh: its vertices used by triangles, then per triangle the centroids
/// of a `k × k` subdivision with `k² ≈ area · samples_per_m2`.
pub fn sample_points(mesh: &Mesh3d, samples_per_m2: f64) -> Vec<[f64; 3]> {
    let mut out = used_vertices(mesh);
    let density = sample_density(samples_per_m2);
    for t in valid_triangles(mesh) {
        triangle_samples(t, density, &mut out);
    }
    out
}

/// The positions of `mesh` that some triangle uses, in index order.
fn used_vertices(mesh: &Mesh3d) -> Vec<V3> {
    let mut used = vec![false; mesh.positions.len()];
    for t in &mesh.triangles {
        if t.iter().all(|&i| (i as usize) < used.len()) {
            for &i in t {
                used[i as usize] = true;
            }
        }
    }
    (0..used.len())
        .filter(|&i| used[i])
        .map(|i| mesh.positions[i])
        .collect()
}

/// The corners of every triangle of `mesh` whose indices are in range.
fn valid_triangles(mesh: &Mesh3d) -> impl Iterator<Item = [V3; 3]> + '_ {
    let n = mesh.positions.len();
    mesh.triangles
        .iter()
        .filter(move |t| t.iter().all(|&i| (i as usize) < n))
        .map(|t| t.map(|i| mesh.positions[i as usize]))
}

fn sample_density(samples_per_m2: f64) -> f64 {
    if samples_per_m2.is_finite() && samples_per_m2 > 0.0 {
        samples_per_m2
    } else {
        DEFAULT_SAMPLES_PER_M2
    }
}

/// Appends the samples of triangle `[a, b, c]`: the centroids of a `k × k` subdivision, `k² ≈ area · density`.
fn triangle_samples([a, b, c]: [V3; 3], density: f64, out: &mut Vec<V3>) {
    let want = (tri_area(a, b, c) * density).ceil().max(1.0);
    let k = (want.sqrt().ceil() as usize).clamp(1, MAX_SUBDIVISIONS);
    out.extend(subdivision_centroids([a, b, c], k));
}

/// The centroids of the `k²` triangles of a `k × k` subdivision of `[a, b, c]` (similar to it, `k` along each side),
/// in a fixed order: points spread evenly over the triangle, none on its edges. None for `k` = 0.
pub fn subdivision_centroids([a, b, c]: [V3; 3], k: usize) -> impl Iterator<Item = V3> {
    let kf = k as f64;
    let at = move |u: f64, v: f64| -> V3 {
        [0, 1, 2].map(|d| a[d] + (b[d] - a[d]) * u + (c[d] - a[d]) * v)
    };
    (0..k).flat_map(move |i| {
        (0..k - i).flat_map(move |j| {
            let (fi, fj) = (i as f64, j as f64);
            let lower = at((fi + 1.0 / 3.0) / kf, (fj + 1.0 / 3.0) / kf);
            let upper = (i + j + 1 < k).then(|| at((fi + 2.0 / 3.0) / kf, (fj + 2.0 / 3.0) / kf));
            std::iter::once(lower).chain(upper)
        })
    })
}

/// Largest distance (m) from a sample of `from` to the surface of `to`; `f64::INFINITY` when `to` has no
/// triangles but `from` has, 0 when both are empty.
pub fn directed_hausdorff_m(from: &Mesh3d, to: &Mesh3d, samples_per_m2: f64) -> f64 {
    let bvh = MeshBvh::new(to);
    if bvh.is_empty() {
        return if used_vertices(from).is_empty() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    // A sample within the largest distance so far cannot raise it: the first triangle found that near settles it,
    // and only the others need the nearest triangle (the early break of Taha & Hanbury's Hausdorff algorithm).
    // Kept squared, so the result is exactly the maximum over every sample's distance. Neighbouring samples are
    // mostly near the same triangle of `to`: the last one found is tried first.
    let mut worst2 = 0.0f64;
    let mut last = Recent::default();
    // `None` for a sample without any distance (not a point): then there is no bound.
    let settle = |p: V3, worst2: &mut f64, last: &mut Recent| -> Option<()> {
        if !bvh.is_within_squared_near(p, *worst2, last) {
            let (d2, t) = bvh.closest_squared(p)?;
            *worst2 = worst2.max(d2);
            last.push(t);
        }
        Some(())
    };
    for p in used_vertices(from) {
        if settle(p, &mut worst2, &mut last).is_none() {
            return f64::INFINITY;
        }
    }
    let density = sample_density(samples_per_m2);
    let mut samples = Vec::new();
    for corners in valid_triangles(from) {
        // The distance to one triangle of `to` is a convex function: when all three corners are within `worst2` of
        // one triangle, so is every point between them, and none of this triangle's samples can raise the maximum.
        let reach = Reach::new(worst2);
        let one_holds_all = |t: u32| corners.iter().all(|&c| bvh.triangle_within(t, c, reach));
        if last.ids().iter().any(|&t| one_holds_all(t))
            || bvh
                .find_within_squared(corners[0], worst2)
                .is_some_and(one_holds_all)
        {
            continue;
        }
        samples.clear();
        triangle_samples(corners, density, &mut samples);
        for &p in &samples {
            if settle(p, &mut worst2, &mut last).is_none() {
                return f64::INFINITY;
            }
        }
    }
    worst2.sqrt()
}

/// Two-sided sampled Hausdorff distance (m) between two meshes in the same frame.
///
/// ```
/// use citylod_model::Mesh3d;
/// let a = Mesh3d { positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], triangles: vec![[0, 1, 2]] };
/// let mut b = a.clone();
/// b.positions[2][2] = 0.5; // lift one corner by 0.5 m
/// let d = citylod_mesh::hausdorff::hausdorff_m(&a, &b, 100.0);
/// assert!(d > 0.3 && d <= 0.5 + 1e-9);
/// ```
pub fn hausdorff_m(a: &Mesh3d, b: &Mesh3d, samples_per_m2: f64) -> f64 {
    directed_hausdorff_m(a, b, samples_per_m2).max(directed_hausdorff_m(b, a, samples_per_m2))
}

/// The geometric error (m) of `simplified` as a stand-in for `original`: the sampled two-sided Hausdorff
/// distance at [`DEFAULT_SAMPLES_PER_M2`], but never below [`RESOLUTION_M`] when the meshes differ, so a
/// changed mesh never claims zero error (a viewer must still be able to refine to the original). 0 when
/// the two meshes are identical.
pub fn measured_error_m(original: &Mesh3d, simplified: &Mesh3d) -> f64 {
    if original == simplified {
        return 0.0;
    }
    // A triangle both meshes have (the same three corners) is at distance 0 from the other mesh: its samples cannot
    // raise the distance above the floor, so only the others are sampled — the same result, from fewer samples where
    // the simplification left the surface as it was.
    let one_way = |from: &Mesh3d, to: &Mesh3d| {
        let shared = triangle_keys(to);
        let own = Mesh3d {
            positions: from.positions.clone(),
            triangles: from
                .triangles
                .iter()
                .filter(|t| triangle_key(from, t).is_none_or(|k| !shared.contains(&k)))
                .copied()
                .collect(),
        };
        directed_hausdorff_m(&own, to, DEFAULT_SAMPLES_PER_M2)
    };
    one_way(original, simplified)
        .max(one_way(simplified, original))
        .max(RESOLUTION_M)
}

/// A triangle's corners as exact bit patterns, sorted: the same key for the same triangle in any mesh, whatever its
/// corner order. `None` for an index out of range.
fn triangle_key(mesh: &Mesh3d, t: &[u32; 3]) -> Option<[[u64; 3]; 3]> {
    let mut k = [[0u64; 3]; 3];
    for (slot, &i) in k.iter_mut().zip(t) {
        *slot = mesh.positions.get(i as usize)?.map(f64::to_bits);
    }
    k.sort_unstable();
    Some(k)
}

fn triangle_keys(mesh: &Mesh3d) -> std::collections::HashSet<[[u64; 3]; 3]> {
    mesh.triangles
        .iter()
        .filter_map(|t| triangle_key(mesh, t))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 × 10 m grid of 1 m squares, two triangles each.
    fn grid() -> Mesh3d {
        let mut m = Mesh3d::default();
        for j in 0..=10 {
            for i in 0..=10 {
                m.positions.push([i as f64, j as f64, 0.0]);
            }
        }
        for j in 0..10u32 {
            for i in 0..10u32 {
                let a = j * 11 + i;
                m.triangles.push([a, a + 1, a + 12]);
                m.triangles.push([a, a + 12, a + 11]);
            }
        }
        m
    }

    /// Sampling only the triangles the other mesh does not share gives exactly what sampling everything gives, once
    /// the 1 mm floor applies: a corner lifted 0.3 m, 0.2 mm (under the floor), or the triangles merely reordered.
    #[test]
    fn the_measured_error_skips_shared_triangles_without_changing() {
        let a = grid();
        for lift in [0.3, 0.0002] {
            let mut b = a.clone();
            b.positions[5 * 11 + 5][2] = lift;
            let full = hausdorff_m(&a, &b, DEFAULT_SAMPLES_PER_M2).max(RESOLUTION_M);
            assert_eq!(measured_error_m(&a, &b), full, "lift {lift}");
            assert_eq!(measured_error_m(&b, &a), full, "lift {lift}");
        }
        assert!(
            (measured_error_m(&a, &{
                let mut b = a.clone();
                b.positions[60][2] = 0.3;
                b
            }) - 0.3)
                .abs()
                < 1e-9
        );
        let mut turned = a.clone();
        turned.triangles.reverse();
        for t in &mut turned.triangles {
            t.rotate_left(1);
        }
        assert_eq!(measured_error_m(&a, &turned), RESOLUTION_M);
    }

    #[test]
    fn samples_cover_each_triangle_at_the_requested_density() {
        let m = Mesh3d {
            positions: vec![[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0]],
            triangles: vec![[0, 1, 2]],
        };
        let s = sample_points(&m, 1.0);
        // 50 m² → k = 8 → 64 samples, plus 3 vertices.
        assert_eq!(s.len(), 67);
        assert!(s
            .iter()
            .all(|p| p[0] >= 0.0 && p[1] >= 0.0 && p[0] + p[1] <= 10.0 + 1e-9));
    }

    #[test]
    fn identical_meshes_have_zero_error_and_a_moved_vertex_does_not() {
        let a = crate::simplify::halfedge::tests::subdivided_box([4.0, 4.0, 4.0], 2);
        assert!(hausdorff_m(&a, &a, 4.0) < 1e-9);
        assert_eq!(measured_error_m(&a, &a), 0.0);
        let mut b = a.clone();
        let top = (0..b.positions.len())
            .find(|&i| b.positions[i] == [2.0, 2.0, 4.0])
            .unwrap();
        b.positions[top][2] = 5.0;
        let d = hausdorff_m(&a, &b, 16.0);
        assert!((d - 1.0).abs() < 1e-9, "{d}");
    }

    /// The early break (a sample within the largest distance so far is not measured) gives exactly the maximum
    /// over every sample's nearest distance, bit for bit.
    #[test]
    fn the_early_break_gives_exactly_the_maximum_over_every_sample() {
        let a = crate::simplify::halfedge::tests::subdivided_box([6.0, 4.0, 5.0], 4);
        let mut b = a.clone();
        for (i, p) in b.positions.iter_mut().enumerate() {
            // A bumpy copy: every vertex moved by its own small amount.
            let k = ((i * 7919) % 17) as f64 / 17.0;
            p[0] += 0.3 * k;
            p[2] += 0.2 * (1.0 - k) * if i % 2 == 0 { 1.0 } else { -1.0 };
        }
        // And a fine grid against a coarse copy with a corner raised: most fine triangles lie, corners and all, within
        // the distance found of one coarse triangle, and are not sampled at all.
        let fine = grid();
        let coarse = Mesh3d {
            positions: vec![
                [0.0, 0.0, 0.0],
                [10.0, 0.0, 0.0],
                [10.0, 10.0, 0.7],
                [0.0, 10.0, 0.0],
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        for (from, to) in [(&a, &b), (&b, &a), (&fine, &coarse), (&coarse, &fine)] {
            let bvh = MeshBvh::new(to);
            let every = sample_points(from, 9.0)
                .into_iter()
                .map(|p| bvh.closest(p).unwrap().0)
                .fold(0.0f64, f64::max);
            let d = directed_hausdorff_m(from, to, 9.0);
            assert!(d > 0.05);
            assert_eq!(d.to_bits(), every.to_bits(), "{d} against {every}");
        }
    }
}
