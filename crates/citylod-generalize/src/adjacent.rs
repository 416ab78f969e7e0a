//! Adjacent distance between two footprints (seed 000 §3.1.1): d = d_min·(1 − N·λ) with
//! N = (l′₁/l₁ + l′₂/l₂)/2 from the adjacent sides, and the convex-hull reduction of candidate
//! vertices (§3.1.2). Local ENU metres in and out. Invariant: touching, overlapping or contained
//! footprints have d = 0; otherwise 0 < (1 − λ)·d_min ≤ d ≤ d_min, and the hull reduction gives the
//! same sides and the same d as the brute-force search (ties broken geometrically, never by index).

use citylod_model::Footprint;
use geo_types::{Coord, Line};

/// The result of comparing two footprints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adjacency {
    /// Adjacent distance d = d_min·(1 − N·λ) (m); 0 when the footprints touch, overlap or contain
    /// one another; `f64::INFINITY` when a footprint has no usable ring (fewer than 3 distinct points).
    pub d_m: f64,
    /// Smallest distance between the two footprints' boundaries (m).
    pub d_min_m: f64,
    /// N ∈ [0, 1]: how parallel and fully facing the adjacent sides are (1 = parallel, fully facing).
    pub n_factor: f64,
    /// The adjacent sides (side of `a`, side of `b`), each with its endpoints in lexicographic order;
    /// `None` when d = 0 or a footprint is degenerate.
    pub sides: Option<[Line<f64>; 2]>,
}

/// Adjacent distance with λ = `lambda` (seed default 0.6), using the convex-hull reduction of
/// candidate vertices when both footprints are single polygons without holes (brute force otherwise).
///
/// ```
/// use citylod_generalize::adjacent_distance;
/// use geo_types::{polygon, MultiPolygon};
/// let a = MultiPolygon(vec![polygon![(x: 0., y: 0.), (x: 10., y: 0.), (x: 10., y: 4.), (x: 0., y: 4.)]]);
/// let b = MultiPolygon(vec![polygon![(x: 0., y: 6.), (x: 10., y: 6.), (x: 10., y: 10.), (x: 0., y: 10.)]]);
/// let adj = adjacent_distance(&a, &b, 0.6);
/// assert!((adj.d_min_m - 2.0).abs() < 1e-12 && (adj.d_m - 0.8).abs() < 1e-12);
/// ```
pub fn adjacent_distance(a: &Footprint, b: &Footprint, lambda: f64) -> Adjacency {
    compute(a, b, lambda, HULL_MIN_WORK)
}

/// Below this many vertex–edge pairs the hull costs more than it saves (typical buildings have 8
/// vertices); both paths give identical results (tested).
const HULL_MIN_WORK: usize = 256;

/// The same as [`adjacent_distance`] but searching every vertex–edge pair (O(m·n)); the reference
/// the hull reduction is tested against.
pub fn adjacent_distance_brute_force(a: &Footprint, b: &Footprint, lambda: f64) -> Adjacency {
    compute(a, b, lambda, usize::MAX)
}

/// A footprint's rings as open, counter-clockwise vertex lists without repeated consecutive points.
struct Rings(Vec<Vec<Coord<f64>>>);

impl Rings {
    fn of(fp: &Footprint) -> Self {
        let mut rings = Vec::new();
        for poly in &fp.0 {
            for ring in std::iter::once(poly.exterior()).chain(poly.interiors()) {
                let mut pts: Vec<Coord<f64>> = Vec::with_capacity(ring.0.len());
                for &c in &ring.0 {
                    if !(c.x.is_finite() && c.y.is_finite()) {
                        continue;
                    }
                    if pts.last() != Some(&c) {
                        pts.push(c);
                    }
                }
                while pts.len() > 1 && pts.first() == pts.last() {
                    pts.pop();
                }
                if pts.len() < 3 {
                    continue;
                }
                if signed_area(&pts) < 0.0 {
                    pts.reverse();
                }
                rings.push(pts);
            }
        }
        Rings(rings)
    }
}

fn signed_area(pts: &[Coord<f64>]) -> f64 {
    let n = pts.len();
    (0..n)
        .map(|i| {
            let (p, q) = (pts[i], pts[(i + 1) % n]);
            p.x * q.y - q.x * p.y
        })
        .sum::<f64>()
        / 2.0
}

/// Which vertices of each ring take part in the search (vertex role); edges incident to a kept
/// vertex take part in the edge role.
struct Keep(Vec<Vec<bool>>);

impl Keep {
    fn all(r: &Rings) -> Self {
        Keep(r.0.iter().map(|ring| vec![true; ring.len()]).collect())
    }
    fn vertex(&self, ring: usize, i: usize) -> bool {
        self.0[ring][i]
    }
    fn edge(&self, ring: usize, i: usize) -> bool {
        let k = &self.0[ring];
        k[i] || k[(i + 1) % k.len()]
    }
}

/// Uses the hull reduction when both footprints are single rings and m·n ≥ `hull_min_work`.
fn compute(a: &Footprint, b: &Footprint, lambda: f64, hull_min_work: usize) -> Adjacency {
    let (ra, rb) = (Rings::of(a), Rings::of(b));
    if ra.0.is_empty() || rb.0.is_empty() {
        return Adjacency {
            d_m: f64::INFINITY,
            d_min_m: f64::INFINITY,
            n_factor: 0.0,
            sides: None,
        };
    }
    if footprints_meet(&ra, &rb) {
        return Adjacency {
            d_m: 0.0,
            d_min_m: 0.0,
            n_factor: 0.0,
            sides: None,
        };
    }
    let use_hull = ra.0.len() == 1
        && rb.0.len() == 1
        && ra.0[0].len().saturating_mul(rb.0[0].len()) >= hull_min_work;
    let (ka, kb) = if use_hull {
        match hull_reduction(&ra.0[0], &rb.0[0]) {
            Some((ka, kb)) => (Keep(vec![ka]), Keep(vec![kb])),
            None => (Keep::all(&ra), Keep::all(&rb)),
        }
    } else {
        (Keep::all(&ra), Keep::all(&rb))
    };

    // One sweep over vertex–edge pairs in both directions (squared distances), keeping every
    // configuration that could still attain d_min within the tolerance. `accept` grows with its
    // argument, so filtering with the running minimum never drops a configuration the final one keeps.
    let accept = |d2: f64| {
        let d = d2.sqrt();
        let tol = 1e-9 * d.max(1.0);
        (d + tol) * (d + tol)
    };
    let mut d2_min = f64::INFINITY;
    let mut bound = f64::INFINITY;
    // (vertex from a?, (ring, vertex), (ring, edge start), squared distance, closest point)
    type Config = (bool, (usize, usize), (usize, usize), f64, Coord<f64>);
    let mut configs: Vec<Config> = Vec::new();
    for (from_a, (rv, kv, re, ke)) in [(true, (&ra, &ka, &rb, &kb)), (false, (&rb, &kb, &ra, &ka))]
    {
        for_each_vertex_edge(rv, kv, re, ke, bound, |v, e, d2, closest| {
            if d2 > bound {
                return bound;
            }
            if d2 < d2_min {
                d2_min = d2;
                bound = accept(d2);
                configs.retain(|c| c.3 <= bound);
            }
            configs.push((from_a, v, e, d2, closest));
            bound
        });
    }
    let d_min = d2_min.sqrt();
    let tol = 1e-9 * d_min.max(1.0);

    // Every configuration attaining d_min proposes adjacent sides; keep the best.
    let mut best: Option<Candidate> = None;
    for &(from_a, (vr, vi), (er, ei), _, closest) in &configs {
        let (rv, re) = if from_a { (&ra, &rb) } else { (&rb, &ra) };
        let ring_v = &rv.0[vr];
        let ring_e = &re.0[er];
        let v_sides = sides_at(ring_v, vi);
        let e0 = ring_e[ei];
        let e1 = ring_e[(ei + 1) % ring_e.len()];
        let e_sides: &[Line<f64>] = &if dist_pt(closest, e0) <= tol {
            sides_at(ring_e, ei)
        } else if dist_pt(closest, e1) <= tol {
            sides_at(ring_e, (ei + 1) % ring_e.len())
        } else {
            [Line::new(e0, e1); 2]
        };
        for sv in v_sides {
            for &se in e_sides {
                let (sa, sb) = if from_a { (sv, se) } else { (se, sv) };
                let c = Candidate::new(sa, sb);
                if best.as_ref().is_none_or(|b| c.better_than(b)) {
                    best = Some(c);
                }
            }
        }
    }
    let Some(best) = best else {
        return Adjacency {
            d_m: f64::INFINITY,
            d_min_m: d_min,
            n_factor: 0.0,
            sides: None,
        };
    };
    Adjacency {
        d_m: d_min * (1.0 - best.n * lambda),
        d_min_m: d_min,
        n_factor: best.n,
        sides: Some([best.sa, best.sb]),
    }
}

/// True when the footprints touch, overlap or one contains the other: some boundary segments meet
/// (closed segments, so shared vertices and shared sides count), or a vertex of one lies inside the
/// other (even–odd over all rings, so a building in another's courtyard is outside it).
fn footprints_meet(ra: &Rings, rb: &Rings) -> bool {
    let bbox_of = |r: &[Coord<f64>]| {
        r.iter().fold(
            [
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            ],
            |b, c| [b[0].min(c.x), b[1].min(c.y), b[2].max(c.x), b[3].max(c.y)],
        )
    };
    for ring_a in &ra.0 {
        let ba = bbox_of(ring_a);
        for ring_b in &rb.0 {
            let bb = bbox_of(ring_b);
            if ba[0] > bb[2] || bb[0] > ba[2] || ba[1] > bb[3] || bb[1] > ba[3] {
                continue;
            }
            let (na, nb) = (ring_a.len(), ring_b.len());
            for i in 0..na {
                let (p1, p2) = (ring_a[i], ring_a[(i + 1) % na]);
                if p1.x.max(p2.x) < bb[0]
                    || p1.x.min(p2.x) > bb[2]
                    || p1.y.max(p2.y) < bb[1]
                    || p1.y.min(p2.y) > bb[3]
                {
                    continue;
                }
                for j in 0..nb {
                    if segments_meet(p1, p2, ring_b[j], ring_b[(j + 1) % nb]) {
                        return true;
                    }
                }
            }
        }
    }
    point_in_rings(ra.0[0][0], rb) || point_in_rings(rb.0[0][0], ra)
}

fn segments_meet(p1: Coord<f64>, p2: Coord<f64>, q1: Coord<f64>, q2: Coord<f64>) -> bool {
    if p1.x.max(p2.x) < q1.x.min(q2.x)
        || q1.x.max(q2.x) < p1.x.min(p2.x)
        || p1.y.max(p2.y) < q1.y.min(q2.y)
        || q1.y.max(q2.y) < p1.y.min(p2.y)
    {
        return false;
    }
    let (d1, d2) = (cross3(q1, q2, p1), cross3(q1, q2, p2));
    let (d3, d4) = (cross3(p1, p2, q1), cross3(p1, p2, q2));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    // Collinear or touching cases: the bounding boxes overlap, so an endpoint on the other's line lies on it.
    let within = |a: Coord<f64>, b: Coord<f64>, p: Coord<f64>| {
        p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
    };
    (d1 == 0.0 && within(q1, q2, p1))
        || (d2 == 0.0 && within(q1, q2, p2))
        || (d3 == 0.0 && within(p1, p2, q1))
        || (d4 == 0.0 && within(p1, p2, q2))
}

fn point_in_rings(p: Coord<f64>, rings: &Rings) -> bool {
    rings.0.iter().filter(|r| point_in_ring(p, r)).count() % 2 == 1
}

/// Angles between sides closer than this are ties (rad). Two aligned rectangles whose corners face
/// each other offer two pairs at angle 0, the facing sides (N = 1) and the collinear ones (N = 0); a
/// city stored on a 0.1 mm grid (a File Geodatabase's 1e-9°) or reprojected turns a 10 m side by
/// ~1e-5 rad, and without a tolerance that noise, not N, picked the pair (d = 0.4·d_min or d_min).
/// 5e-5 rad is half a millimetre over 10 m: it makes Boston from GeoJSON, from a geodatabase in
/// lon/lat and from one in EPSG:26986 cluster alike. Wider tolerances (1e-4 rad and up) also
/// merge angles that differ in the data and were measured to move Delft's coarse errors
/// (docs/coarse-bytes.md, session 33).
const ANGLE_TIE_RAD: f64 = 5e-5;

/// A proposed pair of adjacent sides. Preference: smallest angle between the sides (the paper's
/// rule), then largest N (so that the pair that faces best wins among equals, e.g. two aligned
/// rectangles whose corner pairs also offer their collinear short sides), then coordinates. Angles
/// within [`ANGLE_TIE_RAD`] of each other are equal.
struct Candidate {
    sa: Line<f64>,
    sb: Line<f64>,
    angle: f64,
    n: f64,
}

impl Candidate {
    fn new(sa: Line<f64>, sb: Line<f64>) -> Self {
        let (sa, sb) = (canonical(sa), canonical(sb));
        let (u, v) = (sa.delta(), sb.delta());
        let cross = u.x * v.y - u.y * v.x;
        let dot = u.x * v.x + u.y * v.y;
        let angle = cross.abs().atan2(dot.abs());
        let n = (overlap_ratio(sa, sb) + overlap_ratio(sb, sa)) / 2.0;
        Candidate { sa, sb, angle, n }
    }

    fn better_than(&self, other: &Candidate) -> bool {
        const N_TOL: f64 = 1e-12;
        if (self.angle - other.angle).abs() > ANGLE_TIE_RAD {
            return self.angle < other.angle;
        }
        if (self.n - other.n).abs() > N_TOL {
            return self.n > other.n;
        }
        key(self) < key(other)
    }
}

fn key(c: &Candidate) -> [f64; 8] {
    [
        c.sa.start.x,
        c.sa.start.y,
        c.sa.end.x,
        c.sa.end.y,
        c.sb.start.x,
        c.sb.start.y,
        c.sb.end.x,
        c.sb.end.y,
    ]
}

fn canonical(l: Line<f64>) -> Line<f64> {
    if (l.start.x, l.start.y) <= (l.end.x, l.end.y) {
        l
    } else {
        Line::new(l.end, l.start)
    }
}

/// l′/l: the length of `other` projected onto the line of `side`, clipped to `side`, over |side|.
fn overlap_ratio(side: Line<f64>, other: Line<f64>) -> f64 {
    let d = side.delta();
    let len = d.x.hypot(d.y);
    if len == 0.0 {
        return 0.0;
    }
    let (ux, uy) = (d.x / len, d.y / len);
    let t = |p: Coord<f64>| (p.x - side.start.x) * ux + (p.y - side.start.y) * uy;
    let (t0, t1) = (t(other.start), t(other.end));
    let (lo, hi) = (t0.min(t1).max(0.0), t0.max(t1).min(len));
    ((hi - lo).max(0.0) / len).min(1.0)
}

fn sides_at(ring: &[Coord<f64>], i: usize) -> [Line<f64>; 2] {
    let n = ring.len();
    [
        Line::new(ring[(i + n - 1) % n], ring[i]),
        Line::new(ring[i], ring[(i + 1) % n]),
    ]
}

fn dist_pt(p: Coord<f64>, q: Coord<f64>) -> f64 {
    (p.x - q.x).hypot(p.y - q.y)
}

/// Calls `f((ring, vertex), (ring, edge start), squared distance, closest point on the edge)` for
/// every kept vertex of `rv` against every kept edge of `re`.
/// Calls `f` for every kept (vertex, edge) pair with their squared distance and the closest point, except pairs
/// whose edge's box is already farther from the vertex than the bound `f` last returned (`bound` at first):
/// `f` has no use for those. The box distance is a lower bound of the true one; the margin covers rounding.
fn for_each_vertex_edge(
    rv: &Rings,
    kv: &Keep,
    re: &Rings,
    ke: &Keep,
    mut bound: f64,
    mut f: impl FnMut((usize, usize), (usize, usize), f64, Coord<f64>) -> f64,
) {
    // The kept edges once, with their ends and boxes: (ring, edge), start, end, [min x, min y, max x, max y].
    type Edge = ((usize, usize), Coord<f64>, Coord<f64>, [f64; 4]);
    let edges: Vec<Edge> =
        re.0.iter()
            .enumerate()
            .flat_map(|(er, ring_e)| {
                let n = ring_e.len();
                (0..n).filter(move |&ei| ke.edge(er, ei)).map(move |ei| {
                    let (q0, q1) = (ring_e[ei], ring_e[if ei + 1 == n { 0 } else { ei + 1 }]);
                    let b = [
                        q0.x.min(q1.x),
                        q0.y.min(q1.y),
                        q0.x.max(q1.x),
                        q0.y.max(q1.y),
                    ];
                    ((er, ei), q0, q1, b)
                })
            })
            .collect();
    for (vr, ring_v) in rv.0.iter().enumerate() {
        for (vi, &p) in ring_v.iter().enumerate() {
            if !kv.vertex(vr, vi) {
                continue;
            }
            for &(e, q0, q1, b) in &edges {
                let gx = (b[0] - p.x).max(p.x - b[2]).max(0.0);
                let gy = (b[1] - p.y).max(p.y - b[3]).max(0.0);
                if gx * gx + gy * gy > bound * (1.0 + 1e-9) {
                    continue;
                }
                let c = closest_on_segment(p, q0, q1);
                let (dx, dy) = (p.x - c.x, p.y - c.y);
                bound = f((vr, vi), e, dx * dx + dy * dy, c);
            }
        }
    }
}

fn closest_on_segment(p: Coord<f64>, q0: Coord<f64>, q1: Coord<f64>) -> Coord<f64> {
    let (dx, dy) = (q1.x - q0.x, q1.y - q0.y);
    let len2 = dx * dx + dy * dy;
    if len2 == 0.0 {
        return q0;
    }
    let t = (((p.x - q0.x) * dx + (p.y - q0.y) * dy) / len2).clamp(0.0, 1.0);
    if t == 0.0 {
        q0
    } else if t == 1.0 {
        q1
    } else {
        Coord {
            x: q0.x + t * dx,
            y: q0.y + t * dy,
        }
    }
}

fn cross3(o: Coord<f64>, a: Coord<f64>, b: Coord<f64>) -> f64 {
    (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x)
}

/// §3.1.2: the vertices of two disjoint CCW rings that can hold the closest pair. Returns `None`
/// (search everything) when the combined hull alternates between the rings more than twice or the
/// pocket holding the smaller ring cannot be found.
fn hull_reduction(a: &[Coord<f64>], b: &[Coord<f64>]) -> Option<(Vec<bool>, Vec<bool>)> {
    let rings = [a, b];
    let hull = convex_hull(a, b);
    let transitions = (0..hull.len())
        .filter(|&i| hull[i].0 != hull[(i + 1) % hull.len()].0)
        .count();
    match transitions {
        2 => {
            let mut keep = [vec![false; a.len()], vec![false; b.len()]];
            for (which, k) in keep.iter_mut().enumerate() {
                // The run of this ring's hull vertices, from where the hull enters it to where it leaves.
                let h = hull.len();
                let start =
                    (0..h).find(|&i| hull[i].0 == which && hull[(i + h - 1) % h].0 != which)?;
                let mut end = start;
                while hull[(end + 1) % h].0 == which {
                    end = (end + 1) % h;
                }
                let (entry, exit) = (hull[start].1, hull[end].1);
                // Keep the ring from the exit CCW round to the entry: the side facing the other ring.
                // A run of one vertex hides nothing: the whole ring is kept.
                let n = rings[which].len();
                if entry == exit {
                    k.fill(true);
                    continue;
                }
                let mut i = exit;
                loop {
                    k[i] = true;
                    if i == entry {
                        break;
                    }
                    i = (i + 1) % n;
                }
            }
            let [ka, kb] = keep;
            Some((ka, kb))
        }
        0 => {
            let outer = hull[0].0;
            let inner = 1 - outer;
            let ring = rings[outer];
            let n = ring.len();
            let probe = rings[inner][0];
            let h = hull.len();
            for i in 0..h {
                let (i0, i1) = (hull[i].1, hull[(i + 1) % h].1);
                if (i0 + 1) % n == i1 {
                    continue;
                }
                let mut chain = Vec::new();
                let mut j = i0;
                loop {
                    chain.push(j);
                    if j == i1 {
                        break;
                    }
                    j = (j + 1) % n;
                }
                let pocket: Vec<Coord<f64>> = chain.iter().map(|&j| ring[j]).collect();
                if point_in_ring(probe, &pocket) {
                    let mut k_outer = vec![false; n];
                    for &j in &chain {
                        k_outer[j] = true;
                    }
                    let k_inner = vec![true; rings[inner].len()];
                    return Some(if outer == 0 {
                        (k_outer, k_inner)
                    } else {
                        (k_inner, k_outer)
                    });
                }
            }
            None
        }
        _ => None,
    }
}

/// Strict convex hull (collinear points dropped) of both rings, CCW, as (ring 0/1, vertex index).
fn convex_hull(a: &[Coord<f64>], b: &[Coord<f64>]) -> Vec<(usize, usize)> {
    let rings = [a, b];
    let mut pts: Vec<(usize, usize)> = (0..a.len())
        .map(|i| (0, i))
        .chain((0..b.len()).map(|i| (1, i)))
        .collect();
    let at = |p: (usize, usize)| rings[p.0][p.1];
    pts.sort_by(|&p, &q| {
        let (cp, cq) = (at(p), at(q));
        cp.x.total_cmp(&cq.x)
            .then(cp.y.total_cmp(&cq.y))
            .then(p.cmp(&q))
    });
    pts.dedup_by(|p, q| at(*p) == at(*q));
    if pts.len() < 3 {
        return pts;
    }
    let mut hull: Vec<(usize, usize)> = Vec::with_capacity(pts.len() + 1);
    for pass in 0..2 {
        let base = hull.len();
        let iter: Box<dyn Iterator<Item = &(usize, usize)>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= base + 2
                && cross3(at(hull[hull.len() - 2]), at(hull[hull.len() - 1]), at(p)) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// Even–odd point in ring test (boundary points may go either way).
fn point_in_ring(p: Coord<f64>, ring: &[Coord<f64>]) -> bool {
    let n = ring.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (ring[i], ring[(i + 1) % n]);
        if (a.y > p.y) != (b.y > p.y) {
            let x = a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
            if p.x < x {
                inside = !inside;
            }
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo_types::{LineString, MultiPolygon, Polygon};
    use proptest::prelude::*;

    fn fp(pts: &[(f64, f64)]) -> Footprint {
        MultiPolygon(vec![Polygon::new(LineString::from(pts.to_vec()), vec![])])
    }

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Footprint {
        fp(&[(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    /// Figure 1 of the paper: d_min = 2 m throughout, from (a) parallel fully facing to (e) a
    /// vertex pointing at a side; d must grow from (a) to (e). Values worked out by hand.
    #[test]
    fn figure_1_configurations_order_by_facing() {
        let base = rect(0.0, 0.0, 10.0, 4.0); // top side y = 4, x ∈ [0, 10]
                                              // (a) parallel, fully facing, same length: N = 1, d = 2·(1 − 0.6) = 0.8.
        let a = adjacent_distance(&base, &rect(0.0, 6.0, 10.0, 10.0), 0.6);
        assert!(
            close(a.d_min_m, 2.0) && close(a.n_factor, 1.0) && close(a.d_m, 0.8),
            "{a:?}"
        );
        // (b) parallel, facing, other side 20 m long: l′₁/l₁ = 1, l′₂/l₂ = 10/20 → N = 0.75, d = 1.1.
        let b = adjacent_distance(&base, &rect(-5.0, 6.0, 15.0, 10.0), 0.6);
        assert!(close(b.n_factor, 0.75) && close(b.d_m, 1.1), "{b:?}");
        // (c) parallel, staggered by 5 m: both ratios 5/10 → N = 0.5, d = 1.4.
        let c = adjacent_distance(&base, &rect(5.0, 6.0, 15.0, 10.0), 0.6);
        assert!(close(c.n_factor, 0.5) && close(c.d_m, 1.4), "{c:?}");
        // (e) a diamond's vertex (5, 6) 2 m above the top side, its sides at 45° (a tie, both give
        // the same N): s₁ = (5,6)–(8,9), l₁ = 3√2; s₂ = the top side, l₂ = 10.
        // s₂ onto s₁: t ∈ [−7/√2, 3/√2] ∩ [0, 3√2] → l′₁/l₁ = 1/2; s₁ onto s₂: x ∈ [5, 8] → 3/10.
        // N = 0.4, d = 2·(1 − 0.24) = 1.52.
        let diamond = fp(&[(5.0, 6.0), (8.0, 9.0), (5.0, 12.0), (2.0, 9.0)]);
        let e = adjacent_distance(&base, &diamond, 0.6);
        assert!(
            close(e.d_min_m, 2.0) && close(e.n_factor, 0.4) && close(e.d_m, 1.52),
            "{e:?}"
        );
        // The same diamond facing a 4 m side: s₂ = (3,4)–(7,4) (a 4 m wide box):
        // s₂ onto s₁: t ∈ [(−2 − 2)/√2, (2 − 2)/√2] = [−2√2, 0] → l′₁ = 0; s₁ onto s₂: x ∈ [5, 7] → 2/4.
        // N = 0.25, d = 2·(1 − 0.15) = 1.7: the largest, as in figure 1e.
        let e2 = adjacent_distance(&rect(3.0, 0.0, 7.0, 4.0), &diamond, 0.6);
        assert!(close(e2.n_factor, 0.25) && close(e2.d_m, 1.7), "{e2:?}");
        assert!(a.d_m < b.d_m && b.d_m < c.d_m && c.d_m < e.d_m && e.d_m < e2.d_m);
    }

    #[test]
    fn parallel_facing_sides_are_reported() {
        let a = adjacent_distance(&rect(0.0, 0.0, 10.0, 4.0), &rect(0.0, 6.0, 10.0, 10.0), 0.6);
        let [sa, sb] = a.sides.unwrap();
        assert_eq!(
            sa,
            Line::new(Coord { x: 0.0, y: 4.0 }, Coord { x: 10.0, y: 4.0 })
        );
        assert_eq!(
            sb,
            Line::new(Coord { x: 0.0, y: 6.0 }, Coord { x: 10.0, y: 6.0 })
        );
    }

    #[test]
    fn touching_overlapping_and_contained_are_zero() {
        let a = rect(0.0, 0.0, 10.0, 10.0);
        for other in [
            rect(10.0, 0.0, 20.0, 10.0),  // shared side
            rect(10.0, 10.0, 20.0, 20.0), // shared corner
            rect(5.0, 5.0, 15.0, 15.0),   // overlap
            rect(2.0, 2.0, 3.0, 3.0),     // contained
        ] {
            let adj = adjacent_distance(&a, &other, 0.6);
            assert_eq!(adj.d_m, 0.0);
            assert!(adj.sides.is_none());
        }
    }

    #[test]
    fn degenerate_footprint_is_infinitely_far() {
        let a = rect(0.0, 0.0, 1.0, 1.0);
        let empty = MultiPolygon::<f64>(vec![]);
        let line = fp(&[(5.0, 5.0), (6.0, 5.0)]);
        assert_eq!(adjacent_distance(&a, &empty, 0.6).d_m, f64::INFINITY);
        assert_eq!(adjacent_distance(&line, &a, 0.6).d_m, f64::INFINITY);
    }

    #[test]
    fn building_in_a_courtyard_uses_the_hole() {
        let ring = |x0: f64, y0: f64, x1: f64, y1: f64| {
            LineString::from(vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)])
        };
        let court = MultiPolygon(vec![Polygon::new(
            ring(0.0, 0.0, 30.0, 30.0),
            vec![ring(10.0, 10.0, 20.0, 20.0)],
        )]);
        let inside = rect(12.0, 12.0, 18.0, 18.0);
        let adj = adjacent_distance(&court, &inside, 0.6);
        assert!(close(adj.d_min_m, 2.0), "{adj:?}");
    }

    #[test]
    fn hull_reduction_covers_figure_2_pocket_case() {
        // A U-shaped building with a small one inside its mouth (figure 2b).
        let u = fp(&[
            (0.0, 0.0),
            (30.0, 0.0),
            (30.0, 20.0),
            (20.0, 20.0),
            (20.0, 8.0),
            (10.0, 8.0),
            (10.0, 20.0),
            (0.0, 20.0),
        ]);
        let small = rect(13.0, 12.0, 17.0, 16.0);
        let ra = Rings::of(&u);
        let rb = Rings::of(&small);
        let (ka, kb) = hull_reduction(&ra.0[0], &rb.0[0]).expect("pocket found");
        assert_eq!(
            ka.iter().filter(|&&k| k).count(),
            6,
            "only the mouth's vertices"
        );
        assert!(kb.iter().all(|&k| k));
        let fast = compute(&u, &small, 0.6, 0);
        let slow = adjacent_distance_brute_force(&u, &small, 0.6);
        assert_eq!(fast, slow);
        assert!(close(fast.d_min_m, 3.0));
    }

    /// The proptest below would prove little if the hull rarely dropped a vertex: on disjoint random
    /// star polygons it must drop some in most cases, and still agree with brute force.
    #[test]
    fn hull_reduction_drops_vertices_on_most_disjoint_pairs() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let star = |cx: f64, cy: f64, rnd: &mut dyn FnMut() -> f64| {
            let k = 5 + (rnd() * 10.0) as usize;
            let mut ts: Vec<f64> = (0..k).map(|_| rnd()).collect();
            ts.sort_by(f64::total_cmp);
            let pts: Vec<(f64, f64)> = ts
                .iter()
                .map(|t| {
                    let (a, r) = (t * std::f64::consts::TAU, 2.0 + 8.0 * rnd());
                    (cx + r * a.cos(), cy + r * a.sin())
                })
                .collect();
            fp(&pts)
        };
        let (mut disjoint, mut reduced) = (0, 0);
        for _ in 0..500 {
            let (bx, by) = (25.0 * rnd(), 25.0 * rnd());
            let (a, b) = (star(0.0, 0.0, &mut rnd), star(bx, by, &mut rnd));
            let slow = adjacent_distance_brute_force(&a, &b, 0.6);
            if slow.d_m == 0.0 {
                continue;
            }
            disjoint += 1;
            let (ra, rb) = (Rings::of(&a), Rings::of(&b));
            if let Some((ka, kb)) = hull_reduction(&ra.0[0], &rb.0[0]) {
                if ka.iter().chain(&kb).any(|&k| !k) {
                    reduced += 1;
                }
            }
            assert_eq!(compute(&a, &b, 0.6, 0), slow);
        }
        assert!(
            disjoint > 100 && reduced * 10 > disjoint * 7,
            "{reduced} of {disjoint}"
        );
    }

    /// A random star-shaped polygon: `k` vertices at sorted angles around a centre.
    fn star() -> impl Strategy<Value = Footprint> {
        (
            -30.0f64..30.0,
            -30.0f64..30.0,
            prop::collection::vec((0.0f64..1.0, 1.0f64..12.0), 3..14),
            any::<bool>(),
        )
            .prop_map(|(cx, cy, mut spokes, snap)| {
                spokes.sort_by(|p, q| p.0.total_cmp(&q.0));
                spokes.dedup_by(|p, q| (p.0 - q.0).abs() < 1e-3);
                let mut pts: Vec<(f64, f64)> = spokes
                    .iter()
                    .map(|&(t, r)| {
                        let ang = t * std::f64::consts::TAU;
                        let (x, y) = (cx + r * ang.cos(), cy + r * ang.sin());
                        if snap {
                            (x.round(), y.round())
                        } else {
                            (x, y)
                        }
                    })
                    .collect();
                pts.dedup();
                while pts.len() < 3 {
                    pts.push((cx + pts.len() as f64, cy + 1.0));
                }
                fp(&pts)
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        #[test]
        fn hull_reduction_equals_brute_force(a in star(), b in star()) {
            use geo::{Intersects, Validation};
            prop_assume!(a.is_valid() && b.is_valid());
            prop_assert_eq!(adjacent_distance(&a, &b, 0.6).d_m == 0.0, a.intersects(&b));
            let fast = compute(&a, &b, 0.6, 0);
            let slow = adjacent_distance_brute_force(&a, &b, 0.6);
            prop_assert_eq!(fast.sides, slow.sides);
            prop_assert!((fast.d_m - slow.d_m).abs() <= 1e-12 * slow.d_m.max(1.0));
            prop_assert!(fast.d_m <= fast.d_min_m + 1e-12);
            prop_assert!(fast.d_m >= (1.0 - 0.6) * fast.d_min_m - 1e-12);
        }
    }
}
