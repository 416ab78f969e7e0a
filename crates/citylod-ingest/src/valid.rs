//! Polygon validity exactly as geo's `Validation` decides it — rings of at least 3 distinct finite points that do
//! not cross or touch themselves, holes inside their shell, rings and parts meeting at points only — but with each
//! ring's self-intersection test run on the segment pairs whose boxes overlap (an R-tree) instead of on every
//! pair: geo's test took 70 s on one valid footprint of 100,000 vertices. Two large polygons (a part against a
//! part, a hole against its shell or another hole) are compared by cutting one boundary where it meets the other
//! and locating each piece (`Sides`) instead of by geo's `relate`, which took minutes on a star of 20,000 spikes.
//! Small polygons go to geo as they are.

use geo::coordinate_position::CoordPos;
use geo::dimensions::Dimensions;
use geo::{BoundingRect, Intersects, Relate, Validation};
use geo_types::{Coord, Line, LineString, MultiPolygon, Polygon};
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{RTree, RTreeObject, AABB};

/// Rings of up to this many vertices are checked by geo directly (comparing every pair is then cheap).
const DIRECT_VERTICES: usize = 256;

/// Polygons with more holes than this are checked here even when every ring is small: geo relates every hole to
/// every other (a square with 20,000 small holes took 15–20 s).
const DIRECT_HOLES: usize = 64;

/// Box-indexed items: a segment or a polygon by its position in the slice it was built from.
type Boxes = RTree<GeomWithData<Rectangle<[f64; 2]>, usize>>;

/// An R-tree of segments' boxes, each item the segment's position in `lines`.
fn segment_tree<'a>(lines: impl Iterator<Item = &'a Line>) -> Boxes {
    RTree::bulk_load(
        lines
            .enumerate()
            .map(|(i, l)| {
                GeomWithData::new(
                    Rectangle::from_corners([l.start.x, l.start.y], [l.end.x, l.end.y]),
                    i,
                )
            })
            .collect(),
    )
}

/// The bounding boxes of polygons, each item the polygon's position in `polygons` (an empty polygon has none).
fn polygon_boxes(polygons: &[Polygon]) -> Vec<GeomWithData<Rectangle<[f64; 2]>, usize>> {
    polygons
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            p.bounding_rect().map(|r| {
                GeomWithData::new(
                    Rectangle::from_corners([r.min().x, r.min().y], [r.max().x, r.max().y]),
                    i,
                )
            })
        })
        .collect()
}

/// Whether two segments `i` ≠ `j` of a ring count as a self-intersection: they meet, and not only because one
/// ends where the other starts (geo's rule, symmetric in `i` and `j`).
fn crossing(a: &Line, b: &Line) -> bool {
    a.start != b.end && a.end != b.start && a.intersects(b)
}

/// Whether `ring` crosses or touches itself (geo's `SelfIntersection`).
pub(crate) fn ring_intersects_itself(ring: &LineString) -> bool {
    meetings_up_to(std::iter::once(ring), 1, usize::MAX) != Some(0)
}

/// How many pairs of segments of `p`'s rings meet — within a ring where [`crossing`] says so, between two rings
/// wherever they touch — counting up to `cap` and stopping there; `None` when more than `max_tested` pairs of
/// segments with overlapping boxes had to be tested first (thousands of long parallel segments side by side: every
/// box overlaps every other, while the rings may cross once).
pub(crate) fn crossings_up_to(p: &Polygon, cap: usize, max_tested: usize) -> Option<usize> {
    meetings_up_to(
        std::iter::once(p.exterior()).chain(p.interiors()),
        cap,
        max_tested,
    )
}

/// [`crossings_up_to`] over any rings: the pairs are found through an R-tree of the segments' boxes.
fn meetings_up_to<'a>(
    rings: impl Iterator<Item = &'a LineString>,
    cap: usize,
    max_tested: usize,
) -> Option<usize> {
    let lines: Vec<(usize, Line)> = rings
        .enumerate()
        .flat_map(|(r, ring)| ring.lines().map(move |l| (r, l)))
        .collect();
    let tree = segment_tree(lines.iter().map(|(_, l)| l));
    let (mut count, mut tested) = (0, 0usize);
    for (i, (ra, a)) in lines.iter().enumerate() {
        let env = AABB::from_corners([a.start.x, a.start.y], [a.end.x, a.end.y]);
        for g in tree.locate_in_envelope_intersecting(&env) {
            if g.data <= i {
                continue;
            }
            tested += 1;
            if tested > max_tested {
                return None;
            }
            let (rb, b) = &lines[g.data];
            let meet = if ra == rb {
                crossing(a, b)
            } else {
                a.intersects(b)
            };
            if meet {
                count += 1;
                if count >= cap {
                    return Some(count);
                }
            }
        }
    }
    Some(count)
}

/// A ring's own conditions: at least 3 distinct points (4 with the closing one), finite, no self-intersection.
fn ring_is_valid(ring: &LineString) -> bool {
    let mut distinct = ring.0.clone();
    distinct.dedup();
    distinct.len() >= 4
        && ring.0.iter().all(|c| c.x.is_finite() && c.y.is_finite())
        && !ring_intersects_itself(ring)
}

/// `p.is_valid()`, faster for large rings.
pub(crate) fn polygon_is_valid(p: &Polygon) -> bool {
    let largest = std::iter::once(p.exterior())
        .chain(p.interiors())
        .map(|r| r.0.len())
        .max()
        .unwrap_or(0);
    if (largest <= DIRECT_VERTICES && p.interiors().len() <= DIRECT_HOLES)
        || p.exterior().0.is_empty()
    {
        return p.is_valid();
    }
    let rings: Vec<&LineString> = std::iter::once(p.exterior())
        .chain(p.interiors())
        .filter(|r| !r.0.is_empty())
        .collect();
    if !rings.iter().all(|r| ring_is_valid(r)) {
        return false;
    }
    // Holes: inside the shell, meeting it and each other at points only, not overlapping each other.
    let shell = Polygon::new(p.exterior().clone(), vec![]);
    let holes: Vec<Polygon> = p
        .interiors()
        .iter()
        .filter(|r| !r.0.is_empty())
        .map(|r| Polygon::new(r.clone(), vec![]))
        .collect();
    // The shell's segments indexed once for all its holes, and the holes' boxes, so that only holes whose boxes meet
    // are compared (every pair of 20,000 holes is 2·10⁸ relations).
    let shell_index = Boundary::of(&shell);
    let hole_boxes = polygon_boxes(&holes);
    let hole_tree = RTree::bulk_load(hole_boxes.clone());
    for (k, h) in holes.iter().enumerate() {
        if vertex_count(&shell).saturating_mul(vertex_count(h)) > RELATE_MAX_WORK
            || holes.len() > DIRECT_HOLES
        {
            // Inside the shell: no arc of the hole outside it, none crossing or along its boundary.
            let hs = Sides::against(h, &shell_index);
            if hs.crosses_or_shares || hs.outside || !hs.inside {
                return false;
            }
        } else {
            let m = shell.relate(h);
            if !m.is_contains()
                || m.get(CoordPos::OnBoundary, CoordPos::OnBoundary) == Dimensions::OneDimensional
            {
                return false;
            }
        }
        // Boxes are in the holes' order (a hole without one, empty, is skipped).
        let Ok(at) = hole_boxes.binary_search_by_key(&k, |b| b.data) else {
            continue;
        };
        let k_box = &hole_boxes[at];
        let mut near: Vec<usize> = hole_tree
            .locate_in_envelope_intersecting(&k_box.geom().envelope())
            .map(|b| b.data)
            .filter(|&j| j > k)
            .collect();
        near.sort_unstable();
        for g in near.iter().map(|&j| &holes[j]) {
            if vertex_count(h).saturating_mul(vertex_count(g)) > RELATE_MAX_WORK {
                let (hg, gh) = (Sides::of(h, g), Sides::of(g, h));
                if hg.crosses_or_shares || hg.inside || gh.inside {
                    return false;
                }
                continue;
            }
            let m = h.relate(g);
            if m.get(CoordPos::Inside, CoordPos::Inside) == Dimensions::TwoDimensional
                || m.get(CoordPos::OnBoundary, CoordPos::OnBoundary) == Dimensions::OneDimensional
            {
                return false;
            }
        }
    }
    true
}

/// Above this product of two polygons' vertex counts, they are compared by [`Sides`] instead of geo's
/// `relate`, whose self-noding compares the segments of each polygon with one another: for a star of 20,000
/// long, nearly parallel spikes that took minutes.
const RELATE_MAX_WORK: usize = 1 << 16;

/// Past this many pairs of parts touching at points, their interiors are told apart by area (parts against union)
/// instead of pair by pair.
const TOUCHING_RELATED: usize = 2_000;

/// Share of the parts' total area an overlap must exceed to count, in the area test: the overlay rounds vertices to
/// its integer grid, which moves areas by far less.
const OVERLAP_TOLERANCE: f64 = 1e-7;

/// Points of all of `p`'s rings, closing points included.
pub(crate) fn vertex_count(p: &Polygon) -> usize {
    std::iter::once(p.exterior())
        .chain(p.interiors())
        .map(|r| r.0.len())
        .sum()
}

/// Exact orientation of `c` against the line `a` → `b`: > 0 left, 0 on it.
fn orient(a: Coord, b: Coord, c: Coord) -> f64 {
    let p = |q: Coord| robust::Coord { x: q.x, y: q.y };
    robust::orient2d(p(a), p(b), p(c))
}

/// Where the boundary of a valid polygon `p` lies against a valid polygon `q`. The boundaries are cut at
/// every point where they meet; each open piece of `p`'s boundary between two such points then lies wholly
/// inside `q`, wholly outside it, or along its boundary — the midpoint of the piece tells which (exact
/// orientation tests; the midpoint is rounded, so a piece shorter than a few ulps could be misjudged).
#[derive(Debug, Default)]
struct Sides {
    /// The boundaries cross somewhere, or share a piece of line.
    crosses_or_shares: bool,
    /// Some piece of `p`'s boundary lies in `q`'s interior.
    inside: bool,
    /// Some piece of `p`'s boundary lies outside `q`.
    outside: bool,
}

/// A polygon's boundary segments with an R-tree over them, for locating points and cutting other boundaries.
struct Boundary {
    lines: Vec<Line>,
    tree: Boxes,
}

impl Boundary {
    fn of(q: &Polygon) -> Boundary {
        let lines: Vec<Line> = std::iter::once(q.exterior())
            .chain(q.interiors())
            .flat_map(|r| r.lines())
            .filter(|l| l.start != l.end)
            .collect();
        let tree = segment_tree(lines.iter());
        Boundary { lines, tree }
    }
}

impl Sides {
    fn of(p: &Polygon, q: &Polygon) -> Sides {
        Sides::against(p, &Boundary::of(q))
    }

    fn against(p: &Polygon, q: &Boundary) -> Sides {
        let (q_lines, tree) = (&q.lines, &q.tree);
        let mut sides = Sides::default();
        let mut cuts: Vec<f64> = Vec::new();
        for s in std::iter::once(p.exterior())
            .chain(p.interiors())
            .flat_map(|r| r.lines())
            .filter(|l| l.start != l.end)
        {
            let (a, b) = (s.start, s.end);
            let d = b - a;
            let along = |c: Coord| ((c - a).x * d.x + (c - a).y * d.y) / (d.x * d.x + d.y * d.y);
            cuts.clear();
            cuts.extend([0.0, 1.0]);
            let env = AABB::from_corners([a.x, a.y], [b.x, b.y]);
            for t in tree.locate_in_envelope_intersecting(&env) {
                let t = q_lines[t.data];
                let (o1, o2) = (orient(t.start, t.end, a), orient(t.start, t.end, b));
                let (o3, o4) = (orient(a, b, t.start), orient(a, b, t.end));
                if o1 * o2 < 0.0 && o3 * o4 < 0.0 {
                    sides.crosses_or_shares = true;
                    return sides;
                }
                if o1 == 0.0 && o2 == 0.0 {
                    // Collinear: a shared piece when their spans along s overlap by more than a point.
                    let (u, v) = (along(t.start), along(t.end));
                    if u.max(v).min(1.0) > u.min(v).max(0.0) {
                        sides.crosses_or_shares = true;
                        return sides;
                    }
                }
                // Touching: an end of one on the other cuts s there.
                for (o, c) in [(o3, t.start), (o4, t.end)] {
                    if o == 0.0 && on_box(c, a, b) {
                        cuts.push(along(c).clamp(0.0, 1.0));
                    }
                }
            }
            cuts.sort_by(f64::total_cmp);
            for w in cuts.windows(2) {
                if w[1] <= w[0] {
                    continue;
                }
                let m = a + d * ((w[0] + w[1]) / 2.0);
                match locate(m, q_lines, tree) {
                    Some(true) => sides.inside = true,
                    Some(false) => sides.outside = true,
                    None => {}
                }
            }
        }
        sides
    }
}

/// Whether `c` lies in the bounding box of `a`–`b` (with an orientation of 0, on the segment).
fn on_box(c: Coord, a: Coord, b: Coord) -> bool {
    c.x >= a.x.min(b.x) && c.x <= a.x.max(b.x) && c.y >= a.y.min(b.y) && c.y <= a.y.max(b.y)
}

/// `Some(true)` when `m` is in the interior of the polygon whose boundary segments are `lines`,
/// `Some(false)` outside, `None` on the boundary: the parity of the segments a ray towards +x crosses
/// (half-open in y, exact orientations).
fn locate(m: Coord, lines: &[Line], tree: &Boxes) -> Option<bool> {
    let ray = AABB::from_corners([m.x, m.y], [f64::MAX, m.y]);
    let mut inside = false;
    for g in tree.locate_in_envelope_intersecting(&ray) {
        let l = lines[g.data];
        let (a, b) = (l.start, l.end);
        let o = orient(a, b, m);
        if o == 0.0 && on_box(m, a, b) {
            return None;
        }
        if (a.y > m.y) != (b.y > m.y) {
            // The segment spans the ray's height; it crosses the ray when m is on its left going up, or on
            // its right going down.
            if (b.y > a.y && o > 0.0) || (b.y < a.y && o < 0.0) {
                inside = !inside;
            }
        }
    }
    Some(inside)
}

/// `mp.is_valid()`, faster for large rings and many parts: every part valid, parts neither overlapping nor
/// sharing a line. Only parts whose bounding boxes meet are related to each other (an R-tree): comparing every
/// pair took 87 s for 50,000 parts.
pub(crate) fn multipolygon_is_valid(mp: &MultiPolygon) -> bool {
    if !mp.0.iter().all(polygon_is_valid) {
        return false;
    }
    let boxes = polygon_boxes(&mp.0);
    let tree = RTree::bulk_load(boxes.clone());
    // Parts nested in one another's holes all have meeting boxes: past this many pairs, one pass over every segment
    // instead (4,000 concentric rings were 8·10⁶ relations, 16 s).
    const PAIRS_RELATED: usize = 10_000;
    let pairs = boxes
        .iter()
        .flat_map(|b| {
            tree.locate_in_envelope_intersecting(&b.geom().envelope())
                .filter(move |o| o.data > b.data)
        })
        .take(PAIRS_RELATED + 1)
        .count();
    if pairs > PAIRS_RELATED {
        if let Some(valid) = parts_meet_at_points_only(mp) {
            return valid;
        }
    }
    all_pairs_meet_at_points_only(mp, &boxes, &tree)
}

/// Whether parts `p` and `q` (each valid) neither overlap nor share a line: geo's `relate`, or [`Sides`] for large
/// ones.
fn pair_meets_at_points_only(p: &Polygon, q: &Polygon) -> bool {
    if vertex_count(p).saturating_mul(vertex_count(q)) > RELATE_MAX_WORK {
        let (pq, qp) = (Sides::of(p, q), Sides::of(q, p));
        return !(pq.crosses_or_shares || pq.inside || qp.inside);
    }
    let m = p.relate(q);
    m.get(CoordPos::Inside, CoordPos::Inside) != Dimensions::TwoDimensional
        && m.get(CoordPos::OnBoundary, CoordPos::OnBoundary) != Dimensions::OneDimensional
}

/// Every pair of parts whose boxes meet, related.
fn all_pairs_meet_at_points_only(
    mp: &MultiPolygon,
    boxes: &[GeomWithData<Rectangle<[f64; 2]>, usize>],
    tree: &Boxes,
) -> bool {
    boxes.iter().all(|b| {
        let p = &mp.0[b.data];
        tree.locate_in_envelope_intersecting(&b.geom().envelope())
            .filter(|o| o.data > b.data)
            .all(|o| pair_meets_at_points_only(p, &mp.0[o.data]))
    })
}

/// Whether the parts of `mp` (each valid) have disjoint interiors and boundaries meeting at points only, in one
/// pass over all their segments: no segment of one part crosses or runs along one of another, and no part's outer
/// ring lies in another's interior (one point of it located against every other part by the parity of a ray's
/// crossings, counted per part). `None` when no point of some part's outer ring is off the other parts' boundaries
/// (then the caller relates pairs).
fn parts_meet_at_points_only(mp: &MultiPolygon) -> Option<bool> {
    let segments: Vec<(Line, usize)> =
        mp.0.iter()
            .enumerate()
            .flat_map(|(k, p)| {
                std::iter::once(p.exterior())
                    .chain(p.interiors())
                    .flat_map(|r| r.lines())
                    .filter(|l| l.start != l.end)
                    .map(move |l| (l, k))
            })
            .collect();
    let tree = segment_tree(segments.iter().map(|(l, _)| l));
    // Parts whose boundaries touch at a point: a ray's parity cannot tell whether they overlap there (a square and a
    // triangle through two of its corners), so these pairs are related as a pair.
    let mut touching: Vec<(usize, usize)> = Vec::new();
    for (i, &(s, k)) in segments.iter().enumerate() {
        let env = AABB::from_corners([s.start.x, s.start.y], [s.end.x, s.end.y]);
        for g in tree.locate_in_envelope_intersecting(&env) {
            // Each pair of segments once, from its lower index.
            let (t, q) = segments[g.data];
            if q == k || g.data < i {
                continue;
            }
            let (a, b) = (s.start, s.end);
            let (o1, o2) = (orient(t.start, t.end, a), orient(t.start, t.end, b));
            let (o3, o4) = (orient(a, b, t.start), orient(a, b, t.end));
            if o1 * o2 < 0.0 && o3 * o4 < 0.0 {
                return Some(false);
            }
            if o1 == 0.0 && o2 == 0.0 {
                let d = b - a;
                let along =
                    |c: Coord| ((c - a).x * d.x + (c - a).y * d.y) / (d.x * d.x + d.y * d.y);
                let (u, v) = (along(t.start), along(t.end));
                if u.max(v).min(1.0) > u.min(v).max(0.0) {
                    return Some(false);
                }
            }
            let touch = (o1 == 0.0 && on_box(a, t.start, t.end))
                || (o2 == 0.0 && on_box(b, t.start, t.end))
                || (o3 == 0.0 && on_box(t.start, a, b))
                || (o4 == 0.0 && on_box(t.end, a, b));
            // Past the bound only the count matters (a fan's every pair touches at its centre: n² pairs).
            if touch && touching.len() <= 2 * TOUCHING_RELATED {
                touching.push((k.min(q), k.max(q)));
                if touching.len() > 2 * TOUCHING_RELATED {
                    touching.sort_unstable();
                    touching.dedup();
                }
            }
        }
    }
    touching.sort_unstable();
    touching.dedup();
    if touching.len() > TOUCHING_RELATED {
        // Boundaries that meet at points only (no crossing, no shared stretch: checked above) leave the interiors
        // disjoint exactly when the parts' areas add up to their union's: one overlay instead of relating every
        // touching pair (a fan of 3,000 triangles around one point is 4.5 million pairs, 8.5 s).
        let sum: f64 = mp.0.iter().map(geo::Area::unsigned_area).sum();
        let union = geo::Area::unsigned_area(&citylod_geom::union_nonzero(&mp.0));
        return Some(sum - union <= OVERLAP_TOLERANCE * sum);
    }
    if !touching
        .iter()
        .all(|&(k, q)| pair_meets_at_points_only(&mp.0[k], &mp.0[q]))
    {
        return Some(false);
    }
    let on_other = |m: Coord, k: usize| {
        let at = AABB::from_point([m.x, m.y]);
        tree.locate_in_envelope_intersecting(&at).any(|g| {
            let (l, q) = segments[g.data];
            q != k && orient(l.start, l.end, m) == 0.0 && on_box(m, l.start, l.end)
        })
    };
    let mut parity = vec![false; mp.0.len()];
    let mut flipped: Vec<usize> = Vec::new();
    for (k, p) in mp.0.iter().enumerate() {
        let m = p
            .exterior()
            .lines()
            .filter(|l| l.start != l.end)
            .map(|l| l.start + (l.end - l.start) * 0.5)
            .find(|&m| !on_other(m, k))?;
        let ray = AABB::from_corners([m.x, m.y], [f64::MAX, m.y]);
        for g in tree.locate_in_envelope_intersecting(&ray) {
            let (l, q) = segments[g.data];
            if q == k {
                continue;
            }
            let (a, b) = (l.start, l.end);
            if (a.y > m.y) != (b.y > m.y) {
                let o = orient(a, b, m);
                if (b.y > a.y && o > 0.0) || (b.y < a.y && o < 0.0) {
                    parity[q] = !parity[q];
                    flipped.push(q);
                }
            }
        }
        if flipped.iter().any(|&q| parity[q]) {
            return Some(false);
        }
        for q in flipped.drain(..) {
            parity[q] = false;
        }
    }
    Some(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo_types::Coord;

    fn ring(pts: &[(f64, f64)]) -> LineString {
        let mut v: Vec<Coord> = pts.iter().map(|&(x, y)| Coord { x, y }).collect();
        v.push(v[0]);
        LineString::from(v)
    }

    /// A wavy circle of `n` vertices, radius ~`r`, centred at (cx, cy), counter-clockwise.
    fn circle(n: usize, r: f64, cx: f64, cy: f64) -> Vec<(f64, f64)> {
        (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                let rr = r * (1.0 + 0.05 * (12.0 * a).sin());
                (cx + rr * a.cos(), cy + rr * a.sin())
            })
            .collect()
    }

    /// `n` thin triangles around (cx, cy), all touching at that point only, counter-clockwise.
    fn fan(n: usize, cx: f64, cy: f64) -> Vec<Polygon> {
        (0..n)
            .map(|k| {
                let a0 = std::f64::consts::TAU * k as f64 / n as f64;
                let a1 = std::f64::consts::TAU * (k as f64 + 0.5) / n as f64;
                let p = |a: f64| (cx + 100.0 * a.cos(), cy + 100.0 * a.sin());
                Polygon::new(ring(&[(cx, cy), p(a0), p(a1)]), vec![])
            })
            .collect()
    }

    #[test]
    fn parts_touching_at_one_point_by_thousands_are_checked_by_area() {
        // A fan of 3,000 triangles meeting at its centre: 4.5 million touching pairs, once related one by one
        // (8.5 s; 9,000 took 110 s and 2.5 GB), now told apart by comparing the parts' areas with their union's.
        let valid = MultiPolygon(fan(3000, 0.0, 0.0));
        assert!(multipolygon_is_valid(&valid));
        // The same fan beside a square and a triangle whose boundaries meet at two corners only while their
        // interiors overlap (the triangle's edge is the square's diagonal): invalid, by area as pair by pair.
        let square = Polygon::new(
            ring(&[(1000.0, 0.0), (1002.0, 0.0), (1002.0, 2.0), (1000.0, 2.0)]),
            vec![],
        );
        let across = Polygon::new(ring(&[(1000.0, 0.0), (1002.0, 2.0), (999.0, 3.0)]), vec![]);
        let pair = MultiPolygon(vec![square.clone(), across.clone()]);
        assert!(!multipolygon_is_valid(&pair));
        let mut parts = fan(3000, 0.0, 0.0);
        parts.extend([square, across]);
        assert!(!multipolygon_is_valid(&MultiPolygon(parts)));
        // Small fans take the pairwise path and agree.
        assert!(multipolygon_is_valid(&MultiPolygon(fan(40, 0.0, 0.0))));
    }

    #[test]
    fn the_segment_tree_finds_what_geo_finds() {
        // Random rings (most cross themselves), touching rings and spikes, against geo's own test.
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 33) % 11) as f64
        };
        let mut crossing_seen = [0usize; 2];
        for n in 3..40 {
            for _ in 0..40 {
                let pts: Vec<(f64, f64)> = (0..n).map(|_| (rnd(), rnd())).collect();
                let r = ring(&pts);
                let p = Polygon::new(r.clone(), vec![]);
                let geo_says = p.is_valid();
                let mut distinct = r.0.clone();
                distinct.dedup();
                if distinct.len() != r.0.len() {
                    continue; // the reader drops repeated points before validity is asked
                }
                assert_eq!(ring_is_valid(&r), geo_says, "{pts:?}");
                crossing_seen[usize::from(geo_says)] += 1;
            }
        }
        assert!(
            crossing_seen[0] > 100 && crossing_seen[1] > 10,
            "{crossing_seen:?}"
        );
        // A ring through one vertex twice, end to start (geo accepts it), and a bowtie (it does not).
        let touch = ring(&[(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (1.0, 0.0), (0.0, 2.0)]);
        assert_eq!(
            ring_is_valid(&touch),
            Polygon::new(touch.clone(), vec![]).is_valid()
        );
        let bowtie = ring(&[(0.0, 0.0), (2.0, 2.0), (2.0, 0.0), (0.0, 2.0)]);
        assert!(!ring_is_valid(&bowtie));
    }

    #[test]
    fn large_polygons_and_multipolygons_agree_with_geo() {
        let big = circle(2_000, 100.0, 0.0, 0.0);
        let hole = circle(1_000, 30.0, 0.0, 0.0)
            .into_iter()
            .rev()
            .collect::<Vec<_>>();
        let hole_out = circle(1_000, 30.0, 500.0, 0.0)
            .into_iter()
            .rev()
            .collect::<Vec<_>>();
        let mut crossed = big.clone();
        crossed.swap(10, 1_500);
        let cases = [
            Polygon::new(ring(&big), vec![]),
            Polygon::new(ring(&big), vec![ring(&hole)]),
            Polygon::new(ring(&big), vec![ring(&hole_out)]),
            Polygon::new(ring(&big), vec![ring(&hole), ring(&hole)]),
            Polygon::new(ring(&crossed), vec![]),
        ];
        let expected = [true, true, false, false, false];
        for (p, want) in cases.iter().zip(expected) {
            assert_eq!(p.is_valid(), want);
            assert_eq!(polygon_is_valid(p), want);
        }
        let apart = Polygon::new(ring(&circle(2_000, 100.0, 300.0, 0.0)), vec![]);
        let overlapping = Polygon::new(ring(&circle(2_000, 100.0, 150.0, 0.0)), vec![]);
        for (mp, want) in [
            (MultiPolygon(vec![cases[0].clone(), apart]), true),
            (MultiPolygon(vec![cases[0].clone(), overlapping]), false),
        ] {
            assert_eq!(mp.is_valid(), want);
            assert_eq!(multipolygon_is_valid(&mp), want);
        }
    }

    #[test]
    fn many_parts_agree_with_geo() {
        // A 20 × 20 grid of unit squares 0.5 apart (valid), then with one pair touching at a corner (valid),
        // sharing an edge (invalid) and overlapping (invalid).
        let square = |x: f64, y: f64| {
            Polygon::new(
                ring(&[(x, y), (x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0)]),
                vec![],
            )
        };
        let grid: Vec<Polygon> = (0..400)
            .map(|k| square((k % 20) as f64 * 1.5, (k / 20) as f64 * 1.5))
            .collect();
        for (extra, want) in [
            (None, true),
            (Some(square(-1.0, -1.0)), true),
            (Some(square(-1.0, 0.0)), false),
            (Some(square(28.7, 28.7)), false),
        ] {
            let mut parts = grid.clone();
            parts.extend(extra);
            let mp = MultiPolygon(parts);
            assert_eq!(mp.is_valid(), want);
            assert_eq!(multipolygon_is_valid(&mp), want);
            // The one-pass check (used past PAIRS_RELATED pairs) gives the same verdicts.
            assert_eq!(parts_meet_at_points_only(&mp), Some(want));
        }
    }

    #[test]
    fn many_holes_agree_with_geo() {
        // A 50 × 50 shell with a 20 × 20 grid of unit holes 0.5 apart (valid, past DIRECT_HOLES), then with one
        // more hole touching another at a corner (valid), sharing an edge (invalid), overlapping one (invalid),
        // touching the shell at a corner (valid) and sticking out of it (invalid).
        let square =
            |x: f64, y: f64| ring(&[(x, y), (x, y + 1.0), (x + 1.0, y + 1.0), (x + 1.0, y)]);
        let shell = ring(&[(0.0, 0.0), (50.0, 0.0), (50.0, 50.0), (0.0, 50.0)]);
        let grid: Vec<LineString> = (0..400)
            .map(|k| square(2.0 + (k % 20) as f64 * 1.5, 2.0 + (k / 20) as f64 * 1.5))
            .collect();
        for (extra, want) in [
            (None, true),
            (Some(square(1.0, 1.0)), true),
            (Some(square(1.0, 2.0)), false),
            (Some(square(2.5, 2.5)), false),
            (
                Some(ring(&[(25.0, 50.0), (24.0, 49.0), (26.0, 49.0)])),
                true,
            ),
            (Some(square(49.5, 20.0)), false),
        ] {
            let mut holes = grid.clone();
            holes.extend(extra.clone());
            let p = Polygon::new(shell.clone(), holes);
            assert_eq!(p.is_valid(), want, "{extra:?}");
            assert_eq!(polygon_is_valid(&p), want, "{extra:?}");
        }
    }

    #[test]
    fn nested_parts_agree_with_geo() {
        // 150 concentric square annuli, each in the hole of the next (valid; past PAIRS_RELATED pairs of boxes), then
        // with one annulus widened to share its outline with the next one's hole (invalid) or to overlap it
        // (invalid), or replaced by a solid diamond over the annuli inside it (invalid).
        let square = |h: f64| ring(&[(-h, -h), (h, -h), (h, h), (-h, h)]);
        let annulus = |k: usize, widen: f64| {
            let r = 2.0 * k as f64 + 1.0;
            Polygon::new(square(r + 0.5 + widen), vec![square(r)])
        };
        let diamond = |k: usize| {
            // Inside annulus k's hole, its corners touching the hole's sides at their midpoints.
            let r = 2.0 * k as f64 + 1.0;
            ring(&[(0.0, -r), (r, 0.0), (0.0, r), (-r, 0.0)])
        };
        let nested = |change: Option<(usize, Polygon)>| {
            let mut parts: Vec<Polygon> = (1..=150).map(|k| annulus(k, 0.0)).collect();
            if let Some((k, p)) = change {
                parts[k - 1] = p;
            }
            MultiPolygon(parts)
        };
        for (change, want) in [
            (None, true),
            (Some((10, annulus(10, 1.5))), false),
            (Some((10, annulus(10, 1.8))), false),
            (Some((10, Polygon::new(diamond(11), vec![]))), false),
        ] {
            let mp = nested(change.clone());
            assert_eq!(mp.is_valid(), want, "{:?}", change.as_ref().map(|c| c.0));
            assert_eq!(
                multipolygon_is_valid(&mp),
                want,
                "{:?}",
                change.as_ref().map(|c| c.0)
            );
            assert_eq!(parts_meet_at_points_only(&mp), Some(want));
        }
        // Two parts overlapping while their boundaries meet only at vertices (a square and a triangle through two of
        // its corners), among the annuli.
        let mut parts = nested(None).0;
        parts.push(Polygon::new(
            ring(&[(400.0, 0.0), (402.0, 0.0), (402.0, 2.0), (400.0, 2.0)]),
            vec![],
        ));
        parts.push(Polygon::new(
            ring(&[(402.0, 0.0), (403.0, 3.0), (400.0, 2.0)]),
            vec![],
        ));
        let mp = MultiPolygon(parts);
        assert!(!mp.is_valid());
        assert_eq!(parts_meet_at_points_only(&mp), Some(false));
        assert!(!multipolygon_is_valid(&mp));
        // A diamond in the innermost hole touching it at four points, and a small square inside a band.
        let mut parts = nested(None).0;
        parts.push(Polygon::new(diamond(1), vec![]));
        let mp = MultiPolygon(parts.clone());
        assert!(mp.is_valid());
        assert!(multipolygon_is_valid(&mp));
        assert_eq!(parts_meet_at_points_only(&mp), Some(true));
        parts.push(Polygon::new(
            ring(&[(5.1, 0.0), (5.3, 0.0), (5.3, 0.2), (5.1, 0.2)]),
            vec![],
        ));
        let mp = MultiPolygon(parts);
        assert!(!mp.is_valid());
        assert!(!multipolygon_is_valid(&mp));
        assert_eq!(parts_meet_at_points_only(&mp), Some(false));
    }

    /// geo's verdict on a pair of parts and on a hole in a shell, against [`Sides`].
    fn pair_by_geo(p: &Polygon, q: &Polygon) -> bool {
        let m = p.relate(q);
        m.get(CoordPos::Inside, CoordPos::Inside) != Dimensions::TwoDimensional
            && m.get(CoordPos::OnBoundary, CoordPos::OnBoundary) != Dimensions::OneDimensional
    }
    fn pair_by_sides(p: &Polygon, q: &Polygon) -> bool {
        let (pq, qp) = (Sides::of(p, q), Sides::of(q, p));
        !(pq.crosses_or_shares || pq.inside || qp.inside)
    }
    fn hole_by_geo(shell: &Polygon, h: &Polygon) -> bool {
        let m = shell.relate(h);
        m.is_contains()
            && m.get(CoordPos::OnBoundary, CoordPos::OnBoundary) != Dimensions::OneDimensional
    }
    fn hole_by_sides(shell: &Polygon, h: &Polygon) -> bool {
        let hs = Sides::of(h, shell);
        !(hs.crosses_or_shares || hs.outside || !hs.inside)
    }

    #[test]
    fn sides_agree_with_geo_on_pairs_and_holes() {
        // Small integer polygons on a 9 × 9 grid, so that vertices land on each other's edges, edges run
        // along each other and corners touch: every kind of contact, many times over.
        let mut seed = 777u64;
        let mut rnd = |k: u64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 33) % k) as f64
        };
        let shape = |rnd: &mut dyn FnMut(u64) -> f64| -> Polygon {
            let (x, y) = (rnd(7), rnd(7));
            let (w, h) = (1.0 + rnd(4), 1.0 + rnd(4));
            match rnd(3) as u32 {
                0 => Polygon::new(
                    ring(&[(x, y), (x + w, y), (x + w, y + h), (x, y + h)]),
                    vec![],
                ),
                1 => Polygon::new(ring(&[(x, y), (x + w, y), (x, y + h)]), vec![]),
                _ => Polygon::new(
                    ring(&[
                        (x, y),
                        (x + w, y),
                        (x + w, y + 1.0),
                        (x + 1.0, y + 1.0),
                        (x + 1.0, y + h),
                        (x, y + h),
                    ]),
                    vec![],
                ),
            }
        };
        let (mut pairs_valid, mut pairs_invalid, mut holes_valid, mut holes_invalid) = (0, 0, 0, 0);
        for _ in 0..3_000 {
            let (p, q) = (shape(&mut rnd), shape(&mut rnd));
            if !p.is_valid() || !q.is_valid() {
                continue;
            }
            let want = pair_by_geo(&p, &q);
            assert_eq!(pair_by_sides(&p, &q), want, "{p:?} {q:?}");
            if want {
                pairs_valid += 1
            } else {
                pairs_invalid += 1
            }
            // The small shape as a hole in the other, and in an L-shaped shell around most of the grid.
            let shell = Polygon::new(
                ring(&[
                    (0.0, 0.0),
                    (9.0, 0.0),
                    (9.0, 5.0),
                    (5.0, 5.0),
                    (5.0, 9.0),
                    (0.0, 9.0),
                ]),
                vec![],
            );
            for (shell, h) in [(&p, &q), (&shell, &q)] {
                let want = hole_by_geo(shell, h);
                assert_eq!(hole_by_sides(shell, h), want, "{shell:?} {h:?}");
                if want {
                    holes_valid += 1
                } else {
                    holes_invalid += 1
                }
            }
        }
        assert!(
            pairs_valid > 200 && pairs_invalid > 200,
            "{pairs_valid} {pairs_invalid}"
        );
        assert!(
            holes_valid > 300 && holes_invalid > 1_000,
            "{holes_valid} {holes_invalid}"
        );
    }

    /// A star of 20,000 long spikes with a square overlapping one tip, and apart from it; a small hole
    /// in the star's core. geo's `relate` took minutes on these; here they go through [`Sides`].
    #[test]
    fn a_spiky_star_and_its_neighbours_are_checked() {
        let n = 20_000;
        let star: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                let r = if i % 2 == 0 { 100.0 } else { 20.0 };
                (r * a.cos(), r * a.sin())
            })
            .collect();
        let star = Polygon::new(ring(&star), vec![]);
        let square = |x: f64| {
            Polygon::new(
                ring(&[(x, -5.0), (x + 20.0, -5.0), (x + 20.0, 5.0), (x, 5.0)]),
                vec![],
            )
        };
        let overlapping = MultiPolygon(vec![star.clone(), square(90.0)]);
        let apart = MultiPolygon(vec![star.clone(), square(101.0)]);
        assert!(!multipolygon_is_valid(&overlapping));
        assert!(multipolygon_is_valid(&apart));
        let hole = ring(&[(-5.0, -5.0), (-5.0, 5.0), (5.0, 5.0), (5.0, -5.0)]);
        let holed = Polygon::new(star.exterior().clone(), vec![hole]);
        assert!(polygon_is_valid(&holed));
        let hole_out = ring(&[(95.0, 50.0), (95.0, 60.0), (105.0, 60.0), (105.0, 50.0)]);
        assert!(!polygon_is_valid(&Polygon::new(
            star.exterior().clone(),
            vec![hole_out]
        )));
    }

    #[test]
    fn a_ring_of_a_hundred_thousand_vertices_is_checked() {
        let p = Polygon::new(ring(&circle(100_000, 200.0, 0.0, 0.0)), vec![]);
        assert!(polygon_is_valid(&p));
        let mut pts = circle(100_000, 200.0, 0.0, 0.0);
        pts.swap(5, 60_000);
        assert!(!polygon_is_valid(&Polygon::new(ring(&pts), vec![])));
    }

    /// A comb of 200 long parallel teeth with one twist: one crossing pair among ~20,000 pairs of overlapping
    /// boxes. Counted in full it is found; with a budget of 1,000 tests the count gives up.
    #[test]
    fn crossings_are_counted_within_a_budget_of_tests() {
        let mut pts: Vec<(f64, f64)> = Vec::new();
        for k in 0..200 {
            let x = k as f64;
            pts.extend([
                (x, 0.0),
                (x + 300.0, 300.0),
                (x + 300.5, 300.0),
                (x + 0.5, 0.0),
            ]);
        }
        pts.extend([(210.0, -10.0), (-10.0, -10.0)]);
        pts.swap(401, 402);
        let p = Polygon::new(ring(&pts), vec![]);
        assert!(!polygon_is_valid(&p));
        assert_eq!(crossings_up_to(&p, 100, usize::MAX), Some(1));
        assert_eq!(crossings_up_to(&p, 100, 1_000), None);
        // The count stops at the cap.
        let star: Vec<(f64, f64)> = (0..101)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU * 0.37;
                let r = if i % 2 == 0 { 50.0 } else { 20.0 };
                (r * a.cos(), r * a.sin())
            })
            .collect();
        let star = Polygon::new(ring(&star), vec![]);
        assert_eq!(crossings_up_to(&star, 10, usize::MAX), Some(10));
    }
}
