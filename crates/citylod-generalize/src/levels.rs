//! Condensing the single-link dendrogram into a few balanced levels (seed 000 §3.3.2). Thresholds
//! (m) sit where the sorted merge distance jumps most (rate rᵢ = (dᵢ₊₁ − dᵢ)/max(dᵢ, d_floor)); a level
//! with more than δp = 2·⌈n^(1/L)⌉ children per node on average gets a lower threshold from the largest
//! rate inside its crowded clusters, and nodes still over δp are split into parts that stay connected
//! through the candidate edges the level applies (grown region by region along the cluster's longer
//! axis), the children no part could take being cut spatially. Invariant: every level partitions the
//! level below, no node has more than δp children, and the top level is one node.

use crate::graph::{on_distance_grid, CandidateEdge};
use crate::single_link::{Merge, UnionFind};

/// Tuning of the condensing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelOptions {
    /// L = max(1, ⌊log₂ n / depth_divisor⌋) levels above the buildings before balancing (seed: 1.5).
    pub depth_divisor: f64,
    /// Floor for dᵢ in the rate rᵢ, so that touching buildings (d = 0) give finite rates (m).
    pub d_floor_m: f64,
    /// At most this many levels are inserted below one planned threshold.
    pub max_inserts_per_level: usize,
}

impl Default for LevelOptions {
    fn default() -> Self {
        LevelOptions {
            depth_divisor: 1.5,
            d_floor_m: 1.0,
            max_inserts_per_level: 2,
        }
    }
}

/// Why a level exists.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LevelKind {
    /// One of the L − 1 thresholds at the largest distance-increase rates.
    Rate,
    /// A threshold inserted by balancing (the level had more than δp children per node on average).
    Inserted,
    /// Every merge of the dendrogram applied (the single-link top).
    Top,
    /// A purely spatial grouping above the top, when splits left more than one top node.
    ExtraTop,
}

/// One level above the buildings.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PlannedLevel {
    pub kind: LevelKind,
    /// Every merge with d ≤ threshold_m is applied at this level (m); the top's is the largest merge d.
    pub threshold_m: f64,
    /// Merges of the dendrogram applied (a prefix of the sorted merges).
    pub n_merges: usize,
    /// Each node's children: indices into the level below, ascending. Nodes are ordered by their
    /// smallest building, children likewise.
    #[serde(skip)]
    pub groups: Vec<Vec<u32>>,
    /// Nodes over δp children whose merges in this level's interval all have the same distance
    /// (typically touching row houses, d = 0), split spatially.
    pub tie_splits: usize,
    /// Nodes over δp children split spatially because the insertion budget ran out.
    pub budget_splits: usize,
}

/// The condensed levels and the balancing parameters.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LevelPlan {
    /// L = max(1, ⌊log₂ n / depth_divisor⌋): planned levels above the buildings before balancing.
    pub target_levels: usize,
    /// Thresholds from the largest rates: min(L − 1, number of distance increases).
    pub rate_levels: usize,
    /// Rate thresholds dropped because their level would not at least halve the node count (their
    /// merges go to the next level); typical for the last few merges of isolated outliers.
    pub rate_levels_skipped: usize,
    /// p = ⌈n^(1/L)⌉, the children per node of a perfectly balanced tree.
    pub p: usize,
    /// δp = 2p, the most children a node may have.
    pub delta_p: usize,
    /// Levels above the buildings, finest first; the last one holds a single node.
    pub levels: Vec<PlannedLevel>,
}

/// L = max(1, ⌊log₂ n / depth_divisor⌋) (n = 37, divisor 1.5 → 3, the seed's example).
pub fn target_levels(n: usize, depth_divisor: f64) -> usize {
    if n < 2 || depth_divisor.is_nan() || depth_divisor <= 0.0 {
        return 1;
    }
    // More levels than n − 1 merges could never be made (a tiny divisor asked for billions).
    (((n as f64).log2() / depth_divisor).floor() as usize).clamp(1, n - 1)
}

/// Condenses `merges` (from [`crate::single_link`], sorted by d) over `n` buildings into levels.
/// `edges` are the candidate edges single-link ran on (any order; the merges are some of them): a
/// node over δp children is split into parts connected by the edges its level applies. `boxes[i]` =
/// [min x, min y, max x, max y] of building i (local ENU m), used to grow compact parts and to cut
/// what stays over spatially (no edges: every split is spatial).
/// The number of levels above the buildings is `rate_levels` − `rate_levels_skipped` + inserted
/// levels + 1 (top) + extra top levels; see [`PlannedLevel::kind`]. n = 0 gives no levels.
pub fn condense(
    n: usize,
    merges: &[Merge],
    edges: &[CandidateEdge],
    boxes: &[[f64; 4]],
    opts: &LevelOptions,
) -> LevelPlan {
    debug_assert_eq!(boxes.len(), n);
    debug_assert!(merges.windows(2).all(|w| w[0].d_m <= w[1].d_m));
    let l = target_levels(n, opts.depth_divisor);
    let p = if n < 2 {
        1
    } else {
        let r = (n as f64).powf(1.0 / l as f64);
        // Guard against 3.0000000001 for exact powers.
        (r - 1e-9).ceil().max(1.0) as usize
    };
    let delta_p = (2 * p).max(2);
    let mut plan = LevelPlan {
        target_levels: l,
        rate_levels: 0,
        rate_levels_skipped: 0,
        p,
        delta_p,
        levels: Vec::new(),
    };
    if n == 0 {
        return plan;
    }
    let m = merges.len();
    let d = |i: usize| merges[i].d_m;
    let rate = |i: usize| (d(i + 1) - d(i)) / d(i).max(opts.d_floor_m);

    let mut rates: Vec<(f64, usize)> = (0..m.saturating_sub(1))
        .filter(|&i| d(i + 1) > d(i))
        .map(|i| (rate(i), i))
        .collect();
    rates.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    let mut targets: Vec<(usize, LevelKind)> = rates
        .iter()
        .take(l - 1)
        .map(|&(_, i)| (i + 1, LevelKind::Rate))
        .collect();
    targets.sort_unstable();
    plan.rate_levels = targets.len();
    targets.push((m, LevelKind::Top));

    let threshold_at = |k: usize| {
        if k == 0 {
            0.0
        } else if k == m {
            d(m - 1)
        } else {
            (d(k - 1) + d(k)) / 2.0
        }
    };

    let mut cross = CrossEdges::new(n, edges);

    let mut below: Vec<NodeInfo> = (0..n as u32)
        .map(|i| NodeInfo {
            rep: i,
            bbox: boxes[i as usize],
        })
        .collect();
    let mut uf_lo = UnionFind::new(n);
    let mut k_lo = 0usize;
    let mut slot = vec![u32::MAX; n];

    for (k_hi, kind) in targets {
        let mut inserted = 0usize;
        loop {
            let mut k = k_hi;
            // Paper: while the level is too crowded (m·δp < m_ch), replace its threshold by a lower one.
            let (groups, internal) = loop {
                let mut uf = uf_lo.clone();
                for mg in &merges[k_lo..k] {
                    uf.union(mg.a, mg.b);
                }
                let (groups, roots) = group_children(&below, &mut uf, &mut slot);
                // Merge indices inside this interval, for the groups over δp children.
                let mut internal: Vec<Vec<usize>> = vec![Vec::new(); groups.len()];
                for (j, mg) in merges.iter().enumerate().take(k).skip(k_lo) {
                    let g = slot[uf.find(mg.a) as usize] as usize;
                    if groups[g].len() > delta_p {
                        internal[g].push(j);
                    }
                }
                for r in roots {
                    slot[r as usize] = u32::MAX;
                }
                let crowded = groups.len() * delta_p < below.len();
                let cut = if crowded && inserted < opts.max_inserts_per_level {
                    best_local_cut(merges, &internal, opts.d_floor_m)
                } else {
                    None
                };
                match cut {
                    Some(kc) => {
                        debug_assert!(k_lo < kc && kc < k);
                        k = kc;
                    }
                    None => break (groups, internal),
                }
            };
            // A rate level that does not at least halve the node count hands its merges to the next.
            if kind == LevelKind::Rate && k == k_hi && groups.len() * 2 > below.len() {
                plan.rate_levels_skipped += 1;
                break;
            }
            if k != k_hi {
                inserted += 1;
            }
            let mut level = PlannedLevel {
                kind: if k == k_hi { kind } else { LevelKind::Inserted },
                threshold_m: threshold_at(k),
                n_merges: k,
                groups: Vec::new(),
                tie_splits: 0,
                budget_splits: 0,
            };
            let mut out: Vec<Vec<u32>> = Vec::with_capacity(groups.len());
            let crowded_links = if groups.iter().any(|g| g.len() > delta_p) {
                cross.advance(if k == 0 { f64::NEG_INFINITY } else { d(k - 1) });
                cross.links_inside(&groups, delta_p)
            } else {
                vec![Vec::new(); groups.len()]
            };
            for ((g, js), links) in groups.into_iter().zip(internal).zip(crowded_links) {
                if g.len() > delta_p {
                    let tie = js
                        .first()
                        .is_none_or(|&f| d(f) == d(*js.last().expect("non-empty")));
                    if tie {
                        level.tie_splits += 1;
                    } else {
                        level.budget_splits += 1;
                    }
                    split_connected(&g, &links, &below, delta_p, &mut out);
                } else {
                    out.push(g);
                }
            }
            below = finish_level(&mut level, out, &below);
            cross.relabel(&level.groups);
            plan.levels.push(level);
            // Children of later levels are looked up through the merges applied so far.
            for mg in &merges[k_lo..k] {
                uf_lo.union(mg.a, mg.b);
            }
            k_lo = k;
            if k == k_hi {
                break;
            }
        }
    }

    while below.len() > 1 {
        let mut all: Vec<u32> = (0..below.len() as u32).collect();
        let mut out = Vec::new();
        let mut level = PlannedLevel {
            kind: LevelKind::ExtraTop,
            threshold_m: threshold_at(m),
            n_merges: m,
            groups: Vec::new(),
            tie_splits: 0,
            budget_splits: 0,
        };
        if all.len() > delta_p {
            level.tie_splits += 1;
        }
        cross.advance(f64::INFINITY);
        let groups = vec![std::mem::take(&mut all)];
        let links = cross
            .links_inside(&groups, delta_p)
            .pop()
            .unwrap_or_default();
        split_connected(&groups[0], &links, &below, delta_p, &mut out);
        below = finish_level(&mut level, out, &below);
        cross.relabel(&level.groups);
        plan.levels.push(level);
    }
    plan
}

/// The lower threshold for a crowded level: over the groups with more than δp children, the largest
/// rate between consecutive distinct distances of the group's own merges (the seed's rule applied to
/// the crowded clusters' distance sequences); returns the number of merges to apply (all merges with
/// d ≤ the lower distance, so ties are never cut). `None` when every crowded group is a tie.
fn best_local_cut(merges: &[Merge], internal: &[Vec<usize>], d_floor_m: f64) -> Option<usize> {
    let d = |i: usize| merges[i].d_m;
    let mut best: Option<(f64, usize)> = None;
    for js in internal {
        for w in js.windows(2) {
            let (lo, hi) = (d(w[0]), d(w[1]));
            if hi > lo {
                let r = (hi - lo) / lo.max(d_floor_m);
                let k = merges.partition_point(|mg| mg.d_m <= lo);
                if best.is_none_or(|(br, bk)| r > br || (r == br && k < bk)) {
                    best = Some((r, k));
                }
            }
        }
    }
    best.map(|(_, k)| k)
}

/// What condensing needs to know of a node: its smallest building and its bounding box.
#[derive(Debug, Clone, Copy)]
struct NodeInfo {
    rep: u32,
    bbox: [f64; 4],
}

impl NodeInfo {
    /// The box's centre on the distance grid, so that parts grown in a regular town do not depend on
    /// sub-millimetre differences (which axis is longer, which child is nearer its seed).
    fn centre(&self) -> [f64; 2] {
        let b = self.bbox;
        [
            on_distance_grid((b[0] + b[2]) / 2.0),
            on_distance_grid((b[1] + b[3]) / 2.0),
        ]
    }
}

/// 0 when `points` spread at least as far along x as along y, else 1.
fn longer_axis(points: impl IntoIterator<Item = [f64; 2]>) -> usize {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    usize::from(hi[1] - lo[1] > hi[0] - lo[0])
}

fn dist2(p: [f64; 2], q: [f64; 2]) -> f64 {
    (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)
}

/// Groups the nodes of the level below by their union–find component. Leaves `slot[root]` = group
/// index for the returned roots (the caller resets them).
fn group_children(
    below: &[NodeInfo],
    uf: &mut UnionFind,
    slot: &mut [u32],
) -> (Vec<Vec<u32>>, Vec<u32>) {
    let mut groups: Vec<Vec<u32>> = Vec::new();
    let mut roots = Vec::new();
    for (c, info) in below.iter().enumerate() {
        let r = uf.find(info.rep);
        if slot[r as usize] == u32::MAX {
            slot[r as usize] = groups.len() as u32;
            groups.push(Vec::new());
            roots.push(r);
        }
        groups[slot[r as usize] as usize].push(c as u32);
    }
    (groups, roots)
}

/// Orders the groups by first child (= by smallest building) and returns the new level's nodes.
fn finish_level(
    level: &mut PlannedLevel,
    mut groups: Vec<Vec<u32>>,
    below: &[NodeInfo],
) -> Vec<NodeInfo> {
    groups.sort_unstable_by_key(|g| g[0]);
    let infos = groups
        .iter()
        .map(|g| {
            let mut bbox = below[g[0] as usize].bbox;
            for &c in &g[1..] {
                let b = below[c as usize].bbox;
                bbox = [
                    bbox[0].min(b[0]),
                    bbox[1].min(b[1]),
                    bbox[2].max(b[2]),
                    bbox[3].max(b[3]),
                ];
            }
            NodeInfo {
                rep: below[g[0] as usize].rep,
                bbox,
            }
        })
        .collect();
    level.groups = groups;
    infos
}

/// The candidate edges a level may split along: those up to the level's distance whose buildings lie
/// in different nodes of the level below. Single-link joins the two ends of every such edge, but a
/// spatial split can still leave them apart, and the next level sees their cluster (all its parts)
/// as one crowded group again, so edges are kept until their ends share a node.
struct CrossEdges {
    /// Every edge between distinct buildings, by (d, a, b).
    sorted: Vec<(f64, u32, u32)>,
    /// Edges of `sorted` before this one have been taken into `pending` or dropped.
    next: usize,
    /// Building pairs whose nodes differ on the level below.
    pending: Vec<(u32, u32)>,
    /// Each building's node on the level below.
    node_of: Vec<u32>,
}

impl CrossEdges {
    fn new(n: usize, edges: &[CandidateEdge]) -> Self {
        let mut sorted: Vec<(f64, u32, u32)> = edges
            .iter()
            .filter(|e| e.a != e.b && (e.a as usize) < n && (e.b as usize) < n)
            .map(|e| (e.d_m, e.a, e.b))
            .collect();
        sorted.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
        CrossEdges {
            sorted,
            next: 0,
            pending: Vec::new(),
            node_of: (0..n as u32).collect(),
        }
    }

    /// Takes the edges up to `d_max_m` (m) in.
    fn advance(&mut self, d_max_m: f64) {
        while let Some(&(d, a, b)) = self.sorted.get(self.next) {
            if d > d_max_m {
                break;
            }
            if self.node_of[a as usize] != self.node_of[b as usize] {
                self.pending.push((a, b));
            }
            self.next += 1;
        }
    }

    /// For each group over `max` children (indices into the level below), the pairs of its children
    /// an edge taken in joins, ascending and without repeats; other groups get none.
    fn links_inside(&self, groups: &[Vec<u32>], max: usize) -> Vec<Vec<(u32, u32)>> {
        let n_below = groups.iter().map(Vec::len).sum::<usize>();
        let mut group_of = vec![u32::MAX; n_below];
        for (gi, g) in groups.iter().enumerate() {
            if g.len() > max {
                for &c in g {
                    group_of[c as usize] = gi as u32;
                }
            }
        }
        let mut links = vec![Vec::new(); groups.len()];
        for &(a, b) in &self.pending {
            let (ca, cb) = (self.node_of[a as usize], self.node_of[b as usize]);
            let gi = group_of[ca as usize];
            if ca != cb && gi != u32::MAX && gi == group_of[cb as usize] {
                links[gi as usize].push((ca.min(cb), ca.max(cb)));
            }
        }
        for l in &mut links {
            l.sort_unstable();
            l.dedup();
        }
        links
    }

    /// Moves every building up to its node of the new level (`groups`: its nodes' children) and drops
    /// the edges now inside one node.
    fn relabel(&mut self, groups: &[Vec<u32>]) {
        let n_below = groups.iter().map(Vec::len).sum::<usize>();
        let mut parent = vec![0u32; n_below];
        for (gi, g) in groups.iter().enumerate() {
            for &c in g {
                parent[c as usize] = gi as u32;
            }
        }
        for v in &mut self.node_of {
            *v = parent[*v as usize];
        }
        let node_of = &self.node_of;
        self.pending
            .retain(|&(a, b)| node_of[a as usize] != node_of[b as usize]);
    }
}

/// Splits a node's `children` (ascending indices into `below`) into parts of at most `max`, each
/// connected through `links` (pairs of children) where it can be: q = ⌈m / max⌉ parts of about m / q
/// children are grown one after the other, each from the first free child along the longer axis of
/// the children's centres, taking the linked free child nearest to its seed until full (first those
/// with no other free neighbour, which would be left alone). A part left smaller than half that size
/// joins the smallest linked part with room; a child still alone joins the part with room whose child
/// lies nearest (beside it, though not linked); what is left is cut spatially ([`split_spatially`]).
/// No links: a spatial split.
fn split_connected(
    children: &[u32],
    links: &[(u32, u32)],
    below: &[NodeInfo],
    max: usize,
    out: &mut Vec<Vec<u32>>,
) {
    let m = children.len();
    let max = max.max(1);
    if m <= max {
        out.push(children.to_vec());
        return;
    }
    if links.is_empty() {
        split_spatially(&mut children.to_vec(), below, max, out);
        return;
    }
    let local = |c: u32| {
        children
            .binary_search(&c)
            .expect("linked children belong to the node")
    };
    // Neighbours in compressed rows.
    let mut degree = vec![0usize; m + 1];
    for &(a, b) in links {
        degree[local(a) + 1] += 1;
        degree[local(b) + 1] += 1;
    }
    for i in 0..m {
        degree[i + 1] += degree[i];
    }
    let start = degree;
    let mut fill = start.clone();
    let mut nbr = vec![0usize; start[m]];
    for &(a, b) in links {
        let (la, lb) = (local(a), local(b));
        nbr[fill[la]] = lb;
        fill[la] += 1;
        nbr[fill[lb]] = la;
        fill[lb] += 1;
    }
    let centre: Vec<[f64; 2]> = children
        .iter()
        .map(|&c| below[c as usize].centre())
        .collect();
    let axis = longer_axis(centre.iter().copied());
    let mut seeds: Vec<usize> = (0..m).collect();
    seeds.sort_unstable_by(|&a, &b| centre[a][axis].total_cmp(&centre[b][axis]).then(a.cmp(&b)));

    let parts_wanted = m.div_ceil(max);
    let target = m.div_ceil(parts_wanted);
    const FREE: usize = usize::MAX;
    let mut part_of = vec![FREE; m];
    // Free neighbours of each child (with the links' multiplicity), kept as children are taken, and the part
    // whose frontier last queued a child: a dense cluster (hundreds of touching or stacked footprints) would
    // otherwise rescan every neighbour list at every step, and queue a child once per neighbour taken.
    let mut free_nbrs: Vec<usize> = (0..m).map(|i| start[i + 1] - start[i]).collect();
    let mut queued = vec![FREE; m];
    let mut parts: Vec<Vec<usize>> = Vec::new();
    let mut frontier: Vec<usize> = Vec::new();
    let mut take = |x: usize,
                    pi: usize,
                    part_of: &mut [usize],
                    frontier: &mut Vec<usize>,
                    free_nbrs: &mut [usize]| {
        part_of[x] = pi;
        for &n in &nbr[start[x]..start[x + 1]] {
            free_nbrs[n] -= 1;
            if part_of[n] == FREE && queued[n] != pi {
                queued[n] = pi;
                frontier.push(n);
            }
        }
    };
    for &seed in &seeds {
        if part_of[seed] != FREE {
            continue;
        }
        let pi = parts.len();
        let mut part = vec![seed];
        frontier.clear();
        take(seed, pi, &mut part_of, &mut frontier, &mut free_nbrs);
        let to_seed = |j: usize| dist2(centre[j], centre[seed]);
        while part.len() < target {
            frontier.retain(|&j| part_of[j] == FREE);
            // A child with no other free neighbour is taken first: left behind, it would be alone.
            let open = |j: usize| free_nbrs[j] > 0;
            let Some(pos) = (0..frontier.len()).min_by(|&x, &y| {
                let (a, b) = (frontier[x], frontier[y]);
                (open(a), to_seed(a), a)
                    .partial_cmp(&(open(b), to_seed(b), b))
                    .unwrap_or(std::cmp::Ordering::Equal)
            }) else {
                break;
            };
            let j = frontier.swap_remove(pos);
            part.push(j);
            take(j, pi, &mut part_of, &mut frontier, &mut free_nbrs);
        }
        parts.push(part);
    }

    // Small parts join the smallest linked part with room (smallest parts first).
    let mut order: Vec<usize> = (0..parts.len()).collect();
    order.sort_by_key(|&p| (parts[p].len(), p));
    for &p in &order {
        let size = parts[p].len();
        if size == 0 || 2 * size >= target {
            continue;
        }
        let mut best: Option<(usize, usize)> = None;
        for &i in &parts[p] {
            for &j in &nbr[start[i]..start[i + 1]] {
                let q = part_of[j];
                if q == p || parts[q].len() + size > max {
                    continue;
                }
                if best.is_none_or(|(bs, bq)| (parts[q].len(), q) < (bs, bq)) {
                    best = Some((parts[q].len(), q));
                }
            }
        }
        if let Some((_, q)) = best {
            let moved = std::mem::take(&mut parts[p]);
            for &i in &moved {
                part_of[i] = q;
            }
            parts[q].extend(moved);
        }
    }

    // A child still alone joins the part with room nearest to it, so that it lies beside its part
    // (a scan of all children per lone child; beyond ORPHAN_SCAN_LIMIT pairs they are cut spatially).
    const ORPHAN_SCAN_LIMIT: usize = 50_000_000;
    let lone = parts.iter().filter(|p| p.len() == 1).count();
    for o in 0..m {
        if lone.saturating_mul(m) > ORPHAN_SCAN_LIMIT {
            break;
        }
        let p = part_of[o];
        if parts[p].len() != 1 {
            continue;
        }
        let near = (0..m)
            .filter(|&j| part_of[j] != p && parts[part_of[j]].len() < max)
            .min_by(|&a, &b| {
                let d = |j: usize| dist2(centre[j], centre[o]);
                d(a).total_cmp(&d(b)).then(a.cmp(&b))
            });
        if let Some(j) = near {
            let q = part_of[j];
            parts[p].clear();
            part_of[o] = q;
            parts[q].push(o);
        }
    }

    let mut alone: Vec<u32> = Vec::new();
    for part in parts {
        match part.len() {
            0 => {}
            1 => alone.push(children[part[0]]),
            _ => {
                let mut v: Vec<u32> = part.into_iter().map(|i| children[i]).collect();
                v.sort_unstable();
                out.push(v);
            }
        }
    }
    if !alone.is_empty() {
        split_spatially(&mut alone, below, max, out);
    }
}

/// Recursive median split along the longer axis of the children's box centres until every piece has
/// at most `max` children; pieces come out with their children ascending.
fn split_spatially(children: &mut [u32], below: &[NodeInfo], max: usize, out: &mut Vec<Vec<u32>>) {
    if children.len() <= max.max(1) {
        let mut v = children.to_vec();
        v.sort_unstable();
        out.push(v);
        return;
    }
    let centre = |c: u32| below[c as usize].centre();
    let axis = longer_axis(children.iter().map(|&c| centre(c)));
    children.sort_unstable_by(|&a, &b| centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b)));
    let mid = children.len() / 2;
    let (left, right) = children.split_at_mut(mid);
    split_spatially(left, below, max, out);
    split_spatially(right, below, max, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn merges(ds: &[(f64, u32, u32)]) -> Vec<Merge> {
        ds.iter().map(|&(d_m, a, b)| Merge { d_m, a, b }).collect()
    }

    fn unit_boxes(n: usize) -> Vec<[f64; 4]> {
        (0..n)
            .map(|i| [i as f64, 0.0, i as f64 + 1.0, 1.0])
            .collect()
    }

    /// Every level's groups partition the level below, and no node has more than δp children.
    fn check(plan: &LevelPlan, n: usize) {
        let mut below = n;
        for lv in &plan.levels {
            let mut seen = vec![false; below];
            for g in &lv.groups {
                assert!(
                    g.len() <= plan.delta_p,
                    "{} children > δp {}",
                    g.len(),
                    plan.delta_p
                );
                assert!(g.windows(2).all(|w| w[0] < w[1]));
                for &c in g {
                    assert!(!std::mem::replace(&mut seen[c as usize], true));
                }
            }
            assert!(seen.iter().all(|&s| s));
            assert!(lv.groups.windows(2).all(|w| w[0][0] < w[1][0]));
            below = lv.groups.len();
        }
        assert_eq!(below, 1, "one top node");
    }

    #[test]
    fn depth_formula_matches_the_seed_example() {
        assert_eq!(target_levels(37, 1.5), 3);
        // Never more levels than merges: a divisor of 1e-9 asked for 10 billion.
        assert_eq!(target_levels(1000, 1e-9), 999);
        assert_eq!(target_levels(22_186, 1.5), 9);
        assert_eq!(target_levels(1, 1.5), 1);
        assert_eq!(target_levels(2, 1.5), 1);
    }

    #[test]
    fn seed_figure_6_threshold_falls_between_32_and_58() {
        // Figure 6b: six buildings merged at 19, 23, 27, 32, 58. With L = 2 (divisor 1.2) the single
        // rate threshold goes where d jumps from 32 to 58.
        let ms = merges(&[
            (19.0, 0, 1),
            (23.0, 1, 2),
            (27.0, 3, 4),
            (32.0, 2, 3),
            (58.0, 4, 5),
        ]);
        let opts = LevelOptions {
            depth_divisor: 1.2,
            ..Default::default()
        };
        let plan = condense(6, &ms, &[], &unit_boxes(6), &opts);
        assert_eq!(plan.target_levels, 2);
        assert_eq!(plan.levels[0].kind, LevelKind::Rate);
        assert_eq!(plan.levels[0].threshold_m, 45.0);
        assert_eq!(plan.levels[0].groups, vec![vec![0, 1, 2, 3, 4], vec![5]]);
        check(&plan, 6);
    }

    #[test]
    fn crowded_level_gets_an_inserted_threshold() {
        // 32 buildings: 8 quads at 1 m, quads paired at 3 m, pairs of pairs at 9 m, halves at 100 m.
        // L = ⌊5 / 2.5⌋ = 2 gives one rate threshold, at the 9 → 100 jump: 2 nodes of 16 children
        // (p = 6, δp = 12, and 2·12 < 32: crowded). The crowded clusters' own distance sequence
        // 1, 3, 9 jumps most (ties go low) at 1 → 3, so a level of the 8 quads is inserted below.
        let mut ms: Vec<(f64, u32, u32)> = Vec::new();
        for q in 0..8u32 {
            ms.extend((0..3).map(|k| (1.0, 4 * q + k, 4 * q + k + 1)));
        }
        ms.extend((0..4u32).map(|r| (3.0, 8 * r, 8 * r + 4)));
        ms.extend((0..2u32).map(|s| (9.0, 16 * s, 16 * s + 8)));
        ms.push((100.0, 0, 16));
        let opts = LevelOptions {
            depth_divisor: 2.5,
            ..Default::default()
        };
        let plan = condense(32, &merges(&ms), &[], &unit_boxes(32), &opts);
        assert_eq!(
            (plan.target_levels, plan.p, plan.delta_p, plan.rate_levels),
            (2, 6, 12, 1)
        );
        check(&plan, 32);
        let kinds: Vec<LevelKind> = plan.levels.iter().map(|l| l.kind).collect();
        assert_eq!(
            kinds,
            vec![LevelKind::Inserted, LevelKind::Rate, LevelKind::Top]
        );
        assert_eq!(plan.levels[0].groups.len(), 8);
        assert_eq!(plan.levels[0].threshold_m, 2.0);
        assert_eq!(plan.levels[1].groups.len(), 2);
        assert!(plan
            .levels
            .iter()
            .all(|l| l.tie_splits == 0 && l.budget_splits == 0));
    }

    #[test]
    fn rate_level_that_does_not_halve_is_skipped() {
        // Figure 6 with L = ⌊log₂ 6 / 0.8⌋ = 3: rates 0.21 (19 → 23), 0.17, 0.19, 0.81 (32 → 58). The
        // threshold at 21 would only join one pair (6 → 5 nodes), so its merge moves up to the 45 m level.
        let ms = merges(&[
            (19.0, 0, 1),
            (23.0, 1, 2),
            (27.0, 3, 4),
            (32.0, 2, 3),
            (58.0, 4, 5),
        ]);
        let opts = LevelOptions {
            depth_divisor: 0.8,
            ..Default::default()
        };
        let plan = condense(6, &ms, &[], &unit_boxes(6), &opts);
        check(&plan, 6);
        assert_eq!((plan.rate_levels, plan.rate_levels_skipped), (2, 1));
        assert_eq!(plan.levels[0].threshold_m, 45.0);
        // δp = 2·⌈6^(1/3)⌉ = 4: the 5-building cluster is split spatially (a budget split).
        assert_eq!(
            plan.levels[0].groups,
            vec![vec![0, 1], vec![2, 3, 4], vec![5]]
        );
        assert_eq!(plan.levels[0].budget_splits, 1);
    }

    #[test]
    fn touching_row_houses_are_split_spatially_and_reported() {
        let n = 500;
        let ms: Vec<(f64, u32, u32)> = (0..n as u32 - 1).map(|i| (0.0, i, i + 1)).collect();
        let plan = condense(
            n,
            &merges(&ms),
            &[],
            &unit_boxes(n),
            &LevelOptions::default(),
        );
        check(&plan, n);
        assert!(plan.levels.iter().map(|l| l.tie_splits).sum::<usize>() > 0);
        // Spatial pieces of a row are runs of consecutive houses.
        for g in &plan.levels[0].groups {
            assert_eq!(g.last().unwrap() - g[0] + 1, g.len() as u32);
        }
    }

    /// Whether the buildings of `group` are one piece through `edges`.
    fn connected(group: &[u32], edges: &[CandidateEdge]) -> bool {
        let mut uf = UnionFind::new(group.len());
        let pos = |b: u32| group.iter().position(|&x| x == b);
        for e in edges {
            if let (Some(a), Some(b)) = (pos(e.a), pos(e.b)) {
                uf.union(a as u32, b as u32);
            }
        }
        let r = uf.find(0);
        (0..group.len() as u32).all(|i| uf.find(i) == r)
    }

    #[test]
    fn crowded_rows_around_a_yard_are_split_into_connected_parts() {
        // Two rows of 20 touching houses, 12 m apart across a back yard, joined at one end by a row of
        // 11: one U-shaped cluster at d = 0, n = 51 so δp = 8. Median cuts across the U put houses of
        // both rows into one part (linked only through the far end); parts grown along the candidate
        // edges stay on one side.
        let mut boxes = Vec::new();
        for i in 0..20 {
            boxes.push([i as f64, 0.0, i as f64 + 1.0, 1.0]);
        }
        for i in 0..20 {
            boxes.push([i as f64, 12.0, i as f64 + 1.0, 13.0]);
        }
        for j in 1..12 {
            boxes.push([0.0, j as f64, 1.0, j as f64 + 1.0]);
        }
        let n = boxes.len();
        let e = |a: usize, b: usize| CandidateEdge {
            a: a as u32,
            b: b as u32,
            d_m: 0.0,
        };
        let mut edges: Vec<CandidateEdge> = (0..19).map(|i| e(i, i + 1)).collect();
        edges.extend((20..39).map(|i| e(i, i + 1)));
        edges.extend((40..50).map(|i| e(i, i + 1)));
        edges.push(e(0, 40));
        edges.push(e(50, 20));
        let ms = crate::single_link::single_link(n, &edges);
        assert_eq!(ms.len(), n - 1);
        let opts = LevelOptions::default();

        let plan = condense(n, &ms, &edges, &boxes, &opts);
        check(&plan, n);
        assert_eq!(plan.delta_p, 8);
        let first = &plan.levels[0];
        assert_eq!(first.tie_splits, 1);
        assert!(first.groups.iter().all(|g| connected(g, &edges)));
        // As few parts as a spatial split makes: ⌈51 / 8⌉ = 7 at best.
        let spatial = condense(n, &ms, &[], &boxes, &opts);
        check(&spatial, n);
        assert!(first.groups.len() <= spatial.levels[0].groups.len());
        assert!(first.groups.len() >= 7);
        assert!(spatial.levels[0]
            .groups
            .iter()
            .any(|g| !connected(g, &edges)));
    }

    #[test]
    fn a_star_split_keeps_its_hub_part_connected_and_cuts_the_leaves_spatially() {
        // A long hall (0) touched by 30 sheds that touch nothing else: one part holds the hall and its
        // nearest sheds, the other sheds (alone once the hall is taken) are grouped by a spatial cut.
        let mut boxes = vec![[0.0, 0.0, 60.0, 10.0]];
        for i in 0..15 {
            boxes.push([4.0 * i as f64, 10.0, 4.0 * i as f64 + 2.0, 12.0]);
            boxes.push([4.0 * i as f64, -2.0, 4.0 * i as f64 + 2.0, 0.0]);
        }
        let n = boxes.len();
        let edges: Vec<CandidateEdge> = (1..n as u32)
            .map(|b| CandidateEdge { a: 0, b, d_m: 0.0 })
            .collect();
        let ms = crate::single_link::single_link(n, &edges);
        let plan = condense(n, &ms, &edges, &boxes, &LevelOptions::default());
        check(&plan, n);
        let first = &plan.levels[0].groups;
        let hub = first.iter().find(|g| g.contains(&0)).unwrap();
        assert_eq!(hub.len(), plan.delta_p);
        // The rest: 31 − δp sheds in parts of at most δp, no part of a single shed more than needed.
        assert!(first.len() <= 1 + (n - plan.delta_p).div_ceil(plan.delta_p / 2));
    }

    #[test]
    fn stacked_footprints_split_into_full_connected_parts() {
        // 400 copies of one footprint (a file listing every storey, say): every pair touches, so each part of
        // the first level's split is a clique; all parts but at most one are full, none alone.
        let n = 400;
        let boxes = vec![[0.0, 0.0, 10.0, 10.0]; n];
        let mut edges = Vec::new();
        for a in 0..n as u32 {
            for b in a + 1..n as u32 {
                edges.push(CandidateEdge { a, b, d_m: 0.0 });
            }
        }
        let ms = crate::single_link::single_link(n, &edges);
        let plan = condense(n, &ms, &edges, &boxes, &LevelOptions::default());
        check(&plan, n);
        let first = &plan.levels[0].groups;
        let target = n.div_ceil(n.div_ceil(plan.delta_p));
        assert!(first.iter().all(|g| g.len() > 1), "{first:?}");
        assert!(
            first.iter().filter(|g| g.len() < target).count() <= 1,
            "{first:?}"
        );
    }

    #[test]
    fn single_building_has_one_top_level() {
        let plan = condense(1, &[], &[], &unit_boxes(1), &LevelOptions::default());
        assert_eq!(plan.levels.len(), 1);
        assert_eq!(plan.levels[0].groups, vec![vec![0]]);
    }

    #[test]
    fn disconnected_dendrogram_still_gets_one_top() {
        let plan = condense(40, &[], &[], &unit_boxes(40), &LevelOptions::default());
        check(&plan, 40);
        assert!(plan.levels.iter().any(|l| l.kind == LevelKind::ExtraTop));
    }
}
