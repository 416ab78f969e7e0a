//! Sparse candidate graph for single-link clustering (DESIGN.md §3.1): every pair of buildings whose
//! bounding boxes lie within `reach_m` of each other (rstar R-tree), plus every Delaunay edge (spade) of
//! footprint vertices that joins two different buildings, so the graph is connected. Edge weights are
//! adjacent distances (seed 000 §3.1, m), computed in parallel. Invariant: edges are unique `a < b`
//! pairs sorted by (a, b), and the graph over all buildings is connected.

use crate::adjacent::adjacent_distance;
use crate::single_link::{Merge, UnionFind};
use citylod_model::Footprint;
use geo::Area;
use rayon::prelude::*;
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{RTree, AABB};
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};

/// An edge of the candidate graph: buildings `a < b` (indices) and their adjacent distance (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CandidateEdge {
    pub a: u32,
    pub b: u32,
    pub d_m: f64,
}

/// How the candidate pairs were found.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct GraphStats {
    /// The bounding-box reach used (m).
    pub reach_m: f64,
    /// Distinct pairs found by the R-tree reach query.
    pub n_reach_pairs: usize,
    /// Distinct pairs found by the Delaunay triangulation.
    pub n_delaunay_pairs: usize,
    /// Points inserted into the triangulation.
    pub n_delaunay_points: usize,
    /// Edges added only to join components the two searches left apart (0 on sound input).
    pub n_fallback_edges: usize,
    /// Footprints identical to an earlier one (same vertices, bit for bit): each is joined to the first
    /// of its kind at distance 0 and left out of the searches, so a pile of k copies costs k − 1 edges
    /// instead of k(k − 1)/2.
    pub n_duplicate_footprints: usize,
    /// The reach of the refinement pass (m); merges below (1 − λ)·reach_far_m equal brute force.
    pub reach_far_m: f64,
    /// Pairs added by the refinement pass ([`refine_pairs`]).
    pub n_refine_pairs: usize,
    /// Distinct candidate edges in total.
    pub n_edges: usize,
}

/// The automatic reach rule: `factor` × the median of √(footprint area) over the buildings, i.e. a
/// fraction of the typical building size (m). 0 when there are no buildings.
pub fn auto_reach_m(footprints: &[&Footprint], factor: f64) -> f64 {
    let mut sizes: Vec<f64> = footprints
        .iter()
        .map(|f| f.unsigned_area().sqrt())
        .filter(|s| s.is_finite())
        .collect();
    if sizes.is_empty() {
        return 0.0;
    }
    let mid = sizes.len() / 2;
    let (_, median, _) = sizes.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    factor * *median
}

/// Builds the candidate graph over `footprints` (local ENU m; index = building index): the pairs of
/// [`candidate_pairs`] weighted by [`weigh_pairs`].
/// The reach pairs are weighed while the (serial) triangulation runs, on the core it leaves idle; the rest
/// after it. The edges are those of [`weigh_pairs`] over [`candidate_pairs`], in the same order.
pub fn candidate_graph(
    footprints: &[&Footprint],
    reach_m: f64,
    lambda_adjacent: f64,
    max_points_per_building: usize,
) -> (Vec<CandidateEdge>, GraphStats) {
    let (pairs, stats, reach_edges) =
        candidate_pairs_with(footprints, reach_m, max_points_per_building, |reach| {
            weigh_pairs(footprints, reach, lambda_adjacent)
        });
    // Both lists are sorted by pair: take a reach pair's weight, compute the others'.
    let mut next = reach_edges.iter().peekable();
    let todo: Vec<(u32, u32)> = pairs
        .iter()
        .copied()
        .filter(|&(a, b)| {
            while next.next_if(|e| (e.a, e.b) < (a, b)).is_some() {}
            next.next_if(|e| (e.a, e.b) == (a, b)).is_none()
        })
        .collect();
    let mut computed = weigh_pairs(footprints, &todo, lambda_adjacent).into_iter();
    let mut known = reach_edges.into_iter().peekable();
    let edges = pairs
        .iter()
        .map(|&(a, b)| match known.next_if(|e| (e.a, e.b) == (a, b)) {
            Some(e) => e,
            None => computed.next().expect("one computed edge per other pair"),
        })
        .collect();
    (edges, stats)
}

/// The candidate pairs (a < b, sorted, unique) over `footprints`: R-tree reach pairs, Delaunay pairs
/// and, if those leave the graph disconnected, one fallback edge from each component to the previous
/// one (components ordered by their first building). `max_points_per_building` caps how many
/// exterior vertices of one footprint enter the triangulation (evenly spaced, at least 1).
/// Footprints without finite vertices only join through the fallback edges.
pub fn candidate_pairs(
    footprints: &[&Footprint],
    reach_m: f64,
    max_points_per_building: usize,
) -> (Vec<(u32, u32)>, GraphStats) {
    let (pairs, stats, ()) =
        candidate_pairs_with(footprints, reach_m, max_points_per_building, |_| ());
    (pairs, stats)
}

/// [`candidate_pairs`], running `beside` on the reach pairs (sorted, unique) while the triangulation runs.
fn candidate_pairs_with<R: Send>(
    footprints: &[&Footprint],
    reach_m: f64,
    max_points_per_building: usize,
    beside: impl FnOnce(&[(u32, u32)]) -> R + Send,
) -> (Vec<(u32, u32)>, GraphStats, R) {
    let n = footprints.len();
    let first = first_of_kind(footprints);
    let boxes = searched_boxes(footprints, &first);

    // The triangulation is serial: the reach search, and what the caller does with its pairs, run beside it.
    let ((delaunay_pairs, n_points), (reach_pairs, beside_out)) = rayon::join(
        || delaunay_pairs(footprints, &first, max_points_per_building),
        || {
            let pairs = reach_pairs(&boxes, reach_m);
            let out = beside(&pairs);
            (pairs, out)
        },
    );
    let twins: Vec<(u32, u32)> = (0..n as u32)
        .filter(|&i| first[i as usize] != i)
        .map(|i| (first[i as usize], i))
        .collect();
    let mut pairs: Vec<(u32, u32)> =
        Vec::with_capacity(reach_pairs.len() + delaunay_pairs.len() + twins.len());
    pairs.extend_from_slice(&reach_pairs);
    pairs.extend_from_slice(&delaunay_pairs);
    pairs.extend_from_slice(&twins);
    pairs.sort_unstable();
    pairs.dedup();

    let mut uf = UnionFind::new(n);
    for &(a, b) in &pairs {
        uf.union(a, b);
    }
    let mut firsts: Vec<u32> = Vec::new(); // first building of each component, in building order
    let mut seen = vec![false; n];
    for i in 0..n as u32 {
        let r = uf.find(i) as usize;
        if !std::mem::replace(&mut seen[r], true) {
            firsts.push(i);
        }
    }
    let n_fallback_edges = firsts.len().saturating_sub(1);
    if n_fallback_edges > 0 {
        pairs.extend(firsts.windows(2).map(|w| (w[0], w[1])));
        pairs.sort_unstable();
        pairs.dedup();
    }
    let stats = GraphStats {
        reach_m,
        n_reach_pairs: reach_pairs.len(),
        n_delaunay_pairs: delaunay_pairs.len(),
        n_delaunay_points: n_points,
        n_fallback_edges,
        n_duplicate_footprints: twins.len(),
        reach_far_m: 0.0,
        n_refine_pairs: 0,
        n_edges: pairs.len(),
    };
    (pairs, stats, beside_out)
}

/// Resolution of the merge distances (m): adjacent distances are rounded to this grid before
/// clustering, so differences below it are ties. The same city stored with a coarser coordinate grid
/// (a File Geodatabase's 1e-9°, a GeoJSON export's 7 decimals) or projected differently moves its
/// distances by fractions of a millimetre; unrounded, those differences order merges that are equal
/// in the city, and on a regular town they decide where the levels' thresholds fall. Half the 2 cm
/// grid the writer stores exact buildings on, and far below any level threshold.
pub const DISTANCE_RESOLUTION_M: f64 = 0.01;

/// `d_m` on the [`DISTANCE_RESOLUTION_M`] grid (nearest step; infinities and NaN unchanged).
pub fn on_distance_grid(d_m: f64) -> f64 {
    if d_m.is_finite() {
        (d_m / DISTANCE_RESOLUTION_M).round() * DISTANCE_RESOLUTION_M
    } else {
        d_m
    }
}

/// Adjacent distance of every pair, on the [`DISTANCE_RESOLUTION_M`] grid (rayon; the output order
/// is the input order).
pub fn weigh_pairs(
    footprints: &[&Footprint],
    pairs: &[(u32, u32)],
    lambda_adjacent: f64,
) -> Vec<CandidateEdge> {
    pairs
        .par_iter()
        .map(|&(a, b)| CandidateEdge {
            a,
            b,
            d_m: on_distance_grid(
                adjacent_distance(
                    footprints[a as usize],
                    footprints[b as usize],
                    lambda_adjacent,
                )
                .d_m,
            ),
        })
        .collect()
}

/// Pairs that could still change the single-link result, found after a first clustering: every pair
/// (a, b) not in `existing` (sorted) whose boxes are within `reach_far_m` (max-norm gap) and whose
/// lower bound (1 − λ)·gap ≤ d (the Euclidean gap between the boxes is ≤ d_min) is below the distance
/// at which `merges` first join a and b. Adding these pairs and clustering again makes every merge
/// with d < (1 − λ)·reach_far_m exact: a pair left out has d ≥ its bound ≥ its final join distance
/// (rounding d to the distance grid keeps that order, since the join distance is on the grid).
/// Works in chunks of buildings so memory stays bounded; the result is sorted and unique.
pub fn refine_pairs(
    footprints: &[&Footprint],
    existing: &[(u32, u32)],
    merges: &[Merge],
    reach_far_m: f64,
    lambda_adjacent: f64,
) -> Vec<(u32, u32)> {
    const CHUNK: usize = 1 << 16;
    let n = footprints.len();
    // A copy is joined to its original at 0 and is as far from every other building: no pair of it counts.
    let boxes = searched_boxes(footprints, &first_of_kind(footprints));
    let half = reach_far_m.max(0.0) / 2.0;
    let grown =
        |b: &[f64; 4]| AABB::from_corners([b[0] - half, b[1] - half], [b[2] + half, b[3] + half]);
    let items: Vec<GeomWithData<Rectangle<[f64; 2]>, u32>> = boxes
        .iter()
        .enumerate()
        .filter_map(|(i, b)| {
            b.as_ref()
                .map(|b| GeomWithData::new(Rectangle::from_aabb(grown(b)), i as u32))
        })
        .collect();
    let tree = RTree::bulk_load(items);
    let keep = 1.0 - lambda_adjacent;

    // Cluster labels at a ladder of distances 0, ¼, ½, 1, 2, …, 512 m: a pair whose buildings already
    // share a label at a rung ≤ its bound is joined below the bound and is dropped before the exact sweep.
    let ladder: Vec<f64> = std::iter::once(0.0)
        .chain((-2..=9).map(|k| 2f64.powi(k)))
        .collect();
    let mut labels: Vec<Vec<u32>> = Vec::with_capacity(ladder.len());
    {
        let mut uf = UnionFind::new(n);
        let mut next = 0;
        for &rung in &ladder {
            while next < merges.len() && merges[next].d_m <= rung {
                uf.union(merges[next].a, merges[next].b);
                next += 1;
            }
            labels.push((0..n as u32).map(|i| uf.find(i)).collect());
        }
    }
    let joined_below = |bound: f64, a: usize, b: usize| {
        let rung = ladder.partition_point(|&r| r <= bound);
        rung > 0 && labels[rung - 1][a] == labels[rung - 1][b]
    };

    let mut out = Vec::new();
    for start in (0..n).step_by(CHUNK) {
        let end = (start + CHUNK).min(n);
        // (lower bound of d, a, b)
        let mut queries: Vec<(f64, u32, u32)> = (start..end)
            .into_par_iter()
            .flat_map_iter(|i| {
                let mut found = Vec::new();
                if let Some(bi) = &boxes[i] {
                    for o in tree.locate_in_envelope_intersecting(&grown(bi)) {
                        let j = o.data as usize;
                        if j <= i {
                            continue;
                        }
                        let bj = boxes[j].as_ref().expect("in the tree");
                        let gx = (bi[0] - bj[2]).max(bj[0] - bi[2]).max(0.0);
                        let gy = (bi[1] - bj[3]).max(bj[1] - bi[3]).max(0.0);
                        let bound = keep * gx.hypot(gy);
                        if !joined_below(bound, i, j) {
                            found.push((bound, i as u32, j as u32));
                        }
                    }
                }
                found
            })
            .collect();
        queries.sort_unstable_by(|p, q| p.0.total_cmp(&q.0).then((p.1, p.2).cmp(&(q.1, q.2))));
        let mut uf = UnionFind::new(n);
        let mut next = 0;
        for &(bound, a, b) in &queries {
            while next < merges.len() && merges[next].d_m <= bound {
                uf.union(merges[next].a, merges[next].b);
                next += 1;
            }
            if uf.find(a) != uf.find(b) && existing.binary_search(&(a, b)).is_err() {
                out.push((a, b));
            }
        }
    }
    out.sort_unstable();
    out
}

/// For every footprint, the index of the first footprint identical to it (itself if none is): the
/// same polygons with the same vertices, compared bit for bit. Footprints without a finite vertex are
/// their own kind (they only join through fallback edges).
fn first_of_kind(footprints: &[&Footprint]) -> Vec<u32> {
    use std::hash::{Hash, Hasher};
    let key = |i: usize| {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        footprint_bits(footprints[i]).for_each(|b| b.hash(&mut h));
        h.finish()
    };
    let n = footprints.len();
    let mut order: Vec<(u64, u32)> = (0..n)
        .into_par_iter()
        .filter(|&i| bbox(footprints[i]).is_some())
        .map(|i| (key(i), i as u32))
        .collect();
    order.par_sort_unstable();
    let mut first: Vec<u32> = (0..n as u32).collect();
    for run in order.chunk_by(|x, y| x.0 == y.0) {
        // Equal hashes: compare for real; each footprint joins the first earlier one it equals.
        for (k, &(_, i)) in run.iter().enumerate() {
            let same = run[..k].iter().map(|&(_, j)| j).find(|&j| {
                first[j as usize] == j
                    && footprint_bits(footprints[j as usize])
                        .eq(footprint_bits(footprints[i as usize]))
            });
            if let Some(j) = same {
                first[i as usize] = j;
            }
        }
    }
    first
}

/// A footprint as a sequence of words: its number of polygons, then per polygon its number of holes
/// and per ring (the exterior first) its length and its coordinates' bits. Two footprints are
/// identical when their sequences are.
fn footprint_bits(fp: &Footprint) -> impl Iterator<Item = u64> + '_ {
    fn ring(r: &geo::LineString) -> impl Iterator<Item = u64> + '_ {
        std::iter::once(r.0.len() as u64)
            .chain(r.0.iter().flat_map(|c| [c.x.to_bits(), c.y.to_bits()]))
    }
    std::iter::once(fp.0.len() as u64).chain(fp.0.iter().flat_map(move |p| {
        std::iter::once(p.interiors().len() as u64)
            .chain(ring(p.exterior()))
            .chain(p.interiors().iter().flat_map(ring))
    }))
}

/// The boxes the reach searches use: a copy of an earlier footprint has none (it is joined to that
/// one directly).
fn searched_boxes(footprints: &[&Footprint], first: &[u32]) -> Vec<Option<[f64; 4]>> {
    footprints
        .iter()
        .enumerate()
        .map(|(i, f)| if first[i] == i as u32 { bbox(f) } else { None })
        .collect()
}

/// [min x, min y, max x, max y] over the finite vertices, `None` when there are none.
pub(crate) fn bbox(fp: &Footprint) -> Option<[f64; 4]> {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for poly in &fp.0 {
        for c in &poly.exterior().0 {
            if c.x.is_finite() && c.y.is_finite() {
                b = [b[0].min(c.x), b[1].min(c.y), b[2].max(c.x), b[3].max(c.y)];
            }
        }
    }
    (b[0] <= b[2]).then_some(b)
}

/// Most reach pairs one building keeps: those of its nearest boxes. A pair stays when either building keeps it,
/// so a pair is lost only between two buildings that each have more than this many others within reach. On real
/// data that does not happen (most others within reach of one building: Boston 91, one large footprint ringed by
/// small ones, whose neighbours have few; NYC 40, Delft 27), but footprints stacked on one another — the same
/// building imported thousands of times with rounding noise — would otherwise give every pair of the stack, a
/// graph quadratic in time and memory (2,000 copies: 2 million pairs). Every building of a stack still keeps its
/// nearest, at distance 0, and the Delaunay edges keep the graph connected.
pub const REACH_MAX_NEIGHBOURS: usize = 64;

/// Most boxes one building's reach search looks at before it keeps its [`REACH_MAX_NEIGHBOURS`] nearest: the
/// search stops there, so a stack costs each building a bounded search.
const REACH_SCAN_LIMIT: usize = 1_024;

/// Pairs whose boxes, each grown by `reach_m / 2`, intersect: the gap between the boxes along each
/// axis is at most `reach_m` (a max-norm box distance); of each building's, its [`REACH_MAX_NEIGHBOURS`]
/// nearest (by that gap, then index) among the first [`REACH_SCAN_LIMIT`] the search finds. Sorted.
fn reach_pairs(boxes: &[Option<[f64; 4]>], reach_m: f64) -> Vec<(u32, u32)> {
    let half = reach_m.max(0.0) / 2.0;
    let grown =
        |b: &[f64; 4]| AABB::from_corners([b[0] - half, b[1] - half], [b[2] + half, b[3] + half]);
    let items: Vec<GeomWithData<Rectangle<[f64; 2]>, u32>> = boxes
        .iter()
        .enumerate()
        .filter_map(|(i, b)| {
            b.as_ref().map(|b| {
                let e = grown(b);
                GeomWithData::new(Rectangle::from_aabb(e), i as u32)
            })
        })
        .collect();
    let tree = RTree::bulk_load(items);
    let gap = |a: &[f64; 4], b: &[f64; 4]| {
        let gx = (a[0] - b[2]).max(b[0] - a[2]).max(0.0);
        let gy = (a[1] - b[3]).max(b[1] - a[3]).max(0.0);
        gx.max(gy)
    };
    let mut pairs: Vec<(u32, u32)> = boxes
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, b)| {
            let i = i as u32;
            let mut found: Vec<u32> = match b {
                Some(b) => tree
                    .locate_in_envelope_intersecting(&grown(b))
                    .filter(|o| o.data != i)
                    .take(REACH_SCAN_LIMIT)
                    .map(|o| o.data)
                    .collect(),
                None => Vec::new(),
            };
            if found.len() > REACH_MAX_NEIGHBOURS {
                let b = b.as_ref().expect("found only with a box");
                let key = |j: &u32| {
                    (
                        gap(b, boxes[*j as usize].as_ref().expect("in the tree")),
                        *j,
                    )
                };
                // The nearest, in no particular order: the pairs are sorted at the end.
                found.select_nth_unstable_by(REACH_MAX_NEIGHBOURS, |x, y| {
                    let (kx, ky) = (key(x), key(y));
                    kx.0.total_cmp(&ky.0).then(kx.1.cmp(&ky.1))
                });
                found.truncate(REACH_MAX_NEIGHBOURS);
            }
            found.into_iter().map(move |j| (i.min(j), i.max(j)))
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

struct Site {
    pos: Point2<f64>,
    building: u32,
}

impl HasPosition for Site {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.pos
    }
}

/// The grid the triangulation's points are put on: 2⁻⁶ m (1.6 cm). The pairs it yields are only candidates
/// (their distances come from the footprints), and on a power-of-two grid the predicates' differences are exact:
/// points that are almost but not quite collinear (rows of buildings in lon/lat, projected) otherwise send every
/// in-circle test to its slow exact path (10,000 squares in a row took 43 s, 0.3 s snapped).
const SITE_GRID_M: f64 = 1.0 / 64.0;

fn snap(v: f64) -> f64 {
    (v / SITE_GRID_M).round() * SITE_GRID_M
}

/// Delaunay edges between different buildings, over up to `max_points` exterior vertices per footprint.
/// Copies of an earlier footprint (`first[i] != i`) are left out.
fn delaunay_pairs(
    footprints: &[&Footprint],
    first: &[u32],
    max_points: usize,
) -> (Vec<(u32, u32)>, usize) {
    let max_points = max_points.max(1);
    let mut sites: Vec<Site> = Vec::new();
    for (i, fp) in footprints.iter().enumerate() {
        if first[i] != i as u32 {
            continue;
        }
        // Each ring from its lowest vertex (x, then y), and the chosen points in that order too: the
        // triangulation of cocircular sites (corners of aligned buildings on the site grid) depends on
        // the insertion order, and the same building stored with its rings starting elsewhere (a File
        // Geodatabase written by GDAL starts them one vertex on) must give the same pairs.
        let lowest = |a: &&geo_types::Coord<f64>, b: &&geo_types::Coord<f64>| {
            a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y))
        };
        let mut pts: Vec<&geo_types::Coord<f64>> = Vec::new();
        for p in &fp.0 {
            let c = &p.exterior().0;
            // Rings are closed: skip the repeated last point.
            let ring: Vec<_> = c[..c.len().saturating_sub(1)]
                .iter()
                .filter(|c| c.x.is_finite() && c.y.is_finite())
                .collect();
            let start = (0..ring.len())
                .min_by(|&a, &b| lowest(&ring[a], &ring[b]))
                .unwrap_or(0);
            pts.extend(ring[start..].iter().chain(&ring[..start]));
        }
        let step = pts.len().div_ceil(max_points).max(1);
        let mut chosen: Vec<_> = pts.iter().step_by(step).collect();
        chosen.sort_by(|a, b| lowest(a, b));
        for c in chosen {
            sites.push(Site {
                pos: Point2::new(snap(c.x), snap(c.y)),
                building: i as u32,
            });
        }
    }
    let n_points = sites.len();
    // bulk_load_stable keeps the input order for equal points, so the result does not depend on threads.
    let Ok(tri) = DelaunayTriangulation::<Site>::bulk_load_stable(sites) else {
        return (Vec::new(), n_points);
    };
    let mut pairs: Vec<(u32, u32)> = tri
        .undirected_edges()
        .filter_map(|e| {
            let [v0, v1] = e.vertices();
            let (a, b) = (v0.data().building, v1.data().building);
            (a != b).then_some((a.min(b), a.max(b)))
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    (pairs, n_points)
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo_types::{polygon, MultiPolygon};

    fn square(x: f64, y: f64, w: f64) -> Footprint {
        MultiPolygon(vec![
            polygon![(x: x, y: y), (x: x + w, y: y), (x: x + w, y: y + w), (x: x, y: y + w)],
        ])
    }

    /// Single-link on `edges` joins at the same distances as on the graph of every pair of `refs`.
    fn assert_single_link_as_on_every_pair(refs: &[&Footprint], edges: &[CandidateEdge]) {
        let n = refs.len();
        let all: Vec<(u32, u32)> = (0..n as u32)
            .flat_map(|a| (a + 1..n as u32).map(move |b| (a, b)))
            .collect();
        let brute = weigh_pairs(refs, &all, 0.6);
        let d = |es: &[CandidateEdge]| -> Vec<f64> {
            crate::single_link::single_link(n, es)
                .iter()
                .map(|m| m.d_m)
                .collect()
        };
        assert_eq!(d(edges), d(&brute));
    }

    fn connected(n: usize, edges: &[CandidateEdge]) -> bool {
        let mut uf = UnionFind::new(n);
        for e in edges {
            uf.union(e.a, e.b);
        }
        (0..n as u32).all(|i| uf.find(i) == uf.find(0))
    }

    #[test]
    fn far_apart_clusters_stay_connected_through_delaunay() {
        let fps: Vec<Footprint> = (0..20)
            .map(|i| {
                square(
                    (i % 5) as f64 * 12.0 + (i / 10) as f64 * 5000.0,
                    (i / 5) as f64 * 12.0,
                    10.0,
                )
            })
            .collect();
        let refs: Vec<&Footprint> = fps.iter().collect();
        let (edges, stats) = candidate_graph(&refs, 3.0, 0.6, 16);
        assert!(connected(fps.len(), &edges));
        assert_eq!(stats.n_fallback_edges, 0);
        assert!(edges
            .windows(2)
            .all(|w| (w[0].a, w[0].b) < (w[1].a, w[1].b)));
        assert!(edges.iter().all(|e| e.a < e.b && e.d_m >= 0.0));
    }

    /// The reach pairs weighed beside the triangulation give the edges of weighing every candidate pair after
    /// it: the same pairs, in the same order, with the same distances (a grid with gaps on both sides of the
    /// reach, a duplicate and a far building, so reach, Delaunay-only and twin pairs all occur).
    #[test]
    fn candidate_graph_weighs_like_weigh_pairs() {
        let mut fps: Vec<Footprint> = (0..60)
            .map(|i| {
                let gap = [0.0, 1.5, 4.0, 9.0][i % 4];
                square((i % 10) as f64 * (10.0 + gap), (i / 10) as f64 * 13.0, 10.0)
            })
            .collect();
        fps.push(square(0.0, 0.0, 10.0));
        fps.push(square(90_000.0, 0.0, 10.0));
        let refs: Vec<&Footprint> = fps.iter().collect();
        let (edges, stats) = candidate_graph(&refs, 3.0, 0.6, 16);
        let (pairs, _) = candidate_pairs(&refs, 3.0, 16);
        let plain = weigh_pairs(&refs, &pairs, 0.6);
        assert!(stats.n_reach_pairs > 0 && stats.n_delaunay_pairs > stats.n_reach_pairs);
        assert_eq!(stats.n_duplicate_footprints, 1);
        assert_eq!(edges.len(), plain.len());
        for (e, p) in edges.iter().zip(&plain) {
            assert_eq!((e.a, e.b, e.d_m.to_bits()), (p.a, p.b, p.d_m.to_bits()));
        }
    }

    #[test]
    fn identical_and_collinear_buildings_are_connected() {
        let mut fps: Vec<Footprint> = (0..30)
            .map(|i| square(i as f64 * 50.0, 0.0, 10.0))
            .collect();
        fps.push(square(0.0, 0.0, 10.0)); // identical to the first: its vertices vanish in the triangulation
        let refs: Vec<&Footprint> = fps.iter().collect();
        let (edges, _) = candidate_graph(&refs, 1.0, 0.6, 16);
        assert!(connected(fps.len(), &edges));
        let twin = edges
            .iter()
            .find(|e| (e.a, e.b) == (0, 30))
            .expect("twins are candidates");
        assert_eq!(twin.d_m, 0.0);
    }

    #[test]
    fn a_pile_of_copies_costs_one_edge_per_copy() {
        // 400 copies of one footprint (stacked units, or a feature repeated), beside a row of others.
        let mut fps: Vec<Footprint> = (0..10)
            .map(|i| square(i as f64 * 12.0, 0.0, 10.0))
            .collect();
        fps.extend((0..400).map(|_| square(12.0, 0.0, 10.0)));
        // Same box, different footprints: a square with a hole, and the square's ring started elsewhere.
        let mut holed = square(12.0, 0.0, 10.0);
        holed.0[0].interiors_push(vec![(14.0, 2.0), (16.0, 2.0), (16.0, 4.0), (14.0, 2.0)]);
        fps.push(holed);
        fps.push(MultiPolygon(vec![polygon![
            (x: 22.0, y: 0.0), (x: 22.0, y: 10.0), (x: 12.0, y: 10.0), (x: 12.0, y: 0.0)
        ]]));
        let n = fps.len();
        let refs: Vec<&Footprint> = fps.iter().collect();
        let (edges, stats) = candidate_graph(&refs, 3.0, 0.6, 16);
        assert_eq!(stats.n_duplicate_footprints, 400);
        assert!(connected(n, &edges));
        // Every copy is joined to building 1 at 0, and to nothing else.
        for c in 10..410u32 {
            let touching: Vec<_> = edges.iter().filter(|e| e.a == c || e.b == c).collect();
            assert_eq!(touching.len(), 1, "copy {c}: {touching:?}");
            assert_eq!((touching[0].a, touching[0].b, touching[0].d_m), (1, c, 0.0));
        }
        assert!(edges.len() < 400 + 60, "{} edges", edges.len());
        // The two look-alikes are searched as footprints of their own.
        for other in [410u32, 411] {
            assert!(edges.iter().any(|e| e.b == other && e.a != 1));
        }
        // Single-link joins at the same distances as on the graph of every pair.
        assert_single_link_as_on_every_pair(&refs, &edges);
    }

    /// 600 copies of one square, each moved by up to a millimetre (the same building imported again and again
    /// with rounding noise, so no two are identical): each keeps its [`REACH_MAX_NEIGHBOURS`] nearest instead
    /// of all 600 others in reach, and single-link still joins the pile at 0, and the row and the pile at the
    /// same distances as on the graph of every pair.
    #[test]
    fn a_pile_of_near_copies_keeps_a_bounded_number_of_reach_pairs() {
        let mut fps: Vec<Footprint> = (0..10)
            .map(|i| square(i as f64 * 12.0, 0.0, 10.0))
            .collect();
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut jitter = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2e-3
        };
        // The pile stands 2 m from the row's end, within reach: the row's end keeps the pile's nearest copies.
        fps.extend((0..600).map(|_| square(120.0 + jitter(), jitter(), 10.0)));
        let n = fps.len();
        let refs: Vec<&Footprint> = fps.iter().collect();
        let (edges, stats) = candidate_graph(&refs, 3.0, 0.6, 16);
        assert_eq!(stats.n_duplicate_footprints, 0);
        assert!(connected(n, &edges));
        assert!(
            stats.n_reach_pairs <= 600 * REACH_MAX_NEIGHBOURS
                && stats.n_reach_pairs >= 600 * REACH_MAX_NEIGHBOURS / 2,
            "{} reach pairs",
            stats.n_reach_pairs
        );
        for c in 10..n as u32 {
            let degree = edges.iter().filter(|e| e.a == c || e.b == c).count();
            assert!(
                degree >= REACH_MAX_NEIGHBOURS,
                "near copy {c}: {degree} edges"
            );
        }
        assert_single_link_as_on_every_pair(&refs, &edges);
    }

    /// A large footprint ringed by 150 small ones within reach (more than [`REACH_MAX_NEIGHBOURS`]): every
    /// small one has few others in reach and keeps its pair with the large one, so no pair is lost.
    #[test]
    fn a_building_with_many_neighbours_keeps_every_reach_pair() {
        let mut fps: Vec<Footprint> = vec![square(0.0, 0.0, 300.0)];
        for k in 0..150 {
            let t = k as f64 * 8.0;
            let (x, y) = match k % 4 {
                0 => (t % 300.0, -6.0),
                1 => (t % 300.0, 301.0),
                2 => (-6.0, t % 300.0),
                _ => (301.0, t % 300.0),
            };
            fps.push(square(x, y, 5.0));
        }
        let refs: Vec<&Footprint> = fps.iter().collect();
        let (pairs, _) = candidate_pairs(&refs, 3.0, 16);
        for k in 1..fps.len() as u32 {
            assert!(pairs.binary_search(&(0, k)).is_ok(), "pair (0, {k}) lost");
        }
    }

    #[test]
    fn a_long_almost_straight_row_is_triangulated_on_the_grid() {
        // 2,000 squares in a row whose corners wander by nanometres off the line, as projected lon/lat does:
        // the triangulation works on the 1.6 cm grid, where they are collinear, and still joins neighbours.
        let fps: Vec<Footprint> = (0..2_000)
            .map(|i| {
                let x = i as f64 * 12.0;
                let e = 1e-9 * ((i * 7919) % 13) as f64;
                MultiPolygon(vec![polygon![
                    (x: x, y: e), (x: x + 10.0, y: -e), (x: x + 10.0, y: 10.0 + e), (x: x, y: 10.0 - e)
                ]])
            })
            .collect();
        let refs: Vec<&Footprint> = fps.iter().collect();
        let (pairs, stats) = candidate_pairs(&refs, 1.0, 16);
        assert_eq!(stats.n_reach_pairs, 0);
        assert_eq!(stats.n_fallback_edges, 0);
        for i in 0..1_999u32 {
            assert!(pairs.binary_search(&(i, i + 1)).is_ok(), "{i}");
        }
        assert_eq!(snap(0.3), 19.0 / 64.0);
        assert_eq!(snap(-1e-9), 0.0);
    }

    #[test]
    fn empty_footprints_are_joined_by_fallback_edges() {
        let fps = [
            square(0.0, 0.0, 10.0),
            MultiPolygon(vec![]),
            square(100.0, 0.0, 10.0),
        ];
        let refs: Vec<&Footprint> = fps.iter().collect();
        let (edges, stats) = candidate_graph(&refs, 1.0, 0.6, 16);
        assert!(connected(3, &edges));
        assert_eq!(stats.n_fallback_edges, 1);
    }

    #[test]
    fn auto_reach_is_a_fraction_of_the_median_size() {
        let fps = [
            square(0.0, 0.0, 10.0),
            square(0.0, 0.0, 20.0),
            square(0.0, 0.0, 30.0),
        ];
        let refs: Vec<&Footprint> = fps.iter().collect();
        assert!((auto_reach_m(&refs, 0.5) - 10.0).abs() < 1e-12);
        assert_eq!(auto_reach_m(&[], 0.5), 0.0);
    }
}
