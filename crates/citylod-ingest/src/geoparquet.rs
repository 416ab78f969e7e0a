//! GeoParquet (`.parquet`, `.geoparquet`): what Overture Maps publishes its buildings as, and what GDAL, GeoPandas
//! and DuckDB write. The file's `geo` metadata names the geometry column, its encoding and its CRS (GeoParquet 1.0
//! and 1.1): WKB (ISO or EWKB, read by the GeoPackage reader's WKB reader, 3D surface models included) or GeoArrow's
//! native `polygon` / `multipolygon` (coordinates as `{x, y[, z]}` structs or interleaved lists); the CRS is a
//! PROJJSON object (its `id`; a compound or bound CRS's horizontal part), absent = OGC:CRS84 (lon/lat), `null` =
//! unknown (then `--crs` must name it). A Parquet file without `geo` metadata is read when it has a binary column
//! named as GDAL and DuckDB name a WKB geometry (`geometry`, `geom`, `wkb_geometry`, `the_geom`), with `--crs`.
//!
//! Every other column is an attribute: numbers, text, booleans as they are; a struct's fields flattened to
//! `column.field` (Overture's `names.primary`); lists and maps as compact JSON text; dates and times as text. The
//! GeoParquet 1.1 bounding-box covering column (Overture's `bbox`) is left out, and binary columns too (said in a
//! note). A feature's id is its `id` column (Overture's GERS id), else `FILE#ROW`. Row groups are read in parallel.

use crate::crs::DeclaredCrs;
use crate::feature::{RawFeature, RawPolygon, VectorDoc};
use crate::gpkg::Geometry;
use crate::report::IssueReason;
use citylod_model::{AttrValue, Attributes};
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::Field;
use rayon::prelude::*;
use std::collections::BTreeSet;
use std::path::Path;

/// The names GDAL and DuckDB give a WKB geometry column, tried when a file has no `geo` metadata.
const WKB_COLUMN_NAMES: &[&str] = &["geometry", "geom", "wkb_geometry", "the_geom"];
/// Nesting of lists and structs read into an attribute's JSON text (deeper is cut, said with `…`).
const MAX_NESTING: usize = 32;

/// A file named as Parquet, or starting with Parquet's magic number.
pub(crate) fn is_parquet(path: &Path) -> bool {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if [".parquet", ".geoparquet", ".pq"]
        .iter()
        .any(|e| name.ends_with(e))
    {
        return true;
    }
    let mut head = [0u8; 4];
    path.is_file()
        && std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
            .is_ok()
        && &head == b"PAR1"
}

/// How the geometry column holds its geometries.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Encoding {
    Wkb,
    /// GeoArrow `polygon`: a list of rings, each a list of coordinates.
    Polygon,
    /// GeoArrow `multipolygon`: a list of polygons.
    MultiPolygon,
    /// GeoArrow `linestring`: a list of coordinates (streets, for `--streets`).
    LineString,
    /// GeoArrow `multilinestring`: a list of linestrings.
    MultiLineString,
}

/// A row read: its feature, and its 3D surface model (its label and faces) when it holds one.
type Row = (
    RawFeature,
    Option<(String, Vec<crate::surface_model::Face>)>,
);

/// What the `geo` metadata (or, without it, the schema) says of the geometry.
struct GeoColumn {
    name: String,
    encoding: Encoding,
    crs: Option<DeclaredCrs>,
    /// The bounding-box covering column (GeoParquet 1.1), not read as attributes.
    covering: Option<String>,
}

/// Reads the buildings of a GeoParquet file; `Err` (a detail) when it is no Parquet file, names no geometry column
/// this reader can read, or cannot be decoded.
pub(crate) fn read(path: &Path) -> Result<VectorDoc, String> {
    // The Parquet decoder has panicked on malformed input; a file must give an error, never a crash.
    std::panic::catch_unwind(|| read_file(path))
        .unwrap_or_else(|_| Err("the Parquet reader failed on this file (a damaged file?)".into()))
}

fn read_file(path: &Path) -> Result<VectorDoc, String> {
    // Held whole: row groups are read in parallel, and clones of one file handle would share its position.
    let bytes =
        bytes::Bytes::from(std::fs::read(path).map_err(|e| format!("cannot read the file: {e}"))?);
    let reader =
        SerializedFileReader::new(bytes).map_err(|e| format!("not a Parquet file: {e}"))?;
    let meta = reader.metadata().file_metadata();
    let mut notes = Vec::new();
    let geo_text = meta
        .key_value_metadata()
        .into_iter()
        .flatten()
        .find(|kv| kv.key == "geo")
        .and_then(|kv| kv.value.clone());
    let top: Vec<(String, bool)> = meta
        .schema_descr()
        .root_schema()
        .get_fields()
        .iter()
        .map(|f| {
            let binary = f.is_primitive()
                && f.get_physical_type() == parquet::basic::Type::BYTE_ARRAY
                && f.get_basic_info().logical_type_ref().is_none()
                && f.get_basic_info().converted_type() == parquet::basic::ConvertedType::NONE;
            (f.name().to_string(), binary)
        })
        .collect();
    let geo = match geo_text {
        Some(text) => geo_metadata(&text)?,
        None => {
            let Some((name, _)) = top.iter().find(|(n, binary)| {
                *binary && WKB_COLUMN_NAMES.contains(&n.to_ascii_lowercase().as_str())
            }) else {
                return Err(format!(
                    "a Parquet file without GeoParquet metadata (its key-value metadata has no \"geo\"), and no \
                     binary column named {} to read as WKB: {} column(s): {}",
                    WKB_COLUMN_NAMES.join(", "),
                    top.len(),
                    crate::geojson::listing(&top.iter().map(|t| t.0.clone()).collect::<Vec<_>>())
                ));
            };
            notes.push(format!(
                "no GeoParquet metadata: the binary column {name:?} read as WKB, in the CRS --crs names"
            ));
            GeoColumn {
                name: name.clone(),
                encoding: Encoding::Wkb,
                crs: None,
                covering: None,
            }
        }
    };
    if !top.iter().any(|(n, _)| *n == geo.name) {
        return Err(format!(
            "the GeoParquet metadata names the geometry column {:?}, which the file does not have",
            geo.name
        ));
    }
    let binary: Vec<String> = top
        .iter()
        .filter(|(n, b)| *b && *n != geo.name && Some(n) != geo.covering.as_ref())
        .map(|(n, _)| n.clone())
        .collect();
    if !binary.is_empty() {
        notes.push(format!(
            "binary column(s) not read as attributes: {}",
            crate::geojson::listing(&binary)
        ));
    }
    if let Some(c) = &geo.covering {
        notes.push(format!(
            "the bounding-box column {c:?} (the GeoParquet covering of the geometry) is not read as attributes"
        ));
    }
    let skip: BTreeSet<&str> = binary
        .iter()
        .map(String::as_str)
        .chain(geo.covering.as_deref())
        .collect();
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // Row numbers: where each row group starts.
    let mut starts = vec![0usize];
    for i in 0..reader.num_row_groups() {
        let n = usize::try_from(reader.metadata().row_group(i).num_rows()).unwrap_or(0);
        starts.push(starts[i].saturating_add(n));
    }
    let groups: Vec<Result<Vec<Row>, String>> = (0
        ..reader.num_row_groups())
        .into_par_iter()
        .map(|g| {
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                row_group(&reader, g, starts[g], &geo, &skip, &file_name)
            }))
            .unwrap_or_else(|_| {
                Err(format!(
                    "row group {g} cannot be decoded: the Parquet reader failed on it (a damaged file?)"
                ))
            })
        })
        .collect();
    let mut features = Vec::new();
    let mut surfaces = Vec::new();
    for g in groups {
        for (f, s) in g? {
            if let Some((label, faces)) = s {
                surfaces.push((features.len(), label, faces));
            }
            features.push(f);
        }
    }
    Ok(VectorDoc {
        features,
        surfaces,
        declared_crs: geo.crs,
        z_unit_m: None,
        notes,
    })
}

/// The `geo` metadata: the primary geometry column, its encoding, its CRS and covering.
fn geo_metadata(text: &str) -> Result<GeoColumn, String> {
    let geo: serde_json::Value = serde_json::from_str(text)
        .map_err(|e| format!("the GeoParquet metadata (\"geo\") is not JSON: {e}"))?;
    let name = geo["primary_column"]
        .as_str()
        .ok_or("the GeoParquet metadata names no primary_column")?
        .to_string();
    let column = &geo["columns"][&name];
    if !column.is_object() {
        return Err(format!(
            "the GeoParquet metadata's columns do not describe the primary column {name:?}"
        ));
    }
    let encoding = match column["encoding"].as_str().map(str::to_ascii_lowercase).as_deref() {
        Some("wkb") => Encoding::Wkb,
        Some("polygon") => Encoding::Polygon,
        Some("multipolygon") => Encoding::MultiPolygon,
        Some("linestring") => Encoding::LineString,
        Some("multilinestring") => Encoding::MultiLineString,
        Some(other) => {
            return Err(format!(
                "the geometry column {name:?} is encoded as {other:?}, not as footprints or lines (WKB, polygon, \
                 multipolygon, linestring or multilinestring)"
            ))
        }
        None => return Err(format!("the geometry column {name:?} names no encoding")),
    };
    let crs = match column.get("crs") {
        // Absent: OGC:CRS84 (GeoParquet 1.0 §crs).
        None => Some(DeclaredCrs::Name("OGC:CRS84".into())),
        Some(serde_json::Value::Null) => None,
        Some(serde_json::Value::String(s)) => Some(DeclaredCrs::Name(s.clone())),
        Some(projjson) => Some(projjson_crs(projjson)),
    };
    let covering = column["covering"]["bbox"]["xmin"][0]
        .as_str()
        .map(str::to_string);
    Ok(GeoColumn {
        name,
        encoding,
        crs,
        covering,
    })
}

/// A PROJJSON CRS as a name: its `id` (authority and code), else a compound CRS's first component's or a bound
/// CRS's source CRS's.
fn projjson_crs(v: &serde_json::Value) -> DeclaredCrs {
    fn id(v: &serde_json::Value) -> Option<String> {
        let id = v.get("id").or_else(|| v["ids"].get(0))?;
        let authority = id["authority"].as_str()?;
        let code = match &id["code"] {
            serde_json::Value::String(s) => s.clone(),
            serde_json::Value::Number(n) => n.to_string(),
            _ => return None,
        };
        Some(format!("{authority}:{code}"))
    }
    let found = id(v)
        .or_else(|| id(&v["components"][0]))
        .or_else(|| id(&v["source_crs"]))
        .or_else(|| id(&v["source_crs"]["components"][0]));
    match found {
        Some(name) => DeclaredCrs::Name(name),
        None => DeclaredCrs::NotUnderstood {
            member: "geo.columns.crs",
            detail: format!(
                "a PROJJSON {} {:?} without an authority id",
                v["type"].as_str().unwrap_or("CRS"),
                v["name"].as_str().unwrap_or("")
            ),
        },
    }
}

/// The features of one row group (`first` = the number of its first row in the file), each with its 3D surface
/// model's faces when it holds one.
fn row_group(
    reader: &SerializedFileReader<bytes::Bytes>,
    g: usize,
    first: usize,
    geo: &GeoColumn,
    skip: &BTreeSet<&str>,
    file_name: &str,
) -> Result<Vec<Row>, String> {
    let rg = reader
        .get_row_group(g)
        .map_err(|e| format!("row group {g}: {e}"))?;
    let rows = rg
        .get_row_iter(None)
        .map_err(|e| format!("row group {g}: {e}"))?;
    let mut out = Vec::new();
    for (i, row) in rows.enumerate() {
        let n = first + i;
        let row = row.map_err(|e| format!("row {n}: {e}"))?;
        let mut attributes = Attributes::new();
        let mut geometry = None;
        for (name, field) in row.into_columns() {
            if name == geo.name {
                geometry = Some(field);
            } else if !skip.contains(name.as_str()) {
                put(&mut attributes, name, field);
            }
        }
        let mut f = RawFeature {
            source_id: crate::feature::source_id(&attributes, file_name, n),
            attributes,
            ..Default::default()
        };
        let label = format!("row {n}");
        let read = match (geo.encoding, geometry) {
            (_, None | Some(Field::Null)) => {
                Err((IssueReason::NoGeometry, "geometry is null".to_string()))
            }
            (Encoding::Wkb, Some(Field::Bytes(b))) => crate::gpkg::wkb_geometry(b.data()),
            (Encoding::Wkb, Some(other)) => Err((
                IssueReason::MalformedGeometry,
                format!("the geometry column holds {} instead of WKB", kind(&other)),
            )),
            (Encoding::Polygon, Some(v)) => native_polygon(&v).map(|p| vec![p]).map(footprint),
            (Encoding::MultiPolygon, Some(v)) => each(&v, native_polygon).map(footprint),
            (Encoding::LineString, Some(v)) => {
                native_line(&v).map(|l| Geometry::Lines(vec![l], "LineString"))
            }
            (Encoding::MultiLineString, Some(v)) => {
                each(&v, native_line).map(|lines| Geometry::Lines(lines, "MultiLineString"))
            }
        };
        let faces = crate::gpkg::put_geometry(&mut f, read, &label);
        out.push((f, faces.map(|faces| (label, faces))));
    }
    Ok(out)
}

/// Each element of a GeoArrow list, read by `read`.
fn each<T>(
    v: &Field,
    read: impl Fn(&Field) -> Result<T, (IssueReason, String)>,
) -> Result<Vec<T>, (IssueReason, String)> {
    match v {
        Field::ListInternal(l) => l.elements().iter().map(read).collect(),
        other => Err(not_a_list(other)),
    }
}

/// A GeoArrow linestring: its coordinates.
fn native_line(v: &Field) -> Result<Vec<[f64; 2]>, (IssueReason, String)> {
    let line = each(v, coordinate)?;
    if line.is_empty() {
        return Err((IssueReason::EmptyGeometry, "an empty line".into()));
    }
    Ok(line)
}

fn footprint(polygons: Vec<RawPolygon>) -> Geometry {
    Geometry::Footprint(polygons, Vec::new())
}

fn not_a_list(v: &Field) -> (IssueReason, String) {
    (
        IssueReason::MalformedGeometry,
        format!("a native geometry holds {} where a list belongs", kind(v)),
    )
}

/// A GeoArrow polygon: its rings as open rings of (x, y) (a repeated closing point left out).
fn native_polygon(v: &Field) -> Result<RawPolygon, (IssueReason, String)> {
    let out = each(v, |ring| {
        let mut r = each(ring, coordinate)?;
        if r.len() > 1 && r.first() == r.last() {
            r.pop();
        }
        Ok(r)
    })?;
    if out.iter().all(Vec::is_empty) {
        return Err((IssueReason::EmptyGeometry, "an empty polygon".into()));
    }
    Ok(out)
}

/// One GeoArrow coordinate: a struct with `x` and `y` (separated), or a list of two or more numbers (interleaved).
fn coordinate(p: &Field) -> Result<[f64; 2], (IssueReason, String)> {
    let number = |f: &Field| match f {
        Field::Double(x) => Some(*x),
        Field::Float(x) => Some(f64::from(*x)),
        _ => None,
    };
    let xy = match p {
        Field::Group(row) => {
            let get = |k: &str| {
                row.get_column_iter()
                    .find(|(n, _)| n.as_str() == k)
                    .and_then(|(_, v)| number(v))
            };
            get("x").zip(get("y"))
        }
        Field::ListInternal(l) => match l.elements() {
            [x, y, ..] => number(x).zip(number(y)),
            _ => None,
        },
        _ => None,
    };
    xy.map(|(x, y)| [x, y]).ok_or_else(|| {
        (
            IssueReason::MalformedGeometry,
            format!("a coordinate given as {}, not as {{x, y}} numbers", kind(p)),
        )
    })
}

/// A value's kind, for messages.
fn kind(v: &Field) -> &'static str {
    match v {
        Field::Null => "null",
        Field::Bool(_) => "a boolean",
        Field::Str(_) => "text",
        Field::Bytes(_) => "binary data",
        Field::Group(_) => "a struct",
        Field::ListInternal(_) => "a list",
        Field::MapInternal(_) => "a map",
        _ => "a number",
    }
}

/// Puts a column's value into the attributes: a struct's fields as `name.field` (recursively), anything else as
/// one value.
fn put(attributes: &mut Attributes, name: String, field: Field) {
    match field {
        Field::Group(row) => {
            for (k, v) in row.into_columns() {
                put(attributes, format!("{name}.{k}"), v);
            }
        }
        other => {
            attributes.insert(name, value(&other));
        }
    }
}

/// A scalar as an attribute value; a list or map as compact JSON text.
fn value(v: &Field) -> AttrValue {
    match v {
        Field::Null => AttrValue::Null,
        Field::Bool(b) => AttrValue::Bool(*b),
        Field::Byte(x) => AttrValue::Int(i64::from(*x)),
        Field::Short(x) => AttrValue::Int(i64::from(*x)),
        Field::Int(x) => AttrValue::Int(i64::from(*x)),
        Field::Long(x) => AttrValue::Int(*x),
        Field::UByte(x) => AttrValue::Int(i64::from(*x)),
        Field::UShort(x) => AttrValue::Int(i64::from(*x)),
        Field::UInt(x) => AttrValue::Int(i64::from(*x)),
        Field::ULong(x) => i64::try_from(*x).map_or(AttrValue::Float(*x as f64), AttrValue::Int),
        Field::Float16(x) => AttrValue::Float(f64::from(*x)),
        Field::Float(x) => AttrValue::Float(f64::from(*x)),
        Field::Double(x) => AttrValue::Float(*x),
        Field::Str(s) => AttrValue::String(s.clone()),
        Field::ListInternal(_) | Field::MapInternal(_) | Field::Group(_) => {
            AttrValue::String(json(v, 0).to_string())
        }
        Field::Decimal(_) => v
            .to_string()
            .parse::<f64>()
            .map_or_else(|_| AttrValue::String(v.to_string()), AttrValue::Float),
        // Dates, times and timestamps as the Parquet crate writes them; binary as hexadecimal.
        Field::Bytes(b) => AttrValue::String(b.data().iter().map(|x| format!("{x:02x}")).collect()),
        other => AttrValue::String(other.to_string()),
    }
}

/// A value as JSON, for lists, maps and structs inside them.
fn json(v: &Field, depth: usize) -> serde_json::Value {
    use serde_json::Value;
    if depth > MAX_NESTING {
        return Value::String("…".into());
    }
    match v {
        Field::ListInternal(l) => {
            Value::Array(l.elements().iter().map(|e| json(e, depth + 1)).collect())
        }
        Field::MapInternal(m) => Value::Object(
            m.entries()
                .iter()
                .map(|(k, v)| {
                    let key = match k {
                        Field::Str(s) => s.clone(),
                        other => other.to_string(),
                    };
                    (key, json(v, depth + 1))
                })
                .collect(),
        ),
        Field::Group(row) => Value::Object(
            row.get_column_iter()
                .map(|(k, v)| (k.clone(), json(v, depth + 1)))
                .collect(),
        ),
        scalar => match value(scalar) {
            AttrValue::Null => Value::Null,
            AttrValue::Bool(b) => Value::Bool(b),
            AttrValue::Int(i) => Value::from(i),
            AttrValue::Float(x) => {
                serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)
            }
            AttrValue::String(s) => Value::String(s),
        },
    }
}
