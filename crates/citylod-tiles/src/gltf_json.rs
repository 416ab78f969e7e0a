//! The subset of glTF 2.0 JSON citylod writes and reads, with the extensions it uses
//! (KHR_mesh_quantization needs no JSON; EXT_meshopt_compression, KHR_draco_mesh_compression, EXT_mesh_features,
//! EXT_structural_metadata), as serde structs without logic. Maps are BTreeMaps: sorted, deterministic.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub const ARRAY_BUFFER: u32 = 34962;
pub const ELEMENT_ARRAY_BUFFER: u32 = 34963;
pub const BYTE: u32 = 5120;
pub const UNSIGNED_BYTE: u32 = 5121;
pub const SHORT: u32 = 5122;
pub const UNSIGNED_SHORT: u32 = 5123;
pub const UNSIGNED_INT: u32 = 5125;
pub const FLOAT: u32 = 5126;
pub const MODE_TRIANGLES: u32 = 4;
pub const MODE_TRIANGLE_STRIP: u32 = 5;
pub const MODE_TRIANGLE_FAN: u32 = 6;

pub const EXT_MESHOPT: &str = "EXT_meshopt_compression";
pub const KHR_DRACO: &str = "KHR_draco_mesh_compression";
pub const KHR_QUANTIZATION: &str = "KHR_mesh_quantization";
pub const EXT_MESH_FEATURES: &str = "EXT_mesh_features";
pub const EXT_STRUCTURAL_METADATA: &str = "EXT_structural_metadata";

fn is_zero(n: &usize) -> bool {
    *n == 0
}

fn is_false(b: &bool) -> bool {
    !*b
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Gltf {
    pub asset: Asset,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extensions_used: Vec<String>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extensions_required: Vec<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<usize>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub scenes: Vec<Scene>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub nodes: Vec<Node>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub meshes: Vec<Mesh>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<Material>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub accessors: Vec<Accessor>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub buffer_views: Vec<BufferView>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub buffers: Vec<Buffer>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extensions: Option<RootExtensions>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Asset {
    pub version: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generator: Option<String>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    #[serde(default)]
    pub nodes: Vec<usize>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Node {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<usize>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub children: Vec<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub matrix: Option<[f64; 16]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub translation: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<[f64; 4]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<[f64; 3]>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    pub primitives: Vec<Primitive>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Primitive {
    pub attributes: BTreeMap<String, usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub indices: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extensions: Option<PrimitiveExtensions>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PrimitiveExtensions {
    #[serde(
        rename = "EXT_mesh_features",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub mesh_features: Option<MeshFeatures>,
    #[serde(
        rename = "KHR_draco_mesh_compression",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub draco: Option<DracoPrimitive>,
}

/// KHR_draco_mesh_compression on a primitive: the compressed mesh and each glTF attribute's Draco
/// unique id.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct DracoPrimitive {
    pub buffer_view: usize,
    pub attributes: BTreeMap<String, u32>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct MeshFeatures {
    pub feature_ids: Vec<FeatureId>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct FeatureId {
    pub feature_count: usize,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub attribute: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub property_table: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub null_feature_id: Option<u32>,
    /// Feature ids from a texture, and the draft extension's `offset` and `repeat` (read only to refuse them;
    /// citylod writes attributes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<serde_json::Value>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<serde_json::Value>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub repeat: Option<serde_json::Value>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Material {
    /// Read with glTF's defaults for what a file leaves out (the reader ignores materials); always written.
    #[serde(default)]
    pub pbr_metallic_roughness: Pbr,
    #[serde(default, skip_serializing_if = "is_false")]
    pub double_sided: bool,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Pbr {
    #[serde(default = "white")]
    pub base_color_factor: [f64; 4],
    #[serde(default = "one")]
    pub metallic_factor: f64,
    #[serde(default = "one")]
    pub roughness_factor: f64,
}

/// glTF's defaults: white, fully metallic, fully rough.
impl Default for Pbr {
    fn default() -> Self {
        Pbr {
            base_color_factor: white(),
            metallic_factor: 1.0,
            roughness_factor: 1.0,
        }
    }
}

fn white() -> [f64; 4] {
    [1.0; 4]
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Accessor {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub buffer_view: Option<usize>,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub byte_offset: usize,
    pub component_type: u32,
    #[serde(default, skip_serializing_if = "is_false")]
    pub normalized: bool,
    pub count: usize,
    pub r#type: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<Vec<f64>>,
    /// Elements that differ from the base values (read only; citylod writes none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sparse: Option<Sparse>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Sparse {
    pub count: usize,
    pub indices: SparseIndices,
    pub values: SparseValues,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct SparseIndices {
    pub buffer_view: usize,
    #[serde(default)]
    pub byte_offset: usize,
    pub component_type: u32,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct SparseValues {
    pub buffer_view: usize,
    #[serde(default)]
    pub byte_offset: usize,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct BufferView {
    pub buffer: usize,
    #[serde(default)]
    pub byte_offset: usize,
    pub byte_length: usize,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub byte_stride: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extensions: Option<BufferViewExtensions>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BufferViewExtensions {
    /// Also read under KHR_meshopt_compression, the same layout (its codec and filter versions are the decoder's).
    #[serde(
        rename = "EXT_meshopt_compression",
        alias = "KHR_meshopt_compression",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub meshopt: Option<MeshoptView>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct MeshoptView {
    pub buffer: usize,
    #[serde(default)]
    pub byte_offset: usize,
    pub byte_length: usize,
    pub byte_stride: usize,
    pub count: usize,
    /// "ATTRIBUTES", "TRIANGLES" or "INDICES".
    pub mode: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub filter: Option<String>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Buffer {
    pub byte_length: usize,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uri: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extensions: Option<BufferExtensions>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BufferExtensions {
    #[serde(
        rename = "EXT_meshopt_compression",
        alias = "KHR_meshopt_compression",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub meshopt: Option<MeshoptBuffer>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshoptBuffer {
    #[serde(default)]
    pub fallback: bool,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RootExtensions {
    #[serde(
        rename = "EXT_structural_metadata",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub structural_metadata: Option<StructuralMetadata>,
    /// Cesium's relative-to-centre offset (read only; citylod places content with the tile transform).
    #[serde(
        rename = "CESIUM_RTC",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub cesium_rtc: Option<CesiumRtc>,
}

/// `CESIUM_RTC`: positions are relative to `center`, in the tile's z-up frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CesiumRtc {
    pub center: [f64; 3],
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct StructuralMetadata {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schema: Option<Schema>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub property_tables: Vec<PropertyTable>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Schema {
    pub id: String,
    #[serde(default)]
    pub classes: BTreeMap<String, Class>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Class {
    #[serde(default)]
    pub properties: BTreeMap<String, ClassProperty>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct ClassProperty {
    /// "SCALAR", "STRING", "BOOLEAN", …
    pub r#type: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub component_type: Option<String>,
    /// The name to show (citylod: the input attribute's, when the property id had to differ from it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub no_data: Option<serde_json::Value>,
    /// Read to refuse what the reader does not decode (citylod writes none of them): arrays, and values to be
    /// normalized, offset or scaled.
    #[serde(default, skip_serializing_if = "is_false")]
    pub array: bool,
    #[serde(default, skip_serializing_if = "is_false")]
    pub normalized: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<serde_json::Value>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<serde_json::Value>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PropertyTable {
    pub class: String,
    pub count: usize,
    #[serde(default)]
    pub properties: BTreeMap<String, PropertyTableProperty>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct PropertyTableProperty {
    pub values: usize,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub string_offsets: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub string_offset_type: Option<String>,
    /// A table's own offset and scale for the column (refused by the reader, like the class's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<serde_json::Value>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<serde_json::Value>,
}
