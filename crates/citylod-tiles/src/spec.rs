//! What the writer is asked to write: a tree of tiles holding features (a mesh in local ENU metres,
//! a class and one value per property of the class), and the metadata schema the classes come from.
//! Invariant checked by [`MetadataSchema::validate`]: ids match `^[a-zA-Z_][a-zA-Z0-9_]*$`, unique.

use crate::TilesError;
use citylod_model::Mesh3d;

/// Type of one property, as stored in the property tables (EXT_structural_metadata).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PropertyKind {
    /// UTF-8 text; null is written as the empty string (the `noData` value).
    String,
    /// IEEE 754 double; null is written as `f64::MIN` (the `noData` value).
    Float64,
    /// IEEE 754 single (rounded to nearest from the f64 given); null is written as `f32::MIN`.
    Float32,
    /// Signed 32-bit integer; null is written as `i32::MIN` (the `noData` value).
    Int32,
    /// Signed 64-bit integer; null is written as `i64::MIN` (the `noData` value).
    Int64,
    /// Unsigned 32-bit integer; null is written as `u32::MAX` (the `noData` value).
    UInt32,
    /// A bit per feature; the spec gives booleans no `noData`, so null is written as `false`.
    Boolean,
}

impl PropertyKind {
    /// Whether an `Int32` column holds `v`: in range and not `i32::MIN`, its `noData` value.
    pub fn int32_holds(v: i64) -> bool {
        v > i32::MIN as i64 && v <= i32::MAX as i64
    }
}

/// One property of a class.
#[derive(Debug, Clone, PartialEq)]
pub struct PropertyDef {
    /// Property id: `^[a-zA-Z_][a-zA-Z0-9_]*$` (sanitize attribute names before; keep the original
    /// name in `description` if it matters).
    pub name: String,
    pub kind: PropertyKind,
    /// Documentation: written to the schema document ([`crate::schema_to_json`]), not into every glb.
    pub description: Option<String>,
    /// Whether features may have no value: only then does the schema declare a `noData` value (strings and
    /// numbers), and a null for a property that is not nullable is an error.
    pub nullable: bool,
    /// The `noData` of a nullable STRING property; `None` is `""`. A column whose values include the empty string
    /// needs another one, or those values would read back as missing.
    pub string_no_data: Option<String>,
    /// The attribute's name in the input when `name` had to differ from it (`building:levels` →
    /// `building_levels`): written as the schema property's `name`, what a client may show for it.
    pub input_name: Option<String>,
}

/// A class of features ("building", later "cluster").
#[derive(Debug, Clone, PartialEq)]
pub struct ClassDef {
    /// Class id, same rule as property ids.
    pub id: String,
    pub properties: Vec<PropertyDef>,
}

/// The metadata schema written inline in every glb.
#[derive(Debug, Clone, PartialEq)]
pub struct MetadataSchema {
    /// Schema id, same rule as property ids.
    pub id: String,
    pub classes: Vec<ClassDef>,
}

/// One property value of one feature. The writer converts between numeric variants when the value
/// fits the property's kind (an `Int` for a `Float64`, an integral `Float` for an `Int64`) and writes
/// any non-null value as text for a `String` property.
#[derive(Debug, Clone, PartialEq)]
pub enum PropValue {
    Null,
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
}

/// One feature of a tile: its mesh, its class (index into `MetadataSchema::classes`) and one value
/// per property of that class, in the class's order.
#[derive(Debug, Clone, PartialEq)]
pub struct ContentFeature {
    /// Triangles in local ENU metres (x east, y north, z up), counter-clockwise seen from outside.
    pub mesh: Mesh3d,
    pub class: usize,
    pub values: Vec<PropValue>,
    /// How far (m, per axis) the writer may move this feature's vertices when it rounds them to its grid: 0
    /// for exact geometry (buildings in leaf tiles, 3D models), which gets the finest grid
    /// ([`crate::WriteOptions::quantization_step_m`]); a feature of a tile that is refined away when its error
    /// shows — a generalized block, a landmark on it — may take a share of that error. The grid is a
    /// power-of-two multiple of the finest one with half a step ≤ this.
    pub max_rounding_m: f64,
}

/// A tile: the features drawn when it is selected, its children (which REPLACE it when refined),
/// and its geometric error (m). A tile without features has no content.
///
/// `C` is what the tile holds: its features (the default), or — for a city too big to hold every tile's meshes at
/// once — a description the caller turns into features when the writer encodes that tile
/// ([`crate::write_tileset_with`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TileSpec<C = Vec<ContentFeature>> {
    pub features: C,
    pub children: Vec<TileSpec<C>>,
    pub geometric_error_m: f64,
}

impl<C> TileSpec<C> {
    /// The same tree with `f` applied to what every tile holds.
    pub fn map<D>(self, f: &impl Fn(C) -> D) -> TileSpec<D> {
        TileSpec {
            features: f(self.features),
            children: self.children.into_iter().map(|c| c.map(f)).collect(),
            geometric_error_m: self.geometric_error_m,
        }
    }

    /// Number of tiles in this subtree, this one included.
    pub fn count_tiles(&self) -> usize {
        1 + self
            .children
            .iter()
            .map(TileSpec::count_tiles)
            .sum::<usize>()
    }
}

/// True for a valid 3D Tiles metadata id.
pub fn is_id(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

impl MetadataSchema {
    /// Checks ids and their uniqueness; reports every problem found.
    pub fn validate(&self) -> Result<(), TilesError> {
        let mut errs = Vec::new();
        if !is_id(&self.id) {
            errs.push(format!("schema id {:?} is not an identifier", self.id));
        }
        let mut class_ids = std::collections::BTreeSet::new();
        for c in &self.classes {
            if !is_id(&c.id) {
                errs.push(format!("class id {:?} is not an identifier", c.id));
            }
            if !class_ids.insert(&c.id) {
                errs.push(format!("class id {:?} appears twice", c.id));
            }
            let mut names = std::collections::BTreeSet::new();
            for p in &c.properties {
                if !is_id(&p.name) {
                    errs.push(format!(
                        "class {}: property {:?} is not an identifier",
                        c.id, p.name
                    ));
                }
                if !names.insert(&p.name) {
                    errs.push(format!(
                        "class {}: property {:?} appears twice",
                        c.id, p.name
                    ));
                }
            }
        }
        if errs.is_empty() {
            Ok(())
        } else {
            Err(TilesError::Schema(errs.join("; ")))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_and_duplicate_ids_are_all_reported() {
        let schema = MetadataSchema {
            id: "citylod".into(),
            classes: vec![ClassDef {
                id: "building".into(),
                properties: vec![
                    PropertyDef {
                        name: "building:height".into(),
                        kind: PropertyKind::Float64,
                        description: None,
                        nullable: true,
                        string_no_data: None,
                        input_name: None,
                    },
                    PropertyDef {
                        name: "a".into(),
                        kind: PropertyKind::String,
                        description: None,
                        nullable: true,
                        string_no_data: None,
                        input_name: None,
                    },
                    PropertyDef {
                        name: "a".into(),
                        kind: PropertyKind::String,
                        description: None,
                        nullable: true,
                        string_no_data: None,
                        input_name: None,
                    },
                ],
            }],
        };
        let msg = schema.validate().unwrap_err().to_string();
        assert!(
            msg.contains("building:height") && msg.contains("twice"),
            "{msg}"
        );
        assert!(is_id("_x9") && !is_id("9x") && !is_id(""));
    }
}
