//! Cut coverage and tree consistency (DESIGN.md §6): the selected tiles plus the frustum-culled
//! subtrees must cover every building exactly once; a block tile's Σ member_count must equal what
//! its children hold; geometricError must never grow from a tile to a child; a building index must
//! sit in one leaf only. Identity: `building_index` of leaf features, or a block's `members` list.

use std::collections::BTreeMap;

use crate::finding::{Finding, FindingKind};
use crate::select::Selection;
use crate::tileset::{FeatureInfo, LoadedTileset, NodeRef};
use crate::vec3;

/// Relative slack when comparing geometric errors (float noise of the writer).
const ERROR_SLACK: f64 = 1e-9;

/// View-independent checks of the whole tree: errors monotone, buildings in one leaf only, member
/// counts consistent between a tile and its children, features identifiable, content inside its tile's and
/// its ancestors' boxes ([`crate::check_volumes`]).
pub fn check_tree(ts: &LoadedTileset) -> Vec<Finding> {
    let mut out = Vec::new();
    let n = ts.tiles.len();
    for (i, node) in ts.tree.tiles.iter().enumerate() {
        for &c in node.children.iter().filter(|&&c| c < n) {
            let (pe, ce) = (node.geometric_error_m, ts.tree.tiles[c].geometric_error_m);
            if ce > pe + ERROR_SLACK * pe.abs().max(1.0) {
                out.push(
                    Finding::at(
                        FindingKind::ErrorGrows,
                        ts,
                        c,
                        format!(
                            "geometricError {ce} m is larger than its parent {}'s {pe} m",
                            ts.tiles[i].path_in_tree
                        ),
                    )
                    .values(ce, pe),
                );
            }
        }
    }

    // Buildings in two leaves, grouped by the pair of tiles.
    let mut first: BTreeMap<u32, usize> = BTreeMap::new();
    let mut twice: BTreeMap<(usize, usize), Vec<u32>> = BTreeMap::new();
    for (i, t) in ts.tiles.iter().enumerate() {
        if !ts.tree.tiles[i].children.is_empty() {
            continue; // buildings of inner tiles are landmarks, shown again below
        }
        for f in &t.features {
            if let NodeRef::Building { building_index } = f.node {
                if let Some(&j) = first.get(&building_index) {
                    twice.entry((j, i)).or_default().push(building_index);
                } else {
                    first.insert(building_index, i);
                }
            }
        }
    }
    for ((j, i), b) in twice {
        out.push(
            Finding::at(
                FindingKind::BuildingInTwoLeaves,
                ts,
                i,
                format!(
                    "{} building(s) of this tile are also in tile {}",
                    b.len(),
                    ts.tiles[j].path_in_tree
                ),
            )
            .node(NodeRef::Building {
                building_index: b[0],
            })
            .buildings(&b),
        );
    }

    let counts = held_counts(ts);
    let identity_checked = ts.identity_checked();
    for (i, t) in ts.tiles.iter().enumerate() {
        let unknown = t
            .features
            .iter()
            .filter(|f| matches!(f.node, NodeRef::Feature { .. }))
            .count();
        if unknown > 0 && identity_checked {
            out.push(Finding::at(
                FindingKind::UnknownFeature,
                ts,
                i,
                format!(
                    "{unknown} feature(s) have neither building_index nor level and node_index"
                ),
            ));
        }
        // citylod draws every triangle for a feature: one without is content no building or block stands for.
        let orphans = t
            .triangle_features
            .iter()
            .filter(|&&f| f as usize >= t.features.len())
            .count();
        if orphans > 0 && identity_checked {
            out.push(Finding::at(
                FindingKind::UnknownFeature,
                ts,
                i,
                format!("{orphans} triangle(s) belong to no feature of the tile's property tables"),
            ));
        }
        if !t.has_clusters() {
            continue;
        }
        let Some(total) = t.member_total() else {
            continue;
        };
        let children = &ts.tree.tiles[i].children;
        let held: Option<u64> = if children.is_empty() {
            Some(t.under.len() as u64)
        } else {
            children
                .iter()
                .filter(|&&c| c < n)
                .map(|&c| counts[c])
                .sum()
        };
        if let Some(held) = held.filter(|&h| h != total) {
            out.push(
                Finding::at(
                    FindingKind::MemberCountMismatch,
                    ts,
                    i,
                    format!(
                        "the blocks of this tile hold {total} buildings (Σ member_count) but its \
                         children hold {held}: refining it {} {} building(s)",
                        if held < total { "loses" } else { "adds" },
                        total.abs_diff(held)
                    ),
                )
                .values(held as f64, total as f64),
            );
        }
    }
    out.extend(crate::volumes::check_volumes(ts));
    out
}

/// Buildings each tile stands for: Σ member_count of its content, or its children's when it has
/// none; `None` when some block does not say.
fn held_counts(ts: &LoadedTileset) -> Vec<Option<u64>> {
    let n = ts.tiles.len();
    let mut counts = vec![None; n];
    for i in (0..n).rev() {
        counts[i] = if ts.tiles[i].features.is_empty() {
            ts.tree.tiles[i]
                .children
                .iter()
                .filter(|&&c| c > i && c < n)
                .map(|&c| counts[c])
                .sum()
        } else {
            ts.tiles[i].member_total()
        };
    }
    counts
}

/// Coverage of one cut: every building covered exactly once by the selected tiles and the culled
/// subtrees; holes (empty tiles selected, blocks that stand for fewer buildings than lie below
/// them) and bad links are reported too.
pub fn check_cut(ts: &LoadedTileset, sel: &Selection) -> Vec<Finding> {
    let mut out = Vec::new();
    if sel.root_below_threshold {
        out.push(Finding::at(
            FindingKind::TilesetNotDrawn,
            ts,
            ts.tree.root,
            format!(
                "the tileset's geometricError {} m already meets the SSE threshold at the root's \
                 distance: a client draws nothing",
                ts.tree.tileset_geometric_error_m
            ),
        ));
        return out;
    }
    for &(p, c) in &sel.bad_links {
        out.push(Finding::at(
            FindingKind::BadLink,
            ts,
            p,
            format!("child link to tile #{c} is out of range or revisits a tile"),
        ));
    }

    // (building, covering tile) pairs; `owner` says which frontier tile each building lies under.
    let mut covered: Vec<(u32, usize)> = Vec::new();
    let mut owner: BTreeMap<u32, usize> = BTreeMap::new();
    let frontier = sel
        .selected
        .iter()
        .chain(&sel.selected_empty)
        .chain(&sel.culled);
    for &i in frontier {
        let Some(t) = ts.tiles.get(i) else { continue };
        for &b in &t.under {
            owner.insert(b, i);
        }
    }
    // An empty tile chosen because none of its children is in view hides nothing: as culled.
    for &i in sel.culled.iter().chain(&sel.selected_empty_out_of_view) {
        covered.extend(ts.tiles[i].under.iter().map(|&b| (b, i)));
    }
    for &i in &sel.selected_empty {
        if sel.selected_empty_out_of_view.binary_search(&i).is_ok() {
            continue;
        }
        out.push(Finding::at(
            FindingKind::EmptyTileSelected,
            ts,
            i,
            format!(
                "selected but without content: {} building(s) below it are not drawn",
                ts.tiles[i].under.len()
            ),
        ));
    }
    for &i in &sel.selected {
        let t = &ts.tiles[i];
        // Buildings beside blocks are the blocks' landmarks: members of a block already.
        let clusters = t.has_clusters();
        let counted: Vec<_> = t
            .features
            .iter()
            .filter(|f| !clusters || !matches!(f.node, NodeRef::Building { .. }))
            .collect();
        if !counted.is_empty() && counted.iter().all(|f| f.members.is_some()) {
            covered.extend(
                counted
                    .iter()
                    .flat_map(|f| f.members.iter().flatten())
                    .map(|&b| (b, i)),
            );
            continue;
        }
        // Blocks known only by their member_count stand for the buildings below the tile.
        covered.extend(t.under.iter().map(|&b| (b, i)));
        if let Some(total) = t.member_total() {
            let below = t.under.len() as u64;
            if total < below {
                out.push(
                    Finding::at(
                        FindingKind::BuildingMissing,
                        ts,
                        i,
                        format!(
                            "the blocks of this selected tile stand for {total} buildings \
                             (Σ member_count) but {below} lie below it: {} missing from the cut",
                            below - total
                        ),
                    )
                    .values(total as f64, below as f64),
                );
            }
        }
    }
    // A refined block tile whose children hold fewer buildings than its blocks loses the rest.
    let counts = held_counts(ts);
    for &i in &sel.refined {
        let t = &ts.tiles[i];
        let (Some(total), true) = (t.member_total(), t.has_clusters()) else {
            continue;
        };
        let held: Option<u64> = ts.tree.tiles[i]
            .children
            .iter()
            .filter(|&&c| c < ts.tiles.len())
            .map(|&c| counts[c])
            .sum();
        if let Some(held) = held.filter(|&h| h < total) {
            out.push(
                Finding::at(
                    FindingKind::BuildingMissing,
                    ts,
                    i,
                    format!(
                        "this tile is refined but its children hold {held} of the {total} buildings \
                         its blocks stand for: {} missing from the cut",
                        total - held
                    ),
                )
                .values(held as f64, total as f64),
            );
        }
    }
    covered.sort_unstable();

    let mut twice: BTreeMap<Vec<usize>, Vec<u32>> = BTreeMap::new();
    for run in covered.chunk_by(|a, b| a.0 == b.0) {
        if run.len() > 1 {
            let tiles: Vec<usize> = run.iter().map(|&(_, t)| t).collect();
            twice.entry(tiles).or_default().push(run[0].0);
        }
    }
    for (tiles, b) in twice {
        let names: Vec<&str> = tiles
            .iter()
            .map(|&t| ts.tiles[t].path_in_tree.as_str())
            .collect();
        out.push(
            Finding::at(
                FindingKind::BuildingTwice,
                ts,
                tiles[tiles.len() - 1],
                format!(
                    "{} building(s) covered by {} tiles of the cut: {}",
                    b.len(),
                    tiles.len(),
                    names.join(", ")
                ),
            )
            .node(NodeRef::Building {
                building_index: b[0],
            })
            .buildings(&b),
        );
    }

    let mut missing: BTreeMap<Option<usize>, Vec<u32>> = BTreeMap::new();
    let mut covered_iter = covered.iter().map(|&(b, _)| b).peekable();
    for &b in &ts.buildings {
        while covered_iter.next_if(|&c| c < b).is_some() {}
        if covered_iter.peek() != Some(&b) {
            missing.entry(owner.get(&b).copied()).or_default().push(b);
        }
    }
    for (tile, b) in missing {
        let message = match tile {
            Some(_) => format!("{} building(s) below this tile are not in the cut", b.len()),
            None => format!(
                "{} building(s) are reachable from no tile of the cut",
                b.len()
            ),
        };
        // No owning tile (reached only through a bad link): `at` leaves the tile empty.
        let f = Finding::at(
            FindingKind::BuildingMissing,
            ts,
            tile.unwrap_or(usize::MAX),
            message,
        );
        out.push(
            f.node(NodeRef::Building {
                building_index: b[0],
            })
            .buildings(&b),
        );
    }
    out
}

/// Less drawn area than this (m²) is no area: a feature whose triangles are all collapsed.
const NO_AREA_M2: f64 = 1e-4;

/// One finding per tile with content whose property table has features that draw nothing (no triangle, or
/// triangles of no area in all: content collapsed by a broken transform or garbled positions), unless the tile's
/// geometricError e allows a block to vanish whole: κ·√area ≤ e, κ = δH/√δA (a small block on a coarse grid, far
/// below a pixel wherever the tile is drawn). Coverage counts features, so without this a building could count as
/// covered and never be drawn.
pub fn check_features_drawn(ts: &LoadedTileset, tol: crate::Tolerances) -> Vec<Finding> {
    let kappa = tol.dh_px / tol.da_px.sqrt();
    let mut out = Vec::new();
    for (i, t) in ts.tiles.iter().enumerate() {
        let Some(mesh) = &t.mesh else { continue };
        let mut area = vec![0.0f64; t.features.len()];
        for (tri, &f) in mesh.triangles.iter().zip(&t.triangle_features) {
            let Some(a) = area.get_mut(f as usize) else {
                continue;
            };
            let p = tri.map(|v| mesh.positions.get(v as usize).copied());
            if let [Some(p), Some(q), Some(r)] = p {
                *a += vec3::norm(vec3::cross(vec3::sub(q, p), vec3::sub(r, p))) / 2.0;
            }
        }
        let error_m = ts.tree.tiles.get(i).map_or(0.0, |n| n.geometric_error_m);
        let may_vanish = |f: &FeatureInfo| f.area_m2.is_some_and(|a| kappa * a.sqrt() <= error_m);
        let empty: Vec<usize> = (0..t.features.len())
            .filter(|&k| (area[k].is_nan() || area[k] < NO_AREA_M2) && !may_vanish(&t.features[k]))
            .collect();
        let Some(&first) = empty.first() else {
            continue;
        };
        let buildings: Vec<u32> = empty
            .iter()
            .flat_map(|&k| t.features[k].members.clone().unwrap_or_default())
            .collect();
        out.push(
            Finding::at(
                FindingKind::FeatureDrawsNothing,
                ts,
                i,
                format!(
                    "{} of the tile's {} features draw no triangle with area, though its geometricError ({error_m} \
                     m) does not allow them to vanish",
                    empty.len(),
                    t.features.len()
                ),
            )
            .node(t.features[first].node)
            .buildings(&buildings),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::select::{OrientedBox, TileNode, TileTree};
    use crate::tileset::{FeatureInfo, TileInfo};
    use citylod_model::Mesh3d;

    fn building(b: u32) -> FeatureInfo {
        FeatureInfo::building(b)
    }

    fn block(members: u32) -> FeatureInfo {
        FeatureInfo {
            node: NodeRef::Cluster {
                level: 1,
                node_index: 0,
            },
            member_count: Some(members),
            members: None,
            dh_m: 3.0,
            da_m2: 10.0,
            area_m2: None,
            fallback: false,
            bounds_m: None,
            heights: None,
        }
    }

    /// Root (one block of 4) → leaves {0, 1} and {2, 3}.
    fn tileset(root_count: u32, leaves: [&[u32]; 2], errors: [f64; 3]) -> LoadedTileset {
        let info = |path: &str, features: Vec<FeatureInfo>| TileInfo {
            path_in_tree: path.into(),
            content_uri: Some(format!("tiles/{path}.glb")),
            content_bytes: 0,
            content_uris: vec![],
            volume_kind: Default::default(),
            exact_volume: None,
            mesh: None,
            features,
            triangle_features: Vec::new(),
            under: Vec::new(),
        };
        let mut tiles = vec![
            info("0", vec![block(root_count)]),
            info("0/0", leaves[0].iter().map(|&b| building(b)).collect()),
            info("0/1", leaves[1].iter().map(|&b| building(b)).collect()),
        ];
        tiles[1].under = leaves[0].to_vec();
        tiles[2].under = leaves[1].to_vec();
        let mut all: Vec<u32> = leaves.concat();
        all.sort_unstable();
        tiles[0].under = all.clone();
        let node = |e: f64, children: Vec<usize>| TileNode {
            bounds: OrientedBox::from_min_max([0.0; 3], [1.0; 3]),
            geometric_error_m: e,
            children,
            has_content: true,
            external_tileset: false,
        };
        LoadedTileset {
            tree: TileTree {
                tiles: vec![
                    node(errors[0], vec![1, 2]),
                    node(errors[1], vec![]),
                    node(errors[2], vec![]),
                ],
                root: 0,
                tileset_geometric_error_m: 100.0,
            },
            tiles,
            buildings: all.into_iter().collect(),
            written_by_citylod: true,
        }
    }

    fn kinds(f: &[Finding]) -> Vec<FindingKind> {
        f.iter().map(|f| f.kind).collect()
    }

    /// A feature whose triangles have no area counts as covering its buildings but draws nothing: a finding,
    /// unless a block is small enough for its tile's error to let it vanish whole (κ·√area ≤ e).
    #[test]
    fn features_drawing_nothing_are_found_unless_the_error_allows_them_to_vanish() {
        let tol = crate::Tolerances::default(); // κ = 20 / √200 ≈ 1.41 m per √m²
        let mut ts = tileset(4, [&[0, 1], &[2, 3]], [50.0, 0.0, 0.0]);
        let drawn = |features: &[u32]| {
            let mut mesh = Mesh3d {
                positions: Vec::new(),
                triangles: Vec::new(),
            };
            for (k, &f) in features.iter().enumerate() {
                let x = 10.0 * k as f64;
                // Feature u32::MAX (none) draws a proper triangle; any other feature, one collapsed onto a line.
                let far = if f == u32::MAX { 4.0 } else { 0.0 };
                let v = mesh.positions.len() as u32;
                mesh.positions
                    .extend([[x, 0.0, 0.0], [x + 4.0, 0.0, 0.0], [x, far, 0.0]]);
                mesh.triangles.push([v, v + 1, v + 2]);
            }
            mesh
        };
        // Leaf 0/0: building 0 drawn, building 1 collapsed; leaf 0/1: both drawn.
        ts.tiles[1].mesh = Some(drawn(&[u32::MAX, 1]));
        ts.tiles[1].triangle_features = vec![0, 1];
        ts.tiles[2].mesh = Some(drawn(&[u32::MAX, u32::MAX]));
        ts.tiles[2].triangle_features = vec![0, 1];
        // The root's block of 4 collapsed: 1,000 m² may vanish at 50 m (κ·√1000 ≈ 44.7 m), 2,000 m² may not.
        ts.tiles[0].mesh = Some(drawn(&[0]));
        ts.tiles[0].triangle_features = vec![0];
        ts.tiles[0].features[0].area_m2 = Some(1000.0);
        let f = check_features_drawn(&ts, tol);
        assert_eq!(kinds(&f), vec![FindingKind::FeatureDrawsNothing], "{f:?}");
        assert_eq!(
            (f[0].tile.as_str(), f[0].buildings.as_slice()),
            ("0/0", &[1][..])
        );
        ts.tiles[0].features[0].area_m2 = Some(2000.0);
        let f = check_features_drawn(&ts, tol);
        assert_eq!(f.len(), 2, "{f:?}");
        assert_eq!(f[0].tile, "0");
        // A feature without any triangle at all draws nothing too.
        ts.tiles[2].triangle_features = vec![0, 0];
        assert_eq!(check_features_drawn(&ts, tol).len(), 3);
    }

    fn sel(selected: Vec<usize>, refined: Vec<usize>, culled: Vec<usize>) -> Selection {
        Selection {
            selected,
            refined,
            culled,
            ..Selection::default()
        }
    }

    #[test]
    fn sound_tree_and_cuts_have_no_findings() {
        let ts = tileset(4, [&[0, 1], &[2, 3]], [5.0, 0.0, 0.0]);
        assert!(check_tree(&ts).is_empty());
        assert!(check_cut(&ts, &sel(vec![0], vec![], vec![])).is_empty());
        assert!(check_cut(&ts, &sel(vec![1], vec![0], vec![2])).is_empty());
    }

    #[test]
    fn landmark_beside_its_block_is_not_counted_twice() {
        let mut ts = tileset(4, [&[0, 1], &[2, 3]], [5.0, 0.0, 0.0]);
        ts.tiles[0].features.push(building(2));
        assert!(check_tree(&ts).is_empty());
        assert!(check_cut(&ts, &sel(vec![0], vec![], vec![])).is_empty());
        ts.tiles[0].features[0].members = Some(vec![0, 1, 2, 3]);
        assert!(check_cut(&ts, &sel(vec![0], vec![], vec![])).is_empty());
    }

    #[test]
    fn features_without_identity_are_findings_unless_the_tileset_is_third_party() {
        let unknown = |feature| FeatureInfo {
            node: NodeRef::Feature { feature },
            ..building(0)
        };
        let unknown_tiles = |f: &[Finding]| -> Vec<String> {
            f.iter()
                .filter(|f| f.kind == FindingKind::UnknownFeature)
                .map(|f| f.tile.clone())
                .collect()
        };
        // citylod's tileset with one leaf's features stripped of their identity: a finding at that leaf.
        let mut ts = tileset(4, [&[0, 1], &[2, 3]], [5.0, 0.0, 0.0]);
        ts.tiles[2].features = vec![unknown(0), unknown(1)];
        assert_eq!(unknown_tiles(&check_tree(&ts)), vec!["0/1"]);
        // Not said to be citylod's, but other features carry citylod's identity: still a finding.
        ts.written_by_citylod = false;
        assert!(ts.identity_checked());
        assert_eq!(unknown_tiles(&check_tree(&ts)), vec!["0/1"]);
        // A third-party tileset whose features all have identities of their own: nothing to hold them to.
        for t in &mut ts.tiles {
            t.features = vec![unknown(0)];
        }
        assert!(!ts.identity_checked());
        assert!(unknown_tiles(&check_tree(&ts)).is_empty());
        // The same features in a tileset citylod says it wrote are findings in every tile.
        ts.written_by_citylod = true;
        assert_eq!(unknown_tiles(&check_tree(&ts)), vec!["0", "0/0", "0/1"]);
        // Content whose features are gone altogether: its triangles belong to no feature.
        let mut ts = tileset(4, [&[0, 1], &[2, 3]], [5.0, 0.0, 0.0]);
        ts.tiles[2].features.clear();
        ts.tiles[2].triangle_features = vec![u32::MAX, u32::MAX];
        let f = check_tree(&ts);
        assert_eq!(unknown_tiles(&f), vec!["0/1"]);
        assert!(
            f.iter()
                .any(|f| f.message.contains("2 triangle(s) belong to no feature")),
            "{f:?}"
        );
    }

    #[test]
    fn growing_error_is_found_at_the_child() {
        let ts = tileset(4, [&[0, 1], &[2, 3]], [5.0, 0.0, 9.0]);
        let f = check_tree(&ts);
        assert_eq!(kinds(&f), vec![FindingKind::ErrorGrows]);
        assert_eq!(f[0].tile, "0/1");
    }

    #[test]
    fn building_in_two_leaves_is_found_and_covered_twice() {
        let ts = tileset(4, [&[0, 1], &[1, 3]], [5.0, 0.0, 0.0]);
        assert!(kinds(&check_tree(&ts)).contains(&FindingKind::BuildingInTwoLeaves));
        let f = check_cut(&ts, &sel(vec![1, 2], vec![0], vec![]));
        let twice: Vec<&Finding> = f
            .iter()
            .filter(|f| f.kind == FindingKind::BuildingTwice)
            .collect();
        assert_eq!(twice.len(), 1);
        assert_eq!(twice[0].buildings, vec![1]);
    }

    #[test]
    fn lost_child_is_a_member_count_mismatch_at_the_parent() {
        let mut ts = tileset(4, [&[0, 1], &[2, 3]], [5.0, 0.0, 0.0]);
        ts.tree.tiles[0].children = vec![1];
        ts.tiles[0].under = vec![0, 1];
        ts.buildings = [0, 1].into_iter().collect();
        let f = check_tree(&ts);
        assert_eq!(kinds(&f), vec![FindingKind::MemberCountMismatch]);
        assert_eq!((f[0].tile.as_str(), f[0].measured), ("0", Some(2.0)));
        let f = check_cut(&ts, &sel(vec![1], vec![0], vec![]));
        assert_eq!(kinds(&f), vec![FindingKind::BuildingMissing]);
        assert_eq!(f[0].tile, "0");
    }

    #[test]
    fn block_dropped_from_a_selected_tile_is_missing_from_the_cut() {
        let ts = tileset(3, [&[0, 1], &[2, 3]], [5.0, 0.0, 0.0]);
        let f = check_cut(&ts, &sel(vec![0], vec![], vec![]));
        assert_eq!(kinds(&f), vec![FindingKind::BuildingMissing]);
    }

    #[test]
    fn empty_selected_tile_is_a_hole() {
        let ts = tileset(4, [&[0, 1], &[2, 3]], [5.0, 0.0, 0.0]);
        let mut s = sel(vec![1], vec![0], vec![]);
        s.selected_empty = vec![2];
        let f = check_cut(&ts, &s);
        assert_eq!(
            kinds(&f),
            vec![FindingKind::EmptyTileSelected, FindingKind::BuildingMissing]
        );
        assert_eq!(f[1].buildings, vec![2, 3]);
        // … unless it was chosen because none of its children is in view: nothing below it can be seen.
        s.selected_empty_out_of_view = vec![2];
        assert_eq!(kinds(&check_cut(&ts, &s)), vec![]);
    }
}
