//! Generalization of building footprints into a hierarchy of legible blocks (seed 000, Yang et al. 2011).
//!
//! Buildings (footprints in local ENU metres) are clustered by single-link on the *adjacent distance*
//! over a sparse candidate graph; the dendrogram is condensed into L ≈ log₂ n / 1.5 balanced levels;
//! each cluster's footprint is the children bridged, unioned and simplified, with its Δh and Δa.
//!
//! Modules (one algorithm each):
//! - `adjacent`     — adjacent distance d = d_min·(1 − N·λ) and the convex-hull reduction (§3.1)
//! - `graph`        — sparse candidate graph: R-tree neighbours plus Delaunay edges between buildings
//! - `single_link`  — Kruskal single-link clustering → dendrogram
//! - `levels`       — condensing the dendrogram into levels and balancing them (§3.3.2)
//! - `merge`        — merging footprints through constrained-Delaunay connection pairs (§3.2), then
//!   bridging the islands left within the level's reach so a cluster has one outline
//! - `simplify`     — removing small or sliver concave triangles and near-collinear vertices (§3.2)
//! - `stats`        — per-node height (Eq. 5), h_min, h_max, Δh, Δa
//! - `streets`      — street centre lines as barriers: edges across a street join only above a level
//! - `dump`         — GeoJSON and PNG pictures of every level
//! - `hierarchy`    — the `generalize` entry point tying the stages together, and the landmark rule
//!   (seed 001: members far taller than their block are drawn apart and left out of its Δh)
//!
//! ```
//! use citylod_generalize::{generalize, GeneralizeOptions};
//! use citylod_model::{Building, BuildingId, HeightSource};
//! use geo_types::{polygon, MultiPolygon};
//! let house = |i: u32, x: f64| Building {
//!     id: BuildingId(i), source_id: format!("h{i}"),
//!     footprint: MultiPolygon(vec![polygon![(x: x, y: 0.), (x: x + 8., y: 0.), (x: x + 8., y: 10.), (x: x, y: 10.)]]),
//!     base_z_m: 0.0, height_m: 9.0, height_source: HeightSource::Default,
//!     attributes: Default::default(), mesh: None,
//! };
//! let city: Vec<Building> = (0..12).map(|i| house(i, i as f64 * 10.0 + if i >= 6 { 40.0 } else { 0.0 })).collect();
//! let g = generalize(&city, &GeneralizeOptions::default()).unwrap();
//! assert!(g.hierarchy.check_invariants(city.len()).is_empty());
//! assert_eq!(g.hierarchy.levels.last().unwrap().nodes.len(), 1);
//! ```

mod adjacent;
mod dump;
mod graph;
mod hierarchy;
mod levels;
mod merge;
mod simplify;
mod single_link;
mod stats;
pub mod streets;

pub use adjacent::{adjacent_distance, adjacent_distance_brute_force, Adjacency};
pub use dump::{dump_levels, is_dump_file_name, DumpError};
pub use graph::{
    auto_reach_m, candidate_graph, candidate_pairs, refine_pairs, weigh_pairs, CandidateEdge,
    GraphStats,
};
pub use hierarchy::{
    cluster, generalize, generalize_with_streets, island_reach_m, landmarks_of, GeneralizeError,
    GeneralizeOptions, GeneralizeReport, Generalized, LevelReport, PhaseTimings,
    StreetBarrierReport,
};
pub use levels::{condense, target_levels, LevelKind, LevelOptions, LevelPlan, PlannedLevel};
pub use merge::{merge_footprints, merge_footprints_weighted, MergeResult, ADJACENT_LAMBDA};
pub use simplify::{
    fill_concave_within, reoutline_within, simplify_footprint, Reoutlined, CONVEX_COLLINEAR_TOL_M,
    SLIVER_FACTOR,
};
pub use single_link::{single_link, Merge};
pub use stats::{node_stats, NodeStats};
