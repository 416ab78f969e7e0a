//! citylod-check proves citylod's promise by drawing it (DESIGN.md §6): for a camera it finds the cut a
//! standard 3D Tiles client draws ([`select`]), renders scenes headless with wgpu ([`Renderer`]) and
//! compares the cut's picture with full detail ([`compare`]). Root ENU frame (x east, y north, z up), m.
//! A decoded tileset becomes a [`LoadedTileset`]; [`check_tree`] validates it once and
//! [`check_view`] validates, renders and compares the cut of one camera (coverage, seed criterion).
//!
//! ```
//! use citylod_check::{select, Camera, OrientedBox, TileNode, TileTree, Viewport};
//! let tree = TileTree {
//!     tiles: vec![TileNode {
//!         bounds: OrientedBox::from_min_max([-100.0, -100.0, 0.0], [100.0, 100.0, 30.0]),
//!         geometric_error_m: 0.0,
//!         children: vec![],
//!         has_content: true,
//!         external_tileset: false,
//!     }],
//!     root: 0,
//!     tileset_geometric_error_m: 500.0,
//! };
//! let camera = Camera::from_enu([0.0, -400.0, 300.0], 0.0, -35.0, 45.0).unwrap();
//! let cut = select(&tree, &camera, Viewport::new(1024, 768), 16.0);
//! assert_eq!(cut.selected, vec![0]);
//! ```

mod camera;
mod compare;
mod coverage;
mod criterion;
mod error;
mod finding;
mod image;
mod measured;
mod render;
mod scene;
mod select;
mod sheet;
mod tileset;
mod vec3;
mod view_check;
mod views;
mod volumes;

pub use camera::{globe_enu_axes, Camera, Viewport, NEAR_M};
pub use compare::{
    compare, ImageMetrics, COLOUR_TOLERANCE, DIFF_ADDED, DIFF_RECOLOURED, DIFF_REMOVED,
};
pub use coverage::{check_cut, check_features_drawn, check_tree};
pub use criterion::{check_criterion, view_error, CriterionStats, Tolerances, ViewError};
pub use error::CheckError;
pub use finding::{Finding, FindingKind, MAX_LISTED};
pub use image::Image;
pub use measured::check_measured;
pub use render::{Canvas, RenderLayers, Renderer, NO_FEATURE, SKY};
pub use scene::{box_mesh, Scene};
pub use select::{
    compute_sse, meets_threshold, select, OrientedBox, Selection, TileNode, TileTree,
};
pub use sheet::contact_sheet;
pub use tileset::{BlockHeights, FeatureInfo, LoadedTileset, NodeRef, TileInfo};
pub use view_check::{
    check_view, skyline, CheckSettings, Skyline, ViewOutcome, SKYLINE_TOLERANCE_PX,
};
pub use views::{
    standard_views, standard_views_over, NoContent, ViewContent, EYE_CLEARANCE_M,
    EYE_CLEARANCE_RADIUS_M, STANDARD_FOVY_DEG, STREET_HEIGHT_M,
};
pub use volumes::check_volumes;
