//! The `building` metadata class of a build: fixed properties (source id, citylod's building index, height)
//! followed by every input attribute, its type inferred over all buildings (boolean; integer, as INT32 while
//! every value fits; other number; else string),
//! and the per-building rows of that table. Property ids are the attribute names made safe for
//! EXT_structural_metadata (`[A-Za-z_][A-Za-z0-9_]*`); a renamed attribute keeps its original name in the
//! property's description.

use citylod_model::{AttrValue, Building, Mesh3d};
use citylod_tiles::{
    ClassDef, ContentFeature, MetadataSchema, PropValue, PropertyDef, PropertyKind,
};
use std::collections::{BTreeMap, BTreeSet};

pub struct BuildingTable {
    class: ClassDef,
    /// (attribute name, inferred kind), in the class's property order after the fixed properties.
    attrs: Vec<(String, PropertyKind)>,
    /// Attributes without a column of their own, written together as one JSON object per building in the
    /// last property (sorted by name; empty when every attribute has its column).
    folded: BTreeSet<String>,
}

/// An input attribute that fewer than this share of the buildings have gets no column of its own: every column
/// costs each glb its schema entry, table entry and buffer view, and a row in every building's table, so data
/// whose features each carry a few rare keys (OpenStreetMap tags) would otherwise write thousands of mostly empty
/// columns into every tile (10,000 buildings with 10 of 3,000 keys each: 36 MB of tiles from 4.6 MB of input).
pub const MIN_COLUMN_SHARE: f64 = 0.01;

/// At most this many attribute columns, the most widely held first (ties by name); the rest are folded too.
pub const MAX_ATTRIBUTE_COLUMNS: usize = 256;

/// The property holding the folded attributes (made unique like the others).
const FOLDED_PROPERTY: &str = "other_attributes";

/// What became of the input attributes: for the build report.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AttributeSummary {
    /// Attributes with a column of their own.
    pub columns: usize,
    /// The property holding the others as a JSON object (absent when there are none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub folded_property: Option<String>,
    /// The attributes folded into it, sorted.
    pub folded: Vec<String>,
    /// Attributes whose names are no property id (`building:levels`, `höhe`, `1st`) or clash with one: input name →
    /// the property id written (the schema's description of that property names the input attribute too).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub renamed: BTreeMap<String, String>,
}

const FIXED: [(&str, PropertyKind, &str); 5] = [
    (
        "source_id",
        PropertyKind::String,
        "the feature's id in the input",
    ),
    (
        "building_index",
        PropertyKind::UInt32,
        "citylod's index of the building (input order)",
    ),
    (
        "height_m",
        PropertyKind::Float64,
        "height above the ground, metres",
    ),
    (
        "ground_z_m",
        PropertyKind::Float64,
        "ground height in the tileset's local frame, metres",
    ),
    (
        "height_source",
        PropertyKind::String,
        "which rule gave the height",
    ),
];

impl BuildingTable {
    pub fn new(buildings: &[Building]) -> Self {
        let mut kinds: BTreeMap<&str, Option<PropertyKind>> = BTreeMap::new();
        // Buildings with a value (not null) per attribute.
        let mut present: BTreeMap<&str, usize> = BTreeMap::new();
        // Buildings that hold a value of the attribute ([`is_value`]).
        let mut held: BTreeMap<&str, usize> = BTreeMap::new();
        // Attributes some building has as the empty string.
        let mut empty: BTreeSet<&str> = BTreeSet::new();
        for b in buildings {
            for (k, v) in &b.attributes {
                if matches!(v, AttrValue::String(s) if s.is_empty()) {
                    empty.insert(k.as_str());
                }
                *held.entry(k.as_str()).or_default() += usize::from(is_value(v));
                let seen = kinds.entry(k.as_str()).or_insert(None);
                let this = match v {
                    AttrValue::Null => continue,
                    AttrValue::Bool(_) => PropertyKind::Boolean,
                    AttrValue::Int(i) if PropertyKind::int32_holds(*i) => PropertyKind::Int32,
                    AttrValue::Int(_) => PropertyKind::Int64,
                    AttrValue::Float(_) => PropertyKind::Float64,
                    AttrValue::String(_) => PropertyKind::String,
                };
                *present.entry(k.as_str()).or_default() += 1;
                *seen = Some(match (*seen, this) {
                    (None, _) => this,
                    (Some(prev), _) if prev == this => prev,
                    // Integers past 32 bits make the column INT64 (a double holds them exactly only to 2^53);
                    // integers mixed with other numbers are all written as doubles.
                    (
                        Some(PropertyKind::Int32 | PropertyKind::Int64),
                        PropertyKind::Int32 | PropertyKind::Int64,
                    ) => PropertyKind::Int64,
                    (
                        Some(PropertyKind::Int32 | PropertyKind::Int64 | PropertyKind::Float64),
                        PropertyKind::Int32 | PropertyKind::Int64 | PropertyKind::Float64,
                    ) => PropertyKind::Float64,
                    (Some(_), _) => PropertyKind::String,
                });
            }
        }
        let mut used: BTreeSet<String> = FIXED.iter().map(|f| f.0.to_string()).collect();
        let mut properties: Vec<PropertyDef> = FIXED
            .iter()
            .map(|&(id, kind, desc)| PropertyDef {
                name: id.to_string(),
                kind,
                description: Some(desc.to_string()),
                nullable: false,
                string_no_data: None,
                input_name: None,
            })
            .collect();
        // Columns: the attributes at least MIN_COLUMN_SHARE of the buildings have, at most MAX_ATTRIBUTE_COLUMNS
        // of them, the most widely held first.
        let min_held = ((MIN_COLUMN_SHARE * buildings.len() as f64).ceil() as usize).max(1);
        let mut by_share: Vec<(&str, usize)> = held
            .iter()
            .filter(|&(_, &n)| n >= min_held)
            .map(|(&k, &n)| (k, n))
            .collect();
        by_share.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
        let columns: BTreeSet<&str> = by_share
            .iter()
            .take(MAX_ATTRIBUTE_COLUMNS)
            .map(|&(k, _)| k)
            .collect();
        let folded: BTreeSet<String> = kinds
            .keys()
            .filter(|k| !columns.contains(*k))
            .map(|k| k.to_string())
            .collect();
        // Names that are property ids already keep them; the others are made ids after, so a sanitized name never
        // takes the name another attribute has (`a b` becoming `a_b` beside a real `a_b`).
        let mut ids: BTreeMap<&str, String> = BTreeMap::new();
        for pass_valid in [true, false] {
            for &name in &columns {
                if citylod_tiles::is_id(name) == pass_valid {
                    ids.insert(name, unique_id(name, &mut used));
                }
            }
        }
        let mut attrs = Vec::new();
        for (name, kind) in kinds.into_iter().filter(|(k, _)| columns.contains(k)) {
            // A column holds some value (`held`); the kind is known unless every value was null.
            let kind = kind.unwrap_or(PropertyKind::String);
            let id = ids.remove(name).expect("every column has its id");
            let mut description = (id != name).then(|| format!("input attribute `{name}`"));
            // A BOOLEAN property has no noData value in EXT_structural_metadata, so a missing value would read
            // back as false: true/false absent from some buildings are written as 1/0 with noData instead.
            let kind = if kind == PropertyKind::Boolean && present[name] < buildings.len() {
                description = Some(format!(
                    "input attribute `{name}`: true 1, false 0 (some buildings have no value)"
                ));
                PropertyKind::UInt32
            } else {
                kind
            };
            // A string column's noData is "", unless some building has the empty string and another none: then
            // a text no building has, so the two stay apart.
            let string_no_data = (kind == PropertyKind::String
                && empty.contains(name)
                && present.get(name).copied().unwrap_or(0) < buildings.len())
            .then(|| absent_text(buildings, name));
            let input_name = (id != name).then(|| name.to_string());
            properties.push(PropertyDef {
                name: id,
                kind,
                description,
                nullable: true,
                string_no_data,
                input_name,
            });
            attrs.push((name.to_string(), kind));
        }
        if !folded.is_empty() {
            let id = unique_id(FOLDED_PROPERTY, &mut used);
            properties.push(PropertyDef {
                name: id,
                kind: PropertyKind::String,
                description: Some(format!(
                    "input attributes that fewer than {}% of the buildings have (or past the {MAX_ATTRIBUTE_COLUMNS} \
                     most common), as a JSON object; no value when the building has none of them",
                    MIN_COLUMN_SHARE * 100.0
                )),
                nullable: true,
                string_no_data: None,
                input_name: None,
            });
        }
        Self {
            class: ClassDef {
                id: "building".into(),
                properties,
            },
            attrs,
            folded,
        }
    }

    /// What became of the input attributes.
    pub fn summary(&self) -> AttributeSummary {
        AttributeSummary {
            columns: self.attrs.len(),
            folded_property: (!self.folded.is_empty())
                .then(|| self.class.properties.last().map(|p| p.name.clone()))
                .flatten(),
            folded: self.folded.iter().cloned().collect(),
            renamed: self
                .class
                .properties
                .iter()
                .filter_map(|p| Some((p.input_name.clone()?, p.name.clone())))
                .collect(),
        }
    }

    pub fn feature(&self, b: &Building, mesh: Mesh3d) -> ContentFeature {
        let mut values = Vec::with_capacity(self.class.properties.len());
        values.push(PropValue::Str(b.source_id.clone()));
        values.push(PropValue::Int(b.id.0 as i64));
        values.push(PropValue::Float(b.height_m));
        values.push(PropValue::Float(b.base_z_m));
        values.push(PropValue::Str(
            serde_json::to_value(b.height_source)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default(),
        ));
        for (name, kind) in &self.attrs {
            values.push(match (b.attributes.get(name), kind) {
                (None | Some(AttrValue::Null), _) => PropValue::Null,
                (Some(AttrValue::Bool(v)), PropertyKind::Boolean) => PropValue::Bool(*v),
                (Some(AttrValue::Bool(v)), PropertyKind::UInt32) => PropValue::Int(*v as i64),
                (Some(AttrValue::Int(v)), PropertyKind::Int32 | PropertyKind::Int64) => {
                    PropValue::Int(*v)
                }
                (Some(AttrValue::Int(v)), PropertyKind::Float64) => PropValue::Float(*v as f64),
                (Some(AttrValue::Float(v)), PropertyKind::Float64) => PropValue::Float(*v),
                (Some(v), _) => PropValue::Str(as_text(v)),
            });
        }
        if !self.folded.is_empty() {
            let rare: serde_json::Map<String, serde_json::Value> = b
                .attributes
                .iter()
                .filter(|(k, v)| self.folded.contains(k.as_str()) && is_value(v))
                .map(|(k, v)| (k.clone(), serde_json::to_value(v).unwrap_or_default()))
                .collect();
            values.push(if rare.is_empty() {
                PropValue::Null
            } else {
                PropValue::Str(serde_json::Value::Object(rare).to_string())
            });
        }
        ContentFeature {
            mesh,
            class: 0,
            values,
            max_rounding_m: 0.0,
        }
    }
}

/// Whether an attribute value is one: null and the empty text are no value, in a column (its noData) or in
/// `other_attributes` (GDAL writes every key on every feature, null or empty where it has none, so counting keys
/// would fold nothing and the folded object would repeat every key in every row).
fn is_value(v: &AttrValue) -> bool {
    !matches!(v, AttrValue::Null) && !matches!(v, AttrValue::String(s) if s.is_empty())
}

/// Properties of the `cluster` class: a block of buildings at some level of the hierarchy (a single building
/// that stays alone at that level is a cluster of one and keeps its source id). The block's landmarks are
/// separate features of the `building` class in the same content.
/// Landmarks are features of this class too (`landmark` = true, `building_index` set): CesiumJS picks through one
/// property table per glb, so a tile must hold a single class for clicks to find the right feature.
/// (id, kind, nullable, description)
const CLUSTER: [(&str, PropertyKind, bool, &str); 16] = [
    (
        "level",
        PropertyKind::UInt32,
        false,
        "hierarchy level (0 = the buildings)",
    ),
    (
        "node_index",
        PropertyKind::UInt32,
        false,
        "index of the block within its level",
    ),
    (
        "member_count",
        PropertyKind::UInt32,
        false,
        "buildings in the block",
    ),
    (
        "source_id",
        PropertyKind::String,
        true,
        "the building's source id when the block is a single building",
    ),
    (
        "height_m",
        PropertyKind::Float32,
        false,
        "area-weighted mean height of the buildings, metres",
    ),
    (
        "ground_z_m",
        PropertyKind::Float32,
        false,
        "area-weighted mean base of the buildings (their ground, or the min_height they stand on) in the tileset's local frame, metres: the block stands from here to ground_z_m + height_m",
    ),
    (
        "h_min_m",
        PropertyKind::Float32,
        false,
        "lowest building height, metres",
    ),
    (
        "h_max_m",
        PropertyKind::Float32,
        false,
        "highest building height, metres",
    ),
    (
        "dh_m",
        PropertyKind::Float32,
        false,
        "height spread Δh = h_max − h_min, metres",
    ),
    (
        "da_m2",
        PropertyKind::Float32,
        false,
        "area the block differs from its buildings by, m²: Δa = area(block) − Σ area(buildings) as merged, plus what was filled or cut to simplify its outline within its tile's error",
    ),
    (
        "area_m2",
        PropertyKind::Float32,
        false,
        "footprint area of the block, m²",
    ),
    (
        "geometric_error_m",
        PropertyKind::Float32,
        false,
        "max(Δh, κ·√Δa), and any full-detail prism's distance from its 3D model: the error of drawing it, metres",
    ),
    (
        "fallback",
        PropertyKind::Boolean,
        false,
        "the merged footprint could not be extruded; the buildings are shown",
    ),
    (
        "landmark_count",
        PropertyKind::UInt32,
        false,
        "buildings drawn at full detail on top of the block (features with landmark = true)",
    ),
    (
        "landmark",
        PropertyKind::Boolean,
        false,
        "this feature is one building drawn at full detail on top of its block, not a block",
    ),
    (
        "building_index",
        PropertyKind::UInt32,
        true,
        "for a landmark: citylod's index of the building (as in the building class)",
    ),
];

/// Index of the cluster class in [`schema`].
pub const CLUSTER_CLASS: usize = 1;

/// `(no value)`, with `~` added until no building's `name` attribute is that text.
fn absent_text(buildings: &[Building], name: &str) -> String {
    let taken: BTreeSet<&str> = buildings
        .iter()
        .filter_map(|b| match b.attributes.get(name) {
            Some(AttrValue::String(s)) => Some(s.as_str()),
            _ => None,
        })
        .collect();
    let mut text = String::from("(no value)");
    while taken.contains(text.as_str()) {
        text.push('~');
    }
    text
}

/// The metadata schema of a build: `building` (index 0) and `cluster` (index 1).
pub fn schema(buildings: &BuildingTable) -> MetadataSchema {
    let cluster = ClassDef {
        id: "cluster".into(),
        properties: CLUSTER
            .iter()
            .map(|&(name, kind, nullable, d)| PropertyDef {
                name: name.into(),
                kind,
                description: Some(d.into()),
                nullable,
                string_no_data: None,
                input_name: None,
            })
            .collect(),
    };
    MetadataSchema {
        id: "citylod".into(),
        classes: vec![buildings.class.clone(), cluster],
    }
}

/// One feature of the cluster class; `values` in the order of [`CLUSTER`].
pub struct ClusterRow<'a> {
    pub level: usize,
    pub node_index: u32,
    pub node: &'a citylod_model::Node,
    pub source_id: Option<&'a str>,
    pub geometric_error_m: f64,
    pub fallback: bool,
    /// How far the writer may round the block's vertices (m per axis): a small share of its tile's error.
    pub max_rounding_m: f64,
}

pub fn cluster_feature(row: ClusterRow<'_>, mesh: Mesh3d) -> ContentFeature {
    let n = row.node;
    let values = vec![
        PropValue::Int(row.level as i64),
        PropValue::Int(row.node_index as i64),
        PropValue::Int(n.members.len() as i64),
        row.source_id
            .map_or(PropValue::Null, |s| PropValue::Str(s.to_string())),
        PropValue::Float(n.height_m),
        PropValue::Float(n.base_z_m),
        PropValue::Float(n.h_min_m),
        PropValue::Float(n.h_max_m),
        PropValue::Float(n.dh_m),
        PropValue::Float(n.da_m2),
        PropValue::Float(n.area_m2),
        PropValue::Float(row.geometric_error_m),
        PropValue::Bool(row.fallback),
        PropValue::Int(n.landmarks.len() as i64),
        PropValue::Bool(false),
        PropValue::Null,
    ];
    debug_assert_eq!(values.len(), CLUSTER.len());
    ContentFeature {
        mesh,
        class: CLUSTER_CLASS,
        values,
        max_rounding_m: row.max_rounding_m,
    }
}

/// A landmark of the block at (`level`, `node_index`): the building at full detail, as a `cluster`-class feature
/// of one member with no height spread and no added area; its error is its prism's distance from the building's
/// 3D model (0 without one). Its vertices may be rounded as far as the block's (`max_rounding_m`).
pub fn landmark_feature(
    level: usize,
    node_index: u32,
    b: &Building,
    mesh: Mesh3d,
    geometric_error_m: f64,
    max_rounding_m: f64,
) -> ContentFeature {
    let values = vec![
        PropValue::Int(level as i64),
        PropValue::Int(node_index as i64),
        PropValue::Int(1),
        PropValue::Str(b.source_id.clone()),
        PropValue::Float(b.height_m),
        PropValue::Float(b.base_z_m),
        PropValue::Float(b.height_m),
        PropValue::Float(b.height_m),
        PropValue::Float(0.0),
        PropValue::Float(0.0),
        PropValue::Float(b.area_m2()),
        PropValue::Float(geometric_error_m),
        PropValue::Bool(false),
        PropValue::Int(0),
        PropValue::Bool(true),
        PropValue::Int(b.id.0 as i64),
    ];
    debug_assert_eq!(values.len(), CLUSTER.len());
    ContentFeature {
        mesh,
        class: CLUSTER_CLASS,
        values,
        max_rounding_m,
    }
}

fn as_text(v: &AttrValue) -> String {
    match v {
        AttrValue::Null => String::new(),
        AttrValue::Bool(b) => b.to_string(),
        AttrValue::Int(i) => i.to_string(),
        // Very large or small magnitudes in exponent form: `1e308` is not 309 digits.
        AttrValue::Float(f) if *f != 0.0 && (f.abs() >= 1e16 || f.abs() < 1e-6) => format!("{f:e}"),
        AttrValue::Float(f) => f.to_string(),
        AttrValue::String(s) => s.clone(),
    }
}

/// `building:levels` → `building_levels`; a leading digit gets a `_`; clashes get `_2`, `_3`, ….
fn unique_id(name: &str, used: &mut BTreeSet<String>) -> String {
    let mut base: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if base.is_empty() || base.starts_with(|c: char| c.is_ascii_digit()) {
        base.insert(0, '_');
    }
    let mut id = base.clone();
    let mut k = 2;
    while used.contains(&id) {
        id = format!("{base}_{k}");
        k += 1;
    }
    used.insert(id.clone());
    id
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_text_columns_are_written_short() {
        assert_eq!(as_text(&AttrValue::Float(1e308)), "1e308");
        assert_eq!(as_text(&AttrValue::Float(-2.5e-9)), "-2.5e-9");
        assert_eq!(as_text(&AttrValue::Float(12.5)), "12.5");
        assert_eq!(as_text(&AttrValue::Float(3.0)), "3");
        assert_eq!(as_text(&AttrValue::Float(0.0)), "0");
    }

    #[test]
    fn property_ids_are_safe_and_unique() {
        let mut used: BTreeSet<String> = ["height_m".to_string()].into();
        assert_eq!(unique_id("building:levels", &mut used), "building_levels");
        assert_eq!(unique_id("building_levels", &mut used), "building_levels_2");
        assert_eq!(unique_id("3dbag", &mut used), "_3dbag");
        assert_eq!(unique_id("height_m", &mut used), "height_m_2");
        assert_eq!(unique_id("", &mut used), "_");
    }

    /// A building `i` with these attributes and nothing else of interest.
    fn building<'a>(i: u32, attrs: impl IntoIterator<Item = (&'a str, AttrValue)>) -> Building {
        Building {
            id: citylod_model::BuildingId(i),
            source_id: format!("b{i}"),
            footprint: geo::MultiPolygon(vec![]),
            base_z_m: 0.0,
            height_m: 10.0,
            height_source: citylod_model::HeightSource::Default,
            attributes: attrs.into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
            mesh: None,
        }
    }

    #[test]
    fn attribute_types_are_inferred_over_all_buildings() {
        let b = |i: u32, attrs: &[(&str, AttrValue)]| building(i, attrs.iter().cloned());
        use AttrValue::*;
        let buildings = [
            b(
                0,
                &[
                    ("ints", Int(-7)),
                    ("mixed", Int(3)),
                    ("wide", Int(1)),
                    ("flag", Bool(true)),
                    ("text", Int(1)),
                    ("every", Bool(true)),
                    ("huge", Int((1 << 53) + 1)),
                    ("big_mixed", Int(1 << 40)),
                ],
            ),
            b(
                1,
                &[
                    ("every", Bool(false)),
                    ("big_mixed", Float(0.5)),
                    ("ints", Null),
                    ("mixed", Float(2.5)),
                    ("wide", Int(1 << 40)),
                    ("text", String("x".into())),
                ],
            ),
            b(
                2,
                &[
                    ("ints", Int(i32::MAX as i64)),
                    ("flag", Bool(false)),
                    ("every", Bool(true)),
                ],
            ),
        ];
        let t = BuildingTable::new(&buildings);
        let kind = |name: &str| t.attrs.iter().find(|(n, _)| n == name).unwrap().1;
        assert_eq!(kind("ints"), PropertyKind::Int32);
        assert_eq!(kind("mixed"), PropertyKind::Float64);
        assert_eq!(kind("wide"), PropertyKind::Int64);
        assert_eq!(kind("huge"), PropertyKind::Int64);
        assert_eq!(kind("big_mixed"), PropertyKind::Float64);
        // Booleans stay BOOLEAN where every building has one; where some have none, 1/0 with noData (a
        // BOOLEAN has no noData, a missing value would read back as false).
        assert_eq!(kind("every"), PropertyKind::Boolean);
        assert_eq!(kind("flag"), PropertyKind::UInt32);
        assert_eq!(kind("text"), PropertyKind::String);
        // Values as written: integers stay integers, nulls stay null, a number in a text column becomes text.
        let values = |i: usize| t.feature(&buildings[i], Mesh3d::default()).values;
        let col = |name: &str| 5 + t.attrs.iter().position(|(n, _)| n == name).unwrap();
        assert_eq!(values(0)[col("ints")], PropValue::Int(-7));
        assert_eq!(values(0)[col("flag")], PropValue::Int(1));
        assert_eq!(values(1)[col("flag")], PropValue::Null);
        assert_eq!(values(2)[col("flag")], PropValue::Int(0));
        assert_eq!(values(1)[col("every")], PropValue::Bool(false));
        assert_eq!(values(1)[col("ints")], PropValue::Null);
        assert_eq!(values(0)[col("mixed")], PropValue::Float(3.0));
        // 2^53 + 1 has no double: INT64 keeps it.
        assert_eq!(values(0)[col("huge")], PropValue::Int((1 << 53) + 1));
        assert_eq!(values(1)[col("big_mixed")], PropValue::Float(0.5));
        assert_eq!(values(1)[col("wide")], PropValue::Int(1 << 40));
        assert_eq!(values(0)[col("text")], PropValue::Str("1".into()));
        // Columns without an empty string keep "" as their noData.
        assert!(t
            .class
            .properties
            .iter()
            .all(|p| p.string_no_data.is_none()));
    }

    /// A text attribute that some buildings have as "" and others not at all gets a noData no building has, so
    /// the two read back apart; where only one of the two happens, "" serves.
    #[test]
    fn empty_strings_and_missing_values_get_a_no_data_apart() {
        let b = |i: u32, attrs: &[(&str, &str)]| {
            building(
                i,
                attrs.iter().map(|&(k, v)| (k, AttrValue::String(v.into()))),
            )
        };
        let buildings = [
            b(
                0,
                &[
                    ("both", ""),
                    ("taken", ""),
                    ("only_empty", ""),
                    ("only_missing", "x"),
                ],
            ),
            b(1, &[("taken", "(no value)"), ("only_empty", "")]),
            b(2, &[("both", "y"), ("taken", "z"), ("only_empty", "w")]),
            b(3, &[("only_empty", "v")]),
        ];
        let t = BuildingTable::new(&buildings);
        let no_data = |name: &str| {
            t.class
                .properties
                .iter()
                .find(|p| p.name == name)
                .unwrap()
                .string_no_data
                .clone()
        };
        assert_eq!(no_data("both").as_deref(), Some("(no value)"));
        assert_eq!(no_data("taken").as_deref(), Some("(no value)~"));
        assert_eq!(no_data("only_empty"), None);
        assert_eq!(no_data("only_missing"), None);
    }

    #[test]
    fn attribute_names_that_are_ids_keep_them_and_renames_are_reported() {
        // `a b` sorts before `a_b`: made an id first, it used to take `a_b` and push the real `a_b` to `a_b_2`,
        // so a click showed one attribute's value under the other's name.
        use AttrValue::*;
        let buildings = [building(
            0,
            [
                ("a b", String("s".into())),
                ("a_b", String("t".into())),
                ("building:levels", Int(3)),
                ("building_levels", Int(4)),
                ("1st", Int(1)),
                ("source_id", String("mine".into())),
            ],
        )];
        let t = BuildingTable::new(&buildings);
        let id_of = |name: &str| {
            let k = t.attrs.iter().position(|(n, _)| n == name).unwrap();
            t.class.properties[FIXED.len() + k].name.clone()
        };
        assert_eq!(id_of("a_b"), "a_b");
        assert_eq!(id_of("a b"), "a_b_2");
        assert_eq!(id_of("building_levels"), "building_levels");
        assert_eq!(id_of("building:levels"), "building_levels_2");
        assert_eq!(id_of("1st"), "_1st");
        assert_eq!(id_of("source_id"), "source_id_2");
        let input_name = |id: &str| {
            let p = t.class.properties.iter().find(|p| p.name == id).unwrap();
            p.input_name.clone()
        };
        assert_eq!(
            input_name("building_levels_2").as_deref(),
            Some("building:levels")
        );
        assert_eq!(input_name("building_levels"), None);
        let renamed = t.summary().renamed;
        assert_eq!(
            renamed.into_iter().collect::<Vec<_>>(),
            [
                ("1st".to_string(), "_1st".to_string()),
                ("a b".into(), "a_b_2".into()),
                ("building:levels".into(), "building_levels_2".into()),
                ("source_id".into(), "source_id_2".into()),
            ]
        );
    }

    #[test]
    fn rare_attributes_share_one_json_column_and_columns_are_capped() {
        // 300 buildings: `common` on all, `rare` with a value on two (under 1 %; null or empty on the rest),
        // `other_attributes` as an input name on all.
        let buildings: Vec<Building> = (0..300)
            .map(|i| {
                let mut a = vec![
                    ("common", AttrValue::Int(i as i64)),
                    ("other_attributes", AttrValue::String("x".into())),
                ];
                if i < 2 {
                    a.push(("rare", AttrValue::Float(1.5)));
                    a.push(("rare:text", AttrValue::String("a \"b\"".into())));
                } else {
                    // As GDAL writes it: the key on every feature, null or empty where it has no value.
                    a.push(("rare", AttrValue::Null));
                    a.push(("rare:text", AttrValue::String(String::new())));
                }
                building(i, a)
            })
            .collect();
        let t = BuildingTable::new(&buildings);
        let s = t.summary();
        assert_eq!(s.columns, 2);
        assert_eq!(s.folded, vec!["rare", "rare:text"]);
        // The input's own `other_attributes` keeps its name; the folded column gets the next free one.
        assert_eq!(s.folded_property.as_deref(), Some("other_attributes_2"));
        let names: Vec<&str> = t.class.properties.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(
            names[5..],
            ["common", "other_attributes", "other_attributes_2"]
        );
        let row = |i: usize| t.feature(&buildings[i], Mesh3d::default()).values;
        let folded: serde_json::Value = match row(1).last().unwrap() {
            PropValue::Str(s) => serde_json::from_str(s).unwrap(),
            v => panic!("{v:?}"),
        };
        assert_eq!(
            folded,
            serde_json::json!({"rare": 1.5, "rare:text": "a \"b\""})
        );
        // Neither null nor empty text in the object: nothing is left of it.
        assert_eq!(row(2).last(), Some(&PropValue::Null));
        assert_eq!(row(2).len(), t.class.properties.len());

        // 300 attributes every building has: the first 256 by name get columns.
        let names: Vec<String> = (0..300).map(|k| format!("a{k:03}")).collect();
        let buildings: Vec<Building> = (0..3)
            .map(|i| building(i, names.iter().map(|n| (n.as_str(), AttrValue::Int(1)))))
            .collect();
        let s = BuildingTable::new(&buildings).summary();
        assert_eq!(s.columns, MAX_ATTRIBUTE_COLUMNS);
        assert_eq!(s.folded.first().map(String::as_str), Some("a256"));
        assert_eq!(s.folded.len(), 300 - MAX_ATTRIBUTE_COLUMNS);
        // The cap holds for one building too.
        let s = BuildingTable::new(&buildings[..1]).summary();
        assert_eq!((s.columns, s.folded.len()), (300 - 44, 44));
        let few = [building(0, [("x", AttrValue::Int(1))]), building(1, [])];
        assert_eq!(BuildingTable::new(&few).summary().folded_property, None);
    }

    /// `schemas/metadata.json` documents the metadata schema every glb carries inline: the `cluster` class and the
    /// fixed properties of the `building` class (a build appends one property per input attribute). It must be
    /// exactly what the writer produces; `CITYLOD_WRITE_SCHEMAS=1` rewrites it after a deliberate change.
    #[test]
    fn schemas_metadata_json_is_the_schema_the_glbs_carry() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../schemas/metadata.json");
        let mut doc = serde_json::json!({
            "$comment": "The EXT_structural_metadata schema inline in every citylod glb, there without the descriptions (a glb lists only the classes its property tables use). Besides the five fixed properties listed here, the building class has one property per input attribute (named after it, made safe as an identifier; nullable, noData declared), so it differs per build. Only nullable properties declare noData. The id is `citylod_` and a hash of the classes a schema defines, so a glb of blocks, one of buildings and a build with other attributes each carry their own id (the id below is this file's). Generated from crates/citylod/src/features.rs; a test keeps the two equal.",
        });
        let generated = citylod_tiles::schema_to_json(&schema(&BuildingTable::new(&[])));
        for (k, v) in generated.as_object().unwrap() {
            doc[k] = v.clone();
        }
        let mut text = serde_json::to_string_pretty(&doc).unwrap();
        text.push('\n');
        if std::env::var_os("CITYLOD_WRITE_SCHEMAS").is_some() {
            std::fs::write(&path, &text).unwrap();
        }
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            committed == text,
            "{} differs from the schema the writer produces; rerun with CITYLOD_WRITE_SCHEMAS=1 after a deliberate change",
            path.display()
        );
    }
}
