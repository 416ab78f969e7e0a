//! Property tables of EXT_structural_metadata: the inline schema, and columns encoded as the spec
//! lays them out (numbers little-endian, strings as UTF-8 plus offsets of the narrowest unsigned type
//! that holds the column's length, booleans as a bitstream, least significant bit first). Null rule:
//! numeric and string properties write their `noData` value (see [`PropertyKind`]); booleans have no
//! `noData` in the spec and write `false`.

use crate::gltf_json::{Class, ClassProperty, Schema};
use crate::spec::{MetadataSchema, PropValue, PropertyDef, PropertyKind};
use std::collections::BTreeMap;

pub(crate) const NO_DATA_F64: f64 = f64::MIN;
pub(crate) const NO_DATA_F32: f32 = f32::MIN;
pub(crate) const NO_DATA_I32: i32 = i32::MIN;
pub(crate) const NO_DATA_I64: i64 = i64::MIN;
pub(crate) const NO_DATA_U32: u32 = u32::MAX;

/// The whole schema, every class, as the JSON object an EXT_structural_metadata `schema` holds (what
/// `schemas/metadata.json` documents for citylod's fixed properties).
pub fn schema_to_json(schema: &MetadataSchema) -> serde_json::Value {
    let used: Vec<&str> = schema.classes.iter().map(|c| c.id.as_str()).collect();
    serde_json::to_value(schema_json(schema, &used, true)).expect("schema structs always serialize")
}

/// The schema as written inline in a glb: only the classes `used` (by the glb's property tables), so a tile of
/// blocks does not carry the building class's many attribute properties, and without the properties'
/// descriptions unless `descriptions` (they are documentation, the same in every tile: about 1 KB a tile).
pub(crate) fn schema_json(schema: &MetadataSchema, used: &[&str], descriptions: bool) -> Schema {
    let classes: BTreeMap<String, Class> = schema
        .classes
        .iter()
        .filter(|c| used.contains(&c.id.as_str()))
        .map(|c| {
            let properties = c
                .properties
                .iter()
                .map(|p| {
                    let (ty, ct, no_data) = match p.kind {
                        PropertyKind::String => (
                            "STRING",
                            None,
                            serde_json::json!(p.string_no_data.as_deref().unwrap_or("")),
                        ),
                        PropertyKind::Float64 => {
                            ("SCALAR", Some("FLOAT64"), serde_json::json!(NO_DATA_F64))
                        }
                        PropertyKind::Float32 => {
                            ("SCALAR", Some("FLOAT32"), serde_json::json!(NO_DATA_F32))
                        }
                        PropertyKind::Int32 => {
                            ("SCALAR", Some("INT32"), serde_json::json!(NO_DATA_I32))
                        }
                        PropertyKind::Int64 => {
                            ("SCALAR", Some("INT64"), serde_json::json!(NO_DATA_I64))
                        }
                        PropertyKind::UInt32 => {
                            ("SCALAR", Some("UINT32"), serde_json::json!(NO_DATA_U32))
                        }
                        PropertyKind::Boolean => ("BOOLEAN", None, serde_json::Value::Null),
                    };
                    let prop = ClassProperty {
                        r#type: ty.into(),
                        component_type: ct.map(Into::into),
                        // The spec wants a name of at least one character: an attribute named "" (id `_`) has none.
                        name: p.input_name.clone().filter(|n| !n.is_empty()),
                        description: p.description.clone().filter(|_| descriptions),
                        no_data: (p.nullable && !no_data.is_null()).then_some(no_data),
                        ..Default::default()
                    };
                    (p.name.clone(), prop)
                })
                .collect();
            (c.id.clone(), Class { properties })
        })
        .collect();
    // The spec makes `id` the schema's unique identifier, and glbs of one tileset carry different class sets
    // (blocks, buildings, both) and builds different attributes: the id names the classes it holds, by a hash
    // of their definitions (descriptions left out, they document and do not define).
    let mut definitions = classes.clone();
    for class in definitions.values_mut() {
        for p in class.properties.values_mut() {
            p.description = None;
        }
    }
    let text = serde_json::to_vec(&definitions).expect("schema structs always serialize");
    Schema {
        id: format!("{}_{:08x}", schema.id, fnv1a32(&text)),
        classes,
    }
}

/// The 32-bit FNV-1a hash (deterministic across platforms and runs, unlike the std hasher).
fn fnv1a32(bytes: &[u8]) -> u32 {
    bytes.iter().fold(0x811c_9dc5, |h: u32, &b| {
        (h ^ b as u32).wrapping_mul(0x0100_0193)
    })
}

/// One encoded column: the `values` bytes and, for strings, the `stringOffsets` bytes and their
/// `stringOffsetType`.
pub(crate) struct Column {
    pub values: Vec<u8>,
    pub string_offsets: Option<(Vec<u8>, &'static str)>,
}

/// Encodes one property for `values` (one per feature). `Err` says which feature's value does not
/// fit the kind.
pub(crate) fn encode_column<'a>(
    prop: &PropertyDef,
    values: impl ExactSizeIterator<Item = &'a PropValue>,
) -> Result<Column, (usize, String)> {
    let kind = prop.kind;
    let n = values.len();
    let mut out = Vec::new();
    let mut offsets: Vec<usize> = Vec::new();
    let mut bits = vec![0u8; n.div_ceil(8)];
    for (i, v) in values.enumerate() {
        let bad = |what: &str| (i, format!("{v:?} does not fit a {what} property"));
        if *v == PropValue::Null && !prop.nullable && kind != PropertyKind::Boolean {
            return Err((i, "no value for a property that is not nullable".into()));
        }
        match kind {
            PropertyKind::Float64 => {
                let x = match v {
                    PropValue::Null => NO_DATA_F64,
                    PropValue::Float(f) => *f,
                    PropValue::Int(k) => *k as f64,
                    _ => return Err(bad("Float64")),
                };
                out.extend_from_slice(&x.to_le_bytes());
            }
            PropertyKind::Float32 => {
                let x = match v {
                    PropValue::Null => NO_DATA_F32,
                    PropValue::Float(f) => *f as f32,
                    PropValue::Int(k) => *k as f32,
                    _ => return Err(bad("Float32")),
                };
                out.extend_from_slice(&x.to_le_bytes());
            }
            PropertyKind::Int32 => {
                let x = match v {
                    PropValue::Null => NO_DATA_I32,
                    PropValue::Int(k) if PropertyKind::int32_holds(*k) => *k as i32,
                    PropValue::Float(f)
                        if f.fract() == 0.0 && PropertyKind::int32_holds(*f as i64) =>
                    {
                        *f as i32
                    }
                    _ => return Err(bad("Int32")),
                };
                out.extend_from_slice(&x.to_le_bytes());
            }
            PropertyKind::Int64 => {
                let x = match v {
                    PropValue::Null => NO_DATA_I64,
                    PropValue::Int(k) => *k,
                    PropValue::Float(f) if f.fract() == 0.0 && f.abs() < 9.2e18 => *f as i64,
                    _ => return Err(bad("Int64")),
                };
                out.extend_from_slice(&x.to_le_bytes());
            }
            PropertyKind::UInt32 => {
                let x = match v {
                    PropValue::Null => NO_DATA_U32,
                    PropValue::Int(k) => u32::try_from(*k).map_err(|_| bad("UInt32"))?,
                    PropValue::Float(f) if f.fract() == 0.0 && (0.0..4.3e9).contains(f) => {
                        u32::try_from(*f as u64).map_err(|_| bad("UInt32"))?
                    }
                    _ => return Err(bad("UInt32")),
                };
                out.extend_from_slice(&x.to_le_bytes());
            }
            PropertyKind::Boolean => match v {
                PropValue::Bool(true) => bits[i / 8] |= 1 << (i % 8),
                PropValue::Bool(false) | PropValue::Null => {}
                _ => return Err(bad("Boolean")),
            },
            PropertyKind::String => {
                offsets.push(out.len());
                match v {
                    PropValue::Null => out
                        .extend_from_slice(prop.string_no_data.as_deref().unwrap_or("").as_bytes()),
                    PropValue::Str(s) => out.extend_from_slice(s.as_bytes()),
                    PropValue::Bool(b) => out.extend_from_slice(b.to_string().as_bytes()),
                    PropValue::Int(k) => out.extend_from_slice(k.to_string().as_bytes()),
                    PropValue::Float(f) => out.extend_from_slice(f.to_string().as_bytes()),
                }
            }
        }
    }
    Ok(match kind {
        PropertyKind::Boolean => Column {
            values: bits,
            string_offsets: None,
        },
        PropertyKind::String => {
            offsets.push(out.len());
            Column {
                string_offsets: Some(encode_offsets(&offsets).map_err(|m| (n, m))?),
                values: out,
            }
        }
        _ => Column {
            values: out,
            string_offsets: None,
        },
    })
}

/// String offsets (ascending, the last one the column's length) in the narrowest of UINT8, UINT16 and
/// UINT32 that holds the last: a tile's string column rarely reaches 64 KiB, so this halves what most offsets
/// cost. Returns the bytes and the `stringOffsetType`.
fn encode_offsets(offsets: &[usize]) -> Result<(Vec<u8>, &'static str), String> {
    let last = offsets.last().copied().unwrap_or(0);
    let (ty, size) = if last <= u8::MAX as usize {
        ("UINT8", 1)
    } else if last <= u16::MAX as usize {
        ("UINT16", 2)
    } else if u32::try_from(last).is_ok() {
        ("UINT32", 4)
    } else {
        return Err("string column exceeds 4 GiB".to_string());
    };
    let mut bytes = Vec::with_capacity(offsets.len() * size);
    for &o in offsets {
        bytes.extend_from_slice(&(o as u64).to_le_bytes()[..size]);
    }
    Ok((bytes, ty))
}

/// Decodes `count` values of one property. Values equal to the property's `noData` read as `Null`.
pub(crate) fn decode_column(
    prop: &ClassProperty,
    count: usize,
    values: &[u8],
    string_offsets: Option<(&[u8], &str)>,
) -> Result<Vec<PropValue>, String> {
    let no_data = prop.no_data.as_ref();
    // Misread as plain values these would be wrong without a sign: refused instead.
    for (given, what) in [
        (prop.array, "array"),
        (prop.normalized, "normalized"),
        (
            prop.offset.is_some() || prop.scale.is_some(),
            "offset or scaled",
        ),
    ] {
        if given {
            return Err(format!(
                "{what} properties are not supported by this reader"
            ));
        }
    }
    match prop.r#type.as_str() {
        "BOOLEAN" => {
            if values.len() < count.div_ceil(8) {
                return Err("boolean column too short".into());
            }
            Ok((0..count)
                .map(|i| PropValue::Bool(values[i / 8] >> (i % 8) & 1 == 1))
                .collect())
        }
        "STRING" => {
            let (off_bytes, off_type) = string_offsets.ok_or("string column without offsets")?;
            let offs = read_uints(off_bytes, off_type, count + 1)?;
            let empty = no_data.and_then(|v| v.as_str());
            (0..count)
                .map(|i| {
                    let (a, b) = (offs[i] as usize, offs[i + 1] as usize);
                    let s = values
                        .get(a..b)
                        .ok_or("string offset out of range")
                        .and_then(|s| std::str::from_utf8(s).map_err(|_| "string not UTF-8"))?;
                    Ok(if Some(s) == empty {
                        PropValue::Null
                    } else {
                        PropValue::Str(s.to_string())
                    })
                })
                .collect()
        }
        "SCALAR" => {
            let ct = prop.component_type.as_deref().unwrap_or("");
            let size = component_size(ct).ok_or_else(|| format!("component type {ct:?}"))?;
            if values.len() < size * count {
                return Err("numeric column too short".into());
            }
            Ok((0..count)
                .map(|i| {
                    let b = &values[i * size..(i + 1) * size];
                    let v = match ct {
                        "FLOAT32" => {
                            PropValue::Float(f32::from_le_bytes(b.try_into().unwrap()) as f64)
                        }
                        "FLOAT64" => PropValue::Float(f64::from_le_bytes(b.try_into().unwrap())),
                        "INT8" => PropValue::Int(b[0] as i8 as i64),
                        "INT16" => PropValue::Int(i16::from_le_bytes(b.try_into().unwrap()) as i64),
                        "INT32" => PropValue::Int(i32::from_le_bytes(b.try_into().unwrap()) as i64),
                        "INT64" => PropValue::Int(i64::from_le_bytes(b.try_into().unwrap())),
                        "UINT64" => {
                            PropValue::Int(u64::from_le_bytes(b.try_into().unwrap()) as i64)
                        }
                        _ => PropValue::Int(read_uint(b) as i64),
                    };
                    let is_no_data = match (&v, no_data) {
                        (PropValue::Float(f), Some(nd)) => nd.as_f64() == Some(*f),
                        (PropValue::Int(k), Some(nd)) => {
                            nd.as_i64() == Some(*k)
                                || (nd.as_u64().is_some() && nd.as_u64() == u64::try_from(*k).ok())
                        }
                        _ => false,
                    };
                    if is_no_data {
                        PropValue::Null
                    } else {
                        v
                    }
                })
                .collect())
        }
        other => Err(format!(
            "property type {other:?} is not supported by this reader"
        )),
    }
}

fn component_size(ct: &str) -> Option<usize> {
    Some(match ct {
        "INT8" | "UINT8" => 1,
        "INT16" | "UINT16" => 2,
        "INT32" | "UINT32" | "FLOAT32" => 4,
        "INT64" | "UINT64" | "FLOAT64" => 8,
        _ => return None,
    })
}

fn read_uint(b: &[u8]) -> u64 {
    b.iter().rev().fold(0u64, |acc, &x| acc << 8 | x as u64)
}

fn read_uints(bytes: &[u8], ty: &str, n: usize) -> Result<Vec<u64>, String> {
    let size = component_size(ty).ok_or_else(|| format!("offset type {ty:?}"))?;
    if bytes.len() < size * n {
        return Err("offset column too short".into());
    }
    Ok(bytes.chunks_exact(size).take(n).map(read_uint).collect())
}

/// One decoded feature row: its class and its values by property id.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureRow {
    pub class: String,
    pub values: BTreeMap<String, PropValue>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::{ClassDef, PropertyDef};

    fn def(kind: PropertyKind, nullable: bool) -> PropertyDef {
        PropertyDef {
            name: "p".into(),
            kind,
            description: Some("what p means".into()),
            nullable,
            string_no_data: None,
            input_name: None,
        }
    }

    fn round_trip(kind: PropertyKind, vals: &[PropValue]) -> Vec<PropValue> {
        let schema = MetadataSchema {
            id: "s".into(),
            classes: vec![ClassDef {
                id: "c".into(),
                properties: vec![def(kind, true)],
            }],
        };
        let prop = schema_json(&schema, &["c"], false).classes["c"].properties["p"].clone();
        let col = encode_column(&def(kind, true), vals.iter()).unwrap();
        let offs = col
            .string_offsets
            .as_ref()
            .map(|(o, ty)| (o.as_slice(), *ty));
        decode_column(&prop, vals.len(), &col.values, offs).unwrap()
    }

    #[test]
    fn columns_round_trip_with_nulls() {
        use PropValue::*;
        let s = [Str("Zürich 東京".into()), Null, Str("x".into()), Int(7)];
        assert_eq!(
            round_trip(PropertyKind::String, &s),
            [
                Str("Zürich 東京".into()),
                Null,
                Str("x".into()),
                Str("7".into())
            ]
        );
        let f = [Float(1.5), Null, Int(-3), Float(-0.0)];
        assert_eq!(
            round_trip(PropertyKind::Float64, &f),
            [Float(1.5), Null, Float(-3.0), Float(-0.0)]
        );
        let i = [Int(i64::MAX), Null, Float(12.0)];
        assert_eq!(
            round_trip(PropertyKind::Int64, &i),
            [Int(i64::MAX), Null, Int(12)]
        );
        // FLOAT32: rounded to the nearest single.
        let f32s = [Float(1.5), Null, Int(-3), Float(0.1)];
        assert_eq!(
            round_trip(PropertyKind::Float32, &f32s),
            [Float(1.5), Null, Float(-3.0), Float(0.1f32 as f64)]
        );
        let i32s = [
            Int(i32::MAX as i64),
            Null,
            Float(-12.0),
            Int(i32::MIN as i64 + 1),
        ];
        assert_eq!(
            round_trip(PropertyKind::Int32, &i32s),
            [
                Int(i32::MAX as i64),
                Null,
                Int(-12),
                Int(i32::MIN as i64 + 1)
            ]
        );
        let u = [Int(0), Null, Int(4_000_000_000)];
        assert_eq!(
            round_trip(PropertyKind::UInt32, &u),
            [Int(0), Null, Int(4_000_000_000)]
        );
        let b: Vec<PropValue> = (0..11)
            .map(|k| if k == 5 { Null } else { Bool(k % 3 == 0) })
            .collect();
        let want: Vec<PropValue> = (0..11).map(|k| Bool(k != 5 && k % 3 == 0)).collect();
        assert_eq!(round_trip(PropertyKind::Boolean, &b), want);
    }

    /// With a noData other than "", an empty string and a missing value read back apart; with "" they cannot.
    #[test]
    fn an_empty_string_and_no_value_stay_apart_with_another_no_data() {
        use PropValue::*;
        let mut p = def(PropertyKind::String, true);
        p.string_no_data = Some("(no value)".into());
        let schema = MetadataSchema {
            id: "s".into(),
            classes: vec![ClassDef {
                id: "c".into(),
                properties: vec![p.clone()],
            }],
        };
        let prop = schema_json(&schema, &["c"], false).classes["c"].properties["p"].clone();
        assert_eq!(prop.no_data, Some(serde_json::json!("(no value)")));
        let vals = [Str(String::new()), Null, Str("a".into()), Null];
        let col = encode_column(&p, vals.iter()).unwrap();
        let (o, ty) = col.string_offsets.as_ref().unwrap();
        let back =
            decode_column(&prop, vals.len(), &col.values, Some((o.as_slice(), *ty))).unwrap();
        assert_eq!(back, vals);
        assert_eq!(
            round_trip(PropertyKind::String, &vals),
            [Null, Null, Str("a".into()), Null]
        );
    }

    #[test]
    fn string_offsets_take_the_narrowest_type_that_holds_the_column() {
        use PropValue::*;
        for (len, rows, ty, size) in [
            (3usize, 10usize, "UINT8", 1usize),
            (25, 10, "UINT8", 1),
            (26, 10, "UINT16", 2),
            (700, 93, "UINT16", 2),
            (700, 94, "UINT32", 4),
        ] {
            // `rows` strings of `len` bytes: the last offset is len × rows.
            let vals: Vec<PropValue> = (0..rows)
                .map(|k| Str(char::from(b'a' + (k % 26) as u8).to_string().repeat(len)))
                .collect();
            let col = encode_column(&def(PropertyKind::String, true), vals.iter()).unwrap();
            let (offs, got) = col.string_offsets.as_ref().unwrap();
            assert_eq!(
                (*got, offs.len()),
                (ty, (rows + 1) * size),
                "{len} × {rows}"
            );
            assert_eq!(round_trip(PropertyKind::String, &vals), vals);
        }
    }

    #[test]
    fn values_that_do_not_fit_are_rejected_with_their_index() {
        use PropValue::*;
        let d = |k| def(k, true);
        let e = encode_column(&d(PropertyKind::UInt32), [Int(1), Int(-1)].iter())
            .err()
            .unwrap();
        assert_eq!(e.0, 1);
        assert!(encode_column(&d(PropertyKind::Float64), [Str("a".into())].iter()).is_err());
        assert!(encode_column(&d(PropertyKind::Int64), [Float(0.5)].iter()).is_err());
        // Past 32 bits, or the noData value itself, would not read back.
        assert!(encode_column(&d(PropertyKind::Int32), [Int(1 << 31)].iter()).is_err());
        assert!(encode_column(&d(PropertyKind::Int32), [Int(i32::MIN as i64)].iter()).is_err());
        assert!(encode_column(&d(PropertyKind::Boolean), [Int(1)].iter()).is_err());
        // A null where the schema declares no noData value.
        let e = encode_column(
            &def(PropertyKind::Float32, false),
            [Float(1.0), Null].iter(),
        )
        .err()
        .unwrap();
        assert_eq!(e.0, 1);
    }

    #[test]
    fn only_nullable_properties_declare_no_data_and_glbs_carry_no_descriptions() {
        let schema = MetadataSchema {
            id: "s".into(),
            classes: vec![ClassDef {
                id: "c".into(),
                properties: vec![
                    PropertyDef {
                        name: "a".into(),
                        ..def(PropertyKind::Float32, false)
                    },
                    PropertyDef {
                        name: "b".into(),
                        input_name: Some("b:levels".into()),
                        ..def(PropertyKind::UInt32, true)
                    },
                    PropertyDef {
                        name: "_".into(),
                        input_name: Some(String::new()),
                        ..def(PropertyKind::UInt32, true)
                    },
                ],
            }],
        };
        let inline = schema_json(&schema, &["c"], false);
        let props = &inline.classes["c"].properties;
        // A renamed attribute keeps its input name as the property's name, in every glb.
        assert_eq!(props["b"].name.as_deref(), Some("b:levels"));
        assert_eq!(props["a"].name, None);
        // An attribute named "" has no name (the spec's minLength is 1); its id `_` is all it has.
        assert_eq!(props["_"].name, None);
        assert_eq!(props["a"].no_data, None);
        assert_eq!(props["b"].no_data, Some(serde_json::json!(u32::MAX)));
        assert!(props.values().all(|p| p.description.is_none()));
        let documented = schema_json(&schema, &["c"], true);
        assert_eq!(
            documented.classes["c"].properties["a"]
                .description
                .as_deref(),
            Some("what p means")
        );
        // The id names the definitions: descriptions do not change it, another set of classes does.
        assert_eq!(documented.id, inline.id);
        assert!(inline.id.starts_with("s_") && inline.id.len() == 10);
        let mut two = schema.clone();
        two.classes.push(ClassDef {
            id: "d".into(),
            ..schema.classes[0].clone()
        });
        let one_class = schema_json(&two, &["c"], false);
        let both = schema_json(&two, &["c", "d"], false);
        assert_eq!(one_class.id, inline.id);
        assert_ne!(both.id, inline.id);
        two.classes[0].properties[0].kind = PropertyKind::Float64;
        assert_ne!(schema_json(&two, &["c"], false).id, inline.id);
    }
}
