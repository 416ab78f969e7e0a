//! The `generalize` entry point (seed 000 §3, DESIGN.md §3): candidate graph → adjacent distances →
//! single-link → condensed, balanced levels → per node merged and simplified footprint and Δh/Δa.
//! Local ENU metres throughout. Invariant: every level partitions all buildings (level 0 = one node per
//! building, last level = one node); the result is the same for the same input and options.

use crate::graph::{
    auto_reach_m, bbox, candidate_graph, refine_pairs, weigh_pairs, CandidateEdge, GraphStats,
};
use crate::levels::{condense, LevelKind, LevelOptions};
use crate::merge::connect_islands;
use crate::single_link::{single_link, Merge};
use crate::streets::{raise_crossing, StreetIndex};
use crate::{
    fill_concave_within, merge_footprints_weighted, node_stats, simplify_footprint, NodeStats,
};
use citylod_model::{Building, BuildingId, Footprint, Hierarchy, Level, Node, NodeId};
use geo::Area;
use rayon::prelude::*;
use std::time::Instant;

/// Options of the generalization; every field has the seed's or citylod's stated default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneralizeOptions {
    /// λ of the adjacent distance d = d_min·(1 − N·λ), in [0, 1] (seed: 0.6).
    pub lambda_adjacent: f64,
    /// L = max(1, ⌊log₂ n / depth_divisor⌋) levels above the buildings before balancing, > 0 (seed: 1.5).
    pub depth_divisor: f64,
    /// δa = a_avg / lambda_area (m²), the concave-triangle area simplification removes, > 0 (seed: 50).
    pub lambda_area: f64,
    /// Vertices with an interior angle above this are dropped as collinear (degrees; default 175).
    pub collinear_angle_deg: f64,
    /// Floor for dᵢ in the rate rᵢ = (dᵢ₊₁ − dᵢ)/max(dᵢ, d_floor) (m; default 1). Below a metre the
    /// relative increase measures survey noise (3DBAG's millimetre gaps between row houses), not the
    /// step from one district to the next: with 0.01 m every Delft threshold fell below 0.3 m.
    pub d_floor_m: f64,
    /// Thresholds balancing may insert between two planned ones (default 2).
    pub max_inserts_per_level: usize,
    /// Bounding-box reach of the candidate search (m); `None`: `reach_factor` × median √area.
    pub reach_m: Option<f64>,
    /// See `reach_m` (default 0.5).
    pub reach_factor: f64,
    /// The refinement pass looks this many reaches far (default 6; 0 turns it off): merges with
    /// d < (1 − λ)·reach_far_factor·reach are then the same as with all pairs. On 1,000 central
    /// Boston buildings, identical partitions (vs all pairs) were 88 % without it, 96 % at 3, 100 % at 5.
    pub reach_far_factor: f64,
    /// Footprint vertices per building entering the Delaunay triangulation (default 16).
    pub max_delaunay_points_per_building: usize,
    /// A member whose height exceeds the height of the rest of its block by at least this (m) is a
    /// landmark, drawn at full detail on top of the block (seed 001); ≥ 0, `INFINITY` turns landmarks
    /// off. With `error_kappa` > 0 a landmark is kept only where leaving it out of the block lowers the
    /// block's error (otherwise the full-detail copy adds bytes and nothing a client may show): Boston's top
    /// five levels held 85 towers each (6.6 k triangles a level), then none; its tileset −3 %, NYC's −4 %.
    /// Default 20, measured with that rule (2026-11-22, `citylod check`'s 8 views at 800×600, bytes loaded):
    /// 15 / 20 / 25 / 30 / 40 m give Boston 8.37 / 8.24 / 8.48 / 8.45 / 8.48 MB (tileset 11.84 / 11.81 /
    /// 11.82 / 11.81 / 11.80 MB); NYC's Lower East Side, whose row blocks stand 5 m houses beside 48 m
    /// tenements, 4.50 / 4.36 / 4.40 / 4.37 / 4.29 MB with a far view of 107 / 138 / 230 / 231 / 219 kB
    /// (tileset 631 / 624 / 615 / 611 / 601 kB); Delft 4.75 / 4.73 / 4.73 / 4.73 / 4.73 MB, far view 103 /
    /// 103 / 99 / 99 / 99 kB.
    pub landmark_min_excess_m: f64,
    /// At most ⌊share × members⌋ members of a node are landmarks, in [0, 1) (default 0.5: a tower may
    /// stand out of a pair; 0.02 left Boston's level-1 Δh of 192 m, a tower beside two houses. With 0.34 a
    /// pair of a tower and a house kept Δh ≈ 77 m on NYC's Lower East Side, so the whole 1 km district's far
    /// view refined to the leaves under it: far view 3.2× → 9.2× fewer triangles than full detail at 0.5,
    /// Boston's tileset +0.2 % bytes).
    pub landmark_max_share: f64,
    /// κ of the error model, geometricError = max(Δh, κ·√Δa) (m per √m², DESIGN.md §4; default
    /// 20/√200 ≈ 1.41, the CLI's `--dh-px`/`--da-px`). A block's outline is then further simplified, filling
    /// concave triangles, while its error does not grow: Δa may rise to (max(Δh, κ·√Δa)/κ)². On NYC this
    /// cuts the triangles of levels 1–3 by 12–16 % at no cost in geometricError (Boston, whose blocks are
    /// Δa-bound, by under 1 %). 0 turns it off.
    pub error_kappa: f64,
    /// With street lines ([`generalize_with_streets`]): metres added to the adjacent distance of two buildings
    /// a street separates, so that blocks join across a street only after the blocks within street blocks,
    /// gaps of up to this many metres (seed 002 §3.2.1). Measured on Boston with its streets: 10 / 30 / 100 m
    /// keep streets at the first 2 / 2 / 6 levels and store 12.45 / 12.15 / 15.54 MB (12.07 without streets;
    /// at 100 m the levels above the streets join whole districts at once); NYC keeps them at the first 4
    /// levels for all three.
    pub street_penalty_m: f64,
}

impl Default for GeneralizeOptions {
    fn default() -> Self {
        GeneralizeOptions {
            lambda_adjacent: crate::ADJACENT_LAMBDA,
            depth_divisor: 1.5,
            lambda_area: 50.0,
            collinear_angle_deg: 175.0,
            d_floor_m: 1.0,
            max_inserts_per_level: 2,
            reach_m: None,
            reach_factor: 0.5,
            reach_far_factor: 6.0,
            max_delaunay_points_per_building: 16,
            landmark_min_excess_m: 20.0,
            landmark_max_share: 0.5,
            error_kappa: 20.0 / 200f64.sqrt(),
            street_penalty_m: 30.0,
        }
    }
}

/// Why `generalize` refused its input.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GeneralizeError {
    #[error("no buildings to generalize")]
    NoBuildings,
    #[error("building at index {index} has id {id}; ids must equal input indices")]
    IdNotIndex { index: usize, id: u32 },
    #[error("building {id} ({source_id}) has no ring with 3 distinct finite points")]
    DegenerateFootprint { id: u32, source_id: String },
    #[error("option {name} = {value} is out of range ({expected})")]
    BadOption {
        name: &'static str,
        value: f64,
        expected: &'static str,
    },
}

/// One level of the result, as reported.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LevelReport {
    /// 0 = the buildings.
    pub index: usize,
    /// `None` for the buildings.
    pub kind: Option<LevelKind>,
    pub nodes: usize,
    /// Every single-link merge with d ≤ threshold_m is applied (m); with streets, a merge across a street
    /// counts its distance plus [`GeneralizeOptions::street_penalty_m`].
    pub threshold_m: f64,
    pub max_children: usize,
    pub tie_splits: usize,
    pub budget_splits: usize,
    /// Nodes whose footprint has more than one polygon.
    pub multipolygon_nodes: usize,
    /// Nodes whose merged or simplified footprint lost area below their largest child's, so the
    /// unsimplified union or the children's polygons were kept instead (0 when merging is sound).
    pub footprint_fallbacks: usize,
    /// Landmarks summed over the level's nodes (each building counts once per level).
    pub landmarks: usize,
}

/// Wall-clock time of each phase (ms); the only part of the report that varies between runs.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct PhaseTimings {
    pub candidates_ms: f64,
    pub distances_ms: f64,
    pub single_link_ms: f64,
    pub levels_ms: f64,
    pub footprints_ms: f64,
    pub total_ms: f64,
}

/// What the generalization did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GeneralizeReport {
    pub n_buildings: usize,
    pub n_candidate_edges: usize,
    pub graph: GraphStats,
    /// L from the formula, before balancing.
    pub target_levels: usize,
    /// Thresholds from the largest rates (≤ L − 1).
    pub rate_levels: usize,
    /// Rate thresholds dropped because their level would not at least halve the node count.
    pub rate_levels_skipped: usize,
    pub p: usize,
    pub delta_p: usize,
    /// Every level, buildings first; levels above the buildings = rate levels − skipped + inserted + 1
    /// (top) + extra top.
    pub levels: Vec<LevelReport>,
    pub tie_splits: usize,
    pub budget_splits: usize,
    pub multipolygon_nodes: usize,
    pub footprint_fallbacks: usize,
    /// Landmarks summed over all levels.
    pub landmarks: usize,
    /// Streets as barriers, when street lines were given.
    pub streets: Option<StreetBarrierReport>,
    pub timings: PhaseTimings,
}

/// What the street barriers did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StreetBarrierReport {
    /// Street segments given.
    pub segments: usize,
    /// Candidate edges whose shortest segment between the two footprints crosses a street.
    pub crossing_edges: usize,
    /// The highest level (1 = the first above the buildings) with no merge across a street; 0 when the first
    /// level already joins across one (a street block with gaps wider than the penalty).
    pub barrier_level: usize,
    /// Single-link merges that join buildings across a street (applied above the barrier level).
    pub merges_across: usize,
}

/// The hierarchy and its report.
#[derive(Debug, Clone)]
pub struct Generalized {
    pub hierarchy: Hierarchy,
    pub report: GeneralizeReport,
}

/// Generalizes `buildings` (ids = indices, footprints in local ENU m) into a hierarchy: level 0 holds
/// one node per building (its own footprint), each level above partitions the buildings into clusters
/// with merged, simplified footprints (ring vertices from the members plus union intersection points),
/// and the last level is one node. A building alone in its cluster stays as it is.
///
/// Errors on an empty input, ids that are not the indices, footprints without a usable ring, or
/// options out of range; never panics on input data.
pub fn generalize(
    buildings: &[Building],
    opts: &GeneralizeOptions,
) -> Result<Generalized, GeneralizeError> {
    generalize_with_streets(buildings, opts, &[])
}

/// [`generalize`] with street centre lines as barriers (segments in the buildings' local ENU metres; see
/// [`crate::streets`]): two buildings a street separates are [`GeneralizeOptions::street_penalty_m`] farther
/// apart, so blocks join across streets only after the street blocks around them (no level up to
/// [`StreetBarrierReport::barrier_level`] holds such a join). No segments: the same as [`generalize`].
pub fn generalize_with_streets(
    buildings: &[Building],
    opts: &GeneralizeOptions,
    streets: &[[[f64; 2]; 2]],
) -> Result<Generalized, GeneralizeError> {
    let t_start = Instant::now();
    validate(buildings, opts)?;
    let n = buildings.len();
    let mut timings = PhaseTimings::default();
    let footprints: Vec<&Footprint> = buildings.iter().map(|b| &b.footprint).collect();
    let boxes: Vec<[f64; 4]> = footprints
        .iter()
        .map(|f| bbox(f).unwrap_or([0.0; 4]))
        .collect();
    let index = StreetIndex::new(streets);
    let barrier = (!index.is_empty()).then_some((&index, opts.street_penalty_m));

    let Clustered {
        merges,
        edges,
        stats: graph_stats,
        crossing: crossing_pairs,
    } = cluster_with_streets(&footprints, opts, barrier, &mut timings);
    let crossing_edges = crossing_pairs.len();

    let t = Instant::now();
    let level_opts = LevelOptions {
        depth_divisor: opts.depth_divisor,
        d_floor_m: opts.d_floor_m,
        max_inserts_per_level: opts.max_inserts_per_level,
    };
    let plan = condense(n, &merges, &edges, &boxes, &level_opts);
    drop(edges);
    timings.levels_ms = ms(t);
    let street_report = barrier.map(|_| {
        let within = merges
            .iter()
            .take_while(|m| !crossing_pairs.contains(&(m.a, m.b)))
            .count();
        StreetBarrierReport {
            segments: streets.len(),
            crossing_edges,
            barrier_level: plan
                .levels
                .iter()
                .take_while(|l| l.n_merges <= within)
                .count(),
            merges_across: merges
                .iter()
                .filter(|m| crossing_pairs.contains(&(m.a, m.b)))
                .count(),
        }
    });

    let t = Instant::now();
    let mut levels: Vec<Level> = Vec::with_capacity(plan.levels.len() + 1);
    levels.push(Level {
        threshold_m: 0.0,
        nodes: buildings
            .par_iter()
            .map(|b| {
                let mut node = empty_node(vec![], vec![b.id], b.footprint.clone());
                node_stats(&[b], &b.footprint, &[]).write_into(&mut node);
                node
            })
            .collect(),
    });
    let mut reports = vec![level_report(0, None, &levels[0])];
    for planned in &plan.levels {
        let below = &levels.last().expect("level 0 exists").nodes;
        let bridges = bridges_per_group(&planned.groups, below, &merges, n);
        let a_avg_m2 = below.iter().map(|nd| nd.area_m2).sum::<f64>() / below.len().max(1) as f64;
        let delta_a_m2 = a_avg_m2 / opts.lambda_area;
        let reach_m = island_reach_m(planned.threshold_m, opts.lambda_adjacent);
        let built: Vec<(Node, bool)> = planned
            .groups
            .par_iter()
            .zip(bridges.par_iter())
            .map(|(g, br)| build_node(g, br, below, buildings, delta_a_m2, reach_m, opts))
            .collect();
        let footprint_fallbacks = built.iter().filter(|(_, f)| *f).count();
        let level = Level {
            threshold_m: planned.threshold_m,
            nodes: built.into_iter().map(|(node, _)| node).collect(),
        };
        let mut r = level_report(levels.len(), Some(planned.kind), &level);
        r.footprint_fallbacks = footprint_fallbacks;
        r.tie_splits = planned.tie_splits;
        r.budget_splits = planned.budget_splits;
        reports.push(r);
        levels.push(level);
    }
    timings.footprints_ms = ms(t);
    timings.total_ms = ms(t_start);

    let hierarchy = Hierarchy { levels };
    debug_assert!(hierarchy.check_invariants(n).is_empty());
    let report = GeneralizeReport {
        n_buildings: n,
        n_candidate_edges: graph_stats.n_edges,
        graph: graph_stats,
        target_levels: plan.target_levels,
        rate_levels: plan.rate_levels,
        rate_levels_skipped: plan.rate_levels_skipped,
        p: plan.p,
        delta_p: plan.delta_p,
        tie_splits: reports.iter().map(|r| r.tie_splits).sum(),
        budget_splits: reports.iter().map(|r| r.budget_splits).sum(),
        multipolygon_nodes: reports.iter().skip(1).map(|r| r.multipolygon_nodes).sum(),
        footprint_fallbacks: reports.iter().map(|r| r.footprint_fallbacks).sum(),
        landmarks: reports.iter().map(|r| r.landmarks).sum(),
        levels: reports,
        streets: street_report,
        timings,
    };
    Ok(Generalized { hierarchy, report })
}

/// Single-link clustering of `footprints` (local ENU m) on the sparse candidate graph: reach and
/// Delaunay pairs, clustered, then refined once with [`refine_pairs`] within `reach_far_factor` ×
/// reach and clustered again. Returns the merges (sorted by d) and how the graph was built; fills the
/// candidate, distance and single-link times of `timings`.
pub fn cluster(
    footprints: &[&Footprint],
    opts: &GeneralizeOptions,
    timings: &mut PhaseTimings,
) -> (Vec<Merge>, GraphStats) {
    let c = cluster_with_streets(footprints, opts, None, timings);
    (c.merges, c.stats)
}

/// What single-link clustering produced: the merges, the weighted candidate edges they came from,
/// the graph's statistics and the edges a street crosses (a < b).
struct Clustered {
    merges: Vec<Merge>,
    edges: Vec<CandidateEdge>,
    stats: GraphStats,
    crossing: std::collections::HashSet<(u32, u32)>,
}

/// [`cluster`] with the edges a street crosses lengthened by the penalty ([`raise_crossing`]); also returns
/// the edges and those a street crosses. The merges they cause carry the lengthened distance.
fn cluster_with_streets(
    footprints: &[&Footprint],
    opts: &GeneralizeOptions,
    streets: Option<(&StreetIndex, f64)>,
    timings: &mut PhaseTimings,
) -> Clustered {
    let mut crossing = std::collections::HashSet::new();
    let mut raise = |edges: &mut [CandidateEdge]| {
        if let Some((index, d_barrier)) = streets {
            crossing.extend(raise_crossing(edges, footprints, index, d_barrier));
        }
    };
    let n = footprints.len();
    let t = Instant::now();
    let reach_m = opts
        .reach_m
        .unwrap_or_else(|| auto_reach_m(footprints, opts.reach_factor));
    // The candidate pairs and their adjacent distances, the reach pairs' computed while the triangulation
    // runs: both count as candidates_ms (distances_ms is the refinement's weighing and the street penalty).
    let (mut edges, mut stats) = candidate_graph(
        footprints,
        reach_m,
        opts.lambda_adjacent,
        opts.max_delaunay_points_per_building,
    );
    let pairs: Vec<(u32, u32)> = edges.iter().map(|e| (e.a, e.b)).collect();
    timings.candidates_ms += ms(t);

    let t = Instant::now();
    raise(&mut edges);
    timings.distances_ms += ms(t);

    let t = Instant::now();
    let mut merges = single_link(n, &edges);
    timings.single_link_ms += ms(t);

    stats.reach_far_m = reach_m * opts.reach_far_factor;
    if opts.reach_far_factor > 0.0 {
        let t = Instant::now();
        let extra = refine_pairs(
            footprints,
            &pairs,
            &merges,
            stats.reach_far_m,
            opts.lambda_adjacent,
        );
        timings.candidates_ms += ms(t);
        stats.n_refine_pairs = extra.len();
        stats.n_edges += extra.len();
        if !extra.is_empty() {
            let t = Instant::now();
            let mut more = weigh_pairs(footprints, &extra, opts.lambda_adjacent);
            raise(&mut more);
            edges.extend(more);
            timings.distances_ms += ms(t);
            let t = Instant::now();
            merges = single_link(n, &edges);
            timings.single_link_ms += ms(t);
        }
    }
    Clustered {
        merges,
        edges,
        stats,
        crossing,
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn validate(buildings: &[Building], opts: &GeneralizeOptions) -> Result<(), GeneralizeError> {
    let bad = |name, value, expected| {
        Err(GeneralizeError::BadOption {
            name,
            value,
            expected,
        })
    };
    if !(0.0..=1.0).contains(&opts.lambda_adjacent) {
        return bad("lambda_adjacent", opts.lambda_adjacent, "0 ≤ λ ≤ 1");
    }
    if !(opts.depth_divisor > 0.0 && opts.depth_divisor.is_finite()) {
        return bad("depth_divisor", opts.depth_divisor, "> 0");
    }
    if opts.lambda_area.is_nan() || opts.lambda_area <= 0.0 {
        return bad("lambda_area", opts.lambda_area, "> 0");
    }
    if opts.landmark_min_excess_m.is_nan() || opts.landmark_min_excess_m < 0.0 {
        return bad("landmark_min_excess_m", opts.landmark_min_excess_m, "≥ 0");
    }
    if !(0.0..1.0).contains(&opts.landmark_max_share) {
        return bad(
            "landmark_max_share",
            opts.landmark_max_share,
            "0 ≤ share < 1",
        );
    }
    if !(opts.street_penalty_m >= 0.0 && opts.street_penalty_m.is_finite()) {
        return bad("street_penalty_m", opts.street_penalty_m, "≥ 0 and finite");
    }
    if opts.d_floor_m.is_nan() || opts.d_floor_m <= 0.0 {
        return bad("d_floor_m", opts.d_floor_m, "> 0");
    }
    if let Some(r) = opts.reach_m {
        if !(r >= 0.0 && r.is_finite()) {
            return bad("reach_m", r, "≥ 0 and finite");
        }
    }
    if buildings.is_empty() {
        return Err(GeneralizeError::NoBuildings);
    }
    if buildings.len() > u32::MAX as usize {
        // Ids are u32; the check below would overflow.
        return Err(GeneralizeError::IdNotIndex {
            index: u32::MAX as usize,
            id: u32::MAX,
        });
    }
    for (i, b) in buildings.iter().enumerate() {
        if b.id != BuildingId(i as u32) {
            return Err(GeneralizeError::IdNotIndex {
                index: i,
                id: b.id.0,
            });
        }
        let usable = b.footprint.0.iter().any(|p| {
            let mut pts: Vec<(f64, f64)> = p
                .exterior()
                .0
                .iter()
                .filter(|c| c.x.is_finite() && c.y.is_finite())
                .map(|c| (c.x, c.y))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
            pts.dedup();
            pts.len() >= 3
        });
        if !usable {
            return Err(GeneralizeError::DegenerateFootprint {
                id: b.id.0,
                source_id: b.source_id.clone(),
            });
        }
    }
    Ok(())
}

fn empty_node(children: Vec<NodeId>, members: Vec<BuildingId>, footprint: Footprint) -> Node {
    Node {
        children,
        members,
        footprint,
        height_m: 0.0,
        base_z_m: 0.0,
        h_min_m: 0.0,
        h_max_m: 0.0,
        dh_m: 0.0,
        da_m2: 0.0,
        area_m2: 0.0,
        landmarks: Vec::new(),
    }
}

/// For each group, the pairs of its children (local indices, i < j, unique) joined by a spanning-tree
/// edge of the single-link clustering.
fn bridges_per_group(
    groups: &[Vec<u32>],
    below: &[Node],
    merges: &[Merge],
    n: usize,
) -> Vec<Vec<(usize, usize)>> {
    let mut child_of = vec![0u32; n];
    for (c, node) in below.iter().enumerate() {
        for &BuildingId(b) in &node.members {
            child_of[b as usize] = c as u32;
        }
    }
    let mut place = vec![(0u32, 0u32); below.len()]; // child → (group, local index)
    for (g, children) in groups.iter().enumerate() {
        for (local, &c) in children.iter().enumerate() {
            place[c as usize] = (g as u32, local as u32);
        }
    }
    let mut bridges: Vec<Vec<(usize, usize)>> = vec![Vec::new(); groups.len()];
    for m in merges {
        let (ca, cb) = (child_of[m.a as usize], child_of[m.b as usize]);
        let ((ga, la), (gb, lb)) = (place[ca as usize], place[cb as usize]);
        if ca != cb && ga == gb {
            let (i, j) = (la.min(lb) as usize, la.max(lb) as usize);
            bridges[ga as usize].push((i, j));
        }
    }
    for b in &mut bridges {
        b.sort_unstable();
        b.dedup();
    }
    bridges
}

/// The widest gap (m) between two of a node's polygons that its outline may bridge, on a level whose single-link
/// threshold is `threshold_m`: the largest boundary gap that threshold can join two buildings across, since the
/// adjacent distance d = d_min·(1 − N·λ) is never below (1 − λ)·d_min. Wider gaps come from spatial splits of a
/// cluster (its chain of neighbours runs through other nodes), not from proximity at this level's scale: bridging
/// them drew a 400 m strip across Boston Common into a level-2 block. Those polygons stay apart.
pub fn island_reach_m(threshold_m: f64, lambda_adjacent: f64) -> f64 {
    if lambda_adjacent < 1.0 {
        threshold_m / (1.0 - lambda_adjacent)
    } else {
        f64::INFINITY
    }
}

fn build_node(
    group: &[u32],
    bridges: &[(usize, usize)],
    below: &[Node],
    buildings: &[Building],
    delta_a_m2: f64,
    reach_m: f64,
    opts: &GeneralizeOptions,
) -> (Node, bool) {
    if let [only] = group {
        let mut node = below[*only as usize].clone();
        node.children = vec![NodeId(*only)];
        return (node, false);
    }
    let parts: Vec<&Footprint> = group
        .iter()
        .map(|&c| &below[c as usize].footprint)
        .collect();
    let merged = connect_islands(
        &merge_footprints_weighted(&parts, bridges, opts.lambda_adjacent).footprint,
        reach_m,
        opts.lambda_adjacent,
    );
    let simplified = simplify_footprint(&merged, delta_a_m2, opts.collinear_angle_deg);
    // Coverage guard: a node's footprint can never be smaller than its largest child. Should merging
    // or simplifying lose area anyway, fall back to the unsimplified union, then to the children's
    // polygons side by side, and count it.
    let largest_child_m2 = group
        .iter()
        .map(|&c| below[c as usize].area_m2)
        .fold(0.0, f64::max);
    let covers = |fp: &Footprint| fp.unsigned_area() >= 0.99 * largest_child_m2 - 1e-6;
    let (footprint, fallback) = if covers(&simplified) {
        (simplified, false)
    } else if covers(&merged) {
        (merged, true)
    } else {
        let polys = parts.iter().flat_map(|p| p.0.iter().cloned()).collect();
        (geo_types::MultiPolygon(polys), true)
    };
    let mut members: Vec<BuildingId> = group
        .iter()
        .flat_map(|&c| below[c as usize].members.iter().copied())
        .collect();
    members.sort_unstable();
    let refs: Vec<&Building> = members.iter().map(|id| &buildings[id.0 as usize]).collect();
    let mut landmarks = landmarks_of(&refs, opts.landmark_min_excess_m, opts.landmark_max_share);
    let mut stats = node_stats(&refs, &footprint, &landmarks);
    if opts.error_kappa > 0.0 && opts.error_kappa.is_finite() {
        (landmarks, stats) =
            landmarks_that_pay(&refs, &footprint, landmarks, stats, opts.error_kappa);
    }
    let mut footprint = footprint;
    // Outline detail the node's error already pays for: fill concave triangles up to that error's Δa.
    if !fallback && opts.error_kappa > 0.0 && opts.error_kappa.is_finite() {
        let error_m = stats.dh_m.max(opts.error_kappa * stats.da_m2.sqrt());
        let budget_m2 = (error_m / opts.error_kappa).powi(2) - stats.da_m2;
        // Stay a hair inside the budget so rounding in the area sums cannot lift the error.
        let (filled, added_m2) =
            fill_concave_within(&footprint, budget_m2 * 0.999, opts.collinear_angle_deg);
        if added_m2 > 0.0 {
            footprint = filled;
            stats = node_stats(&refs, &footprint, &landmarks);
        }
    }
    let mut node = empty_node(
        group.iter().map(|&c| NodeId(c)).collect(),
        members,
        footprint,
    );
    stats.write_into(&mut node);
    node.landmarks = landmarks;
    (node, fallback)
}

/// The landmarks worth drawing: a landmark is averaged back into its block while that does not raise the block's
/// error max(Δh, κ·√Δa). Where the error is Δa-bound (coarse levels) the tower's height then hides inside it, so a
/// full-detail copy would add bytes and nothing a client may show; where it is Δh-bound (fine levels) the tower
/// stays a landmark.
///
/// Landmarks are the tallest members and leave Δa alone, so averaging one back in raises the block's h_max to its
/// height and nothing else: every landmark no taller than h_min + the error goes, in one pass (linear in the
/// members). Should the recomputed error still come out higher, the landmarks stay as they were.
fn landmarks_that_pay(
    refs: &[&Building],
    footprint: &Footprint,
    landmarks: Vec<BuildingId>,
    stats: NodeStats,
    kappa: f64,
) -> (Vec<BuildingId>, NodeStats) {
    if landmarks.is_empty() {
        return (landmarks, stats);
    }
    let error = |s: &NodeStats| s.dh_m.max(kappa * s.da_m2.max(0.0).sqrt());
    let before = error(&stats);
    // `refs` are in member (id) order.
    let height = |id: BuildingId| {
        refs.binary_search_by_key(&id, |b| b.id)
            .map_or(f64::INFINITY, |i| refs[i].height_m)
    };
    let kept: Vec<BuildingId> = landmarks
        .iter()
        .copied()
        .filter(|&id| height(id) - stats.h_min_m > before)
        .collect();
    if kept.len() == landmarks.len() {
        return (landmarks, stats);
    }
    let fewer = node_stats(refs, footprint, &kept);
    if error(&fewer) <= before {
        (kept, fewer)
    } else {
        (landmarks, stats)
    }
}

fn level_report(index: usize, kind: Option<LevelKind>, level: &Level) -> LevelReport {
    LevelReport {
        index,
        kind,
        nodes: level.nodes.len(),
        threshold_m: level.threshold_m,
        max_children: level
            .nodes
            .iter()
            .map(|n| n.children.len())
            .max()
            .unwrap_or(0),
        tie_splits: 0,
        budget_splits: 0,
        multipolygon_nodes: level
            .nodes
            .iter()
            .filter(|n| n.footprint.0.len() > 1)
            .count(),
        footprint_fallbacks: 0,
        landmarks: level.nodes.iter().map(|n| n.landmarks.len()).sum(),
    }
}

/// The landmarks of a block with buildings `members` (seed 001: a building much taller than its
/// cluster is drawn on top of the cluster's block instead of being averaged into it). Tallest first,
/// a member is a landmark while its height exceeds the area-weighted mean height (Eq. 5) of the
/// members that are not landmarks by at least `min_excess_m` (m), and at most ⌊`max_share` × members⌋
/// are taken. The rule is applied afresh at every level over all members, so a tower stays a landmark
/// of each ancestor for as long as it stands `min_excess_m` above that ancestor's block (and the cap
/// allows it), and becomes part of the block once the block around it is as tall.
///
/// Returns sorted ids. Degenerate input: fewer than 2 members, a cap of 0, or `min_excess_m` not
/// finite give none; members with zero area all weigh 1.
pub fn landmarks_of(members: &[&Building], min_excess_m: f64, max_share: f64) -> Vec<BuildingId> {
    let cap = (max_share * members.len() as f64).floor();
    if members.len() < 2 || !min_excess_m.is_finite() || cap.is_nan() || cap < 1.0 {
        return Vec::new();
    }
    let cap = (cap as usize).min(members.len() - 1);
    let zero_area = members.iter().all(|b| b.area_m2() <= 0.0);
    let weight = |b: &Building| if zero_area { 1.0 } else { b.area_m2().max(0.0) };
    let mut order: Vec<&Building> = members.to_vec();
    order.sort_by(|a, b| b.height_m.total_cmp(&a.height_m).then(a.id.cmp(&b.id)));
    let (mut w, mut wh) = order.iter().fold((0.0, 0.0), |(w, wh), b| {
        (w + weight(b), wh + weight(b) * b.height_m)
    });
    let mut out = Vec::new();
    for b in order.iter().take(cap) {
        let (rest_w, rest_wh) = (w - weight(b), wh - weight(b) * b.height_m);
        if rest_w <= 0.0 || b.height_m - rest_wh / rest_w < min_excess_m {
            break;
        }
        out.push(b.id);
        (w, wh) = (rest_w, rest_wh);
    }
    out.sort_unstable();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use citylod_model::HeightSource;
    use geo_types::{LineString, MultiPolygon, Polygon};

    fn building(i: usize, pts: Vec<(f64, f64)>, height_m: f64) -> Building {
        Building {
            id: BuildingId(i as u32),
            source_id: format!("b{i}"),
            footprint: MultiPolygon(vec![Polygon::new(LineString::from(pts), vec![])]),
            base_z_m: 0.0,
            height_m,
            height_source: HeightSource::Default,
            attributes: Default::default(),
            mesh: None,
        }
    }

    fn rect(i: usize, x: f64, y: f64, w: f64, h: f64) -> Building {
        building(
            i,
            vec![(x, y), (x + w, y), (x + w, y + h), (x, y + h)],
            5.0 + (i % 7) as f64,
        )
    }

    fn assert_sound(g: &Generalized, n: usize) {
        let h = &g.hierarchy;
        assert_eq!(h.check_invariants(n), Vec::<String>::new());
        assert_eq!(h.levels.last().unwrap().nodes.len(), 1, "one top node");
        for lv in &h.levels[1..] {
            for node in &lv.nodes {
                assert!(node.children.len() <= g.report.delta_p);
            }
        }
    }

    #[test]
    fn one_building_gives_a_two_level_hierarchy() {
        let g = generalize(&[rect(0, 0.0, 0.0, 10.0, 10.0)], &Default::default()).unwrap();
        assert_sound(&g, 1);
        assert_eq!(g.hierarchy.levels.len(), 2);
        let top = &g.hierarchy.levels[1].nodes[0];
        assert_eq!(top.footprint, g.hierarchy.levels[0].nodes[0].footprint);
    }

    #[test]
    fn two_identical_buildings_merge() {
        let bs = [rect(0, 0.0, 0.0, 10.0, 10.0), rect(1, 0.0, 0.0, 10.0, 10.0)];
        let g = generalize(&bs, &Default::default()).unwrap();
        assert_sound(&g, 2);
        // They touch (distance 0), so the first level above the buildings already holds them as one block.
        assert_eq!(
            g.hierarchy.levels[1].nodes.len(),
            1,
            "{:?}",
            g.hierarchy.levels[1].nodes
        );
        assert_eq!(g.hierarchy.levels[1].nodes[0].members.len(), 2);
    }

    #[test]
    fn five_hundred_touching_row_houses() {
        let bs: Vec<Building> = (0..500)
            .map(|i| rect(i, i as f64 * 6.0, 0.0, 6.0, 12.0))
            .collect();
        let g = generalize(&bs, &Default::default()).unwrap();
        assert_sound(&g, 500);
        assert!(g.report.tie_splits > 0);
    }

    #[test]
    fn ten_thousand_vertex_footprint() {
        let big: Vec<(f64, f64)> = (0..10_000)
            .map(|k| {
                let t = k as f64 / 10_000.0 * std::f64::consts::TAU;
                let r = 100.0 + 3.0 * (t * 50.0).sin();
                (r * t.cos(), r * t.sin())
            })
            .collect();
        let mut bs = vec![building(0, big, 30.0)];
        bs.extend((1..40).map(|i| {
            rect(
                i,
                120.0 + (i % 8) as f64 * 15.0,
                (i / 8) as f64 * 15.0,
                10.0,
                10.0,
            )
        }));
        let g = generalize(&bs, &Default::default()).unwrap();
        assert_sound(&g, 40);
    }

    #[test]
    fn buildings_on_one_line() {
        let bs: Vec<Building> = (0..200)
            .map(|i| rect(i, i as f64 * 13.0, 0.0, 10.0, 10.0))
            .collect();
        let g = generalize(&bs, &Default::default()).unwrap();
        assert_sound(&g, 200);
    }

    #[test]
    fn same_input_same_hierarchy() {
        let bs: Vec<Building> = (0..300)
            .map(|i| {
                rect(
                    i,
                    (i % 20) as f64 * 14.0 + (i / 60) as f64 * 3.0,
                    (i / 20) as f64 * 17.0,
                    10.0,
                    12.0,
                )
            })
            .collect();
        let a = generalize(&bs, &Default::default()).unwrap();
        let b = generalize(&bs, &Default::default()).unwrap();
        assert_sound(&a, 300);
        assert_eq!(a.hierarchy.levels.len(), b.hierarchy.levels.len());
        for (la, lb) in a.hierarchy.levels.iter().zip(&b.hierarchy.levels) {
            assert_eq!(la.nodes.len(), lb.nodes.len());
            for (na, nb) in la.nodes.iter().zip(&lb.nodes) {
                assert_eq!(
                    (&na.members, &na.children, &na.footprint),
                    (&nb.members, &nb.children, &nb.footprint)
                );
            }
        }
    }

    /// A planned town of 24 × 24 blocks of 10 m, 4 m apart, every vertex moved by `jitter_m` at most
    /// (deterministic pseudo-random offsets; 0 gives the exact grid). `staggered`: alternate blocks
    /// are set 0.7 m along the street, so no two corners face each other across a gap.
    fn planned_town(jitter_m: f64, staggered: bool) -> Vec<Building> {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut offset = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * jitter_m
        };
        (0..24 * 24)
            .map(|i| {
                let (col, row) = (i % 24, i / 24);
                let set = if staggered { 0.7 } else { 0.0 };
                let x = col as f64 * 14.0 + (row % 2) as f64 * set;
                let y = row as f64 * 14.0 + (col % 2) as f64 * set;
                let corners = [(x, y), (x + 10.0, y), (x + 10.0, y + 10.0), (x, y + 10.0)];
                let pts = corners
                    .iter()
                    .map(|&(cx, cy)| (cx + offset(), cy + offset()))
                    .collect();
                building(i, pts, 9.0 + (i % 5) as f64 * 3.0)
            })
            .collect()
    }

    fn assert_grouped_alike(staggered: bool, jitter_m: f64) {
        let exact = generalize(&planned_town(0.0, staggered), &Default::default()).unwrap();
        let moved = generalize(&planned_town(jitter_m, staggered), &Default::default()).unwrap();
        assert_sound(&exact, 576);
        assert_sound(&moved, 576);
        let members = |g: &Generalized| -> Vec<Vec<Vec<BuildingId>>> {
            g.hierarchy
                .levels
                .iter()
                .map(|l| l.nodes.iter().map(|n| n.members.clone()).collect())
                .collect()
        };
        let shape = |g: &Generalized| -> Vec<usize> {
            g.hierarchy.levels.iter().map(|l| l.nodes.len()).collect()
        };
        assert_eq!(shape(&exact), shape(&moved));
        assert!(
            members(&exact) == members(&moved),
            "same levels, other groups"
        );
    }

    #[test]
    fn a_town_moved_by_fractions_of_a_millimetre_is_grouped_alike() {
        // The same town stored on a coarser coordinate grid or projected differently: its adjacent
        // distances differ below a millimetre. Before distances were rounded to DISTANCE_RESOLUTION_M
        // (and part-growing centres with them), those differences ordered the town's equal merges and
        // placed the levels' thresholds among them: the exact and the moved town got other levels.
        assert_grouped_alike(true, 2e-4);
    }

    #[test]
    fn a_town_with_facing_corners_on_a_geodatabase_grid_is_grouped_alike() {
        // Corners facing across every gap: before angles within ANGLE_TIE_RAD were ties, the noise of
        // a 0.1 mm grid (a File Geodatabase's 1e-9°) chose between the facing and the collinear sides.
        assert_grouped_alike(false, 5e-5);
    }

    /// Twelve 9 m row houses 2 m apart and a 60 m tower among them.
    fn street_with_tower() -> Vec<Building> {
        (0..13)
            .map(|i| {
                let mut b = rect(i, i as f64 * 12.0, 0.0, 10.0, 12.0);
                b.height_m = if i == 6 { 60.0 } else { 9.0 + (i % 3) as f64 };
                b
            })
            .collect()
    }

    #[test]
    fn tall_tower_among_low_houses_is_a_landmark_left_out_of_dh() {
        let bs = street_with_tower();
        let g = generalize(&bs, &Default::default()).unwrap();
        assert_sound(&g, bs.len());
        let share = GeneralizeOptions::default().landmark_max_share;
        let mut seen = 0;
        for lv in &g.hierarchy.levels[1..] {
            for node in lv
                .nodes
                .iter()
                .filter(|n| n.members.contains(&BuildingId(6)))
            {
                if (share * node.members.len() as f64).floor() < 1.0 {
                    continue;
                }
                seen += 1;
                assert_eq!(node.landmarks, vec![BuildingId(6)]);
                assert!(
                    node.h_max_m <= 11.0 && node.dh_m <= 2.0,
                    "Δh {} counts the tower",
                    node.dh_m
                );
                assert!(node.height_m <= 11.0);
            }
        }
        assert!(seen > 0, "some block holds the tower");
        assert!(g.report.landmarks >= seen);
        let off = GeneralizeOptions {
            landmark_min_excess_m: f64::INFINITY,
            ..Default::default()
        };
        let g_off = generalize(&bs, &off).unwrap();
        let top = &g_off.hierarchy.levels.last().unwrap().nodes[0];
        assert!(top.landmarks.is_empty() && top.dh_m >= 50.0);
    }

    #[test]
    fn a_tower_hidden_in_a_block_whose_error_is_area_bound_is_no_landmark() {
        // The street with its tower, houses 30 m apart: the top block fills the gaps, so its error κ·√Δa
        // is larger than the tower's excess; drawing the tower apart would not lower the error.
        let bs: Vec<Building> = street_with_tower()
            .into_iter()
            .enumerate()
            .map(|(i, b)| {
                let mut spread = rect(i, i as f64 * 40.0, 0.0, 10.0, 12.0);
                spread.height_m = b.height_m;
                spread
            })
            .collect();
        let opts = GeneralizeOptions::default();
        let g = generalize(&bs, &opts).unwrap();
        assert_sound(&g, bs.len());
        let top = &g.hierarchy.levels.last().unwrap().nodes[0];
        let area_error = opts.error_kappa * top.da_m2.sqrt();
        assert!(top.landmarks.is_empty(), "{:?}", top.landmarks);
        assert!(top.h_max_m >= 60.0, "the tower is in the block's heights");
        assert!(
            area_error >= top.dh_m,
            "error {area_error} m is Δa-bound (Δh {})",
            top.dh_m
        );
        // Without the error model every candidate is kept.
        let g0 = generalize(
            &bs,
            &GeneralizeOptions {
                error_kappa: 0.0,
                ..opts
            },
        )
        .unwrap();
        let top0 = &g0.hierarchy.levels.last().unwrap().nodes[0];
        assert_eq!(top0.landmarks, vec![BuildingId(6)]);
        assert!(top0.dh_m < top.dh_m);
    }

    #[test]
    fn landmark_share_cap_is_respected() {
        // Every third house is a 50 m tower: far more candidates than a 10 % cap allows.
        let bs: Vec<Building> = (0..60)
            .map(|i| {
                let mut b = rect(
                    i,
                    (i % 20) as f64 * 12.0,
                    (i / 20) as f64 * 15.0,
                    10.0,
                    12.0,
                );
                b.height_m = if i % 3 == 0 { 50.0 } else { 8.0 };
                b
            })
            .collect();
        let opts = GeneralizeOptions {
            landmark_min_excess_m: 20.0,
            landmark_max_share: 0.1,
            // Every candidate is kept, whether or not it lowers the block's error (the cap alone binds).
            error_kappa: 0.0,
            ..Default::default()
        };
        let g = generalize(&bs, &opts).unwrap();
        assert_sound(&g, bs.len());
        for lv in &g.hierarchy.levels {
            for node in &lv.nodes {
                assert!(node.landmarks.len() as f64 <= (0.1 * node.members.len() as f64).floor());
                assert!(node.landmarks.iter().all(|b| node.members.contains(b)));
            }
        }
        let top = &g.hierarchy.levels.last().unwrap().nodes[0];
        assert_eq!(top.landmarks.len(), 6, "the cap binds at the top");
    }

    #[test]
    fn landmark_needs_the_full_excess_over_the_rest() {
        let bs = street_with_tower();
        let refs: Vec<&Building> = bs.iter().collect();
        assert_eq!(landmarks_of(&refs, 20.0, 0.34), vec![BuildingId(6)]);
        // The rest averages 10 m, so the 60 m tower stands 50 m out: not 50.5.
        assert!(landmarks_of(&refs, 50.5, 0.34).is_empty());
        assert!(
            landmarks_of(&refs[..2], 0.0, 0.34).is_empty(),
            "cap ⌊0.68⌋ = 0"
        );
        // At the default share a pair may keep its tower: the rest is then the other building alone.
        let share = GeneralizeOptions::default().landmark_max_share;
        let pair = [&bs[5], &bs[6]];
        assert_eq!(landmarks_of(&pair, 20.0, share), vec![BuildingId(6)]);
        assert!(landmarks_of(&refs, 20.0, 0.0).is_empty());
    }

    #[test]
    fn coarse_levels_of_a_real_city_keep_apart_only_distant_islands() {
        // Before islands were connected, Boston's top node kept ~1,500 separate polygons; now a node keeps
        // apart only polygons no bridge within the level's reach joins.
        let Some(fps) = crate::merge::tests::boston_sample(3000) else {
            return;
        };
        let bs: Vec<Building> = fps
            .into_iter()
            .enumerate()
            .map(|(i, f)| Building {
                footprint: f,
                ..rect(i, 0.0, 0.0, 1.0, 1.0)
            })
            .collect();
        let g = generalize(&bs, &Default::default()).unwrap();
        assert_sound(&g, bs.len());
        let levels = &g.hierarchy.levels;
        let lambda = GeneralizeOptions::default().lambda_adjacent;
        let mut apart = 0;
        for (l, lv) in levels.iter().enumerate().skip(levels.len() / 2) {
            let reach_m = island_reach_m(lv.threshold_m, lambda);
            for node in &lv.nodes {
                // The polygons a node keeps apart are farther apart than the level's reach.
                let polys = &node.footprint.0;
                for (i, p) in polys.iter().enumerate() {
                    let nearest_m = polys
                        .iter()
                        .enumerate()
                        .filter(|&(j, _)| j != i)
                        .map(|(_, q)| geo::Distance::distance(&geo::Euclidean, p, q))
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        nearest_m > reach_m,
                        "level {l}: polygons {nearest_m:.1} m apart, reach {reach_m:.1} m"
                    );
                    apart += usize::from(polys.len() > 1);
                }
            }
            let polys: usize = lv.nodes.iter().map(|n| n.footprint.0.len()).sum();
            assert!(
                polys <= 2 * lv.nodes.len(),
                "level {l}: {polys} polygons in {} nodes",
                lv.nodes.len()
            );
        }
        assert!(
            apart > 0,
            "the sample has clusters split across open ground"
        );
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        assert_eq!(
            generalize(&[], &Default::default()).unwrap_err(),
            GeneralizeError::NoBuildings
        );
        let mut b = rect(0, 0.0, 0.0, 1.0, 1.0);
        b.id = BuildingId(3);
        assert!(matches!(
            generalize(&[b], &Default::default()),
            Err(GeneralizeError::IdNotIndex { .. })
        ));
        let flat = building(0, vec![(0.0, 0.0), (1.0, 0.0), (0.0, 0.0)], 3.0);
        assert!(matches!(
            generalize(&[flat], &Default::default()),
            Err(GeneralizeError::DegenerateFootprint { .. })
        ));
        let opts = GeneralizeOptions {
            lambda_adjacent: 1.5,
            ..Default::default()
        };
        assert!(matches!(
            generalize(&[rect(0, 0.0, 0.0, 1.0, 1.0)], &opts),
            Err(GeneralizeError::BadOption {
                name: "lambda_adjacent",
                ..
            })
        ));
    }
}
