//! Esri Shapefile input: the `.shp` geometry with its `.dbf` attribute table (and `.shx` index, `.cpg` code page
//! when present), read with the `shapefile` crate; the CRS from the `.prj` beside it. Polygons (with Z or M too)
//! become footprints: a shapefile's outer rings run clockwise and its holes counter-clockwise, in any order, so each
//! hole joins the outer ring that holds it. Other shapes are skipped with their type as the reason.

use crate::crs::DeclaredCrs;
use crate::feature::{RawFeature, RawPolygon};
use crate::report::IssueReason;
use citylod_model::{AttrValue, Attributes};
use shapefile::{PolygonRing, Shape};
use std::path::Path;

/// What a shapefile holds: its features and the CRS its `.prj` declares (`None` without a `.prj`).
pub(crate) struct ShapefileDoc {
    pub features: Vec<RawFeature>,
    pub declared_crs: Option<DeclaredCrs>,
}

/// Reads `path` (a `.shp`) with its `.dbf`. Errors (a missing `.dbf`, a file that is not a shapefile, a record cut
/// short) name what went wrong; one unusable shape is a skipped feature, not an error.
pub(crate) fn read(path: &Path) -> Result<ShapefileDoc, String> {
    let mut reader = shapefile::Reader::from_path(path).map_err(|e| match e {
        shapefile::Error::MissingDbf => {
            "its attribute table (.dbf beside it) is missing; a shapefile needs both".to_string()
        }
        e => format!("not a readable shapefile: {e}"),
    })?;
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut features = Vec::new();
    for (index, item) in reader.iter_shapes_and_records().enumerate() {
        let (shape, record) = item.map_err(|e| format!("record {}: {e}", index + 1))?;
        let attributes: Attributes = record
            .into_iter()
            .map(|(name, value)| (name, attr_value(value)))
            .collect();
        let mut out = RawFeature {
            source_id: source_id(&attributes, &file_name, index),
            attributes,
            ..Default::default()
        };
        match polygons(&shape) {
            Ok(p) if p.is_empty() => {
                out.skip = Some((IssueReason::EmptyGeometry, "polygon without rings".into()))
            }
            Ok(p) => out.polygons = p,
            Err(skip) => out.skip = Some(skip),
        }
        features.push(out);
    }
    // Shapes and records pair one to one: a .shp that ends early (its header shortened with it) would lose the
    // buildings of the records left over without a word.
    let dbf = path.with_extension("dbf");
    let records = std::fs::read(&dbf)
        .ok()
        .and_then(|b| Some(u32::from_le_bytes(b.get(4..8)?.try_into().ok()?) as usize));
    if let Some(records) = records.filter(|&r| r != features.len()) {
        return Err(format!(
            "the .shp holds {} shape(s) and its .dbf {records} record(s): one of them is cut short or belongs to \
             another file",
            features.len()
        ));
    }
    let prj = path.with_extension("prj");
    let declared_crs = match std::fs::read(&prj) {
        Ok(bytes) => Some(declared_crs(&String::from_utf8_lossy(&bytes))),
        Err(_) => None,
    };
    Ok(ShapefileDoc {
        features,
        declared_crs,
    })
}

/// The footprint polygons of a shape, or why it has none.
fn polygons(shape: &Shape) -> Result<Vec<RawPolygon>, (IssueReason, String)> {
    let xy = |rings: Vec<(bool, Vec<[f64; 2]>)>| group_rings(rings);
    match shape {
        Shape::Polygon(p) => Ok(xy(p
            .rings()
            .iter()
            .map(|r| ring(r, |q| [q.x, q.y]))
            .collect())),
        Shape::PolygonM(p) => Ok(xy(p
            .rings()
            .iter()
            .map(|r| ring(r, |q| [q.x, q.y]))
            .collect())),
        Shape::PolygonZ(p) => Ok(xy(p
            .rings()
            .iter()
            .map(|r| ring(r, |q| [q.x, q.y]))
            .collect())),
        Shape::NullShape => Err((IssueReason::NoGeometry, "null shape".into())),
        other => Err((
            IssueReason::UnsupportedGeometry,
            format!("{} shape, not a polygon", other.shapetype()),
        )),
    }
}

/// (is outer, open ring) of a shapefile ring: its closing point (the first repeated) dropped, and turned to the
/// OGC's winding (outer rings counter-clockwise, holes clockwise), the reverse of a shapefile's, so that only rings
/// wound against their own format's rule count as reoriented.
fn ring<P>(r: &PolygonRing<P>, xy: impl Fn(&P) -> [f64; 2]) -> (bool, Vec<[f64; 2]>) {
    let mut points: Vec<[f64; 2]> = r.points().iter().map(xy).collect();
    if points.len() > 1 && points.first() == points.last() {
        points.pop();
    }
    points.reverse();
    (matches!(r, PolygonRing::Outer(_)), points)
}

/// Polygons from rings in any order: each outer ring starts one, each hole joins the first outer ring holding its
/// first point (the last outer ring when none does; ingest's repair then settles what is left).
fn group_rings(rings: Vec<(bool, Vec<[f64; 2]>)>) -> Vec<RawPolygon> {
    let mut polygons: Vec<RawPolygon> = rings
        .iter()
        .filter(|(outer, _)| *outer)
        .map(|(_, r)| vec![r.clone()])
        .collect();
    for (_, hole) in rings.into_iter().filter(|(outer, _)| !*outer) {
        let Some(&first) = hole.first() else { continue };
        match polygons
            .iter()
            .position(|p| contains(&p[0], first))
            .or(polygons.len().checked_sub(1))
        {
            Some(k) => polygons[k].push(hole),
            // Holes without any outer ring: taken as outlines (their orientation is repaired later).
            None => polygons.push(vec![hole]),
        }
    }
    polygons
}

/// Whether `p` lies inside the open ring `r` (crossing count of a ray towards +x).
fn contains(r: &[[f64; 2]], p: [f64; 2]) -> bool {
    let n = r.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (r[i], r[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// A dBase value as an attribute: blank fields are null, whole numbers of numeric fields integers, dates
/// `YYYY-MM-DD`.
fn attr_value(v: shapefile::dbase::FieldValue) -> AttrValue {
    use shapefile::dbase::FieldValue as F;
    let number = |x: f64| {
        if x.fract() == 0.0 && x.abs() < 9.007_199_254_740_992e15 {
            AttrValue::Int(x as i64)
        } else {
            AttrValue::Float(x)
        }
    };
    match v {
        F::Character(Some(s)) | F::Memo(s) => AttrValue::String(s),
        F::Numeric(Some(x)) => number(x),
        F::Float(Some(x)) => AttrValue::Float(x as f64),
        F::Integer(i) => AttrValue::Int(i as i64),
        F::Double(x) | F::Currency(x) => AttrValue::Float(x),
        F::Logical(Some(b)) => AttrValue::Bool(b),
        F::Date(Some(d)) => {
            AttrValue::String(format!("{:04}-{:02}-{:02}", d.year(), d.month(), d.day()))
        }
        F::DateTime(t) => {
            let (d, c) = (t.date(), t.time());
            AttrValue::String(format!(
                "{:04}-{:02}-{:02}T{:02}:{:02}:{:02}",
                d.year(),
                d.month(),
                d.day(),
                c.hours(),
                c.minutes(),
                c.seconds()
            ))
        }
        F::Character(None)
        | F::Numeric(None)
        | F::Float(None)
        | F::Logical(None)
        | F::Date(None) => AttrValue::Null,
    }
}

/// The building's id as for GeoJSON properties: `id`, else `@id`, else OSM's `osm_type/osm_id`, else `FILE#INDEX`
/// (the record's 0-based position).
fn source_id(a: &Attributes, file_name: &str, index: usize) -> String {
    let text = |k: &str| match a.get(k) {
        Some(AttrValue::String(s)) if !s.is_empty() => Some(s.clone()),
        Some(AttrValue::Int(i)) => Some(i.to_string()),
        _ => None,
    };
    text("id")
        .or_else(|| text("@id"))
        .or_else(|| Some(format!("{}/{}", text("osm_type")?, text("osm_id")?)))
        .unwrap_or_else(|| format!("{file_name}#{index}"))
}

/// The CRS a `.prj` (OGC or Esri WKT) declares: the EPSG code of its outermost `AUTHORITY` / `ID` when it has one,
/// WGS 84 for a geographic CRS on the WGS 84 datum, else not understood (the user gives `--crs`).
fn declared_crs(wkt: &str) -> DeclaredCrs {
    let wkt = wkt.trim().trim_start_matches('\u{feff}');
    // The outermost node's authority is its last child: `AUTHORITY["EPSG","26986"]]` or `ID["EPSG",26986]]` at
    // the very end.
    let code = ["AUTHORITY[", "ID["].iter().find_map(|tag| {
        let at = wkt.rfind(tag)?;
        let rest = &wkt[at + tag.len()..];
        let close = rest.find(']')?;
        if rest[close + 1..].trim() != "]" {
            return None;
        }
        let mut parts = rest[..close].split(',').map(|s| s.trim().trim_matches('"'));
        let (authority, code) = (parts.next()?, parts.next()?);
        (authority.eq_ignore_ascii_case("EPSG") && code.bytes().all(|b| b.is_ascii_digit()))
            .then(|| format!("EPSG:{code}"))
    });
    if let Some(code) = code {
        return DeclaredCrs::Name(code);
    }
    let upper = wkt.to_ascii_uppercase();
    let geographic = upper.starts_with("GEOGCS[") || upper.starts_with("GEOGCRS[");
    if geographic
        && (upper.contains("WGS_1984") || upper.contains("WGS 84") || upper.contains("WGS84"))
    {
        return DeclaredCrs::Name("EPSG:4326".into());
    }
    DeclaredCrs::NotUnderstood {
        member: ".prj",
        detail: format!(
            "it names no EPSG code ({})",
            wkt.chars().take(80).collect::<String>()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prj_files_name_their_epsg_code_or_ask_for_one() {
        let name = |w: &str| match declared_crs(w) {
            DeclaredCrs::Name(n) => n,
            DeclaredCrs::NotUnderstood { member, .. } => format!("? {member}"),
        };
        let ogc = r#"PROJCS["NAD83 / Massachusetts Mainland",GEOGCS["NAD83",DATUM["North_American_Datum_1983",SPHEROID["GRS 1980",6378137,298.257222101,AUTHORITY["EPSG","7019"]],AUTHORITY["EPSG","6269"]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433],AUTHORITY["EPSG","4269"]],PROJECTION["Lambert_Conformal_Conic_2SP"],UNIT["metre",1],AUTHORITY["EPSG","26986"]]"#;
        assert_eq!(name(ogc), "EPSG:26986");
        // Esri's WKT has no authority: the datum's own code deep inside is not the CRS's.
        let esri = r#"PROJCS["NAD_1983_StatePlane_Massachusetts_Mainland_FIPS_2001",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],UNIT["Meter",1.0]]"#;
        assert_eq!(name(esri), "? .prj");
        let nested_only =
            r#"PROJCS["x",GEOGCS["NAD83",AUTHORITY["EPSG","4269"]],UNIT["Meter",1.0]]"#;
        assert_eq!(name(nested_only), "? .prj");
        let wgs84 = "\u{feff}GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]]\n";
        assert_eq!(name(wgs84), "EPSG:4326");
        let wkt2 = r#"PROJCRS["Amersfoort / RD New",BASEGEOGCRS["Amersfoort",DATUM["Amersfoort",ELLIPSOID["Bessel 1841",6377397.155,299.1528128]]],CONVERSION["RD New",METHOD["Oblique Stereographic"]],CS[Cartesian,2],ID["EPSG",28992]]"#;
        assert_eq!(name(wkt2), "EPSG:28992");
    }

    #[test]
    fn holes_join_the_outer_ring_that_holds_them_in_any_order() {
        let square = |x0: f64, s: f64| vec![[x0, 0.0], [x0, s], [x0 + s, s], [x0 + s, 0.0]];
        let hole_in = |x0: f64| {
            vec![
                [x0 + 1.0, 1.0],
                [x0 + 2.0, 1.0],
                [x0 + 2.0, 2.0],
                [x0 + 1.0, 2.0],
            ]
        };
        // The second square's hole comes first, before either outer ring.
        let p = group_rings(vec![
            (false, hole_in(10.0)),
            (true, square(0.0, 5.0)),
            (true, square(10.0, 5.0)),
            (false, hole_in(0.0)),
        ]);
        assert_eq!(p.len(), 2);
        assert_eq!(p[0], vec![square(0.0, 5.0), hole_in(0.0)]);
        assert_eq!(p[1], vec![square(10.0, 5.0), hole_in(10.0)]);
        // A hole no outer ring holds joins the last one; holes alone become outlines.
        let p = group_rings(vec![(true, square(0.0, 5.0)), (false, hole_in(20.0))]);
        assert_eq!(p[0].len(), 2);
        assert_eq!(group_rings(vec![(false, hole_in(0.0))]).len(), 1);
    }

    #[test]
    fn dbase_values_become_attributes() {
        use shapefile::dbase::FieldValue as F;
        assert_eq!(attr_value(F::Character(None)), AttrValue::Null);
        assert_eq!(attr_value(F::Numeric(Some(12.0))), AttrValue::Int(12));
        assert_eq!(attr_value(F::Numeric(Some(12.5))), AttrValue::Float(12.5));
        assert_eq!(attr_value(F::Numeric(None)), AttrValue::Null);
        assert_eq!(attr_value(F::Logical(Some(true))), AttrValue::Bool(true));
        assert_eq!(
            attr_value(F::Date(Some(
                shapefile::dbase::Date::new(7, 3, 2011).unwrap()
            ))),
            AttrValue::String("2011-03-07".into())
        );
        let a: Attributes = [
            ("osm_type".to_string(), AttrValue::String("way".into())),
            ("osm_id".to_string(), AttrValue::Int(5)),
        ]
        .into_iter()
        .collect();
        assert_eq!(source_id(&a, "f.shp", 3), "way/5");
        assert_eq!(source_id(&Attributes::default(), "f.shp", 3), "f.shp#3");
    }
}
