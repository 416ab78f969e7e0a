//! GeoJSON reader (RFC 7946): a FeatureCollection, a single Feature or a bare geometry. Polygon,
//! MultiPolygon and the polygons of a GeometryCollection (nested ones flattened; other members dropped
//! and reported) become raw footprints in source coordinates; other geometries are marked as skipped.
//! Properties become attributes, each parsed on its own: a repeated key keeps its last value, a value
//! nested too deep is dropped, both reported. A legacy `crs` member (GeoJSON 2008) is read as [`DeclaredCrs`].

use crate::crs::DeclaredCrs;
use crate::feature::{attr_value, attributes, RawFeature, RawPolygon};
use crate::report::IssueReason;
use rayon::prelude::*;
use serde_json::value::RawValue;
use serde_json::Value;
use std::borrow::Cow;

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

/// The outline of a FeatureCollection (or of a single Feature), with its features still as unparsed JSON text.
#[derive(serde::Deserialize)]
struct Collection<'a> {
    #[serde(rename = "type")]
    kind: Option<String>,
    #[serde(borrow)]
    features: Option<Vec<&'a RawValue>>,
    crs: Option<Value>,
}

/// Fast path for the text of a FeatureCollection or a single Feature: one scan for the outline, then each
/// feature is read from its own text (a collection's in parallel, in order) by [`read_feature_text`]. `Ok(None)`
/// when the text is valid JSON but neither; `Err` when it is not valid JSON or repeats one of the members read
/// here.
pub(crate) fn read_features_text(
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
    let features = match (c.kind.as_deref(), c.features) {
        (Some("FeatureCollection"), Some(raw)) => raw
            .par_iter()
            .enumerate()
            .map(|(i, r)| read_feature_text(r.get(), file_name, i))
            .collect(),
        (Some("Feature"), _) => vec![read_feature_text(text, file_name, 0)],
        _ => return Ok(None),
    };
    Ok(Some(GeoJsonDoc {
        features,
        declared_crs: c.crs.as_ref().and_then(DeclaredCrs::from_geojson),
    }))
}

/// A GeoJSON text sequence (RFC 8142, `ogr2ogr -f GeoJSONSeq`: each Feature after an RS character) or
/// newline-delimited GeoJSON (one Feature per line): its features, each read by [`read_feature_text`] (numbered in
/// file order). `None` when the text is neither: no RS before the first value, and not at least two lines of which
/// the first is a whole Feature. Such a file is WGS84 lon/lat, as RFC 7946 has it.
pub(crate) fn read_sequence(text: &str, file_name: &str) -> Option<GeoJsonDoc> {
    const RS: char = '\u{1e}';
    let records: Vec<&str> = if text.trim_start().starts_with(RS) {
        text.split(RS)
            .map(str::trim)
            .filter(|r| !r.is_empty())
            .collect()
    } else {
        // Every JSON input passes here: a second non-empty line is looked for before the first is parsed, so a
        // document on one line is not parsed twice, and one spread over lines fails on its first line, `{`.
        let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
        let (first, second) = (lines.next()?, lines.next()?);
        let kind = serde_json::from_str::<Collection>(first).ok()?.kind;
        if kind.as_deref() != Some("Feature") {
            return None;
        }
        [first, second].into_iter().chain(lines).collect()
    };
    Some(GeoJsonDoc {
        features: records
            .par_iter()
            .enumerate()
            .map(|(i, r)| read_feature_text(r, file_name, i))
            .collect(),
        declared_crs: None,
    })
}

/// The members of a Feature the reader uses; repeats of other (foreign) members are not reported.
const FEATURE_MEMBERS: [&str; 4] = ["type", "id", "geometry", "properties"];

/// Deepest nesting of arrays and objects serde_json parses in one value (its recursion limit, 128, counts the
/// level it refuses).
const MAX_DEPTH: usize = 127;

/// One feature from its JSON text, each member the reader uses and each property parsed on its own, so that a
/// problem in one property costs only that property: a key given twice keeps its last value (`duplicate_key`), a
/// property nested deeper than [`MAX_DEPTH`] is dropped (`property_too_deep_dropped`) and one holding a number
/// beyond a double, or a `\u` escape that is no character, is kept as its JSON text (`number_kept_as_text`,
/// `undecodable_value_kept_as_text`), each recorded as a repair. In the geometry
/// such a value skips the feature, as any malformed geometry does.
fn read_feature_text(text: &str, file_name: &str, index: usize) -> RawFeature {
    let rejected = |detail: String| RawFeature {
        source_id: format!("{file_name}#{index}"),
        skip: Some((IssueReason::MalformedGeometry, detail)),
        ..Default::default()
    };
    let members = match serde_json::from_str::<Members>(text) {
        Ok(m) => m.0,
        Err(_) if !text.trim_start().starts_with('{') => return rejected(NOT_A_FEATURE.into()),
        Err(e) => return rejected(format!("feature JSON rejected: {e}")),
    };
    let mut given: [Vec<&RawValue>; 4] = Default::default();
    for (key, raw) in &members {
        if let Some(i) = FEATURE_MEMBERS.iter().position(|m| m == key) {
            given[i].push(*raw);
        }
    }
    let mut repairs = Vec::new();
    let repeated: Vec<String> = FEATURE_MEMBERS
        .iter()
        .zip(&given)
        .filter(|(_, values)| values.len() > 1)
        .map(|(name, values)| repeat_note(name, values))
        .collect();
    if !repeated.is_empty() {
        repairs.push((
            IssueReason::DuplicateKey,
            format!(
                "repeated feature members, the last of each kept: {}",
                repeated.join(", ")
            ),
        ));
    }
    let [kind, id, geometry, properties] = given.map(|values| values.last().copied());
    // A `type` that does not parse is no "Feature": the feature is skipped as not one.
    let kind = kind.and_then(|r| serde_json::from_str::<Value>(r.get()).ok());
    let id = match id.map(|r| (r, parse(r))) {
        None => None,
        Some((_, Ok(v))) => Some(v),
        // Kept as its text, as other numeric ids are; an array or object is no id (as when it parses).
        Some((r, Err(Unparsed::BeyondDouble(_)))) if !r.get().starts_with(['[', '{']) => {
            Some(Value::String(r.get().to_string()))
        }
        Some((_, Err(Unparsed::BeyondDouble(_) | Unparsed::TooDeep(_)))) => None,
        Some((r, Err(Unparsed::Other(e)))) => match serde_json::from_str::<Key>(r.get()) {
            // A string id with a `\u` escape that is no character (a lone UTF-16 surrogate): kept with that
            // escape as text, as such property values and keys are; the geometry is not at fault.
            Ok(Key(text, true)) => {
                repairs.push((
                    IssueReason::UndecodableValueKeptAsText,
                    format!(
                        "the feature id has a \\u escape that is no character (a lone UTF-16 surrogate), kept \
                         with that escape as text: {text}"
                    ),
                ));
                Some(Value::String(text.into_owned()))
            }
            _ => return rejected(format!("feature JSON rejected: {e}")),
        },
    };
    let properties = match properties.map(|r| read_properties(r, &mut repairs)) {
        None => None,
        Some(Ok(p)) => p,
        Some(Err(e)) => return rejected(format!("feature JSON rejected: {e}")),
    };
    let geometry = geometry.map(parse).transpose().map_err(unparsed_geometry);
    let parts = Parts {
        kind: kind.as_ref(),
        id: id.as_ref(),
        properties: properties.as_ref(),
        geometry: geometry.as_ref().map(Option::as_ref).map_err(Clone::clone),
        repairs,
    };
    feature(parts, file_name, index)
}

/// The skip of a feature whose geometry serde_json does not parse.
fn unparsed_geometry(u: Unparsed) -> Skip {
    match u {
        Unparsed::TooDeep(depth) => (
            IssueReason::MalformedGeometry,
            format!("geometry nested {depth} levels deep; at most {MAX_DEPTH} are read"),
        ),
        Unparsed::BeyondDouble(e) => (
            IssueReason::NonFiniteCoordinate,
            format!("geometry JSON rejected: {e}"),
        ),
        Unparsed::Other(e) => (
            IssueReason::MalformedGeometry,
            format!("geometry JSON rejected: {e}"),
        ),
    }
}

/// A feature's `properties` from their text: each member parsed on its own, the last of a repeated key kept, one
/// nested too deep dropped, one with a number beyond a double or an undecodable `\u` escape (a lone UTF-16
/// surrogate) kept as its JSON text, each recorded in `repairs`. `properties` that are not an object are one such
/// value (`None` when dropped). A key with a lone surrogate is kept with its escape written out
/// (`undecodable_key_kept_as_text`). `Err` when the members cannot be read at all.
fn read_properties(
    raw: &RawValue,
    repairs: &mut Vec<(IssueReason, String)>,
) -> Result<Option<Value>, serde_json::Error> {
    let (mut too_deep, mut as_text, mut undecodable) = (Vec::new(), Vec::new(), Vec::new());
    let mut read = |name: &str, raw: &RawValue| match parse(raw) {
        Ok(v) => Some(v),
        Err(Unparsed::TooDeep(depth)) => {
            too_deep.push(format!("{name} ({depth} levels)"));
            None
        }
        Err(Unparsed::BeyondDouble(_)) => {
            as_text.push(name.to_string());
            Some(Value::String(raw.get().to_string()))
        }
        Err(Unparsed::Other(_)) => {
            undecodable.push(name.to_string());
            Some(Value::String(raw.get().to_string()))
        }
    };
    let value = if raw.get().starts_with('{') {
        let (mut members, undecodable_keys) = {
            let m = serde_json::from_str::<Members>(raw.get())?;
            (m.0, m.1)
        };
        if !undecodable_keys.is_empty() {
            repairs.push((
                IssueReason::UndecodableKeyKeptAsText,
                format!(
                    "a key with a \\u escape that is no character (a lone UTF-16 surrogate), kept with that escape as text: {}",
                    listing(&undecodable_keys)
                ),
            ));
        }
        // Stable: the values of a repeated key stay in document order, the last one last.
        members.sort_by(|a, b| a.0.cmp(&b.0));
        let mut repeated = Vec::new();
        let mut object = serde_json::Map::with_capacity(members.len());
        for run in members.chunk_by(|a, b| a.0 == b.0) {
            let (key, last) = &run[run.len() - 1];
            if run.len() > 1 {
                let values: Vec<&RawValue> = run.iter().map(|(_, r)| *r).collect();
                repeated.push(repeat_note(key, &values));
            }
            if let Some(v) = read(key, last) {
                object.insert(key.to_string(), v);
            }
        }
        if !repeated.is_empty() {
            repairs.push((
                IssueReason::DuplicateKey,
                format!(
                    "repeated property keys, the last value of each kept: {}",
                    listing(&repeated)
                ),
            ));
        }
        Some(Value::Object(object))
    } else {
        read(NON_OBJECT_PROPERTIES, raw)
    };
    if !too_deep.is_empty() {
        repairs.push((
            IssueReason::PropertyTooDeepDropped,
            format!(
                "nested deeper than {MAX_DEPTH} levels, dropped: {}",
                listing(&too_deep)
            ),
        ));
    }
    if !as_text.is_empty() {
        repairs.push((
            IssueReason::NumberKeptAsText,
            format!(
                "{} beyond the range of a double, kept as JSON text: {}",
                if as_text.len() == 1 {
                    "a number"
                } else {
                    "numbers"
                },
                listing(&as_text)
            ),
        ));
    }
    if !undecodable.is_empty() {
        repairs.push((
            IssueReason::UndecodableValueKeptAsText,
            format!(
                "a \\u escape that is no character (a lone UTF-16 surrogate), kept as JSON text: {}",
                listing(&undecodable)
            ),
        ));
    }
    Ok(value)
}

/// `key (given N times, …)` for a repair detail: whether the values it was given are equal.
fn repeat_note(key: &str, values: &[&RawValue]) -> String {
    let first = values[0];
    let equal = values.iter().all(|r| {
        r.get() == first.get() || matches!((parse(r), parse(first)), (Ok(a), Ok(b)) if a == b)
    });
    let how = if equal { "equal" } else { "different" };
    format!("{key} (given {} times, {how} values)", values.len())
}

/// A JSON object's members in document order, a repeated key as often as given (a map would keep one), the
/// values unparsed; and the keys that held a lone surrogate (see [`Key`]), in document order.
struct Members<'a>(Vec<(Cow<'a, str>, &'a RawValue)>, Vec<String>);

impl<'de> serde::Deserialize<'de> for Members<'de> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = Members<'de>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a JSON object")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> Result<Members<'de>, A::Error> {
                let (mut out, mut undecodable) = (Vec::new(), Vec::new());
                while let Some(Key(k, lone_surrogate)) = map.next_key()? {
                    if lone_surrogate {
                        undecodable.push(k.to_string());
                    }
                    out.push((k, map.next_value()?));
                }
                Ok(Members(out, undecodable))
            }
        }
        d.deserialize_map(Visit)
    }
}

/// An object key, borrowed from the text unless it has escapes. A `\u` escape of a lone UTF-16 surrogate, which
/// is no character, stays that escape in the key's text (`caf\ud800`), and the flag is set.
struct Key<'a>(Cow<'a, str>, bool);

impl<'de> serde::Deserialize<'de> for Key<'de> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = Key<'de>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a string")
            }
            fn visit_borrowed_str<E>(self, s: &'de str) -> Result<Key<'de>, E> {
                Ok(Key(Cow::Borrowed(s), false))
            }
            fn visit_str<E>(self, s: &str) -> Result<Key<'de>, E> {
                Ok(Key(Cow::Owned(s.to_string()), false))
            }
            fn visit_borrowed_bytes<E>(self, b: &'de [u8]) -> Result<Key<'de>, E> {
                Ok(match std::str::from_utf8(b) {
                    Ok(s) => Key(Cow::Borrowed(s), false),
                    Err(_) => Key(Cow::Owned(wtf8_escaped(b)), true),
                })
            }
            fn visit_bytes<E>(self, b: &[u8]) -> Result<Key<'de>, E> {
                Ok(match std::str::from_utf8(b) {
                    Ok(s) => Key(Cow::Owned(s.to_string()), false),
                    Err(_) => Key(Cow::Owned(wtf8_escaped(b)), true),
                })
            }
        }
        // As bytes, serde_json decodes a lone surrogate (as WTF-8) where a string refuses it.
        d.deserialize_bytes(Visit)
    }
}

/// Text of a WTF-8 string (UTF-8 plus encoded lone surrogates, which serde_json gives for `\u` escapes of lone
/// surrogates read as bytes): each lone surrogate written back as its escape `\uXXXX`.
fn wtf8_escaped(mut b: &[u8]) -> String {
    let mut out = String::with_capacity(b.len() + 8);
    while !b.is_empty() {
        match std::str::from_utf8(b) {
            Ok(s) => {
                out.push_str(s);
                break;
            }
            Err(e) => {
                let (good, rest) = b.split_at(e.valid_up_to());
                out.push_str(std::str::from_utf8(good).expect("valid up to here"));
                // A surrogate U+D800..U+DFFF in three bytes: 1110_1101, 10_1xxxxx, 10_xxxxxx.
                if let [0xED, b1 @ 0xA0..=0xBF, b2 @ 0x80..=0xBF, ..] = *rest {
                    let unit = 0xD000 | (u32::from(b1 & 0x3F) << 6) | u32::from(b2 & 0x3F);
                    out.push_str(&format!("\\u{unit:04x}"));
                    b = &rest[3..];
                } else {
                    out.push(char::REPLACEMENT_CHARACTER);
                    b = &rest[e.error_len().unwrap_or(rest.len()).max(1)..];
                }
            }
        }
    }
    out
}

/// Why serde_json did not parse a value whose syntax the outline scan accepted.
enum Unparsed {
    /// Arrays and objects nested this many levels deep, more than [`MAX_DEPTH`].
    TooDeep(usize),
    /// A number beyond the range of a double (`1e400`).
    BeyondDouble(serde_json::Error),
    /// Anything else (a lone UTF-16 surrogate in a `\u` escape).
    Other(serde_json::Error),
}

/// One value parsed on its own; serde_json's recursion limit then applies to it alone.
fn parse(raw: &RawValue) -> Result<Value, Unparsed> {
    serde_json::from_str(raw.get()).map_err(|e| match nesting_depth(raw.get()) {
        depth if depth > MAX_DEPTH => Unparsed::TooDeep(depth),
        _ if e.to_string().starts_with("number out of range") => Unparsed::BeyondDouble(e),
        _ => Unparsed::Other(e),
    })
}

/// Deepest nesting of arrays and objects in JSON text, in one pass without recursion (any depth).
fn nesting_depth(json: &str) -> usize {
    let (mut depth, mut deepest, mut in_string, mut escaped) = (0usize, 0, false, false);
    for b in json.bytes() {
        if in_string {
            match b {
                _ if escaped => escaped = false,
                b'\\' => escaped = true,
                b'"' => in_string = false,
                _ => {}
            }
            continue;
        }
        match b {
            b'"' => in_string = true,
            b'[' | b'{' => {
                depth += 1;
                deepest = deepest.max(depth);
            }
            b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    deepest
}

/// The members of a Feature the reader uses, parsed; `geometry` is `Err` when it could not be parsed.
struct Parts<'v> {
    kind: Option<&'v Value>,
    id: Option<&'v Value>,
    properties: Option<&'v Value>,
    geometry: Result<Option<&'v Value>, Skip>,
    /// Repairs already made while parsing.
    repairs: Vec<(IssueReason, String)>,
}

/// A feature already parsed as one value (a document read whole).
fn read_feature(f: &Value, file_name: &str, index: usize) -> RawFeature {
    let parts = Parts {
        kind: f.get("type"),
        id: f.get("id"),
        properties: f.get("properties"),
        geometry: Ok(f.get("geometry")),
        repairs: Vec::new(),
    };
    feature(parts, file_name, index)
}

const NOT_A_FEATURE: &str = "member of \"features\" is not a Feature";

/// The raw feature of parsed parts: source id, attributes, geometry, or the reason it is skipped.
fn feature(parts: Parts, file_name: &str, index: usize) -> RawFeature {
    let props = parts.properties;
    let mut out = RawFeature {
        source_id: source_id(parts.id, props, file_name, index),
        attributes: attributes(props),
        repairs: parts.repairs,
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
    if parts.kind.and_then(Value::as_str) != Some("Feature") {
        out.skip = Some((IssueReason::MalformedGeometry, NOT_A_FEATURE.into()));
        return out;
    }
    match parts.geometry {
        Ok(g) => fill_geometry(&mut out, g),
        Err(skip) => out.skip = Some(skip),
    }
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
fn source_id(id: Option<&Value>, props: Option<&Value>, file_name: &str, index: usize) -> String {
    fn text(v: Option<&Value>) -> Option<String> {
        match v? {
            Value::String(s) if !s.is_empty() => Some(s.clone()),
            Value::Number(n) => Some(n.to_string()),
            _ => None,
        }
    }
    text(id)
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
    out.z_ignored = geometry.get("coordinates").is_some_and(nonzero_z);
}

/// Whether some position under `v` (a coordinates array, any nesting) has a third number other than 0.
fn nonzero_z(v: &Value) -> bool {
    let Some(items) = v.as_array() else {
        return false;
    };
    if items.first().is_some_and(Value::is_number) {
        return items
            .get(2)
            .and_then(Value::as_f64)
            .is_some_and(|z| z != 0.0);
    }
    items.iter().any(nonzero_z)
}

type Skip = (IssueReason, String);

fn collect_polygons(
    g: &Value,
    polygons: &mut Vec<RawPolygon>,
    repairs: &mut Vec<(IssueReason, String)>,
) -> Result<(), Skip> {
    let Some(kind) = g.get("type").and_then(Value::as_str) else {
        return Err((
            IssueReason::MalformedGeometry,
            "a geometry without a \"type\" string".to_string(),
        ));
    };
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
                repairs.push(crate::feature::dropped_members(&dropped));
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

/// Names for a message: the first ten, then how many more.
pub(crate) fn listing(dropped: &[String]) -> String {
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
            let fast = read_features_text(&doc.to_string(), "f").unwrap().unwrap();
            assert_eq!(fast.declared_crs, expected);
        }
        let link = json!({"type": "FeatureCollection", "features": [],
            "crs": {"type": "link", "properties": {"href": "http://x/2263.proj4", "type": "proj4"}}});
        let Some(DeclaredCrs::NotUnderstood { member, detail }) =
            read_features_text(&link.to_string(), "f")
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
        let fast = read_features_text(text, "f").unwrap().unwrap();
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
        assert!(read_features_text("[1, 2]", "f").unwrap().is_none());
        assert!(read_features_text(r#"{"type": "CityJSON"}"#, "f")
            .unwrap()
            .is_none());
        assert!(
            read_features_text(r#"{"type": "FeatureCollection", "features": [{"#, "f").is_err()
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
        let d = read_features_text(&text, "f").unwrap().unwrap();
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
        let e = read_features_text(text, "f").err().expect("rejected");
        assert!(e.to_string().contains("duplicate field `features`"), "{e}");
        assert_eq!(e.line(), 3);
        // Other repeated members (not read here) do not matter.
        let ok = r#"{"type": "FeatureCollection", "name": "a", "name": "b", "features": []}"#;
        assert_eq!(
            read_features_text(ok, "f").unwrap().unwrap().features.len(),
            0
        );
    }

    /// `[[…]]` nested `depth` levels deep.
    fn nested_arrays(depth: usize) -> String {
        format!("{}{}", "[".repeat(depth), "]".repeat(depth))
    }

    const SQUARE: &str =
        r#"{"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 0]]]}"#;

    fn one_feature(text: &str) -> RawFeature {
        let mut d = read_features_text(text, "f").unwrap().unwrap().features;
        assert_eq!(d.len(), 1);
        d.remove(0)
    }

    fn repair(f: &RawFeature, reason: IssueReason) -> Option<&str> {
        f.repairs
            .iter()
            .find(|(r, _)| *r == reason)
            .map(|(_, d)| d.as_str())
    }

    #[test]
    fn a_lone_surrogate_in_a_property_is_kept_as_text_not_a_skip() {
        let text = format!(
            r#"{{"type": "FeatureCollection", "features": [{{"type": "Feature", "id": "s",
            "properties": {{"name": "caf\ud800", "nested": ["\udc00"], "height": 12}},
            "geometry": {SQUARE}}}]}}"#
        );
        let f = one_feature(&text);
        assert!(f.skip.is_none(), "{:?}", f.skip);
        assert_eq!(f.source_id, "s");
        let get = |k: &str| f.attributes.get(k);
        assert_eq!(
            get("name"),
            Some(&AttrValue::String(r#""caf\ud800""#.into()))
        );
        assert_eq!(
            get("nested"),
            Some(&AttrValue::String(r#"["\udc00"]"#.into()))
        );
        assert_eq!(get("height"), Some(&AttrValue::Int(12)));
        let detail = repair(&f, IssueReason::UndecodableValueKeptAsText).expect("reported");
        assert!(
            detail.contains("name") && detail.contains("nested"),
            "{detail}"
        );
    }

    /// A lone surrogate in the feature's id skipped the feature as `malformed_geometry` (found by fuzzing); the id
    /// keeps the escape as text, the repair says so, and the building is read.
    #[test]
    fn a_lone_surrogate_in_the_id_keeps_it_escaped_not_a_skip() {
        let text = format!(
            r#"{{"type": "FeatureCollection", "features": [{{"type": "Feature", "id": "a\ud800b",
            "properties": {{"height": 12}}, "geometry": {SQUARE}}}]}}"#
        );
        let f = one_feature(&text);
        assert!(f.skip.is_none(), "{:?}", f.skip);
        assert_eq!(f.source_id, r"a\ud800b");
        let detail = repair(&f, IssueReason::UndecodableValueKeptAsText).expect("reported");
        assert!(detail.contains("feature id"), "{detail}");
    }

    #[test]
    fn a_lone_surrogate_in_a_property_key_keeps_the_key_escaped_not_a_skip() {
        let text = format!(
            r#"{{"type": "FeatureCollection", "features": [{{"type": "Feature", "id": "k",
            "properties": {{"caf\ud800": 1, "\uDC00x\u00e9": "v", "height": 12}},
            "geometry": {SQUARE}}}]}}"#
        );
        let f = one_feature(&text);
        assert!(f.skip.is_none(), "{:?}", f.skip);
        assert_eq!(f.source_id, "k");
        let get = |k: &str| f.attributes.get(k);
        assert_eq!(get(r"caf\ud800"), Some(&AttrValue::Int(1)));
        assert_eq!(get("\\udc00x\u{e9}"), Some(&AttrValue::String("v".into())));
        assert_eq!(get("height"), Some(&AttrValue::Int(12)));
        let detail = repair(&f, IssueReason::UndecodableKeyKeptAsText).expect("reported");
        assert!(detail.contains(r"caf\ud800"), "{detail}");
        assert!(repair(&f, IssueReason::UndecodableValueKeptAsText).is_none());
        assert_eq!(wtf8_escaped("plain é".as_bytes()), "plain é");
    }

    #[test]
    fn a_property_nested_too_deep_is_dropped_and_the_building_kept() {
        for depth in [MAX_DEPTH + 1, 3_000, 100_000] {
            let deep_object = format!("{}1{}", r#"{"k":"#.repeat(depth), "}".repeat(depth));
            let text = format!(
                r#"{{"type": "FeatureCollection", "features": [{{"type": "Feature", "id": "deep",
                    "properties": {{"height": 10, "a": {}, "name": "x", "o": {deep_object}}}, "geometry": {SQUARE}}}]}}"#,
                nested_arrays(depth)
            );
            let f = one_feature(&text);
            assert!(f.skip.is_none(), "{depth}: {:?}", f.skip);
            assert_eq!(f.source_id, "deep");
            assert_eq!(f.polygons.len(), 1);
            let names: Vec<&String> = f.attributes.keys().collect();
            assert_eq!(names, ["height", "name"], "{depth}");
            let detail = repair(&f, IssueReason::PropertyTooDeepDropped).expect("reported");
            assert!(
                detail.contains(&format!("a ({depth} levels)"))
                    && detail.contains(&format!("o ({depth} levels)")),
                "{detail}"
            );
        }
        // The deepest value the parser reads is kept, as JSON text like any nested value.
        let text = format!(
            r#"{{"type": "Feature", "properties": {{"a": {}}}, "geometry": {SQUARE}}}"#,
            nested_arrays(MAX_DEPTH)
        );
        let f = one_feature(&text);
        assert_eq!(
            f.attributes.get("a"),
            Some(&AttrValue::String(nested_arrays(MAX_DEPTH)))
        );
        assert!(f.repairs.is_empty(), "{:?}", f.repairs);
    }

    #[test]
    fn too_deep_properties_or_geometry_are_named_as_such() {
        let deep = nested_arrays(100_000);
        // `properties` itself too deep: dropped, the building kept.
        let f = one_feature(&format!(
            r#"{{"type": "Feature", "id": 3, "properties": {deep}, "geometry": {SQUARE}}}"#
        ));
        assert!(f.skip.is_none() && f.attributes.is_empty(), "{:?}", f.skip);
        assert!(repair(&f, IssueReason::PropertyTooDeepDropped)
            .unwrap()
            .contains("properties (100000 levels)"));
        // A geometry that deep is malformed, and says why.
        let f = one_feature(&format!(
            r#"{{"type": "Feature", "id": 4, "properties": {{}}, "geometry": {{"type": "Polygon", "coordinates": {deep}}}}}"#
        ));
        let (reason, detail) = f.skip.unwrap();
        assert_eq!(
            (reason, f.source_id.as_str()),
            (IssueReason::MalformedGeometry, "4")
        );
        assert!(detail.contains("100001 levels deep"), "{detail}");
        // An id that deep is no id, as an array never is.
        let f = one_feature(&format!(
            r#"{{"type": "Feature", "id": {deep}, "properties": {{"id": "p"}}, "geometry": {SQUARE}}}"#
        ));
        assert_eq!((f.source_id.as_str(), f.skip), ("p", None));
    }

    #[test]
    fn repeated_property_keys_keep_the_last_value_and_are_reported() {
        let f = one_feature(&format!(
            r#"{{"type": "Feature", "id": "r", "properties": {{"height": 10, "name": "a", "height": 20,
                "name": "a", "only": 1, "h\u0065ight": 30}}, "geometry": {SQUARE}}}"#
        ));
        assert!(f.skip.is_none());
        assert_eq!(f.attributes.get("height"), Some(&AttrValue::Int(30)));
        assert_eq!(f.attributes.get("only"), Some(&AttrValue::Int(1)));
        let detail = repair(&f, IssueReason::DuplicateKey).expect("reported");
        assert_eq!(
            detail,
            "repeated property keys, the last value of each kept: height (given 3 times, different values), \
             name (given 2 times, equal values)"
        );
        // The last value is the one read, even when it cannot be: no earlier one stands in for it.
        let f = one_feature(&format!(
            r#"{{"type": "Feature", "properties": {{"a": 1, "a": {}}}, "geometry": {SQUARE}}}"#,
            nested_arrays(500)
        ));
        assert!(f.attributes.get("a").is_none());
        assert!(repair(&f, IssueReason::DuplicateKey).is_some());
        assert!(repair(&f, IssueReason::PropertyTooDeepDropped).is_some());
        // An id repeated in the properties: the last is the feature's id.
        let f = one_feature(&format!(
            r#"{{"type": "Feature", "properties": {{"id": "x", "id": "y"}}, "geometry": {SQUARE}}}"#
        ));
        assert_eq!(f.source_id, "y");
    }

    #[test]
    fn repeated_feature_members_keep_the_last_and_are_reported() {
        let moved = SQUARE.replace("[1, 0], [1, 1]", "[5, 0], [5, 5]");
        let member = format!(
            r#"{{"type": "Feature", "type": "Feature", "id": "a", "id": "b", "properties": {{"h": 1}},
                "properties": {{"h": 2}}, "geometry": {SQUARE}, "geometry": {moved}, "bbox": [0], "bbox": [1]}}"#
        );
        let f = one_feature(&format!(
            r#"{{"type": "FeatureCollection", "features": [{member}]}}"#
        ));
        assert!(f.skip.is_none(), "{:?}", f.skip);
        assert_eq!(f.source_id, "b");
        assert_eq!(f.attributes.get("h"), Some(&AttrValue::Int(2)));
        assert_eq!(f.polygons[0][0][1], [5.0, 0.0], "the last geometry");
        let detail = repair(&f, IssueReason::DuplicateKey).expect("reported");
        assert_eq!(
            detail,
            "repeated feature members, the last of each kept: type (given 2 times, equal values), \
             id (given 2 times, different values), geometry (given 2 times, different values), \
             properties (given 2 times, different values)"
        );
        assert_eq!(
            f.repairs.len(),
            1,
            "a foreign member (bbox) is not read: {:?}",
            f.repairs
        );
        // A document that is one Feature: its `type` is read for the outline, where a repeat is an error.
        let e = read_features_text(&member, "f").err().expect("rejected");
        assert!(e.to_string().contains("duplicate field `type`"), "{e}");
        // The same geometry twice, but written differently: equal values.
        let spaced = SQUARE.replace(", ", ",");
        let f = one_feature(&format!(
            r#"{{"type": "Feature", "properties": null, "geometry": {SQUARE}, "geometry": {spaced}}}"#
        ));
        assert!(repair(&f, IssueReason::DuplicateKey)
            .unwrap()
            .contains("geometry (given 2 times, equal values)"));
        // A file without repeats reports none.
        let f = one_feature(&format!(
            r#"{{"type": "Feature", "properties": {{"a": 1, "b": 2}}, "geometry": {SQUARE}}}"#
        ));
        assert!(f.repairs.is_empty(), "{:?}", f.repairs);
    }

    #[test]
    fn numeric_and_text_ids_read_the_same() {
        let text = format!(
            r#"{{"type": "FeatureCollection", "features": [
                {{"type": "Feature", "id": 1, "properties": {{}}, "geometry": {SQUARE}}},
                {{"type": "Feature", "id": "1", "properties": {{}}, "geometry": {SQUARE}}},
                {{"type": "Feature", "id": 1e400, "properties": {{}}, "geometry": {SQUARE}}}]}}"#
        );
        let ids: Vec<String> = read_features_text(&text, "f")
            .unwrap()
            .unwrap()
            .features
            .into_iter()
            .map(|f| f.source_id)
            .collect();
        assert_eq!(ids, ["1", "1", "1e400"]);
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
