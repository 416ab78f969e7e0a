//! A writer of GeoParquet files for tests and benchmarks (the parquet crate's writer): building footprints of a
//! GeoJSON FeatureCollection in lon/lat as WKB Polygons / MultiPolygons with `id`, `num_floors` and `names.primary`
//! columns, as Overture Maps lays its buildings out, in row groups of `per_group` rows, ZSTD-compressed.

use parquet::basic::{Compression, ZstdLevel};
use parquet::data_type::{ByteArray, ByteArrayType, DoubleType};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use std::io::Write;
use std::sync::Arc;

/// One row: id, WKB, storeys, name.
type Row = (String, Vec<u8>, Option<f64>, Option<String>);

fn wkb_rings(out: &mut Vec<u8>, rings: &[serde_json::Value], dx: f64) {
    out.extend(1u8.to_le_bytes());
    out.extend(3u32.to_le_bytes());
    out.extend((rings.len() as u32).to_le_bytes());
    for ring in rings {
        let points = ring.as_array().cloned().unwrap_or_default();
        out.extend((points.len() as u32).to_le_bytes());
        for p in &points {
            out.extend((p[0].as_f64().unwrap_or(0.0) + dx).to_le_bytes());
            out.extend(p[1].as_f64().unwrap_or(0.0).to_le_bytes());
        }
    }
}

/// Writes the Polygon and MultiPolygon features of `doc` `copies` times, each copy `step_deg` degrees of longitude
/// east of the last, as GeoParquet 1.1 (WKB, lon/lat).
pub fn write_buildings(
    doc: &serde_json::Value,
    copies: usize,
    step_deg: f64,
    per_group: usize,
    out: impl Write + Send,
) -> parquet::errors::Result<()> {
    let features = doc["features"].as_array().cloned().unwrap_or_default();
    let mut rows: Vec<Row> = Vec::new();
    for copy in 0..copies {
        let dx = copy as f64 * step_deg;
        for (i, f) in features.iter().enumerate() {
            let g = &f["geometry"];
            let mut wkb = Vec::new();
            match g["type"].as_str() {
                Some("Polygon") => {
                    wkb_rings(&mut wkb, g["coordinates"].as_array().map_or(&[], |v| v), dx)
                }
                Some("MultiPolygon") => {
                    let polygons = g["coordinates"].as_array().cloned().unwrap_or_default();
                    wkb.extend(1u8.to_le_bytes());
                    wkb.extend(6u32.to_le_bytes());
                    wkb.extend((polygons.len() as u32).to_le_bytes());
                    for p in &polygons {
                        wkb_rings(&mut wkb, p.as_array().map_or(&[], |v| v), dx);
                    }
                }
                _ => continue,
            }
            let p = &f["properties"];
            rows.push((
                format!("{copy}-{i}"),
                wkb,
                p["stories"].as_f64(),
                p["name"]
                    .as_str()
                    .filter(|s| !s.is_empty())
                    .map(str::to_string),
            ));
        }
    }
    let schema = Arc::new(parquet::schema::parser::parse_message_type(
        "message building {
            required binary id (UTF8);
            required binary geometry;
            optional double num_floors;
            optional group names { optional binary primary (UTF8); }
        }",
    )?);
    let geo = r#"{"version": "1.1.0", "primary_column": "geometry", "columns": {"geometry": {"encoding": "WKB", "geometry_types": ["Polygon", "MultiPolygon"]}}}"#;
    let props = WriterProperties::builder()
        .set_compression(Compression::ZSTD(ZstdLevel::default()))
        .set_key_value_metadata(Some(vec![KeyValue::new("geo".into(), geo.to_string())]))
        .build();
    let mut w = SerializedFileWriter::new(out, schema, Arc::new(props))?;
    for group in rows.chunks(per_group.max(1)) {
        let mut rg = w.next_row_group()?;
        let mut column = 0;
        while let Some(mut col) = rg.next_column()? {
            match column {
                0 => {
                    let v: Vec<ByteArray> = group
                        .iter()
                        .map(|r| ByteArray::from(r.0.as_str()))
                        .collect();
                    col.typed::<ByteArrayType>().write_batch(&v, None, None)?;
                }
                1 => {
                    let v: Vec<ByteArray> =
                        group.iter().map(|r| ByteArray::from(r.1.clone())).collect();
                    col.typed::<ByteArrayType>().write_batch(&v, None, None)?;
                }
                2 => {
                    let v: Vec<f64> = group.iter().filter_map(|r| r.2).collect();
                    let d: Vec<i16> = group.iter().map(|r| i16::from(r.2.is_some())).collect();
                    col.typed::<DoubleType>().write_batch(&v, Some(&d), None)?;
                }
                _ => {
                    // names (optional, level 1) → primary (optional, level 2): names is always there.
                    let v: Vec<ByteArray> = group
                        .iter()
                        .filter_map(|r| r.3.as_deref().map(ByteArray::from))
                        .collect();
                    let d: Vec<i16> = group.iter().map(|r| 1 + i16::from(r.3.is_some())).collect();
                    col.typed::<ByteArrayType>()
                        .write_batch(&v, Some(&d), None)?;
                }
            }
            col.close()?;
            column += 1;
        }
        rg.close()?;
    }
    w.close()?;
    Ok(())
}
