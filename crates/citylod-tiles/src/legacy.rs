//! The 3D Tiles 1.0 tile formats the reader takes besides glb: Batched 3D Model (`b3dm`: a feature table, a batch
//! table and an embedded glb whose vertices carry `_BATCHID`) and Composite (`cmpt`: tiles of any format one after
//! another). 3D Tiles 1.1 keeps both valid (deprecated for glb), and most city tilesets written before 2023 use them.
//! Instanced models (`i3dm`) and point clouds (`pnts`) are named and refused: citylod draws surfaces of buildings.
//! Layouts: 3D Tiles 1.0, "Batched 3D Model" and "Composite" (a 28- and a 16-byte header, little-endian u32s).

use crate::read::MAX_TABLE_CELLS;
use crate::spec::PropValue;
use std::collections::BTreeMap;

/// What a b3dm holds besides its glb.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Batched<'a> {
    /// The embedded glb.
    pub glb: &'a [u8],
    /// Features in the batch table: the `_BATCHID` of a vertex indexes them.
    pub batch_length: usize,
    /// The feature table's `RTC_CENTER`: positions are relative to it (tile frame, z up).
    pub rtc_center: Option<[f64; 3]>,
    /// The batch table's JSON and binary body, decoded by [`Batched::rows`] once the caller has checked that the glb
    /// backs `batch_length` features (a small file may declare millions).
    pub table_json: &'a [u8],
    pub table_bin: &'a [u8],
}

impl Batched<'_> {
    /// The rows of the batch table, one per feature, each with every property.
    pub fn rows(&self) -> Result<Vec<BTreeMap<String, PropValue>>, String> {
        let columns = if self.table_json.iter().all(u8::is_ascii_whitespace) {
            Vec::new()
        } else {
            batch_columns(self.table_json, self.table_bin, self.batch_length)?
        };
        let mut rows = vec![BTreeMap::new(); self.batch_length];
        for (name, values) in columns {
            for (row, v) in rows.iter_mut().zip(values) {
                row.insert(name.clone(), v);
            }
        }
        Ok(rows)
    }
}

/// Most features one batch table may declare (the glb must also have a vertex for each).
const MAX_BATCH_LENGTH: usize = 1 << 24;

/// Most composite tiles nested in one another.
pub(crate) const MAX_COMPOSITE_DEPTH: usize = 8;

fn u32_at(b: &[u8], i: usize) -> Result<usize, String> {
    crate::glb::le_u32(b, i)
        .map(|v| v as usize)
        .ok_or_else(|| "truncated header".to_string())
}

/// The file's own length from the 3D Tiles 1.0 header (magic, version 1, byteLength), checked against `b`.
fn header_length(b: &[u8], what: &str, min: usize) -> Result<usize, String> {
    let version = u32_at(b, 4)?;
    if version != 1 {
        return Err(format!("{what} version {version}; only version 1 is read"));
    }
    let total = u32_at(b, 8)?;
    if total > b.len() {
        return Err(format!(
            "truncated: the {what} header gives a length of {total} bytes, the file has {}",
            b.len()
        ));
    }
    if total < min {
        return Err(format!(
            "the {what} header gives a length of {total} bytes, less than its header"
        ));
    }
    Ok(total)
}

/// Splits a b3dm into its glb, feature table and batch table.
pub(crate) fn parse_b3dm(b: &[u8]) -> Result<Batched<'_>, String> {
    let total = header_length(b, "b3dm", 28)?;
    let b = &b[..total];
    let lens = [
        u32_at(b, 12)?,
        u32_at(b, 16)?,
        u32_at(b, 20)?,
        u32_at(b, 24)?,
    ];
    let glb_start = lens.iter().try_fold(28usize, |a, &l| a.checked_add(l));
    let Some(glb_start) = glb_start.filter(|&s| s <= total) else {
        // Before 3D Tiles 1.0 the header had 20 or 24 bytes; its fields then read as lengths past the file.
        return Err(format!(
            "its table lengths ({lens:?} bytes) run past the file's {total} bytes: not a 3D Tiles 1.0 b3dm \
             (a header from before 1.0?)"
        ));
    };
    let (ft_json, ft_bin) = (
        &b[28..28 + lens[0]],
        &b[28 + lens[0]..28 + lens[0] + lens[1]],
    );
    let bt_at = 28 + lens[0] + lens[1];
    let (bt_json, bt_bin) = (
        &b[bt_at..bt_at + lens[2]],
        &b[bt_at + lens[2]..bt_at + lens[2] + lens[3]],
    );
    if ft_json.iter().all(u8::is_ascii_whitespace) {
        return Err("its feature table is empty: BATCH_LENGTH is required".into());
    }
    let ft: serde_json::Value =
        serde_json::from_slice(ft_json).map_err(|e| format!("feature table JSON: {e}"))?;
    let batch_length = match ft.get("BATCH_LENGTH") {
        Some(v) => table_value(v, ft_bin, "UNSIGNED_INT", 1)
            .map_err(|e| format!("feature table BATCH_LENGTH: {e}"))?
            .first()
            .copied()
            .filter(|x| x.fract() == 0.0 && *x >= 0.0 && *x <= MAX_BATCH_LENGTH as f64)
            .ok_or_else(|| {
                format!(
                    "feature table BATCH_LENGTH {v} is not a count of at most {MAX_BATCH_LENGTH}"
                )
            })? as usize,
        None => return Err("feature table without BATCH_LENGTH".into()),
    };
    let rtc_center = match ft.get("RTC_CENTER") {
        None => None,
        Some(v) => {
            let c = table_value(v, ft_bin, "FLOAT", 3)
                .map_err(|e| format!("feature table RTC_CENTER: {e}"))?;
            match c[..] {
                [x, y, z] if c.iter().all(|v| v.is_finite()) => Some([x, y, z]),
                _ => {
                    return Err(format!(
                        "feature table RTC_CENTER {v} is not a finite point"
                    ))
                }
            }
        }
    };
    Ok(Batched {
        glb: &b[glb_start..],
        batch_length,
        rtc_center,
        table_json: bt_json,
        table_bin: bt_bin,
    })
}

/// A feature-table value: a JSON number or array of `count` numbers, or `{"byteOffset"}` into the binary body with
/// the component type the property has by definition (a `componentType` given with it is not the property's).
fn table_value(
    v: &serde_json::Value,
    bin: &[u8],
    component: &str,
    count: usize,
) -> Result<Vec<f64>, String> {
    match v {
        serde_json::Value::Number(n) if count == 1 => Ok(vec![n.as_f64().unwrap_or(f64::NAN)]),
        serde_json::Value::Array(a) if a.len() == count => {
            Ok(a.iter().map(|x| x.as_f64().unwrap_or(f64::NAN)).collect())
        }
        serde_json::Value::Object(o) => binary_values(bin, byte_offset(o)?, component, count),
        other => Err(format!("{other} is not {count} number(s)")),
    }
}

/// The `byteOffset` of a binary reference: a non-negative integer.
fn byte_offset(o: &serde_json::Map<String, serde_json::Value>) -> Result<usize, String> {
    match o.get("byteOffset") {
        None => Err("a binary reference without byteOffset".into()),
        Some(v) => v
            .as_u64()
            .map(|x| x as usize)
            .ok_or_else(|| format!("byteOffset {v} is not a non-negative integer")),
    }
}

/// Bytes of one value of a 3D Tiles 1.0 component type; `None` for a name that is not one.
fn component_size(component: &str) -> Option<usize> {
    match component {
        "BYTE" | "UNSIGNED_BYTE" => Some(1),
        "SHORT" | "UNSIGNED_SHORT" => Some(2),
        "INT" | "UNSIGNED_INT" | "FLOAT" => Some(4),
        "DOUBLE" => Some(8),
        _ => None,
    }
}

/// `count` scalars of `component` type from `bin` at `offset`.
fn binary_values(
    bin: &[u8],
    offset: usize,
    component: &str,
    count: usize,
) -> Result<Vec<f64>, String> {
    let size = component_size(component).ok_or_else(|| format!("component type {component:?}"))?;
    let end = count
        .checked_mul(size)
        .and_then(|n| n.checked_add(offset))
        .filter(|&e| e <= bin.len())
        .ok_or_else(|| {
            format!(
                "{count} {component} value(s) at byte {offset} run past the binary body's {} bytes",
                bin.len()
            )
        })?;
    Ok(bin[offset..end]
        .chunks_exact(size)
        .map(|c| match component {
            "BYTE" => c[0] as i8 as f64,
            "UNSIGNED_BYTE" => c[0] as f64,
            "SHORT" => i16::from_le_bytes([c[0], c[1]]) as f64,
            "UNSIGNED_SHORT" => u16::from_le_bytes([c[0], c[1]]) as f64,
            "INT" => i32::from_le_bytes(c.try_into().unwrap()) as f64,
            "UNSIGNED_INT" => u32::from_le_bytes(c.try_into().unwrap()) as f64,
            "FLOAT" => f32::from_le_bytes(c.try_into().unwrap()) as f64,
            _ => f64::from_le_bytes(c.try_into().unwrap()),
        })
        .collect())
}

/// The batch table's properties, column by column. A property is a JSON array of one value per feature, or a
/// binary reference (`byteOffset`, `componentType`, `type`) into the batch table's body; a vector or a JSON array or
/// object value is kept as its JSON text, integers of integer component types as integers. `extensions` and
/// `extras` are not properties (3DTILES_batch_table_hierarchy's inherited properties are not read). Binary
/// properties may not share bytes, and rows × properties stay within
/// [`MAX_TABLE_CELLS`]: every value is decoded into memory.
fn batch_columns(
    json: &[u8],
    bin: &[u8],
    batch_length: usize,
) -> Result<Vec<(String, Vec<PropValue>)>, String> {
    let bt: serde_json::Map<String, serde_json::Value> =
        serde_json::from_slice(json).map_err(|e| format!("batch table JSON: {e}"))?;
    let properties = bt
        .keys()
        .filter(|k| *k != "extensions" && *k != "extras")
        .count();
    if batch_length.saturating_mul(properties) > MAX_TABLE_CELLS {
        return Err(format!(
            "its batch table has {properties} properties of {batch_length} features, more than the \
             {MAX_TABLE_CELLS} values citylod's reader holds"
        ));
    }
    // The byte ranges of the binary properties read so far: they may not overlap.
    let mut ranges: BTreeMap<usize, (usize, &str)> = BTreeMap::new();
    let mut columns = Vec::with_capacity(properties);
    for (name, v) in bt
        .iter()
        .filter(|(k, _)| *k != "extensions" && *k != "extras")
    {
        let err = |m: String| format!("batch table property {name:?}: {m}");
        let values: Vec<PropValue> = match v {
            serde_json::Value::Array(a) => {
                if a.len() != batch_length {
                    return Err(err(format!(
                        "{} values for {batch_length} features",
                        a.len()
                    )));
                }
                a.iter().map(json_value).collect()
            }
            serde_json::Value::Object(o) => {
                let offset = byte_offset(o).map_err(err)? as u64;
                let component = o
                    .get("componentType")
                    .and_then(serde_json::Value::as_str)
                    .ok_or_else(|| {
                        err(format!(
                            "componentType {} is not a name such as \"FLOAT\"",
                            o.get("componentType").unwrap_or(&serde_json::Value::Null)
                        ))
                    })?;
                let n = match o.get("type").and_then(serde_json::Value::as_str) {
                    Some("SCALAR") => 1,
                    Some("VEC2") => 2,
                    Some("VEC3") => 3,
                    Some("VEC4") => 4,
                    _ => {
                        return Err(err(format!(
                            "type {} is not SCALAR, VEC2, VEC3 or VEC4",
                            o.get("type").unwrap_or(&serde_json::Value::Null)
                        )))
                    }
                };
                let count = batch_length
                    .checked_mul(n)
                    .ok_or_else(|| err("too many values".into()))?;
                let flat = binary_values(bin, offset as usize, component, count).map_err(err)?;
                let start = offset as usize;
                let end = start + flat.len() * component_size(component).unwrap_or(1);
                // The ranges so far are disjoint: only the last one starting before `end` can reach past `start`.
                if let Some((_, (_, other))) = ranges
                    .range(..end)
                    .next_back()
                    .filter(|(_, (e, _))| *e > start)
                {
                    return Err(err(format!(
                        "its bytes {start}..{end} of the binary body share bytes with property {other:?}'s"
                    )));
                }
                ranges.insert(start, (end, name.as_str()));
                let integer = !matches!(component, "FLOAT" | "DOUBLE");
                flat.chunks_exact(n)
                    .map(|c| match c {
                        [x] if integer => PropValue::Int(*x as i64),
                        [x] => PropValue::Float(*x),
                        _ => PropValue::Str(serde_json::to_string(c).unwrap_or_default()),
                    })
                    .collect()
            }
            other => {
                return Err(err(format!(
                    "{other} is neither an array nor a binary reference"
                )))
            }
        };
        columns.push((name.clone(), values));
    }
    Ok(columns)
}

fn json_value(v: &serde_json::Value) -> PropValue {
    match v {
        serde_json::Value::Null => PropValue::Null,
        serde_json::Value::Bool(b) => PropValue::Bool(*b),
        serde_json::Value::Number(n) => match n.as_i64() {
            Some(i) => PropValue::Int(i),
            None => PropValue::Float(n.as_f64().unwrap_or(f64::NAN)),
        },
        serde_json::Value::String(s) => PropValue::Str(s.clone()),
        other => PropValue::Str(other.to_string()),
    }
}

/// The inner tiles of a cmpt, each a slice starting with its own magic.
pub(crate) fn parse_cmpt(b: &[u8]) -> Result<Vec<&[u8]>, String> {
    let total = header_length(b, "cmpt", 16)?;
    let b = &b[..total];
    let count = u32_at(b, 12)?;
    let mut tiles = Vec::new();
    let mut pos = 16;
    for k in 0..count {
        let len = u32_at(b, pos + 8)
            .map_err(|_| format!("inner tile {k} of {count}: truncated at byte {pos}"))?;
        if len < 12 {
            return Err(format!(
                "inner tile {k} of {count} at byte {pos} claims {len} bytes, less than a tile's header"
            ));
        }
        let end = pos
            .checked_add(len)
            .filter(|&e| e <= total)
            .ok_or_else(|| {
                format!(
                    "inner tile {k} of {count} at byte {pos} claims {len} bytes, past the composite's {total}"
                )
            })?;
        tiles.push(&b[pos..end]);
        pos = end;
    }
    // Inner tiles are 8-byte aligned, so up to 7 bytes of padding may follow the last; more is a tile the header
    // does not count.
    if total - pos >= 8 {
        return Err(format!(
            "{} bytes follow its {count} inner tile(s): tilesLength is short of the tiles it holds",
            total - pos
        ));
    }
    Ok(tiles)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A b3dm around `glb`: feature table and batch table JSON padded to 8 bytes, binary bodies as given.
    pub(crate) fn b3dm(
        ft: &serde_json::Value,
        ft_bin: &[u8],
        bt: Option<&serde_json::Value>,
        bt_bin: &[u8],
        glb: &[u8],
    ) -> Vec<u8> {
        // As 3D Tiles 1.0 lays them out: each binary body and the glb start on an 8-byte boundary of the file (the
        // JSON after the 28-byte header padded with spaces, the bodies with zeros).
        let pad_to = |mut v: Vec<u8>, at: usize, with: u8| {
            v.resize((at + v.len()).next_multiple_of(8) - at, with);
            v
        };
        let ft = pad_to(ft.to_string().into_bytes(), 28, b' ');
        let ft_bin = pad_to(ft_bin.to_vec(), 0, 0);
        let bt = bt.map_or(Vec::new(), |bt| {
            pad_to(
                bt.to_string().into_bytes(),
                28 + ft.len() + ft_bin.len(),
                b' ',
            )
        });
        let bt_bin = pad_to(bt_bin.to_vec(), 0, 0);
        let total = 28 + ft.len() + ft_bin.len() + bt.len() + bt_bin.len() + glb.len();
        let mut out = b"b3dm".to_vec();
        for v in [1, total, ft.len(), ft_bin.len(), bt.len(), bt_bin.len()] {
            out.extend((v as u32).to_le_bytes());
        }
        for part in [&ft[..], &ft_bin, &bt, &bt_bin, glb] {
            out.extend_from_slice(part);
        }
        out
    }

    /// A cmpt of `tiles`.
    pub(crate) fn cmpt(tiles: &[&[u8]]) -> Vec<u8> {
        let total = 16 + tiles.iter().map(|t| t.len()).sum::<usize>();
        let mut out = b"cmpt".to_vec();
        for v in [1, total, tiles.len()] {
            out.extend((v as u32).to_le_bytes());
        }
        for t in tiles {
            out.extend_from_slice(t);
        }
        out
    }

    #[test]
    fn b3dm_tables_are_read_from_json_and_binary() {
        let glb = b"glTF-stand-in".to_vec();
        let mut ft_bin = Vec::new();
        for v in [100.0f32, -50.0, 7.5] {
            ft_bin.extend(v.to_le_bytes());
        }
        let mut bt_bin = Vec::new();
        for v in [3u16, 9] {
            bt_bin.extend(v.to_le_bytes());
        }
        bt_bin.resize(8, 0);
        for v in [1.5f64, 2.5, -1.0, 4.0] {
            bt_bin.extend(v.to_le_bytes());
        }
        let b = b3dm(
            &serde_json::json!({"BATCH_LENGTH": 2, "RTC_CENTER": {"byteOffset": 0}}),
            &ft_bin,
            Some(&serde_json::json!({
                "name": ["a", null],
                "height": [12, 30.5],
                "tags": [{"k": 1}, [1, 2]],
                "floors": {"byteOffset": 0, "componentType": "UNSIGNED_SHORT", "type": "SCALAR"},
                "offset": {"byteOffset": 8, "componentType": "DOUBLE", "type": "VEC2"},
                "extensions": {"3DTILES_batch_table_hierarchy": {}}
            })),
            &bt_bin,
            &glb,
        );
        let p = parse_b3dm(&b).unwrap();
        assert_eq!(p.glb, &glb[..]);
        assert_eq!(p.batch_length, 2);
        assert_eq!(p.rtc_center, Some([100.0, -50.0, 7.5]));
        let r = &p.rows().unwrap();
        assert_eq!(r[0]["name"], PropValue::Str("a".into()));
        assert_eq!(r[1]["name"], PropValue::Null);
        assert_eq!(r[0]["height"], PropValue::Int(12));
        assert_eq!(r[1]["height"], PropValue::Float(30.5));
        assert_eq!(r[0]["tags"], PropValue::Str(r#"{"k":1}"#.into()));
        assert_eq!(r[1]["floors"], PropValue::Int(9));
        assert_eq!(r[1]["offset"], PropValue::Str("[-1.0,4.0]".into()));
        assert!(!r[0].contains_key("extensions"));

        // RTC_CENTER as a JSON array, no batch table: rows without properties.
        let b = b3dm(
            &serde_json::json!({"BATCH_LENGTH": 3, "RTC_CENTER": [1, 2, 3]}),
            &[],
            None,
            &[],
            &glb,
        );
        let p = parse_b3dm(&b).unwrap();
        assert_eq!(
            (p.rtc_center, p.rows().unwrap().len()),
            (Some([1.0, 2.0, 3.0]), 3)
        );
    }

    #[test]
    fn broken_b3dm_and_cmpt_are_errors_naming_what_is_wrong() {
        let glb = b"glTF".to_vec();
        let ok = b3dm(
            &serde_json::json!({"BATCH_LENGTH": 1}),
            &[],
            None,
            &[],
            &glb,
        );
        let err = |b: &[u8]| parse_b3dm(b).and_then(|p| p.rows().map(drop)).unwrap_err();
        assert!(err(&ok[..20]).contains("truncated"), "{}", err(&ok[..20]));
        let mut v0 = ok.clone();
        v0[4] = 0;
        assert!(err(&v0).contains("version 0"));
        let mut long_table = ok.clone();
        long_table[12..16].copy_from_slice(&10_000u32.to_le_bytes());
        assert!(
            err(&long_table).contains("run past"),
            "{}",
            err(&long_table)
        );
        for (ft, want) in [
            (serde_json::json!({}), "without BATCH_LENGTH"),
            (serde_json::json!({"BATCH_LENGTH": -1}), "BATCH_LENGTH"),
            (serde_json::json!({"BATCH_LENGTH": 1e12}), "BATCH_LENGTH"),
            (
                serde_json::json!({"BATCH_LENGTH": 1, "RTC_CENTER": [1, 2]}),
                "RTC_CENTER",
            ),
            (
                serde_json::json!({"BATCH_LENGTH": 1, "RTC_CENTER": {"byteOffset": 4}}),
                "run past",
            ),
        ] {
            let e = err(&b3dm(&ft, &[], None, &[], &glb));
            assert!(e.contains(want), "{ft}: {e}");
        }
        for (bt, want) in [
            (serde_json::json!({"h": [1, 2]}), "2 values for 1 features"),
            (serde_json::json!({"h": 3}), "neither an array"),
            (
                serde_json::json!({"h": {"byteOffset": 0, "componentType": "DOUBLE", "type": "SCALAR"}}),
                "run past",
            ),
            (
                serde_json::json!({"h": {"byteOffset": 0, "componentType": "HALF", "type": "SCALAR"}}),
                "component type",
            ),
            (
                serde_json::json!({"h": {"byteOffset": 0, "componentType": "BYTE", "type": "MAT2"}}),
                "type",
            ),
        ] {
            let e = err(&b3dm(
                &serde_json::json!({"BATCH_LENGTH": 1}),
                &[],
                Some(&bt),
                &[],
                &glb,
            ));
            assert!(e.contains(want) && e.contains("\"h\""), "{bt}: {e}");
        }
        // Binary properties sharing bytes (K columns decoded from N bytes), and more values than the reader holds.
        let shared = serde_json::json!({
            "a": {"byteOffset": 0, "componentType": "UNSIGNED_BYTE", "type": "SCALAR"},
            "b": {"byteOffset": 0, "componentType": "UNSIGNED_BYTE", "type": "SCALAR"}
        });
        let e = err(&b3dm(
            &serde_json::json!({"BATCH_LENGTH": 8}),
            &[],
            Some(&shared),
            &[0; 8],
            &glb,
        ));
        assert!(e.contains("share bytes") && e.contains("\"b\""), "{e}");
        let e = err(&b3dm(
            &serde_json::json!({"BATCH_LENGTH": 8}),
            &[],
            Some(&shared),
            &[0; 16],
            &glb,
        ));
        assert!(
            e.contains("share bytes"),
            "overlapping ranges in a larger body: {e}"
        );
        let wide = serde_json::json!({"a": [], "b": [], "c": []});
        let e = err(&b3dm(
            &serde_json::json!({"BATCH_LENGTH": 1 << 23}),
            &[],
            Some(&wide),
            &[],
            &glb,
        ));
        assert!(e.contains("3 properties of 8388608 features"), "{e}");

        let inner = b3dm(
            &serde_json::json!({"BATCH_LENGTH": 0}),
            &[],
            None,
            &[],
            &glb,
        );
        let c = cmpt(&[&inner, &inner]);
        assert_eq!(parse_cmpt(&c).unwrap(), vec![&inner[..], &inner[..]]);
        let mut lying = c.clone();
        lying[12..16].copy_from_slice(&3u32.to_le_bytes());
        assert!(parse_cmpt(&lying)
            .unwrap_err()
            .contains("inner tile 2 of 3"));
        // A tile count short of the tiles the composite holds.
        let mut short_count = c.clone();
        short_count[12..16].copy_from_slice(&1u32.to_le_bytes());
        let e = parse_cmpt(&short_count).unwrap_err();
        assert!(e.contains("follow its 1 inner tile"), "{e}");
        let mut tiny_inner = c.clone();
        tiny_inner[16 + 8..16 + 12].copy_from_slice(&4u32.to_le_bytes());
        let e = parse_cmpt(&tiny_inner).unwrap_err();
        assert!(e.contains("less than a tile's header"), "{e}");
        let mut long_inner = c.clone();
        long_inner[16 + 8..16 + 12].copy_from_slice(&100_000u32.to_le_bytes());
        assert!(parse_cmpt(&long_inner)
            .unwrap_err()
            .contains("past the composite"));
    }
}
