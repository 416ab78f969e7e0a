//! Triangle meshes for buildings and clusters, in local ENU metres (x east, y north, z up).
//!
//! LoD1 prisms ([`extrude`]) — walls per ring edge and a roof cap with holes; LoD2 simplification
//! ([`simplify`]: seed 003 topology-preserving QEM within an error bound, seed 004 profiles, plain QEM);
//! the measured error of a simplified mesh ([`hausdorff`]); topology checks ([`topology`]).
//!
//! ```
//! use geo_types::{polygon, MultiPolygon};
//! let square = MultiPolygon(vec![polygon![(x: 0.0, y: 0.0), (x: 10.0, y: 0.0), (x: 10.0, y: 10.0), (x: 0.0, y: 10.0)]]);
//! let mesh = citylod_mesh::extrude(&square, 2.0, 12.0).unwrap();
//! assert_eq!(mesh.triangles.len(), 4 * 2 + 2); // four wall quads, a two-triangle roof
//! ```

mod extrude;
pub mod hausdorff;
mod ring;
pub mod roof;
pub mod simplify;
pub mod topology;

pub use extrude::{extrude, MeshError};
pub use ring::signed_area2;
