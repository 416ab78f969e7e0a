//! Merging the footprints of a node's children (seed 000 §3.2): each spanning-tree pair is joined by a
//! *connection pair* of constrained-Delaunay triangles between the two footprints, then all children and
//! bridges are unioned once. Local ENU metres in and out. Invariant: the merged footprint covers every part
//! and every vertex is an input vertex or a boolean-union intersection point (bridges add no vertex).

use citylod_geom::union_nonzero;
use citylod_model::Footprint;
use geo::algorithm::kernels::{Kernel, Orientation, RobustKernel};
use geo_types::{coord, Coord, LineString, MultiPolygon, Polygon};
use rstar::primitives::{GeomWithData, Line};
use rstar::{Envelope, RTree, AABB};
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};
use std::collections::BTreeMap;

/// Default weight λ of the side-similarity term in the adjacent distance (seed 000 Eq. 1): the clustering's and
/// the one that ranks connection pairs (d_pair) in [`merge_footprints`]; [`merge_footprints_weighted`] and
/// `connect_islands` take the caller's.
pub const ADJACENT_LAMBDA: f64 = 0.6;
/// Connection pairs tried per footprint pair, best first, before giving up on the pair.
const MAX_PAIR_TRIES: usize = 64;

/// The merged footprint of a node.
#[derive(Debug, Clone, PartialEq)]
pub struct MergeResult {
    /// Union of the parts and the bridges (local ENU m): exteriors CCW, holes CW, OGC-valid.
    pub footprint: Footprint,
    /// True when the union has more than one polygon: some hinted pair could not be bridged (no
    /// connection pair, or every candidate bridge crossed another footprint) or touched at a point only.
    pub disconnected: bool,
}

/// Merges `parts` (local ENU m) into one footprint, bridging every pair `(i, j)` of `bridges_hint` (indices
/// into `parts`, the spanning-tree edges of the single-link clustering) with its best connection pair:
/// two constrained-Delaunay triangles of the pair's nearby vertices sharing an edge that joins the two
/// footprints, each with its other side on one footprint. Strict pairs (both sides are footprint edges)
/// win over non-strict ones; among them the smallest d_pair, the adjacent distance (seed 000 Eq. 1,
/// λ = 0.6) between the two sides. Bridges never cross or enclose any part. Touching, intersecting and
/// included parts need no bridge: the final union joins them. Holes are kept.
///
/// Degenerate input: empty parts give an empty footprint; rings with fewer than 3 distinct points are
/// ignored; out-of-range or self pairs in `bridges_hint` are ignored.
///
/// # Examples
/// ```
/// use citylod_generalize::merge_footprints;
/// use geo_types::{polygon, MultiPolygon};
/// let a = MultiPolygon(vec![polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.0), (x: 10.0, y: 10.0), (x: 0.0, y: 10.0)]]);
/// let b = MultiPolygon(vec![polygon![(x: 13.0, y: 0.0), (x: 23.0, y: 0.0), (x: 23.0, y: 10.0), (x: 13.0, y: 10.0)]]);
/// let merged = merge_footprints(&[&a, &b], &[(0, 1)]);
/// assert!(!merged.disconnected);
/// assert_eq!(merged.footprint.0.len(), 1);
/// ```
pub fn merge_footprints(parts: &[&Footprint], bridges_hint: &[(usize, usize)]) -> MergeResult {
    merge_footprints_weighted(parts, bridges_hint, ADJACENT_LAMBDA)
}

/// [`merge_footprints`] with connection pairs ranked by the adjacent distance d_min·(1 − N·λ) of weight
/// `lambda_adjacent` (0–1; the clustering's λ, so that both rank sides alike).
pub fn merge_footprints_weighted(
    parts: &[&Footprint],
    bridges_hint: &[(usize, usize)],
    lambda_adjacent: f64,
) -> MergeResult {
    merge_with_bridges(parts, bridges_hint, lambda_adjacent).0
}

/// `merge_footprints_weighted`, also returning the bridges (CCW) that went into the union.
pub(crate) fn merge_with_bridges(
    parts: &[&Footprint],
    bridges_hint: &[(usize, usize)],
    lambda_adjacent: f64,
) -> (MergeResult, Vec<Polygon<f64>>) {
    let ctx = Context::new(parts);
    let mut bridges = Vec::new();
    let mut pairs: Vec<(usize, usize)> = bridges_hint
        .iter()
        .filter(|&&(i, j)| i != j && i < parts.len() && j < parts.len())
        .map(|&(i, j)| (i.min(j), i.max(j)))
        .collect();
    debug_assert_eq!(pairs.len(), bridges_hint.len(), "bad bridge hint");
    pairs.sort_unstable();
    pairs.dedup();
    for (i, j) in pairs {
        if let PairOutcome::Bridged(pieces) = bridge_pair(&ctx, i, j, lambda_adjacent) {
            bridges.extend(pieces.iter().map(|p| bridge_polygon(p)));
        }
    }
    let mut polys: Vec<Polygon<f64>> = Vec::new();
    for part in &ctx.parts {
        for rings in &part.polys {
            let mut it = rings.iter().map(|r| closed_ring(r));
            if let Some(ext) = it.next() {
                polys.push(Polygon::new(ext, it.collect()));
            }
        }
    }
    polys.extend(bridges.iter().cloned());
    // One overlay of every ring with the non-zero rule: on valid parts (winding 0 or 1 each) it equals
    // `unary_union`, which picks its rule from the first ring's orientation and so loses everything when
    // that ring is a self-crossing one; non-zero also keeps both lobes of a self-crossing ring.
    let footprint = union_nonzero(&polys);
    let disconnected = footprint.0.len() > 1;
    (
        MergeResult {
            footprint,
            disconnected,
        },
        bridges,
    )
}

/// Rounds of [`connect_islands`]; each joins every island to a neighbour, so the count at least halves
/// per round while bridges succeed.
const MAX_CONNECT_ROUNDS: usize = 8;
/// Nearest islands (by bounding box) weighed as bridge candidates per island and round.
const CONNECT_NEIGHBOURS: usize = 4;

/// Joins the polygons ("islands") of a merged footprint (local ENU m) wherever a clean bridge of at most
/// `max_gap_m` exists: per round, a minimum spanning tree over each island's `CONNECT_NEIGHBOURS` nearest
/// islands (exact boundary gap, pairs over `max_gap_m` left out) is bridged with connection pairs, as in
/// [`merge_footprints`], and unioned. Seed 000 gives every cluster one outline; without this, an island of a
/// child that the spanning-tree bridge did not reach stays apart in every ancestor, and the coarse levels keep
/// every such island (Boston: 1,485 islands and 18k vertices in the top node). The cap keeps islands apart that
/// only a spatial split put together (see `hierarchy::island_reach_m`). The result covers `fp`, and its
/// vertices are `fp`'s plus union intersection points. Degenerate input: empty or single-polygon footprints
/// come back unchanged; islands no clean bridge reaches stay apart. Connection pairs are ranked with
/// `lambda_adjacent`.
pub(crate) fn connect_islands(fp: &Footprint, max_gap_m: f64, lambda_adjacent: f64) -> Footprint {
    let mut cur = fp.clone();
    for _ in 0..MAX_CONNECT_ROUNDS {
        let k = cur.0.len();
        if k <= 1 {
            break;
        }
        let islands: Vec<Footprint> = cur
            .0
            .iter()
            .map(|p| MultiPolygon(vec![p.clone()]))
            .collect();
        let refs: Vec<&Footprint> = islands.iter().collect();
        let ctx = Context::new(&refs);
        type Boxed = GeomWithData<rstar::primitives::Rectangle<[f64; 2]>, usize>;
        let boxes: Vec<Boxed> = ctx
            .parts
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                p.bbox
                    .map(|b| Boxed::new(rstar::primitives::Rectangle::from_aabb(b), i))
            })
            .collect();
        let tree = RTree::bulk_load(boxes.clone());
        let mut edges: Vec<(f64, usize, usize)> = Vec::new();
        for bx in &boxes {
            let i = bx.data;
            let c = rstar::RTreeObject::envelope(bx.geom()).center();
            let mut near: Vec<(f64, usize)> = tree
                .nearest_neighbor_iter_with_distance_2(&c)
                .filter(|(o, _)| o.data != i)
                .take(4 * CONNECT_NEIGHBOURS)
                .map(|(o, _)| {
                    (
                        box_dist2(
                            rstar::RTreeObject::envelope(bx.geom()),
                            rstar::RTreeObject::envelope(o.geom()),
                        ),
                        o.data,
                    )
                })
                .collect();
            near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            for &(_, j) in near.iter().take(CONNECT_NEIGHBOURS) {
                let (a, b) = (i.min(j), i.max(j));
                let gap_m = gap_between(&ctx.parts[a], &ctx.parts[b]).unwrap_or(0.0);
                if gap_m <= max_gap_m {
                    edges.push((gap_m, a, b));
                }
            }
        }
        edges.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        edges.dedup();
        let mut uf = crate::single_link::UnionFind::new(k);
        let mut pieces: Vec<Polygon<f64>> = Vec::new();
        for &(_, a, b) in &edges {
            if uf.find(a as u32) == uf.find(b as u32) {
                continue;
            }
            match bridge_pair(&ctx, a, b, lambda_adjacent) {
                PairOutcome::Bridged(ps) => {
                    pieces.extend(ps.iter().map(|p| bridge_polygon(p)));
                    uf.union(a as u32, b as u32);
                }
                PairOutcome::Touching => {
                    uf.union(a as u32, b as u32);
                }
                PairOutcome::Unbridged => {}
            }
        }
        if pieces.is_empty() {
            break;
        }
        let mut polys = cur.0.clone();
        polys.extend(pieces);
        let next = union_nonzero(&polys);
        if next.0.len() >= k {
            break;
        }
        cur = next;
    }
    cur
}

/// Squared distance (m²) between two boxes, 0 when they overlap.
fn box_dist2(a: AABB<[f64; 2]>, b: AABB<[f64; 2]>) -> f64 {
    let dx = (b.lower()[0] - a.upper()[0])
        .max(a.lower()[0] - b.upper()[0])
        .max(0.0);
    let dy = (b.lower()[1] - a.upper()[1])
        .max(a.lower()[1] - b.upper()[1])
        .max(0.0);
    dx * dx + dy * dy
}

/// Identifies a vertex: part, polygon, ring (0 = exterior) and index in the open ring; segment `idx`
/// runs from vertex `idx` to vertex `idx + 1` (cyclically).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct VKey {
    part: u32,
    poly: u32,
    ring: u32,
    idx: u32,
}

type Seg = GeomWithData<Line<[f64; 2]>, VKey>;

/// One part with its rings normalized (open, no repeated points, solid on the left: exterior CCW,
/// holes CW) and an R-tree of its segments.
struct Part {
    polys: Vec<Vec<Vec<[f64; 2]>>>,
    segs: RTree<Seg>,
    bbox: Option<AABB<[f64; 2]>>,
}

struct Context {
    parts: Vec<Part>,
    /// Segments of every part, for the bridge-crossing and winding tests.
    all_segs: RTree<Seg>,
    max_x: f64,
}

impl Context {
    fn new(parts: &[&Footprint]) -> Self {
        let mut out = Vec::with_capacity(parts.len());
        let mut all = Vec::new();
        for (pi, fp) in parts.iter().enumerate() {
            let mut polys = Vec::new();
            for poly in fp.0.iter() {
                let Some(ext) = open_ring(poly.exterior(), true) else {
                    continue;
                };
                let mut rings = vec![ext];
                rings.extend(poly.interiors().iter().filter_map(|r| open_ring(r, false)));
                polys.push(rings);
            }
            let mut segs = Vec::new();
            for (k, rings) in polys.iter().enumerate() {
                for (r, pts) in rings.iter().enumerate() {
                    for i in 0..pts.len() {
                        let key = VKey {
                            part: pi as u32,
                            poly: k as u32,
                            ring: r as u32,
                            idx: i as u32,
                        };
                        segs.push(Seg::new(Line::new(pts[i], pts[(i + 1) % pts.len()]), key));
                    }
                }
            }
            all.extend(segs.iter().cloned());
            let segs = RTree::bulk_load(segs);
            let bbox = (segs.size() > 0).then(|| segs.root().envelope());
            out.push(Part { polys, segs, bbox });
        }
        let all_segs = RTree::bulk_load(all);
        let max_x = if all_segs.size() > 0 {
            all_segs.root().envelope().upper()[0]
        } else {
            0.0
        };
        Context {
            parts: out,
            all_segs,
            max_x,
        }
    }

    fn pos(&self, k: VKey) -> [f64; 2] {
        self.parts[k.part as usize].polys[k.poly as usize][k.ring as usize][k.idx as usize]
    }

    fn ring_len(&self, k: VKey) -> usize {
        self.parts[k.part as usize].polys[k.poly as usize][k.ring as usize].len()
    }

    /// True when `a` and `b` are consecutive vertices of the same ring.
    fn adjacent(&self, a: VKey, b: VKey) -> bool {
        if (a.part, a.poly, a.ring) != (b.part, b.poly, b.ring) {
            return false;
        }
        let n = self.ring_len(a) as u32;
        (a.idx + 1) % n == b.idx || (b.idx + 1) % n == a.idx
    }

    /// Winding number of all parts' rings around `p`; > 0 means inside some part.
    fn winding(&self, p: [f64; 2]) -> i32 {
        winding_in(&self.all_segs, self.max_x, p)
    }
}

/// Winding number of the (solid-left oriented) segments of `tree` around `p` (ray to +x).
fn winding_in(tree: &RTree<Seg>, max_x: f64, p: [f64; 2]) -> i32 {
    let env = AABB::from_corners(p, [max_x.max(p[0]) + 1.0, p[1]]);
    let mut w = 0;
    for s in tree.locate_in_envelope_intersecting(&env) {
        let (a, b) = (s.geom().from, s.geom().to);
        if a[1] <= p[1] && b[1] > p[1] && cross(a, b, p) > 0.0 {
            w += 1;
        } else if b[1] <= p[1] && a[1] > p[1] && cross(a, b, p) < 0.0 {
            w -= 1;
        }
    }
    w
}

enum PairOutcome {
    /// The parts touch, overlap or contain one another: the union joins them.
    Touching,
    /// The bridge (3 or 4 input vertices) and, for a non-strict side, the pocket between that chord and
    /// the footprint's outline (filled, as the paper's merged outline follows the chord).
    Bridged(Vec<Vec<[f64; 2]>>),
    /// No clean connection pair and no clean fallback bridge.
    Unbridged,
}

/// A connection pair: triangles (u, a2, w) on part A's side and (u, w, b2) on B's side of edge u–w.
struct Candidate {
    strict: bool,
    d_pair_m: f64,
    key: (VKey, VKey, VKey, VKey),
    quad: [[f64; 2]; 4],
}

/// Above this many points a triangulation is bulk-loaded: inserted one by one in ring order, the points
/// of a round outline cost O(n²) flips (a 100,000-point circle took minutes). Below, one-by-one
/// insertion is faster.
const BULK_LOAD_MIN_POINTS: usize = 256;

/// A Delaunay triangulation of the points of `keys` (no constraints yet) and the vertex of each key
/// (equal points share one). A key whose point spade rejects (not finite, out of its range) has no vertex.
fn triangulate_points(
    ctx: &Context,
    keys: &[VKey],
) -> (
    ConstrainedDelaunayTriangulation<Point2<f64>>,
    BTreeMap<VKey, spade::handles::FixedVertexHandle>,
) {
    let point = |k: VKey| {
        let p = ctx.pos(k);
        Point2::new(p[0], p[1])
    };
    let mut handle = BTreeMap::new();
    if keys.len() < BULK_LOAD_MIN_POINTS {
        let mut cdt = ConstrainedDelaunayTriangulation::new();
        for &k in keys {
            if let Ok(h) = cdt.insert(point(k)) {
                handle.insert(k, h);
            }
        }
        return (cdt, handle);
    }
    let valid = |p: &Point2<f64>| {
        spade::validate_coordinate(p.x).is_ok() && spade::validate_coordinate(p.y).is_ok()
    };
    let points: Vec<Point2<f64>> = keys.iter().map(|&k| point(k)).filter(valid).collect();
    let cdt =
        ConstrainedDelaunayTriangulation::bulk_load_cdt(points, Vec::new()).unwrap_or_default();
    // Equal points share one vertex; -0.0 and 0.0 are equal.
    let bits = |p: Point2<f64>| ((p.x + 0.0).to_bits(), (p.y + 0.0).to_bits());
    let by_point: std::collections::HashMap<_, _> = cdt
        .vertices()
        .map(|v| (bits(v.position()), v.fix()))
        .collect();
    for &k in keys {
        if let Some(&h) = by_point.get(&bits(point(k))) {
            handle.insert(k, h);
        }
    }
    (cdt, handle)
}

fn bridge_pair(ctx: &Context, ia: usize, ib: usize, lambda_adjacent: f64) -> PairOutcome {
    let (pa, pb) = (&ctx.parts[ia], &ctx.parts[ib]);
    let (Some(_), Some(_)) = (pa.bbox, pb.bbox) else {
        return PairOutcome::Unbridged;
    };
    let Some(gap_m) = gap_between(pa, pb) else {
        return PairOutcome::Touching;
    };
    let reach_m = 2.0 * gap_m + 1.0;
    let mut keys: Vec<VKey> = Vec::new();
    keys.extend(segment_ends_within(pa, pb, reach_m));
    keys.extend(segment_ends_within(pb, pa, reach_m));
    keys.sort_unstable();
    keys.dedup();

    let (mut cdt, handle) = triangulate_points(ctx, &keys);
    let mut owner: Vec<Option<VKey>> = vec![None; cdt.num_vertices()];
    for &k in &keys {
        if let Some(h) = handle.get(&k) {
            owner[h.index()].get_or_insert(k);
        }
    }
    for &k in &keys {
        let n = ctx.ring_len(k) as u32;
        let next = VKey {
            idx: (k.idx + 1) % n,
            ..k
        };
        if let (Some(&h0), Some(&h1)) = (handle.get(&k), handle.get(&next)) {
            if h0 != h1 && !cdt.exists_constraint(h0, h1) && cdt.can_add_constraint(h0, h1) {
                cdt.add_constraint(h0, h1);
            }
        }
    }

    let part_a = ia as u32;
    let mut cands: Vec<Candidate> = Vec::new();
    for e in cdt.undirected_edges() {
        let [v0, v1] = e.vertices();
        let (Some(o0), Some(o1)) = (owner[v0.fix().index()], owner[v1.fix().index()]) else {
            continue;
        };
        if o0.part == o1.part {
            continue;
        }
        let de = e.as_directed();
        let (Some(t_l), Some(t_r)) = (de.opposite_vertex(), de.rev().opposite_vertex()) else {
            continue;
        };
        let (Some(ol), Some(or)) = (owner[t_l.fix().index()], owner[t_r.fix().index()]) else {
            continue;
        };
        if ol.part == or.part {
            continue;
        }
        let (u, w) = if o0.part == part_a {
            (o0, o1)
        } else {
            (o1, o0)
        };
        let (a2, b2) = if ol.part == part_a {
            (ol, or)
        } else {
            (or, ol)
        };
        let s1 = [ctx.pos(u), ctx.pos(a2)];
        let s2 = [ctx.pos(w), ctx.pos(b2)];
        cands.push(Candidate {
            strict: ctx.adjacent(u, a2) && ctx.adjacent(w, b2),
            d_pair_m: adjacent_distance_m(s1, s2, lambda_adjacent),
            key: (u, a2, w, b2),
            quad: [ctx.pos(u), ctx.pos(a2), ctx.pos(w), ctx.pos(b2)],
        });
    }
    cands.sort_by(|x, y| {
        (!x.strict)
            .cmp(&!y.strict)
            .then(x.d_pair_m.total_cmp(&y.d_pair_m))
            .then(x.key.cmp(&y.key))
    });
    for c in cands.iter().take(MAX_PAIR_TRIES) {
        if !bridge_is_clean(ctx, &c.quad) {
            continue;
        }
        let (u, a2, w, b2) = c.key;
        let mut pieces = vec![c.quad.to_vec()];
        let mut ok = true;
        for (x, y) in [(u, a2), (w, b2)] {
            if !ctx.adjacent(x, y) {
                match pocket(ctx, x, y) {
                    Some(p) => pieces.push(p),
                    None => ok = false,
                }
            }
        }
        if ok {
            return PairOutcome::Bridged(pieces);
        }
    }
    if let Some(t) = nearest_feature_bridge(ctx, ia, ib, gap_m) {
        return PairOutcome::Bridged(vec![t]);
    }
    PairOutcome::Unbridged
}

/// The gap (m) between two parts' boundaries, 0 when they touch at isolated points only (corner to
/// corner: the union would keep them apart), or `None` when they overlap: boundaries cross or share a
/// stretch of edge, or one lies inside the other. Cost O(|small| log |big| + k log |small|), k = big's
/// vertices near small.
fn gap_between(a: &Part, b: &Part) -> Option<f64> {
    let (small, big) = if a.segs.size() <= b.segs.size() {
        (a, b)
    } else {
        (b, a)
    };
    let (sb, bb) = (small.bbox?, big.bbox?);
    let mut d2 = f64::INFINITY;
    for s in small.segs.iter() {
        let p = s.geom().from;
        if let Some(n) = big.segs.nearest_neighbor(&p) {
            d2 = d2.min(point_segment_dist2(p, n.geom().from, n.geom().to));
        }
        let env = s.envelope_of();
        if env.intersects(&bb) {
            for t in big.segs.locate_in_envelope_intersecting(&env) {
                if substantial_contact(s.geom().from, s.geom().to, t.geom().from, t.geom().to) {
                    return None;
                }
            }
        }
    }
    let d = d2.sqrt();
    let near = grow(sb, d);
    for t in big.segs.locate_in_envelope_intersecting(&near) {
        let p = t.geom().from;
        if let Some(n) = small.segs.nearest_neighbor(&p) {
            d2 = d2.min(point_segment_dist2(p, n.geom().from, n.geom().to));
        }
    }
    // A vertex strictly inside the other part means overlap; test one per part that is off the other's
    // boundary (a touching vertex would be ambiguous).
    let inside = |of: &Part, other: &Part, ob: AABB<[f64; 2]>| {
        of.segs
            .iter()
            .map(|s| s.geom().from)
            .find(|&p| {
                other
                    .segs
                    .nearest_neighbor(&p)
                    .is_some_and(|n| point_segment_dist2(p, n.geom().from, n.geom().to) > 0.0)
            })
            .is_some_and(|p| winding_in(&other.segs, ob.upper()[0], p) > 0)
    };
    if inside(small, big, bb) || inside(big, small, sb) {
        return None;
    }
    Some(d2.sqrt())
}

/// True when segments a–b and c–d cross properly or share a stretch of positive length; touching at a
/// single point is not substantial.
fn substantial_contact(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let (o1, o2) = (orient(a, b, c), orient(a, b, d));
    let (o3, o4) = (orient(c, d, a), orient(c, d, b));
    use Orientation::Collinear as C;
    if o1 != C && o2 != C && o3 != C && o4 != C {
        return o1 != o2 && o3 != o4;
    }
    if o1 == C && o2 == C {
        let strictly_in =
            |x: [f64; 2], y: [f64; 2], p: [f64; 2]| p != x && p != y && on_segment(x, y, p);
        return strictly_in(a, b, c)
            || strictly_in(a, b, d)
            || strictly_in(c, d, a)
            || strictly_in(c, d, b)
            || (a == c && b == d)
            || (a == d && b == c);
    }
    false
}

trait EnvelopeOf {
    fn envelope_of(&self) -> AABB<[f64; 2]>;
}
impl EnvelopeOf for Seg {
    fn envelope_of(&self) -> AABB<[f64; 2]> {
        AABB::from_corners(self.geom().from, self.geom().to)
    }
}

fn grow(e: AABB<[f64; 2]>, by: f64) -> AABB<[f64; 2]> {
    let (l, u) = (e.lower(), e.upper());
    AABB::from_corners([l[0] - by, l[1] - by], [u[0] + by, u[1] + by])
}

/// Both ends of every segment of `of` lying within `reach_m` of `other`'s boundary.
fn segment_ends_within(of: &Part, other: &Part, reach_m: f64) -> Vec<VKey> {
    let Some(ob) = other.bbox else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for s in of.segs.locate_in_envelope_intersecting(&grow(ob, reach_m)) {
        let (a, b) = (s.geom().from, s.geom().to);
        let near = other
            .segs
            .locate_in_envelope_intersecting(&grow(s.envelope_of(), reach_m))
            .any(|t| segment_dist(a, b, t.geom().from, t.geom().to) <= reach_m);
        if near {
            let k = s.data;
            let n = of.polys[k.poly as usize][k.ring as usize].len() as u32;
            out.push(k);
            out.push(VKey {
                idx: (k.idx + 1) % n,
                ..k
            });
        }
    }
    out
}

/// A bridge (corners `q`, a fan of triangles from `q[0]`) is clean when its triangles have area and one
/// orientation, no part's segment touches a bridge edge except at a shared end, no part vertex lies in
/// the closed bridge other than its corners, and it lies outside every part (it fills empty space only).
fn bridge_is_clean(ctx: &Context, q: &[[f64; 2]]) -> bool {
    let tris: Vec<[[f64; 2]; 3]> = (1..q.len() - 1).map(|i| [q[0], q[i], q[i + 1]]).collect();
    let scale = q
        .iter()
        .fold(1.0f64, |m, p| m.max(p[0].abs()).max(p[1].abs()));
    let eps = 1e-12 * scale * scale;
    let a0 = tri_area2(tris[0]);
    if tris
        .iter()
        .any(|&t| tri_area2(t).abs() <= eps || tri_area2(t) * a0 < 0.0)
    {
        return false;
    }
    for i in 0..q.len() {
        let (a, b) = (q[i], q[(i + 1) % q.len()]);
        let env = AABB::from_corners(a, b);
        for s in ctx.all_segs.locate_in_envelope_intersecting(&env) {
            let (c, d) = (s.geom().from, s.geom().to);
            if c == a || c == b || d == a || d == b {
                continue;
            }
            if segments_intersect(a, b, c, d) {
                return false;
            }
        }
    }
    let env = AABB::from_points(q.iter());
    for s in ctx.all_segs.locate_in_envelope_intersecting(&env) {
        let p = s.geom().from;
        if !q.contains(&p) && tris.iter().any(|&t| in_closed_triangle(p, t)) {
            return false;
        }
    }
    tris.iter().all(|t| {
        let c = [
            (t[0][0] + t[1][0] + t[2][0]) / 3.0,
            (t[0][1] + t[1][1] + t[2][1]) / 3.0,
        ];
        ctx.winding(c) <= 0
    })
}

/// The region between the chord x–y (two vertices of one ring) and the shorter stretch of the ring
/// between them, when that region lies outside the footprint (the ring, solid on its left, then runs
/// clockwise around it); `None` otherwise.
fn pocket(ctx: &Context, x: VKey, y: VKey) -> Option<Vec<[f64; 2]>> {
    if (x.part, x.poly, x.ring) != (y.part, y.poly, y.ring) {
        return None;
    }
    let n = ctx.ring_len(x) as u32;
    let fwd = (y.idx + n - x.idx) % n;
    let (from, steps) = if fwd <= n - fwd {
        (x, fwd)
    } else {
        (y, n - fwd)
    };
    let path: Vec<[f64; 2]> = (0..=steps)
        .map(|k| {
            ctx.pos(VKey {
                idx: (from.idx + k) % n,
                ..from
            })
        })
        .collect();
    (path.len() >= 3 && signed_area2(&path) < 0.0).then_some(path)
}

/// Fallback when no connection pair is clean (another part in the way of every Delaunay pair, or parts
/// touching corner to corner so their Delaunay vertices coincide): the smallest clean quad joining an
/// edge at the nearest vertex of one part to the nearest segment of the other, or for touching parts
/// (gap 0) the smallest such triangle. All corners are input vertices.
fn nearest_feature_bridge(
    ctx: &Context,
    ia: usize,
    ib: usize,
    gap_m: f64,
) -> Option<Vec<[f64; 2]>> {
    let mut near: Vec<(f64, VKey, VKey)> = Vec::new();
    for (x, y) in [(ia, ib), (ib, ia)] {
        let (px, py) = (&ctx.parts[x], &ctx.parts[y]);
        let env = grow(py.bbox?, gap_m + 1e-9);
        for s in px.segs.locate_in_envelope_intersecting(&env) {
            let p = s.geom().from;
            if let Some(n) = py.segs.nearest_neighbor(&p) {
                let d2 = point_segment_dist2(p, n.geom().from, n.geom().to);
                if d2.sqrt() <= gap_m * 1.5 + 1e-9 {
                    near.push((d2, s.data, n.data));
                }
            }
        }
    }
    near.sort_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
    let mut best: Option<(f64, Vec<[f64; 2]>)> = None;
    for &(_, v, seg) in near.iter().take(8) {
        let n = ctx.ring_len(v) as u32;
        let m = ctx.ring_len(seg) as u32;
        let (s0, s1) = (
            ctx.pos(seg),
            ctx.pos(VKey {
                idx: (seg.idx + 1) % m,
                ..seg
            }),
        );
        let p = ctx.pos(v);
        let mut shapes: Vec<Vec<[f64; 2]>> = Vec::new();
        for k in [(v.idx + n - 1) % n, (v.idx + 1) % n] {
            let q = ctx.pos(VKey { idx: k, ..v });
            if gap_m == 0.0 {
                shapes.push(vec![p, q, s0]);
                shapes.push(vec![p, q, s1]);
            } else {
                for (e0, e1) in [(s0, s1), (s1, s0)] {
                    shapes.push(vec![p, q, e0, e1]);
                    shapes.push(vec![q, e0, e1, p]);
                }
            }
        }
        for sh in shapes {
            let area = signed_area2(&sh).abs();
            if best.as_ref().is_none_or(|b| area < b.0) && bridge_is_clean(ctx, &sh) {
                best = Some((area, sh));
            }
        }
    }
    best.map(|b| b.1)
}

/// Adjacent distance (m) between two segments, seed 000 Eq. 1–2: d_min · (1 − N·λ), where N is the mean
/// share of each side covered by the other's projection onto it. Parallel, fully facing sides give the
/// smallest value; staggered or skewed sides a larger one.
fn adjacent_distance_m(s1: [[f64; 2]; 2], s2: [[f64; 2]; 2], lambda: f64) -> f64 {
    let d_min = segment_dist(s1[0], s1[1], s2[0], s2[1]);
    let n = 0.5 * (projected_share(s1, s2) + projected_share(s2, s1));
    d_min * (1.0 - n * lambda)
}

/// Share of `onto` covered by the orthogonal projection of `s` onto its line, in [0, 1].
fn projected_share(onto: [[f64; 2]; 2], s: [[f64; 2]; 2]) -> f64 {
    let d = [onto[1][0] - onto[0][0], onto[1][1] - onto[0][1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    if len2 <= 0.0 {
        return 0.0;
    }
    let t = |p: [f64; 2]| ((p[0] - onto[0][0]) * d[0] + (p[1] - onto[0][1]) * d[1]) / len2;
    let (t0, t1) = (t(s[0]), t(s[1]));
    (t0.max(t1).min(1.0) - t0.min(t1).max(0.0)).max(0.0)
}

fn bridge_polygon(q: &[[f64; 2]]) -> Polygon<f64> {
    let mut pts: Vec<[f64; 2]> = q.to_vec();
    if signed_area2(&pts) < 0.0 {
        pts.reverse();
    }
    Polygon::new(closed_ring(&pts), Vec::new())
}

/// Open ring without repeated points, oriented CCW when `exterior`, CW otherwise (a ring of zero signed
/// area, e.g. a symmetric self-crossing one, is left as it is); `None` when fewer than 3 points remain
/// or a coordinate is not finite.
pub(crate) fn open_ring(ls: &LineString<f64>, exterior: bool) -> Option<Vec<[f64; 2]>> {
    let mut pts: Vec<[f64; 2]> = Vec::with_capacity(ls.0.len());
    for c in &ls.0 {
        let p = [c.x, c.y];
        if !(p[0].is_finite() && p[1].is_finite()) {
            return None;
        }
        if pts.last() != Some(&p) {
            pts.push(p);
        }
    }
    while pts.len() > 1 && pts.first() == pts.last() {
        pts.pop();
    }
    if pts.len() < 3 {
        return None;
    }
    let a = signed_area2(&pts);
    if a != 0.0 && (a > 0.0) != exterior {
        pts.reverse();
    }
    Some(pts)
}

pub(crate) fn closed_ring(pts: &[[f64; 2]]) -> LineString<f64> {
    let mut cs: Vec<Coord<f64>> = pts.iter().map(|p| coord! { x: p[0], y: p[1] }).collect();
    if let Some(&f) = cs.first() {
        cs.push(f);
    }
    LineString(cs)
}

/// Twice the signed area of an open ring (> 0 for CCW).
pub(crate) fn signed_area2(pts: &[[f64; 2]]) -> f64 {
    let n = pts.len();
    (0..n)
        .map(|i| {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

fn tri_area2(t: [[f64; 2]; 3]) -> f64 {
    cross(t[0], t[1], t[2])
}

/// (b − a) × (c − a): > 0 when c is left of a→b.
pub(crate) fn cross(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> Orientation {
    RobustKernel::orient2d(
        coord! { x: a[0], y: a[1] },
        coord! { x: b[0], y: b[1] },
        coord! { x: c[0], y: c[1] },
    )
}

/// True when `p` lies in the closed triangle `t` (either orientation), decided with exact predicates.
pub(crate) fn in_closed_triangle(p: [f64; 2], t: [[f64; 2]; 3]) -> bool {
    let o = [
        orient(t[0], t[1], p),
        orient(t[1], t[2], p),
        orient(t[2], t[0], p),
    ];
    let has_ccw = o.contains(&Orientation::CounterClockwise);
    let has_cw = o.contains(&Orientation::Clockwise);
    if has_ccw && has_cw {
        return false;
    }
    if has_ccw || has_cw {
        return true;
    }
    // Degenerate triangle: p must lie on one of its sides.
    (0..3).any(|i| on_segment(t[i], t[(i + 1) % 3], p))
}

fn on_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> bool {
    orient(a, b, p) == Orientation::Collinear
        && p[0] >= a[0].min(b[0])
        && p[0] <= a[0].max(b[0])
        && p[1] >= a[1].min(b[1])
        && p[1] <= a[1].max(b[1])
}

/// Closed segment intersection (touching counts), exact predicates.
pub(crate) fn segments_intersect(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let (o1, o2) = (orient(a, b, c), orient(a, b, d));
    let (o3, o4) = (orient(c, d, a), orient(c, d, b));
    use Orientation::Collinear as C;
    if o1 != o2 && o3 != o4 && o1 != C && o2 != C && o3 != C && o4 != C {
        return true;
    }
    (o1 == C && on_segment(a, b, c))
        || (o2 == C && on_segment(a, b, d))
        || (o3 == C && on_segment(c, d, a))
        || (o4 == C && on_segment(c, d, b))
}

/// The point of segment a–b nearest to `p`.
pub(crate) fn closest_on_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    [a[0] + t * d[0], a[1] + t * d[1]]
}

pub(crate) fn point_segment_dist2(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let c = closest_on_segment(p, a, b);
    let q = [c[0] - p[0], c[1] - p[1]];
    q[0] * q[0] + q[1] * q[1]
}

fn segment_dist(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> f64 {
    if segments_intersect(a, b, c, d) {
        return 0.0;
    }
    point_segment_dist2(a, c, d)
        .min(point_segment_dist2(b, c, d))
        .min(point_segment_dist2(c, a, b))
        .min(point_segment_dist2(d, a, b))
        .sqrt()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use geo::bool_ops::{BooleanOps, FillRule, OpType};
    use geo::orient::{Direction, Orient};
    use geo::{Area, Validation};
    use geo_types::polygon;
    use proptest::prelude::*;

    pub(crate) fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Footprint {
        MultiPolygon(vec![
            polygon![(x: x0, y: y0), (x: x1, y: y0), (x: x1, y: y1), (x: x0, y: y1)],
        ])
    }

    /// Area of `parts` not covered by `fp` (m²).
    pub(crate) fn uncovered_m2(parts: &[&Footprint], fp: &Footprint) -> f64 {
        let oriented: Vec<Footprint> = parts.iter().map(|p| p.orient(Direction::Default)).collect();
        MultiPolygon(oriented.into_iter().flat_map(|p| p.0).collect())
            .boolean_op_with_fill_rule(&MultiPolygon(Vec::new()), OpType::Union, FillRule::NonZero)
            .difference(fp)
            .unsigned_area()
    }

    fn all_vertices(fp: &Footprint) -> Vec<[f64; 2]> {
        fp.0.iter()
            .flat_map(|p| std::iter::once(p.exterior()).chain(p.interiors()))
            .flat_map(|r| r.0.iter().map(|c| [c.x, c.y]))
            .collect()
    }

    fn segments(polys: impl Iterator<Item = Polygon<f64>>) -> Vec<[[f64; 2]; 2]> {
        polys
            .flat_map(|p| {
                std::iter::once(p.exterior().clone())
                    .chain(p.interiors().iter().cloned())
                    .collect::<Vec<_>>()
            })
            .flat_map(|r| {
                r.0.windows(2)
                    .map(|w| [[w[0].x, w[0].y], [w[1].x, w[1].y]])
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    /// Every vertex of `out` is an input vertex or lies on two non-parallel input or bridge segments.
    fn vertices_from_inputs(
        parts: &[&Footprint],
        bridges: &[Polygon<f64>],
        out: &Footprint,
    ) -> bool {
        let inputs: Vec<[f64; 2]> = parts.iter().flat_map(|p| all_vertices(p)).collect();
        let segs = segments(
            parts
                .iter()
                .flat_map(|p| p.0.clone())
                .chain(bridges.iter().cloned()),
        );
        all_vertices(out).iter().all(|v| {
            let near = |a: &[f64; 2]| (a[0] - v[0]).hypot(a[1] - v[1]) < 1e-6;
            if inputs.iter().any(near) {
                return true;
            }
            let on: Vec<&[[f64; 2]; 2]> = segs
                .iter()
                .filter(|s| point_segment_dist2(*v, s[0], s[1]) < 1e-12)
                .collect();
            on.iter().any(|s| {
                on.iter().any(|t| {
                    let (d, e) = (
                        [s[1][0] - s[0][0], s[1][1] - s[0][1]],
                        [t[1][0] - t[0][0], t[1][1] - t[0][1]],
                    );
                    (d[0] * e[1] - d[1] * e[0]).abs() > 1e-9 * d[0].hypot(d[1]) * e[0].hypot(e[1])
                })
            })
        })
    }

    #[test]
    fn facing_rectangles_bridge_with_the_gap_quad() {
        let (a, b) = (rect(0.0, 0.0, 10.0, 10.0), rect(13.0, 0.0, 23.0, 10.0));
        let (m, bridges) = merge_with_bridges(&[&a, &b], &[(0, 1)], ADJACENT_LAMBDA);
        assert!(!m.disconnected);
        assert_eq!(bridges.len(), 1);
        assert!(
            (m.footprint.unsigned_area() - 230.0).abs() < 1e-6,
            "{}",
            m.footprint.unsigned_area()
        );
        assert!(m.footprint.is_valid());
        // The merged outline is the 23 × 10 rectangle (collinear points may remain).
        assert!(uncovered_m2(&[&rect(0.0, 0.0, 23.0, 10.0)], &m.footprint) < 1e-6);
    }

    #[test]
    fn densely_sampled_facing_sides_bridge_over_the_bulk_threshold() {
        // Two 100 m walls 3 m apart, each sampled every 25 cm (collinear points: a degenerate case for
        // one-by-one insertion), so the bridge search triangulates over BULK_LOAD_MIN_POINTS points.
        let wall = |x: f64, facing_right: bool| {
            let ys: Vec<f64> = (0..=400).map(|i| i as f64 * 0.25).collect();
            let (x_far, x_near) = if facing_right {
                (x - 10.0, x)
            } else {
                (x + 10.0, x)
            };
            let mut pts = vec![(x_far, 100.0), (x_far, 0.0)];
            pts.extend(ys.iter().map(|&y| (x_near, y)));
            if !facing_right {
                pts.reverse();
            }
            let mut ring: Vec<geo_types::Coord<f64>> = pts
                .iter()
                .map(|&(x, y)| geo_types::Coord { x, y })
                .collect();
            ring.push(ring[0]);
            MultiPolygon(vec![Polygon::new(geo_types::LineString(ring), vec![])])
        };
        let (a, b) = (wall(10.0, true), wall(13.0, false));
        let (m, bridges) = merge_with_bridges(&[&a, &b], &[(0, 1)], ADJACENT_LAMBDA);
        assert!(!m.disconnected);
        assert_eq!(bridges.len(), 1);
        assert_eq!(m.footprint.0.len(), 1);
        assert!(m.footprint.is_valid());
        assert!(uncovered_m2(&[&a, &b], &m.footprint) < 1e-6);
        let added = m.footprint.unsigned_area() - 2000.0;
        assert!(added > 0.0 && added <= 300.0 + 1e-6, "{added}");
    }

    #[test]
    fn staggered_rectangles_bridge_only_facing_overlap() {
        let (a, b) = (rect(0.0, 0.0, 10.0, 30.0), rect(12.0, 20.0, 22.0, 50.0));
        let (m, bridges) = merge_with_bridges(&[&a, &b], &[(0, 1)], ADJACENT_LAMBDA);
        assert!(!m.disconnected);
        assert_eq!(bridges.len(), 1);
        let added = m.footprint.unsigned_area() - 600.0;
        // Strict pair on the two facing sides: a quad in the 2 m gap, at most 2 × 30 m.
        assert!(added > 0.0 && added <= 60.0 + 1e-6, "{added}");
        assert!(m.footprint.is_valid());
        assert!(uncovered_m2(&[&a, &b], &m.footprint) < 1e-6);
    }

    #[test]
    fn intersecting_and_included_parts_need_no_bridge() {
        let (a, b) = (rect(0.0, 0.0, 10.0, 10.0), rect(5.0, 5.0, 15.0, 15.0));
        let (m, bridges) = merge_with_bridges(&[&a, &b], &[(0, 1)], ADJACENT_LAMBDA);
        assert!(bridges.is_empty() && !m.disconnected);
        assert!((m.footprint.unsigned_area() - 175.0).abs() < 1e-6);
        let inner = rect(2.0, 2.0, 4.0, 4.0);
        let (m, bridges) = merge_with_bridges(&[&a, &inner], &[(0, 1)], ADJACENT_LAMBDA);
        assert!(bridges.is_empty() && !m.disconnected);
        assert!((m.footprint.unsigned_area() - 100.0).abs() < 1e-6);
        // A cross: the rectangles overlap though no vertex of either lies inside the other.
        let (h, v) = (rect(0.0, 4.0, 20.0, 6.0), rect(9.0, -5.0, 11.0, 15.0));
        let (m, bridges) = merge_with_bridges(&[&h, &v], &[(0, 1)], ADJACENT_LAMBDA);
        assert!(bridges.is_empty() && !m.disconnected);
        assert!((m.footprint.unsigned_area() - 76.0).abs() < 1e-6);
    }

    fn courtyard() -> Footprint {
        MultiPolygon(vec![Polygon::new(
            rect(0.0, 0.0, 30.0, 30.0).0[0].exterior().clone(),
            vec![LineString::from(vec![
                (10.0, 10.0),
                (10.0, 20.0),
                (20.0, 20.0),
                (20.0, 10.0),
                (10.0, 10.0),
            ])],
        )])
    }

    #[test]
    fn courtyard_hole_is_kept() {
        let (a, b) = (courtyard(), rect(32.0, 0.0, 40.0, 30.0));
        let m = merge_footprints(&[&a, &b], &[(0, 1)]);
        assert!(!m.disconnected);
        assert_eq!(m.footprint.0[0].interiors().len(), 1);
        assert!((m.footprint.unsigned_area() - (800.0 + 240.0 + 60.0)).abs() < 1e-6);
        assert!(m.footprint.is_valid());
    }

    #[test]
    fn part_in_courtyard_is_bridged_inside_the_hole() {
        let (a, b) = (courtyard(), rect(12.0, 12.0, 18.0, 18.0));
        let (m, bridges) = merge_with_bridges(&[&a, &b], &[(0, 1)], ADJACENT_LAMBDA);
        assert_eq!(bridges.len(), 1);
        assert!(!m.disconnected);
        assert!(m.footprint.is_valid());
        assert!(uncovered_m2(&[&a, &b], &m.footprint) < 1e-6);
    }

    #[test]
    fn bridge_never_crosses_another_part() {
        // C is a wall between A and B; only A–B is hinted, so a bridge would have to cross C.
        let (a, b, c) = (
            rect(0.0, 0.0, 10.0, 10.0),
            rect(20.0, 0.0, 30.0, 10.0),
            rect(14.0, -50.0, 16.0, 60.0),
        );
        let (m, bridges) = merge_with_bridges(&[&a, &b, &c], &[(0, 1)], ADJACENT_LAMBDA);
        assert!(bridges.is_empty());
        assert!(m.disconnected);
        assert_eq!(m.footprint.0.len(), 3);
        // Hinting A–C and C–B joins all three.
        let m = merge_footprints(&[&a, &b, &c], &[(0, 2), (2, 1)]);
        assert!(!m.disconnected);
        assert!(m.footprint.is_valid());
    }

    #[test]
    fn corner_touching_parts_are_joined_by_a_triangle() {
        let (a, b) = (rect(0.0, 0.0, 10.0, 10.0), rect(10.0, 10.0, 20.0, 20.0));
        let (m, bridges) = merge_with_bridges(&[&a, &b], &[(0, 1)], ADJACENT_LAMBDA);
        assert_eq!(bridges.len(), 1);
        assert_eq!(bridges[0].exterior().0.len(), 4);
        assert!(!m.disconnected && m.footprint.is_valid());
        assert!((m.footprint.unsigned_area() - 250.0).abs() < 1e-6);
    }

    fn recessed() -> Footprint {
        MultiPolygon(vec![
            polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.0), (x: 10.0, y: 4.0),
            (x: 8.0, y: 4.0), (x: 8.0, y: 6.0), (x: 10.0, y: 6.0), (x: 10.0, y: 10.0), (x: 0.0, y: 10.0)],
        ])
    }

    #[test]
    fn pocket_behind_a_chord_is_the_outside_stretch_only() {
        let a = recessed();
        let ctx = Context::new(&[&a]);
        let key = |idx| VKey {
            part: 0,
            poly: 0,
            ring: 0,
            idx,
        };
        // Chord (10, 4)–(10, 6) across the recess: the pocket is the 2 × 2 recess.
        let p = pocket(&ctx, key(2), key(5)).unwrap();
        assert_eq!(p.len(), 4);
        assert!((signed_area2(&p).abs() / 2.0 - 4.0).abs() < 1e-12);
        assert!(pocket(&ctx, key(5), key(2)).is_some());
        // Chord (10, 0)–(0, 10) runs through the solid: no pocket.
        assert!(pocket(&ctx, key(1), key(7)).is_none());
    }

    #[test]
    fn recessed_facing_side_merges_valid_and_covering() {
        let (a, b) = (recessed(), rect(12.0, 3.0, 14.0, 7.0));
        let m = merge_footprints(&[&a, &b], &[(0, 1)]);
        assert!(!m.disconnected && m.footprint.is_valid());
        assert!(uncovered_m2(&[&a, &b], &m.footprint) < 1e-9);
    }

    #[test]
    fn self_crossing_first_part_does_not_empty_the_union() {
        // A bow-tie first (Boston has a few): its lobes wind opposite ways.
        let bow = MultiPolygon(vec![
            polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 10.0), (x: 10.0, y: 0.0), (x: 0.0, y: 10.0)],
        ]);
        let b = rect(12.0, 0.0, 20.0, 10.0);
        let m = merge_footprints(&[&bow, &b], &[(0, 1)]);
        assert!(m.footprint.is_valid());
        assert!(
            m.footprint.unsigned_area() >= 80.0 + 50.0 - 1e-6,
            "{}",
            m.footprint.unsigned_area()
        );
    }

    #[test]
    fn merge_is_deterministic() {
        let parts = [
            rect(0.0, 0.0, 10.0, 10.0),
            rect(13.0, 1.0, 23.0, 12.0),
            rect(5.0, 14.0, 12.0, 30.0),
        ];
        let refs: Vec<&Footprint> = parts.iter().collect();
        let m1 = merge_footprints(&refs, &[(0, 1), (0, 2)]);
        let m2 = merge_footprints(&refs, &[(2, 0), (1, 0)]);
        assert_eq!(m1, m2);
    }

    #[test]
    fn empty_and_bad_input_do_not_panic() {
        let m = merge_footprints(&[], &[]);
        assert!(m.footprint.0.is_empty() && !m.disconnected);
        let degenerate = MultiPolygon(vec![
            polygon![(x: 0.0, y: 0.0), (x: 1.0, y: 1.0), (x: 2.0, y: 2.0)],
        ]);
        let a = rect(5.0, 5.0, 6.0, 6.0);
        let m = merge_footprints(&[&degenerate, &a], &[(0, 1)]);
        assert!((m.footprint.unsigned_area() - 1.0).abs() < 1e-9);
    }

    fn rotated_rect(cx: f64, cy: f64, w: f64, h: f64, angle: f64) -> Footprint {
        let (s, c) = angle.sin_cos();
        let pts: Vec<(f64, f64)> = [(-w, -h), (w, -h), (w, h), (-w, h), (-w, -h)]
            .iter()
            .map(|&(x, y)| {
                (
                    cx + x / 2.0 * c - y / 2.0 * s,
                    cy + x / 2.0 * s + y / 2.0 * c,
                )
            })
            .collect();
        MultiPolygon(vec![Polygon::new(LineString::from(pts), vec![])])
    }

    #[test]
    fn connect_islands_joins_separate_squares_across_the_gaps_asked() {
        let squares: Vec<Footprint> = [
            (0.0, 0.0),
            (13.0, 0.0),
            (26.0, 2.0),
            (5.0, 16.0),
            (40.0, 30.0),
        ]
        .iter()
        .map(|&(x, y)| rect(x, y, x + 10.0, y + 10.0))
        .collect();
        let fp = MultiPolygon(squares.iter().flat_map(|s| s.0.clone()).collect());
        let joined = connect_islands(&fp, f64::INFINITY, ADJACENT_LAMBDA);
        assert_eq!(joined.0.len(), 1, "one outline");
        let parts: Vec<&Footprint> = squares.iter().collect();
        assert!(uncovered_m2(&parts, &joined) < 1e-9, "covers every square");
        let input = all_vertices(&fp);
        for v in all_vertices(&joined) {
            assert!(input.contains(&v), "vertex {v:?} is not an input vertex");
        }
        assert!(joined.is_valid());
        // Gaps: 3 m, 3 m and 6 m between the first four squares; the last is 18 m from the nearest.
        for (max_gap_m, polygons) in [(20.0, 1), (7.0, 2), (4.0, 3), (2.0, 5)] {
            let joined = connect_islands(&fp, max_gap_m, ADJACENT_LAMBDA);
            assert_eq!(joined.0.len(), polygons, "max gap {max_gap_m} m");
            assert!(uncovered_m2(&parts, &joined) < 1e-9);
            assert!(joined.is_valid());
        }
    }

    /// Up to `n` Boston footprints nearest the data's centre, in local ENU metres; `None` without data.
    pub(crate) fn boston_sample(n: usize) -> Option<Vec<Footprint>> {
        citylod_testdata::read_shared_data("boston/boston_buildings.geojson", |p| {
            read_boston_sample(p, n)
        })
    }

    fn read_boston_sample(path: &std::path::Path, n: usize) -> Option<Vec<Footprint>> {
        let text = std::fs::read_to_string(path).ok()?;
        let v: serde_json::Value = serde_json::from_str(&text).ok()?;
        let ring = |r: &serde_json::Value| -> Vec<(f64, f64)> {
            r.as_array()
                .into_iter()
                .flatten()
                .filter_map(|p| Some((p[0].as_f64()?, p[1].as_f64()?)))
                .collect()
        };
        type LonLatPolys = Vec<Vec<Vec<(f64, f64)>>>;
        let mut lonlat: Vec<LonLatPolys> = Vec::new();
        for f in v["features"].as_array()? {
            let g = &f["geometry"];
            let polys: Vec<&serde_json::Value> = match g["type"].as_str() {
                Some("Polygon") => vec![&g["coordinates"]],
                Some("MultiPolygon") => g["coordinates"].as_array()?.iter().collect(),
                _ => continue,
            };
            lonlat.push(
                polys
                    .iter()
                    .map(|p| p.as_array().into_iter().flatten().map(ring).collect())
                    .collect(),
            );
        }
        let first = |b: &LonLatPolys| b[0][0][0];
        let (sx, sy) = lonlat
            .iter()
            .fold((0.0, 0.0), |(x, y), b| (x + first(b).0, y + first(b).1));
        let frame =
            citylod_model::LocalFrame::new(sx / lonlat.len() as f64, sy / lonlat.len() as f64, 0.0);
        let mut fps: Vec<Footprint> = lonlat
            .iter()
            .map(|b| {
                MultiPolygon(
                    b.iter()
                        .map(|rings| {
                            let mut rs = rings.iter().map(|r| {
                                LineString::from(
                                    r.iter()
                                        .map(|&(lon, lat)| {
                                            let p = frame.geodetic_to_enu(lon, lat, 0.0);
                                            (p[0], p[1])
                                        })
                                        .collect::<Vec<_>>(),
                                )
                            });
                            let ext = rs.next().unwrap_or_else(|| LineString(vec![]));
                            Polygon::new(ext, rs.collect())
                        })
                        .collect::<Vec<_>>(),
                )
                .orient(Direction::Default)
            })
            .filter(|fp: &Footprint| fp.unsigned_area() > 0.0)
            .collect();
        let d = |fp: &Footprint| {
            let c = fp.0[0].exterior().0[0];
            c.x.hypot(c.y)
        };
        fps.sort_by(|a, b| d(a).total_cmp(&d(b)));
        fps.truncate(n);
        Some(fps)
    }

    /// Groups footprints by an 80 m grid on their first vertex.
    pub(crate) fn grid_groups(fps: &[Footprint], cell_m: f64) -> Vec<Vec<usize>> {
        let mut g: BTreeMap<(i64, i64), Vec<usize>> = BTreeMap::new();
        for (i, fp) in fps.iter().enumerate() {
            let c = fp.0[0].exterior().0[0];
            g.entry(((c.x / cell_m).floor() as i64, (c.y / cell_m).floor() as i64))
                .or_default()
                .push(i);
        }
        g.into_values().collect()
    }

    #[test]
    fn boston_groups_merge_valid_covering_and_connected() {
        let Some(fps) = boston_sample(1000) else {
            return;
        };
        assert_eq!(fps.len(), 1000);
        let groups = grid_groups(&fps, 80.0);
        type Group<'a> = (Vec<&'a Footprint>, Vec<(usize, usize)>);
        let inputs: Vec<Group> = groups
            .iter()
            .map(|g| {
                let parts: Vec<&Footprint> = g.iter().map(|&i| &fps[i]).collect();
                let hints = gap_mst_hints(&parts);
                (parts, hints)
            })
            .collect();
        let t0 = std::time::Instant::now();
        let merged: Vec<MergeResult> = inputs.iter().map(|(p, h)| merge_footprints(p, h)).collect();
        let t_merge = t0.elapsed();
        let all: Vec<&Footprint> = fps.iter().collect();
        let all_hints = gap_mst_hints(&all);
        let t1 = std::time::Instant::now();
        let one = merge_footprints(&all, &all_hints);
        let t_one = t1.elapsed();
        let components = all.len() - all_hints.len();
        let disconnected = merged.iter().filter(|m| m.disconnected).count();
        eprintln!(
            "boston 1000: {} groups merged in {t_merge:?} ({disconnected} disconnected); one node of 1000 \
             children in {t_one:?}: {} polygons for {components} spanning-tree components",
            groups.len(),
            one.footprint.0.len()
        );
        for ((parts, hints), m) in inputs.iter().zip(&merged) {
            assert!(
                m.footprint.is_valid(),
                "{:?}",
                m.footprint.validation_errors()
            );
            let area: f64 = parts.iter().map(|p| p.unsigned_area()).sum();
            assert!(uncovered_m2(parts, &m.footprint) < 1e-6 * area);
            // Every spanning-tree component is one polygon, but for a rare bridge blocked by a third part.
            assert!(m.footprint.0.len() <= parts.len() - hints.len() + 1);
        }
        assert!(one.footprint.is_valid());
        let area: f64 = all.iter().map(|p| p.unsigned_area()).sum();
        assert!(uncovered_m2(&all, &one.footprint) < 1e-6 * area);
        assert!(
            one.footprint.0.len() <= components + 5,
            "{} polygons",
            one.footprint.0.len()
        );
    }

    /// Spanning-tree hints from Kruskal on the boundary gaps of parts whose boxes lie within 40 m.
    pub(crate) fn gap_mst_hints(parts: &[&Footprint]) -> Vec<(usize, usize)> {
        let ctx = Context::new(parts);
        let boxes: Vec<GeomWithData<rstar::primitives::Rectangle<[f64; 2]>, usize>> = ctx
            .parts
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                p.bbox
                    .map(|b| GeomWithData::new(rstar::primitives::Rectangle::from_aabb(b), i))
            })
            .collect();
        let tree = RTree::bulk_load(boxes.clone());
        let mut edges = Vec::new();
        for b in &boxes {
            for o in tree.locate_in_envelope_intersecting(&grow(
                rstar::RTreeObject::envelope(b.geom()),
                40.0,
            )) {
                if o.data > b.data {
                    let g = gap_between(&ctx.parts[b.data], &ctx.parts[o.data]).unwrap_or(0.0);
                    edges.push((g, b.data, o.data));
                }
            }
        }
        edges.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
        let mut root: Vec<usize> = (0..parts.len()).collect();
        fn find(r: &mut [usize], mut x: usize) -> usize {
            while r[x] != x {
                r[x] = r[r[x]];
                x = r[x];
            }
            x
        }
        let mut hints = Vec::new();
        for (_, i, j) in edges {
            let (a, b) = (find(&mut root, i), find(&mut root, j));
            if a != b {
                root[a] = b;
                hints.push((i, j));
            }
        }
        hints
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn merged_footprint_is_valid_covers_parts_and_adds_no_vertex(
            rects in prop::collection::vec((0.0f64..60.0, 0.0f64..60.0, 2.0f64..20.0, 2.0f64..20.0, 0.0f64..0.8), 2..7)
        ) {
            let parts: Vec<Footprint> = rects.iter().map(|&(x, y, w, h, a)| rotated_rect(x, y, w, h, a)).collect();
            let refs: Vec<&Footprint> = parts.iter().collect();
            let hints: Vec<(usize, usize)> = (1..parts.len()).map(|i| (i - 1, i)).collect();
            let (m, bridges) = merge_with_bridges(&refs, &hints, ADJACENT_LAMBDA);
            prop_assert!(m.footprint.is_valid(), "{:?}", m.footprint.validation_errors());
            let total: f64 = parts.iter().map(|p| p.unsigned_area()).sum();
            prop_assert!(uncovered_m2(&refs, &m.footprint) < 1e-7 * total);
            prop_assert!(vertices_from_inputs(&refs, &bridges, &m.footprint));
            for b in &bridges {
                for c in &b.exterior().0 {
                    let v = [c.x, c.y];
                    prop_assert!(refs.iter().any(|p| all_vertices(p).contains(&v)));
                }
            }
            prop_assert_eq!(m.disconnected, m.footprint.0.len() > 1);
        }
    }
}
