//! The generalization hierarchy (seed 000 §3.3): level 0 holds one node per building; every level above
//! partitions all buildings into clusters. Invariant (checked by `check_invariants`): each level is a
//! partition of every building, and each node's children partition its members among the level below.

use crate::building::{BuildingId, Footprint};

/// Index of a node within its level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
pub struct NodeId(pub u32);

/// A cluster of buildings at one level.
#[derive(Debug, Clone)]
pub struct Node {
    /// Children: indices of nodes in the level below (empty at level 0).
    pub children: Vec<NodeId>,
    /// Every building under this node, sorted.
    pub members: Vec<BuildingId>,
    /// The merged and simplified footprint (local ENU m).
    pub footprint: Footprint,
    /// Area-weighted mean height of the (non-landmark) members (m), seed 000 Eq. 5.
    pub height_m: f64,
    /// Area-weighted mean base height of the members (m).
    pub base_z_m: f64,
    pub h_min_m: f64,
    pub h_max_m: f64,
    /// Δh = h_max − h_min over non-landmark members (m).
    pub dh_m: f64,
    /// Δa = area(footprint) − Σ area(members) (m²), ≥ 0.
    pub da_m2: f64,
    /// Area of the node footprint (m²).
    pub area_m2: f64,
    /// Members drawn at full detail on top of this node's block (seed 001); empty if none.
    pub landmarks: Vec<BuildingId>,
}

/// One level of the hierarchy.
#[derive(Debug, Clone, Default)]
pub struct Level {
    /// The adjacent-distance threshold (m) that produced this level (0 for the buildings).
    pub threshold_m: f64,
    pub nodes: Vec<Node>,
}

/// Levels from the buildings (index 0) up to the coarsest level (last).
#[derive(Debug, Clone, Default)]
pub struct Hierarchy {
    pub levels: Vec<Level>,
}

impl Hierarchy {
    /// Checks the partition invariants and returns every violation found (empty when sound).
    pub fn check_invariants(&self, n_buildings: usize) -> Vec<String> {
        let mut errs = Vec::new();
        for (li, level) in self.levels.iter().enumerate() {
            let mut seen = vec![false; n_buildings];
            for (ni, node) in level.nodes.iter().enumerate() {
                for &BuildingId(b) in &node.members {
                    match seen.get_mut(b as usize) {
                        None => {
                            errs.push(format!("level {li} node {ni}: building {b} out of range"))
                        }
                        Some(s) if *s => {
                            errs.push(format!("level {li}: building {b} in two nodes"))
                        }
                        Some(s) => *s = true,
                    }
                }
                if li > 0 {
                    let below = &self.levels[li - 1];
                    let mut m: Vec<BuildingId> = Vec::new();
                    for &NodeId(c) in &node.children {
                        match below.nodes.get(c as usize) {
                            Some(child) => m.extend_from_slice(&child.members),
                            None => {
                                errs.push(format!("level {li} node {ni}: child {c} out of range"))
                            }
                        }
                    }
                    m.sort();
                    if m != node.members {
                        errs.push(format!(
                            "level {li} node {ni}: children do not partition its members"
                        ));
                    }
                }
                if node.dh_m < 0.0 || node.da_m2 < -1e-6 {
                    errs.push(format!("level {li} node {ni}: negative Δh or Δa"));
                }
            }
            if let Some(b) = seen.iter().position(|s| !s) {
                errs.push(format!("level {li}: building {b} missing"));
            }
        }
        errs
    }
}
