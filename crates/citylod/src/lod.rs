//! The level-of-detail tree of a build: every level of the hierarchy meshed (buildings as prisms, blocks as prisms
//! of their merged footprints), packed into tiles within the budget, with each tile's geometric error from the
//! measured Δh and Δa (DESIGN.md §4); a block's landmarks (seed 001) are `cluster` features flagged `landmark` beside it, in the same
//! content. Without a hierarchy (`--leaves-only`) the buildings alone, in leaf tiles.

use crate::build::LevelSummary;
use crate::features::{cluster_feature, landmark_feature, BuildingTable, ClusterRow};
use citylod_model::{Building, BuildingId, Hierarchy, Mesh3d, Node, NodeId};
use citylod_tiles::hlod::{assemble, pack, tile_errors, TileBudget};
use citylod_tiles::{tile_spatially, ContentFeature, TileSpec};
use rayon::prelude::*;

/// A block's mesh: its extruded merged footprint, or — when that fails — its buildings' own prisms.
struct NodeMesh {
    mesh: Mesh3d,
    fallback: bool,
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
    pub fn build(buildings: &[Building], hierarchy: Option<&'h Hierarchy>, kappa: f64) -> Self {
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
        Self {
            building_table: BuildingTable::new(buildings),
            buildings: building_meshes,
            failed_buildings,
            hierarchy,
            nodes,
            kappa,
        }
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

    fn building_feature(&self, buildings: &[Building], b: BuildingId) -> Option<ContentFeature> {
        let mesh = self.buildings[b.0 as usize].clone()?;
        Some(self.building_table.feature(&buildings[b.0 as usize], mesh))
    }

    /// The tile tree to write, and a summary per level.
    pub fn tiles(
        &self,
        buildings: &[Building],
        budget: TileBudget,
    ) -> (TileSpec, Vec<LevelSummary>) {
        let Some(h) = self.hierarchy else {
            let features: Vec<ContentFeature> = (0..buildings.len() as u32)
                .filter_map(|i| self.building_feature(buildings, BuildingId(i)))
                .collect();
            let triangles = features.iter().map(|f| f.mesh.triangles.len()).sum();
            let nodes = features.len();
            let root = tile_spatially(features, budget.max_features, budget.max_triangles);
            let summary = LevelSummary {
                level: 0,
                nodes,
                tiles: root.count_tiles(),
                triangles,
                geometric_error_min_m: 0.0,
                geometric_error_max_m: 0.0,
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
                    + self
                        .landmarks_of(&h.levels[level].nodes[n.0 as usize], nm)
                        .map(|b| {
                            self.buildings[b.0 as usize]
                                .as_ref()
                                .map_or(0, |m| m.triangles.len())
                        })
                        .sum::<usize>()
            }
        };
        let error = |level: usize, n: NodeId| -> f64 {
            if level == 0 {
                0.0
            } else {
                self.node_error(&h.levels[level].nodes[n.0 as usize])
            }
        };
        let packing = pack(h, &triangles, budget);
        debug_assert!(citylod_tiles::hlod::check_packing(h, &packing).is_empty());
        let errors = tile_errors(&packing, &error);
        let features = |level: usize, n: NodeId| -> Vec<ContentFeature> {
            let node = &h.levels[level].nodes[n.0 as usize];
            if level == 0 {
                return self
                    .building_feature(buildings, node.members[0])
                    .into_iter()
                    .collect();
            }
            let nm = &self.nodes[level - 1][n.0 as usize];
            let source_id = (node.members.len() == 1)
                .then(|| buildings[node.members[0].0 as usize].source_id.as_str());
            let row = ClusterRow {
                level,
                node_index: n.0,
                node,
                source_id,
                geometric_error_m: self.node_error(node),
                fallback: nm.fallback,
            };
            let mut out = vec![cluster_feature(row, nm.mesh.clone())];
            out.extend(self.landmarks_of(node, nm).filter_map(|b| {
                let mesh = self.buildings[b.0 as usize].clone()?;
                Some(landmark_feature(level, n.0, &buildings[b.0 as usize], mesh))
            }));
            out
        };
        let root = assemble(&packing, &errors, &features);
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
                    triangles: (0..n as u32).map(|i| triangles(level, NodeId(i))).sum(),
                    geometric_error_min_m: errs
                        .iter()
                        .copied()
                        .fold(f64::INFINITY, f64::min)
                        .min(f64::MAX),
                    geometric_error_max_m: errs.iter().copied().fold(0.0, f64::max),
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
