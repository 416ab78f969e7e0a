//! Bounding volume hierarchy over a triangle mesh: closest point (for the sampled Hausdorff distance) and
//! first ray hit (for visibility checks). Median split on the longest centroid axis; leaves hold ≤ 4
//! triangles. Metres in, metres out. Deterministic for a given mesh.

use citylod_model::Mesh3d;

use crate::simplify::geom::{
    closest_point_on_triangle, dist2, segment_triangle_hit, Aabb, PlaneFrame, Reach, V3,
};

const LEAF_SIZE: usize = 4;

struct Node {
    bounds: Aabb,
    /// Leaf: triangles `order[start..start + count]`; inner node when `count == 0`.
    start: u32,
    count: u32,
    children: [u32; 2],
}

/// Triangle BVH over a borrowed mesh.
pub struct MeshBvh<'a> {
    mesh: &'a Mesh3d,
    nodes: Vec<Node>,
    order: Vec<u32>,
    /// Plane per triangle (a degenerate one for a left-out triangle), for the shortcuts of "within" queries.
    planes: Vec<PlaneFrame>,
}

impl<'a> MeshBvh<'a> {
    /// Builds the hierarchy; triangles with out-of-range indices are left out.
    pub fn new(mesh: &'a Mesh3d) -> Self {
        let n = mesh.positions.len();
        let valid = |t: &[u32; 3]| t.iter().all(|&i| (i as usize) < n);
        let mut order: Vec<u32> = (0..mesh.triangles.len() as u32)
            .filter(|&t| valid(&mesh.triangles[t as usize]))
            .collect();
        let centroid: Vec<V3> = mesh
            .triangles
            .iter()
            .map(|t| {
                if valid(t) {
                    let p = t.map(|i| mesh.positions[i as usize]);
                    [0, 1, 2].map(|k| (p[0][k] + p[1][k] + p[2][k]) / 3.0)
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        let planes = mesh
            .triangles
            .iter()
            .map(|t| {
                if valid(t) {
                    let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
                    PlaneFrame::new(a, b, c)
                } else {
                    PlaneFrame::new([0.0; 3], [0.0; 3], [0.0; 3])
                }
            })
            .collect();
        let mut bvh = MeshBvh {
            mesh,
            nodes: Vec::new(),
            order: Vec::new(),
            planes,
        };
        if !order.is_empty() {
            let len = order.len();
            bvh.build(&mut order, 0, len, &centroid);
        }
        bvh.order = order;
        bvh
    }

    fn tri(&self, t: u32) -> [V3; 3] {
        self.mesh.triangles[t as usize].map(|i| self.mesh.positions[i as usize])
    }

    fn build(&mut self, order: &mut [u32], start: usize, end: usize, centroid: &[V3]) -> u32 {
        let mut bounds = Aabb::empty();
        let mut cb = Aabb::empty();
        for &t in &order[start..end] {
            for p in self.tri(t) {
                bounds.add(p);
            }
            cb.add(centroid[t as usize]);
        }
        let id = self.nodes.len() as u32;
        self.nodes.push(Node {
            bounds,
            start: start as u32,
            count: (end - start) as u32,
            children: [0, 0],
        });
        if end - start <= LEAF_SIZE {
            return id;
        }
        let ext = [0, 1, 2].map(|k| cb.max[k] - cb.min[k]);
        let axis = (0..3)
            .max_by(|&a, &b| ext[a].total_cmp(&ext[b]))
            .unwrap_or(0);
        let mid = (start + end) / 2;
        order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
            centroid[a as usize][axis]
                .total_cmp(&centroid[b as usize][axis])
                .then(a.cmp(&b))
        });
        let left = self.build(order, start, mid, centroid);
        let right = self.build(order, mid, end, centroid);
        let node = &mut self.nodes[id as usize];
        node.count = 0;
        node.children = [left, right];
        id
    }

    /// Closest point on the mesh to `p`: (distance in m, triangle index), or `None` for an empty mesh.
    pub fn closest(&self, p: V3) -> Option<(f64, u32)> {
        let mut best = (f64::INFINITY, u32::MAX);
        self.closest_within(p, &mut best);
        (best.1 != u32::MAX).then(|| (best.0.sqrt(), best.1))
    }

    /// Whether the hierarchy holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Closest point on the mesh to `p`: (squared distance in m², triangle index), or `None` for an empty mesh.
    pub fn closest_squared(&self, p: V3) -> Option<(f64, u32)> {
        let mut best = (f64::INFINITY, u32::MAX);
        self.closest_within(p, &mut best);
        (best.1 != u32::MAX).then_some(best)
    }

    /// A triangle whose squared distance from `p` is at most `r2` (m²): the first one found, `None` when there is
    /// none.
    pub fn find_within_squared(&self, p: V3, r2: f64) -> Option<u32> {
        self.find_within(p, Reach::new(r2))
    }

    /// Triangle `t` lies within `reach` of `p`: its plane first, then the closest point.
    #[inline]
    pub(crate) fn triangle_within(&self, t: u32, p: V3, reach: Reach) -> bool {
        reach
            .decide(p, &self.planes[t as usize])
            .unwrap_or_else(|| self.triangle_dist2(t, p) <= reach.r2)
    }

    /// [`Self::find_within_squared`] with its reach.
    fn find_within(&self, p: V3, reach: Reach) -> Option<u32> {
        let r2 = reach.r2;
        // Median splits keep the depth near log2(n / LEAF_SIZE): a fixed stack saves an allocation per call.
        let mut stack = [0u32; 128];
        let mut len = usize::from(!self.nodes.is_empty());
        while len > 0 {
            len -= 1;
            let node = &self.nodes[stack[len] as usize];
            if node.bounds.dist2(p) > r2 {
                continue;
            }
            if node.count > 0 {
                let leaf = &self.order[node.start as usize..(node.start + node.count) as usize];
                if let Some(&t) = leaf.iter().find(|&&t| self.triangle_within(t, p, reach)) {
                    return Some(t);
                }
            } else if len + 2 <= stack.len() {
                stack[len] = node.children[0];
                stack[len + 1] = node.children[1];
                len += 2;
            } else {
                // Deeper than any median-split tree gets: fall back to the full closest-point search.
                return self
                    .closest_squared(p)
                    .filter(|&(d2, _)| d2 <= r2)
                    .map(|(_, t)| t);
            }
        }
        None
    }

    /// [`Self::find_within_squared`] for a run of nearby points: the triangles that answered the last few points
    /// (`recent`) are tried first, and the one that answers this point becomes the most recent.
    pub fn is_within_squared_near(&self, p: V3, r2: f64, recent: &mut Recent) -> bool {
        let reach = Reach::new(r2);
        if let Some(k) = recent
            .ids()
            .iter()
            .position(|&t| self.triangle_within(t, p, reach))
        {
            recent.promote(k);
            return true;
        }
        match self.find_within(p, reach) {
            Some(t) => {
                recent.push(t);
                true
            }
            None => false,
        }
    }

    /// Squared distance (m²) from `p` to triangle `t` of the mesh (an index the hierarchy holds).
    pub fn triangle_dist2(&self, t: u32, p: V3) -> f64 {
        let [a, b, c] = self.tri(t);
        dist2(p, closest_point_on_triangle(p, a, b, c))
    }

    /// Improves `best` (squared distance, triangle) with anything closer than it.
    fn closest_within(&self, p: V3, best: &mut (f64, u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = vec![0u32];
        while let Some(id) = stack.pop() {
            let node = &self.nodes[id as usize];
            if node.bounds.dist2(p) >= best.0 {
                continue;
            }
            if node.count > 0 {
                for &t in &self.order[node.start as usize..(node.start + node.count) as usize] {
                    let [a, b, c] = self.tri(t);
                    let d = dist2(p, closest_point_on_triangle(p, a, b, c));
                    if d < best.0 || (d == best.0 && t < best.1) {
                        *best = (d, t);
                    }
                }
            } else {
                let [l, r] = node.children;
                let (dl, dr) = (
                    self.nodes[l as usize].bounds.dist2(p),
                    self.nodes[r as usize].bounds.dist2(p),
                );
                // Visit the nearer child first: push it last.
                if dl <= dr {
                    stack.push(r);
                    stack.push(l);
                } else {
                    stack.push(l);
                    stack.push(r);
                }
            }
        }
    }

    /// First triangle hit by the ray `origin + t·dir` for `t` in `(t_min, t_max]` (t in units of `dir`):
    /// `(t, triangle)`. Ties go to the lower triangle index.
    pub fn ray_hit(&self, origin: V3, dir: V3, t_min: f64, t_max: f64) -> Option<(f64, u32)> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = dir.map(|d| {
            if d.abs() > 1e-300 {
                1.0 / d
            } else {
                f64::INFINITY.copysign(d)
            }
        });
        let mut best: Option<(f64, u32)> = None;
        let mut limit = t_max;
        let mut stack = vec![0u32];
        while let Some(id) = stack.pop() {
            let node = &self.nodes[id as usize];
            if !slab(&node.bounds, origin, inv, t_min, limit) {
                continue;
            }
            if node.count > 0 {
                for &t in &self.order[node.start as usize..(node.start + node.count) as usize] {
                    let [a, b, c] = self.tri(t);
                    if let Some(h) = segment_triangle_hit(origin, dir, a, b, c, t_min, limit) {
                        if best.is_none_or(|(bt, bi)| h < bt || (h == bt && t < bi)) {
                            best = Some((h, t));
                            limit = h;
                        }
                    }
                }
            } else {
                stack.extend(node.children);
            }
        }
        best
    }
}

/// The last few triangles that answered a query, most recent first (see [`MeshBvh::is_within_squared_near`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct Recent {
    ids: [u32; RECENT],
    len: usize,
}

/// How many triangles [`Recent`] keeps: a sample run crosses from one triangle to its neighbours and back.
const RECENT: usize = 4;

impl Recent {
    pub fn ids(&self) -> &[u32] {
        &self.ids[..self.len]
    }

    /// Makes `t` the most recent.
    pub fn push(&mut self, t: u32) {
        self.len = (self.len + 1).min(RECENT);
        self.ids.copy_within(0..self.len - 1, 1);
        self.ids[0] = t;
    }

    /// Moves the `k`-th most recent to the front.
    fn promote(&mut self, k: usize) {
        self.ids[..=k].rotate_right(1);
    }
}

fn slab(b: &Aabb, o: V3, inv: V3, t0: f64, t1: f64) -> bool {
    let (mut lo, mut hi) = (t0, t1);
    for k in 0..3 {
        let (mut a, mut c) = ((b.min[k] - o[k]) * inv[k], (b.max[k] - o[k]) * inv[k]);
        if a.is_nan() || c.is_nan() {
            // Ray parallel to the slab and starting on its plane.
            if o[k] < b.min[k] || o[k] > b.max[k] {
                return false;
            }
            continue;
        }
        if a > c {
            std::mem::swap(&mut a, &mut c);
        }
        lo = lo.max(a);
        hi = hi.min(c);
        if lo > hi {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_squares() -> Mesh3d {
        // Unit squares at z = 0 and z = 5.
        Mesh3d {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 5.0],
                [1.0, 0.0, 5.0],
                [1.0, 1.0, 5.0],
                [0.0, 1.0, 5.0],
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]],
        }
    }

    #[test]
    fn closest_point_matches_brute_force() {
        let m = two_squares();
        let bvh = MeshBvh::new(&m);
        let (d, t) = bvh.closest([0.3, 0.6, 4.0]).unwrap();
        assert!((d - 1.0).abs() < 1e-12);
        assert!(t >= 2);
        let (d, _) = bvh.closest([3.0, 0.5, 0.0]).unwrap();
        assert!((d - 2.0).abs() < 1e-12);
        let within = |r: f64| bvh.find_within_squared([3.0, 0.5, 0.0], r * r).is_some();
        assert!(within(2.0 + 1e-9));
        assert!(!within(2.0 - 1e-9));
    }

    #[test]
    fn ray_hits_the_nearer_square_first() {
        let m = two_squares();
        let bvh = MeshBvh::new(&m);
        let (t, tri) = bvh
            .ray_hit([0.4, 0.3, -1.0], [0.0, 0.0, 1.0], 0.0, 100.0)
            .unwrap();
        assert!((t - 1.0).abs() < 1e-12 && tri < 2);
        assert!(bvh
            .ray_hit([0.4, 0.3, -1.0], [1.0, 0.0, 0.0], 0.0, 100.0)
            .is_none());
    }

    #[test]
    fn recent_keeps_the_last_four_answers_most_recent_first() {
        let mut r = Recent::default();
        assert!(r.ids().is_empty());
        for t in [7, 8, 9, 10, 11] {
            r.push(t);
        }
        assert_eq!(r.ids(), &[11, 10, 9, 8]);
        // A hit on an older one moves it to the front.
        let bvh_mesh = two_squares();
        let bvh = MeshBvh::new(&bvh_mesh);
        let mut r = Recent::default();
        for t in [0, 1, 2, 3] {
            r.push(t);
        }
        // Triangles 0 and 1 are the square at z = 0, 2 and 3 the one at z = 5: a point over the lower square is
        // answered by 1 or 0, which then leads.
        assert!(bvh.is_within_squared_near([0.5, 0.5, 0.1], 0.01 + 1e-12, &mut r));
        assert!(matches!(r.ids()[0], 0 | 1), "{:?}", r.ids());
        assert_eq!(r.ids().len(), 4);
        // A point near nothing is not within, and leaves the list as it was.
        let before = r;
        assert!(!bvh.is_within_squared_near([0.5, 0.5, 2.5], 1.0, &mut r));
        assert_eq!(r.ids(), before.ids());
    }
}
