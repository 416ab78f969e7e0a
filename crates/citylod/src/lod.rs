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
use citylod_tiles::{point_bounds, tile_spatially_by, Bounds, ContentFeature, TileSpec};
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

/// How a block is drawn: its merged footprint extruded, or — when that fails — its buildings' own prisms
/// (`fallback`). The mesh itself is made again where a tile draws the block ([`LodTree::block_mesh`]), not kept.
struct NodeMesh {
    /// Triangles of the mesh.
    triangles: usize,
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
    /// Drawn as its simplified model wherever its prism would be (see [`rough_prisms`]).
    simplified_for_prism: bool,
}

/// The buildings whose prisms stand in for their models so badly (a church's spire over a roof at its 70th
/// percentile) that one of them would set the error of its prism tile and of every block tile above it: prism error
/// over [`citylod_tiles::hlod::DEMOTE_ERROR_RATIO`] × the median of all (and over
/// [`citylod_tiles::hlod::MIN_PARENT_ERROR_M`], which a tile with children claims anyway: LoD1 models, whose prisms
/// are nearly exact, have a median near 0), roughest first, while the triangles their
/// simplified models add stay within [`citylod_tiles::hlod::DEMOTE_MAX_ADDED_SHARE`] of the prisms' — the rule
/// that draws a rough block as its buildings, over the whole level of prisms at once. Such a building is drawn as
/// its simplified model wherever its prism would be (its prism tile, a block's landmark, a block drawn as its
/// buildings). On Delft (`--lod 2.2`) 78.9, 39.1 and 30.7 m prisms lifted their tiles and the blocks above.
fn rough_prisms(models: &[Option<ModelChain>], prism_triangles: &[Option<u32>]) -> Vec<usize> {
    use citylod_tiles::hlod::{DEMOTE_ERROR_RATIO, DEMOTE_MAX_ADDED_SHARE, MIN_PARENT_ERROR_M};
    let chains = chains(models);
    if chains.is_empty() {
        return Vec::new();
    }
    let mut errors: Vec<f64> = chains.iter().map(|(_, m)| m.prism_error_m).collect();
    errors.sort_by(f64::total_cmp);
    let rough_from_m = (DEMOTE_ERROR_RATIO * errors[errors.len() / 2]).max(MIN_PARENT_ERROR_M);
    let prisms: usize = chains
        .iter()
        .map(|&(i, _)| prism_triangles[i].unwrap_or(0) as usize)
        .sum();
    let mut room = DEMOTE_MAX_ADDED_SHARE * prisms as f64;
    let mut rough: Vec<(usize, &ModelChain)> = chains
        .into_iter()
        .filter(|(_, m)| m.prism_error_m > rough_from_m && m.simplified_error_m < m.prism_error_m)
        .collect();
    // Roughest first; ties by building, so the choice is deterministic.
    rough.sort_by(|a, b| {
        b.1.prism_error_m
            .total_cmp(&a.1.prism_error_m)
            .then(a.0.cmp(&b.0))
    });
    let mut chosen = Vec::new();
    for (i, m) in rough {
        let added = m.simplified.triangles.len() as f64 - prism_triangles[i].unwrap_or(0) as f64;
        // Each prism tile is lowered by its own roughest; one that does not fit leaves the others' worth it.
        if added > room {
            continue;
        }
        room -= added.max(0.0);
        chosen.push(i);
    }
    chosen.sort_unstable();
    chosen
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
    /// The buildings drawn as their simplified models where their prisms would be ([`rough_prisms`]), source ids.
    pub prisms_drawn_as_simplified: Vec<String>,
}

pub struct LodTree<'h> {
    pub building_table: BuildingTable,
    /// The buildings, whose prisms are extruded again whenever a tile draws them ([`LodTree::prism`]) rather than
    /// kept: a million prisms would hold ~0.7 GB through the whole write.
    buildings: &'h [Building],
    /// Triangles of each building's prism by building id; `None` for a building that could not be meshed.
    prism_triangles: Vec<Option<u32>>,
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

/// A building's prism: its footprint extruded from its base to its top.
fn prism_of(b: &Building) -> Result<Mesh3d, citylod_mesh::MeshError> {
    citylod_mesh::extrude(&b.footprint, b.base_z_m, b.base_z_m + b.height_m)
}

/// Building `b`'s prism when it could be meshed (`counts[b]`, its triangle count, is set), else `None`.
fn meshed_prism(counts: &[Option<u32>], buildings: &[Building], b: BuildingId) -> Option<Mesh3d> {
    counts[b.0 as usize]?;
    prism_of(&buildings[b.0 as usize]).ok()
}

/// A block's mesh: its footprint extruded from its base to its (area-weighted mean) top.
fn extruded(n: &Node) -> Result<Mesh3d, citylod_mesh::MeshError> {
    citylod_mesh::extrude(&n.footprint, n.base_z_m, n.base_z_m + n.height_m)
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
        buildings: &'h [Building],
        hierarchy: Option<&'h Hierarchy>,
        kappa: f64,
        collinear_angle_deg: f64,
        model_opts: &ModelOptions,
    ) -> Self {
        let meshed: Vec<Result<u32, String>> = buildings
            .par_iter()
            .map(|b| {
                prism_of(b)
                    .map(|m| m.triangles.len() as u32)
                    .map_err(|e| e.to_string())
            })
            .collect();
        let mut failed_buildings = Vec::new();
        let prism_triangles: Vec<Option<u32>> = meshed
            .into_iter()
            .enumerate()
            .map(|(i, m)| {
                m.map_err(|e| failed_buildings.push((BuildingId(i as u32), e)))
                    .ok()
            })
            .collect();
        let mut models: Vec<Option<ModelChain>> = buildings
            .par_iter()
            .enumerate()
            .map(|(i, b)| {
                let model = b.mesh.as_ref()?;
                if model.mesh.triangles.is_empty() {
                    return None;
                }
                let prism = &meshed_prism(&prism_triangles, buildings, BuildingId(i as u32))?;
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
                    simplified_for_prism: false,
                })
            })
            .collect();
        let mut prism_triangles = prism_triangles;
        // Without levels (`--leaves-only`) no prism is drawn: the buildings are their full models.
        let rough = match hierarchy {
            Some(_) => rough_prisms(&models, &prism_triangles),
            None => Vec::new(),
        };
        for i in rough {
            let m = models[i].as_mut().expect("a chain");
            m.simplified_for_prism = true;
            prism_triangles[i] = Some(m.simplified.triangles.len() as u32);
        }
        let nodes = hierarchy
            .map(|h| {
                h.levels
                    .iter()
                    .skip(1)
                    .map(|level| {
                        level
                            .nodes
                            .par_iter()
                            .map(|n| match extruded(n) {
                                Ok(mesh) => NodeMesh {
                                    triangles: mesh.triangles.len(),
                                    fallback: false,
                                },
                                Err(_) => NodeMesh {
                                    triangles: n
                                        .members
                                        .iter()
                                        .map(|b| {
                                            prism_triangles[b.0 as usize].unwrap_or(0) as usize
                                        })
                                        .sum(),
                                    fallback: true,
                                },
                            })
                            .collect()
                    })
                    .collect()
            })
            .unwrap_or_default();
        let model_summary = summarize_models(buildings, &models, model_opts.rate);
        Self {
            building_table: BuildingTable::new(buildings),
            buildings,
            prism_triangles,
            failed_buildings,
            hierarchy,
            nodes,
            kappa,
            collinear_angle_deg,
            models,
            model_summary,
        }
    }

    /// The chain below a tile of buildings `ids`: a tile of their simplified models whose error is the largest
    /// simplified model's, holding a tile of the full models (error 0); just the full models' tile when the simplifier
    /// changed none of them. Buildings without a model get a tile of their prisms (exact, error 0) beside the chain,
    /// instead of being repeated in each of its tiles (OpenStreetMap input with a few roofed buildings among many:
    /// the Lower East Side's 26 of 1,407); `lift_prism_leaves` then moves it up beside the prisms' tile. Empty when
    /// none of them has a model.
    fn model_chain(&self, ids: Vec<BuildingId>) -> Vec<TileSpec<TileRef>> {
        let (ids, prisms): (Vec<BuildingId>, Vec<BuildingId>) = ids
            .into_iter()
            .partition(|b| self.models[b.0 as usize].is_some());
        if ids.is_empty() {
            return Vec::new();
        }
        let simplified_error_m = ids
            .iter()
            .filter_map(|b| self.models[b.0 as usize].as_ref())
            .map(|m| m.simplified_error_m)
            .fold(0.0, f64::max);
        let version = |ids: Vec<BuildingId>, full: bool| TileRef::Models { ids, full };
        let full = TileSpec {
            features: version(ids.clone(), true),
            children: vec![],
            geometric_error_m: 0.0,
        };
        // Models the simplifier left as they were (error 0): no simplified tile, the prisms refine to the full models.
        let mut chain = vec![if simplified_error_m == 0.0 {
            full
        } else {
            TileSpec {
                features: version(ids, false),
                children: vec![full],
                geometric_error_m: simplified_error_m,
            }
        }];
        if !prisms.is_empty() {
            chain.push(TileSpec {
                features: TileRef::Buildings(prisms),
                children: vec![],
                geometric_error_m: 0.0,
            });
        }
        chain
    }

    /// A building prism's error (m): its distance from the 3D model when there is one, else 0 (exact); the
    /// simplified model's where that stands in for the prism.
    fn prism_error(&self, b: BuildingId) -> f64 {
        self.models[b.0 as usize].as_ref().map_or(0.0, |m| {
            if m.simplified_for_prism {
                m.simplified_error_m
            } else {
                m.prism_error_m
            }
        })
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

    fn building_feature(&self, b: BuildingId) -> Option<ContentFeature> {
        let mesh = self.prism(b)?;
        Some(
            self.building_table
                .feature(&self.buildings[b.0 as usize], mesh),
        )
    }

    /// The mesh of a block as `nm` says it is drawn: its footprint extruded again (the same mesh as when it was
    /// counted), or its buildings' prisms.
    fn block_mesh(&self, node: &Node, nm: &NodeMesh) -> Mesh3d {
        if nm.fallback {
            return concat(node.members.iter().filter_map(|&b| self.prism(b)));
        }
        // It was extruded once already, so this cannot fail; an empty mesh (no content) if it ever did.
        extruded(node).unwrap_or_default()
    }

    /// Building `b`'s prism, extruded again (the same mesh every time) — or its simplified model where that stands
    /// in for the prism ([`rough_prisms`]); `None` when it could not be meshed.
    fn prism(&self, b: BuildingId) -> Option<Mesh3d> {
        match &self.models[b.0 as usize] {
            Some(m) if m.simplified_for_prism => Some(m.simplified.clone()),
            _ => meshed_prism(&self.prism_triangles, self.buildings, b),
        }
    }

    /// Whether building `b` is drawn as its simplified model where its prism would be.
    fn simplified_for_prism(&self, b: BuildingId) -> bool {
        self.models[b.0 as usize]
            .as_ref()
            .is_some_and(|m| m.simplified_for_prism)
    }

    /// Triangles of building `b`'s prism (0 when it could not be meshed).
    fn prism_tris(&self, b: BuildingId) -> usize {
        self.prism_triangles[b.0 as usize].map_or(0, |t| t as usize)
    }

    /// Triangles of the landmarks drawn on top of `node`.
    fn landmark_triangles(&self, node: &Node, nm: &NodeMesh) -> usize {
        self.landmarks_of(node, nm)
            .map(|b| self.prism_tris(b))
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
                // A building drawn as its simplified model has no footprint prism to re-outline.
                let unchanged = match level {
                    0 => {
                        let b = node.members[0];
                        self.prism_triangles[b.0 as usize].is_none() || self.simplified_for_prism(b)
                    }
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
                // The block covered its buildings, so it differed from them by Δa; it now differs by at most
                // Δa + filled + cut (a corner cut off a building counts as much as ground filled).
                let mut node = node.into_owned();
                node.da_m2 += r.filled_m2 + r.cut_m2;
                node.area_m2 = r.footprint.unsigned_area();
                node.footprint = r.footprint;
                let triangles = extruded(&node).ok()?.triangles.len();
                Some((
                    level,
                    n,
                    demoted,
                    node,
                    NodeMesh {
                        triangles,
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

    /// The tile tree to write (each tile saying what it holds), the plan that makes each tile's features, and a
    /// summary per level.
    pub fn tiles(
        &self,
        budget: TileBudget,
        level_ratio: f64,
    ) -> (TilePlan<'_>, TileSpec<TileRef>, Vec<LevelSummary>) {
        let buildings = self.buildings;
        let Some(h) = self.hierarchy else {
            // Each building's bounds and triangles, for the spatial split; the meshes are made again when written.
            let measure =
                |m: &Mesh3d| (point_bounds(m.positions.iter().copied()), m.triangles.len());
            let drawn: Vec<(BuildingId, (Option<Bounds>, usize))> = (0..buildings.len() as u32)
                .into_par_iter()
                .filter_map(|i| {
                    let b = BuildingId(i);
                    let m = match &self.models[i as usize] {
                        Some(m) => measure(&m.full),
                        None => measure(&self.prism(b)?),
                    };
                    Some((b, m))
                })
                .collect();
            let triangles = drawn.iter().map(|(_, (_, t))| t).sum();
            let nodes = drawn.len();
            let root = tile_spatially_by(
                drawn,
                |&(_, m)| m,
                budget.max_features,
                budget.max_triangles,
            );
            let root = root.map(&|d: Vec<(BuildingId, (Option<Bounds>, usize))>| {
                TileRef::Buildings(d.into_iter().map(|(b, _)| b).collect())
            });
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
            let plan = TilePlan {
                tree: self,
                levels: None,
            };
            return (plan, root, vec![summary]);
        };
        let triangles = |level: usize, n: NodeId| -> usize {
            if level == 0 {
                self.prism_tris(h.levels[0].nodes[n.0 as usize].members[0])
            } else {
                let nm = &self.nodes[level - 1][n.0 as usize];
                nm.triangles + self.landmark_triangles(&h.levels[level].nodes[n.0 as usize], nm)
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
                    Some((node, nm)) => nm.triangles + landmark_triangles(node, nm),
                    None => triangles(level, n),
                },
            }
        };
        // Triangles a tile of `tile_level` draws for a node: as written, or as re-outlined for that tile when it
        // draws the node in a rough ancestor's stead.
        let drawn = |tile_level: usize, l: usize, n: NodeId| -> usize {
            // (A building has no landmarks.)
            match spent.demoted.get(&(l, n.0)).filter(|_| l < tile_level) {
                Some((node, nm)) => nm.triangles + landmark_triangles(node, nm),
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
        let below = |nodes: &[NodeId]| -> Vec<TileSpec<TileRef>> {
            self.model_chain(
                nodes
                    .iter()
                    .map(|n| h.levels[0].nodes[n.0 as usize].members[0])
                    .collect(),
            )
        };
        let mut root = assemble(
            &packing,
            &errors,
            &TileContent {
                tile: &TileRef::Packed,
                below_buildings: &below,
            },
        );
        lift_prism_leaves(&mut root);
        at_least_children(&mut root);
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
        let plan = TilePlan {
            tree: self,
            levels: Some(PlanLevels {
                h,
                packing,
                spent,
                tile_error,
                demoted_tile_error,
            }),
        };
        (plan, root, summary)
    }
}

/// Raises every tile's geometric error to its children's (returns it): a tile's error bounds what any cut below
/// it shows, and a model chain's simplified tile can claim more than the prisms' tile above it, where a
/// simplifier made models worse than their prisms (`--building-simplifier qem` on the roofs example: 8.7 m under
/// 6.0 m). The packing's tiles are monotone already ([`citylod_tiles::hlod::tile_errors`]).
fn at_least_children<C>(tile: &mut TileSpec<C>) -> f64 {
    let below = tile
        .children
        .iter_mut()
        .map(at_least_children)
        .fold(0.0, f64::max);
    tile.geometric_error_m = tile.geometric_error_m.max(below);
    tile.geometric_error_m
}

/// Moves the leaf of modelless prisms that [`LodTree::model_chain`] hangs under a tile of buildings up beside that
/// tile, which then holds only the buildings with a 3D model (heading their chain): a building without a model is
/// written once below the blocks, not in its tile and again in the leaf. The root keeps its leaf below it (a tree
/// needs one root).
fn lift_prism_leaves(tile: &mut TileSpec<TileRef>) {
    let mut children = Vec::with_capacity(tile.children.len());
    for mut child in std::mem::take(&mut tile.children) {
        lift_prism_leaves(&mut child);
        // A tile of buildings: its children are its model chain (and the leaf); a block tile's children are tiles of
        // the packing (and, once lifted, leaves that stay where they are).
        let heads_chain = child
            .children
            .iter()
            .any(|c| matches!(c.features, TileRef::Models { .. }));
        if let (TileRef::Packed(i), true) = (&child.features, heads_chain) {
            let i = *i;
            let leaf = child
                .children
                .iter()
                .position(|c| matches!(c.features, TileRef::Buildings(_)));
            if let Some(k) = leaf {
                let leaf = child.children.remove(k);
                child.features = TileRef::PackedModelled(i);
                children.push(child);
                children.push(leaf);
                continue;
            }
        }
        children.push(child);
    }
    tile.children = children;
}

/// What a tile of the tree [`LodTree::tiles`] plans holds, made into features only when the writer encodes the tile
/// ([`TilePlan::features`]), so a city's meshes are not held twice: a million buildings need ~1.5 GB less.
#[derive(Debug, Clone, PartialEq)]
pub enum TileRef {
    /// Tile `i` of the packing: the nodes it draws (its own, or a rough block's descendants in its stead).
    Packed(usize),
    /// Tile `i` of the packing, a tile of buildings, with only those that have a 3D model: the others' prisms are in a
    /// leaf tile beside it (`lift_prism_leaves`).
    PackedModelled(usize),
    /// The 3D models of these buildings below their prisms' tile: `full`, or simplified (the prism for a building
    /// without a model).
    Models { ids: Vec<BuildingId>, full: bool },
    /// Buildings of a tileset without levels (`--leaves-only`): their full models, else their prisms.
    Buildings(Vec<BuildingId>),
}

impl Default for TileRef {
    fn default() -> Self {
        TileRef::Buildings(Vec::new())
    }
}

/// The written levels' packing and what re-outlining spent, kept so each tile's features can be made when it is
/// written.
struct PlanLevels<'a> {
    h: &'a Hierarchy,
    packing: citylod_tiles::hlod::Packing,
    spent: Spent,
    /// The geometric error of the tile each node is written in, `[level][node]`.
    tile_error: Vec<Vec<f64>>,
    /// The error of the tile drawing a rough block's descendants in its stead, by (level, node) of the descendant.
    demoted_tile_error: HashMap<(usize, u32), f64>,
}

/// Everything needed to make any tile's features from its [`TileRef`].
pub struct TilePlan<'a> {
    tree: &'a LodTree<'a>,
    /// `None` without a hierarchy (`--leaves-only`).
    levels: Option<PlanLevels<'a>>,
}

impl TilePlan<'_> {
    /// The features of a tile, in the order the tile draws them.
    pub fn features(&self, r: &TileRef) -> Vec<ContentFeature> {
        let tree = self.tree;
        match r {
            TileRef::Buildings(ids) => ids
                .iter()
                .filter_map(|&b| match &tree.models[b.0 as usize] {
                    Some(m) => Some(
                        tree.building_table
                            .feature(&tree.buildings[b.0 as usize], m.full.clone()),
                    ),
                    None => tree.building_feature(b),
                })
                .collect(),
            TileRef::Models { ids, full } => ids
                .iter()
                .filter_map(|&b| {
                    let mesh = match &tree.models[b.0 as usize] {
                        Some(m) if *full => m.full.clone(),
                        Some(m) => m.simplified.clone(),
                        None => tree.prism(b)?,
                    };
                    Some(
                        tree.building_table
                            .feature(&tree.buildings[b.0 as usize], mesh),
                    )
                })
                .collect(),
            TileRef::Packed(i) | TileRef::PackedModelled(i) => {
                let Some(lv) = &self.levels else {
                    return Vec::new();
                };
                let modelled_only = matches!(r, TileRef::PackedModelled(_));
                let t = &lv.packing.tiles[*i];
                t.drawn
                    .iter()
                    .filter(|&&(level, n)| {
                        !modelled_only
                            || level != 0
                            || tree.models[lv.h.levels[0].nodes[n.0 as usize].members[0].0 as usize]
                                .is_some()
                    })
                    .flat_map(|&(level, n)| self.node_features(lv, t.level, level, n))
                    .collect()
            }
        }
    }

    /// A node as written in its own tile: re-outlined within the tile's error when it was.
    fn node_and_mesh<'s>(
        &'s self,
        lv: &'s PlanLevels,
        level: usize,
        n: NodeId,
    ) -> (&'s Node, &'s NodeMesh) {
        match &lv.spent.own[level - 1][n.0 as usize] {
            Some((node, nm)) => (node, nm),
            None => (
                &lv.h.levels[level].nodes[n.0 as usize],
                &self.tree.nodes[level - 1][n.0 as usize],
            ),
        }
    }

    /// The features of node `n` of `level` drawn in a tile of `tile_level` (greater when the tile draws it in a rough
    /// ancestor's stead): its block and the landmarks on it, or a building.
    fn node_features(
        &self,
        lv: &PlanLevels,
        tile_level: usize,
        level: usize,
        n: NodeId,
    ) -> Vec<ContentFeature> {
        let tree = self.tree;
        let demoted = tile_level > level;
        // A descendant drawn in a rough block's stead may be rounded, and was re-outlined, within the error
        // of the tile that draws it.
        let rounding_m = ROUNDING_SHARE
            * if demoted {
                // Every descendant a tile draws is in the map; 0 (the finest grid) is always safe.
                lv.demoted_tile_error
                    .get(&(level, n.0))
                    .copied()
                    .unwrap_or(0.0)
            } else {
                lv.tile_error[level][n.0 as usize]
            };
        if level == 0 {
            let b = lv.h.levels[0].nodes[n.0 as usize].members[0];
            if !demoted {
                return tree.building_feature(b).into_iter().collect();
            }
            // A building of a block too rough for its tile, drawn in the block's stead: the level-0 node as a
            // cluster-class feature of one member (one class per tile, for picking).
            let (node, mesh) = match lv.spent.demoted.get(&(0, n.0)) {
                Some((node, nm)) => (node.clone(), tree.block_mesh(node, nm)),
                None => {
                    let Some(mesh) = tree.prism(b) else {
                        return Vec::new();
                    };
                    (tree.drawn_node(lv.h, 0, n).into_owned(), mesh)
                }
            };
            let row = ClusterRow {
                level: 0,
                node_index: n.0,
                node: &node,
                source_id: Some(tree.buildings[b.0 as usize].source_id.as_str()),
                geometric_error_m: tree.node_error(&node).max(tree.prism_error(b)),
                fallback: false,
                max_rounding_m: rounding_m,
            };
            return vec![cluster_feature(row, mesh)];
        }
        let (node, nm) = match lv.spent.demoted.get(&(level, n.0)).filter(|_| demoted) {
            Some((node, nm)) => (node, nm),
            None => self.node_and_mesh(lv, level, n),
        };
        let source_id = (node.members.len() == 1).then(|| {
            tree.buildings[node.members[0].0 as usize]
                .source_id
                .as_str()
        });
        let row = ClusterRow {
            level,
            node_index: n.0,
            node,
            source_id,
            geometric_error_m: tree.drawn_error(node, nm),
            fallback: nm.fallback,
            max_rounding_m: rounding_m,
        };
        let mut out = vec![cluster_feature(row, tree.block_mesh(node, nm))];
        out.extend(tree.landmarks_of(node, nm).filter_map(|b| {
            let mesh = tree.prism(b)?;
            // Every vertex of the building, rounded like the block it stands on: a shift of under 5.4 % of
            // the tile's error is sub-pixel where the tile is drawn, and the tile keeps one grid, so one mesh
            // (NYC: 7 of 11 tiles had a second mesh for their landmarks; tileset 2 % smaller).
            Some(landmark_feature(
                level,
                n.0,
                &tree.buildings[b.0 as usize],
                mesh,
                tree.prism_error(b),
                rounding_m,
            ))
        }));
        out
    }
}

/// The buildings with a 3D model chain, by index.
fn chains(models: &[Option<ModelChain>]) -> Vec<(usize, &ModelChain)> {
    models
        .iter()
        .enumerate()
        .filter_map(|(i, m)| Some((i, m.as_ref()?)))
        .collect()
}

fn summarize_models(
    buildings: &[Building],
    models: &[Option<ModelChain>],
    rate: f64,
) -> Option<ModelSummary> {
    let chains = chains(models);
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
        prisms_drawn_as_simplified: chains
            .iter()
            .filter(|(_, m)| m.simplified_for_prism)
            .map(|(i, _)| buildings[*i].source_id.clone())
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model chain whose simplified tile claims more than the prisms' tile above it (a simplifier that made models
    /// worse than their prisms): every tile above is raised to it, the tiles beside and below keep theirs.
    #[test]
    fn a_tile_claims_at_least_what_its_children_do() {
        let tile = |e: f64, children: Vec<TileSpec<u32>>| TileSpec {
            features: 0,
            children,
            geometric_error_m: e,
        };
        let mut root = tile(
            20.0,
            vec![
                tile(6.0, vec![tile(8.7, vec![tile(0.0, vec![])])]),
                tile(3.0, vec![tile(0.0, vec![])]),
            ],
        );
        assert_eq!(at_least_children(&mut root), 20.0);
        let errors = |t: &TileSpec<u32>| {
            [
                t.children[0].geometric_error_m,
                t.children[0].children[0].geometric_error_m,
                t.children[0].children[0].children[0].geometric_error_m,
                t.children[1].geometric_error_m,
            ]
        };
        assert_eq!(errors(&root), [8.7, 8.7, 0.0, 3.0]);
        let mut low = tile(1.0, vec![tile(8.7, vec![])]);
        assert_eq!(at_least_children(&mut low), 8.7);
    }

    /// A chain whose simplified model has `simplified` triangles, with the given errors.
    fn chain(prism_error_m: f64, simplified_error_m: f64, simplified: usize) -> Option<ModelChain> {
        let mesh = |n: usize| Mesh3d {
            positions: vec![[0.0; 3]; 3],
            triangles: vec![[0, 1, 2]; n],
        };
        Some(ModelChain {
            full: mesh(2 * simplified),
            simplified: mesh(simplified),
            simplified_error_m,
            prism_error_m,
            rate_reached: 0.5,
            note: None,
            simplified_for_prism: false,
        })
    }

    #[test]
    fn only_prisms_far_rougher_than_the_median_give_way_within_the_triangle_share() {
        // Twenty buildings of 20-triangle prisms (400 in all, so 40 triangles may be added), median prism error 2 m.
        let mut models: Vec<Option<ModelChain>> = (0..20).map(|_| chain(2.0, 0.3, 30)).collect();
        models[3] = chain(50.0, 0.5, 30); // +10 triangles: chosen
        models[5] = chain(40.0, 0.5, 55); // +35: over what is left, passed over
        models[6] = chain(30.0, 0.4, 25); // +5: chosen
        models[7] = chain(6.5, 0.4, 21); // over 3 × 2 m, +1: chosen
        models[8] = chain(5.9, 0.4, 21); // under 3 × 2 m: a prism like the others
        models[9] = chain(20.0, 25.0, 21); // its simplified model is worse than its prism
        let prisms = vec![Some(20u32); 20];
        assert_eq!(rough_prisms(&models, &prisms), [3, 6, 7]);
        // Buildings without a model (a prism is all they have) are never chosen; none at all, nothing to do.
        assert!(rough_prisms(&[None, None], &[Some(20), Some(20)]).is_empty());
        // Prisms nearly as exact as their models (LoD1): over 3 × a median of 0 is not rough; over 1 m is.
        let mut models: Vec<Option<ModelChain>> = (0..20).map(|_| chain(0.0, 0.0, 20)).collect();
        models[2] = chain(0.6, 0.1, 20);
        models[4] = chain(1.5, 0.1, 20);
        assert_eq!(rough_prisms(&models, &prisms), [4]);
    }

    /// A model the simplifier leaves nothing of (the profile method finds no outward section in a box wound inside
    /// out, which ingest would have turned; infinite error) is drawn whole as its own simplified model, with a note
    /// (`simplify` returns it unchanged), instead of an infinite error failing the whole build.
    #[test]
    fn a_simplifier_that_leaves_nothing_gives_way_to_the_full_model() {
        use citylod_model::{Attributes, BuildingModel, HeightSource, SurfaceKind};
        use geo::{LineString, MultiPolygon, Polygon};
        let square = LineString::from(vec![
            (0.0, 0.0),
            (10.0, 0.0),
            (10.0, 10.0),
            (0.0, 10.0),
            (0.0, 0.0),
        ]);
        let corners: Vec<[f64; 3]> = (0..8)
            .map(|i| {
                let c = |bit: usize| if i & bit == 0 { 0.0 } else { 10.0 };
                [c(1), c(2), c(4)]
            })
            .collect();
        // The 12 triangles of the box (these quads face outwards), each then wound the other way.
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let triangles: Vec<[u32; 3]> = quads
            .iter()
            .flat_map(|q| [[q[0], q[2], q[1]], [q[0], q[3], q[2]]])
            .collect();
        let mesh = Mesh3d {
            positions: corners,
            triangles,
        };
        assert!(citylod_mesh::topology::signed_volume_m3(&mesh) < 0.0);
        let building = Building {
            id: BuildingId(0),
            source_id: "inside-out".into(),
            footprint: MultiPolygon(vec![Polygon::new(square, vec![])]),
            base_z_m: 0.0,
            height_m: 10.0,
            height_source: HeightSource::Storeys,
            attributes: Attributes::new(),
            mesh: Some(BuildingModel {
                surfaces: vec![SurfaceKind::Wall; mesh.triangles.len()],
                mesh,
                lod: "2.2".into(),
            }),
        };
        let opts = ModelOptions {
            simplifier: citylod_mesh::simplify::Simplifier::Profile {
                step_m: 1.0,
                threshold_m: 0.5,
            },
            rate: 0.6,
        };
        let buildings = [building];
        let tree = LodTree::build(&buildings, None, 1.41, 175.0, &opts);
        let chain = tree.models[0].as_ref().expect("a chain");
        assert_eq!(chain.simplified, chain.full);
        assert_eq!(chain.simplified_error_m, 0.0);
        let note = chain.note.as_deref().unwrap_or_default();
        assert!(note.contains("the full model is drawn instead"), "{note}");
    }
}
