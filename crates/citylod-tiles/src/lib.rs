//! 3D Tiles 1.1 output: a tree of tiles ([`TileSpec`]) becomes `tileset.json` (split into external
//! tilesets past a size limit) plus one glb per tile with content (KHR_mesh_quantization,
//! EXT_meshopt_compression or KHR_draco_mesh_compression, EXT_mesh_features,
//! EXT_structural_metadata), written atomically through a [`Staging`] directory. [`read`] loads it
//! back (tests and the checker). Frames: meshes in local ENU metres; DESIGN.md §2 and §5.
//!
//! ```
//! use citylod_model::{LocalFrame, Mesh3d};
//! use citylod_tiles::*;
//! let schema = MetadataSchema {
//!     id: "citylod".into(),
//!     classes: vec![ClassDef {
//!         id: "building".into(),
//!         properties: vec![PropertyDef { name: "name".into(), kind: PropertyKind::String, description: None, nullable: false, string_no_data: None, input_name: None }],
//!     }],
//! };
//! let mesh = Mesh3d { positions: vec![[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [0.0, 5.0, 3.0]], triangles: vec![[0, 1, 2]] };
//! let features = vec![ContentFeature { mesh, class: 0, values: vec![PropValue::Str("hall".into())], max_rounding_m: 0.0 }];
//! let root = tile_spatially(features, 100, 100_000);
//! let dir = tempfile::tempdir().unwrap();
//! let out = Staging::create(&dir.path().join("tileset")).unwrap();
//! let stats = write_tileset(&out, &root, &LocalFrame::new(4.36, 52.0, 0.0), &schema, &WriteOptions::default()).unwrap();
//! out.write_file("build-report.json", b"{}").unwrap(); // extra files go in before the commit
//! out.commit().unwrap();
//! assert_eq!(stats.triangles, 1);
//! let back = read::read_tileset(&dir.path().join("tileset/tileset.json")).unwrap();
//! assert_eq!(back.tiles[0].content.as_ref().unwrap().features[0].values["name"], PropValue::Str("hall".into()));
//! ```

mod bounding_volume;
mod content;
mod draco;
mod error;
mod external;
mod glb;
mod gltf_json;
pub mod hlod;
mod implicit;
mod legacy;
mod metadata;
pub mod read;
mod shading;
mod spec;
mod staging;
pub mod tileset_json;
mod tiling;
mod write;

pub use content::{bounds as point_bounds, Bounds};
pub use error::TilesError;
pub use metadata::{schema_to_json, FeatureRow};
pub use spec::{
    is_id, ClassDef, ContentFeature, MetadataSchema, PropValue, PropertyDef, PropertyKind, TileSpec,
};
pub use staging::{LeftBehind, Staging, INSIDE_PREFIX as STAGING_INSIDE_PREFIX};
pub use tiling::{tile_spatially, tile_spatially_by};
pub use write::{
    generator, write_tileset, write_tileset_with, written_by_citylod, Compression, WriteOptions,
    WriteStats,
};
