//! GeoJSON reader (RFC 7946): a FeatureCollection, a single Feature or a bare geometry. Polygon,
//! MultiPolygon and the polygons of a GeometryCollection (nested ones flattened; other members dropped
//! and reported) become raw footprints in source coordinates; other geometries are marked as skipped.
//! Properties become attributes. A legacy `crs` member (GeoJSON 2008) is read as [`DeclaredCrs`].

use crate::crs::DeclaredCrs;
use crate::feature::{attr_value, attributes, RawFeature, RawPolygon};
use crate::report::IssueReason;
use rayon::prelude::*;
use serde_json::value::RawValue;
use serde_json::Value;

/// The features of a GeoJSON document and the CRS it declares (legacy `crs` member), if any.
pub(crate) struct GeoJsonDoc {
    pub features: Vec<RawFeature>,
    pub declared_crs: Option<DeclaredCrs>,
}

/// Reads a parsed GeoJSON document; `Err` (a detail) when it is not GeoJSON at all.
pub(crate) fn read(doc: &Value, file_name: &str) -> Result<GeoJsonDoc, String> {
    let declared_crs = doc.get("crs").and_then(DeclaredCrs::from_geojson);
    let kind = doc.get("type").and_then(Value::as_str).unwrap_or("");
    let features: Vec<RawFeature> = match kind {
        "FeatureCollection" => {
            let list = doc
                .get("features")
                .and_then(Value::as_array)
                .ok_or("a FeatureCollection without a \"features\" array")?;
            list.iter()
                .enumerate()
                .map(|(i, f)| read_feature(f, file_name, i))
                .collect()
        }
        "Feature" => vec![read_feature(doc, file_name, 0)],
        "Polygon" | "MultiPolygon" | "GeometryCollection" => {
            let mut f = RawFeature {
                source_id: format!("{file_name}#0"),
                ..Default::default()
            };
            fill_geometry(&mut f, Some(doc));
            vec![f]
        }
        "" => return Err("no top-level \"type\" member".into()),
        other => {
            return Err(format!(
                "top-level type {other:?} is neither GeoJSON nor CityJSON"
            ))
        }
    };
    Ok(GeoJsonDoc {
        features,
        declared_crs,
    })
}

/// The outline of a FeatureCollection, with its features still as unparsed JSON text.
#[derive(serde::Deserialize)]
struct Collection<'a> {
    #[serde(rename = "type")]
    kind: Option<String>,
    #[serde(borrow)]
    features: Option<Vec<&'a RawValue>>,
    crs: Option<Value>,
}

/// Fast path for a FeatureCollection text: one scan for the outline, then the features are parsed
/// in parallel (in order). `Ok(None)` when the text is valid JSON but not a FeatureCollection with
/// a features array; `Err` when it is not valid JSON or repeats one of the members read here.
pub(crate) fn read_collection_text(
    text: &str,
    file_name: &str,
) -> Result<Option<GeoJsonDoc>, serde_json::Error> {
    let c: Collection = match serde_json::from_str(text) {
        Ok(c) => c,
        // Two `features` (or `type`, `crs`) members: a generic JSON reader would keep the last and
        // silently drop the other's features, so the file is rejected with serde's message.
        Err(e) if e.to_string().starts_with("duplicate field") => return Err(e),
        Err(e) if e.classify() == serde_json::error::Category::Data => return Ok(None),
        Err(e) => return Err(e),
    };
    let (Some("FeatureCollection"), Some(raw)) = (c.kind.as_deref(), c.features) else {
        return Ok(None);
    };
    let declared_crs = c.crs.as_ref().and_then(DeclaredCrs::from_geojson);
    let features = raw
        .par_iter()
        .enumerate()
        .map(|(i, r)| match serde_json::from_str::<Value>(r.get()) {
            Ok(v) => read_feature(&v, file_name, i),
            // The outline scan does not convert numbers: 1e999 (beyond f64) surfaces only here.
            Err(e) => {
                let out_of_range = e.to_string().contains("number out of range");
                if out_of_range {
                    if let Some(f) = read_with_numbers_as_text(r.get(), file_name, i) {
                        return f;
                    }
                }
                let reason = if out_of_range {
                    IssueReason::NonFiniteCoordinate
                } else {
                    IssueReason::MalformedGeometry
                };
                let skip = Some((reason, format!("feature JSON rejected: {e}")));
                RawFeature {
                    source_id: format!("{file_name}#{i}"),
                    skip,
                    ..Default::default()
                }
            }
        })
        .collect();
    Ok(Some(GeoJsonDoc {
        features,
        declared_crs,
    }))
}

/// A feature whose only numbers beyond the range of a double (`1e400`) are property values: read with each such
/// value kept as its text, and the repair recorded. `None` when the feature is not an object or such a number
/// lies elsewhere (in the geometry: the feature is then skipped as before).
fn read_with_numbers_as_text(text: &str, file_name: &str, index: usize) -> Option<RawFeature> {
    use std::collections::BTreeMap;
    let members: BTreeMap<String, &RawValue> = serde_json::from_str(text).ok()?;
    let mut object = serde_json::Map::new();
    let mut kept = Vec::new();
    for (k, raw) in members {
        let v = match serde_json::from_str::<Value>(raw.get()) {
            Ok(v) => v,
            Err(_) if k == "properties" => {
                let props: BTreeMap<String, &RawValue> = serde_json::from_str(raw.get()).ok()?;
                let mut out = serde_json::Map::new();
                for (name, value) in props {
                    let v = match serde_json::from_str::<Value>(value.get()) {
                        Ok(v) => v,
                        // Only a bare number is kept as text; anything else is left to the usual skip.
                        Err(_)
                            if value
                                .get()
                                .trim_start()
                                .starts_with(|c: char| c == '-' || c.is_ascii_digit()) =>
                        {
                            kept.push(name.clone());
                            Value::String(value.get().trim().to_string())
                        }
                        Err(_) => return None,
                    };
                    out.insert(name, v);
                }
                Value::Object(out)
            }
            Err(_) => return None,
        };
        object.insert(k, v);
    }
    let mut f = read_feature(&Value::Object(object), file_name, index);
    if !kept.is_empty() {
        f.repairs.push((
            IssueReason::NumberKeptAsText,
            format!(
                "{} beyond the range of a double, kept as text: {}",
                if kept.len() == 1 {
                    "a number"
                } else {
                    "numbers"
                },
                kept.join(", ")
            ),
        ));
    }
    Some(f)
}

fn read_feature(f: &Value, file_name: &str, index: usize) -> RawFeature {
    let props = f.get("properties");
    let mut out = RawFeature {
        source_id: source_id(f, file_name, index),
        attributes: attributes(props),
        ..Default::default()
    };
    // RFC 7946 §3.2 allows an object or null; anything else is kept whole as one attribute.
    if let Some(p) = props.filter(|p| !(p.is_object() || p.is_null())) {
        out.attributes = [(NON_OBJECT_PROPERTIES.to_string(), attr_value(p))]
            .into_iter()
            .collect();
        out.repairs.push((
            IssueReason::PropertiesNotObject,
            format!(
                "\"properties\" is {}, not an object; kept as the attribute \"{NON_OBJECT_PROPERTIES}\"",
                json_kind(p)
            ),
        ));
    }
    out.is_building_part = props
        .and_then(|p| p.get("building:part"))
        .is_some_and(|v| !v.is_null() && v != "no");
    if f.get("type").and_then(Value::as_str) != Some("Feature") {
        out.skip = Some((
            IssueReason::MalformedGeometry,
            "member of \"features\" is not a Feature".into(),
        ));
        return out;
    }
    fill_geometry(&mut out, f.get("geometry"));
    out
}

/// The attribute that holds a feature's `properties` when they are not an object (an array, a string).
pub(crate) const NON_OBJECT_PROPERTIES: &str = "properties";

fn json_kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// GeoJSON `id`, else `properties.id` / `properties["@id"]`, else OSM `osm_type/osm_id`, else `FILE#INDEX`.
fn source_id(f: &Value, file_name: &str, index: usize) -> String {
    fn text(v: Option<&Value>) -> Option<String> {
        match v? {
            Value::String(s) if !s.is_empty() => Some(s.clone()),
            Value::Number(n) => Some(n.to_string()),
            _ => None,
        }
    }
    let props = f.get("properties");
    text(f.get("id"))
        .or_else(|| text(props.and_then(|p| p.get("id"))))
        .or_else(|| text(props.and_then(|p| p.get("@id"))))
        .or_else(|| {
            let t = text(props.and_then(|p| p.get("osm_type")))?;
            let i = text(props.and_then(|p| p.get("osm_id")))?;
            Some(format!("{t}/{i}"))
        })
        .unwrap_or_else(|| format!("{file_name}#{index}"))
}

fn fill_geometry(out: &mut RawFeature, geometry: Option<&Value>) {
    let geometry = match geometry {
        None | Some(Value::Null) => {
            out.skip = Some((IssueReason::NoGeometry, "geometry is null".into()));
            return;
        }
        Some(g) => g,
    };
    let mut polygons = Vec::new();
    if let Err(skip) = collect_polygons(geometry, &mut polygons, &mut out.repairs) {
        out.skip = Some(skip);
        return;
    }
    if polygons.iter().flatten().all(|r| r.is_empty()) {
        out.skip = Some((
            IssueReason::EmptyGeometry,
            "polygonal geometry without coordinates".into(),
        ));
    }
    out.polygons = polygons;
}

type Skip = (IssueReason, String);

fn collect_polygons(
    g: &Value,
    polygons: &mut Vec<RawPolygon>,
    repairs: &mut Vec<(IssueReason, String)>,
) -> Result<(), Skip> {
    let kind = g.get("type").and_then(Value::as_str).unwrap_or("(none)");
    match kind {
        "Polygon" | "MultiPolygon" => polygonal(g, polygons, repairs),
        "GeometryCollection" => {
            let members = g
                .get("geometries")
                .and_then(Value::as_array)
                .ok_or_else(|| {
                    (
                        IssueReason::MalformedGeometry,
                        "GeometryCollection without geometries".to_string(),
                    )
                })?;
            let mut dropped = Vec::new();
            let before = polygons.len();
            for (i, m) in members.iter().enumerate() {
                flatten_member(m, &i.to_string(), polygons, repairs, &mut dropped)?;
            }
            if polygons.len() == before {
                return Err((
                    IssueReason::UnsupportedGeometry,
                    format!(
                        "GeometryCollection without polygons (members: {})",
                        listing(&dropped)
                    ),
                ));
            }
            if !dropped.is_empty() {
                repairs.push((
                    IssueReason::NonPolygonMemberDropped,
                    format!(
                        "{} GeometryCollection member(s) not polygonal, dropped: {}",
                        dropped.len(),
                        listing(&dropped)
                    ),
                ));
            }
            Ok(())
        }
        other => Err((
            IssueReason::UnsupportedGeometry,
            format!("{other} geometry is not a footprint"),
        )),
    }
}

/// One member of a GeometryCollection at `path` (`1/0`: member 0 of member 1): its polygons are
/// collected, nested collections flattened, anything else listed in `dropped` as "member path (Type)".
/// A malformed polygon is an error, as it is outside a collection.
fn flatten_member(
    m: &Value,
    path: &str,
    polygons: &mut Vec<RawPolygon>,
    repairs: &mut Vec<(IssueReason, String)>,
    dropped: &mut Vec<String>,
) -> Result<(), Skip> {
    let kind = m.get("type").and_then(Value::as_str).unwrap_or("no type");
    match kind {
        "Polygon" | "MultiPolygon" => polygonal(m, polygons, repairs),
        "GeometryCollection" => match m.get("geometries").and_then(Value::as_array) {
            Some(members) => {
                for (i, inner) in members.iter().enumerate() {
                    flatten_member(inner, &format!("{path}/{i}"), polygons, repairs, dropped)?;
                }
                Ok(())
            }
            None => {
                dropped.push(format!(
                    "member {path} (GeometryCollection without geometries)"
                ));
                Ok(())
            }
        },
        other => {
            dropped.push(format!("member {path} ({other})"));
            Ok(())
        }
    }
}

/// The rings of a Polygon or each polygon of a MultiPolygon.
fn polygonal(
    g: &Value,
    polygons: &mut Vec<RawPolygon>,
    repairs: &mut Vec<(IssueReason, String)>,
) -> Result<(), Skip> {
    let kind = g.get("type").and_then(Value::as_str).unwrap_or("(none)");
    let coords = g
        .get("coordinates")
        .and_then(Value::as_array)
        .ok_or_else(|| {
            (
                IssueReason::MalformedGeometry,
                format!("{kind} without a coordinates array"),
            )
        })?;
    if kind == "Polygon" {
        polygons.push(polygon(coords, repairs)?);
        return Ok(());
    }
    for p in coords {
        let rings = p.as_array().ok_or_else(|| {
            (
                IssueReason::MalformedGeometry,
                "MultiPolygon member is not an array".into(),
            )
        })?;
        polygons.push(polygon(rings, repairs)?);
    }
    Ok(())
}

/// Dropped members for a message: the first ten, then how many more.
fn listing(dropped: &[String]) -> String {
    const SHOWN: usize = 10;
    if dropped.is_empty() {
        return "none".into();
    }
    let mut s = dropped[..dropped.len().min(SHOWN)].join(", ");
    if dropped.len() > SHOWN {
        s.push_str(&format!(" and {} more", dropped.len() - SHOWN));
    }
    s
}

fn polygon(rings: &[Value], repairs: &mut Vec<(IssueReason, String)>) -> Result<RawPolygon, Skip> {
    rings
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let (ring, was_closed) = ring(r)?;
            if !was_closed && ring.len() >= 3 {
                let what = if i == 0 {
                    "exterior ring".to_string()
                } else {
                    format!("hole {i}")
                };
                repairs.push((
                    IssueReason::RingClosed,
                    format!("{what} was not closed; closed it"),
                ));
            }
            Ok(ring)
        })
        .collect()
}

/// A ring as an open list of (x, y); `true` when the input repeated the first point at the end.
fn ring(r: &Value) -> Result<(Vec<[f64; 2]>, bool), Skip> {
    let bad = |what: &str| (IssueReason::MalformedGeometry, what.to_string());
    let pts = r
        .as_array()
        .ok_or_else(|| bad("ring is not an array of positions"))?;
    let mut out = Vec::with_capacity(pts.len());
    for p in pts {
        let p = p
            .as_array()
            .ok_or_else(|| bad("position is not an array"))?;
        let (Some(x), Some(y)) = (
            p.first().and_then(Value::as_f64),
            p.get(1).and_then(Value::as_f64),
        ) else {
            return Err(bad("position without two numbers"));
        };
        out.push([x, y]);
    }
    let closed = out.len() >= 2 && out.first() == out.last();
    if closed {
        out.pop();
    }
    Ok((out, closed))
}

#[cfg(test)]
mod tests {
    use super::*;
    use citylod_model::AttrValue;
    use serde_json::json;

    #[test]
    fn non_polygon_and_null_geometries_are_marked_skipped() {
        let doc = json!({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {}, "geometry": {"type": "Point", "coordinates": [1, 2]}},
            {"type": "Feature", "properties": {}, "geometry": null},
            {"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": [[1, 2], [3, 4]]}},
            {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": []}},
            {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [[[0, "a"]]]}},
        ]});
        let d = read(&doc, "f.json").unwrap();
        let reasons: Vec<_> = d
            .features
            .iter()
            .map(|f| f.skip.as_ref().map(|s| s.0))
            .collect();
        assert_eq!(
            reasons,
            vec![
                Some(IssueReason::UnsupportedGeometry),
                Some(IssueReason::NoGeometry),
                Some(IssueReason::UnsupportedGeometry),
                Some(IssueReason::EmptyGeometry),
                Some(IssueReason::MalformedGeometry)
            ]
        );
        assert_eq!(d.features[1].source_id, "f.json#1");
    }

    fn square_at(x: f64) -> Value {
        json!({"type": "Polygon", "coordinates": [[[x, 0], [x + 1.0, 0], [x + 1.0, 1], [x, 1], [x, 0]]]})
    }

    #[test]
    fn nested_collections_keep_every_polygon_and_report_dropped_members() {
        let point = json!({"type": "Point", "coordinates": [0, 0]});
        let line = json!({"type": "LineString", "coordinates": [[0, 0], [1, 1]]});
        let gc = |members: Value| json!({"type": "GeometryCollection", "geometries": members});
        let doc = json!({"type": "FeatureCollection", "features": [
            // A polygon beside a collection of only a point (was skipped whole).
            {"type": "Feature", "id": "nested", "properties": {}, "geometry": gc(json!([gc(json!([point])), square_at(0.0)]))},
            // Polygons at two depths, with a line and a point among them.
            {"type": "Feature", "id": "mixed", "properties": {}, "geometry":
                gc(json!([square_at(0.0), line, gc(json!([point, square_at(5.0), {"type": "MultiPolygon",
                    "coordinates": [square_at(9.0)["coordinates"]]}]))]))},
            {"type": "Feature", "id": "no-polygon", "properties": {}, "geometry": gc(json!([point, gc(json!([line]))]))},
            {"type": "Feature", "id": "empty", "properties": {}, "geometry": gc(json!([]))},
        ]});
        let d = read(&doc, "f.json").unwrap();
        let [nested, mixed, none, empty] = &d.features[..] else {
            panic!("4 features")
        };
        assert!(nested.skip.is_none(), "{:?}", nested.skip);
        assert_eq!(nested.polygons.len(), 1);
        assert_eq!(nested.repairs.len(), 1);
        assert_eq!(nested.repairs[0].0, IssueReason::NonPolygonMemberDropped);
        assert!(
            nested.repairs[0].1.contains("member 0/0 (Point)"),
            "{:?}",
            nested.repairs
        );

        assert!(mixed.skip.is_none(), "{:?}", mixed.skip);
        let xs: Vec<f64> = mixed.polygons.iter().map(|p| p[0][0][0]).collect();
        assert_eq!(xs, [0.0, 5.0, 9.0], "every polygon, in document order");
        let note = &mixed.repairs[0].1;
        assert!(
            note.starts_with("2 ")
                && note.contains("member 1 (LineString)")
                && note.contains("member 2/0 (Point)"),
            "{note}"
        );

        let (reason, detail) = none.skip.as_ref().unwrap();
        assert_eq!(*reason, IssueReason::UnsupportedGeometry);
        assert!(
            detail.contains("member 0 (Point)") && detail.contains("member 1/0 (LineString)"),
            "{detail}"
        );
        assert_eq!(
            empty.skip.as_ref().unwrap().0,
            IssueReason::UnsupportedGeometry
        );
    }

    #[test]
    fn dropped_member_listing_is_bounded() {
        let points: Vec<Value> = (0..25)
            .map(|_| json!({"type": "Point", "coordinates": [0, 0]}))
            .collect();
        let mut members = vec![square_at(0.0)];
        members.extend(points);
        let doc = json!({"type": "GeometryCollection", "geometries": members});
        let f = &read(&doc, "f.json").unwrap().features[0];
        let note = &f.repairs[0].1;
        assert!(
            note.starts_with("25 ") && note.ends_with("and 15 more"),
            "{note}"
        );
    }

    #[test]
    fn properties_that_are_not_objects_are_kept_as_one_attribute_and_reported() {
        let doc = json!({"type": "FeatureCollection", "features": [
            {"type": "Feature", "id": "a", "properties": [1, 2, 3], "geometry": square_at(0.0)},
            {"type": "Feature", "id": "s", "properties": "str", "geometry": square_at(2.0)},
            {"type": "Feature", "id": "n", "properties": null, "geometry": square_at(4.0)},
        ]});
        let d = read(&doc, "f.json").unwrap();
        let a = &d.features[0];
        assert_eq!(
            a.attributes["properties"],
            AttrValue::String("[1,2,3]".into())
        );
        assert_eq!(a.repairs[0].0, IssueReason::PropertiesNotObject);
        assert!(a.repairs[0].1.contains("an array"), "{:?}", a.repairs);
        let s = &d.features[1];
        assert_eq!(s.attributes["properties"], AttrValue::String("str".into()));
        assert!(s.repairs[0].1.contains("a string"), "{:?}", s.repairs);
        let n = &d.features[2];
        assert!(
            n.attributes.is_empty() && n.repairs.is_empty(),
            "null properties are allowed"
        );
    }

    #[test]
    fn legacy_crs_members_reach_both_readers() {
        for (crs, expected) in [
            (
                json!({"type": "EPSG", "properties": {"code": 2263}}),
                Some(DeclaredCrs::Name("EPSG:2263".into())),
            ),
            (
                json!({"type": "name", "properties": {"name": "EPSG:2249"}}),
                Some(DeclaredCrs::Name("EPSG:2249".into())),
            ),
            (Value::Null, None),
        ] {
            let doc = json!({"type": "FeatureCollection", "crs": crs, "features": []});
            assert_eq!(read(&doc, "f").unwrap().declared_crs, expected);
            let fast = read_collection_text(&doc.to_string(), "f")
                .unwrap()
                .unwrap();
            assert_eq!(fast.declared_crs, expected);
        }
        let link = json!({"type": "FeatureCollection", "features": [],
            "crs": {"type": "link", "properties": {"href": "http://x/2263.proj4", "type": "proj4"}}});
        let Some(DeclaredCrs::NotUnderstood { member, detail }) =
            read_collection_text(&link.to_string(), "f")
                .unwrap()
                .unwrap()
                .declared_crs
        else {
            panic!("a link is not understood")
        };
        assert_eq!(member, "crs");
        assert!(
            detail.contains("link") && detail.contains("2263.proj4"),
            "{detail}"
        );
    }

    #[test]
    fn collection_fast_path_matches_the_value_reader() {
        let text = r#"{"type": "FeatureCollection", "crs": {"properties": {"name": "EPSG:2249"}}, "features": [
            {"type": "Feature", "id": "a", "properties": {"h": 3}, "geometry": {"type": "Polygon", "coordinates": [[[0,0],[1,0],[1,1],[0,0]]]}},
            {"type": "Feature", "properties": null, "geometry": {"type": "Point", "coordinates": [0, 0]}}]}"#;
        let fast = read_collection_text(text, "f").unwrap().unwrap();
        let slow = read(&serde_json::from_str(text).unwrap(), "f").unwrap();
        assert_eq!(
            fast.declared_crs,
            Some(DeclaredCrs::Name("EPSG:2249".into()))
        );
        assert_eq!(fast.declared_crs, slow.declared_crs);
        assert_eq!(fast.features.len(), 2);
        for (a, b) in fast.features.iter().zip(&slow.features) {
            assert_eq!(
                (&a.source_id, &a.polygons, &a.skip, &a.attributes),
                (&b.source_id, &b.polygons, &b.skip, &b.attributes)
            );
        }
        assert!(read_collection_text("[1, 2]", "f").unwrap().is_none());
        assert!(read_collection_text(r#"{"type": "CityJSON"}"#, "f")
            .unwrap()
            .is_none());
        assert!(
            read_collection_text(r#"{"type": "FeatureCollection", "features": [{"#, "f").is_err()
        );
    }

    #[test]
    fn numbers_beyond_a_double_in_properties_are_kept_as_text() {
        let square = r#"{"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 0]]]}"#;
        let text = format!(
            r#"{{"type": "FeatureCollection", "features": [
                {{"type": "Feature", "id": "a", "properties": {{"year": 1e400, "h": 5, "low": -2e999}},
                  "geometry": {square}}},
                {{"type": "Feature", "id": "b", "properties": {{"h": 5}},
                  "geometry": {{"type": "Polygon", "coordinates": [[[0, 0], [1e400, 0], [1, 1], [0, 0]]]}}}}]}}"#
        );
        let d = read_collection_text(&text, "f").unwrap().unwrap();
        let a = &d.features[0];
        assert!(a.skip.is_none(), "{:?}", a.skip);
        assert_eq!(a.source_id, "a");
        assert_eq!(
            a.attributes.get("year"),
            Some(&AttrValue::String("1e400".into()))
        );
        assert_eq!(
            a.attributes.get("low"),
            Some(&AttrValue::String("-2e999".into()))
        );
        assert_eq!(a.attributes.get("h"), Some(&AttrValue::Int(5)));
        assert_eq!(a.polygons.len(), 1);
        assert!(a
            .repairs
            .iter()
            .any(|(r, m)| *r == IssueReason::NumberKeptAsText && m.contains("low, year")));
        // In the geometry such a number still skips the feature.
        let b = &d.features[1];
        assert_eq!(
            b.skip.as_ref().map(|s| s.0),
            Some(IssueReason::NonFiniteCoordinate)
        );
    }

    #[test]
    fn a_repeated_features_member_is_an_error_not_a_silent_choice() {
        let text = r#"{"type": "FeatureCollection",
            "features": [{"type": "Feature", "properties": {}, "geometry": null}],
            "features": []}"#;
        let e = read_collection_text(text, "f").err().expect("rejected");
        assert!(e.to_string().contains("duplicate field `features`"), "{e}");
        assert_eq!(e.line(), 3);
        // Other repeated members (not read here) do not matter.
        let ok = r#"{"type": "FeatureCollection", "name": "a", "name": "b", "features": []}"#;
        assert_eq!(
            read_collection_text(ok, "f")
                .unwrap()
                .unwrap()
                .features
                .len(),
            0
        );
    }

    #[test]
    fn unclosed_rings_are_closed_and_reported() {
        let doc = json!({"type": "Feature", "id": 7, "properties": {"osm_id": 3},
            "geometry": {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1]]]}});
        let d = read(&doc, "f.json").unwrap();
        let f = &d.features[0];
        assert_eq!(f.source_id, "7");
        assert_eq!(f.polygons[0][0].len(), 3);
        assert_eq!(f.repairs[0].0, IssueReason::RingClosed);
    }

    #[test]
    fn ids_fall_back_to_properties_and_osm_tags() {
        let doc = json!({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {"@id": "way/5"}, "geometry": null},
            {"type": "Feature", "properties": {"osm_type": "relation", "osm_id": 9}, "geometry": null},
        ]});
        let d = read(&doc, "f.json").unwrap();
        assert_eq!(d.features[0].source_id, "way/5");
        assert_eq!(d.features[1].source_id, "relation/9");
    }
}
