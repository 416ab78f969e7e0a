//! The level-of-detail tree of a build: every level of the hierarchy meshed (buildings as prisms, blocks as prisms
//! of their merged footprints), packed into tiles within the budget, with each tile's geometric error from the
//! measured Δh and Δa (DESIGN.md §4); a block's landmarks (seed 001) are `cluster` features flagged `landmark`
//! beside it, in the same content. Buildings with 3D models get a chain below their prism (DESIGN.md §7): the
//! simplified model, then the full model, each tile's error the sampled Hausdorff distance (m) to the full model.
//! Without a hierarchy (`--leaves-only`) the buildings alone (their full models when they have them), in leaf tiles.

use crate::build::LevelSummary;
use crate::features::{cluster_feature, landmark_feature, BuildingTable, ClusterRow};
use citylod_mesh::simplify::Simplifier;
use citylod_model::{Building, BuildingId, Hierarchy, Mesh3d, Node, NodeId};
use citylod_tiles::hlod::{assemble, pack, tile_errors, NodeCost, TileBudget, TileContent};
use citylod_tiles::{tile_spatially, ContentFeature, TileSpec};
use geo::Area;
use rayon::prelude::*;
use std::borrow::Cow;
use std::collections::HashMap;

/// Share of its tile's geometric error the vertices of a block (and of the landmarks drawn on it) may move when
/// the writer rounds them (per axis): the grid is then at most e/16, a shift of at most e/32 per axis (√3·e/32 ≈
/// 5.4 % of e), under a pixel where a client draws the tile (e ≤ 16 px), and `citylod check`'s skyline and pixel
/// comparisons hold. Measured on Boston against e/128 (a grid of e/64): the tileset 12.07 → 11.78 MB and the
/// bytes the 8 views of `citylod check` load 9.53 → 8.49 MB (e/16, a grid of e/8 and up to 1.7 px: 11.55 MB).
pub const ROUNDING_SHARE: f64 = 1.0 / 32.0;

/// A block's mesh: its extruded merged footprint, or — when that fails — its buildings' own prisms.
struct NodeMesh {
    mesh: Mesh3d,
    fallback: bool,
}

/// Nodes re-outlined within the error of the tile that draws them ([`LodTree::spend_tile_errors`]): `own[level -
/// 1][node]` in their own tile; `demoted[(level, node)]` where a tile draws them in a rough ancestor's stead.
struct Spent {
    own: Vec<Vec<Option<(Node, NodeMesh)>>>,
    demoted: HashMap<(usize, u32), (Node, NodeMesh)>,
}

/// How buildings' 3D models are simplified for the level between the full model and the prism.
pub struct ModelOptions {
    pub simplifier: Simplifier,
    /// Share of the triangles to remove, in (0, 1).
    pub rate: f64,
}

/// A building's chain below its prism: the simplified and the full model, with their errors (m) against the full.
struct ModelChain {
    full: Mesh3d,
    simplified: Mesh3d,
    simplified_error_m: f64,
    prism_error_m: f64,
    rate_reached: f64,
    note: Option<String>,
}

/// What the 3D chain did, for the build report.
#[derive(serde::Serialize, Default)]
pub struct ModelSummary {
    pub buildings: usize,
    pub triangles_full: usize,
    pub triangles_simplified: usize,
    pub rate_target: f64,
    pub rate_reached_median: f64,
    /// Buildings whose simplification stopped more than 1 % short of the target, with the simplifier's reason.
    pub short_of_target: usize,
    pub short_of_target_examples: Vec<(String, String)>,
    pub simplified_error_median_m: f64,
    pub simplified_error_max_m: f64,
    pub prism_error_median_m: f64,
    pub prism_error_max_m: f64,
    /// The buildings whose prisms are furthest from their models (source id, m), largest first, at most 5.
    pub prism_error_largest: Vec<(String, f64)>,
}

pub struct LodTree<'h> {
    pub building_table: BuildingTable,
    /// Building prisms by building id; `None` for a building that could not be meshed.
    buildings: Vec<Option<Mesh3d>>,
    pub failed_buildings: Vec<(BuildingId, String)>,
    hierarchy: Option<&'h Hierarchy>,
    /// Meshes of the nodes of levels 1.., indexed `[level - 1][node]`.
    nodes: Vec<Vec<NodeMesh>>,
    /// κ = δH / √δA (m per √m²).
    kappa: f64,
    /// Near-collinear vertices above this interior angle go when a block is re-outlined (degrees).
    collinear_angle_deg: f64,
    /// By building id: the 3D chain, for buildings with a model and a prism.
    models: Vec<Option<ModelChain>>,
    pub model_summary: Option<ModelSummary>,
}

fn concat(meshes: impl Iterator<Item = Mesh3d>) -> Mesh3d {
    let mut out = Mesh3d::default();
    for m in meshes {
        let base = out.positions.len() as u32;
        out.positions.extend(m.positions);
        out.triangles
            .extend(m.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    out
}

impl<'h> LodTree<'h> {
    pub fn build(
        buildings: &[Building],
        hierarchy: Option<&'h Hierarchy>,
        kappa: f64,
        collinear_angle_deg: f64,
        model_opts: &ModelOptions,
    ) -> Self {
        let meshed: Vec<Result<Mesh3d, String>> = buildings
            .par_iter()
            .map(|b| {
                citylod_mesh::extrude(&b.footprint, b.base_z_m, b.base_z_m + b.height_m)
                    .map_err(|e| e.to_string())
            })
            .collect();
        let mut failed_buildings = Vec::new();
        let building_meshes: Vec<Option<Mesh3d>> = meshed
            .into_iter()
            .enumerate()
            .map(|(i, m)| {
                m.map_err(|e| failed_buildings.push((BuildingId(i as u32), e)))
                    .ok()
            })
            .collect();
        let nodes =
            hierarchy
                .map(|h| {
                    h.levels
                        .iter()
                        .skip(1)
                        .map(|level| {
                            level
                                .nodes
                                .par_iter()
                                .map(|n| {
                                    match citylod_mesh::extrude(
                                        &n.footprint,
                                        n.base_z_m,
                                        n.base_z_m + n.height_m,
                                    ) {
                                        Ok(mesh) => NodeMesh {
                                            mesh,
                                            fallback: false,
                                        },
                                        Err(_) => NodeMesh {
                                            mesh: concat(n.members.iter().filter_map(|b| {
                                                building_meshes[b.0 as usize].clone()
                                            })),
                                            fallback: true,
                                        },
                                    }
                                })
                                .collect()
                        })
                        .collect()
                })
                .unwrap_or_default();
        let models: Vec<Option<ModelChain>> = buildings
            .par_iter()
            .zip(building_meshes.par_iter())
            .map(|(b, prism)| {
                let (model, prism) = (b.mesh.as_ref()?, prism.as_ref()?);
                if model.mesh.triangles.is_empty() {
                    return None;
                }
                let full = model.mesh.clone();
                let s = citylod_mesh::simplify::simplify(
                    &full,
                    &model_opts.simplifier,
                    model_opts.rate,
                );
                Some(ModelChain {
                    simplified_error_m: citylod_mesh::hausdorff::measured_error_m(&full, &s.mesh),
                    prism_error_m: citylod_mesh::hausdorff::measured_error_m(&full, prism),
                    simplified: s.mesh,
                    rate_reached: s.rate_reached,
                    note: s.note,
                    full,
                })
            })
            .collect();
        let model_summary = summarize_models(buildings, &models, model_opts.rate);
        Self {
            building_table: BuildingTable::new(buildings),
            buildings: building_meshes,
            failed_buildings,
            hierarchy,
            nodes,
            kappa,
            collinear_angle_deg,
            models,
            model_summary,
        }
    }

    /// The chain below a tile of buildings `ids`: a tile of their simplified models (prisms for buildings
    /// without a model) whose error is the largest simplified model's, holding a tile of the full models (error 0);
    /// just the full models' tile when the simplifier changed none of them. Empty when none of them has a model.
    fn model_chain(&self, buildings: &[Building], ids: &[BuildingId]) -> Vec<TileSpec> {
        if !ids.iter().any(|b| self.models[b.0 as usize].is_some()) {
            return Vec::new();
        }
        let version = |full: bool| -> Vec<ContentFeature> {
            ids.iter()
                .filter_map(|&b| {
                    let mesh = match &self.models[b.0 as usize] {
                        Some(m) if full => m.full.clone(),
                        Some(m) => m.simplified.clone(),
                        None => self.buildings[b.0 as usize].clone()?,
                    };
                    Some(self.building_table.feature(&buildings[b.0 as usize], mesh))
                })
                .collect()
        };
        let simplified_error_m = ids
            .iter()
            .filter_map(|b| self.models[b.0 as usize].as_ref())
            .map(|m| m.simplified_error_m)
            .fold(0.0, f64::max);
        let full = TileSpec {
            features: version(true),
            children: vec![],
            geometric_error_m: 0.0,
        };
        // Models the simplifier left as they were (error 0): no simplified tile, the prisms refine to the full models.
        if simplified_error_m == 0.0 {
            return vec![full];
        }
        vec![TileSpec {
            features: version(false),
            children: vec![full],
            geometric_error_m: simplified_error_m,
        }]
    }

    /// A building prism's error (m): its distance from the 3D model when there is one, else 0 (exact).
    fn prism_error(&self, b: BuildingId) -> f64 {
        self.models[b.0 as usize]
            .as_ref()
            .map_or(0.0, |m| m.prism_error_m)
    }

    /// The landmarks drawn on top of a block (none when the block fell back to its buildings' prisms,
    /// which already show them).
    fn landmarks_of<'a>(
        &self,
        node: &'a Node,
        nm: &NodeMesh,
    ) -> impl Iterator<Item = BuildingId> + 'a {
        let show = !nm.fallback;
        node.landmarks.iter().copied().filter(move |_| show)
    }

    /// The geometric error of drawing `node` instead of its buildings: max(Δh, κ·√Δa) metres.
    fn node_error(&self, node: &Node) -> f64 {
        node.dh_m.max(self.kappa * node.da_m2.max(0.0).sqrt())
    }

    /// The error of what is drawn for `node` (metres): its own, and the distance of each prism drawn at full
    /// detail beside or instead of the block (its landmarks, or its buildings when the block fell back to them)
    /// from its building's 3D model — 0 for buildings without one.
    fn drawn_error(&self, node: &Node, nm: &NodeMesh) -> f64 {
        // `landmarks_of` yields none for a fallen-back block, whose buildings are all drawn instead.
        let fell_back = nm.fallback.then_some(&node.members).into_iter().flatten();
        self.landmarks_of(node, nm)
            .chain(fell_back.copied())
            .map(|b| self.prism_error(b))
            .fold(self.node_error(node), f64::max)
    }

    fn building_feature(&self, buildings: &[Building], b: BuildingId) -> Option<ContentFeature> {
        let mesh = self.buildings[b.0 as usize].clone()?;
        Some(self.building_table.feature(&buildings[b.0 as usize], mesh))
    }

    /// Triangles of the landmarks drawn on top of `node`.
    fn landmark_triangles(&self, node: &Node, nm: &NodeMesh) -> usize {
        self.landmarks_of(node, nm)
            .map(|b| {
                self.buildings[b.0 as usize]
                    .as_ref()
                    .map_or(0, |m| m.triangles.len())
            })
            .sum()
    }

    /// Blocks re-outlined within their tile's error: a tile's geometricError is its worst node's, so every
    /// other block in it may differ from its buildings by up to (e/κ)² in area without raising it (DESIGN.md §4).
    /// Each block of a written level above the buildings loses outline vertices, cheapest area per vertex first —
    /// notches filled, corners cut, courtyards filled — within that budget
    /// ([`citylod_generalize::reoutline_within`]); its Δa grows by the area filled plus the area cut, so its
    /// metadata stays an upper bound of what it changed and its own error stays ≤ the tile's.
    /// The same holds for what a tile draws in a rough block's stead (its descendants on the next level written,
    /// the buildings under a level-1 tile), re-outlined within the budget of the tile that draws them.
    /// `own` is indexed `[level - 1][node]`, `demoted` by (level, node) of the descendants drawn so: `None` /
    /// absent where nothing changed (or the re-extruded prism failed, which keeps the node as it was).
    fn spend_tile_errors(
        &self,
        h: &Hierarchy,
        packing: &citylod_tiles::hlod::Packing,
        errors: &[f64],
    ) -> Spent {
        let mut spent = Spent {
            own: h
                .levels
                .iter()
                .skip(1)
                .map(|l| (0..l.nodes.len()).map(|_| None).collect())
                .collect(),
            demoted: HashMap::new(),
        };
        if self.kappa.is_nan() || self.kappa <= 0.0 {
            return spent;
        }
        // (level, node, error of the tile drawing it, drawn in a rough ancestor's stead)
        let jobs: Vec<(usize, NodeId, f64, bool)> = packing
            .tiles
            .iter()
            .zip(errors)
            .filter(|(t, _)| t.level > 0)
            .flat_map(|(t, &e)| {
                t.drawn
                    .iter()
                    .map(move |&(level, n)| (level, n, e, level != t.level))
            })
            .collect();
        let done: Vec<(usize, NodeId, bool, Node, NodeMesh)> = jobs
            .par_iter()
            .filter_map(|&(level, n, tile_error_m, demoted)| {
                let node = self.drawn_node(h, level, n);
                // A fallen-back block shows its buildings' prisms; a building whose prism could not be built is
                // drawn nowhere (it is in the build report's skips), so not re-outlined into a block tile either.
                let unchanged = match level {
                    0 => self.buildings[node.members[0].0 as usize].is_none(),
                    _ => self.nodes[level - 1][n.0 as usize].fallback,
                };
                if unchanged {
                    return None;
                }
                let budget_m2 = (tile_error_m / self.kappa).powi(2) - node.da_m2;
                // A hair inside the budget so rounding in the area sums cannot lift the error above the tile's.
                let r = citylod_generalize::reoutline_within(
                    &node.footprint,
                    budget_m2 * 0.999,
                    self.collinear_angle_deg,
                );
                if r.filled_m2 + r.cut_m2 <= 0.0 {
                    return None;
                }
                let mesh = citylod_mesh::extrude(
                    &r.footprint,
                    node.base_z_m,
                    node.base_z_m + node.height_m,
                )
                .ok()?;
                // The block covered its buildings, so it differed from them by Δa; it now differs by at most
                // Δa + filled + cut (a corner cut off a building counts as much as ground filled).
                let mut node = node.into_owned();
                node.da_m2 += r.filled_m2 + r.cut_m2;
                node.area_m2 = r.footprint.unsigned_area();
                node.footprint = r.footprint;
                Some((
                    level,
                    n,
                    demoted,
                    node,
                    NodeMesh {
                        mesh,
                        fallback: false,
                    },
                ))
            })
            .collect();
        for (level, n, demoted, node, nm) in done {
            if demoted {
                spent.demoted.insert((level, n.0), (node, nm));
            } else {
                spent.own[level - 1][n.0 as usize] = Some((node, nm));
            }
        }
        spent
    }

    /// The node as a tile draws it before any re-outlining: a building (level 0, drawn in a rough block's stead)
    /// exactly as itself — no height spread, no area added (the level-0 node's own Δa is rounding).
    fn drawn_node<'a>(&self, h: &'a Hierarchy, level: usize, n: NodeId) -> Cow<'a, Node> {
        let node = &h.levels[level].nodes[n.0 as usize];
        if level == 0 {
            Cow::Owned(Node {
                dh_m: 0.0,
                da_m2: 0.0,
                ..node.clone()
            })
        } else {
            Cow::Borrowed(node)
        }
    }

    /// The tile tree to write, and a summary per level.
    pub fn tiles(
        &self,
        buildings: &[Building],
        budget: TileBudget,
        level_ratio: f64,
    ) -> (TileSpec, Vec<LevelSummary>) {
        let Some(h) = self.hierarchy else {
            let features: Vec<ContentFeature> = (0..buildings.len() as u32)
                .filter_map(|i| match &self.models[i as usize] {
                    Some(m) => Some(
                        self.building_table
                            .feature(&buildings[i as usize], m.full.clone()),
                    ),
                    None => self.building_feature(buildings, BuildingId(i)),
                })
                .collect();
            let triangles = features.iter().map(|f| f.mesh.triangles.len()).sum();
            let nodes = features.len();
            let root = tile_spatially(features, budget.max_features, budget.max_triangles);
            let summary = LevelSummary {
                level: 0,
                nodes,
                tiles: root.count_tiles(),
                triangles,
                triangles_as_generalized: triangles,
                blocks_reoutlined: 0,
                blocks_drawn_as_children: 0,
                geometric_error_min_m: Some(0.0),
                geometric_error_max_m: Some(0.0),
                mesh_fallbacks: 0,
            };
            return (root, vec![summary]);
        };
        let triangles = |level: usize, n: NodeId| -> usize {
            if level == 0 {
                self.buildings[h.levels[0].nodes[n.0 as usize].members[0].0 as usize]
                    .as_ref()
                    .map_or(0, |m| m.triangles.len())
            } else {
                let nm = &self.nodes[level - 1][n.0 as usize];
                nm.mesh.triangles.len()
                    + self.landmark_triangles(&h.levels[level].nodes[n.0 as usize], nm)
            }
        };
        let error = |level: usize, n: NodeId| -> f64 {
            if level == 0 {
                self.prism_error(h.levels[0].nodes[n.0 as usize].members[0])
            } else {
                self.drawn_error(
                    &h.levels[level].nodes[n.0 as usize],
                    &self.nodes[level - 1][n.0 as usize],
                )
            }
        };
        let level_tris: Vec<usize> = (0..h.levels.len())
            .map(|l| {
                (0..h.levels[l].nodes.len() as u32)
                    .map(|i| triangles(l, NodeId(i)))
                    .sum()
            })
            .collect();
        // The levels written: the buildings, then each level light enough against the last one kept, and the
        // top, so the root has content (before the top is condensed below).
        let top = h.levels.len().saturating_sub(1);
        let mut kept = vec![0];
        for l in 1..=top {
            if l == top
                || level_tris[l] as f64 <= level_ratio * level_tris[*kept.last().unwrap()] as f64
            {
                kept.push(l);
            }
        }
        let mut packing = pack(
            h,
            &kept,
            &NodeCost {
                triangles: &triangles,
                error_m: &error,
            },
            budget,
        );
        debug_assert!(citylod_tiles::hlod::check_packing(h, &packing).is_empty());
        let mut errors = tile_errors(&packing, &error);
        let spent = self.spend_tile_errors(h, &packing, &errors);
        let landmark_triangles = |node: &Node, nm: &NodeMesh| self.landmark_triangles(node, nm);
        // Triangles of a node as written: re-outlined within its tile's error when it was.
        let written = |level: usize, n: NodeId| -> usize {
            match level {
                0 => triangles(0, n),
                _ => match &spent.own[level - 1][n.0 as usize] {
                    Some((node, nm)) => nm.mesh.triangles.len() + landmark_triangles(node, nm),
                    None => triangles(level, n),
                },
            }
        };
        // Triangles a tile of `tile_level` draws for a node: as written, or as re-outlined for that tile when it
        // draws the node in a rough ancestor's stead.
        let drawn = |tile_level: usize, l: usize, n: NodeId| -> usize {
            // (A building has no landmarks.)
            match spent.demoted.get(&(l, n.0)).filter(|_| l < tile_level) {
                Some((node, nm)) => nm.mesh.triangles.len() + landmark_triangles(node, nm),
                None => written(l, n),
            }
        };
        // The top of the tree is condensed: while the root has a single child tile that is itself too small to
        // be worth splitting, that child becomes the root. The levels above it could save a view no more than a
        // request costs, yet every closer view loads them on its way down (`hlod::MIN_SPLIT_TRIANGLES`; on
        // NYC's Lower East Side the top three levels, 198–596 triangles and 5.8–9.5 kB each, were loaded by
        // every view). The new root's error is unchanged: a tile's error depends only on its subtree.
        let mut root_tile = 0;
        while let Some(([c], false)) = packing
            .tiles
            .get(root_tile)
            .map(|t| (t.children.as_slice(), t.nodes.is_empty()))
        {
            let t = &packing.tiles[*c];
            let tris: usize = t.drawn.iter().map(|&(l, n)| drawn(t.level, l, n)).sum();
            if tris > citylod_tiles::hlod::MIN_SPLIT_TRIANGLES {
                break;
            }
            root_tile = *c;
        }
        if root_tile != 0 {
            packing = packing.rerooted(root_tile);
            errors = tile_errors(&packing, &error);
        }
        // The geometric error of the tile each node is written in, [level][node], and of the tile drawing the
        // descendants of a rough block in its stead, by (level, node) of the descendant.
        let mut tile_error: Vec<Vec<f64>> =
            h.levels.iter().map(|l| vec![0.0; l.nodes.len()]).collect();
        let mut demoted_tile_error: HashMap<(usize, u32), f64> = HashMap::new();
        for (t, &e) in packing.tiles.iter().zip(&errors) {
            for n in &t.nodes {
                tile_error[t.level][n.0 as usize] = e;
            }
            for &(level, n) in t.drawn.iter().filter(|d| d.0 != t.level) {
                demoted_tile_error.insert((level, n.0), e);
            }
        }
        let node_and_mesh = |level: usize, n: NodeId| -> (&Node, &NodeMesh) {
            match &spent.own[level - 1][n.0 as usize] {
                Some((node, nm)) => (node, nm),
                None => (
                    &h.levels[level].nodes[n.0 as usize],
                    &self.nodes[level - 1][n.0 as usize],
                ),
            }
        };
        let features = |tile_level: usize, level: usize, n: NodeId| -> Vec<ContentFeature> {
            let demoted = tile_level > level;
            // A descendant drawn in a rough block's stead may be rounded, and was re-outlined, within the error
            // of the tile that draws it.
            let rounding_m = ROUNDING_SHARE
                * if demoted {
                    // Every descendant a tile draws is in the map; 0 (the finest grid) is always safe.
                    demoted_tile_error
                        .get(&(level, n.0))
                        .copied()
                        .unwrap_or(0.0)
                } else {
                    tile_error[level][n.0 as usize]
                };
            if level == 0 {
                let b = h.levels[0].nodes[n.0 as usize].members[0];
                if !demoted {
                    return self.building_feature(buildings, b).into_iter().collect();
                }
                // A building of a block too rough for its tile, drawn in the block's stead: the level-0 node as a
                // cluster-class feature of one member (one class per tile, for picking).
                let (node, mesh) = match spent.demoted.get(&(0, n.0)) {
                    Some((node, nm)) => (node.clone(), nm.mesh.clone()),
                    None => {
                        let Some(mesh) = self.buildings[b.0 as usize].clone() else {
                            return Vec::new();
                        };
                        (self.drawn_node(h, 0, n).into_owned(), mesh)
                    }
                };
                let row = ClusterRow {
                    level: 0,
                    node_index: n.0,
                    node: &node,
                    source_id: Some(buildings[b.0 as usize].source_id.as_str()),
                    geometric_error_m: self.node_error(&node).max(self.prism_error(b)),
                    fallback: false,
                    max_rounding_m: rounding_m,
                };
                return vec![cluster_feature(row, mesh)];
            }
            let (node, nm) = match spent.demoted.get(&(level, n.0)).filter(|_| demoted) {
                Some((node, nm)) => (node, nm),
                None => node_and_mesh(level, n),
            };
            let source_id = (node.members.len() == 1)
                .then(|| buildings[node.members[0].0 as usize].source_id.as_str());
            let row = ClusterRow {
                level,
                node_index: n.0,
                node,
                source_id,
                geometric_error_m: self.drawn_error(node, nm),
                fallback: nm.fallback,
                max_rounding_m: rounding_m,
            };
            let mut out = vec![cluster_feature(row, nm.mesh.clone())];
            out.extend(self.landmarks_of(node, nm).filter_map(|b| {
                let mesh = self.buildings[b.0 as usize].clone()?;
                // Every vertex of the building, rounded like the block it stands on: a shift of under 1.4 % of
                // the tile's error is sub-pixel where the tile is drawn, and the tile keeps one grid, so one mesh
                // (NYC: 7 of 11 tiles had a second mesh for their landmarks; tileset 2 % smaller).
                Some(landmark_feature(
                    level,
                    n.0,
                    &buildings[b.0 as usize],
                    mesh,
                    self.prism_error(b),
                    rounding_m,
                ))
            }));
            out
        };
        let below = |nodes: &[NodeId]| -> Vec<TileSpec> {
            let ids: Vec<BuildingId> = nodes
                .iter()
                .map(|n| h.levels[0].nodes[n.0 as usize].members[0])
                .collect();
            self.model_chain(buildings, &ids)
        };
        let root = assemble(
            &packing,
            &errors,
            &TileContent {
                nodes: &features,
                below_buildings: &below,
            },
        );
        let summary = (0..h.levels.len())
            .map(|level| {
                let tiles: Vec<usize> = (0..packing.tiles.len())
                    .filter(|&t| packing.tiles[t].level == level)
                    .collect();
                let errs: Vec<f64> = tiles.iter().map(|&t| errors[t]).collect();
                let n = h.levels[level].nodes.len();
                LevelSummary {
                    level,
                    nodes: n,
                    tiles: tiles.len(),
                    triangles: (0..n as u32).map(|i| written(level, NodeId(i))).sum(),
                    triangles_as_generalized: (0..n as u32)
                        .map(|i| triangles(level, NodeId(i)))
                        .sum(),
                    blocks_drawn_as_children: packing
                        .tiles
                        .iter()
                        .filter(|t| t.level == level)
                        .map(|t| t.nodes.len() - t.drawn.iter().filter(|d| d.0 == level).count())
                        .sum(),
                    blocks_reoutlined: match level {
                        0 => 0,
                        _ => spent.own[level - 1].iter().filter(|s| s.is_some()).count(),
                    },
                    geometric_error_min_m: errs.iter().copied().reduce(f64::min),
                    geometric_error_max_m: errs.iter().copied().reduce(f64::max),
                    mesh_fallbacks: if level == 0 {
                        0
                    } else {
                        self.nodes[level - 1].iter().filter(|m| m.fallback).count()
                    },
                }
            })
            .collect();
        (root, summary)
    }
}

fn summarize_models(
    buildings: &[Building],
    models: &[Option<ModelChain>],
    rate: f64,
) -> Option<ModelSummary> {
    let chains: Vec<(usize, &ModelChain)> = models
        .iter()
        .enumerate()
        .filter_map(|(i, m)| Some((i, m.as_ref()?)))
        .collect();
    if chains.is_empty() {
        return None;
    }
    let median = |mut v: Vec<f64>| -> f64 {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let short: Vec<(usize, &ModelChain)> = chains
        .iter()
        .copied()
        .filter(|(_, m)| m.rate_reached < rate - 0.01)
        .collect();
    Some(ModelSummary {
        buildings: chains.len(),
        triangles_full: chains.iter().map(|(_, m)| m.full.triangles.len()).sum(),
        triangles_simplified: chains
            .iter()
            .map(|(_, m)| m.simplified.triangles.len())
            .sum(),
        rate_target: rate,
        rate_reached_median: median(chains.iter().map(|(_, m)| m.rate_reached).collect()),
        short_of_target: short.len(),
        short_of_target_examples: short
            .iter()
            .take(10)
            .map(|(i, m)| {
                (
                    buildings[*i].source_id.clone(),
                    m.note.clone().unwrap_or_else(|| "no reason given".into()),
                )
            })
            .collect(),
        simplified_error_median_m: median(
            chains.iter().map(|(_, m)| m.simplified_error_m).collect(),
        ),
        simplified_error_max_m: chains
            .iter()
            .map(|(_, m)| m.simplified_error_m)
            .fold(0.0, f64::max),
        prism_error_median_m: median(chains.iter().map(|(_, m)| m.prism_error_m).collect()),
        prism_error_max_m: chains
            .iter()
            .map(|(_, m)| m.prism_error_m)
            .fold(0.0, f64::max),
        prism_error_largest: {
            let mut v: Vec<(String, f64)> = chains
                .iter()
                .map(|(i, m)| (buildings[*i].source_id.clone(), m.prism_error_m))
                .collect();
            v.sort_by(|a, b| b.1.total_cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
            v.truncate(5);
            v
        },
    })
}
