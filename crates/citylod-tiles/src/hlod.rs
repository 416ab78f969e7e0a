//! Packing the levels of a generalization hierarchy into a REPLACE tile tree (DESIGN.md §5). A tile of level k
//! holds a spatially compact set of level-k nodes; its children partition the children of those nodes among
//! tiles of level k − 1, each within the budget; the leaves hold level 0, the buildings. Geometric errors are the
//! max over a tile's nodes, raised so that no tile is below any of its descendants.
//! Invariant (`check_packing`): at every level each node is in exactly one tile, and the nodes of a tile's
//! children are exactly the children of its nodes.

use crate::spec::TileSpec;
use citylod_model::{Footprint, Hierarchy, NodeId};

/// Most features and triangles one tile may hold. A single node larger than the budget gets a tile of its own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TileBudget {
    pub max_features: usize,
    pub max_triangles: usize,
}

/// A group of level-k nodes (k ≥ 1) is also split, though within the budget, when its error (the max over its
/// nodes) exceeds its median node error by this factor: a few rough nodes would otherwise make the client
/// refine the whole group. Recursive cuts then isolate the rough nodes in small tiles.
pub const ERROR_SPLIT_RATIO: f64 = 2.0;

/// … or when the group spans more than this many times its error (m per m): a client refines a tile once its
/// nearest corner is within about 50× its error (16 px on a 1000 px high 60° view), so a tile much wider than
/// that is refined for a far corner's sake while the rest of it is still far away.
pub const EXTENT_SPLIT_FACTOR: f64 = 25.0;

/// Error and extent splits stop at groups of fewer triangles than this: below it a request costs more than
/// the bytes it saves (measured in CesiumJS, docs/tile-budget.md: at 2,000 instead of 1,000 Boston's LOD
/// tileset needs 191 instead of 266 requests and 13.5 instead of 13.9 MB over its far, mid and street views,
/// better in every view; at 4,000 requests fall further but NYC's far view gets 7 % heavier).
pub const MIN_SPLIT_TRIANGLES: usize = 2_000;

/// A node of a tile is drawn as its descendants on the next level written instead (their content, their errors)
/// when its own error is over this many times the median of the tile's nodes and theirs is lower, so that a few
/// rough blocks in a tile too small to split (see [`MIN_SPLIT_TRIANGLES`]) do not set the error of all the others …
///
/// Measured (800×600, `citylod check`'s 8 views; 2026-11-22): on NYC's Lower East Side one block of a 10 m and a
/// 57 m building set a level-1 tile's error to 47 m while its blocks' median is 10 m, so the district's far view
/// refined to the leaves. Ratio 3 with [`DEMOTE_MAX_ADDED_SHARE`] 0.1: NYC's far view of the browser tests selects
/// 198 instead of 414 kB, the 8 views load 3 % less on NYC and Delft and 2 % more on Boston, tilesets are 2–8 %
/// larger (lower tile errors leave less room for re-outlining). Ratio 2 or a share of 0.25 load 5–12 % less on
/// NYC and Delft but 7–10 % more on Boston.
pub const DEMOTE_ERROR_RATIO: f64 = 3.0;

/// … while the triangles this adds stay within this share of the tile's (roughest nodes first).
pub const DEMOTE_MAX_ADDED_SHARE: f64 = 0.1;

/// One tile of the packing: the level its nodes belong to, the nodes, child tiles (indices into `tiles`), and
/// what it draws: `(level, node)` pairs, each node as itself (`level` = the tile's) or, for a node demoted
/// because its error would lift the tile's (see [`DEMOTE_ERROR_RATIO`]), its descendants on the level of the
/// children.
#[derive(Debug, Clone, PartialEq)]
pub struct PackedTile {
    pub level: usize,
    pub nodes: Vec<NodeId>,
    pub children: Vec<usize>,
    pub drawn: Vec<(usize, NodeId)>,
}

impl PackedTile {
    fn new(level: usize, nodes: Vec<NodeId>) -> Self {
        let drawn = nodes.iter().map(|&n| (level, n)).collect();
        PackedTile {
            level,
            nodes,
            children: vec![],
            drawn,
        }
    }
}

/// The tile tree; `tiles[0]` is the root. The root holds the top level's nodes, or — when they do not fit in one
/// tile — no nodes (`level` = top + 1) and one child per group of top-level nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Packing {
    pub tiles: Vec<PackedTile>,
}

impl Packing {
    /// The subtree under tile `root` as a packing of its own (`root` becomes `tiles[0]`), tiles in the same
    /// breadth-first order.
    pub fn rerooted(&self, root: usize) -> Packing {
        let mut order = vec![root];
        let mut next = 0;
        while next < order.len() {
            order.extend(self.tiles[order[next]].children.iter().copied());
            next += 1;
        }
        let mut new_index = vec![usize::MAX; self.tiles.len()];
        for (i, &t) in order.iter().enumerate() {
            new_index[t] = i;
        }
        let tiles = order
            .iter()
            .map(|&t| PackedTile {
                children: self.tiles[t]
                    .children
                    .iter()
                    .map(|&c| new_index[c])
                    .collect(),
                ..self.tiles[t].clone()
            })
            .collect();
        Packing { tiles }
    }
}

/// What [`pack`] needs to know about a node of a level: its triangles and its geometric error (m).
pub struct NodeCost<'a> {
    pub triangles: &'a dyn Fn(usize, NodeId) -> usize,
    pub error_m: &'a dyn Fn(usize, NodeId) -> f64,
}

/// Packs the levels `levels` of `h` (ascending level indices; 0 is added when missing) into tiles; the root holds
/// the last of them (the top level when `levels` is empty), so levels above it are not written. A tile of level
/// `levels[i]` has children of level `levels[i − 1]` holding its nodes' descendants there, so skipped levels cost
/// nothing. Groups are split spatially to stay
/// within `budget` and, on levels above 0, where that localizes the error (see [`ERROR_SPLIT_RATIO`],
/// [`EXTENT_SPLIT_FACTOR`]).
pub fn pack(h: &Hierarchy, levels: &[usize], cost: &NodeCost, budget: TileBudget) -> Packing {
    let mut tiles = Vec::new();
    let Some(top) = h.levels.len().checked_sub(1) else {
        return Packing { tiles };
    };
    let mut kept: Vec<usize> = levels.iter().copied().filter(|&l| l <= top).collect();
    kept.push(0);
    kept.sort_unstable();
    kept.dedup();
    let top = *kept.last().unwrap();
    // below[l] = the kept level under kept level l.
    let mut below = vec![None; top + 1];
    for w in kept.windows(2) {
        below[w[1]] = Some(w[0]);
    }
    let top_nodes: Vec<NodeId> = (0..h.levels[top].nodes.len() as u32).map(NodeId).collect();
    let groups = split(h, top, top_nodes, cost, budget);
    if groups.len() == 1 {
        tiles.push(PackedTile::new(top, groups.into_iter().next().unwrap()));
    } else {
        tiles.push(PackedTile {
            children: (1..=groups.len()).collect(),
            ..PackedTile::new(top + 1, vec![])
        });
        tiles.extend(groups.into_iter().map(|nodes| PackedTile::new(top, nodes)));
    }
    // Breadth-first, so tile indices (and so file names) follow a stable order.
    let mut next = if tiles[0].nodes.is_empty() { 1 } else { 0 };
    while next < tiles.len() {
        let (level, parent_nodes) = (tiles[next].level, tiles[next].nodes.clone());
        if let Some(to) = below.get(level).copied().flatten() {
            let child_nodes: Vec<NodeId> = parent_nodes
                .iter()
                .flat_map(|&n| descendants(h, level, n, to))
                .collect();
            let first = tiles.len();
            for nodes in split(h, to, child_nodes, cost, budget) {
                tiles.push(PackedTile::new(to, nodes));
            }
            tiles[next].children = (first..tiles.len()).collect();
            tiles[next].drawn = demote(h, level, &tiles[next].nodes, to, cost);
        }
        next += 1;
    }
    Packing { tiles }
}

/// What a tile of `level` holding `nodes` draws when its children are on level `to`: every node as itself, except
/// the roughest — error over [`DEMOTE_ERROR_RATIO`] × the tile's median, and over the error of its descendants on
/// `to` — which are drawn as those descendants while the triangles added stay within [`DEMOTE_MAX_ADDED_SHARE`]
/// of the tile's. It stops at the first rough node it cannot demote: that node sets the tile's error anyway.
fn demote(
    h: &Hierarchy,
    level: usize,
    nodes: &[NodeId],
    to: usize,
    cost: &NodeCost,
) -> Vec<(usize, NodeId)> {
    if level == 0 || nodes.len() < 2 {
        return nodes.iter().map(|&n| (level, n)).collect();
    }
    let mut errors: Vec<(f64, NodeId)> = nodes
        .iter()
        .map(|&n| ((cost.error_m)(level, n), n))
        .collect();
    let mut sorted: Vec<f64> = errors.iter().map(|e| e.0).collect();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let total: usize = nodes.iter().map(|&n| (cost.triangles)(level, n)).sum();
    let mut room = DEMOTE_MAX_ADDED_SHARE * total as f64;
    // Roughest first; ties by node id, so the choice is deterministic.
    errors.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut demoted: std::collections::BTreeMap<NodeId, Vec<NodeId>> = Default::default();
    for (e, n) in errors {
        if e.is_nan() || e <= DEMOTE_ERROR_RATIO * median {
            break;
        }
        let below = descendants(h, level, n, to);
        let below_error = below
            .iter()
            .map(|&d| (cost.error_m)(to, d))
            .fold(0.0, f64::max);
        let added = below
            .iter()
            .map(|&d| (cost.triangles)(to, d))
            .sum::<usize>() as f64
            - (cost.triangles)(level, n) as f64;
        // A node left as it is keeps the tile's error at `e`, so demoting any smoother one would add triangles
        // and lower nothing.
        if below_error >= e || added > room {
            break;
        }
        room -= added.max(0.0);
        demoted.insert(n, below);
    }
    nodes
        .iter()
        .flat_map(|&n| match demoted.get(&n) {
            Some(below) => below.iter().map(|&d| (to, d)).collect(),
            None => vec![(level, n)],
        })
        .collect()
}

/// The nodes of level `to` (< `level`) under node `n` of `level`, in child order.
fn descendants(h: &Hierarchy, level: usize, n: NodeId, to: usize) -> Vec<NodeId> {
    let mut cur = vec![n];
    for l in (to + 1..=level).rev() {
        cur = cur
            .iter()
            .flat_map(|m| h.levels[l].nodes[m.0 as usize].children.iter().copied())
            .collect();
    }
    cur
}

struct Item {
    node: NodeId,
    centre: [f64; 2],
    /// The node's bounding box: min x, min y, max x, max y.
    bbox: [f64; 4],
    triangles: usize,
    error_m: f64,
}

/// Splits `nodes` of `level` into spatially compact groups: recursive median cuts across the longer side of
/// the nodes' centre extent, ties broken by node id so the result is deterministic.
fn split(
    h: &Hierarchy,
    level: usize,
    nodes: Vec<NodeId>,
    cost: &NodeCost,
    budget: TileBudget,
) -> Vec<Vec<NodeId>> {
    let mut items: Vec<Item> = nodes
        .into_iter()
        .map(|n| {
            let bbox = bbox_of(&h.levels[level].nodes[n.0 as usize].footprint);
            Item {
                node: n,
                centre: [(bbox[0] + bbox[2]) / 2.0, (bbox[1] + bbox[3]) / 2.0],
                bbox,
                triangles: (cost.triangles)(level, n),
                error_m: if level == 0 {
                    0.0
                } else {
                    (cost.error_m)(level, n)
                },
            }
        })
        .collect();
    items.sort_by_key(|i| i.node);
    let mut out = Vec::new();
    split_rec(&mut items, budget, &mut out);
    out
}

fn split_rec(items: &mut [Item], budget: TileBudget, out: &mut Vec<Vec<NodeId>>) {
    let tris: usize = items.iter().map(|i| i.triangles).sum();
    let over_budget = items.len() > budget.max_features || tris > budget.max_triangles;
    if items.len() <= 1 || (!over_budget && tris < 2 * MIN_SPLIT_TRIANGLES) {
        emit(items, out);
        return;
    }
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for i in items.iter() {
        for a in 0..2 {
            lo[a] = lo[a].min(i.centre[a]);
            hi[a] = hi[a].max(i.centre[a]);
        }
    }
    let axis = usize::from(hi[1] - lo[1] > hi[0] - lo[0]);
    items.sort_by(|a, b| {
        a.centre[axis]
            .total_cmp(&b.centre[axis])
            .then(a.node.cmp(&b.node))
    });
    // Cut where half the triangles lie, so both halves weigh about the same.
    let mut acc = 0;
    let mut cut = items.len() / 2;
    for (k, i) in items.iter().enumerate() {
        acc += i.triangles;
        if acc * 2 >= tris {
            cut = (k + 1).clamp(1, items.len() - 1);
            break;
        }
    }
    if !over_budget && !worth_splitting(items, cut) {
        emit(items, out);
        return;
    }
    let (a, b) = items.split_at_mut(cut);
    split_rec(a, budget, out);
    split_rec(b, budget, out);
}

/// Whether a group within the budget still gains from the cut at `cut`: both halves keep at least
/// [`MIN_SPLIT_TRIANGLES`], and the group's error is over [`ERROR_SPLIT_RATIO`] × its median or it is wider than
/// [`EXTENT_SPLIT_FACTOR`] × its error.
fn worth_splitting(items: &[Item], cut: usize) -> bool {
    let (a, b) = items.split_at(cut);
    let tris = |s: &[Item]| s.iter().map(|i| i.triangles).sum::<usize>();
    if tris(a) < MIN_SPLIT_TRIANGLES || tris(b) < MIN_SPLIT_TRIANGLES {
        return false;
    }
    let mut errors: Vec<f64> = items.iter().map(|i| i.error_m).collect();
    errors.sort_by(f64::total_cmp);
    let e = errors.last().copied().unwrap_or(0.0);
    if e <= 0.0 {
        return false;
    }
    if e > ERROR_SPLIT_RATIO * errors[errors.len() / 2] {
        return true;
    }
    let mut bb = [f64::MAX, f64::MAX, f64::MIN, f64::MIN];
    for i in items {
        bb = [
            bb[0].min(i.bbox[0]),
            bb[1].min(i.bbox[1]),
            bb[2].max(i.bbox[2]),
            bb[3].max(i.bbox[3]),
        ];
    }
    (bb[2] - bb[0]).hypot(bb[3] - bb[1]) > EXTENT_SPLIT_FACTOR * e
}

fn emit(items: &[Item], out: &mut Vec<Vec<NodeId>>) {
    if !items.is_empty() {
        let mut g: Vec<NodeId> = items.iter().map(|i| i.node).collect();
        g.sort();
        out.push(g);
    }
}

fn bbox_of(fp: &Footprint) -> [f64; 4] {
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for c in fp.0.iter().flat_map(|p| p.exterior().0.iter()) {
        lo = [lo[0].min(c.x), lo[1].min(c.y)];
        hi = [hi[0].max(c.x), hi[1].max(c.y)];
    }
    if lo[0] > hi[0] {
        return [0.0; 4];
    }
    [lo[0], lo[1], hi[0], hi[1]]
}

/// Least geometric error (m) of a tile with children. A tile whose blocks are all exact — single buildings, rough
/// blocks drawn as their buildings, touching buildings of one height — would otherwise claim 0 and no client would
/// ever load the buildings' own tiles below it, with their attributes: at 1 m a client refining at 16 px reaches
/// them within about 40 m at 800×600 (60 m on a 1080p screen).
pub const MIN_PARENT_ERROR_M: f64 = 1.0;

/// Each tile's geometric error (m): the max of `node_error(level, node)` over what it draws, at least
/// [`MIN_PARENT_ERROR_M`] when it has children, then raised to the max of its children's so errors never grow
/// downward. Tiles of level 0 hold the buildings' footprint prisms: exact (0) for footprint input, the prism's
/// measured error when the buildings have 3D models below them.
pub fn tile_errors(p: &Packing, node_error: &dyn Fn(usize, NodeId) -> f64) -> Vec<f64> {
    let mut err: Vec<f64> = p
        .tiles
        .iter()
        .map(|t| {
            let own = t
                .drawn
                .iter()
                .map(|&(level, n)| node_error(level, n))
                .fold(0.0, f64::max);
            if t.children.is_empty() {
                own
            } else {
                own.max(MIN_PARENT_ERROR_M)
            }
        })
        .collect();
    // Children always have larger indices than their parent (breadth-first), so one backward pass suffices.
    for i in (0..p.tiles.len()).rev() {
        let m = p.tiles[i]
            .children
            .iter()
            .map(|&c| err[c])
            .fold(err[i], f64::max);
        err[i] = m;
    }
    err
}

/// What [`assemble`] puts into tiles: `tile(i)` is what packing tile `i` holds — the features of the nodes it
/// draws (`Packing::tiles[i].drawn`: its own nodes, or a rough one's descendants drawn in its stead; a node may give
/// several features, its block and its landmarks), or a description of them the writer turns into features later
/// ([`crate::write_tileset_with`]) — and `below_buildings(nodes)` the tiles to hang under a tile of level-0 nodes
/// (the finer versions of those buildings, e.g. their 3D models; none for footprint input).
pub struct TileContent<'a, C> {
    pub tile: &'a (dyn Fn(usize) -> C + Sync),
    pub below_buildings: &'a (dyn Fn(&[NodeId]) -> Vec<TileSpec<C>> + Sync),
}

/// The writer's tile tree for a packing: each tile gets `content.tile` of its packing index and the geometric error
/// `errors[tile]`; level-0 tiles get `below_buildings` as children.
///
/// A tile of blocks that is its parent's only child, claims the parent's error and has children of its own is
/// written without content: a client refines it exactly when it refines the parent (the writer gives a tile without
/// content its parent's box, so the two screen-space errors are equal), so it would never be drawn — it is the
/// rougher of the two (the parent's error was raised to it) and only cost bytes and a request. On Delft such a tile
/// held 19 kB of 1.08 MB. Tiles of buildings are kept: with `--lod` the prism tile is a step of every building's
/// chain (prism, simplified, full model), even where one tower's prism error lifts it to its parent's.
pub fn assemble<C: Default>(p: &Packing, errors: &[f64], content: &TileContent<C>) -> TileSpec<C> {
    fn rec<C: Default>(
        p: &Packing,
        i: usize,
        errors: &[f64],
        content: &TileContent<C>,
    ) -> TileSpec<C> {
        let t = &p.tiles[i];
        let mut children: Vec<TileSpec<C>> = t
            .children
            .iter()
            .map(|&c| rec(p, c, errors, content))
            .collect();
        // Blocks only: the buildings' own tiles (their prisms over their 3D models) keep every step of the chain.
        if let ([c], [only]) = (&t.children[..], children.as_mut_slice()) {
            if p.tiles[*c].level > 0
                && only.geometric_error_m == errors[i]
                && !only.children.is_empty()
            {
                only.features = C::default();
            }
        }
        if t.level == 0 {
            children.extend((content.below_buildings)(&t.nodes));
        }
        TileSpec {
            features: (content.tile)(i),
            children,
            geometric_error_m: errors[i],
        }
    }
    if p.tiles.is_empty() {
        return TileSpec::default();
    }
    rec(p, 0, errors, content)
}

/// Checks the packing invariants against `h`; returns every violation found: on every level that has tiles each
/// node is in exactly one tile, level 0 has tiles, and the nodes of a tile's children are exactly its nodes'
/// descendants on the children's (single, lower) level.
pub fn check_packing(h: &Hierarchy, p: &Packing) -> Vec<String> {
    let mut errs = Vec::new();
    let mut seen: Vec<Vec<u32>> = h.levels.iter().map(|l| vec![0; l.nodes.len()]).collect();
    let mut level_used = vec![false; h.levels.len()];
    for (ti, t) in p.tiles.iter().enumerate() {
        if let Some(u) = level_used.get_mut(t.level) {
            *u = true;
        }
        for n in &t.nodes {
            match seen.get_mut(t.level).and_then(|s| s.get_mut(n.0 as usize)) {
                Some(c) => *c += 1,
                None => errs.push(format!(
                    "tile {ti}: node {} of level {} does not exist",
                    n.0, t.level
                )),
            }
        }
        if t.level == 0 {
            if !t.children.is_empty() {
                errs.push(format!("tile {ti}: a building tile has children"));
            }
            continue;
        }
        if t.nodes.is_empty() || t.level >= h.levels.len() {
            continue;
        }
        let child_levels: std::collections::BTreeSet<usize> =
            t.children.iter().map(|&c| p.tiles[c].level).collect();
        let [to] = child_levels.into_iter().collect::<Vec<_>>()[..] else {
            errs.push(format!(
                "tile {ti}: children are missing or on more than one level"
            ));
            continue;
        };
        if to >= t.level {
            errs.push(format!("tile {ti}: a child tile is not on a lower level"));
            continue;
        }
        let mut want: Vec<NodeId> = t
            .nodes
            .iter()
            .flat_map(|&n| descendants(h, t.level, n, to))
            .collect();
        let mut got: Vec<NodeId> = t
            .children
            .iter()
            .flat_map(|&c| p.tiles[c].nodes.iter().copied())
            .collect();
        want.sort();
        got.sort();
        if want != got {
            errs.push(format!(
                "tile {ti}: children tiles do not hold exactly the descendants of its nodes"
            ));
        }
    }
    if !level_used.first().copied().unwrap_or(true) {
        errs.push("level 0 (the buildings) has no tiles".into());
    }
    for (l, s) in seen.iter().enumerate() {
        if !level_used[l] {
            continue;
        }
        if let Some(n) = s.iter().position(|&c| c != 1) {
            errs.push(format!("level {l}: node {n} is in {} tiles", s[n]));
        }
    }
    errs
}

#[cfg(test)]
mod tests {
    use super::*;
    use citylod_model::{BuildingId, Level, Node};
    use geo_types::{polygon, MultiPolygon};

    fn node(x: f64, children: Vec<u32>, members: Vec<u32>, dh: f64) -> Node {
        Node {
            children: children.into_iter().map(NodeId).collect(),
            members: members.into_iter().map(BuildingId).collect(),
            footprint: MultiPolygon(vec![
                polygon![(x: x, y: 0.0), (x: x + 5.0, y: 0.0), (x: x + 5.0, y: 5.0), (x: x, y: 5.0)],
            ]),
            height_m: 10.0,
            base_z_m: 0.0,
            h_min_m: 10.0,
            h_max_m: 10.0 + dh,
            dh_m: dh,
            da_m2: 0.0,
            area_m2: 25.0,
            landmarks: vec![],
        }
    }

    /// `n` buildings in a row, 10 m apart, and the level of their pairs.
    fn row_of_pairs(n: u32) -> [Vec<Node>; 2] {
        let buildings = (0..n)
            .map(|i| node(10.0 * i as f64, vec![], vec![i], 0.0))
            .collect();
        let pairs = (0..n / 2)
            .map(|i| {
                node(
                    20.0 * i as f64,
                    vec![2 * i, 2 * i + 1],
                    vec![2 * i, 2 * i + 1],
                    1.0,
                )
            })
            .collect();
        [buildings, pairs]
    }

    fn hierarchy_of(levels: Vec<Vec<Node>>) -> Hierarchy {
        Hierarchy {
            levels: levels
                .into_iter()
                .map(|nodes| Level {
                    threshold_m: 0.0,
                    nodes,
                })
                .collect(),
        }
    }

    /// 8 buildings in a row → 4 pairs → 2 blocks → 1 top node.
    fn row_hierarchy() -> Hierarchy {
        let [l0, l1] = row_of_pairs(8);
        let l2 = (0..2)
            .map(|i| {
                node(
                    40.0 * i as f64,
                    vec![2 * i, 2 * i + 1],
                    (4 * i..4 * i + 4).collect(),
                    2.0,
                )
            })
            .collect();
        let l3 = vec![node(0.0, vec![0, 1], (0..8).collect(), 3.0)];
        hierarchy_of(vec![l0, l1, l2, l3])
    }

    /// A budget no test tile comes near: tiles are cut only to localize errors.
    const ROOMY: TileBudget = TileBudget {
        max_features: 100,
        max_triangles: 1_000_000,
    };

    fn all_levels(h: &Hierarchy) -> Vec<usize> {
        (0..h.levels.len()).collect()
    }

    fn tris(n: usize) -> impl Fn(usize, NodeId) -> usize {
        move |_, _| n
    }

    fn by_level(level: usize, _: NodeId) -> f64 {
        level as f64
    }

    /// Every level of `h` packed with `triangles` per node, errors by level, and the given budget.
    fn pack_all(
        h: &Hierarchy,
        triangles: usize,
        max_features: usize,
        max_triangles: usize,
    ) -> Packing {
        let cost = NodeCost {
            triangles: &tris(triangles),
            error_m: &by_level,
        };
        let budget = TileBudget {
            max_features,
            max_triangles,
        };
        pack(h, &all_levels(h), &cost, budget)
    }

    #[test]
    fn every_node_in_exactly_one_tile_and_children_partition() {
        let h = row_hierarchy();
        for max_features in [1, 2, 3, 100] {
            let p = pack_all(&h, 10, max_features, 1000);
            assert_eq!(
                check_packing(&h, &p),
                Vec::<String>::new(),
                "max_features {max_features}"
            );
            assert_eq!(p.tiles[0].level, 3);
        }
    }

    #[test]
    fn budget_splits_spatially_and_leaves_are_buildings() {
        let h = row_hierarchy();
        let p = pack_all(&h, 10, 2, 1000);
        let leaves: Vec<&PackedTile> = p.tiles.iter().filter(|t| t.children.is_empty()).collect();
        assert!(leaves.iter().all(|t| t.level == 0 && t.nodes.len() <= 2));
        // A triangle budget of one node per tile forces single-node tiles.
        let p = pack_all(&h, 10, 100, 10);
        assert!(p.tiles.iter().all(|t| t.nodes.len() <= 1));
        assert_eq!(check_packing(&h, &p), Vec::<String>::new());
    }

    #[test]
    fn parent_error_at_least_children() {
        let h = row_hierarchy();
        let p = pack_all(&h, 10, 2, 1000);
        // A deliberately non-monotone node error: level 1 claims more than level 2.
        let e = tile_errors(&p, &|level, _| if level == 1 { 9.0 } else { level as f64 });
        for (i, t) in p.tiles.iter().enumerate() {
            for &c in &t.children {
                assert!(
                    e[i] >= e[c],
                    "tile {i} error {} < child {c} error {}",
                    e[i],
                    e[c]
                );
            }
            if t.level == 0 {
                assert_eq!(e[i], 0.0);
            }
        }
        assert_eq!(e[0], 9.0);
    }

    #[test]
    fn packing_is_deterministic() {
        let h = row_hierarchy();
        assert_eq!(pack_all(&h, 7, 3, 1000), pack_all(&h, 7, 3, 1000));
    }

    #[test]
    fn skipped_levels_give_children_the_descendants() {
        let h = row_hierarchy();
        let c = NodeCost {
            triangles: &tris(10),
            error_m: &by_level,
        };
        let budget = TileBudget {
            max_features: 2,
            max_triangles: 1000,
        };
        let p = pack(&h, &[0, 2, 3], &c, budget);
        assert_eq!(check_packing(&h, &p), Vec::<String>::new());
        let levels: std::collections::BTreeSet<usize> = p.tiles.iter().map(|t| t.level).collect();
        assert_eq!(levels.into_iter().collect::<Vec<_>>(), vec![0, 2, 3]);
        // Levels above the last one listed are not written: the root holds level 2.
        let p = pack(&h, &[0, 2], &c, budget);
        assert_eq!(check_packing(&h, &p), Vec::<String>::new());
        assert!(p.tiles.iter().all(|t| t.level <= 2 || t.nodes.is_empty()));
        assert!(p.tiles.iter().any(|t| t.level == 2));
        // The subtree under the level-3 root's level-2 child is a packing of its own, breadth-first: the same
        // as packing up to level 2 only.
        let p3 = pack(&h, &[0, 2, 3], &c, budget);
        let sub = p3.tiles[0].children[0];
        assert_eq!(p3.tiles[sub].level, 2);
        let r = p3.rerooted(sub);
        assert_eq!(r, p);
        // Every building lands in exactly one leaf tile.
        let mut leaves: Vec<NodeId> = p
            .tiles
            .iter()
            .filter(|t| t.level == 0)
            .flat_map(|t| t.nodes.clone())
            .collect();
        leaves.sort();
        assert_eq!(leaves, (0..8).map(NodeId).collect::<Vec<_>>());
    }

    #[test]
    fn check_packing_catches_a_lost_child() {
        let h = row_hierarchy();
        let mut p = pack_all(&h, 10, 2, 1000);
        let leaf = p.tiles.iter().position(|t| t.level == 0).unwrap();
        p.tiles[leaf].nodes.pop();
        assert!(!check_packing(&h, &p).is_empty());
    }

    /// Level 1 of the row: node 0 is rough (50 m), nodes 1–3 calm (5 m); the four fit one tile that is too small
    /// to split, so node 0 is drawn as its two buildings (exact) when they add few enough triangles.
    fn pack_with_rough_node(building_triangles: usize) -> (Hierarchy, Packing, Vec<f64>) {
        let h = row_hierarchy();
        let err = |level: usize, n: NodeId| match (level, n.0) {
            (0, _) => 0.0,
            (1, 0) => 50.0,
            (1, _) => 5.0,
            _ => 100.0,
        };
        let triangles =
            move |level: usize, _: NodeId| if level == 0 { building_triangles } else { 100 };
        let c = NodeCost {
            triangles: &triangles,
            error_m: &err,
        };
        let p = pack(&h, &[0, 1], &c, ROOMY);
        let e = tile_errors(&p, &err);
        (h, p, e)
    }

    #[test]
    fn a_rough_node_in_a_small_tile_is_drawn_as_its_buildings() {
        let (h, p, e) = pack_with_rough_node(12);
        assert_eq!(check_packing(&h, &p), Vec::<String>::new());
        let l1: Vec<usize> = (0..p.tiles.len())
            .filter(|&t| p.tiles[t].level == 1)
            .collect();
        assert_eq!(l1.len(), 1, "{p:?}");
        let t = &p.tiles[l1[0]];
        assert_eq!(t.nodes.len(), 4);
        let want: Vec<(usize, NodeId)> = vec![
            (0, NodeId(0)),
            (0, NodeId(1)),
            (1, NodeId(1)),
            (1, NodeId(2)),
            (1, NodeId(3)),
        ];
        assert_eq!(t.drawn, want);
        assert_eq!(e[l1[0]], 5.0, "the tile's error is the calm blocks'");
        // What the tile holds: the two buildings, as level-0 nodes drawn in a level-1 tile.
        let spec = assemble(
            &p,
            &e,
            &TileContent {
                tile: &|i| i,
                below_buildings: &|_| Vec::new(),
            },
        );
        fn drawn(p: &Packing, t: &TileSpec<usize>, seen: &mut Vec<(usize, usize, u32)>) {
            let tile = &p.tiles[t.features];
            seen.extend(tile.drawn.iter().map(|&(l, n)| (tile.level, l, n.0)));
            t.children.iter().for_each(|c| drawn(p, c, seen));
        }
        let mut seen = Vec::new();
        drawn(&p, &spec, &mut seen);
        assert_eq!(spec.count_tiles(), p.tiles.len());
        assert!(
            seen.contains(&(1, 0, 0)) && seen.contains(&(1, 0, 1)),
            "{seen:?}"
        );
        assert!(
            !seen.contains(&(1, 1, 0)),
            "the rough block itself is not drawn"
        );
        assert_eq!(
            seen.iter().filter(|s| s.1 == 0).count(),
            10,
            "8 leaves + 2 demoted"
        );
    }

    #[test]
    fn an_only_child_claiming_its_parents_error_is_written_without_content() {
        // A chain level 3 → 2 → 1 → 0, and beside it a level-2 tile with two children.
        let tile = |level: usize, children: Vec<usize>| PackedTile {
            children,
            ..PackedTile::new(level, vec![NodeId(0)])
        };
        let p = Packing {
            tiles: vec![
                tile(3, vec![1, 2]),
                tile(2, vec![3]),
                tile(2, vec![4, 5]),
                tile(1, vec![6]),
                tile(0, vec![]),
                tile(0, vec![]),
                tile(0, vec![]),
            ],
        };
        let no_models = TileContent {
            tile: &|i| Some(i),
            below_buildings: &|_| Vec::new(),
        };
        let model = || TileSpec {
            features: Some(100),
            children: vec![],
            geometric_error_m: 0.0,
        };
        let models = TileContent {
            tile: &|i| Some(i),
            below_buildings: &|_| vec![model()],
        };
        let held_with = |content: &TileContent<Option<usize>>, errors: &[f64]| {
            let spec = assemble(&p, errors, content);
            let mut held = Vec::new();
            fn walk(t: &TileSpec<Option<usize>>, held: &mut Vec<Option<usize>>) {
                held.push(t.features);
                t.children.iter().for_each(|c| walk(c, held));
            }
            walk(&spec, &mut held);
            held
        };
        let held = |errors: &[f64]| held_with(&no_models, errors);
        // Tile 3 (only child of 2, its error, children of its own) is never drawn; a leaf (6) or a child with a
        // sibling (4, 5) is, whatever its error.
        assert_eq!(
            held(&[9.0, 5.0, 4.0, 5.0, 4.0, 4.0, 0.0]),
            [Some(0), Some(1), None, Some(6), Some(2), Some(4), Some(5)]
        );
        // Below its parent's error it is drawn at some distance: kept.
        assert_eq!(
            held(&[9.0, 5.0, 4.0, 4.9, 4.0, 4.0, 0.0]),
            [
                Some(0),
                Some(1),
                Some(3),
                Some(6),
                Some(2),
                Some(4),
                Some(5)
            ]
        );
        // Buildings' tiles with their models below keep their prisms, even at their parent's error.
        assert_eq!(
            held_with(&models, &[9.0, 5.0, 4.0, 4.5, 4.0, 4.0, 4.5]),
            [
                Some(0),
                Some(1),
                Some(3),
                Some(6),
                Some(100),
                Some(2),
                Some(4),
                Some(100),
                Some(5),
                Some(100)
            ]
        );
    }

    #[test]
    fn a_tile_of_exact_blocks_above_the_buildings_claims_the_least_parent_error() {
        // Every level-1 node exact (error 0): the level-1 tile still claims MIN_PARENT_ERROR_M, so clients come down
        // to the buildings; the leaves stay 0.
        let h = row_hierarchy();
        let exact = |_: usize, _: NodeId| 0.0;
        let c = NodeCost {
            triangles: &tris(10),
            error_m: &exact,
        };
        let p = pack(&h, &[0, 1], &c, ROOMY);
        let e = tile_errors(&p, &exact);
        for (t, e) in p.tiles.iter().zip(&e) {
            let want = if t.children.is_empty() {
                0.0
            } else {
                MIN_PARENT_ERROR_M
            };
            assert_eq!(*e, want, "{t:?}");
        }
        assert!(p.tiles.iter().any(|t| t.level == 1));
    }

    #[test]
    fn a_rough_node_stays_when_its_buildings_would_cost_too_much() {
        // Two buildings of 1,000 triangles each would add 1,900 to a tile of 400: over DEMOTE_MAX_ADDED_SHARE.
        let (_, p, e) = pack_with_rough_node(1_000);
        let t = p.tiles.iter().position(|t| t.level == 1).unwrap();
        assert_eq!(p.tiles[t].drawn.len(), 4);
        assert!(p.tiles[t].drawn.iter().all(|&(level, _)| level == 1));
        assert_eq!(e[t], 50.0);
    }

    #[test]
    fn no_smoother_node_is_demoted_once_a_rougher_one_stays() {
        // 16 buildings in pairs under 8 level-1 nodes under one top node. Node 0 (60 m) is too dear to draw as its
        // buildings; node 1 (50 m) would be cheap, but drawing it as its buildings could not lower the tile's
        // error below node 0's 60 m: nothing is demoted. Without node 0's cost, both are.
        let [l0, l1] = row_of_pairs(16);
        let l2 = vec![node(0.0, (0..8).collect(), (0..16).collect(), 2.0)];
        let h = hierarchy_of(vec![l0, l1, l2]);
        let err = |level: usize, n: NodeId| match (level, n.0) {
            (0, _) => 0.0,
            (1, 0) => 60.0,
            (1, 1) => 50.0,
            (1, _) => 5.0,
            _ => 100.0,
        };
        for (dear, want_demoted, want_error) in [(1_000, 0, 60.0), (12, 2, 5.0)] {
            let triangles = move |level: usize, n: NodeId| match (level, n.0) {
                (0, 0 | 1) => dear,
                (0, _) => 12,
                _ => 100,
            };
            let c = NodeCost {
                triangles: &triangles,
                error_m: &err,
            };
            let p = pack(&h, &[0, 1], &c, ROOMY);
            assert_eq!(check_packing(&h, &p), Vec::<String>::new());
            let t = p.tiles.iter().position(|t| t.level == 1).unwrap();
            let demoted =
                p.tiles[t].nodes.len() - p.tiles[t].drawn.iter().filter(|d| d.0 == 1).count();
            assert_eq!(demoted, want_demoted, "{:?}", p.tiles[t].drawn);
            assert_eq!(tile_errors(&p, &err)[t], want_error);
        }
    }

    #[test]
    fn a_rough_node_gets_its_own_tile_within_the_budget() {
        // Level 1: node 0 (x 0..20) is rough (error 50 m), nodes 1–3 calm (5 m); each has 2,500
        // triangles, so all four fit the budget, but the max is 10× the median: worth splitting.
        let h = row_hierarchy();
        let err = |level: usize, n: NodeId| {
            if level == 1 {
                if n.0 == 0 {
                    50.0
                } else {
                    5.0
                }
            } else {
                level as f64
            }
        };
        let c = NodeCost {
            triangles: &tris(2_500),
            error_m: &err,
        };
        let p = pack(&h, &[0, 1, 3], &c, ROOMY);
        assert_eq!(check_packing(&h, &p), Vec::<String>::new());
        let l1: Vec<&PackedTile> = p.tiles.iter().filter(|t| t.level == 1).collect();
        assert_eq!(l1.len(), 2, "{p:?}");
        let e = tile_errors(&p, &err);
        let calm = p
            .tiles
            .iter()
            .position(|t| t.level == 1 && t.nodes == vec![NodeId(2), NodeId(3)])
            .unwrap();
        assert_eq!(e[calm], 5.0);
        // Equal errors and a small extent: no reason to split.
        let even = |_: usize, _: NodeId| 50.0;
        let c = NodeCost {
            triangles: &tris(2_500),
            error_m: &even,
        };
        let p = pack(&h, &[0, 1], &c, ROOMY);
        assert_eq!(p.tiles.iter().filter(|t| t.level == 1).count(), 1);
        // … unless the group is wider than EXTENT_SPLIT_FACTOR × its error (65 m wide, error 1 m).
        let tiny = |_: usize, _: NodeId| 1.0;
        let c = NodeCost {
            triangles: &tris(2_500),
            error_m: &tiny,
        };
        let p = pack(&h, &[0, 1], &c, ROOMY);
        assert!(p.tiles.iter().filter(|t| t.level == 1).count() >= 2);
        // Small groups are never split for error or extent: fewer than MIN_SPLIT_TRIANGLES a side.
        let c = NodeCost {
            triangles: &tris(10),
            error_m: &err,
        };
        let p = pack(&h, &[0, 1], &c, ROOMY);
        assert_eq!(p.tiles.iter().filter(|t| t.level == 1).count(), 1);
    }
}
