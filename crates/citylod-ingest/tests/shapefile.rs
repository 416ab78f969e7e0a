//! Shapefile input on real data: the bundled Lower East Side written as a shapefile (with the `shapefile` crate's
//! writer: outer rings clockwise, holes counter-clockwise, a dBase table, a `.prj`) ingests into the same buildings
//! as the same features written as GeoJSON — ids, attributes, heights and footprints — and broken shapefiles are
//! errors that say what is missing.

use citylod_ingest::{ingest, IngestError, IngestOptions};
use serde_json::Value;
use shapefile::dbase::{FieldValue, Record, TableWriterBuilder};
use shapefile::{Point, Polygon, PolygonRing};
use std::path::{Path, PathBuf};

const WGS84_PRJ: &str = r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#;

fn nyc() -> Value {
    let p =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/nyc-les/les_buildings.geojson");
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// The attributes both files carry: OSM's type and id (the building's source id) and its height tag.
fn kept(props: &Value) -> (Option<String>, Option<i64>, Option<String>) {
    (
        props["osm_type"].as_str().map(str::to_string),
        props["osm_id"].as_i64(),
        props["height"].as_str().map(str::to_string),
    )
}

/// Writes the NYC features as `dir/les.shp` (+ .shx, .dbf, .prj) and as `dir/les.geojson` with the same attributes.
fn write_both(dir: &Path) -> (PathBuf, PathBuf) {
    let doc = nyc();
    let features = doc["features"].as_array().unwrap();
    let table = TableWriterBuilder::new()
        .add_character_field("osm_type".try_into().unwrap(), 10)
        .add_numeric_field("osm_id".try_into().unwrap(), 20, 0)
        .add_character_field("height".try_into().unwrap(), 20);
    let shp = dir.join("les.shp");
    let mut writer = shapefile::Writer::from_path(&shp, table).unwrap();
    let mut geojson = Vec::new();
    for f in features {
        let g = &f["geometry"];
        let polygons: Vec<&Value> = match g["type"].as_str() {
            Some("Polygon") => vec![&g["coordinates"]],
            Some("MultiPolygon") => g["coordinates"].as_array().unwrap().iter().collect(),
            _ => continue,
        };
        let mut rings = Vec::new();
        for p in &polygons {
            for (k, r) in p.as_array().unwrap().iter().enumerate() {
                let points: Vec<Point> = r
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|c| Point::new(c[0].as_f64().unwrap(), c[1].as_f64().unwrap()))
                    .collect();
                rings.push(if k == 0 {
                    PolygonRing::Outer(points)
                } else {
                    PolygonRing::Inner(points)
                });
            }
        }
        let (osm_type, osm_id, height) = kept(&f["properties"]);
        let mut record = Record::default();
        record.insert("osm_type".into(), FieldValue::Character(osm_type.clone()));
        record.insert(
            "osm_id".into(),
            FieldValue::Numeric(osm_id.map(|i| i as f64)),
        );
        record.insert("height".into(), FieldValue::Character(height.clone()));
        writer
            .write_shape_and_record(&Polygon::with_rings(rings), &record)
            .unwrap();
        geojson.push(serde_json::json!({
            "type": "Feature",
            "properties": {"osm_type": osm_type, "osm_id": osm_id, "height": height},
            "geometry": g,
        }));
    }
    drop(writer);
    std::fs::write(dir.join("les.prj"), WGS84_PRJ).unwrap();
    let json = dir.join("les.geojson");
    let fc = serde_json::json!({"type": "FeatureCollection", "features": geojson});
    std::fs::write(&json, fc.to_string()).unwrap();
    (shp, json)
}

#[test]
fn a_shapefile_ingests_into_the_buildings_its_geojson_gives() {
    let dir = tempfile::tempdir().unwrap();
    let (shp, json) = write_both(dir.path());
    let from_shp = ingest(&[shp], &IngestOptions::default()).unwrap();
    let from_json = ingest(&[json], &IngestOptions::default()).unwrap();
    assert!(
        from_json.buildings.len() > 1300,
        "{}",
        from_json.buildings.len()
    );
    assert_eq!(from_shp.buildings.len(), from_json.buildings.len());
    assert_eq!(
        from_shp.report.skipped.len(),
        from_json.report.skipped.len()
    );
    assert_eq!(from_shp.frame, from_json.frame);
    // The .prj's geographic WGS 84 is read as EPSG:4326.
    let file = &from_shp.report.files[0];
    assert_eq!(
        (
            serde_json::to_value(file.format).unwrap(),
            file.crs.as_str()
        ),
        (Value::from("shapefile"), "EPSG:4326")
    );
    for (a, b) in from_shp.buildings.iter().zip(&from_json.buildings) {
        assert_eq!(a.source_id, b.source_id);
        assert!(
            a.source_id.starts_with("way/") || a.source_id.starts_with("relation/"),
            "{}",
            a.source_id
        );
        assert_eq!(a.attributes, b.attributes, "{}", a.source_id);
        assert_eq!(
            (a.height_m, a.base_z_m),
            (b.height_m, b.base_z_m),
            "{}",
            a.source_id
        );
        // The same outline, wound the other way in the file: the same area and extent.
        let (aa, ab) = (a.area_m2(), b.area_m2());
        assert!(
            (aa - ab).abs() <= 1e-9 * ab.max(1.0),
            "{}: {aa} m² against {ab} m²",
            a.source_id
        );
        let bounds = |b: &citylod_model::Building| {
            b.footprint
                .0
                .iter()
                .flat_map(|p| p.exterior().0.iter())
                .fold(
                    [
                        f64::INFINITY,
                        f64::INFINITY,
                        f64::NEG_INFINITY,
                        f64::NEG_INFINITY,
                    ],
                    |r, c| [r[0].min(c.x), r[1].min(c.y), r[2].max(c.x), r[3].max(c.y)],
                )
        };
        let (ra, rb) = (bounds(a), bounds(b));
        assert!(
            ra.iter().zip(rb).all(|(x, y)| (x - y).abs() < 1e-9),
            "{}: {ra:?} {rb:?}",
            a.source_id
        );
    }
}

#[test]
fn broken_shapefiles_say_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    let (shp, _) = write_both(dir.path());
    let opts = IngestOptions::default();
    // An Esri .prj without an EPSG code: the user gives the CRS.
    let esri = r#"PROJCS["NAD_1983_StatePlane_New_York_Long_Island_FIPS_3104_Feet",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],UNIT["Foot_US",0.3048006096012192]]"#;
    std::fs::write(dir.path().join("les.prj"), esri).unwrap();
    let e = ingest(std::slice::from_ref(&shp), &opts).unwrap_err();
    assert!(
        matches!(e, IngestError::CrsNotUnderstood { member: ".prj", .. }),
        "{e}"
    );
    assert!(e.to_string().contains("--crs"), "{e}");
    // --crs overrides the .prj (here the true one, WGS84).
    let with_crs = IngestOptions {
        crs: Some("EPSG:4326".into()),
        ..Default::default()
    };
    assert!(
        ingest(std::slice::from_ref(&shp), &with_crs)
            .unwrap()
            .buildings
            .len()
            > 1300
    );
    // No .prj at all.
    std::fs::remove_file(dir.path().join("les.prj")).unwrap();
    let e = ingest(std::slice::from_ref(&shp), &opts).unwrap_err();
    assert!(matches!(e, IngestError::MissingPrj { .. }), "{e}");
    // A .shp cut after its first shapes, its header's length shortened to match: the .dbf's records outnumber them.
    let whole = std::fs::read(&shp).unwrap();
    let first_end = 100 + 8 + 2 * u32::from_be_bytes(whole[104..108].try_into().unwrap()) as usize;
    let mut cut = whole[..first_end].to_vec();
    cut[24..28].copy_from_slice(&((first_end / 2) as u32).to_be_bytes());
    std::fs::write(&shp, &cut).unwrap();
    let e = ingest(std::slice::from_ref(&shp), &with_crs).unwrap_err();
    assert!(
        e.to_string().contains("holds 1 shape(s) and its .dbf"),
        "{e}"
    );
    std::fs::write(&shp, &whole).unwrap();
    // No .dbf: the attribute table is half of a shapefile.
    std::fs::remove_file(dir.path().join("les.dbf")).unwrap();
    let e = ingest(std::slice::from_ref(&shp), &with_crs).unwrap_err();
    assert!(e.to_string().contains(".dbf"), "{e}");
    // A .shp that is not one.
    let bad = dir.path().join("bad.shp");
    std::fs::write(&bad, b"not a shapefile at all, just text").unwrap();
    std::fs::copy(dir.path().join("les.shx"), dir.path().join("bad.shx")).unwrap();
    let e = ingest(&[bad], &with_crs).unwrap_err();
    assert!(matches!(e, IngestError::InvalidShapefile { .. }), "{e}");
}
