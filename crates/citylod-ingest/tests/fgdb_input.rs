//! Esri File Geodatabase input: the Lower East Side written by GDAL's OpenFileGDB driver (an independent writer) in
//! New York's State Plane in US feet, against the GeoJSON it was written from; geodatabases written by ArcGIS (GDAL's
//! test data) against GDAL's reading of them; and damaged geodatabases, which must give clear errors, never a panic.

use citylod_ingest::{ingest, IngestError, IngestOptions, Ingested, InputFormat, IssueReason};
use citylod_model::AttrValue;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fgdb")
        .join(name)
}

fn read(path: &Path, layer: Option<&str>) -> Result<Ingested, IngestError> {
    let opts = IngestOptions {
        layer: layer.map(str::to_string),
        ..Default::default()
    };
    ingest(&[path.to_path_buf()], &opts)
}

/// (lon°, lat°) of every footprint vertex of a building (closing points left out), sorted.
fn vertices(out: &Ingested, b: &citylod_model::Building) -> Vec<[f64; 2]> {
    let mut v: Vec<[f64; 2]> = b
        .footprint
        .0
        .iter()
        .flat_map(|p| std::iter::once(p.exterior()).chain(p.interiors()))
        .flat_map(|r| r.0[1..].iter())
        .map(|c| {
            let g = out.frame.enu_to_geodetic([c.x, c.y, b.base_z_m]);
            [g[0], g[1]]
        })
        .collect();
    v.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    v
}

/// A copy of a fixture geodatabase in a scratch folder, to damage.
fn scratch_copy(name: &str, tag: &str) -> PathBuf {
    let to = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("citylod-fgdb-{tag}"));
    let _ = std::fs::remove_dir_all(&to);
    let to = to.join(name);
    std::fs::create_dir_all(&to).unwrap();
    for e in std::fs::read_dir(fixture(name)).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
    to
}

#[test]
fn the_lower_east_side_in_state_plane_feet_gives_the_buildings_of_its_geojson() {
    let gdb = read(&fixture("nyc-les-2263.gdb"), None).unwrap();
    let geojson = read(
        &repo_root().join("examples/nyc-les/les_buildings.geojson"),
        None,
    )
    .unwrap();
    let r = &gdb.report;
    r.check_invariants().unwrap();
    assert_eq!(r.files[0].format, InputFormat::FileGeodatabase);
    assert_eq!(r.files[0].crs, "EPSG:2263");
    assert_eq!(r.features_read, 1416);
    assert_eq!(r.features_read, geojson.report.features_read);
    // GDAL wrote OSM's tags with ':' as '_' (building_part, building_levels): the parts rule and heights still apply.
    assert_eq!(r.building_parts, geojson.report.building_parts);
    assert_eq!(r.buildings_written, geojson.report.buildings_written);
    // The geodatabase's rows are numbered from 1 in the GeoJSON's order; ids come from osm_type/osm_id as there.
    let from_gdb: BTreeMap<&str, &citylod_model::Building> = gdb
        .buildings
        .iter()
        .map(|b| (b.source_id.as_str(), b))
        .collect();
    assert_eq!(from_gdb.len(), gdb.buildings.len(), "ids are unique");
    for g in &geojson.buildings {
        let f = from_gdb
            .get(g.source_id.as_str())
            .unwrap_or_else(|| panic!("{} is not read from the geodatabase", g.source_id));
        for (k, v) in g.attributes.iter() {
            let k2 = k.replace(':', "_");
            assert_eq!(f.attributes.get(&k2), Some(v), "{}: {k}", g.source_id);
        }
        assert!(matches!(f.attributes.get("OBJECTID"), Some(AttrValue::Int(n)) if *n >= 1));
        assert_eq!(
            (f.height_m, f.height_source),
            (g.height_m, g.height_source),
            "{}",
            g.source_id
        );
        // Feet on a grid of 1/10,000 ft (GDAL's default resolution), then back to degrees: within 1e-8° (1 mm).
        let (a, b) = (vertices(&gdb, f), vertices(&geojson, g));
        assert_eq!(a.len(), b.len(), "{}", g.source_id);
        for v in &a {
            assert!(
                b.iter()
                    .any(|w| (v[0] - w[0]).abs() < 1e-8 && (v[1] - w[1]).abs() < 1e-8),
                "{}: {v:?} is none of {b:?}",
                g.source_id
            );
        }
        assert_eq!(
            f.footprint
                .0
                .iter()
                .map(|q| q.interiors().len())
                .collect::<Vec<_>>(),
            g.footprint
                .0
                .iter()
                .map(|q| q.interiors().len())
                .collect::<Vec<_>>(),
            "{}",
            g.source_id
        );
    }
    let skipped = |o: &Ingested| {
        let mut v: Vec<(String, IssueReason)> = o
            .report
            .skipped
            .iter()
            .map(|s| (s.feature_id.clone(), s.reason))
            .collect();
        v.sort();
        v
    };
    assert_eq!(skipped(&gdb), skipped(&geojson));
}

/// GDAL's reading of a feature class (`make_fixtures.py`): per row its OBJECTID, attributes and polygons (lon/lat).
#[derive(serde::Deserialize)]
struct Reference {
    objectid: i64,
    attributes: BTreeMap<String, serde_json::Value>,
    polygons: Vec<Vec<Vec<[f64; 2]>>>,
}

fn reference(name: &str) -> Vec<Reference> {
    serde_json::from_str(&std::fs::read_to_string(fixture(name)).unwrap()).unwrap()
}

/// The area of a lon/lat ring in m², on a sphere of the Earth's mean radius (small rings).
fn ring_area_m2(ring: &[[f64; 2]]) -> f64 {
    let lat0 = ring[0][1].to_radians();
    let m = 6_371_008.8_f64.to_radians();
    let xy: Vec<[f64; 2]> = ring
        .iter()
        .map(|p| [p[0] * m * lat0.cos(), p[1] * m])
        .collect();
    let n = xy.len();
    (0..n)
        .map(|i| xy[i][0] * xy[(i + 1) % n][1] - xy[(i + 1) % n][0] * xy[i][1])
        .sum::<f64>()
        .abs()
        / 2.0
}

fn by_objectid(out: &Ingested) -> BTreeMap<i64, &citylod_model::Building> {
    out.buildings
        .iter()
        .map(|b| match b.attributes.get("OBJECTID") {
            Some(AttrValue::Int(n)) => (*n, b),
            other => panic!("{}: OBJECTID {other:?}", b.source_id),
        })
        .collect()
}

#[test]
fn polygons_with_holes_deleted_rows_and_every_field_type_read_as_gdal_reads_them() {
    let out = read(&fixture("kinds.gdb"), Some("blocks")).unwrap();
    let r = &out.report;
    r.check_invariants().unwrap();
    assert_eq!(r.files[0].crs, "EPSG:32618");
    // By the class's WKID in GDB_Items, not by matching its WKT's parameters (which would be said in a note).
    assert!(
        !r.files[0]
            .notes
            .iter()
            .any(|n| n.contains("identified from")),
        "{:?}",
        r.files[0].notes
    );
    // 3,000 rows written, then a whole block of 1,024 OBJECTIDs deleted (the row index leaves it out) and two more.
    let gdal = reference("kinds.blocks.reference.json");
    assert_eq!(gdal.len(), 1974);
    assert_eq!(r.features_read, 1974);
    assert_eq!(r.buildings_written, 1974);
    let ours = by_objectid(&out);
    assert_eq!(
        ours.keys().copied().collect::<Vec<_>>(),
        gdal.iter().map(|g| g.objectid).collect::<Vec<_>>()
    );
    for g in &gdal {
        let b = ours[&g.objectid];
        assert_eq!(b.source_id, format!("kinds.gdb#{}", g.objectid));
        let a = &b.attributes;
        assert_eq!(
            a.get("storeys"),
            Some(&AttrValue::Int(g.attributes["storeys"].as_i64().unwrap()))
        );
        assert_eq!(
            a.get("height"),
            Some(&AttrValue::Float(g.attributes["height"].as_f64().unwrap()))
        );
        match g.attributes["name"].as_str() {
            Some(s) => assert_eq!(a.get("name"), Some(&AttrValue::String(s.into()))),
            None => assert_eq!(a.get("name"), Some(&AttrValue::Null)),
        }
        // Dates as ISO 8601 text; GDAL's has a time zone the field does not store.
        for k in ["built", "surveyed"] {
            match (g.attributes[k].as_str(), a.get(k)) {
                (Some("NaT"), Some(AttrValue::Null)) => {}
                (Some(t), Some(AttrValue::String(s))) => assert_eq!(s, &t[..19], "{k}"),
                (t, s) => panic!("OBJECTID {}: {k} {t:?} against {s:?}", g.objectid),
            }
        }
        // The storeys give the height (3.25 m a storey was written, 3 m taken here): the attribute is read.
        assert_eq!(
            b.height_m,
            3.25 * (g.attributes["storeys"].as_f64().unwrap())
        );
        // Outline and courtyard (every seventh row) as GDAL reads them.
        assert_eq!(b.footprint.0.len(), g.polygons.len());
        assert_eq!(b.footprint.0[0].interiors().len() + 1, g.polygons[0].len());
        let v = vertices(&out, b);
        let w: Vec<[f64; 2]> = g.polygons.iter().flatten().flatten().copied().collect();
        assert_eq!(v.len(), w.len());
        for p in &v {
            assert!(
                w.iter()
                    .any(|q| (p[0] - q[0]).abs() < 1e-9 && (p[1] - q[1]).abs() < 1e-9),
                "OBJECTID {}: {p:?} is none of {w:?}",
                g.objectid
            );
        }
    }
}

#[test]
fn curves_are_followed_in_short_segments() {
    let out = read(&fixture("kinds.gdb"), Some("round")).unwrap();
    let r = &out.report;
    assert_eq!(r.buildings_written, 5);
    let curved: Vec<&str> = r
        .repaired
        .iter()
        .filter(|i| i.reason == IssueReason::CurvesApproximated)
        .map(|i| i.feature_id.as_str())
        .collect();
    assert_eq!(
        curved,
        ["kinds.gdb#1", "kinds.gdb#2", "kinds.gdb#4", "kinds.gdb#5"]
    );
    let ours = by_objectid(&out);
    // A circle of radius 10 m, in 4° steps (a 90-gon: 313.9 m²), GDAL's own linearization within 0.5 %.
    let tower = ours[&1].area_m2();
    let n = 90.0;
    let polygon = 0.5 * n * 100.0 * (std::f64::consts::TAU / n).sin();
    assert!((tower - polygon).abs() < 0.01 * polygon, "{tower}");
    // A 30 m × 30 m room with a half-round apse of radius 15 m: 900 + π·15²/2.
    let apse = ours[&2].area_m2();
    let exact = 900.0 + std::f64::consts::PI * 225.0 / 2.0;
    assert!(
        (apse - exact).abs() < 0.005 * exact,
        "{apse} against {exact}"
    );
    // GDAL's linearization of the same arcs gives the same areas within 1 %.
    let gdal = reference("kinds.round.reference.json");
    for g in gdal.iter().filter(|g| g.objectid <= 2) {
        let ring = &g.polygons[0][0];
        assert!(ring.len() > 30, "GDAL followed the arcs too");
        let ours = ours[&g.objectid].area_m2();
        let theirs = ring_area_m2(ring);
        assert!(
            (ours - theirs).abs() < 0.01 * theirs,
            "{ours} against {theirs}"
        );
    }
    // Full circles, whose points give no direction: a round courtyard in a round building (radii 15 and 5 m), and a
    // square one, stay courtyards.
    let pi = std::f64::consts::PI;
    let k = 1.0006 * (n / std::f64::consts::TAU * (std::f64::consts::TAU / n).sin());
    for (oid, area) in [
        (4, k * pi * (225.0 - 25.0)),
        (5, 1.0006 * (k / 1.0006 * pi * 225.0 - 100.0)),
    ] {
        let b = ours[&oid];
        assert_eq!(b.footprint.0.len(), 1, "OBJECTID {oid}");
        assert_eq!(b.footprint.0[0].interiors().len(), 1, "OBJECTID {oid}");
        assert!(
            (b.area_m2() - area).abs() < 0.002 * area,
            "OBJECTID {oid}: {} against {area}",
            b.area_m2()
        );
    }
    // A plain MultiSurface with a courtyard: 30 × 30 less 15 × 15.
    let plain = ours[&3];
    assert_eq!(plain.footprint.0[0].interiors().len(), 1);
    assert!(
        (plain.area_m2() - 675.0 * 1.0006).abs() < 0.1,
        "{}",
        plain.area_m2()
    );
}

#[test]
fn multipatch_models_stand_on_their_lowest_point_and_reach_their_highest() {
    let out = read(&fixture("kinds.gdb"), Some("models")).unwrap();
    let ours = by_objectid(&out);
    assert_eq!(ours.len(), 3);
    // Two closed boxes and a tent of two triangles (written by GDAL as MultiPatch triangle or ring parts). Areas in
    // UTM's metres, which are 0.03 % longer than true ones here (its scale factor, about 1.0003).
    for (oid, area, height) in [(1, 100.0, 21.0), (2, 256.0, 45.5), (3, 60.0, 12.0)] {
        let b = ours[&oid];
        assert!(
            (b.area_m2() - area * 1.0006).abs() < 2e-4 * area,
            "{oid}: {}",
            b.area_m2()
        );
        assert!((b.height_m - height).abs() < 1e-3, "{oid}: {}", b.height_m);
    }
    // With --lod, the faces are the model.
    let opts = IngestOptions {
        layer: Some("models".into()),
        lod: Some(citylod_ingest::LodChoice::Highest),
        ..Default::default()
    };
    let out = ingest(&[fixture("kinds.gdb")], &opts).unwrap();
    assert!(out.buildings.iter().all(|b| b.mesh.is_some()));
}

#[test]
fn polygons_with_z_in_a_multipatch_layer_are_models() {
    // GDAL's CREATE_MULTIPATCH=YES writes a box's six faces as one polygon with z: walls included, standing at 5 m.
    let out = read(&fixture("kinds.gdb"), Some("walls")).unwrap();
    let r = &out.report;
    assert_eq!(r.buildings_written, 1);
    assert!(r.repaired.is_empty(), "{:?}", r.repaired);
    let b = &out.buildings[0];
    assert!((b.height_m - 12.0).abs() < 1e-6, "{}", b.height_m);
    assert!(
        (b.area_m2() - 100.0 * 1.0006).abs() < 0.05,
        "{}",
        b.area_m2()
    );
    assert_eq!(r.ground_sources.get("geometry"), Some(&1));
}

#[test]
fn arcgis_pro_3_2_tables_with_big_integers_dates_and_times() {
    let out = read(&fixture("pro32.gdb"), None).unwrap();
    let gdal = reference("pro32.buildings.reference.json");
    let ours = by_objectid(&out);
    assert_eq!(ours.len(), gdal.len());
    for g in &gdal {
        let a = &ours[&g.objectid].attributes;
        assert_eq!(
            a.get("bin"),
            Some(&AttrValue::Int(g.attributes["bin"].as_i64().unwrap()))
        );
        assert_eq!(
            a.get("bin"),
            Some(&AttrValue::Int(999_999_999_999 + g.objectid))
        );
        let text = |k: &str| match a.get(k) {
            Some(AttrValue::String(s)) => s.clone(),
            other => panic!("{k}: {other:?}"),
        };
        assert_eq!(
            text("opened"),
            g.attributes["opened"].as_str().unwrap()[..10]
        );
        assert_eq!(text("closes"), g.attributes["closes"].as_str().unwrap());
        assert_eq!(text("stamp"), g.attributes["stamp"].as_str().unwrap());
    }
}

#[test]
fn a_feature_class_without_a_spatial_reference_asks_for_crs() {
    let err = read(&fixture("no-crs.gdb"), None).unwrap_err();
    assert!(
        matches!(err, IngestError::FileGdbWithoutCrs { .. }),
        "{err}"
    );
    let opts = IngestOptions {
        crs: Some("EPSG:32618".into()),
        ..Default::default()
    };
    let out = ingest(&[fixture("no-crs.gdb")], &opts).unwrap();
    assert_eq!(out.buildings.len(), 1);
    assert_eq!(
        out.buildings[0].height_m, 10.0,
        "no height attribute it knows: the default"
    );
}

#[test]
fn layers_are_chosen_by_name_and_wrong_names_list_the_feature_classes() {
    let err = read(&fixture("kinds.gdb"), None).unwrap_err().to_string();
    assert!(
        err.contains(
            "it holds 4 polygon or MultiPatch feature classes, blocks (polygons), round (polygons), models \
             (MultiPatch), walls (MultiPatch); name the one to read with --layer (it also holds roads (lines), \
             not read as buildings)"
        ),
        "{err}"
    );
    let err = read(&fixture("kinds.gdb"), Some("owners"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("\"owners\" is a table without geometry"),
        "{err}"
    );
    let err = read(&fixture("kinds.gdb"), Some("nowhere"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("no feature class \"nowhere\""), "{err}");
    // ArcGIS's names are case-insensitive.
    assert_eq!(
        read(&fixture("kinds.gdb"), Some("ROUND"))
            .unwrap()
            .buildings
            .len(),
        5
    );
    // A class of lines is refused at once, saying what buildings are.
    let err = read(&fixture("kinds.gdb"), Some("roads"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("feature class \"roads\" holds lines; buildings are polygons or MultiPatch"),
        "{err}"
    );
    // A class in a feature dataset may be named with it, as ArcGIS shows it.
    assert_eq!(
        read(&fixture("kinds.gdb"), Some("Buildings/round"))
            .unwrap()
            .buildings
            .len(),
        5
    );
    assert_eq!(
        read(&fixture("kinds.gdb"), Some("Buildings\\round"))
            .unwrap()
            .buildings
            .len(),
        5
    );
    // A system table.
    let err = read(&fixture("kinds.gdb"), Some("GDB_Items"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("one of the geodatabase's system tables"),
        "{err}"
    );
    // One of the geodatabase's files given instead of its folder.
    let member = fixture("kinds.gdb").join("a00000001.gdbtable");
    let err = read(&member, None).unwrap_err().to_string();
    assert!(err.contains("give the .gdb folder"), "{err}");
    // A folder named .gdb that is not one.
    let empty = Path::new(env!("CARGO_TARGET_TMPDIR")).join("citylod-fgdb-empty.gdb");
    let _ = std::fs::remove_dir_all(&empty);
    std::fs::create_dir_all(&empty).unwrap();
    let err = read(&empty, None).unwrap_err().to_string();
    assert!(
        err.contains("holds its catalog table a00000001.gdbtable"),
        "{err}"
    );
}

#[test]
fn damaged_geodatabases_are_refused_with_what_is_wrong() {
    // The catalog cut short.
    let gdb = scratch_copy("no-crs.gdb", "cut-catalog");
    let catalog = gdb.join("a00000001.gdbtable");
    let bytes = std::fs::read(&catalog).unwrap();
    std::fs::write(&catalog, &bytes[..bytes.len() / 2]).unwrap();
    let err = read(&gdb, None).unwrap_err().to_string();
    assert!(
        err.contains("File Geodatabase: its catalog a00000001.gdbtable"),
        "{err}"
    );
    // The feature class's row index gone: the class cannot be read, and the error says which file is missing.
    let gdb = scratch_copy("no-crs.gdb", "no-tablx");
    std::fs::remove_file(gdb.join("a00000009.gdbtablx")).unwrap();
    let err = read(&gdb, None).unwrap_err().to_string();
    assert!(
        err.contains("feature class \"footprints\" (a00000009.gdbtable): cannot read its row index: cannot read a00000009.gdbtablx"),
        "{err}"
    );
    // A table ArcGIS compressed: refused by name, with what to do.
    let gdb = scratch_copy("no-crs.gdb", "compressed");
    std::fs::write(gdb.join("a00000009.cdf"), b"").unwrap();
    let err = read(&gdb, Some("footprints")).unwrap_err().to_string();
    assert!(
        err.contains("feature class \"footprints\" cannot be read: a compressed table")
            && err.contains("Uncompress File Geodatabase Data"),
        "{err}"
    );
    // A sparse row index without its trailer (whose bitmap says which blocks are stored): refused, not read as if
    // every block were there (which would give rows the wrong OBJECTIDs).
    let gdb = scratch_copy("sparse.gdb", "no-trailer");
    let tablx = gdb.join("a00000009.gdbtablx");
    let x = std::fs::read(&tablx).unwrap();
    std::fs::write(&tablx, &x[..16 + 4 * 1024 * 5]).unwrap();
    let err = read(&gdb, None).unwrap_err().to_string();
    assert!(
        err.contains("its row index (.gdbtablx) is cut short"),
        "{err}"
    );
    // A row index pointing past the end of the table: that row's error names it.
    let gdb = scratch_copy("no-crs.gdb", "bad-offset");
    let tablx = gdb.join("a00000009.gdbtablx");
    let mut x = std::fs::read(&tablx).unwrap();
    x[16..20].copy_from_slice(&0x7fff_fff0u32.to_le_bytes());
    std::fs::write(&tablx, &x).unwrap();
    let opts = IngestOptions {
        crs: Some("EPSG:32618".into()),
        ..Default::default()
    };
    // The row is listed as skipped, with what is wrong; the others would be read.
    let out = ingest(&[gdb], &opts).unwrap();
    let skipped = &out.report.skipped[0];
    assert_eq!(skipped.reason, IssueReason::UnreadableRow);
    assert_eq!(
        skipped.detail,
        "OBJECTID 1: the row cannot be read: its offset lies past the end of the table"
    );
    // A row index that lost a row's offset (the table's header still counts it live): the rows it locates are read
    // and the one it cannot is said, not lost silently.
    let whole = read(&fixture("nyc-les-2263.gdb"), None).unwrap();
    let gdb = scratch_copy("nyc-les-2263.gdb", "lost-offset");
    let tablx = gdb.join("a00000009.gdbtablx");
    let mut x = std::fs::read(&tablx).unwrap();
    let size = u32::from_le_bytes(x[12..16].try_into().unwrap()) as usize;
    x[16..16 + size].fill(0);
    std::fs::write(&tablx, &x).unwrap();
    let out = read(&gdb, None).unwrap();
    let live = whole.buildings.len() + whole.report.skipped.len();
    assert_eq!(out.buildings.len() + out.report.skipped.len(), live - 1);
    let said = format!(
        "its header counts {live} live rows but its row index (.gdbtablx) locates {}: 1 row not found, not read.",
        live - 1
    );
    assert!(
        out.report.files[0].notes.iter().any(|n| n.contains(&said)),
        "{:?}",
        out.report.files[0].notes
    );
}

#[test]
fn zipped_geodatabases_read_as_their_folders() {
    // As downloaded: Buildings.gdb.zip with the folder at the top, deflated (written by Python's zipfile).
    let folder = read(&fixture("nyc-les-2263.gdb"), None).unwrap();
    let zipped = read(&fixture("nyc-les-2263.gdb.zip"), None).unwrap();
    assert_eq!(zipped.buildings.len(), folder.buildings.len());
    for (a, b) in zipped.buildings.iter().zip(&folder.buildings) {
        assert_eq!(a.source_id, b.source_id);
        assert_eq!(a.attributes, b.attributes);
        assert_eq!(a.footprint, b.footprint);
        assert_eq!(a.height_m, b.height_m);
    }
    let issues = |o: &Ingested| {
        o.report
            .skipped
            .iter()
            .map(|i| (i.feature_id.clone(), i.reason, i.detail.clone()))
            .collect::<Vec<_>>()
    };
    assert_eq!(issues(&zipped), issues(&folder));
    assert_eq!(zipped.report.files[0].format, InputFormat::FileGeodatabase);
    // Stored, deeper in the archive, with ZIP64 records; ids take the geodatabase's name.
    let opts = IngestOptions {
        crs: Some("EPSG:32618".into()),
        ..Default::default()
    };
    let nested = ingest(&[fixture("nested-zip64.zip")], &opts).unwrap();
    assert_eq!(nested.buildings.len(), 1);
    assert_eq!(nested.buildings[0].source_id, "Footprints.gdb#1");
    // Two geodatabases, or none.
    let err = read(&fixture("two.zip"), None).unwrap_err().to_string();
    assert!(
        err.contains("a ZIP archive holding 2 File Geodatabases (a.gdb, b.gdb)"),
        "{err}"
    );
    let err = read(&fixture("none.zip"), None).unwrap_err().to_string();
    assert!(
        err.contains("a ZIP archive without a File Geodatabase in it"),
        "{err}"
    );
}

#[test]
fn damaged_zip_archives_say_so() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("citylod-fgdb-zips");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let bytes = std::fs::read(fixture("nyc-les-2263.gdb.zip")).unwrap();
    // A byte changed inside the deflated data of the first member (the catalog, after its 30-byte local header and
    // name): inflating fails or the CRC-32 does not match.
    let mut bad = bytes.clone();
    let name_len = u16::from_le_bytes([bad[26], bad[27]]) as usize;
    bad[30 + name_len + 20] ^= 0x55;
    let p = dir.join("flipped.gdb.zip");
    std::fs::write(&p, &bad).unwrap();
    let err = read(&p, None).unwrap_err().to_string();
    assert!(
        err.contains("the archive is damaged")
            || err.contains("cannot be inflated")
            || err.contains("inflates to"),
        "{err}"
    );
    // Cut short: the central directory at the end is gone.
    let p = dir.join("cut.gdb.zip");
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    let err = read(&p, None).unwrap_err().to_string();
    assert!(err.contains("a ZIP archive cut short"), "{err}");
    // Cut anywhere, or a byte changed anywhere: an error or a result, never a panic.
    for k in (0..bytes.len()).step_by(997) {
        std::fs::write(&p, &bytes[..k]).unwrap();
        let _ = read(&p, None);
        let mut m = bytes.clone();
        m[k] = m[k].wrapping_add(0x3b);
        std::fs::write(&p, &m).unwrap();
        let _ = read(&p, None);
    }
}

#[test]
fn a_row_index_with_whole_blocks_missing_gives_every_row_its_objectid() {
    // OBJECTIDs 1-100, 2049-2100, 5000 and 70000: the row index holds 4 of 69 blocks of 1,024, and a bitmap of them.
    let x = std::fs::read(fixture("sparse.gdb/a00000009.gdbtablx")).unwrap();
    assert_eq!(
        u32::from_le_bytes(x[4..8].try_into().unwrap()),
        4,
        "blocks stored"
    );
    let out = read(&fixture("sparse.gdb"), None).unwrap();
    let gdal = reference("sparse.footprints.reference.json");
    let ours = by_objectid(&out);
    assert_eq!(
        ours.keys().copied().collect::<Vec<_>>(),
        gdal.iter().map(|g| g.objectid).collect::<Vec<_>>()
    );
    assert_eq!(ours.len(), 154);
    for g in &gdal {
        let b = ours[&g.objectid];
        assert_eq!(b.height_m, g.attributes["height"].as_f64().unwrap());
        let v = vertices(&out, b);
        let w: Vec<[f64; 2]> = g.polygons.iter().flatten().flatten().copied().collect();
        assert!(v.iter().all(|p| w
            .iter()
            .any(|q| (p[0] - q[0]).abs() < 1e-9 && (p[1] - q[1]).abs() < 1e-9)));
    }
}

#[test]
fn thousands_of_rows_over_several_blocks_with_deleted_rows_and_nulls() {
    use citylod_testdata::fgdb::{write_gdb, GdbOptions, Row};
    // 2,500 squares (three blocks of the row index), every 11th with a courtyard, every 13th without a height, every
    // 17th without a name; rows 1,024 to 1,030 and 2,500 deleted.
    let rows: Vec<Row> = (0..2500)
        .map(|k| {
            let (x, y) = (
                583_000.0 + (k % 50) as f64 * 20.0,
                4_507_000.0 + (k / 50) as f64 * 20.0,
            );
            // Outer ring clockwise, hole counter-clockwise, both closed, as Esri writes them.
            let mut rings = vec![vec![
                [x, y],
                [x, y + 12.0],
                [x + 12.0, y + 12.0],
                [x + 12.0, y],
                [x, y],
            ]];
            if k % 11 == 0 {
                rings.push(vec![
                    [x + 3.0, y + 3.0],
                    [x + 9.0, y + 3.0],
                    [x + 9.0, y + 9.0],
                    [x + 3.0, y + 9.0],
                    [x + 3.0, y + 3.0],
                ]);
            }
            Row {
                rings,
                height: (k % 13 != 0).then_some(4.0 + (k % 7) as f64),
                name: (k % 17 != 0).then(|| format!("bâtiment {k}")),
            }
        })
        .collect();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("citylod-fgdb-written.gdb");
    let _ = std::fs::remove_dir_all(&dir);
    let deleted: Vec<u64> = (1024..=1030).chain([2500]).collect();
    write_gdb(
        &dir,
        "squares",
        &rows,
        &GdbOptions {
            deleted: deleted.clone(),
            ..Default::default()
        },
    )
    .unwrap();
    let opts = IngestOptions {
        crs: Some("EPSG:32618".into()),
        ..Default::default()
    };
    let out = ingest(&[dir], &opts).unwrap();
    let ours = by_objectid(&out);
    assert_eq!(ours.len(), 2500 - deleted.len());
    for (k, row) in rows.iter().enumerate() {
        let oid = k as i64 + 1;
        if deleted.contains(&(oid as u64)) {
            assert!(!ours.contains_key(&oid));
            continue;
        }
        let b = ours[&oid];
        assert_eq!(b.height_m, row.height.unwrap_or(10.0), "OBJECTID {oid}");
        assert_eq!(
            b.attributes.get("name"),
            Some(&row.name.clone().map_or(AttrValue::Null, AttrValue::String))
        );
        let holes = b.footprint.0[0].interiors().len();
        assert_eq!(holes, usize::from(k % 11 == 0), "OBJECTID {oid}");
        let area = if k % 11 == 0 { 144.0 - 36.0 } else { 144.0 };
        assert!(
            (b.area_m2() - area * 1.0006).abs() < 0.05,
            "OBJECTID {oid}: {}",
            b.area_m2()
        );
    }
}

#[test]
fn heights_in_feet_are_read_in_feet_when_asked_and_the_report_says_when_to_ask() {
    let mut opts = IngestOptions {
        height_attr: Some("height_ft".into()),
        ..Default::default()
    };
    let out = ingest(&[fixture("pro32.gdb")], &opts).unwrap();
    assert_eq!(out.buildings[0].height_m, 100.0);
    assert!(
        out.report.files[0].notes.iter().any(|n| n
            .contains("height attribute \"height_ft\" was read in metres")
            && n.contains("--height-unit ft")),
        "{:?}",
        out.report.files[0].notes
    );
    opts.height_unit_m = Some(0.3048);
    let out = ingest(&[fixture("pro32.gdb")], &opts).unwrap();
    assert!((out.buildings[0].height_m - 30.48).abs() < 1e-9);
    assert!(!out.report.files[0]
        .notes
        .iter()
        .any(|n| n.contains("--height-unit")));
}

#[test]
fn names_with_characters_beyond_ascii_are_feature_class_names_like_any_other() {
    use citylod_testdata::fgdb::{write_gdb, GdbOptions, Row};
    // "GD€…": a name whose fourth byte is inside a character (the system tables' prefix test once sliced it).
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("citylod-fgdb-names.gdb");
    let _ = std::fs::remove_dir_all(&dir);
    let row = Row {
        rings: vec![vec![
            [0.0, 0.0],
            [0.0, 10.0],
            [10.0, 10.0],
            [10.0, 0.0],
            [0.0, 0.0],
        ]],
        height: Some(7.0),
        name: Some("Gebäude".into()),
    };
    write_gdb(
        &dir,
        "GD€_Gebäude",
        std::slice::from_ref(&row),
        &GdbOptions::default(),
    )
    .unwrap();
    let opts = IngestOptions {
        crs: Some("EPSG:32618".into()),
        layer: Some("gd€_gebäude".into()),
        ..Default::default()
    };
    let out = ingest(&[dir], &opts).unwrap();
    assert_eq!(out.buildings.len(), 1);
    assert_eq!(out.buildings[0].height_m, 7.0);
}

#[test]
fn feature_datasets_are_shown_and_named_as_arcgis_shows_them() {
    let err = read(&fixture("datasets.gdb"), None)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(
            "Buildings/Footprints (polygons), Buildings/Towers (polygons), Parcels (polygons)"
        ),
        "{err}"
    );
    let err = read(&fixture("datasets.gdb"), Some("buildings"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(
            "\"buildings\" is a feature dataset holding Footprints (polygons), Towers (polygons)"
        ),
        "{err}"
    );
    for name in ["Towers", "Buildings/Towers", "Buildings\\Towers"] {
        let out = read(&fixture("datasets.gdb"), Some(name)).unwrap();
        assert_eq!(out.buildings.len(), 1, "{name}");
        assert_eq!(out.report.files[0].crs, "EPSG:2263");
        assert!(out.report.files[0].notes[0].starts_with("read feature class \"Towers\""));
    }
}

#[test]
fn coded_values_get_their_descriptions_beside_their_codes() {
    let out = read(&fixture("domains.gdb"), None).unwrap();
    let ours = by_objectid(&out);
    let text = |oid: i64, k: &str| ours[&oid].attributes.get(k).cloned();
    let s = |t: &str| Some(AttrValue::String(t.into()));
    // Codes stay as stored; the description of a known code is added as FIELD_description.
    assert_eq!(text(1, "use"), Some(AttrValue::Int(1)));
    assert_eq!(text(1, "use_description"), s("Residential"));
    assert_eq!(text(2, "use_description"), s("Commercial"));
    assert_eq!(text(2, "status_description"), s("Demolished"));
    assert_eq!(text(3, "use_description"), s("Industrial"));
    // Null, and codes the domain does not list, get none.
    assert_eq!(text(4, "use"), Some(AttrValue::Null));
    assert_eq!(text(4, "use_description"), None);
    assert_eq!(text(5, "use"), Some(AttrValue::Int(9)));
    assert_eq!(text(5, "use_description"), None);
    assert_eq!(text(5, "status_description"), None);
    assert!(out.report.files[0]
        .notes
        .iter()
        .any(|n| n.contains("coded values (use, status)")));
}
