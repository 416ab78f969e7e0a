//! The data model every citylod stage shares: buildings in a local east-north-up frame, the levels of
//! the generalization hierarchy, and the frame that places them on the globe. No I/O, no algorithms.
//!
//! ```
//! use citylod_model::LocalFrame;
//! let frame = LocalFrame::new(4.3571, 52.0116, 0.0); // Delft
//! let p = frame.geodetic_to_enu(4.3571, 52.0116, 10.0);
//! assert!(p[0].abs() < 1e-6 && p[1].abs() < 1e-6 && (p[2] - 10.0).abs() < 1e-6);
//! ```

mod attr;
mod building;
mod frame;
mod hierarchy;

pub use attr::{ambiguous_comma, AttrValue, Attributes};
pub use building::{
    footprint_area_m2, Building, BuildingId, BuildingModel, Footprint, HeightSource, Mesh3d,
    SurfaceKind,
};
pub use frame::{ecef_to_geodetic, geodetic_to_ecef, LocalFrame, WGS84_A_M, WGS84_F};
pub use hierarchy::{Hierarchy, Level, Node, NodeId};
