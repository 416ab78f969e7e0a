//! GeoParquet input. On files written by an independent writer (pyarrow, `tools/geoparquet_fixtures.py`) in the shape
//! of Overture Maps' buildings: WKB in lon/lat ingests into the buildings the same features give as GeoJSON, and
//! GeoArrow's native encoding in UTM into the same buildings again, and the roads in GeoArrow's line encodings into the
//! streets their GeoJSON gives. On files written here with the parquet crate's
//! writer: plain Parquet with a WKB column, a CRS the file leaves unknown, encodings that are no footprints, rows
//! that are not buildings, lines for `--streets`, and damaged files that give errors, never a panic.

use citylod_ingest::{
    ingest, read_streets, IngestError, IngestOptions, Ingested, InputFormat, IssueReason,
};
use citylod_model::{AttrValue, LocalFrame};
use citylod_testdata::geopackage::Wkb;
use parquet::data_type::{ByteArray, ByteArrayType};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/geoparquet")
        .join(name)
}

/// A scratch folder under the build's own temporary folder (target/tmp), emptied first: one per test name, so
/// repeated runs leave nothing behind in the system's /tmp.
fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("citylod-gpq-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn read(path: &Path) -> Result<Ingested, IngestError> {
    ingest(&[path.to_path_buf()], &IngestOptions::default())
}

/// (source id, lon/lat of every footprint vertex, base, height) of every building, in order.
type Seen = Vec<(String, Vec<[f64; 2]>, f64, f64)>;

fn seen(o: &Ingested) -> Seen {
    o.buildings
        .iter()
        .map(|b| {
            let v = b
                .footprint
                .0
                .iter()
                .flat_map(|p| std::iter::once(p.exterior()).chain(p.interiors()))
                .flat_map(|r| r.0.iter())
                .map(|c| {
                    let g = o.frame.enu_to_geodetic([c.x, c.y, b.base_z_m]);
                    [g[0], g[1]]
                })
                .collect();
            (b.source_id.clone(), v, b.base_z_m, b.height_m)
        })
        .collect()
}

fn skips(o: &Ingested) -> Vec<(String, IssueReason)> {
    o.report
        .skipped
        .iter()
        .map(|s| (s.feature_id.clone(), s.reason))
        .collect()
}

#[test]
fn overture_shaped_geoparquet_gives_the_buildings_of_its_geojson() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let geojson = read(&root.join("examples/nyc-les/les_buildings.geojson")).unwrap();
    let gpq = read(&fixture("les_overture.parquet")).unwrap();
    let file = &gpq.report.files[0];
    assert_eq!(file.format, InputFormat::GeoParquet);
    assert_eq!((file.features_read, file.buildings_written), (1416, 1403));
    // The same buildings: ids, outlines to the bit, bases and heights; the same 13 outlines drawn by their parts.
    assert_eq!(gpq.frame, geojson.frame);
    let (a, b) = (seen(&gpq), seen(&geojson));
    assert_eq!(a.len(), b.len());
    if let Some((x, y)) = a.iter().zip(&b).find(|(x, y)| x != y) {
        panic!("{x:?}\nagainst\n{y:?}");
    }
    assert_eq!(skips(&gpq), skips(&geojson));
    assert_eq!(skips(&gpq).len(), 13);
    // Overture's columns: a struct's fields flattened, a list of structs as JSON text, integers as integers; the
    // bbox covering is not an attribute (a note says so).
    let holiday = gpq
        .buildings
        .iter()
        .find(|b| b.source_id == "way/110")
        .unwrap();
    let a = &holiday.attributes;
    assert_eq!(
        a.get("names.primary"),
        Some(&AttrValue::String("Holiday Inn".into()))
    );
    assert_eq!(
        a.get("names.common"),
        Some(&AttrValue::String(r#"{"en":"Holiday Inn"}"#.into()))
    );
    assert_eq!(a.get("num_floors"), Some(&AttrValue::Int(8)));
    assert_eq!(a.get("height"), Some(&AttrValue::Float(28.0)));
    assert_eq!(holiday.height_m, 28.0);
    let Some(AttrValue::String(sources)) = a.get("sources") else {
        panic!("{:?}", a.get("sources"));
    };
    let sources: serde_json::Value = serde_json::from_str(sources).unwrap();
    assert_eq!(sources[0]["dataset"], "OpenStreetMap");
    assert_eq!(sources[0]["record_id"], "w110@1");
    assert!(sources[0]["confidence"].is_null());
    assert!(a.iter().all(|(k, _)| !k.starts_with("bbox")), "{a:?}");
    assert!(
        file.notes.iter().any(|n| n.contains("\"bbox\"")),
        "{:?}",
        file.notes
    );
    // `min_height` raises a part's base, as from the GeoJSON's tag.
    assert!(gpq.buildings.iter().any(|b| b.base_z_m > 0.0));
    // Overture's roof_shape, roof_height (OSM's tags as GDAL launders their names): with --lod 2 the same roofs.
    let lod2 = IngestOptions {
        lod: Some("2".parse().unwrap()),
        ..Default::default()
    };
    let roofs = |p: &Path| -> Vec<(String, usize)> {
        ingest(&[p.to_path_buf()], &lod2)
            .unwrap()
            .buildings
            .iter()
            .filter_map(|b| Some((b.source_id.clone(), b.mesh.as_ref()?.mesh.triangles.len())))
            .collect()
    };
    let from_gpq = roofs(&fixture("les_overture.parquet"));
    assert_eq!(
        from_gpq.len(),
        26,
        "17 gabled, 4 onion, 3 skillion, a pyramid, a dome"
    );
    assert_eq!(
        from_gpq,
        roofs(&root.join("examples/nyc-les/les_buildings.geojson"))
    );
}

#[test]
fn geoarrow_native_polygons_in_utm_give_the_same_buildings() {
    let wkb = read(&fixture("les_overture.parquet")).unwrap();
    let native = read(&fixture("les_utm_native.parquet")).unwrap();
    assert_eq!(native.report.files[0].crs, "EPSG:32618");
    assert_eq!(skips(&native), skips(&wkb));
    let (a, b) = (seen(&native), seen(&wkb));
    assert_eq!(a.len(), b.len());
    for ((ida, va, basea, ha), (idb, vb, baseb, hb)) in a.iter().zip(&b) {
        assert_eq!((ida, ha), (idb, hb));
        // The base in the local frame (its curvature below the frame's origin), whose origin differs by the round
        // trip's millimetres.
        assert!(
            (basea - baseb).abs() < 1e-6,
            "{ida}: {basea} against {baseb}"
        );
        assert_eq!(va.len(), vb.len(), "{ida}");
        // Projected by pyproj, back by citylod: within 1e-8° (~1 mm).
        for (p, q) in va.iter().zip(vb) {
            assert!(
                (p[0] - q[0]).abs() < 1e-8 && (p[1] - q[1]).abs() < 1e-8,
                "{ida}: {p:?} against {q:?}"
            );
        }
    }
}

/// Writes a Parquet file of two binary columns, `column` (the geometries) and `name` (UTF-8 text), with `geo` as its
/// GeoParquet metadata when given, in row groups of `per_group` rows.
fn write_parquet(
    path: &Path,
    geo: Option<&str>,
    column: &str,
    rows: &[(Vec<u8>, &str)],
    per_group: usize,
) {
    let rows: Vec<(Vec<u8>, Vec<Option<&str>>)> = rows
        .iter()
        .map(|r| (r.0.clone(), vec![Some(r.1)]))
        .collect();
    write_parquet_texts(path, geo, column, &["name"], &rows, per_group);
}

/// Writes a Parquet file of a binary column `column` (the geometries; an empty one as null) and optional UTF-8 text
/// columns `texts`, with `geo` as its GeoParquet metadata when given, in row groups of `per_group` rows.
fn write_parquet_texts(
    path: &Path,
    geo: Option<&str>,
    column: &str,
    texts: &[&str],
    rows: &[(Vec<u8>, Vec<Option<&str>>)],
    per_group: usize,
) {
    let fields: String = texts
        .iter()
        .map(|t| format!(" optional binary {t} (UTF8);"))
        .collect();
    let schema = Arc::new(
        parquet::schema::parser::parse_message_type(&format!(
            "message m {{ optional binary {column};{fields} }}"
        ))
        .unwrap(),
    );
    let props = WriterProperties::builder()
        .set_key_value_metadata(geo.map(|g| vec![KeyValue::new("geo".into(), g.to_string())]))
        .build();
    let mut w = SerializedFileWriter::new(
        std::fs::File::create(path).unwrap(),
        schema,
        Arc::new(props),
    )
    .unwrap();
    for group in rows.chunks(per_group) {
        let mut rg = w.next_row_group().unwrap();
        let mut index = 0;
        while let Some(mut col) = rg.next_column().unwrap() {
            let cells: Vec<Option<Vec<u8>>> = group
                .iter()
                .map(|r| {
                    if index == 0 {
                        Some(r.0.clone()).filter(|g| !g.is_empty())
                    } else {
                        r.1[index - 1].map(|t| t.as_bytes().to_vec())
                    }
                })
                .collect();
            let values: Vec<ByteArray> = cells
                .iter()
                .flatten()
                .map(|c| ByteArray::from(c.clone()))
                .collect();
            let levels: Vec<i16> = cells.iter().map(|c| i16::from(c.is_some())).collect();
            col.typed::<ByteArrayType>()
                .write_batch(&values, Some(&levels), None)
                .unwrap();
            col.close().unwrap();
            index += 1;
        }
        rg.close().unwrap();
    }
    w.close().unwrap();
}

fn square(x: f64, y: f64, d: f64) -> Vec<[f64; 2]> {
    vec![[x, y], [x + d, y], [x + d, y + d], [x, y + d], [x, y]]
}

fn geo(column: &str, encoding: &str, crs: &str) -> String {
    format!(
        r#"{{"version": "1.0.0", "primary_column": "{column}", "columns": {{"{column}": {{"encoding": "{encoding}"{crs}}}}}}}"#
    )
}

#[test]
fn rows_that_are_not_buildings_are_skipped_with_their_row_and_reason() {
    let dir = scratch("rows");
    let w = Wkb::default();
    let be = Wkb {
        little_endian: false,
        ewkb_z: true,
    };
    let rows = vec![
        (w.polygon(&[square(4.35, 52.0, 0.0002)]), "square"),
        (
            be.multipolygon(&[vec![square(4.351, 52.0, 0.0002)]]),
            "big-endian",
        ),
        (Vec::new(), "null"),
        (w.line(&[[4.35, 52.001], [4.351, 52.001]]), "a line"),
        (vec![1, 3, 0], "cut"),
        (w.point([4.35, 52.0]), "a point"),
    ];
    let p = dir.join("rows.parquet");
    write_parquet(&p, Some(&geo("geometry", "WKB", "")), "geometry", &rows, 4);
    let out = read(&p).unwrap();
    assert_eq!(out.report.files[0].crs, "WGS84 lon/lat");
    let names: Vec<_> = out
        .buildings
        .iter()
        .map(|b| b.attributes.get("name").cloned())
        .collect();
    assert_eq!(
        names,
        [
            Some(AttrValue::String("square".into())),
            Some(AttrValue::String("big-endian".into()))
        ]
    );
    assert_eq!(out.buildings[0].source_id, "rows.parquet#0");
    let got: Vec<(String, IssueReason)> = skips(&out);
    assert_eq!(
        got,
        [
            ("rows.parquet#2".into(), IssueReason::NoGeometry),
            ("rows.parquet#3".into(), IssueReason::UnsupportedGeometry),
            ("rows.parquet#4".into(), IssueReason::MalformedGeometry),
            ("rows.parquet#5".into(), IssueReason::UnsupportedGeometry),
        ]
    );
    assert!(out.report.skipped[0].detail.starts_with("row 2:"));
    // The line is a street for --streets.
    let frame = LocalFrame::new(4.35, 52.0, 0.0);
    let s = read_streets(&p, None, None, None, &frame).unwrap();
    assert_eq!((s.report.features_read, s.report.features_used), (6, 1));
    let expected = 0.001 * 111_320.0 * 52.001f64.to_radians().cos();
    assert!(
        (s.report.length_m - expected).abs() < 0.5,
        "{}",
        s.report.length_m
    );
}

/// Street centre lines in GeoArrow's native `linestring` (interleaved coordinates) and `multilinestring` ({x, y}
/// structs) encodings, written by pyarrow from the Lower East Side's roads, give the segments the GeoJSON gives; read
/// as buildings, every row is skipped as a line.
#[test]
fn geoarrow_native_lines_are_the_streets_of_their_geojson() {
    let roads =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/nyc-les/les_roads.geojson");
    let frame = LocalFrame::new(-73.99, 40.72, 0.0);
    let geojson = read_streets(&roads, None, None, None, &frame).unwrap();
    assert!(
        geojson.report.features_used > 100,
        "{:?}",
        geojson.report.features_used
    );
    for name in [
        "les_roads_linestring.parquet",
        "les_roads_multilinestring.parquet",
    ] {
        let s = read_streets(&fixture(name), None, None, None, &frame).unwrap();
        assert!(
            s.report.crs.starts_with("WGS84 lon/lat"),
            "{name}: {}",
            s.report.crs
        );
        assert_eq!(
            s.report.features_read, geojson.report.features_read,
            "{name}"
        );
        assert_eq!(
            s.report.features_used, geojson.report.features_used,
            "{name}"
        );
        assert_eq!(s.segments, geojson.segments, "{name}");
        let as_buildings = read(&fixture(name)).unwrap();
        assert!(as_buildings.buildings.is_empty(), "{name}");
        let r = &as_buildings.report;
        assert_eq!(r.skipped.len(), geojson.report.features_read, "{name}");
        assert!(
            r.skipped
                .iter()
                .all(|i| i.reason == IssueReason::UnsupportedGeometry
                    && i.detail.contains("LineString geometry is not a footprint")),
            "{name}: {:?}",
            &r.skipped[..2]
        );
    }
}

#[test]
fn the_crs_comes_from_the_metadata_or_from_crs() {
    let dir = scratch("crs");
    let w = Wkb::default();
    let rows = vec![(w.polygon(&[square(85_000.0, 446_000.0, 20.0)]), "rd")];
    // PROJJSON with an id; a compound CRS's horizontal part.
    let rd = r#", "crs": {"type": "ProjectedCRS", "name": "Amersfoort / RD New", "id": {"authority": "EPSG", "code": 28992}}"#;
    let compound = r#", "crs": {"type": "CompoundCRS", "name": "Amersfoort / RD New + NAP height", "components": [{"type": "ProjectedCRS", "name": "Amersfoort / RD New", "id": {"authority": "EPSG", "code": 28992}}, {"type": "VerticalCRS", "name": "NAP height", "id": {"authority": "EPSG", "code": 5709}}]}"#;
    for (name, crs) in [("id", rd), ("compound", compound)] {
        let p = dir.join(format!("{name}.parquet"));
        write_parquet(&p, Some(&geo("geometry", "WKB", crs)), "geometry", &rows, 1);
        let out = read(&p).unwrap();
        assert_eq!(out.report.files[0].crs, "EPSG:28992", "{name}");
        assert!((out.frame.origin_lat_deg - 52.0).abs() < 0.05, "{name}");
    }
    // crs null (unknown) and a Parquet file without GeoParquet metadata: --crs names it, else an error says so.
    let unknown = dir.join("unknown.parquet");
    write_parquet(
        &unknown,
        Some(&geo("geometry", "WKB", r#", "crs": null"#)),
        "geometry",
        &rows,
        1,
    );
    let plain = dir.join("plain.parquet");
    write_parquet(&plain, None, "geom", &rows, 1);
    for p in [&unknown, &plain] {
        assert!(matches!(
            read(p),
            Err(IngestError::GeoParquetWithoutCrs { .. })
        ));
        let given = IngestOptions {
            crs: Some("EPSG:28992".into()),
            ..Default::default()
        };
        let out = ingest(std::slice::from_ref(p), &given).unwrap();
        assert_eq!(out.buildings.len(), 1);
    }
    let out = ingest(
        std::slice::from_ref(&plain),
        &IngestOptions {
            crs: Some("EPSG:28992".into()),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(out.report.files[0]
        .notes
        .iter()
        .any(|n| n.contains("no GeoParquet metadata") && n.contains("\"geom\"")));
    // PROJJSON without an id names no CRS this reader can use.
    let anonymous = dir.join("anonymous.parquet");
    write_parquet(
        &anonymous,
        Some(&geo(
            "geometry",
            "WKB",
            r#", "crs": {"type": "ProjectedCRS", "name": "custom"}"#,
        )),
        "geometry",
        &rows,
        1,
    );
    let e = read(&anonymous).unwrap_err().to_string();
    assert!(
        e.contains("without an authority id") && e.contains("--crs"),
        "{e}"
    );
}

#[test]
fn files_that_are_not_geoparquet_buildings_are_refused_with_the_reason() {
    let dir = scratch("broken");
    let w = Wkb::default();
    let rows = vec![(w.polygon(&[square(4.35, 52.0, 0.0002)]), "a")];
    let err = |p: &Path| match read(p) {
        Err(IngestError::InvalidGeoParquet { detail, .. }) => detail,
        other => panic!("{}: {:?}", p.display(), other.map(|o| o.buildings.len())),
    };
    let text = dir.join("text.parquet");
    std::fs::write(&text, "id,geometry\n1,POINT(1 2)\n").unwrap();
    assert!(err(&text).contains("not a Parquet file"));
    let points = dir.join("points.parquet");
    write_parquet(
        &points,
        Some(&geo("geometry", "point", "")),
        "geometry",
        &rows,
        1,
    );
    assert!(err(&points).contains("encoded as \"point\""));
    let elsewhere = dir.join("elsewhere.parquet");
    write_parquet(
        &elsewhere,
        Some(&geo("shape", "WKB", "")),
        "geometry",
        &rows,
        1,
    );
    assert!(err(&elsewhere).contains("\"shape\", which the file does not have"));
    let nothing = dir.join("nothing.parquet");
    write_parquet(&nothing, None, "blob", &rows, 1);
    let e = err(&nothing);
    assert!(
        e.contains("without GeoParquet metadata") && e.contains("blob"),
        "{e}"
    );
    let bad_json = dir.join("json.parquet");
    write_parquet(&bad_json, Some("{"), "geometry", &rows, 1);
    assert!(err(&bad_json).contains("not JSON"));
}

fn next(state: &mut u64) -> u64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    *state
}

#[test]
fn damaged_files_give_an_error_or_buildings_never_a_panic() {
    let dir = scratch("mutations");
    let good = std::fs::read(fixture("les_overture.parquet")).unwrap();
    let mut read_some = 0;
    for seed in 1..=200u64 {
        let mut state = seed * 0x9E37_79B9;
        let mut bytes = good.clone();
        for _ in 0..1 + next(&mut state) % 4 {
            let at = (next(&mut state) % bytes.len() as u64) as usize;
            match next(&mut state) % 3 {
                0 => bytes[at] = next(&mut state) as u8,
                1 => bytes[at] ^= 1 << (next(&mut state) % 8),
                _ => bytes.truncate(at.max(1)),
            }
        }
        let p = dir.join("m.parquet");
        std::fs::write(&p, &bytes).unwrap();
        let got = std::panic::catch_unwind(|| read(&p).map(|o| o.buildings.len()));
        match got {
            Ok(Ok(n)) => read_some += usize::from(n > 0),
            Ok(Err(_)) => {}
            Err(_) => panic!("seed {seed}: panicked"),
        }
    }
    // Mutations inside compressed pages or statistics still leave files that read.
    assert!(read_some > 0, "{read_some}");
}

#[test]
fn boston_as_geoparquet_gives_the_buildings_of_its_geojson() {
    let Some(path) = citylod_testdata::shared_data("boston/boston_buildings.geojson") else {
        return;
    };
    let opts = IngestOptions {
        storey_height_m: 3.5,
        ..Default::default()
    };
    let geojson = ingest(std::slice::from_ref(&path), &opts).unwrap();
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let p = scratch("boston").join("boston.parquet");
    // Row groups of 5,000: five read in parallel.
    citylod_testdata::geoparquet::write_buildings(
        &doc,
        1,
        0.0,
        5_000,
        std::fs::File::create(&p).unwrap(),
    )
    .unwrap();
    let gpq = ingest(&[p], &opts).unwrap();
    assert_eq!(gpq.buildings.len(), geojson.buildings.len());
    assert_eq!(gpq.frame, geojson.frame);
    // Outlines to the bit (WKB holds the GeoJSON's doubles), storeys × 3.5 m alike, in the same order.
    let strip = |s: Seen| -> Vec<(Vec<[f64; 2]>, f64)> {
        s.into_iter().map(|(_, v, _, h)| (v, h)).collect()
    };
    let (a, b) = (strip(seen(&gpq)), strip(seen(&geojson)));
    if let Some((i, _)) = a.iter().zip(&b).enumerate().find(|(_, (x, y))| x != y) {
        panic!("building {i}: {:?} against {:?}", a[i], b[i]);
    }
    assert_eq!(gpq.report.skipped.len(), geojson.report.skipped.len());
}

#[test]
fn overture_building_parts_draw_the_buildings_they_name() {
    let buildings = fixture("les_overture_buildings.parquet");
    let parts = fixture("les_overture_parts.parquet");
    // The parts alone, and the buildings alone: every row written.
    let alone = read(&parts).unwrap();
    assert_eq!(alone.buildings.len(), 132);
    assert!(alone.report.skipped.is_empty());
    let mut named: std::collections::BTreeMap<String, Vec<String>> = Default::default();
    for p in &alone.buildings {
        if let Some(AttrValue::String(b)) = p.attributes.get("building_id") {
            named
                .entry(b.clone())
                .or_default()
                .push(p.source_id.clone());
        }
    }
    let outlines = read(&buildings).unwrap();
    assert_eq!(outlines.buildings.len(), 1284);
    let has_parts: std::collections::BTreeSet<String> = outlines
        .buildings
        .iter()
        .filter(|b| b.attributes.get("has_parts") == Some(&AttrValue::Bool(true)))
        .map(|b| b.source_id.clone())
        .collect();
    assert_eq!(
        named
            .keys()
            .cloned()
            .collect::<std::collections::BTreeSet<_>>(),
        has_parts
    );
    // Together, in either order: the buildings their parts name are drawn by those parts, not over them.
    for inputs in [
        [buildings.clone(), parts.clone()],
        [parts.clone(), buildings.clone()],
    ] {
        let both = ingest(&inputs, &IngestOptions::default()).unwrap();
        let drawn: std::collections::BTreeMap<String, String> = both
            .report
            .skipped
            .iter()
            .map(|s| {
                assert_eq!(s.reason, IssueReason::DrawnByParts);
                (s.feature_id.clone(), s.detail.clone())
            })
            .collect();
        assert_eq!(
            drawn.keys().collect::<Vec<_>>(),
            named.keys().collect::<Vec<_>>()
        );
        for (building, parts) in &named {
            let detail = &drawn[building];
            assert!(
                detail.contains("naming it by building_id")
                    && parts.iter().all(|p| detail.contains(p.as_str())),
                "{building}: {detail}"
            );
        }
        assert_eq!(both.buildings.len(), 1416 - named.len());
    }
}

#[test]
fn overture_segments_in_tunnels_or_below_the_ground_are_no_street_barriers() {
    let dir = scratch("segments");
    let w = Wkb::default();
    let line = |i: f64| w.line(&[[4.35, 52.0 + i * 0.001], [4.351, 52.0 + i * 0.001]]);
    let rows = vec![
        (line(0.0), vec![Some("road"), None, None]),
        (
            line(1.0),
            vec![
                Some("road"),
                Some(r#"[{"values":["is_tunnel"],"between":null}]"#),
                None,
            ],
        ),
        // A flag for a stretch of the segment, and a bridge: still a barrier.
        (
            line(2.0),
            vec![
                Some("road"),
                Some(
                    r#"[{"values":["is_tunnel"],"between":[0.2,0.4]},{"values":["is_bridge"],"between":null}]"#,
                ),
                None,
            ],
        ),
        (
            line(3.0),
            vec![Some("road"), None, Some(r#"[{"value":-1,"between":null}]"#)],
        ),
        (
            line(4.0),
            vec![
                Some("rail"),
                Some(r#"[{"between":null,"values":["is_under_construction"]}]"#),
                None,
            ],
        ),
    ];
    let p = dir.join("segments.parquet");
    write_parquet_texts(
        &p,
        Some(&geo("geometry", "WKB", "")),
        "geometry",
        &["subtype", "road_flags", "level_rules"],
        &rows,
        10,
    );
    let frame = LocalFrame::new(4.35, 52.0, 0.0);
    let s = read_streets(&p, None, None, None, &frame).unwrap();
    assert_eq!((s.report.features_read, s.report.features_used), (5, 2));
    let why: Vec<(&str, IssueReason, &str)> = s
        .report
        .skipped
        .iter()
        .map(|i| (i.feature_id.as_str(), i.reason, i.detail.as_str()))
        .collect();
    assert_eq!(why.len(), 3);
    assert_eq!(why[0].0, "segments.parquet#1");
    assert!(why.iter().all(|w| w.1 == IssueReason::NotOnGround));
    assert!(
        why[0]
            .2
            .contains("in a tunnel (Overture road_flags is_tunnel)"),
        "{}",
        why[0].2
    );
    assert!(why[1].2.contains("level_rules value -1"), "{}", why[1].2);
    assert!(why[2].2.contains("under construction"), "{}", why[2].2);
}
