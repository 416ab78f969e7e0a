//! Simplifying a merged footprint (seed 000 §3.2, after Visvalingam–Whyatt): remove the vertex of the
//! smallest concave triangle while its area < δa, then near-collinear vertices (angle > 175°). Local ENU
//! metres. Invariants: output vertices ⊆ input vertices, no self-intersection, every ring ≥ 3 vertices,
//! and the output covers the input (up to `CONVEX_COLLINEAR_TOL_M` where a convex near-straight vertex goes).

use crate::merge::{
    closed_ring, cross, in_closed_triangle, open_ring, point_segment_dist2, signed_area2,
};
use citylod_model::Footprint;
use geo_types::{MultiPolygon, Polygon};
use rstar::primitives::GeomWithData;
use rstar::{RTree, AABB};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// A convex vertex whose angle exceeds the collinearity threshold is removed only when it lies at most
/// this far (m) from the chord of its neighbours, so the area given up is a sliver of at most this width.
pub const CONVEX_COLLINEAR_TOL_M: f64 = 0.02;

/// A concave triangle thinner than `SLIVER_FACTOR`·√δa (m; smallest altitude) is filled whatever its
/// area: it is part of a sliver (a hairline gap between row houses bridged at one
/// end, a deep narrow notch). The width grows with δa, so with the level.
pub const SLIVER_FACTOR: f64 = 0.25;

/// Simplifies `fp` (local ENU m) in two passes, each removing one vertex at a time from a priority queue:
///
/// 1. *Concave triangles*: a vertex is concave when, walking its ring with the solid on the left (exterior
///    CCW, holes CW), the turn there is clockwise — a notch in the exterior, or a corner of a hole that
///    points into the hole. Removing it fills the triangle, so the footprint only grows. The vertex with
///    the smallest such triangle goes first while its area < `delta_a_m2` (m²), or at any area when the
///    triangle is thinner than `SLIVER_FACTOR`·√`delta_a_m2` (a sliver). Holes whose
///    whole area is below `delta_a_m2` are filled.
/// 2. *Near-collinear vertices*: vertices whose inner angle > `max_angle_deg` (175° in the paper), most
///    collinear first; a concave one always qualifies, a convex one only within `CONVEX_COLLINEAR_TOL_M`
///    of its neighbours' chord.
///
/// A removal is skipped when any other vertex of the footprint lies in the closed triangle it cuts (which
/// is what a self-intersection or a swallowed ring would need), or when the ring would drop below 3
/// vertices. Cost O(n log n). Degenerate input: rings with fewer than 3 distinct points or zero area are
/// dropped, a polygon without a usable exterior is dropped; `delta_a_m2 <= 0` skips pass 1.
///
/// # Examples
/// ```
/// use citylod_generalize::simplify_footprint;
/// use geo_types::{polygon, MultiPolygon};
/// // A 10 × 10 square with a 1 × 1 notch cut into its top edge.
/// let fp = MultiPolygon(vec![polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.0), (x: 10.0, y: 10.0),
///     (x: 6.0, y: 10.0), (x: 6.0, y: 9.0), (x: 5.0, y: 9.0), (x: 5.0, y: 10.0), (x: 0.0, y: 10.0)]]);
/// let s = simplify_footprint(&fp, 2.0, 175.0);
/// assert_eq!(s.0[0].exterior().0.len(), 5); // the notch is filled: a plain square
/// ```
pub fn simplify_footprint(fp: &Footprint, delta_a_m2: f64, max_angle_deg: f64) -> Footprint {
    let mut net = Net::new(&ring_specs(fp, delta_a_m2));
    if delta_a_m2 > 0.0 {
        net.remove_concave(delta_a_m2, SLIVER_FACTOR * delta_a_m2.sqrt());
    }
    let max_angle_rad = max_angle_deg.to_radians();
    if max_angle_rad.is_finite() && max_angle_rad < std::f64::consts::PI {
        net.remove_collinear(max_angle_rad, f64::INFINITY, false);
    }
    net.into_footprint(fp.0.len(), delta_a_m2)
}

/// Fills concave triangles of `fp` (local ENU m), smallest first, for as long as the area they add stays within
/// `budget_m2` in total (m²): the error-budgeted pass that lets a block drop outline detail its
/// geometricError already pays for (DESIGN.md §4: a node whose error is e may change area by (e/κ)² without
/// raising it). Only concave vertices go, so the result still covers `fp`; the same simplicity and ring-size
/// guards as [`simplify_footprint`] apply, and near-collinear vertices then go as in its pass 2 (`max_angle_deg`).
/// Whole holes compete with the notches on area filled per vertex removed, so a courtyard goes at once when that
/// is the cheaper saving (never one with another polygon of `fp` standing in it).
/// Returns the footprint and the area the fills added (≤ `budget_m2`; the area grows by at most this, a
/// near-straight convex vertex dropped afterwards may give a sliver back).
/// A budget ≤ 0 or not finite returns `fp` unchanged.
///
/// # Examples
/// ```
/// use citylod_generalize::fill_concave_within;
/// use geo_types::{polygon, MultiPolygon};
/// let fp = MultiPolygon(vec![polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.0), (x: 10.0, y: 10.0),
///     (x: 6.0, y: 10.0), (x: 6.0, y: 9.0), (x: 5.0, y: 9.0), (x: 5.0, y: 10.0), (x: 0.0, y: 10.0)]]);
/// let (s, added_m2) = fill_concave_within(&fp, 1.0, 175.0);
/// assert_eq!(s.0[0].exterior().0.len(), 5); // both notch triangles (0.5 m² each) fit in 1 m²
/// assert!((added_m2 - 1.0).abs() < 1e-9);
/// let (same, _) = fill_concave_within(&fp, 0.4, 175.0);
/// assert_eq!(same, fp);
/// ```
pub fn fill_concave_within(fp: &Footprint, budget_m2: f64, max_angle_deg: f64) -> (Footprint, f64) {
    if !(budget_m2 > 0.0 && budget_m2.is_finite()) {
        return (fp.clone(), 0.0);
    }
    let mut net = Net::new(&ring_specs(fp, 0.0));
    let mut added_m2 = net.fill_concave_budget(budget_m2);
    if added_m2 == 0.0 {
        return (fp.clone(), 0.0);
    }
    // Filling leaves straight vertices behind (the mouth of a filled notch).
    let max_angle_rad = max_angle_deg.to_radians();
    if max_angle_rad.is_finite() && max_angle_rad < std::f64::consts::PI {
        added_m2 += net
            .remove_collinear(max_angle_rad, budget_m2 - added_m2, false)
            .0;
    }
    (net.into_footprint(fp.0.len(), 0.0), added_m2)
}

/// What [`reoutline_within`] did: the new footprint, the area it filled and the area it cut (m²).
#[derive(Debug, Clone, PartialEq)]
pub struct Reoutlined {
    pub footprint: Footprint,
    pub filled_m2: f64,
    pub cut_m2: f64,
}

/// Simplifies `fp` (local ENU m) within an area budget by removing vertices, cheapest area per vertex first:
/// concave ones (filling a notch), convex ones (cutting a corner off) and whole holes (filling a courtyard),
/// while the area filled plus the area cut stays within `budget_m2` (m²); then near-straight vertices while
/// their triangles fit too (`max_angle_deg`). Unlike [`fill_concave_within`] the result need not cover `fp`: the
/// symmetric difference between the two is at most `filled_m2 + cut_m2`, which is what a block re-outlined this
/// way adds to its Δa (DESIGN.md §4: a block whose tile's error is e may differ from its buildings by (e/κ)²).
/// Output vertices are a subset of the input's; rings stay simple, disjoint and ≥ 3 vertices; a courtyard with
/// another polygon standing in it is never filled. A budget ≤ 0 or not finite returns `fp` unchanged.
///
/// # Examples
/// ```
/// use citylod_generalize::reoutline_within;
/// use geo_types::{polygon, MultiPolygon};
/// // A 10 × 10 square with a 1 × 1 notch at its top right.
/// let fp = MultiPolygon(vec![polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.0), (x: 10.0, y: 9.0),
///     (x: 9.0, y: 9.0), (x: 9.0, y: 10.0), (x: 0.0, y: 10.0)]]);
/// let r = reoutline_within(&fp, 0.6, 175.0);
/// // Filling half the notch (0.5 m²) removes its inner corner; the next cheapest triangle is 4.5 m².
/// assert_eq!(r.footprint.0[0].exterior().0.len() - 1, 5);
/// assert!((r.filled_m2 + r.cut_m2 - 0.5).abs() < 1e-9);
/// ```
pub fn reoutline_within(fp: &Footprint, budget_m2: f64, max_angle_deg: f64) -> Reoutlined {
    let unchanged = || Reoutlined {
        footprint: fp.clone(),
        filled_m2: 0.0,
        cut_m2: 0.0,
    };
    if !(budget_m2 > 0.0 && budget_m2.is_finite()) {
        return unchanged();
    }
    let mut net = Net::new(&ring_specs(fp, 0.0));
    let (mut filled_m2, mut cut_m2) = net.fill_concave_and_holes(budget_m2, true);
    let max_angle_rad = max_angle_deg.to_radians();
    if max_angle_rad.is_finite() && max_angle_rad < std::f64::consts::PI {
        let (f, c) = net.remove_collinear(max_angle_rad, budget_m2 - filled_m2 - cut_m2, true);
        filled_m2 += f;
        cut_m2 += c;
    }
    if filled_m2 == 0.0 && cut_m2 == 0.0 {
        return unchanged();
    }
    Reoutlined {
        footprint: net.into_footprint(fp.0.len(), 0.0),
        filled_m2,
        cut_m2,
    }
}

/// The usable rings of `fp`, open and oriented (exteriors CCW, holes CW): rings with zero area are dropped, a
/// polygon without a usable exterior is dropped, and holes smaller than `min_hole_m2` (m²) are left out (filled).
fn ring_specs(fp: &Footprint, min_hole_m2: f64) -> Vec<RingSpec> {
    let mut rings: Vec<RingSpec> = Vec::new();
    for (k, poly) in fp.0.iter().enumerate() {
        let Some(ext) = open_ring(poly.exterior(), true).filter(|r| signed_area2(r) != 0.0) else {
            continue;
        };
        rings.push(RingSpec { poly: k, pts: ext });
        for h in poly
            .interiors()
            .iter()
            .filter_map(|r| open_ring(r, false))
            .filter(|h| signed_area2(h) != 0.0)
        {
            if signed_area2(&h).abs() / 2.0 >= min_hole_m2 {
                rings.push(RingSpec { poly: k, pts: h });
            }
        }
    }
    rings
}

struct RingSpec {
    poly: usize,
    pts: Vec<[f64; 2]>,
}

struct Vertex {
    pos: [f64; 2],
    prev: u32,
    next: u32,
    ring: u32,
    alive: bool,
    /// Bumped whenever a neighbour changes, so stale queue entries are skipped.
    version: u32,
}

struct RingState {
    poly: usize,
    first: u32,
    /// Live vertices; 0 once a hole has been filled whole.
    len: usize,
    hole: bool,
    /// Bumped whenever the ring loses a vertex, so stale hole entries are skipped.
    version: u32,
}

type VPoint = GeomWithData<[f64; 2], u32>;

/// Nets of at most this many vertices find the vertices in a box by scanning them all, without a point
/// index: cheaper than building and updating an R-tree for the small rings most blocks have (Boston's build
/// spent about 10.7 / 9.9 / 8.3 % of its profile samples in the nets with the R-tree always / up to 64 vertices
/// scanned / up to 256).
const SCAN_MAX_VERTICES: usize = 256;

/// The rings as doubly linked vertex lists plus a point index of every live vertex (`None` for a small net,
/// which scans its live vertices instead).
struct Net {
    v: Vec<Vertex>,
    rings: Vec<RingState>,
    index: Option<RTree<VPoint>>,
}

#[derive(PartialEq)]
struct Entry {
    key: f64,
    id: u32,
    version: u32,
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        self.key.total_cmp(&o.key).then(self.id.cmp(&o.id))
    }
}

impl Net {
    fn new(rings: &[RingSpec]) -> Self {
        Self::with_scan_max(rings, SCAN_MAX_VERTICES)
    }

    /// A net that scans its vertices when it has at most `scan_max` of them, else indexes them.
    fn with_scan_max(rings: &[RingSpec], scan_max: usize) -> Self {
        let mut v = Vec::new();
        let mut states = Vec::new();
        for (r, spec) in rings.iter().enumerate() {
            let hole = r > 0 && rings[r - 1].poly == spec.poly;
            let base = v.len() as u32;
            let n = spec.pts.len() as u32;
            for (i, &p) in spec.pts.iter().enumerate() {
                let i = i as u32;
                v.push(Vertex {
                    pos: p,
                    prev: base + (i + n - 1) % n,
                    next: base + (i + 1) % n,
                    ring: r as u32,
                    alive: true,
                    version: 0,
                });
            }
            states.push(RingState {
                poly: spec.poly,
                first: base,
                len: n as usize,
                hole,
                version: 0,
            });
        }
        let index = (v.len() > scan_max).then(|| {
            RTree::bulk_load(
                v.iter()
                    .enumerate()
                    .map(|(i, x)| VPoint::new(x.pos, i as u32))
                    .collect(),
            )
        });
        Net {
            v,
            rings: states,
            index,
        }
    }

    /// Whether a live vertex in the closed box `env` (id, position) passes `hit`.
    fn any_in_box(&self, env: &AABB<[f64; 2]>, mut hit: impl FnMut(u32, [f64; 2]) -> bool) -> bool {
        match &self.index {
            Some(tree) => tree
                .locate_in_envelope_intersecting(env)
                .any(|q| hit(q.data, *q.geom())),
            None => {
                let (lo, hi) = (env.lower(), env.upper());
                self.v.iter().enumerate().any(|(i, x)| {
                    x.alive
                        && x.pos[0] >= lo[0]
                        && x.pos[0] <= hi[0]
                        && x.pos[1] >= lo[1]
                        && x.pos[1] <= hi[1]
                        && hit(i as u32, x.pos)
                })
            }
        }
    }

    /// Takes vertex `id` out of the point index (its `alive` flag is the caller's).
    fn unindex(&mut self, id: u32) {
        if let Some(tree) = &mut self.index {
            let removed = tree.remove(&VPoint::new(self.v[id as usize].pos, id));
            debug_assert!(removed.is_some(), "vertex {id} missing from the index");
        }
    }

    fn triangle(&self, id: u32) -> [[f64; 2]; 3] {
        let x = &self.v[id as usize];
        [
            self.v[x.prev as usize].pos,
            x.pos,
            self.v[x.next as usize].pos,
        ]
    }

    /// Twice the signed area of the vertex's triangle: < 0 means concave (solid on the left).
    fn turn2(&self, id: u32) -> f64 {
        let t = self.triangle(id);
        cross(t[0], t[1], t[2])
    }

    /// Inner angle (rad) between the vertex's two sides; π for a straight or degenerate vertex.
    fn angle(&self, id: u32) -> f64 {
        let [p, x, n] = self.triangle(id);
        let a = [p[0] - x[0], p[1] - x[1]];
        let b = [n[0] - x[0], n[1] - x[1]];
        let (la, lb) = (a[0].hypot(a[1]), b[0].hypot(b[1]));
        if la == 0.0 || lb == 0.0 {
            return std::f64::consts::PI;
        }
        ((a[0] * b[0] + a[1] * b[1]) / (la * lb))
            .clamp(-1.0, 1.0)
            .acos()
    }

    /// True when removing the vertex keeps every ring simple, disjoint from the others and ≥ 3 vertices.
    fn can_remove(&self, id: u32) -> bool {
        let x = &self.v[id as usize];
        let ring = &self.rings[x.ring as usize];
        if ring.len <= 3 {
            return false;
        }
        let t = self.triangle(id);
        if ring.len == 4 {
            let nn = self.v[self.v[x.next as usize].next as usize].pos;
            if cross(t[0], t[2], nn) == 0.0 {
                return false;
            }
        }
        let env = AABB::from_points(t.iter());
        !self.any_in_box(&env, |q, p| {
            q != id && q != x.prev && q != x.next && in_closed_triangle(p, t)
        })
    }

    fn remove(&mut self, id: u32) {
        let (p, n, r) = {
            let x = &self.v[id as usize];
            (x.prev, x.next, x.ring)
        };
        self.v[id as usize].alive = false;
        self.v[p as usize].next = n;
        self.v[n as usize].prev = p;
        self.v[p as usize].version += 1;
        self.v[n as usize].version += 1;
        let ring = &mut self.rings[r as usize];
        ring.len -= 1;
        ring.version += 1;
        if ring.first == id {
            ring.first = n;
        }
        self.unindex(id);
    }

    /// Pass 1: smallest concave triangle first, for triangles of area < `delta_a_m2` or slivers (thinner
    /// than `sliver_m`).
    fn remove_concave(&mut self, delta_a_m2: f64, sliver_m: f64) {
        // A sliver: the triangle's smallest altitude, 2·area / longest side, is below `sliver_m`.
        let qualifies = |net: &Net, id: u32, area_m2: f64| {
            let [p, x, n] = net.triangle(id);
            let d = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
            let longest_m = d(p, x).max(d(x, n)).max(d(p, n));
            area_m2 < delta_a_m2 || 2.0 * area_m2 < sliver_m * longest_m
        };
        self.fill_concave(qualifies, f64::INFINITY);
    }

    /// The error-budgeted pass: smallest concave triangle first while the running total of filled area stays
    /// within `budget_m2`; returns that total (m²).
    fn fill_concave_budget(&mut self, budget_m2: f64) -> f64 {
        self.fill_concave_and_holes(budget_m2, false).0
    }

    /// The live vertices of ring `r`, in order.
    fn ring_points(&self, r: usize) -> Vec<[f64; 2]> {
        let ring = &self.rings[r];
        let mut pts = Vec::with_capacity(ring.len);
        let mut id = ring.first;
        for _ in 0..ring.len {
            pts.push(self.v[id as usize].pos);
            id = self.v[id as usize].next;
        }
        pts
    }

    /// True when hole `r` can be filled whole: no vertex of another ring lies inside it (an island standing
    /// in a courtyard would then overlap the filled polygon).
    fn can_fill_hole(&self, r: usize, pts: &[[f64; 2]]) -> bool {
        let env = AABB::from_points(pts.iter());
        !self.any_in_box(&env, |q, p| {
            self.v[q as usize].ring as usize != r && point_in_ring(p, pts)
        })
    }

    /// Fills hole `r` whole: its vertices leave the net and the ring is dropped from the output.
    fn fill_hole(&mut self, r: usize) {
        let ring = &self.rings[r];
        let mut id = ring.first;
        let mut ids = Vec::with_capacity(ring.len);
        for _ in 0..ring.len {
            ids.push(id);
            id = self.v[id as usize].next;
        }
        for id in ids {
            self.v[id as usize].alive = false;
            self.unindex(id);
        }
        let ring = &mut self.rings[r];
        ring.len = 0;
        ring.version += 1;
    }

    /// The budgeted pass: concave triangles (one vertex each), with `cuts` also convex ones, and whole holes (all
    /// their vertices) compete on area changed per vertex removed, cheapest first, while the running total stays
    /// within `budget_m2`; returns the area filled and the area cut (m²). A hole shrunk to a triangle by corner
    /// fills can then still go at once.
    fn fill_concave_and_holes(&mut self, budget_m2: f64, cuts: bool) -> (f64, f64) {
        let mut tri = BinaryHeap::new();
        let push_tri = |net: &Net, heap: &mut BinaryHeap<std::cmp::Reverse<Entry>>, id: u32| {
            let turn_m2 = net.turn2(id) / 2.0;
            let area_m2 = if cuts { turn_m2.abs() } else { -turn_m2 };
            if area_m2 > 0.0 && area_m2 <= budget_m2 {
                heap.push(std::cmp::Reverse(Entry {
                    key: area_m2,
                    id,
                    version: net.v[id as usize].version,
                }));
            }
        };
        let mut holes = BinaryHeap::new();
        let push_hole = |net: &Net, heap: &mut BinaryHeap<std::cmp::Reverse<Entry>>, r: usize| {
            let ring = &net.rings[r];
            if !ring.hole || ring.len == 0 {
                return;
            }
            let area_m2 = signed_area2(&net.ring_points(r)).abs() / 2.0;
            if area_m2 <= budget_m2 {
                heap.push(std::cmp::Reverse(Entry {
                    key: area_m2 / ring.len as f64,
                    id: r as u32,
                    version: ring.version,
                }));
            }
        };
        for id in 0..self.v.len() as u32 {
            push_tri(self, &mut tri, id);
        }
        for r in 0..self.rings.len() {
            push_hole(self, &mut holes, r);
        }
        let (mut filled_m2, mut cut_m2) = (0.0, 0.0);
        let mut triangles_left = true;
        loop {
            let spent_m2 = filled_m2 + cut_m2;
            let take_hole = match (tri.peek(), holes.peek()) {
                (_, None) if !triangles_left => break,
                (None, None) => break,
                (Some(t), Some(h)) => !triangles_left || h.0.key < t.0.key,
                (None, Some(_)) => true,
                (Some(_), None) => false,
            };
            if take_hole {
                let std::cmp::Reverse(e) = holes.pop().expect("peeked");
                let r = e.id as usize;
                if self.rings[r].len == 0 || self.rings[r].version != e.version {
                    continue;
                }
                let pts = self.ring_points(r);
                let area_m2 = signed_area2(&pts).abs() / 2.0;
                // Unaffordable now means unaffordable for good: the remaining budget only shrinks.
                if spent_m2 + area_m2 > budget_m2 || !self.can_fill_hole(r, &pts) {
                    continue;
                }
                filled_m2 += area_m2;
                self.fill_hole(r);
                continue;
            }
            let std::cmp::Reverse(e) = tri.pop().expect("peeked");
            let x = &self.v[e.id as usize];
            if !x.alive || x.version != e.version || !self.can_remove(e.id) {
                continue;
            }
            // Ordered by area, so the first triangle that does not fit ends the triangle fills.
            if spent_m2 + e.key > budget_m2 {
                triangles_left = false;
                tri.clear();
                continue;
            }
            if self.turn2(e.id) < 0.0 {
                filled_m2 += e.key;
            } else {
                cut_m2 += e.key;
            }
            let (p, n, r) = (x.prev, x.next, x.ring as usize);
            self.remove(e.id);
            push_tri(self, &mut tri, p);
            push_tri(self, &mut tri, n);
            push_hole(self, &mut holes, r);
        }
        (filled_m2, cut_m2)
    }

    /// Removes concave vertices, smallest triangle first, among those `qualifies(net, vertex, area m²)` accepts,
    /// until the next one would take the filled area past `budget_m2`; returns the area filled (m²).
    fn fill_concave(&mut self, qualifies: impl Fn(&Net, u32, f64) -> bool, budget_m2: f64) -> f64 {
        let mut heap = BinaryHeap::new();
        let push = |net: &Net, heap: &mut BinaryHeap<std::cmp::Reverse<Entry>>, id: u32| {
            let area_m2 = -net.turn2(id) / 2.0;
            if area_m2 > 0.0 && qualifies(net, id, area_m2) {
                heap.push(std::cmp::Reverse(Entry {
                    key: area_m2,
                    id,
                    version: net.v[id as usize].version,
                }));
            }
        };
        for id in 0..self.v.len() as u32 {
            push(self, &mut heap, id);
        }
        let mut spent_m2 = 0.0;
        while let Some(std::cmp::Reverse(e)) = heap.pop() {
            let x = &self.v[e.id as usize];
            if !x.alive || x.version != e.version || !self.can_remove(e.id) {
                continue;
            }
            // The heap is ordered by area, so the first triangle that does not fit ends the pass.
            if spent_m2 + e.key > budget_m2 {
                break;
            }
            spent_m2 += e.key;
            let (p, n) = (x.prev, x.next);
            self.remove(e.id);
            push(self, &mut heap, p);
            push(self, &mut heap, n);
        }
        spent_m2
    }

    /// True when the vertex may go in pass 2: its angle exceeds the threshold, and it is concave, straight,
    /// or convex within `CONVEX_COLLINEAR_TOL_M` of the chord.
    fn collinear_candidate(&self, id: u32, max_angle_rad: f64) -> Option<f64> {
        let a = self.angle(id);
        if a <= max_angle_rad {
            return None;
        }
        if self.turn2(id) > 0.0 {
            let [p, x, n] = self.triangle(id);
            if point_segment_dist2(x, p, n) > CONVEX_COLLINEAR_TOL_M * CONVEX_COLLINEAR_TOL_M {
                return None;
            }
        }
        Some(a)
    }

    /// Pass 2: most collinear vertex first while its angle > `max_angle_rad`; a concave one only while the area
    /// it fills keeps the running total within `budget_m2`, and with `count_cuts` a convex one too only while the
    /// area it cuts does (without, a convex vertex goes within `CONVEX_COLLINEAR_TOL_M` of its chord, uncounted).
    /// Returns the area the removals filled and the area counted as cut (m²).
    fn remove_collinear(
        &mut self,
        max_angle_rad: f64,
        budget_m2: f64,
        count_cuts: bool,
    ) -> (f64, f64) {
        let mut heap = BinaryHeap::new();
        let push = |net: &Net, heap: &mut BinaryHeap<Entry>, id: u32| {
            if let Some(a) = net.collinear_candidate(id, max_angle_rad) {
                heap.push(Entry {
                    key: a,
                    id,
                    version: net.v[id as usize].version,
                });
            }
        };
        for id in 0..self.v.len() as u32 {
            push(self, &mut heap, id);
        }
        let (mut filled_m2, mut cut_m2) = (0.0, 0.0);
        while let Some(e) = heap.pop() {
            let x = &self.v[e.id as usize];
            if !x.alive || x.version != e.version || !self.can_remove(e.id) {
                continue;
            }
            let turn_m2 = self.turn2(e.id) / 2.0;
            let (fill_m2, cut_here_m2) = if turn_m2 < 0.0 {
                (-turn_m2, 0.0)
            } else if count_cuts {
                (0.0, turn_m2)
            } else {
                (0.0, 0.0)
            };
            if filled_m2 + cut_m2 + fill_m2 + cut_here_m2 > budget_m2 {
                continue;
            }
            filled_m2 += fill_m2;
            cut_m2 += cut_here_m2;
            let (p, n) = (x.prev, x.next);
            self.remove(e.id);
            push(self, &mut heap, p);
            push(self, &mut heap, n);
        }
        (filled_m2, cut_m2)
    }

    fn into_footprint(self, n_polys: usize, delta_a_m2: f64) -> Footprint {
        type Rings = (Vec<[f64; 2]>, Vec<Vec<[f64; 2]>>);
        let mut polys: Vec<Option<Rings>> = vec![None; n_polys];
        for ring in self.rings.iter().filter(|r| r.len > 0) {
            let mut pts = Vec::with_capacity(ring.len);
            let mut id = ring.first;
            for _ in 0..ring.len {
                pts.push(self.v[id as usize].pos);
                id = self.v[id as usize].next;
            }
            debug_assert_eq!(id, ring.first, "ring links broken");
            match &mut polys[ring.poly] {
                None => polys[ring.poly] = Some((pts, Vec::new())),
                Some((_, holes)) => {
                    if signed_area2(&pts).abs() / 2.0 >= delta_a_m2 {
                        holes.push(pts);
                    }
                }
            }
        }
        MultiPolygon(
            polys
                .into_iter()
                .flatten()
                .map(|(ext, holes)| {
                    Polygon::new(
                        closed_ring(&ext),
                        holes.iter().map(|h| closed_ring(h)).collect(),
                    )
                })
                .collect(),
        )
    }
}

/// Even-odd test of `p` against the closed ring `pts` (points on the boundary may go either way).
fn point_in_ring(p: [f64; 2], pts: &[[f64; 2]]) -> bool {
    let mut inside = false;
    let mut j = pts.len() - 1;
    for i in 0..pts.len() {
        let (a, b) = (pts[i], pts[j]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]
        {
            inside = !inside;
        }
        j = i;
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::merge::tests::{rect, uncovered_m2};
    use geo::{Area, Validation};
    use geo_types::{polygon, LineString};
    use proptest::prelude::*;

    #[test]
    fn budgeted_fill_covers_the_input_and_stays_within_its_budget() {
        // A comb: a 40 × 10 bar with five 2 × 4 teeth cut into its top edge, each tooth gap 8 m².
        let mut ring = vec![(0.0, 0.0), (40.0, 0.0), (40.0, 10.0)];
        for k in (0..5).rev() {
            let x = 4.0 + 8.0 * k as f64;
            ring.extend([(x + 2.0, 10.0), (x + 2.0, 6.0), (x, 6.0), (x, 10.0)]);
        }
        ring.push((0.0, 10.0));
        let fp = MultiPolygon(vec![Polygon::new(LineString::from(ring), vec![])]);
        for budget in [0.0, 5.0, 17.0, 40.0, 1e6] {
            let (s, added) = fill_concave_within(&fp, budget, 175.0);
            assert!(added <= budget + 1e-9, "budget {budget}: added {added}");
            assert!(
                uncovered_m2(&[&fp], &s) < 1e-9,
                "budget {budget}: lost area"
            );
            assert!((s.unsigned_area() - fp.unsigned_area() - added).abs() < 1e-6);
            assert!(s.is_valid(), "budget {budget}: {s:?}");
        }
        // Each gap is two 4 m² triangles and leaves two straight vertices behind once filled: 17 m² fills
        // exactly two gaps; a huge budget fills all five, leaving the bar's 4 corners.
        let n = vertex_count(&fp);
        assert_eq!(
            vertex_count(&fill_concave_within(&fp, 17.0, 175.0).0),
            n - 8
        );
        assert_eq!(vertex_count(&fill_concave_within(&fp, 1e6, 175.0).0), 4);
    }

    #[test]
    fn budgeted_fill_takes_a_whole_courtyard_when_it_is_the_cheaper_vertex_saving() {
        // A 30 × 30 block with a 4 × 4 courtyard (16 m², 4 vertices: 4 m² a vertex) and one 1 × 10 notch in its
        // top edge (two 5 m² concave triangles: 5 m² a vertex).
        let mut fp = with_hole(4.0);
        let ext: Vec<(f64, f64)> = vec![
            (0.0, 0.0),
            (30.0, 0.0),
            (30.0, 30.0),
            (15.5, 30.0),
            (15.5, 20.0),
            (14.5, 20.0),
            (14.5, 30.0),
            (0.0, 30.0),
        ];
        fp.0[0] = Polygon::new(LineString::from(ext), fp.0[0].interiors().to_vec());
        assert!(fp.is_valid());
        // 16 m² buys the courtyard (4 vertices), not the notch (10 m² for 2 vertices and then its mouth).
        let (s, added) = fill_concave_within(&fp, 16.5, 175.0);
        assert!((added - 16.0).abs() < 1e-9, "added {added}");
        assert!(s.0[0].interiors().is_empty());
        assert_eq!(s.0[0].exterior().0.len() - 1, 8, "the notch is kept");
        // 26 m² buys both; everything left is the square.
        let (s, added) = fill_concave_within(&fp, 26.5, 175.0);
        assert!((added - 26.0).abs() < 1e-9, "added {added}");
        assert_eq!(vertex_count(&s), 4);
        // Less than either: the courtyard's corners are concave too, but each corner triangle is 8 m², so
        // 6 m² fills one notch triangle (5 m²) only and the courtyard stays whole.
        let (s, added) = fill_concave_within(&fp, 6.0, 175.0);
        assert!((added - 5.0).abs() < 1e-9, "added {added}");
        assert_eq!(s.0[0].interiors().len(), 1);
    }

    #[test]
    fn reoutline_cuts_small_corners_where_filling_would_cost_more() {
        // A 20 × 10 bar with a 1 × 1 tooth standing out of its top edge: the tooth's two convex corners cost
        // 0.5 m² each to cut, its two concave feet 0.5 m² to fill, so a budget of 1 m² takes the tooth away;
        // fill-only cannot (filling the feet makes the tooth a wider bump with the same vertex count).
        let fp = MultiPolygon(vec![polygon![
            (x: 0.0, y: 0.0), (x: 20.0, y: 0.0), (x: 20.0, y: 10.0), (x: 11.0, y: 10.0), (x: 11.0, y: 11.0),
            (x: 10.0, y: 11.0), (x: 10.0, y: 10.0), (x: 0.0, y: 10.0)
        ]]);
        let r = reoutline_within(&fp, 1.0, 175.0);
        assert!(r.footprint.is_valid());
        assert_eq!(vertex_count(&r.footprint), 4, "{:?}", r.footprint);
        assert!(r.filled_m2 + r.cut_m2 <= 1.0 + 1e-9);
        // The changed area is at most what was counted.
        let changed = uncovered_m2(&[&fp], &r.footprint) + uncovered_m2(&[&r.footprint], &fp);
        assert!(changed <= r.filled_m2 + r.cut_m2 + 1e-9, "{changed}");
        let (filled_only, _) = fill_concave_within(&fp, 1.0, 175.0);
        assert!(vertex_count(&filled_only) > 4);
        // No budget, no change.
        assert_eq!(reoutline_within(&fp, 0.0, 175.0).footprint, fp);
    }

    #[test]
    fn budgeted_fill_never_fills_a_courtyard_around_an_island() {
        // A courtyard with another polygon of the same footprint standing in it: filling the courtyard would
        // overlap that polygon, so only budget for the island's own notches could be spent.
        let block = with_hole(20.0);
        let island = rect(12.0, 12.0, 18.0, 18.0);
        let fp = MultiPolygon(vec![block.0[0].clone(), island.0[0].clone()]);
        assert!(fp.is_valid());
        let (s, added) = fill_concave_within(&fp, 1e6, 175.0);
        assert!(s.is_valid(), "{:?}", s.validation_errors());
        assert_eq!(s.0.len(), 2);
        assert_eq!(
            s.0[0].interiors().len(),
            1,
            "the courtyard around the island is kept"
        );
        assert!(added < 1e-9, "added {added}");
    }

    #[test]
    fn hairline_slit_is_filled_though_its_triangles_exceed_delta_a() {
        // A 30 × 30 block with a 0.2 m wide, 20 m deep slit from its top edge (two row houses bridged
        // at one end): each slit triangle is 2 m², above δa = 1 m², but 0.2 m < 0.25·√1 m.
        let fp = MultiPolygon(vec![polygon![
            (x: 0.0, y: 0.0), (x: 30.0, y: 0.0), (x: 30.0, y: 30.0), (x: 15.2, y: 30.0),
            (x: 15.2, y: 10.0), (x: 15.0, y: 10.0), (x: 15.0, y: 30.0), (x: 0.0, y: 30.0)
        ]]);
        let s = simplify_footprint(&fp, 1.0, 175.0);
        assert_eq!(vertex_count(&s), 4, "{s:?}");
        assert!(uncovered_m2(&[&fp], &s) < 1e-9);
        assert!((s.unsigned_area() - 900.0).abs() < 1e-9);
    }

    fn vertex_count(fp: &Footprint) -> usize {
        fp.0.iter()
            .flat_map(|p| std::iter::once(p.exterior()).chain(p.interiors()))
            .map(|r| r.0.len() - 1)
            .sum()
    }

    fn vertices(fp: &Footprint) -> Vec<[f64; 2]> {
        fp.0.iter()
            .flat_map(|p| std::iter::once(p.exterior()).chain(p.interiors()))
            .flat_map(|r| r.0.iter().map(|c| [c.x, c.y]))
            .collect()
    }

    /// A 10 × 10 square with a notch of `w` × `d` m in its top edge.
    fn notched(w: f64, d: f64) -> Footprint {
        MultiPolygon(vec![
            polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.0), (x: 10.0, y: 10.0),
            (x: 5.0 + w, y: 10.0), (x: 5.0 + w, y: 10.0 - d), (x: 5.0, y: 10.0 - d), (x: 5.0, y: 10.0),
            (x: 0.0, y: 10.0)],
        ])
    }

    #[test]
    fn notch_smaller_than_delta_a_is_filled() {
        let s = simplify_footprint(&notched(1.0, 1.0), 2.0, 175.0);
        assert_eq!(vertex_count(&s), 4);
        assert!((s.unsigned_area() - 100.0).abs() < 1e-9);
        // An L-shaped building: the 5 × 5 missing corner is one concave triangle of 12.5 m².
        let l = MultiPolygon(vec![
            polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.0), (x: 10.0, y: 5.0),
            (x: 5.0, y: 5.0), (x: 5.0, y: 10.0), (x: 0.0, y: 10.0)],
        ]);
        let s = simplify_footprint(&l, 13.0, 175.0);
        assert_eq!(vertex_count(&s), 5);
        assert!((s.unsigned_area() - 87.5).abs() < 1e-9);
    }

    #[test]
    fn notch_larger_than_delta_a_is_kept() {
        let fp = notched(3.0, 4.0);
        let s = simplify_footprint(&fp, 2.0, 175.0);
        assert_eq!(vertex_count(&s), 8);
        assert!((s.unsigned_area() - fp.unsigned_area()).abs() < 1e-9);
    }

    fn with_hole(side: f64) -> Footprint {
        let h = 15.0 - side / 2.0;
        MultiPolygon(vec![Polygon::new(
            rect(0.0, 0.0, 30.0, 30.0).0[0].exterior().clone(),
            vec![LineString::from(vec![
                (h, h),
                (h, h + side),
                (h + side, h + side),
                (h + side, h),
                (h, h),
            ])],
        )])
    }

    #[test]
    fn courtyard_larger_than_delta_a_is_kept_and_small_hole_filled() {
        let s = simplify_footprint(&with_hole(10.0), 20.0, 175.0);
        assert_eq!(s.0[0].interiors().len(), 1);
        assert_eq!(s.0[0].interiors()[0].0.len(), 5);
        assert!((s.unsigned_area() - 800.0).abs() < 1e-9);
        let s = simplify_footprint(&with_hole(2.0), 20.0, 175.0);
        assert!(s.0[0].interiors().is_empty());
    }

    #[test]
    fn hole_corners_count_as_concave_from_the_solid() {
        // A 10 × 10 courtyard whose east side bulges 1 m into the solid at (21, 15): seen from the solid
        // that corner is concave (5 m² triangle) and goes; the square corners (25 m² and more) stay.
        let fp = MultiPolygon(vec![Polygon::new(
            rect(0.0, 0.0, 30.0, 30.0).0[0].exterior().clone(),
            vec![LineString::from(vec![
                (10.0, 10.0),
                (10.0, 20.0),
                (20.0, 20.0),
                (21.0, 15.0),
                (20.0, 10.0),
                (10.0, 10.0),
            ])],
        )]);
        let s = simplify_footprint(&fp, 10.0, 175.0);
        assert_eq!(s.0[0].interiors()[0].0.len(), 5);
        assert!((s.unsigned_area() - 800.0).abs() < 1e-9);
    }

    #[test]
    fn near_collinear_vertices_go_only_when_concave_or_within_tolerance() {
        // Concave bend of 179° on the bottom edge: removed (adds a sliver).
        let concave = MultiPolygon(vec![
            polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.087), (x: 20.0, y: 0.0),
            (x: 20.0, y: 10.0), (x: 0.0, y: 10.0)],
        ]);
        assert_eq!(vertex_count(&simplify_footprint(&concave, 0.0, 175.0)), 4);
        // Convex bend of 179°, 8.7 cm off the chord: kept, it would uncover solid.
        let convex = MultiPolygon(vec![
            polygon![(x: 0.0, y: 0.0), (x: 10.0, y: -0.087), (x: 20.0, y: 0.0),
            (x: 20.0, y: 10.0), (x: 0.0, y: 10.0)],
        ]);
        assert_eq!(vertex_count(&simplify_footprint(&convex, 0.0, 175.0)), 5);
        // Convex but within 1 cm: removed.
        let tiny = MultiPolygon(vec![
            polygon![(x: 0.0, y: 0.0), (x: 10.0, y: -0.01), (x: 20.0, y: 0.0),
            (x: 20.0, y: 10.0), (x: 0.0, y: 10.0)],
        ]);
        assert_eq!(vertex_count(&simplify_footprint(&tiny, 0.0, 175.0)), 4);
    }

    #[test]
    fn filling_a_notch_never_swallows_another_polygon() {
        // A U with a separate building standing in its 4 × 4 notch; δa far above the notch area.
        let u = MultiPolygon(vec![
            polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.0), (x: 10.0, y: 10.0), (x: 7.0, y: 10.0),
                (x: 7.0, y: 5.0), (x: 3.0, y: 5.0), (x: 3.0, y: 10.0), (x: 0.0, y: 10.0)],
            polygon![(x: 4.0, y: 6.0), (x: 6.0, y: 6.0), (x: 6.0, y: 8.0), (x: 4.0, y: 8.0)],
        ]);
        let s = simplify_footprint(&u, 1000.0, 175.0);
        assert!(s.is_valid(), "{:?}", s.validation_errors());
        assert_eq!(s.0.len(), 2);
        assert!(uncovered_m2(&[&u], &s) < 1e-9);
    }

    #[test]
    fn rings_never_drop_below_three_vertices() {
        let tri = MultiPolygon(vec![
            polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.0), (x: 5.0, y: 0.01)],
        ]);
        let s = simplify_footprint(&tri, 1e9, 175.0);
        assert_eq!(vertex_count(&s), 3);
        assert!(simplify_footprint(&MultiPolygon(vec![]), 10.0, 175.0)
            .0
            .is_empty());
    }

    #[test]
    fn boston_merged_groups_simplify_valid_and_covering() {
        use crate::merge::tests::{boston_sample, gap_mst_hints, grid_groups};
        let Some(fps) = boston_sample(1000) else {
            return;
        };
        let a_avg_m2 = fps.iter().map(|f| f.unsigned_area()).sum::<f64>() / fps.len() as f64;
        let merged: Vec<Footprint> = grid_groups(&fps, 80.0)
            .iter()
            .map(|g| {
                let parts: Vec<&Footprint> = g.iter().map(|&i| &fps[i]).collect();
                crate::merge::merge_footprints(&parts, &gap_mst_hints(&parts)).footprint
            })
            .collect();
        let before: usize = merged.iter().map(vertex_count).sum();
        for delta_a_m2 in [a_avg_m2 / 50.0, a_avg_m2 / 5.0] {
            let t0 = std::time::Instant::now();
            let out: Vec<Footprint> = merged
                .iter()
                .map(|m| simplify_footprint(m, delta_a_m2, 175.0))
                .collect();
            let dt = t0.elapsed();
            let after: usize = out.iter().map(vertex_count).sum();
            eprintln!(
                "boston simplify δa = {delta_a_m2:.1} m²: {before} → {after} vertices in {dt:?}"
            );
            assert!(after < before);
            for (m, s) in merged.iter().zip(&out) {
                assert!(s.is_valid(), "{:?}", s.validation_errors());
                let input = vertices(m);
                assert!(vertices(s).iter().all(|v| input.contains(v)));
                let perimeter: f64 =
                    m.0.iter()
                        .flat_map(|p| std::iter::once(p.exterior()).chain(p.interiors()))
                        .flat_map(|r| r.0.windows(2))
                        .map(|w| (w[1].x - w[0].x).hypot(w[1].y - w[0].y))
                        .sum();
                assert!(uncovered_m2(&[m], s) <= perimeter * CONVEX_COLLINEAR_TOL_M + 1e-9);
            }
        }
    }

    /// A star-shaped polygon: radii around (0, 0) at sorted angles, so it is simple.
    fn star(radii: &[(f64, f64)]) -> Footprint {
        let mut pts: Vec<(f64, f64)> = radii.to_vec();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        pts.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-3);
        let mut ring: Vec<(f64, f64)> = pts
            .iter()
            .map(|&(t, r)| (r * t.cos(), r * t.sin()))
            .collect();
        ring.push(ring[0]);
        MultiPolygon(vec![Polygon::new(LineString::from(ring), vec![])])
    }

    /// Rectangles (x, y, w, h) as footprints, and their merge (bridged in list order).
    fn merge_rects(rects: &[(f64, f64, f64, f64)]) -> (Vec<Footprint>, Footprint) {
        let parts: Vec<Footprint> = rects
            .iter()
            .map(|&(x, y, w, h)| rect(x, y, x + w, y + h))
            .collect();
        let refs: Vec<&Footprint> = parts.iter().collect();
        let hints: Vec<(usize, usize)> = (1..parts.len()).map(|i| (i - 1, i)).collect();
        let merged = crate::merge::merge_footprints(&refs, &hints).footprint;
        (parts, merged)
    }

    /// Summed length of the exteriors (m).
    fn exterior_perimeter_m(fp: &Footprint) -> f64 {
        fp.0.iter()
            .flat_map(|p| p.exterior().0.windows(2))
            .map(|w| (w[1].x - w[0].x).hypot(w[1].y - w[0].y))
            .sum()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        /// Scanning the vertices and searching the R-tree find the same vertices: the budgeted fills, cuts and
        /// collinear removals give the same outline either way.
        #[test]
        fn scanning_and_indexed_nets_reoutline_alike(
            rects in prop::collection::vec((0.0f64..60.0, 0.0f64..60.0, 2.0f64..20.0, 2.0f64..20.0), 2..12),
            budget in 0.0f64..400.0,
            angle in 150.0f64..180.0,
        ) {
            let (_, merged) = merge_rects(&rects);
            let run = |scan_max: usize| {
                let mut net = Net::with_scan_max(&ring_specs(&merged, 0.0), scan_max);
                assert_eq!(net.index.is_none(), scan_max == usize::MAX || net.v.is_empty());
                let (f1, c1) = net.fill_concave_and_holes(budget, true);
                let (f2, c2) = net.remove_collinear(angle.to_radians(), budget - f1 - c1, true);
                (net.into_footprint(merged.0.len(), 0.0), f1 + f2, c1 + c2)
            };
            prop_assert_eq!(run(usize::MAX), run(0));
        }

        #[test]
        fn simplified_is_valid_subset_and_covers_input(
            radii in prop::collection::vec((0.0f64..std::f64::consts::TAU, 2.0f64..30.0), 4..60),
            delta_a in 0.0f64..200.0,
            angle in 150.0f64..180.0,
        ) {
            let fp = star(&radii);
            prop_assume!(fp.0[0].exterior().0.len() >= 4 && fp.is_valid());
            let s = simplify_footprint(&fp, delta_a, angle);
            prop_assert!(s.is_valid(), "{:?}", s.validation_errors());
            let input = vertices(&fp);
            prop_assert!(vertices(&s).iter().all(|v| input.contains(v)));
            for p in &s.0 {
                prop_assert!(p.exterior().0.len() >= 4);
            }
            prop_assert!(uncovered_m2(&[&fp], &s) <= exterior_perimeter_m(&fp) * CONVEX_COLLINEAR_TOL_M + 1e-9);
        }

        #[test]
        fn budgeted_fill_of_a_merge_is_valid_covering_and_within_budget(
            rects in prop::collection::vec((0.0f64..60.0, 0.0f64..60.0, 2.0f64..20.0, 2.0f64..20.0), 2..10),
            budget in 0.0f64..400.0,
        ) {
            // Overlapping rectangles merge into outlines with notches and courtyards.
            let (_, merged) = merge_rects(&rects);
            prop_assume!(merged.is_valid());
            let (s, added) = fill_concave_within(&merged, budget, 175.0);
            prop_assert!(s.is_valid(), "{:?}", s.validation_errors());
            prop_assert!(added <= budget + 1e-9);
            // `added` is what the fills took; a convex near-straight vertex the collinear pass drops may give a
            // sliver back, so the area grows by at most `added`.
            prop_assert!(s.unsigned_area() - merged.unsigned_area() <= added + 1e-6 * merged.unsigned_area().max(1.0),
                "area grew by {} but {added} was reported", s.unsigned_area() - merged.unsigned_area());
            let input = vertices(&merged);
            prop_assert!(vertices(&s).iter().all(|v| input.contains(v)));
            prop_assert!(vertex_count(&s) <= vertex_count(&merged));
            prop_assert!(uncovered_m2(&[&merged], &s) <= exterior_perimeter_m(&merged) * CONVEX_COLLINEAR_TOL_M + 1e-9);
        }

        #[test]
        fn reoutline_of_a_merge_is_valid_and_changes_at_most_what_it_counts(
            rects in prop::collection::vec((0.0f64..60.0, 0.0f64..60.0, 2.0f64..20.0, 2.0f64..20.0), 2..10),
            budget in 0.0f64..400.0,
        ) {
            let (_, merged) = merge_rects(&rects);
            prop_assume!(merged.is_valid());
            let r = reoutline_within(&merged, budget, 175.0);
            prop_assert!(r.footprint.is_valid(), "{:?}", r.footprint.validation_errors());
            prop_assert!(r.filled_m2 >= 0.0 && r.cut_m2 >= 0.0);
            prop_assert!(r.filled_m2 + r.cut_m2 <= budget + 1e-9);
            let input = vertices(&merged);
            prop_assert!(vertices(&r.footprint).iter().all(|v| input.contains(v)));
            prop_assert!(vertex_count(&r.footprint) <= vertex_count(&merged));
            let changed = uncovered_m2(&[&merged], &r.footprint) + uncovered_m2(&[&r.footprint], &merged);
            prop_assert!(changed <= r.filled_m2 + r.cut_m2 + 1e-6 * merged.unsigned_area().max(1.0),
                "changed {changed} > counted {} + {}", r.filled_m2, r.cut_m2);
            prop_assert_eq!(r.footprint.0.len(), merged.0.len());
        }

        #[test]
        fn simplified_merge_stays_valid_and_covers_the_parts(
            rects in prop::collection::vec((0.0f64..60.0, 0.0f64..60.0, 2.0f64..20.0, 2.0f64..20.0), 2..8),
            delta_a in 0.0f64..100.0,
        ) {
            let (parts, merged) = merge_rects(&rects);
            let s = simplify_footprint(&merged, delta_a, 175.0);
            prop_assert!(s.is_valid(), "{:?}", s.validation_errors());
            let input = vertices(&merged);
            prop_assert!(vertices(&s).iter().all(|v| input.contains(v)));
            // Only a convex near-straight vertex may give up solid: a sliver ≤ CONVEX_COLLINEAR_TOL_M wide.
            let refs: Vec<&Footprint> = parts.iter().collect();
            prop_assert!(uncovered_m2(&refs, &s) <= exterior_perimeter_m(&merged) * CONVEX_COLLINEAR_TOL_M + 1e-9);
        }
    }
}
