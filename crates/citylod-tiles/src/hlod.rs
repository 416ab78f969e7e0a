//! Packing the levels of a generalization hierarchy into a REPLACE tile tree (DESIGN.md §5). A tile of level k
//! holds a spatially compact set of level-k nodes; its children partition the children of those nodes among
//! tiles of level k − 1, each within the budget; the leaves hold level 0, the buildings. Geometric errors are the
//! max over a tile's nodes, raised so that no tile is below any of its descendants.
//! Invariant (`check_packing`): at every level each node is in exactly one tile, and the nodes of a tile's
//! children are exactly the children of its nodes.

use crate::spec::{ContentFeature, TileSpec};
use citylod_model::{Footprint, Hierarchy, NodeId};

/// Most features and triangles one tile may hold. A single node larger than the budget gets a tile of its own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TileBudget {
    pub max_features: usize,
    pub max_triangles: usize,
}

/// One tile of the packing: the level its nodes belong to, the nodes, and child tiles (indices into `tiles`).
#[derive(Debug, Clone, PartialEq)]
pub struct PackedTile {
    pub level: usize,
    pub nodes: Vec<NodeId>,
    pub children: Vec<usize>,
}

/// The tile tree; `tiles[0]` is the root. The root holds the top level's nodes, or — when they do not fit in one
/// tile — no nodes (`level` = top + 1) and one child per group of top-level nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Packing {
    pub tiles: Vec<PackedTile>,
}

/// Packs `h` into tiles. `triangles(level, node)` is the triangle count of that node's mesh.
pub fn pack(
    h: &Hierarchy,
    triangles: &dyn Fn(usize, NodeId) -> usize,
    budget: TileBudget,
) -> Packing {
    let mut tiles = Vec::new();
    let Some(top) = h.levels.len().checked_sub(1) else {
        return Packing { tiles };
    };
    let top_nodes: Vec<NodeId> = (0..h.levels[top].nodes.len() as u32).map(NodeId).collect();
    let groups = split(h, top, top_nodes, triangles, budget);
    if groups.len() == 1 {
        tiles.push(PackedTile {
            level: top,
            nodes: groups.into_iter().next().unwrap(),
            children: vec![],
        });
    } else {
        tiles.push(PackedTile {
            level: top + 1,
            nodes: vec![],
            children: (1..=groups.len()).collect(),
        });
        tiles.extend(groups.into_iter().map(|nodes| PackedTile {
            level: top,
            nodes,
            children: vec![],
        }));
    }
    // Breadth-first, so tile indices (and so file names) follow a stable order.
    let mut next = if tiles[0].nodes.is_empty() { 1 } else { 0 };
    while next < tiles.len() {
        let (level, parent_nodes) = (tiles[next].level, tiles[next].nodes.clone());
        if level > 0 {
            let child_nodes: Vec<NodeId> = parent_nodes
                .iter()
                .flat_map(|n| h.levels[level].nodes[n.0 as usize].children.iter().copied())
                .collect();
            let first = tiles.len();
            for nodes in split(h, level - 1, child_nodes, triangles, budget) {
                tiles.push(PackedTile {
                    level: level - 1,
                    nodes,
                    children: vec![],
                });
            }
            tiles[next].children = (first..tiles.len()).collect();
        }
        next += 1;
    }
    Packing { tiles }
}

/// Splits `nodes` of `level` into spatially compact groups within the budget: recursive median cuts across the
/// longer side of the nodes' centre extent, ties broken by node id so the result is deterministic.
fn split(
    h: &Hierarchy,
    level: usize,
    nodes: Vec<NodeId>,
    triangles: &dyn Fn(usize, NodeId) -> usize,
    budget: TileBudget,
) -> Vec<Vec<NodeId>> {
    let mut items: Vec<(NodeId, [f64; 2], usize)> = nodes
        .into_iter()
        .map(|n| {
            (
                n,
                bbox_centre(&h.levels[level].nodes[n.0 as usize].footprint),
                triangles(level, n),
            )
        })
        .collect();
    items.sort_by_key(|i| i.0);
    let mut out = Vec::new();
    split_rec(&mut items, budget, &mut out);
    out
}

fn split_rec(
    items: &mut [(NodeId, [f64; 2], usize)],
    budget: TileBudget,
    out: &mut Vec<Vec<NodeId>>,
) {
    let tris: usize = items.iter().map(|i| i.2).sum();
    if items.len() <= 1 || (items.len() <= budget.max_features && tris <= budget.max_triangles) {
        if !items.is_empty() {
            let mut g: Vec<NodeId> = items.iter().map(|i| i.0).collect();
            g.sort();
            out.push(g);
        }
        return;
    }
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for i in items.iter() {
        for a in 0..2 {
            lo[a] = lo[a].min(i.1[a]);
            hi[a] = hi[a].max(i.1[a]);
        }
    }
    let axis = usize::from(hi[1] - lo[1] > hi[0] - lo[0]);
    items.sort_by(|a, b| a.1[axis].total_cmp(&b.1[axis]).then(a.0.cmp(&b.0)));
    // Cut where half the triangles lie, so both halves weigh about the same.
    let mut acc = 0;
    let mut cut = items.len() / 2;
    for (k, i) in items.iter().enumerate() {
        acc += i.2;
        if acc * 2 >= tris {
            cut = (k + 1).clamp(1, items.len() - 1);
            break;
        }
    }
    let (a, b) = items.split_at_mut(cut);
    split_rec(a, budget, out);
    split_rec(b, budget, out);
}

fn bbox_centre(fp: &Footprint) -> [f64; 2] {
    let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
    for c in fp.0.iter().flat_map(|p| p.exterior().0.iter()) {
        lo = [lo[0].min(c.x), lo[1].min(c.y)];
        hi = [hi[0].max(c.x), hi[1].max(c.y)];
    }
    if lo[0] > hi[0] {
        return [0.0, 0.0];
    }
    [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0]
}

/// Each tile's geometric error (m): the max of `node_error(level, node)` over its nodes, then raised to the max of
/// its children's so errors never grow downward. Tiles of level 0 (the buildings) are exact: 0.
pub fn tile_errors(p: &Packing, node_error: &dyn Fn(usize, NodeId) -> f64) -> Vec<f64> {
    let mut err: Vec<f64> = p
        .tiles
        .iter()
        .map(|t| {
            if t.level == 0 {
                0.0
            } else {
                t.nodes
                    .iter()
                    .map(|&n| node_error(t.level, n))
                    .fold(0.0, f64::max)
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

/// The writer's tile tree for a packing: each tile gets the features `features(level, node)` of its nodes (a
/// node may give several: its block and its landmarks) and the geometric error `errors[tile]`.
pub fn assemble(
    p: &Packing,
    errors: &[f64],
    features: &(dyn Fn(usize, NodeId) -> Vec<ContentFeature> + Sync),
) -> TileSpec {
    fn rec(
        p: &Packing,
        i: usize,
        errors: &[f64],
        features: &(dyn Fn(usize, NodeId) -> Vec<ContentFeature> + Sync),
    ) -> TileSpec {
        let t = &p.tiles[i];
        TileSpec {
            features: t.nodes.iter().flat_map(|&n| features(t.level, n)).collect(),
            children: t
                .children
                .iter()
                .map(|&c| rec(p, c, errors, features))
                .collect(),
            geometric_error_m: errors[i],
        }
    }
    if p.tiles.is_empty() {
        return TileSpec::default();
    }
    rec(p, 0, errors, features)
}

/// Checks the packing invariants against `h`; returns every violation found.
pub fn check_packing(h: &Hierarchy, p: &Packing) -> Vec<String> {
    let mut errs = Vec::new();
    let mut seen: Vec<Vec<u32>> = h.levels.iter().map(|l| vec![0; l.nodes.len()]).collect();
    for (ti, t) in p.tiles.iter().enumerate() {
        for n in &t.nodes {
            match seen.get_mut(t.level).and_then(|s| s.get_mut(n.0 as usize)) {
                Some(c) => *c += 1,
                None => errs.push(format!(
                    "tile {ti}: node {} of level {} does not exist",
                    n.0, t.level
                )),
            }
        }
        if t.level > 0 && !t.nodes.is_empty() {
            let mut want: Vec<NodeId> = t
                .nodes
                .iter()
                .flat_map(|n| {
                    h.levels[t.level].nodes[n.0 as usize]
                        .children
                        .iter()
                        .copied()
                })
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
                    "tile {ti}: children tiles do not hold exactly the children of its nodes"
                ));
            }
        }
        if t.level == 0 && !t.children.is_empty() {
            errs.push(format!("tile {ti}: a building tile has children"));
        }
    }
    for (l, s) in seen.iter().enumerate() {
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

    /// 8 buildings in a row → 4 pairs → 2 blocks → 1 top node.
    fn row_hierarchy() -> Hierarchy {
        let l0 = (0..8)
            .map(|i| node(10.0 * i as f64, vec![], vec![i], 0.0))
            .collect();
        let l1 = (0..4)
            .map(|i| {
                node(
                    20.0 * i as f64,
                    vec![2 * i, 2 * i + 1],
                    vec![2 * i, 2 * i + 1],
                    1.0,
                )
            })
            .collect();
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
        Hierarchy {
            levels: [l0, l1, l2, l3]
                .into_iter()
                .map(|nodes| Level {
                    threshold_m: 0.0,
                    nodes,
                })
                .collect(),
        }
    }

    #[test]
    fn every_node_in_exactly_one_tile_and_children_partition() {
        let h = row_hierarchy();
        for max_features in [1, 2, 3, 100] {
            let p = pack(
                &h,
                &|_, _| 10,
                TileBudget {
                    max_features,
                    max_triangles: 1000,
                },
            );
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
        let p = pack(
            &h,
            &|_, _| 10,
            TileBudget {
                max_features: 2,
                max_triangles: 1000,
            },
        );
        let leaves: Vec<&PackedTile> = p.tiles.iter().filter(|t| t.children.is_empty()).collect();
        assert!(leaves.iter().all(|t| t.level == 0 && t.nodes.len() <= 2));
        // A triangle budget of one node per tile forces single-node tiles.
        let p = pack(
            &h,
            &|_, _| 10,
            TileBudget {
                max_features: 100,
                max_triangles: 10,
            },
        );
        assert!(p.tiles.iter().all(|t| t.nodes.len() <= 1));
        assert_eq!(check_packing(&h, &p), Vec::<String>::new());
    }

    #[test]
    fn parent_error_at_least_children() {
        let h = row_hierarchy();
        let p = pack(
            &h,
            &|_, _| 10,
            TileBudget {
                max_features: 2,
                max_triangles: 1000,
            },
        );
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
        let b = TileBudget {
            max_features: 3,
            max_triangles: 1000,
        };
        assert_eq!(pack(&h, &|_, _| 7, b), pack(&h, &|_, _| 7, b));
    }
}
