//! The subset of 3D Tiles 1.1 `tileset.json` citylod writes and reads, as serde structs (no logic).
//! Boxes are 12 numbers in the tile's frame (z up): centre, then the x, y and z half-axis vectors.
//! Transforms are 4×4 column-major.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Tileset {
    pub asset: Asset,
    pub geometric_error: f64,
    /// Application data; citylod writes `{"citylod": {…}}` here when asked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extras: Option<serde_json::Value>,
    pub root: Tile,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Asset {
    pub version: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generator: Option<String>,
    /// Before 3D Tiles 1.0 a tileset could say its glTF content was not y-up (read only, to refuse it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gltf_up_axis: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Tile {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transform: Option<[f64; 16]>,
    pub bounding_volume: BoundingVolume,
    pub geometric_error: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refine: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub content: Option<Content>,
    /// 3D Tiles 1.1 multiple contents (exclusive with `content`); citylod writes `content` only.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub contents: Vec<Content>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub children: Vec<Tile>,
    /// 3D Tiles 1.1 implicit tiling (read only; see `implicit.rs`); citylod writes explicit trees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub implicit_tiling: Option<serde_json::Value>,
    /// Extensions (read only: `3DTILES_implicit_tiling`, the 1.0 form of `implicitTiling`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extensions: Option<serde_json::Value>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoundingVolume {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r#box: Option<[f64; 12]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<[f64; 6]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sphere: Option<[f64; 4]>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Content {
    pub uri: String,
}
