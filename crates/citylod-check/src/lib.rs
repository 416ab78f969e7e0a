//! citylod-check proves citylod's promise by drawing it (DESIGN.md §6): for a camera it finds the cut a
//! standard 3D Tiles client draws ([`select`]), renders scenes headless with wgpu ([`Renderer`]) and
//! compares the cut's picture with full detail ([`compare`]). Root ENU frame (x east, y north, z up), m.
//!
//! ```
//! use citylod_check::{select, Camera, OrientedBox, TileNode, TileTree, Viewport};
//! let tree = TileTree {
//!     tiles: vec![TileNode {
//!         bounds: OrientedBox::from_min_max([-100.0, -100.0, 0.0], [100.0, 100.0, 30.0]),
//!         geometric_error_m: 0.0,
//!         children: vec![],
//!         has_content: true,
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
mod error;
mod image;
mod render;
mod scene;
mod select;
mod sheet;
mod vec3;
mod views;

pub use camera::{Camera, Viewport, NEAR_M};
pub use compare::{
    compare, ImageMetrics, COLOUR_TOLERANCE, DIFF_ADDED, DIFF_RECOLOURED, DIFF_REMOVED,
};
pub use error::CheckError;
pub use image::Image;
pub use render::{RenderLayers, Renderer, NO_FEATURE, SKY};
pub use scene::{box_mesh, Scene};
pub use select::{
    compute_sse, meets_threshold, select, OrientedBox, Selection, TileNode, TileTree,
};
pub use sheet::contact_sheet;
pub use views::{standard_views, STANDARD_FOVY_DEG, STREET_HEIGHT_M};
