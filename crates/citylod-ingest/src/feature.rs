//! A feature as a reader hands it over, before CRS conversion and repair: source id, attributes and
//! polygon rings in source CRS coordinates (open rings: the closing point is not repeated).
//! Readers never fail on one bad feature: they mark it with a skip reason instead.

use crate::model3d::RawModel;
use crate::report::IssueReason;
use citylod_model::{AttrValue, Attributes};

/// Rings of one polygon: `[exterior, hole, …]`, each an open ring of source (x, y).
pub(crate) type RawPolygon = Vec<Vec<[f64; 2]>>;

/// One building as read from a file.
#[derive(Debug, Clone, Default)]
pub(crate) struct RawFeature {
    pub source_id: String,
    pub attributes: Attributes,
    pub polygons: Vec<RawPolygon>,
    /// Repairs the reader already made (e.g. ring closed), with details.
    pub repairs: Vec<(IssueReason, String)>,
    /// The polygons are pieces of one outline to be unioned (CityJSON ground surfaces, building
    /// parts): merging them is assembly, not a repair.
    pub assemble: bool,
    /// Lowest z of the footprint vertices (CityJSON), in source height units (m).
    pub footprint_min_z: Option<f64>,
    /// Highest z of the building's 3D geometry (CityJSON), m.
    pub top_z: Option<f64>,
    /// Set when the feature cannot become a building.
    pub skip: Option<(IssueReason, String)>,
    /// OSM `building:part` tag present (set by `ingest` from the attribute, whatever the format).
    pub is_building_part: bool,
    /// The 3D model (CityJSON, when `IngestOptions::lod` asks for one), or why there is none.
    pub model: Option<Result<RawModel, (IssueReason, String)>>,
    /// GeoJSON positions carried a z other than 0, which is not read (a note for the file says so).
    pub z_ignored: bool,
    /// The feature's line geometry (a shapefile PolyLine, a GeoPackage LineString or curve), in source (x, y): not
    /// a building (`skip` says so), but what `--streets` reads from these formats.
    pub lines: Vec<Vec<[f64; 2]>>,
}

/// What a reader of a format with several layers wants from it: buildings, or street lines (`--streets`).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Want {
    Footprints,
    Lines,
}

/// What a Shapefile or GeoPackage reader hands over: the features, the faces of those holding 3D surface models
/// (their footprints wait for the CRS: `surface_model::stand`), the CRS the file declares (`None`: none, or the
/// undefined one) and what the user should know about the file as a whole.
pub(crate) struct VectorDoc {
    pub features: Vec<RawFeature>,
    pub surfaces: Vec<crate::surface_model::Surfaces>,
    pub declared_crs: Option<crate::crs::DeclaredCrs>,
    /// Metres per unit of z when the file declares a vertical CRS (a `.prj`'s `VERTCS`).
    pub z_unit_m: Option<f64>,
    pub notes: Vec<String>,
}

/// The building's id as for GeoJSON properties: `id`, else `@id`, else OSM's `osm_type/osm_id`, else `FILE#N` (a
/// shapefile record's 0-based position, a GeoPackage row's FID).
pub(crate) fn source_id(a: &Attributes, file_name: &str, n: impl std::fmt::Display) -> String {
    let text = |k: &str| match a.get(k) {
        Some(AttrValue::String(s)) if !s.is_empty() => Some(s.clone()),
        Some(AttrValue::Int(i)) => Some(i.to_string()),
        _ => None,
    };
    text("id")
        .or_else(|| text("@id"))
        .or_else(|| Some(format!("{}/{}", text("osm_type")?, text("osm_id")?)))
        .unwrap_or_else(|| format!("{file_name}#{n}"))
}

/// The bounding box of a ring: [min x, min y, max x, max y].
pub(crate) fn ring_box(r: &[[f64; 2]]) -> [f64; 4] {
    r.iter().fold(
        [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ],
        |b, p| {
            [
                b[0].min(p[0]),
                b[1].min(p[1]),
                b[2].max(p[0]),
                b[3].max(p[1]),
            ]
        },
    )
}

/// The repair that says which members of a GeometryCollection were not polygons (`dropped`: "member PATH (Type)").
pub(crate) fn dropped_members(dropped: &[String]) -> (IssueReason, String) {
    (
        IssueReason::NonPolygonMemberDropped,
        format!(
            "{} GeometryCollection member(s) not polygonal, dropped: {}",
            dropped.len(),
            crate::geojson::listing(dropped)
        ),
    )
}

/// JSON value → attribute value; nested objects and arrays become compact JSON text.
pub(crate) fn attr_value(v: &serde_json::Value) -> AttrValue {
    use serde_json::Value;
    match v {
        Value::Null => AttrValue::Null,
        Value::Bool(b) => AttrValue::Bool(*b),
        Value::Number(n) => match n.as_i64() {
            Some(i) => AttrValue::Int(i),
            None => AttrValue::Float(n.as_f64().unwrap_or(f64::NAN)),
        },
        Value::String(s) => AttrValue::String(s.clone()),
        other => AttrValue::String(other.to_string()),
    }
}

/// A JSON object's members as attributes (sorted by name).
pub(crate) fn attributes(v: Option<&serde_json::Value>) -> Attributes {
    v.and_then(|v| v.as_object())
        .map(|m| m.iter().map(|(k, v)| (k.clone(), attr_value(v))).collect())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn source_ids_follow_the_geojson_rule() {
        let a: Attributes = [
            ("osm_type".to_string(), AttrValue::String("way".into())),
            ("osm_id".to_string(), AttrValue::Int(5)),
        ]
        .into_iter()
        .collect();
        assert_eq!(source_id(&a, "f.shp", 3), "way/5");
        assert_eq!(source_id(&Attributes::default(), "f.shp", 3), "f.shp#3");
    }

    #[test]
    fn nested_values_become_compact_json_strings() {
        let v: serde_json::Value = serde_json::json!({
            "a": 1, "b": 2.5, "c": "x", "d": null, "e": true, "f": {"g": [1, 2]}, "h": [1, "two"]
        });
        let a = attributes(Some(&v));
        assert_eq!(a["a"], AttrValue::Int(1));
        assert_eq!(a["b"], AttrValue::Float(2.5));
        assert_eq!(a["c"], AttrValue::String("x".into()));
        assert_eq!(a["d"], AttrValue::Null);
        assert_eq!(a["e"], AttrValue::Bool(true));
        assert_eq!(a["f"], AttrValue::String(r#"{"g":[1,2]}"#.into()));
        assert_eq!(a["h"], AttrValue::String(r#"[1,"two"]"#.into()));
    }
}
