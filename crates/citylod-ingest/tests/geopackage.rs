//! GeoPackage input. On real data written by an independent writer: GDAL's GeoPackage of 200 Lower East Side
//! buildings in EPSG:2263 (feet, a Lambert conic on NAD83) ingests into the buildings the same features give as
//! GeoJSON. On fixtures written by `citylod_testdata::geopackage` (exactly the tables and geometry bytes a test
//! chooses): every encoding of a footprint GeoPackage allows reads alike, and every way a row can fail to be a
//! building — null, empty, not polygonal, cut short, standing on edge — is a skip with its reason and FID, every odd
//! cell a value or a repair, every file-level problem an error saying what to do.

use citylod_ingest::{ingest, IngestError, IngestOptions, Ingested};
use citylod_model::{AttrValue, Attributes};
use citylod_testdata::geopackage::{blob, write, Envelope, Layer, Row, Srs, Wkb};
use rusqlite::types::Value as Sql;
use serde_json::Value;
use std::path::{Path, PathBuf};

fn gdal_fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/geopackage/les_gdal.gpkg")
}

fn with_layer(layer: &str) -> IngestOptions {
    IngestOptions {
        layer: Some(layer.into()),
        ..Default::default()
    }
}

fn without_nulls(a: &Attributes) -> Attributes {
    a.iter()
        .filter(|(_, v)| **v != AttrValue::Null)
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect()
}

#[test]
fn a_geopackage_written_by_gdal_ingests_into_the_buildings_its_geojson_gives() {
    let path = gdal_fixture();
    let from_gpkg = ingest(std::slice::from_ref(&path), &with_layer("buildings")).unwrap();
    // The same features as GeoJSON (the fixture holds every seventh of the bundled file, in its order).
    let all: Value = serde_json::from_str(
        &std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../examples/nyc-les/les_buildings.geojson"),
        )
        .unwrap(),
    )
    .unwrap();
    let first: Vec<Value> = all["features"]
        .as_array()
        .unwrap()
        .iter()
        .step_by(7)
        .cloned()
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("every7th.geojson");
    std::fs::write(
        &json,
        serde_json::json!({"type": "FeatureCollection", "features": first}).to_string(),
    )
    .unwrap();
    let from_json = ingest(&[json], &IngestOptions::default()).unwrap();

    assert!(
        from_json.buildings.len() > 150,
        "{}",
        from_json.buildings.len()
    );
    assert_eq!(from_gpkg.buildings.len(), from_json.buildings.len());
    assert_eq!(
        from_gpkg.report.skipped.len(),
        from_json.report.skipped.len()
    );
    let file = &from_gpkg.report.files[0];
    assert_eq!(
        (
            serde_json::to_value(file.format).unwrap(),
            file.crs.as_str(),
            file.features_read
        ),
        (Value::from("geo_package"), "EPSG:2263", 203)
    );
    assert_eq!(
        file.notes,
        vec!["layer \"buildings\" read, of 2 feature tables (buildings, roads)".to_string()]
    );
    // Feet on NAD83 back to WGS 84 degrees: the frames agree to a millimetre (1e-8° ≈ 1 mm).
    assert!((from_gpkg.frame.origin_lon_deg - from_json.frame.origin_lon_deg).abs() < 1e-8);
    assert!((from_gpkg.frame.origin_lat_deg - from_json.frame.origin_lat_deg).abs() < 1e-8);
    let mut holes = 0;
    for (a, b) in from_gpkg.buildings.iter().zip(&from_json.buildings) {
        assert_eq!(a.source_id, b.source_id);
        assert!(
            a.source_id.starts_with("way/") || a.source_id.starts_with("relation/"),
            "{}",
            a.source_id
        );
        // GDAL writes a column for every property, NULL where a feature has none; osm_id as an integer. The FID is
        // an attribute too (QGIS shows it so): 1 to 203.
        let fid = a.attributes.get("fid").cloned();
        assert!(
            matches!(fid, Some(AttrValue::Int(f)) if (1..=203).contains(&f)),
            "{fid:?}"
        );
        let attrs: Attributes = without_nulls(&a.attributes)
            .iter()
            .filter(|(k, _)| k.as_str() != "fid")
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        assert_eq!(attrs, b.attributes, "{}", a.source_id);
        assert_eq!(a.height_m, b.height_m, "{}", a.source_id);
        assert!((a.base_z_m - b.base_z_m).abs() < 1e-6, "{}", a.source_id);
        assert_eq!(a.footprint.0.len(), b.footprint.0.len(), "{}", a.source_id);
        let h = |x: &citylod_model::Building| {
            x.footprint
                .0
                .iter()
                .map(|p| p.interiors().len())
                .sum::<usize>()
        };
        assert_eq!(h(a), h(b), "{}", a.source_id);
        holes += h(a);
        let (aa, ab) = (a.area_m2(), b.area_m2());
        assert!(
            (aa - ab).abs() <= 1e-6 * ab + 1e-4,
            "{}: {aa} m² against {ab} m²",
            a.source_id
        );
    }
    assert!(holes > 0, "the comparison saw courtyards");
}

#[test]
fn a_geopackage_of_several_layers_is_read_by_the_layer_named() {
    let path = gdal_fixture();
    let e = ingest(std::slice::from_ref(&path), &IngestOptions::default()).unwrap_err();
    assert!(matches!(e, IngestError::InvalidGeoPackage { .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("--layer") && text.contains("buildings (MULTIPOLYGON), roads (LINESTRING)"),
        "{text}"
    );
    let e = ingest(std::slice::from_ref(&path), &with_layer("building")).unwrap_err();
    assert!(
        e.to_string()
            .contains("no feature table \"building\" (its feature tables: buildings (MULTIPOLYGON), roads (LINESTRING))"),
        "{e}"
    );
    // The roads are lines: every one skipped, by its FID, none lost without a word.
    let roads = ingest(std::slice::from_ref(&path), &with_layer("roads")).unwrap();
    assert!(roads.buildings.is_empty());
    assert_eq!(roads.report.skipped.len(), 20);
    let s = &roads.report.skipped[0];
    assert_eq!(s.reason.as_str(), "unsupported_geometry");
    assert_eq!(s.feature_id, "les_gdal.gpkg#1");
    assert_eq!(s.detail, "FID 1: LineString geometry is not a footprint");
    // --layer without a GeoPackage among the inputs is a usage error, not ignored.
    let geojson =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/nyc-les/les_buildings.geojson");
    let e = ingest(&[geojson], &with_layer("buildings")).unwrap_err();
    assert!(
        matches!(
            e,
            IngestError::InvalidOption {
                name: "--layer",
                ..
            }
        ),
        "{e}"
    );
}

/// A 10 m square at `x` metres east of a point in Manhattan, in lon/lat, closed, counter-clockwise.
fn square(x: f64, size: f64) -> Vec<[f64; 2]> {
    let (lon0, lat0) = (-73.99, 40.72);
    let (dlon, dlat) = (1.0 / 84_300.0, 1.0 / 111_000.0);
    let p = |e: f64, n: f64| [lon0 + e * dlon, lat0 + n * dlat];
    vec![
        p(x, 0.0),
        p(x + size, 0.0),
        p(x + size, size),
        p(x, size),
        p(x, 0.0),
    ]
}

fn with_z(r: &[[f64; 2]], z: f64) -> Vec<[f64; 3]> {
    r.iter().map(|p| [p[0], p[1], z]).collect()
}

fn layer(rows: Vec<Row>, columns: Vec<(&str, &str)>) -> Layer {
    Layer {
        table: "buildings".into(),
        geometry_column: "geom".into(),
        geometry_type: "GEOMETRY".into(),
        srs_id: 4326,
        columns: columns
            .into_iter()
            .map(|(n, t)| (n.to_string(), t.to_string()))
            .collect(),
        rows,
    }
}

/// The geometry blob of a 10 m square `20 i` m east of [`square`]'s point, in lon/lat.
fn square_blob(i: usize) -> Option<Vec<u8>> {
    let le = Wkb::default();
    Some(blob(
        4326,
        Envelope::Xy,
        false,
        &le.polygon(&[square(20.0 * i as f64, 10.0)]),
    ))
}

fn row(fid: i64, geometry: Option<Vec<u8>>) -> Row {
    Row {
        fid,
        geometry,
        values: vec![],
    }
}

fn one_layer(dir: &Path, name: &str, l: Layer) -> PathBuf {
    let p = dir.join(name);
    write(&p, &[], &[l]);
    p
}

fn skips(r: &Ingested) -> Vec<(String, String, String)> {
    r.report
        .skipped
        .iter()
        .map(|s| {
            (
                s.feature_id.clone(),
                s.reason.as_str().to_string(),
                s.detail.clone(),
            )
        })
        .collect()
}

#[test]
fn every_encoding_of_a_footprint_reads_alike() {
    let le = Wkb::default();
    let be = Wkb {
        little_endian: false,
        ..Wkb::default()
    };
    let ewkb = Wkb {
        ewkb_z: true,
        ..Wkb::default()
    };
    let sq = |i: usize| square(20.0 * i as f64, 10.0);
    let mut srid_flagged = vec![1u8];
    srid_flagged.extend((3u32 | 0x2000_0000).to_le_bytes());
    srid_flagged.extend(4326u32.to_le_bytes());
    srid_flagged.extend(&le.polygon(&[sq(9)])[5..]);
    let mut open = sq(10);
    open.pop();
    let variants: Vec<Vec<u8>> = vec![
        blob(4326, Envelope::None, false, &le.polygon(&[sq(0)])),
        blob(4326, Envelope::Xy, false, &be.polygon(&[sq(1)])),
        blob(
            4326,
            Envelope::Xyz,
            false,
            &le.polygon_z(&[with_z(&sq(2), 5.0)]),
        ),
        blob(
            4326,
            Envelope::Xym,
            false,
            &ewkb.polygon_z(&[with_z(&sq(3), 5.0)]),
        ),
        blob(
            4326,
            Envelope::Xyzm,
            false,
            &le.multipolygon(&[vec![sq(4)]]),
        ),
        blob(
            4326,
            Envelope::Xy,
            false,
            &be.multipolygon_z(&[vec![with_z(&sq(5), 0.0)]]),
        ),
        blob(
            4326,
            Envelope::Xy,
            false,
            &le.collection(&[le.point([0.0, 0.0]), be.polygon(&[sq(6)])]),
        ),
        blob(
            4326,
            Envelope::Xy,
            false,
            &le.collection(&[
                le.collection(&[le.line(&[[0.0, 0.0], [1.0, 1.0]])]),
                le.polygon(&[sq(7)]),
            ]),
        ),
        // A sloped roof face in Z is still a plan outline.
        blob(
            4326,
            Envelope::None,
            false,
            &le.polygon_z(&[sq(8)
                .iter()
                .enumerate()
                .map(|(k, p)| [p[0], p[1], k as f64])
                .collect()]),
        ),
        blob(4326, Envelope::None, false, &srid_flagged),
        blob(4326, Envelope::None, false, &le.polygon(&[open])),
    ];
    let n = variants.len();
    let rows = variants
        .into_iter()
        .enumerate()
        .map(|(i, b)| row(i as i64 + 1, Some(b)))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let p = one_layer(dir.path(), "variants.gpkg", layer(rows, vec![]));
    let r = ingest(&[p], &IngestOptions::default()).unwrap();
    assert_eq!(skips(&r), vec![]);
    assert_eq!(r.buildings.len(), n);
    for b in &r.buildings {
        assert!(
            (b.area_m2() - 100.0).abs() < 0.5,
            "{}: {} m²",
            b.source_id,
            b.area_m2()
        );
    }
    let mut repairs: Vec<(String, String)> = r
        .report
        .repaired
        .iter()
        .map(|s| (s.feature_id.clone(), s.reason.as_str().to_string()))
        .collect();
    repairs.sort();
    assert_eq!(
        repairs,
        vec![
            ("variants.gpkg#11".to_string(), "ring_closed".to_string()),
            (
                "variants.gpkg#7".to_string(),
                "non_polygon_member_dropped".to_string()
            ),
            (
                "variants.gpkg#8".to_string(),
                "non_polygon_member_dropped".to_string()
            ),
        ]
    );
    let dropped = r
        .report
        .repaired
        .iter()
        .find(|s| s.feature_id == "variants.gpkg#8")
        .unwrap();
    assert_eq!(
        dropped.detail,
        "1 GeometryCollection member(s) not polygonal, dropped: member 0/0 (LineString)"
    );
}

#[test]
fn rows_that_are_no_footprint_are_skipped_with_their_reason_and_fid() {
    let le = Wkb::default();
    let good = le.polygon(&[square(0.0, 10.0)]);
    let mut nan = square(20.0, 10.0);
    nan[2][0] = f64::NAN;
    // The four walls of a 10 m box, without roof or floor: a 3D surface model with nothing to stand on.
    let walls = box_faces(&square(40.0, 10.0), 0.0, 9.0)[..4].to_vec();
    let mut cut = blob(4326, Envelope::Xy, false, &good);
    cut.truncate(cut.len() - 5);
    let rows = vec![
        row(1, None),
        row(2, Some(blob(4326, Envelope::Xy, true, &[]))),
        row(
            3,
            Some(blob(4326, Envelope::None, false, &le.point([1.0, 2.0]))),
        ),
        row(4, Some(cut)),
        row(
            5,
            Some(blob(4326, Envelope::None, false, &le.polygon(&[nan]))),
        ),
        row(
            6,
            Some(blob(
                4326,
                Envelope::None,
                false,
                &le.multipolygon_z(&walls),
            )),
        ),
        row(7, Some(good[..].to_vec())),
        row(
            8,
            Some({
                let mut b = blob(4326, Envelope::None, false, &good);
                b[3] |= 0b0010_0000;
                b
            }),
        ),
        row(9, Some(blob(4326, Envelope::None, false, &le.polygon(&[])))),
        row(10, Some(blob(4326, Envelope::Xy, false, &good))),
    ];
    let dir = tempfile::tempdir().unwrap();
    let p = one_layer(dir.path(), "bad.gpkg", layer(rows, vec![]));
    let r = ingest(&[p], &IngestOptions::default()).unwrap();
    assert_eq!(r.buildings.len(), 1);
    assert_eq!(r.buildings[0].source_id, "bad.gpkg#10");
    let got: Vec<(String, String)> = skips(&r)
        .into_iter()
        .map(|(id, reason, detail)| (id, format!("{reason}: {detail}")))
        .collect();
    let want = [
        ("bad.gpkg#1", "no_geometry: FID 1: geometry is null"),
        ("bad.gpkg#2", "empty_geometry: FID 2: an empty geometry"),
        ("bad.gpkg#3", "unsupported_geometry: FID 3: Point geometry is not a footprint"),
        ("bad.gpkg#4", "malformed_geometry: FID 4: a ring said to hold 5 points, more than the rest of its 88-byte WKB"),
        ("bad.gpkg#5", &*format!("non_finite_coordinate: FID 5: a vertex (NaN, {}) that is not a finite number", square(20.0, 10.0)[2][1])),
        ("bad.gpkg#6", "no_footprint: FID 6: a 3D surface model of walls only: no face to take its footprint from"),
        ("bad.gpkg#7", "malformed_geometry: FID 7: the geometry blob does not start with a GeoPackage header ('GP')"),
        ("bad.gpkg#8", "unsupported_geometry: FID 8: a GeoPackage extended geometry type (not a standard WKB geometry)"),
        ("bad.gpkg#9", "empty_geometry: FID 9: polygonal geometry without coordinates"),
    ];
    assert_eq!(
        got,
        want.iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect::<Vec<_>>()
    );
}

/// The faces of a box on the closed outline `s` (counter-clockwise) from `z0` to `z1`: four walls, the roof, the floor.
fn box_faces(s: &[[f64; 2]], z0: f64, z1: f64) -> Vec<Vec<Vec<[f64; 3]>>> {
    let mut faces: Vec<Vec<Vec<[f64; 3]>>> = (0..s.len() - 1)
        .map(|k| {
            vec![vec![
                [s[k][0], s[k][1], z0],
                [s[k + 1][0], s[k + 1][1], z0],
                [s[k + 1][0], s[k + 1][1], z1],
                [s[k][0], s[k][1], z1],
                [s[k][0], s[k][1], z0],
            ]]
        })
        .collect();
    faces.push(vec![with_z(s, z1)]);
    let mut floor = with_z(s, z0);
    floor.reverse();
    faces.push(vec![floor]);
    faces
}

#[test]
fn rows_holding_3d_surface_models_stand_on_their_lowest_faces() {
    let le = Wkb::default();
    let sq = |i: f64| square(20.0 * i, 10.0);
    // Walls and roof from 0 to 9 m (no floor); a box from 1 to 9 m with its floor; the same as a TIN; an L-shaped
    // roof of two faces, one sloped, over walls reaching 0 m (MultiPolygon Z, as a 3D layer of 3DBAG holds them).
    let open_box = box_faces(&sq(0.0), 0.0, 9.0)[..5].to_vec();
    let closed = box_faces(&sq(1.0), 1.0, 9.0);
    let tri = |f: &Vec<Vec<[f64; 3]>>| -> Vec<[[f64; 3]; 3]> {
        let r = &f[0];
        vec![[r[0], r[1], r[2]], [r[0], r[2], r[3]]]
    };
    let tin: Vec<[[f64; 3]; 3]> = box_faces(&sq(2.0), 0.0, 6.0).iter().flat_map(tri).collect();
    let a = sq(3.0);
    let b = square(70.0, 5.0);
    let mut roofs = box_faces(&a, 0.0, 12.0)[..4].to_vec();
    roofs.push(vec![with_z(&a, 12.0)]);
    roofs.push(vec![b
        .iter()
        .map(|p| [p[0], p[1], if p[0] > b[0][0] { 8.0 } else { 10.0 }])
        .collect()]);
    let rows = vec![
        row(
            1,
            Some(blob(
                4326,
                Envelope::Xyz,
                false,
                &le.multipolygon_z(&open_box),
            )),
        ),
        row(
            2,
            Some(blob(
                4326,
                Envelope::Xyz,
                false,
                &le.polyhedral_surface_z(&closed),
            )),
        ),
        row(3, Some(blob(4326, Envelope::Xyz, false, &le.tin_z(&tin)))),
        row(
            4,
            Some(blob(4326, Envelope::Xyz, false, &le.multipolygon_z(&roofs))),
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let p = one_layer(dir.path(), "models.gpkg", layer(rows, vec![]));
    let r = ingest(std::slice::from_ref(&p), &IngestOptions::default()).unwrap();
    assert_eq!(skips(&r), vec![]);
    let got: Vec<(f64, f64, f64)> = r
        .buildings
        .iter()
        .map(|b| {
            (
                (b.area_m2() * 10.0).round() / 10.0,
                b.height_m,
                b.base_z_m - r.buildings[0].base_z_m,
            )
        })
        .collect();
    // Bases differ by the earth's curvature across the local frame (~0.1 mm here).
    let close = |x: f64, y: f64| (x - y).abs() < 1e-3;
    let want = [
        (100.0, 9.0, 0.0),
        (100.0, 8.0, 1.0),
        (100.0, 6.0, 0.0),
        (125.0, 12.0, 0.0),
    ];
    for (g, w) in got.iter().zip(want) {
        assert!(
            (g.0 - w.0).abs() < 0.5 && close(g.1, w.1) && close(g.2, w.2),
            "{got:?} against {want:?}"
        );
    }
    assert_eq!(got.len(), 4);
    // Heights come from the geometry, not the default.
    assert_eq!(
        r.report.height_sources.get("geometry").copied(),
        Some(4),
        "{:?}",
        r.report.height_sources
    );
    assert!(r.buildings.iter().all(|b| b.mesh.is_none()));

    // With --lod, the faces are the building's model: floors ground, walls walls, the rest roofs.
    let r = ingest(
        &[p],
        &IngestOptions {
            lod: Some(citylod_ingest::LodChoice::Highest),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(r.report.buildings_with_mesh, 4);
    assert_eq!(r.report.mesh_lods.get("GeoPackage 3D").copied(), Some(4));
    use citylod_model::SurfaceKind::{Ground, Roof, Wall};
    let kinds = |i: usize| {
        let m = r.buildings[i].mesh.as_ref().unwrap();
        [Ground, Wall, Roof].map(|k| m.surfaces.iter().filter(|s| **s == k).count())
    };
    // Triangles: a box's floor and roof two each, its walls eight.
    assert_eq!(kinds(0), [0, 8, 2]);
    assert_eq!(kinds(1), [2, 8, 2]);
    assert_eq!(kinds(2), [2, 8, 2]);
    assert_eq!(kinds(3)[0], 0);
}

#[test]
fn cells_become_typed_attributes_and_odd_ones_are_reported() {
    let g = square_blob;
    let cols = vec![
        ("name", "TEXT"),
        ("height", "REAL"),
        ("levels", "INTEGER"),
        ("is_monument", "BOOLEAN"),
        ("photo", "BLOB"),
        ("built", "DATE"),
    ];
    let rows = vec![
        Row {
            fid: 5,
            geometry: g(0),
            values: vec![
                Sql::Text("Essex Market".into()),
                Sql::Real(21.5),
                Sql::Integer(4),
                Sql::Integer(1),
                Sql::Blob(vec![1, 2, 3]),
                Sql::Text("1940-01-10".into()),
            ],
        },
        Row {
            fid: 7,
            geometry: g(1),
            values: vec![
                Sql::Blob(vec![0xCA, 0xFE]),
                Sql::Null,
                Sql::Null,
                Sql::Integer(0),
                Sql::Null,
                Sql::Null,
            ],
        },
    ];
    let dir = tempfile::tempdir().unwrap();
    let p = one_layer(dir.path(), "cells.gpkg", layer(rows, cols));
    // A text cell that is not UTF-8 (SQLite stores what it is given).
    let db = rusqlite::Connection::open(&p).unwrap();
    db.execute(
        "UPDATE buildings SET built = CAST(x'4d61727a20c3' AS TEXT) WHERE fid = 7",
        [],
    )
    .unwrap();
    drop(db);
    let r = ingest(&[p], &IngestOptions::default()).unwrap();
    assert_eq!(r.buildings.len(), 2);
    let a = &r.buildings[0].attributes;
    assert_eq!(r.buildings[0].source_id, "cells.gpkg#5");
    assert_eq!(a["name"], AttrValue::String("Essex Market".into()));
    assert_eq!(a["height"], AttrValue::Float(21.5));
    assert_eq!(a["levels"], AttrValue::Int(4));
    assert_eq!(a["is_monument"], AttrValue::Bool(true));
    assert_eq!(a["built"], AttrValue::String("1940-01-10".into()));
    assert!(a.get("photo").is_none() && a.get("geom").is_none());
    // The FID is an attribute too, as QGIS shows it, so --id-attr can name it.
    assert_eq!(a["fid"], AttrValue::Int(5));
    assert_eq!(r.buildings[0].height_m, 21.5);
    let b = &r.buildings[1].attributes;
    assert_eq!(b["name"], AttrValue::String("cafe".into()));
    assert_eq!(b["is_monument"], AttrValue::Bool(false));
    assert_eq!(b["built"], AttrValue::String("Marz \u{FFFD}".into()));
    let details: Vec<String> = r
        .report
        .repaired
        .iter()
        .filter(|s| s.reason.as_str() == "undecodable_value_kept_as_text")
        .map(|s| format!("{}: {}", s.feature_id, s.detail))
        .collect();
    assert_eq!(
        details,
        vec![
            "cells.gpkg#7: column \"name\": a blob of 2 bytes, kept as hexadecimal text",
            "cells.gpkg#7: column \"built\": text that is not UTF-8, kept with its undecodable bytes replaced",
        ]
    );
    assert_eq!(
        r.report.files[0].notes,
        vec!["BLOB column(s) not read as attributes: photo".to_string()]
    );
}

/// The Esri WKT ArcGIS writes for EPSG:2263, without its code.
const ESRI_2263: &str = r#"PROJCS["NAD_1983_StatePlane_New_York_Long_Island_FIPS_3104_Feet",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],PARAMETER["False_Easting",984250.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-74.0],PARAMETER["Standard_Parallel_1",40.66666666666666],PARAMETER["Standard_Parallel_2",41.03333333333333],PARAMETER["Latitude_Of_Origin",40.16666666666666],UNIT["Foot_US",0.3048006096012192]]"#;

#[test]
fn the_layers_crs_comes_from_its_spatial_reference_system() {
    let le = Wkb::default();
    // 100 ft squares near the Lower East Side in EPSG:2263.
    let ft = |x: f64| {
        let (x0, y0) = (987_000.0 + x, 201_000.0);
        vec![
            [x0, y0],
            [x0 + 100.0, y0],
            [x0 + 100.0, y0 + 100.0],
            [x0, y0 + 100.0],
            [x0, y0],
        ]
    };
    let rows = |srs: i32| {
        vec![
            row(
                1,
                Some(blob(srs, Envelope::Xy, false, &le.polygon(&[ft(0.0)]))),
            ),
            row(
                2,
                Some(blob(srs, Envelope::Xy, false, &le.polygon(&[ft(200.0)]))),
            ),
        ]
    };
    let dir = tempfile::tempdir().unwrap();
    let ft2_in_m2 = (100.0 * 0.3048006096012192f64).powi(2);
    // A custom srs_id whose definition is an Esri WKT without a code: matched against the EPSG table.
    let p = dir.path().join("esri.gpkg");
    let srs = Srs {
        srs_id: 100_000,
        organization: "NONE".into(),
        organization_coordsys_id: 0,
        definition: ESRI_2263.into(),
    };
    let mut l = layer(rows(100_000), vec![]);
    l.srs_id = 100_000;
    write(&p, &[srs], &[l]);
    let r = ingest(&[p], &IngestOptions::default()).unwrap();
    assert_eq!(r.report.files[0].crs, "EPSG:2263");
    assert_eq!(r.buildings.len(), 2);
    assert!(
        (r.buildings[0].area_m2() - ft2_in_m2).abs() < 0.01,
        "{}",
        r.buildings[0].area_m2()
    );

    // By EPSG code.
    let p = dir.path().join("epsg.gpkg");
    let mut l = layer(rows(2263), vec![]);
    l.srs_id = 2263;
    write(&p, &[Srs::epsg(2263)], &[l]);
    let r = ingest(&[p], &IngestOptions::default()).unwrap();
    assert_eq!(r.report.files[0].crs, "EPSG:2263");

    // The undefined systems leave the CRS to --crs.
    let p = dir.path().join("undefined.gpkg");
    let mut l = layer(rows(-1), vec![]);
    l.srs_id = -1;
    write(&p, &[], &[l]);
    let e = ingest(std::slice::from_ref(&p), &IngestOptions::default()).unwrap_err();
    assert!(matches!(e, IngestError::GeoPackageWithoutCrs { .. }), "{e}");
    assert!(e.to_string().contains("--crs"), "{e}");
    let r = ingest(
        &[p],
        &IngestOptions {
            crs: Some("EPSG:2263".into()),
            ..Default::default()
        },
    )
    .unwrap();
    assert!((r.buildings[1].area_m2() - ft2_in_m2).abs() < 0.01);

    // An srs_id the table does not list.
    let p = dir.path().join("unlisted.gpkg");
    let mut l = layer(rows(31_337), vec![]);
    l.srs_id = 31_337;
    write(&p, &[], &[l]);
    let e = ingest(&[p], &IngestOptions::default()).unwrap_err();
    assert!(
        matches!(
            e,
            IngestError::CrsNotUnderstood {
                member: "gpkg_spatial_ref_sys",
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("srs_id 31337"), "{e}");
}

#[test]
fn files_that_are_not_geopackages_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let err = |p: &Path| {
        ingest(&[p.to_path_buf()], &IngestOptions::default())
            .unwrap_err()
            .to_string()
    };
    let text = dir.path().join("text.gpkg");
    std::fs::write(&text, "{\"type\": \"FeatureCollection\"}").unwrap();
    assert!(
        err(&text).contains("not an SQLite database"),
        "{}",
        err(&text)
    );
    let empty = dir.path().join("empty.gpkg");
    std::fs::write(&empty, "").unwrap();
    assert!(err(&empty).contains("not an SQLite database"));
    let plain = dir.path().join("plain.gpkg");
    rusqlite::Connection::open(&plain)
        .unwrap()
        .execute_batch("CREATE TABLE t (a INTEGER);")
        .unwrap();
    assert!(
        err(&plain)
            .contains("an SQLite database but not a GeoPackage: it has no gpkg_contents table"),
        "{}",
        err(&plain)
    );
    // A GeoPackage of tiles or attributes only.
    let none = dir.path().join("none.gpkg");
    write(&none, &[], &[]);
    assert!(
        err(&none).contains("without feature tables"),
        "{}",
        err(&none)
    );
    let wal = dir.path().join("city.gpkg-wal");
    std::fs::write(&wal, [0u8; 32]).unwrap();
    assert!(
        err(&wal).contains("write-ahead log beside a GeoPackage; give the .gpkg as the input"),
        "{}",
        err(&wal)
    );
}

#[test]
fn broken_bytes_give_errors_or_skips_not_panics() {
    // Every cut of a geometry blob, as rows of one table: each row a building or a skip, never a panic.
    let le = Wkb::default();
    let whole = blob(
        4326,
        Envelope::Xy,
        false,
        &le.collection(&[
            le.point([0.0, 0.0]),
            le.multipolygon(&[
                vec![square(0.0, 10.0), square(2.0, 3.0)],
                vec![square(30.0, 5.0)],
            ]),
        ]),
    );
    let cuts: Vec<Row> = (0..whole.len())
        .map(|n| row(n as i64 + 1, Some(whole[..n].to_vec())))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let p = one_layer(dir.path(), "cuts.gpkg", layer(cuts, vec![]));
    let r = ingest(&[p], &IngestOptions::default()).unwrap();
    assert!(r.buildings.is_empty());
    assert_eq!(r.report.skipped.len(), whole.len());
    // Every byte flipped: a building, a skip, or (a coordinate thrown across the globe) the file refused as too
    // wide for one frame.
    let flips: Vec<Row> = (0..whole.len())
        .map(|i| {
            let mut b = whole.clone();
            b[i] ^= 0xFF;
            row(i as i64 + 1, Some(b))
        })
        .collect();
    let p = one_layer(dir.path(), "flips.gpkg", layer(flips, vec![]));
    match ingest(&[p], &IngestOptions::default()) {
        Ok(r) => assert_eq!(r.buildings.len() + r.report.skipped.len(), whole.len()),
        Err(e) => assert!(matches!(e, IngestError::TooWide { .. }), "{e}"),
    }

    // The database file itself cut and garbled: an error naming the file, or buildings, never a panic.
    let bytes = std::fs::read(gdal_fixture()).unwrap();
    let broken = dir.path().join("broken.gpkg");
    let step = bytes.len() / 97;
    for k in 0..97 {
        let mut b = bytes.clone();
        if k % 2 == 0 {
            b.truncate(k * step);
        } else {
            for x in &mut b[k * step..(k * step + 512).min(bytes.len())] {
                *x = x.wrapping_mul(31).wrapping_add(7);
            }
        }
        std::fs::write(&broken, &b).unwrap();
        if let Err(e) = ingest(std::slice::from_ref(&broken), &with_layer("buildings")) {
            assert!(e.to_string().contains("broken.gpkg"), "{e}");
        }
    }
}

/// Delft's 3DBAG buildings as a 3D GeoPackage layer holds them: one MultiPolygon Z per building of every LoD 2.2
/// face of its parts, in EPSG:28992, with the building's attributes.
fn delft_as_3d_layer(jsonl: &Path, out: &Path) -> usize {
    let text = std::fs::read_to_string(jsonl).unwrap();
    let mut lines = text.lines();
    let header: Value = serde_json::from_str(lines.next().unwrap()).unwrap();
    let t = &header["transform"];
    let (scale, shift): (Vec<f64>, Vec<f64>) = (
        (0..3).map(|i| t["scale"][i].as_f64().unwrap()).collect(),
        (0..3)
            .map(|i| t["translate"][i].as_f64().unwrap())
            .collect(),
    );
    let wkb = Wkb::default();
    let mut rows = Vec::new();
    for line in lines {
        let f: Value = serde_json::from_str(line).unwrap();
        let verts: Vec<[f64; 3]> = f["vertices"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| std::array::from_fn(|i| v[i].as_f64().unwrap() * scale[i] + shift[i]))
            .collect();
        let id = f["id"].as_str().unwrap();
        let building = &f["CityObjects"][id];
        let mut faces: Vec<Vec<Vec<[f64; 3]>>> = Vec::new();
        for child in building["children"].as_array().into_iter().flatten() {
            let part = &f["CityObjects"][child.as_str().unwrap()];
            for g in part["geometry"].as_array().into_iter().flatten() {
                if g["lod"].as_str() != Some("2.2") || g["type"] != "Solid" {
                    continue;
                }
                for shell in g["boundaries"].as_array().unwrap() {
                    for surface in shell.as_array().unwrap() {
                        faces.push(
                            surface
                                .as_array()
                                .unwrap()
                                .iter()
                                .map(|r| {
                                    let mut ring: Vec<[f64; 3]> = r
                                        .as_array()
                                        .unwrap()
                                        .iter()
                                        .map(|i| verts[i.as_u64().unwrap() as usize])
                                        .collect();
                                    ring.push(ring[0]);
                                    ring
                                })
                                .collect(),
                        );
                    }
                }
            }
        }
        let attrs = &building["attributes"];
        rows.push(Row {
            fid: rows.len() as i64 + 1,
            geometry: Some(blob(
                28992,
                Envelope::Xyz,
                false,
                &wkb.multipolygon_z(&faces),
            )),
            values: vec![
                Sql::Text(id.to_string()),
                attrs["b3_h_maaiveld"].as_f64().map_or(Sql::Null, Sql::Real),
                attrs["b3_h_dak_70p"].as_f64().map_or(Sql::Null, Sql::Real),
            ],
        });
    }
    let n = rows.len();
    let mut l = layer(
        rows,
        vec![
            ("identificatie", "TEXT"),
            ("b3_h_maaiveld", "REAL"),
            ("b3_h_dak_70p", "REAL"),
        ],
    );
    l.table = "lod22_3d".into();
    l.srs_id = 28992;
    write(out, &[Srs::epsg(28992)], &[l]);
    n
}

#[test]
fn delfts_buildings_as_a_3d_layer_ingest_as_their_cityjson_does() {
    let Some(jsonl) = citylod_testdata::shared_data("delft-3dbag/delft.city.jsonl") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let gpkg = dir.path().join("delft3d.gpkg");
    let rows = delft_as_3d_layer(&jsonl, &gpkg);
    let opts = IngestOptions {
        lod: Some(citylod_ingest::LodChoice::Exact("2.2".into())),
        id_attr: Some("identificatie".into()),
        ..Default::default()
    };
    let from_gpkg = ingest(&[gpkg], &opts).unwrap();
    let from_json = ingest(&[jsonl], &opts).unwrap();
    assert!(rows > 1000, "{rows}");
    assert_eq!(from_gpkg.buildings.len(), rows);
    assert_eq!(from_json.buildings.len(), rows);
    assert_eq!(from_gpkg.report.buildings_with_mesh, rows);
    let mut area_off = Vec::new();
    for (a, b) in from_gpkg.buildings.iter().zip(&from_json.buildings) {
        assert_eq!(a.source_id, b.source_id);
        // The same 3DBAG height rule (roof − ground attributes) on both.
        assert!((a.height_m - b.height_m).abs() < 1e-9, "{}", a.source_id);
        // The same faces: as many triangles of each kind, give or take the ones told apart by slope instead of
        // semantics (a few steep roof faces).
        let (ma, mb) = (a.mesh.as_ref().unwrap(), b.mesh.as_ref().unwrap());
        let tris = |m: &citylod_model::BuildingModel| m.mesh.triangles.len() as i64;
        assert!(
            (tris(ma) - tris(mb)).abs() <= 2,
            "{}: {} / {}",
            a.source_id,
            tris(ma),
            tris(mb)
        );
        // The footprint from the floor faces against 3DBAG's LoD0 outline.
        area_off.push((a.area_m2() - b.area_m2()).abs() / b.area_m2());
    }
    area_off.sort_by(f64::total_cmp);
    let median = area_off[area_off.len() / 2];
    assert!(
        median < 0.01,
        "median relative footprint area difference {median}"
    );
}

#[test]
fn heights_of_3d_rows_in_a_crs_in_feet_are_feet() {
    // A 100 ft box 30 ft high in EPSG:2263 (US survey feet), without a vertical CRS: z in feet, as ArcGIS takes it.
    let (x0, y0) = (987_000.0, 201_000.0);
    let ring = vec![
        [x0, y0],
        [x0 + 100.0, y0],
        [x0 + 100.0, y0 + 100.0],
        [x0, y0 + 100.0],
        [x0, y0],
    ];
    let faces = box_faces(&ring, 0.0, 30.0);
    let le = Wkb::default();
    let mut l = layer(
        vec![row(
            1,
            Some(blob(
                2263,
                Envelope::Xyz,
                false,
                &le.polyhedral_surface_z(&faces),
            )),
        )],
        vec![],
    );
    l.srs_id = 2263;
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("feet.gpkg");
    write(&p, &[Srs::epsg(2263)], &[l]);
    let r = ingest(
        &[p],
        &IngestOptions {
            lod: Some(citylod_ingest::LodChoice::Highest),
            ..Default::default()
        },
    )
    .unwrap();
    let ft = 0.3048006096012192;
    let b = &r.buildings[0];
    assert!((b.height_m - 30.0 * ft).abs() < 1e-6, "{}", b.height_m);
    let m = &b.mesh.as_ref().unwrap().mesh;
    let (lo, hi) = m
        .positions
        .iter()
        .fold((f64::MAX, f64::MIN), |(lo, hi), p| {
            (lo.min(p[2]), hi.max(p[2]))
        });
    assert!((hi - lo - 30.0 * ft).abs() < 0.01, "{lo} .. {hi}");
    assert_eq!(
        r.report.files[0].notes,
        vec![format!(
            "the heights (z) of its 1 3D surface model(s) were read in units of {ft} m (its vertical CRS's, else its \
             CRS's linear unit, as ArcGIS takes z without a vertical CRS) and converted to metres"
        )]
    );
}

/// A point `x`, `y` metres east and north of one on the Lower East Side, in UTM zone 18N (EPSG:26918): arcs are
/// circles in the CRS's own coordinates, so a projected CRS in metres keeps the areas simple.
fn at(x: f64, y: f64) -> [f64; 2] {
    [585_000.0 + x, 4_507_000.0 + y]
}

/// A closed `size` m square `x` m east of [`at`]'s point.
fn utm_square(x: f64, size: f64) -> Vec<[f64; 2]> {
    vec![
        at(x, 0.0),
        at(x + size, 0.0),
        at(x + size, size),
        at(x, size),
        at(x, 0.0),
    ]
}

#[test]
fn curved_geometries_are_read_with_their_arcs_as_segments() {
    let le = Wkb::default();
    // A circle of radius 10 m as one CircularString ring (start, opposite point, start): 314 m².
    let circle = le.of_members(
        10,
        &[le.circular_string(&[at(0.0, 0.0), at(20.0, 0.0), at(0.0, 0.0)])],
    );
    // A 20 × 10 m rectangle whose east side bulges out in a half circle, as a CompoundCurve ring: 200 + 39.3 m².
    let d_shape = le.of_members(
        10,
        &[le.of_members(
            9,
            &[
                le.line(&[at(100.0, 0.0), at(120.0, 0.0)]),
                le.circular_string(&[at(120.0, 0.0), at(125.0, 5.0), at(120.0, 10.0)]),
                le.line(&[at(120.0, 10.0), at(100.0, 10.0), at(100.0, 0.0)]),
            ],
        )],
    );
    // A MultiSurface of a plain Polygon and a CurvePolygon with straight rings only: 100 + 100 m², no arcs.
    let straight = le.of_members(
        12,
        &[
            le.polygon(&[utm_square(200.0, 10.0)]),
            le.of_members(10, &[le.line(&utm_square(220.0, 10.0))]),
        ],
    );
    // A collection holding a curve and a MultiCurve beside its polygon: the curves dropped and said.
    let with_curves = le.collection(&[
        le.circular_string(&[at(0.0, 0.0), at(1.0, 1.0), at(2.0, 0.0)]),
        le.of_members(11, &[le.line(&[[0.0, 0.0], [1.0, 1.0]])]),
        le.polygon(&[utm_square(300.0, 10.0)]),
    ]);
    let rows = [circle, d_shape, straight, with_curves]
        .into_iter()
        .enumerate()
        .map(|(i, w)| row(i as i64 + 1, Some(blob(26918, Envelope::Xy, false, &w))))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("curves.gpkg");
    let mut l = layer(rows, vec![]);
    l.srs_id = 26918;
    write(&p, &[Srs::epsg(26918)], &[l]);
    let r = ingest(&[p], &IngestOptions::default()).unwrap();
    assert_eq!(skips(&r), vec![]);
    let areas: Vec<f64> = r.buildings.iter().map(|b| b.area_m2()).collect();
    let pi = std::f64::consts::PI;
    for (got, want) in areas
        .iter()
        .zip([100.0 * pi, 200.0 + 12.5 * pi, 200.0, 100.0])
    {
        // A 4° chord loses (1 − sin 4° / (4° in radians)) ≈ 0.08 % of a circle's area; UTM's scale 0.1 %.
        assert!((got - want).abs() < 0.005 * want, "{areas:?}");
    }
    let repairs: Vec<(String, String, String)> = r
        .report
        .repaired
        .iter()
        .map(|s| {
            (
                s.feature_id.clone(),
                s.reason.as_str().to_string(),
                s.detail.clone(),
            )
        })
        .collect();
    assert_eq!(
        repairs,
        [
            ("curves.gpkg#1", "curves_approximated", "1 circular arc(s) approximated by straight segments of at most 4° of arc"),
            ("curves.gpkg#2", "curves_approximated", "1 circular arc(s) approximated by straight segments of at most 4° of arc"),
            ("curves.gpkg#4", "non_polygon_member_dropped", "2 GeometryCollection member(s) not polygonal, dropped: member 0 (CircularString), member 1 (MultiCurve)"),
        ]
        .map(|(a, b, c)| (a.to_string(), b.to_string(), c.to_string()))
    );
    // The circle has 90 segments of 4°.
    assert_eq!(r.buildings[0].footprint.0[0].exterior().0.len(), 91);
}

#[test]
fn collections_of_the_wrong_members_are_malformed_whatever_their_depth() {
    // A MultiPoint holding a MultiPoint holding …, 50,000 deep, beside a polygon in a collection: the first wrong
    // member ends the reading (it used to recurse until the stack overflowed).
    let le = Wkb::default();
    let mut nested = Vec::new();
    for _ in 0..50_000 {
        nested.push(1u8);
        nested.extend(4u32.to_le_bytes());
        nested.extend(1u32.to_le_bytes());
    }
    nested.extend(le.point([0.0, 0.0]));
    let rows = vec![
        row(
            1,
            Some(blob(
                4326,
                Envelope::Xy,
                false,
                &le.collection(&[le.polygon(&[square(0.0, 10.0)]), nested]),
            )),
        ),
        // Members of nothing: an empty MultiPolygon and an empty collection.
        row(
            2,
            Some(blob(4326, Envelope::None, false, &le.multipolygon(&[]))),
        ),
        row(
            3,
            Some(blob(4326, Envelope::None, false, &le.collection(&[]))),
        ),
        row(
            4,
            Some(blob(
                4326,
                Envelope::None,
                false,
                &le.polygon(&[square(20.0, 10.0)]),
            )),
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let p = one_layer(dir.path(), "deep.gpkg", layer(rows, vec![]));
    let r = ingest(&[p], &IngestOptions::default()).unwrap();
    assert_eq!(r.buildings.len(), 1);
    assert_eq!(
        skips(&r),
        [
            (
                "deep.gpkg#1",
                "malformed_geometry",
                "FID 1: MultiPoint member 0 is a MultiPoint, which a MultiPoint cannot hold"
            ),
            (
                "deep.gpkg#2",
                "empty_geometry",
                "FID 2: a collection without members"
            ),
            (
                "deep.gpkg#3",
                "empty_geometry",
                "FID 3: a collection without members"
            ),
        ]
        .map(|(a, b, c)| (a.to_string(), b.to_string(), c.to_string()))
    );
}

#[test]
fn tables_as_gdal_and_qgis_read_them() {
    let g = square_blob;
    let rows = (0..3)
        .map(|i| Row {
            fid: 10 * (i as i64 + 1),
            geometry: g(i),
            values: vec![Sql::Integer(i as i64 + 2), Sql::Blob(vec![7; 3])],
        })
        .collect();
    let mut l = layer(rows, vec![("levels", "INTEGER"), ("thumb", "BLOB(1000)")]);
    l.table = "Lod12_2D".into();
    l.geometry_column = "geom".into();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("tables.gpkg");
    write(&p, &[], &[l]);
    let db = rusqlite::Connection::open(&p).unwrap();
    db.execute_batch(
        // A generated column (table_info does not list it), the geometry column registered in another case, and a
        // view over the table with its fid, registered as a second layer.
        "ALTER TABLE Lod12_2D ADD COLUMN height REAL GENERATED ALWAYS AS (levels * 3.0) VIRTUAL;
         UPDATE gpkg_geometry_columns SET column_name = 'GEOM';
         CREATE VIEW tall AS SELECT fid, geom, levels FROM Lod12_2D WHERE levels > 2;
         INSERT INTO gpkg_contents (table_name, data_type, identifier, srs_id) VALUES ('tall', 'features', 'tall', 4326);
         INSERT INTO gpkg_geometry_columns VALUES ('tall', 'geom', 'POLYGON', 4326, 0, 0);",
    )
    .unwrap();
    drop(db);
    // The layer named in another case; BLOB(n) left out as BLOB is.
    let r = ingest(std::slice::from_ref(&p), &with_layer("lod12_2d")).unwrap();
    assert_eq!(r.buildings.len(), 3);
    assert_eq!(r.buildings[2].source_id, "tables.gpkg#30");
    assert_eq!(r.buildings[2].attributes["height"], AttrValue::Float(12.0));
    assert_eq!(r.buildings[2].height_m, 12.0);
    assert!(r.buildings[2].attributes.get("thumb").is_none());
    assert!(
        r.report.files[0]
            .notes
            .iter()
            .any(|n| n == "BLOB column(s) not read as attributes: thumb"),
        "{:?}",
        r.report.files[0].notes
    );
    assert!(r.report.repaired.is_empty(), "{:?}", r.report.repaired);
    // --id-attr may name the FID.
    let r = ingest(
        std::slice::from_ref(&p),
        &IngestOptions {
            id_attr: Some("fid".into()),
            ..with_layer("Lod12_2D")
        },
    )
    .unwrap();
    assert_eq!(
        r.buildings
            .iter()
            .map(|b| b.source_id.as_str())
            .collect::<Vec<_>>(),
        ["10", "20", "30"]
    );
    // A view: its rows by their fid column.
    let r = ingest(std::slice::from_ref(&p), &with_layer("tall")).unwrap();
    assert_eq!(
        r.buildings
            .iter()
            .map(|b| b.source_id.as_str())
            .collect::<Vec<_>>(),
        ["tables.gpkg#20", "tables.gpkg#30"]
    );
    // gpkg_geometry_columns spelling the table in another case than gpkg_contents (SQLite's names ignore case): the
    // same table, read.
    let db = rusqlite::Connection::open(&p).unwrap();
    db.execute_batch(
        "UPDATE gpkg_geometry_columns SET table_name = 'LOD12_2d' WHERE table_name = 'Lod12_2D';",
    )
    .unwrap();
    drop(db);
    let r = ingest(std::slice::from_ref(&p), &with_layer("Lod12_2D")).unwrap();
    assert_eq!(r.buildings.len(), 3);
    assert!(
        r.report.files[0]
            .notes
            .iter()
            .all(|n| !n.contains("gpkg_geometry_columns")),
        "{:?}",
        r.report.files[0].notes
    );
}

#[test]
fn a_crs_is_read_from_the_wkt2_definition_and_codes_the_table_lacks_from_their_wkt() {
    let le = Wkb::default();
    let (x0, y0) = (987_000.0, 201_000.0);
    let ft = vec![
        [x0, y0],
        [x0 + 100.0, y0],
        [x0 + 100.0, y0 + 100.0],
        [x0, y0 + 100.0],
        [x0, y0],
    ];
    let dir = tempfile::tempdir().unwrap();
    let make = |name: &str, srs: Srs, wkt2: Option<&str>| {
        let id = srs.srs_id;
        let mut l = layer(
            vec![row(
                1,
                Some(blob(
                    id as i32,
                    Envelope::Xy,
                    false,
                    &le.polygon(std::slice::from_ref(&ft)),
                )),
            )],
            vec![],
        );
        l.srs_id = id;
        let p = dir.path().join(name);
        write(&p, &[srs], &[l]);
        if let Some(w) = wkt2 {
            let db = rusqlite::Connection::open(&p).unwrap();
            db.execute_batch("ALTER TABLE gpkg_spatial_ref_sys ADD COLUMN definition_12_063 TEXT NOT NULL DEFAULT 'undefined';").unwrap();
            db.execute(
                "UPDATE gpkg_spatial_ref_sys SET definition_12_063 = ?1 WHERE srs_id = ?2",
                rusqlite::params![w, id],
            )
            .unwrap();
        }
        ingest(&[p], &IngestOptions::default())
    };
    // Only the WKT 2 column defines it (the WKT 1 definition 'undefined').
    let wkt2 = r#"PROJCRS["NAD83 / New York Long Island (ftUS)",BASEGEOGCRS["NAD83",DATUM["North American Datum 1983",ELLIPSOID["GRS 1980",6378137,298.257222101]]],CONVERSION["SPCS83 New York Long Island zone (US survey foot)",METHOD["Lambert Conic Conformal (2SP)"]],CS[Cartesian,2],ID["EPSG",2263]]"#;
    let custom = |def: &str| Srs {
        srs_id: 100_001,
        organization: "NONE".into(),
        organization_coordsys_id: 100_001,
        definition: def.into(),
    };
    let r = make("wkt2.gpkg", custom("undefined"), Some(wkt2)).unwrap();
    assert_eq!(r.report.files[0].crs, "EPSG:2263");
    // An EPSG code the offline table lacks, with the WKT of one it has.
    let lacking = Srs {
        srs_id: 99_999,
        organization: "EPSG".into(),
        organization_coordsys_id: 99_999,
        definition: ESRI_2263.into(),
    };
    let r = make("lacking.gpkg", lacking, None).unwrap();
    assert_eq!(r.report.files[0].crs, "EPSG:2263");
    assert!(
        r.report.files[0]
            .notes
            .iter()
            .any(|n| n.contains("the spatial reference system's")),
        "{:?}",
        r.report.files[0].notes
    );
    // A custom system with no definition at all.
    let e = make("nodef.gpkg", custom(""), None).unwrap_err();
    assert!(
        e.to_string()
            .contains("srs_id 100001 (NONE 100001) has no definition"),
        "{e}"
    );
}

#[test]
fn curves_that_cannot_be_a_ring_are_malformed_and_leaning_walls_are_walls() {
    let le = Wkb::default();
    // A CompoundCurve whose second part starts 1 m from where the first ends (GDAL refuses it too).
    let gap = le.of_members(
        10,
        &[le.of_members(
            9,
            &[
                le.line(&[at(0.0, 0.0), at(10.0, 0.0), at(10.0, 10.0)]),
                le.line(&[at(11.0, 10.0), at(0.0, 10.0), at(0.0, 0.0)]),
            ],
        )],
    );
    // A CircularString of four points: arcs take three, each from the last one's end.
    let even = le.of_members(
        10,
        &[le.circular_string(&[at(0.0, 0.0), at(5.0, 5.0), at(10.0, 0.0), at(0.0, 0.0)])],
    );
    // 12,000 full circles in one ring: over a million points once the arcs are segments.
    let mut pts = vec![at(0.0, 0.0)];
    for _ in 0..12_000 {
        pts.push(at(2.0, 0.0));
        pts.push(at(0.0, 0.0));
    }
    let many = le.of_members(10, &[le.circular_string(&pts)]);
    // A 10 m box whose walls lean 1 mm over their 9 m, in MultiPolygon Z: still a 3D model, not a flat footprint.
    let s = utm_square(100.0, 10.0);
    let mut faces: Vec<Vec<Vec<[f64; 3]>>> = (0..4)
        .map(|k| {
            let (a, b) = (s[k], s[k + 1]);
            vec![vec![
                [a[0], a[1], 0.0],
                [b[0], b[1], 0.0],
                [b[0] + 0.001, b[1], 9.0],
                [a[0] + 0.001, a[1], 9.0],
                [a[0], a[1], 0.0],
            ]]
        })
        .collect();
    faces.push(vec![s.iter().map(|p| [p[0] + 0.001, p[1], 9.0]).collect()]);
    let rows = vec![
        row(1, Some(blob(26918, Envelope::Xy, false, &gap))),
        row(2, Some(blob(26918, Envelope::Xy, false, &even))),
        row(3, Some(blob(26918, Envelope::Xy, false, &many))),
        row(
            4,
            Some(blob(
                26918,
                Envelope::Xyz,
                false,
                &le.multipolygon_z(&faces),
            )),
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("odd.gpkg");
    let mut l = layer(rows, vec![]);
    l.srs_id = 26918;
    write(&p, &[Srs::epsg(26918)], &[l]);
    let r = ingest(&[p], &IngestOptions::default()).unwrap();
    assert_eq!(
        skips(&r),
        [
            ("odd.gpkg#1", "malformed_geometry", "FID 1: CompoundCurve part 1 does not start where part 0 ends"),
            ("odd.gpkg#2", "malformed_geometry", "FID 2: a CircularString of 4 points (arcs of three, each from the last's end, make an odd count)"),
            ("odd.gpkg#3", "malformed_geometry", "FID 3: circular arcs approximated by over 1000000 points in one geometry"),
        ]
        .map(|(a, b, c)| (a.to_string(), b.to_string(), c.to_string()))
    );
    assert_eq!(r.buildings.len(), 1);
    assert_eq!(r.buildings[0].height_m, 9.0);
    assert!((r.buildings[0].area_m2() - 100.0).abs() < 0.5);
}
