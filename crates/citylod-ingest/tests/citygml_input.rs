//! CityGML through `ingest`: the real files in `tests/citygml/` (see its ATTRIBUTION.md) — Zürich's LoD2 buildings of
//! thematic surfaces and BuildingParts (CityGML 1.0, CH1903), a Delft 3dfier LoD0/LoD1 tile (2.0, EPSG:7415), SIG3D's
//! generic attribute example (2.0) — a CityGML 3.0 model written here, Den Haag's CityJSON written as CityGML and
//! read back the same, and files cut or broken anywhere never panicking.

use citylod_ingest::{
    ingest, IngestError, IngestOptions, Ingested, InputFormat, IssueReason, LodChoice,
};
use citylod_model::{AttrValue, HeightSource, SurfaceKind};
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/citygml")
        .join(name)
}

fn read(path: &Path, opts: &IngestOptions) -> Result<Ingested, IngestError> {
    ingest(&[path.to_path_buf()], opts)
}

fn lod2() -> IngestOptions {
    IngestOptions {
        lod: Some("2".parse::<LodChoice>().unwrap()),
        ..Default::default()
    }
}

fn shoelace(pts: &[[f64; 3]]) -> f64 {
    let n = pts.len();
    (0..n)
        .map(|i| {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        .abs()
        / 2.0
}

fn point(text: &str) -> [f64; 3] {
    let v: Vec<f64> = text
        .split_ascii_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    [v[0], v[1], v[2]]
}

fn pos_list(text: &str) -> Vec<[f64; 3]> {
    let v: Vec<f64> = text
        .split_ascii_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    let mut pts: Vec<[f64; 3]> = v.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
    if pts.first() == pts.last() {
        pts.pop();
    }
    pts
}

/// What the Zürich file says of each building, read here with a plain tree walk: its ground surfaces' area (m²,
/// in CH1903), and the lowest and highest z of its envelope.
fn zurich_expected() -> HashMap<String, (f64, f64, f64)> {
    let text = std::fs::read_to_string(fixture("zurich-lod2-citygml1.xml")).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let mut out = HashMap::new();
    for b in doc
        .descendants()
        .filter(|n| n.tag_name().name() == "Building")
    {
        let id = b
            .attributes()
            .find(|a| a.name() == "id")
            .unwrap()
            .value()
            .to_string();
        let corner = |name: &str| -> [f64; 3] {
            let c = b
                .children()
                .find(|c| c.tag_name().name() == "boundedBy")
                .unwrap()
                .descendants()
                .find(|d| d.tag_name().name() == name)
                .unwrap();
            point(c.text().unwrap())
        };
        let area: f64 = b
            .descendants()
            .filter(|n| n.tag_name().name() == "GroundSurface")
            .flat_map(|g| g.descendants().filter(|n| n.tag_name().name() == "posList"))
            .map(|p| shoelace(&pos_list(p.text().unwrap())))
            .sum();
        out.insert(
            id,
            (area, corner("lowerCorner")[2], corner("upperCorner")[2]),
        );
    }
    out
}

#[test]
fn zurich_lod2_buildings_of_thematic_surfaces_and_parts() {
    let expected = zurich_expected();
    assert_eq!(expected.len(), 4);
    let out = read(&fixture("zurich-lod2-citygml1.xml"), &lod2()).unwrap();
    let r = &out.report;
    r.check_invariants().unwrap();
    assert_eq!(r.files[0].format, InputFormat::CityGml);
    assert_eq!(r.files[0].crs, "EPSG:21781");
    assert!(
        r.files[0].notes.iter().any(|n| n.contains("CH1903")),
        "{:?}",
        r.files[0].notes
    );
    assert_eq!((r.features_read, out.buildings.len()), (4, 4));
    assert!(r.skipped.is_empty() && r.mesh_issues.is_empty(), "{r:?}");
    for b in &out.buildings {
        let (area, low, high) = expected[&b.source_id];
        // Every ground surface of the building's parts, unioned; CH1903's scale differs from the ground's by < 0.1 %.
        assert!(
            (b.area_m2() - area).abs() < area * 2e-3,
            "{}: {} m², not {area}",
            b.source_id,
            b.area_m2()
        );
        assert_eq!(b.height_source, HeightSource::Geometry);
        assert!((b.height_m - (high - low)).abs() < 1e-6, "{}", b.source_id);
        let c = b.footprint.0[0].exterior().0[0];
        let ground = out.frame.enu_to_geodetic([c.x, c.y, b.base_z_m])[2];
        assert!(
            (ground - low).abs() < 1e-3,
            "{}: {ground} m, not {low}",
            b.source_id
        );
        let g = out
            .frame
            .enu_to_geodetic([b.footprint.0[0].exterior().0[0].x, 0.0, 0.0]);
        assert!((8.53..8.56).contains(&g[0]), "{g:?}");
        assert!((47.36..47.39).contains(&out.frame.origin_lat_deg));
        // Its model: the parts' thematic surfaces, typed.
        let m = b.mesh.as_ref().expect("an LoD 2 model");
        m.check_invariants().unwrap();
        assert_eq!(m.lod, "2");
        for kind in [SurfaceKind::Roof, SurfaceKind::Wall, SurfaceKind::Ground] {
            assert!(m.surfaces.contains(&kind), "{}: no {kind:?}", b.source_id);
        }
        let top = m
            .mesh
            .positions
            .iter()
            .map(|p| p[2])
            .fold(f64::MIN, f64::max);
        assert!((top - b.base_z_m - b.height_m).abs() < 1e-3);
    }
    // Attributes: the class, generic attributes as numbers, external references by their system.
    let b = out
        .buildings
        .iter()
        .find(|b| b.source_id == "UUID_39ea5cbd-d1fb-4298-aa60-ea489dcc869d")
        .unwrap();
    assert_eq!(
        b.attributes.get("class"),
        Some(&AttrValue::String("BB07".into()))
    );
    assert_eq!(b.attributes.get("Region"), Some(&AttrValue::Int(8)));
    assert_eq!(
        b.attributes.get("externalReference:EGID"),
        Some(&AttrValue::String("302040712".into()))
    );
}

#[test]
fn delft_lod1_stands_on_its_footprint_with_its_measured_height() {
    let path = fixture("delft-citygml2.xml");
    let text = std::fs::read_to_string(&path).unwrap();
    let out = read(&path, &IngestOptions::default()).unwrap();
    let r = &out.report;
    r.check_invariants().unwrap();
    assert_eq!(r.files[0].crs, "EPSG:7415 (horizontal EPSG:28992)");
    assert_eq!(out.buildings.len(), 3);
    let doc = roxmltree::Document::parse(&text).unwrap();
    for b in &out.buildings {
        let e = doc
            .descendants()
            .find(|n| {
                n.attributes()
                    .any(|a| a.name() == "id" && a.value() == b.source_id)
            })
            .unwrap();
        let measured: f64 = e
            .children()
            .find(|c| c.tag_name().name() == "measuredHeight")
            .unwrap()
            .text()
            .unwrap()
            .parse()
            .unwrap();
        // The footprint is the LoD0 footprint, not the roof edge around it.
        let pts = |name: &str| -> Vec<[f64; 3]> {
            let g = e.children().find(|c| c.tag_name().name() == name).unwrap();
            let mut p: Vec<[f64; 3]> = g
                .descendants()
                .filter(|d| d.tag_name().name() == "pos")
                .map(|d| point(d.text().unwrap()))
                .collect();
            p.pop();
            p
        };
        let (foot, edge) = (pts("lod0FootPrint"), pts("lod0RoofEdge"));
        assert!((b.area_m2() - shoelace(&foot)).abs() < 0.05 * shoelace(&foot));
        if (shoelace(&edge) - shoelace(&foot)).abs() > 1.0 {
            assert!((b.area_m2() - shoelace(&edge)).abs() > 0.5);
        }
        assert_eq!(b.height_source, HeightSource::KnownAttribute);
        assert!((b.height_m - measured).abs() < 1e-9, "{}", b.source_id);
        let c = b.footprint.0[0].exterior().0[0];
        let ground = out.frame.enu_to_geodetic([c.x, c.y, b.base_z_m])[2];
        assert!(
            (ground - foot[0][2]).abs() < 1e-3,
            "{}: {ground} m, not {}",
            b.source_id,
            foot[0][2]
        );
    }
}

#[test]
fn generic_attributes_keep_their_types_and_sets() {
    // The example declares CH1903 for coordinates of a German UTM zone: --crs replaces it, and the report says so.
    let opts = IngestOptions {
        crs: Some("EPSG:25832".into()),
        ..Default::default()
    };
    let out = read(&fixture("sig3d-genericattributes-citygml2.xml"), &opts).unwrap();
    assert!(
        out.report.files[0]
            .notes
            .iter()
            .any(|n| n.contains("declares EPSG:21781") && n.contains("--crs EPSG:25832")),
        "{:?}",
        out.report.files[0].notes
    );
    let a = &out.buildings[0].attributes;
    let get = |k: &str| a.get(k).cloned();
    assert_eq!(get("Bauweise"), Some(AttrValue::String("Massivbau".into())));
    assert_eq!(get("Anzahl der Eingänge"), Some(AttrValue::Int(3)));
    assert_eq!(get("Grundflächenzahl GFZ"), Some(AttrValue::Float(0.33)));
    assert_eq!(
        get("Datum der Baufreigabe"),
        Some(AttrValue::String("2012-03-09".into()))
    );
    assert_eq!(get("Breite des Gebäudes"), Some(AttrValue::Float(20.75)));
    assert_eq!(get("Basismengen.Höhe"), Some(AttrValue::Float(9.0)));
    assert_eq!(get("Basismengen.Volumen"), Some(AttrValue::Float(1260.0)));
    assert_eq!(
        get("name"),
        Some(AttrValue::String("Haus mit generischen Attributen".into()))
    );
    // An LoD1 box 10 m × 8 m × 9 m.
    assert!((out.buildings[0].area_m2() - 80.0).abs() < 0.5);
    assert!((out.buildings[0].height_m - 9.0).abs() < 1e-9);
}

/// A gabled house 10 m × 8 m, eaves at 6 m and ridge at 9 m above z0, as polygons (ground, 4 walls, 2 roof planes),
/// each with its type, at (x0, y0).
fn gabled_house(x0: f64, y0: f64, z0: f64) -> Vec<(&'static str, Vec<[f64; 3]>)> {
    let p = |x: f64, y: f64, z: f64| [x0 + x, y0 + y, z0 + z];
    vec![
        (
            "GroundSurface",
            vec![p(0., 0., 0.), p(0., 8., 0.), p(10., 8., 0.), p(10., 0., 0.)],
        ),
        (
            "WallSurface",
            vec![p(0., 0., 0.), p(10., 0., 0.), p(10., 0., 6.), p(0., 0., 6.)],
        ),
        (
            "WallSurface",
            vec![
                p(10., 0., 0.),
                p(10., 8., 0.),
                p(10., 8., 6.),
                p(10., 4., 9.),
                p(10., 0., 6.),
            ],
        ),
        (
            "WallSurface",
            vec![p(10., 8., 0.), p(0., 8., 0.), p(0., 8., 6.), p(10., 8., 6.)],
        ),
        (
            "WallSurface",
            vec![
                p(0., 8., 0.),
                p(0., 0., 0.),
                p(0., 0., 6.),
                p(0., 4., 9.),
                p(0., 8., 6.),
            ],
        ),
        (
            "RoofSurface",
            vec![p(0., 0., 6.), p(10., 0., 6.), p(10., 4., 9.), p(0., 4., 9.)],
        ),
        (
            "RoofSurface",
            vec![p(0., 8., 6.), p(0., 4., 9.), p(10., 4., 9.), p(10., 8., 6.)],
        ),
    ]
}

fn pos_list_text(ring: &[[f64; 3]]) -> String {
    ring.iter()
        .chain(ring.first())
        .map(|p| format!("{} {} {}", p[0], p[1], p[2]))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A CityGML 3.0 model in ISO-8859-1 near Cologne (ETRS89 / UTM 32 by the AdV's name): B1 a gabled house whose
/// lod2Solid refers to its thematic surfaces' polygons (one through a reversed OrientableSurface), B2 a box whose
/// broken lod3 geometry is left out, B3 with only a reference to nothing, and a road.
/// In ISO-8859-1 as its declaration says, or (`latin1` false) in UTF-8 with a byte-order mark and no declaration.
fn citygml3(latin1: bool) -> Vec<u8> {
    let (x0, y0, z0) = (356_000.0, 5_645_000.0, 50.0);
    let house = gabled_house(x0, y0, z0);
    let mut boundary = String::new();
    let mut members = String::new();
    for (i, (kind, ring)) in house.iter().enumerate() {
        let con = "con";
        // Wall 1 is written inward (reversed); the solid turns it back with an OrientableSurface.
        let reversed: Vec<[f64; 3]> = ring.iter().rev().copied().collect();
        let ring = if i == 1 { &reversed } else { ring };
        boundary.push_str(&format!(
            "<core:boundary><{con}:{kind} gml:id=\"B1_s{i}\"><core:lod2MultiSurface><gml:MultiSurface>\
             <gml:surfaceMember><gml:Polygon gml:id=\"B1_p{i}\"><gml:exterior><gml:LinearRing>\
             <gml:posList>{}</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember>\
             </gml:MultiSurface></core:lod2MultiSurface></{con}:{kind}></core:boundary>\n",
            pos_list_text(ring)
        ));
        if i == 1 {
            members.push_str(&format!(
                "<gml:surfaceMember><gml:OrientableSurface orientation=\"-\">\
                 <gml:baseSurface xlink:href=\"#B1_p{i}\"/></gml:OrientableSurface></gml:surfaceMember>"
            ));
        } else {
            members.push_str(&format!("<gml:surfaceMember xlink:href=\"#B1_p{i}\"/>"));
        }
    }
    let bx = |x: f64, y: f64, h: f64| -> String {
        let p = |a: f64, b: f64, z: f64| [x0 + x + a, y0 + y + b, z0 + z];
        let faces = [
            vec![p(0., 0., 0.), p(0., 6., 0.), p(6., 6., 0.), p(6., 0., 0.)],
            vec![p(0., 0., h), p(6., 0., h), p(6., 6., h), p(0., 6., h)],
            vec![p(0., 0., 0.), p(6., 0., 0.), p(6., 0., h), p(0., 0., h)],
            vec![p(6., 0., 0.), p(6., 6., 0.), p(6., 6., h), p(6., 0., h)],
            vec![p(6., 6., 0.), p(0., 6., 0.), p(0., 6., h), p(6., 6., h)],
            vec![p(0., 6., 0.), p(0., 0., 0.), p(0., 0., h), p(0., 6., h)],
        ];
        faces
            .iter()
            .map(|f| {
                format!(
                    "<gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>{}</gml:LinearRing>\
                     </gml:exterior></gml:Polygon></gml:surfaceMember>",
                    f.iter()
                        .chain(f.first())
                        .map(|q| format!("<gml:pos>{} {} {}</gml:pos>", q[0], q[1], q[2]))
                        .collect::<String>()
                )
            })
            .collect()
    };
    let text = format!(
        r##"<?xml version="1.0" encoding="ISO-8859-1"?>
<!-- written by citylod's tests -->
<core:CityModel xmlns:core="http://www.opengis.net/citygml/3.0" xmlns:bldg="http://www.opengis.net/citygml/building/3.0"
  xmlns:con="http://www.opengis.net/citygml/construction/3.0" xmlns:gen="http://www.opengis.net/citygml/generics/3.0"
  xmlns:tran="http://www.opengis.net/citygml/transportation/3.0" xmlns:gml="http://www.opengis.net/gml/3.2"
  xmlns:xlink="http://www.w3.org/1999/xlink">
 <gml:name>Prüfmodell</gml:name>
 <gml:boundedBy><gml:Envelope srsName="urn:adv:crs:ETRS89_UTM32*DE_DHHN2016_NH" srsDimension="3">
  <gml:lowerCorner>356000 5645000 50</gml:lowerCorner><gml:upperCorner>356040 5645010 59</gml:upperCorner>
 </gml:Envelope></gml:boundedBy>
 <core:cityObjectMember>
  <bldg:Building gml:id="B1">
   <gml:name>Haus Müller</gml:name>
   <gen:genericAttribute><gen:StringAttribute><gen:name>Bauweise</gen:name><gen:value>Massivbau</gen:value></gen:StringAttribute></gen:genericAttribute>
   <gen:genericAttribute><gen:IntAttribute><gen:name>Eingänge</gen:name><gen:value>2</gen:value></gen:IntAttribute></gen:genericAttribute>
   <con:height><con:Height><con:highReference>highestPoint</con:highReference><con:lowReference>lowestGroundPoint</con:lowReference>
    <con:status>measured</con:status><con:value uom="m">9</con:value></con:Height></con:height>
   <bldg:storeysAboveGround>2</bldg:storeysAboveGround>
   {boundary}
   <core:lod2Solid><gml:Solid><gml:exterior><gml:Shell>{members}</gml:Shell></gml:exterior></gml:Solid></core:lod2Solid>
  </bldg:Building>
 </core:cityObjectMember>
 <core:cityObjectMember><tran:Road gml:id="R1"/></core:cityObjectMember>
 <core:cityObjectMember>
  <bldg:Building gml:id="B2">
   <core:lod1Solid><gml:Solid><gml:exterior><gml:Shell>{box}</gml:Shell></gml:exterior></gml:Solid></core:lod1Solid>
   <core:lod3MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>
    <gml:posList>1 2 3 4</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></core:lod3MultiSurface>
  </bldg:Building>
 </core:cityObjectMember>
 <core:cityObjectMember>
  <bldg:Building gml:id="B3">
   <core:lod1Solid xlink:href="#nowhere"/>
  </bldg:Building>
 </core:cityObjectMember>
</core:CityModel>
"##,
        box = bx(20.0, 0.0, 7.5),
    );
    if !latin1 {
        let text = text.replacen("<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>", "", 1);
        return [&b"\xef\xbb\xbf"[..], text.as_bytes()].concat();
    }
    let (bytes, _, bad) = encoding_rs::WINDOWS_1252.encode(&text);
    assert!(!bad);
    bytes.into_owned()
}

#[test]
fn citygml3_in_latin1_with_references_orientation_and_broken_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("model.gml");
    std::fs::write(&plain, citygml3(true)).unwrap();
    let gz = dir.path().join("model.gml.gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(&citygml3(true)).unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    // UTF-8 with a byte-order mark: read as a stream, where the others are read whole.
    let utf8 = dir.path().join("model-utf8.gml");
    std::fs::write(&utf8, citygml3(false)).unwrap();
    for path in [&plain, &gz, &utf8] {
        let out = read(path, &lod2()).unwrap();
        let r = &out.report;
        r.check_invariants().unwrap();
        assert_eq!(r.files[0].crs, "EPSG:25832", "{path:?}");
        assert_eq!(r.files[0].non_building_objects, 1);
        assert!(r.files[0].notes.iter().any(|n| n == "CityGML 3.0"));
        assert_eq!(r.features_read, 3);
        // B3: nothing but a reference to no element.
        assert_eq!(r.skipped.len(), 1, "{:?}", r.skipped);
        assert_eq!(r.skipped[0].feature_id, "B3");
        assert_eq!(r.skipped[0].reason, IssueReason::MalformedGeometry);
        assert!(
            r.skipped[0].detail.contains("#nowhere"),
            "{}",
            r.skipped[0].detail
        );
        let by_id: HashMap<&str, &citylod_model::Building> = out
            .buildings
            .iter()
            .map(|b| (b.source_id.as_str(), b))
            .collect();
        // B1: the ground surface, the 9 m of its con:height, its typed solid.
        let b1 = by_id["B1"];
        // 80 m² on the UTM grid, 144 km from its central meridian: 80.02 m² on the ground.
        assert!(
            (b1.area_m2() - 80.0 / 0.99986_f64.powi(2)).abs() < 0.01,
            "{}",
            b1.area_m2()
        );
        assert_eq!(b1.height_source, HeightSource::KnownAttribute);
        assert!((b1.height_m - 9.0).abs() < 1e-9);
        assert_eq!(
            b1.attributes.get("name"),
            Some(&AttrValue::String("Haus Müller".into()))
        );
        assert_eq!(
            b1.attributes.get("Bauweise"),
            Some(&AttrValue::String("Massivbau".into()))
        );
        assert_eq!(b1.attributes.get("Eingänge"), Some(&AttrValue::Int(2)));
        assert_eq!(
            b1.attributes.get("storeysAboveGround"),
            Some(&AttrValue::Int(2))
        );
        let m = b1.mesh.as_ref().unwrap();
        // Ground 2, walls 2 + 3 + 2 + 3, roof 2 + 2 triangles, each typed by the thematic surface its polygon is in;
        // the reversed wall turned back, so the solid is closed and wound outwards.
        assert_eq!(m.mesh.triangles.len(), 16);
        let count = |k: SurfaceKind| m.surfaces.iter().filter(|s| **s == k).count();
        assert_eq!(
            (
                count(SurfaceKind::Ground),
                count(SurfaceKind::Wall),
                count(SurfaceKind::Roof)
            ),
            (2, 10, 4)
        );
        assert!(citylod_mesh::topology::signed_volume_m3(&m.mesh) > 0.0);
        let volume = citylod_mesh::topology::signed_volume_m3(&m.mesh);
        let want = (80.0 * 6.0 + 0.5 * 8.0 * 3.0 * 10.0) / 0.99986_f64.powi(2);
        assert!((volume - want).abs() < 0.05, "{volume} m³, not {want}");
        // B2: its box, and the lod3 geometry it could not read, listed with its line.
        let b2 = by_id["B2"];
        assert!((b2.height_m - 7.5).abs() < 1e-9);
        let repair = r
            .repaired
            .iter()
            .find(|i| i.feature_id == "B2" && i.reason == IssueReason::GeometryNotRead)
            .expect("the lod3 geometry listed");
        assert!(
            repair.detail.contains("lod3MultiSurface") && repair.detail.contains("line 37"),
            "{}",
            repair.detail
        );
        assert!(
            (out.frame.origin_lon_deg - 6.94).abs() < 0.05,
            "{:?}",
            out.frame
        );
        assert!((out.frame.origin_lat_deg - 50.94).abs() < 0.05);
    }
}

#[test]
fn broken_files_are_refused_with_the_reason_and_none_panics() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let refused = |p: &Path, want: &str| match read(p, &IngestOptions::default()) {
        Err(e @ IngestError::InvalidCityGml { .. }) => {
            assert!(e.to_string().contains(want), "{e}")
        }
        other => panic!("{p:?}: {other:?}"),
    };
    let text = std::fs::read(fixture("zurich-lod2-citygml1.xml")).unwrap();
    refused(
        &write("cut.gml", &text[..text.len() / 2]),
        "not well-formed XML",
    );
    let doctype = String::from_utf8(text.clone()).unwrap().replacen(
        "<CityModel",
        "<!DOCTYPE x [<!ENTITY a \"aaaa\">]><CityModel",
        1,
    );
    refused(&write("doctype.gml", doctype.as_bytes()), "DOCTYPE");
    let latin = String::from_utf8(text.clone()).unwrap().replacen(
        "encoding=\"UTF-8\"",
        "encoding=\"x-unknown\"",
        1,
    );
    refused(&write("enc.gml", latin.as_bytes()), "x-unknown");
    // Cut at many places, or with a byte changed: an error or buildings, never a panic.
    let mut rng = citylod_testdata::SplitMix64(7);
    for k in 0..160 {
        let mut b = text.clone();
        let at = (rng.next_u64() as usize) % b.len();
        if k % 2 == 0 {
            b.truncate(at);
        } else {
            b[at] = b"<>/\"# 0-9x"[(rng.next_u64() % 10) as usize];
        }
        let p = write("fuzz.gml", &b);
        if let Ok(out) = read(&p, &lod2()) {
            out.report.check_invariants().unwrap();
        }
    }
}

#[test]
fn den_haag_as_citygml_gives_the_buildings_its_cityjson_gives() {
    let Some(path) = citylod_testdata::shared_data("denhaag-lod2/DenHaag_01.json") else {
        return;
    };
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let gml = dir.path().join("denhaag.gml");
    let mut text = Vec::new();
    let srs = "urn:ogc:def:crs,crs:EPSG::28992,crs:EPSG::5109";
    citylod_testdata::citygml::from_cityjson(&doc, 1, 0.0, srs, &mut text).unwrap();
    std::fs::write(&gml, text).unwrap();
    let from_json = read(
        &path,
        &IngestOptions {
            crs: Some("EPSG:28992".into()),
            ..lod2()
        },
    )
    .unwrap();
    // The GML names its CRS (a compound URN, RD New + NAP): no --crs.
    let from_gml = read(&gml, &lod2()).unwrap();
    assert_eq!(from_gml.report.files[0].crs, "EPSG:28992");
    assert_eq!(from_gml.report.files[0].non_building_objects, 1);
    let (a, b) = (&from_json.report, &from_gml.report);
    assert_eq!(a.features_read, 844);
    assert_eq!(
        (b.features_read, b.buildings_written),
        (a.features_read, a.buildings_written)
    );
    assert_eq!(b.skipped_by_reason, a.skipped_by_reason);
    assert_eq!(b.mesh_issues_by_reason, a.mesh_issues_by_reason);
    assert_eq!(b.height_sources, a.height_sources);
    assert_eq!(from_gml.frame, from_json.frame);
    let json_by_id: HashMap<&str, &citylod_model::Building> = from_json
        .buildings
        .iter()
        .map(|b| (b.source_id.as_str(), b))
        .collect();
    for g in &from_gml.buildings {
        let j = json_by_id[g.source_id.as_str()];
        assert_eq!(g.footprint, j.footprint, "{}", g.source_id);
        assert_eq!(
            (g.base_z_m, g.height_m),
            (j.base_z_m, j.height_m),
            "{}",
            g.source_id
        );
        let (gm, jm) = (g.mesh.as_ref(), j.mesh.as_ref());
        assert_eq!(
            gm.map(|m| m.mesh.triangles.len()),
            jm.map(|m| m.mesh.triangles.len()),
            "{}",
            g.source_id
        );
        assert_eq!(
            gm.map(|m| &m.surfaces),
            jm.map(|m| &m.surfaces),
            "{}",
            g.source_id
        );
    }
}

/// A 10 m box at Tokyo Station in a geographic CRS, its coordinates in the order `order` gives ("latlon", "lonlat").
fn tokyo(srs: &str, order: &str) -> String {
    let (lat0, lon0): (f64, f64) = (35.6812, 139.7671);
    let (dlat, dlon) = (
        10.0 / 111_000.0,
        10.0 / (111_000.0 * lat0.to_radians().cos()),
    );
    let corners = [
        (0.0, 0.0),
        (0.0, dlon),
        (dlat, dlon),
        (dlat, 0.0),
        (0.0, 0.0),
    ];
    let ring = |z: f64| -> String {
        corners
            .iter()
            .map(|(a, b)| {
                let (lat, lon) = (lat0 + a, lon0 + b);
                if order == "latlon" {
                    format!("{lat} {lon} {z}")
                } else {
                    format!("{lon} {lat} {z}")
                }
            })
            .collect::<Vec<_>>()
            .join(" ")
    };
    format!(
        r#"<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:bldg="http://www.opengis.net/citygml/building/2.0"
 xmlns:gml="http://www.opengis.net/gml"><cityObjectMember><bldg:Building gml:id="T1">
 <bldg:measuredHeight uom="m">30</bldg:measuredHeight>
 <bldg:lod0FootPrint><gml:MultiSurface srsName="{srs}" srsDimension="3"><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>
 <gml:posList>{}</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod0FootPrint>
 </bldg:Building></cityObjectMember></CityModel>"#,
        ring(3.0)
    )
}

#[test]
fn a_citygml_file_without_a_srs_name_asks_for_crs_naming_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nocrs.gml");
    std::fs::write(&p, tokyo("X", "lonlat").replace(r#" srsName="X""#, "")).unwrap();
    let e = read(&p, &IngestOptions::default()).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, IngestError::MissingCrs { .. }), "{text}");
    assert!(text.contains("srsName") && text.contains("--crs"), "{text}");
    assert!(!text.contains("metadata.referenceSystem"), "{text}");
}

#[test]
fn geographic_crs_coordinates_come_latitude_first_as_epsg_orders_them() {
    let dir = tempfile::tempdir().unwrap();
    for (srs, order, note) in [
        // Japan's PLATEAU: JGD2011 + height, latitude first.
        (
            "http://www.opengis.net/def/crs/EPSG/0/6697",
            "latlon",
            "latitude, longitude",
        ),
        (
            "urn:ogc:def:crs:EPSG::4326",
            "latlon",
            "latitude, longitude",
        ),
        // Longitude first in a file that names EPSG:4326: 139.8 cannot be a latitude.
        ("EPSG:4326", "lonlat", "cannot be a latitude"),
    ] {
        let p = dir.path().join("tokyo.gml");
        std::fs::write(&p, tokyo(srs, order)).unwrap();
        let out = read(&p, &IngestOptions::default()).unwrap();
        let f = &out.report.files[0];
        assert!(
            f.notes.iter().any(|n| n.contains(note)),
            "{srs}: {:?}",
            f.notes
        );
        assert_eq!(out.buildings.len(), 1, "{srs}: {:?}", out.report.skipped);
        let b = &out.buildings[0];
        assert!(
            (b.area_m2() - 100.0).abs() < 1.0,
            "{srs}: {} m²",
            b.area_m2()
        );
        assert!(
            (out.frame.origin_lon_deg - 139.767).abs() < 0.001,
            "{srs}: {:?}",
            out.frame
        );
        assert!(
            (out.frame.origin_lat_deg - 35.681).abs() < 0.001,
            "{srs}: {:?}",
            out.frame
        );
        assert!((b.height_m - 30.0).abs() < 1e-9);
        assert!((out.frame.origin_h_m - 3.0).abs() < 1e-9);
    }
}

#[test]
fn a_zip_archive_of_citygml_tiles_reads_each_as_a_file() {
    let out = read(&fixture("tiles.zip"), &lod2()).unwrap();
    let r = &out.report;
    r.check_invariants().unwrap();
    // Each tile a file of its own, in name order, with its CRS; the README and the resource fork not read.
    let files: Vec<(String, String, usize)> = r
        .files
        .iter()
        .map(|f| (f.path.clone(), f.crs.clone(), f.buildings_written))
        .collect();
    assert_eq!(files.len(), 2, "{files:?}");
    assert!(
        files[0].0.ends_with("tiles.zip/tiles/zurich-a.gml"),
        "{files:?}"
    );
    assert!(
        files[1].0.ends_with("tiles.zip/tiles/zurich-b.gml.gz"),
        "{files:?}"
    );
    for f in &files {
        assert_eq!((f.1.as_str(), f.2), ("EPSG:21781", 2), "{files:?}");
    }
    // The same buildings, footprints, heights and models as the file read whole.
    let whole = read(&fixture("zurich-lod2-citygml1.xml"), &lod2()).unwrap();
    let key = |o: &Ingested| {
        let mut v: Vec<(String, u64, u64, usize)> = o
            .buildings
            .iter()
            .map(|b| {
                (
                    b.source_id.clone(),
                    (b.area_m2() * 1e4).round() as u64,
                    (b.height_m * 1e6).round() as u64,
                    b.mesh.as_ref().map_or(0, |m| m.mesh.triangles.len()),
                )
            })
            .collect();
        v.sort();
        v
    };
    assert_eq!(key(&out), key(&whole));
    assert_eq!(out.frame, whole.frame);
}

#[test]
fn z_in_a_crs_in_feet_is_in_feet_and_measured_heights_follow_their_uom() {
    // A 30 ft × 30 ft LoD1 box 100 ft high in New York's State Plane (US survey feet), as NYC's 3D building model
    // gives z; and one whose measuredHeight says 50 ft.
    let (x0, y0) = (987_000.0, 201_000.0);
    let solid = |dx: f64, h: f64| -> String {
        let p = |a: f64, b: f64, z: f64| format!("{} {} {}", x0 + dx + a, y0 + b, z);
        let faces = [
            [
                p(0., 0., 10.),
                p(0., 30., 10.),
                p(30., 30., 10.),
                p(30., 0., 10.),
            ],
            [
                p(0., 0., 10. + h),
                p(30., 0., 10. + h),
                p(30., 30., 10. + h),
                p(0., 30., 10. + h),
            ],
            [
                p(0., 0., 10.),
                p(30., 0., 10.),
                p(30., 0., 10. + h),
                p(0., 0., 10. + h),
            ],
            [
                p(30., 0., 10.),
                p(30., 30., 10.),
                p(30., 30., 10. + h),
                p(30., 0., 10. + h),
            ],
            [
                p(30., 30., 10.),
                p(0., 30., 10.),
                p(0., 30., 10. + h),
                p(30., 30., 10. + h),
            ],
            [
                p(0., 30., 10.),
                p(0., 0., 10.),
                p(0., 0., 10. + h),
                p(0., 30., 10. + h),
            ],
        ];
        faces
            .iter()
            .map(|f| {
                format!(
                    "<gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing><gml:posList>{} {}</gml:posList>\
                     </gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember>",
                    f.join(" "),
                    f[0]
                )
            })
            .collect()
    };
    let text = format!(
        r#"<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:bldg="http://www.opengis.net/citygml/building/2.0"
 xmlns:gml="http://www.opengis.net/gml">
 <gml:boundedBy><gml:Envelope srsName="EPSG:2263"><gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>1 1 1</gml:upperCorner></gml:Envelope></gml:boundedBy>
 <cityObjectMember><bldg:Building gml:id="A"><bldg:lod1Solid><gml:Solid><gml:exterior><gml:CompositeSurface>{}</gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod1Solid></bldg:Building></cityObjectMember>
 <cityObjectMember><bldg:Building gml:id="B"><bldg:measuredHeight uom="ft">50</bldg:measuredHeight>
  <bldg:lod1Solid><gml:Solid><gml:exterior><gml:CompositeSurface>{}</gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod1Solid></bldg:Building></cityObjectMember>
</CityModel>"#,
        solid(0.0, 100.0),
        solid(60.0, 100.0)
    );
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nyc.gml");
    std::fs::write(&p, text).unwrap();
    let out = read(&p, &IngestOptions::default()).unwrap();
    let f = &out.report.files[0];
    assert!(
        f.notes.iter().any(|n| n.contains("z is in the CRS's unit")),
        "{:?}",
        f.notes
    );
    let us_ft = 1200.0 / 3937.0;
    let by_id: HashMap<&str, &citylod_model::Building> = out
        .buildings
        .iter()
        .map(|b| (b.source_id.as_str(), b))
        .collect();
    let a = by_id["A"];
    assert_eq!(a.height_source, HeightSource::Geometry);
    assert!((a.height_m - 100.0 * us_ft).abs() < 1e-6, "{}", a.height_m);
    assert!(
        (a.area_m2() - (30.0 * us_ft).powi(2)).abs() < 0.1,
        "{}",
        a.area_m2()
    );
    assert!((out.frame.origin_h_m - 10.0 * us_ft).abs() < 1e-6);
    let b = by_id["B"];
    assert_eq!(b.height_source, HeightSource::KnownAttribute);
    assert!((b.height_m - 50.0 * 0.3048).abs() < 1e-9, "{}", b.height_m);
}

#[test]
fn a_wfs_answer_of_citygml_buildings_is_read() {
    // What a WFS 2.0 GetFeature request for CityGML buildings answers (the 3D City Database's WFS, GeoServer's
    // CityGML output): a FeatureCollection whose members are the buildings.
    let text = r#"<?xml version="1.0" encoding="UTF-8"?>
<wfs:FeatureCollection xmlns:wfs="http://www.opengis.net/wfs/2.0" xmlns:gml="http://www.opengis.net/gml"
 xmlns:bldg="http://www.opengis.net/citygml/building/2.0" numberMatched="2" numberReturned="2">
 <wfs:member><bldg:Building gml:id="W1"><bldg:measuredHeight uom="m">12</bldg:measuredHeight>
  <bldg:lod0FootPrint><gml:MultiSurface srsName="EPSG:25832"><gml:surfaceMember><gml:Polygon><gml:exterior>
  <gml:LinearRing><gml:posList srsDimension="3">356000 5645000 50 356010 5645000 50 356010 5645010 50 356000 5645010 50 356000 5645000 50</gml:posList>
  </gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod0FootPrint>
 </bldg:Building></wfs:member>
 <wfs:member><bldg:Building gml:id="W2"><bldg:measuredHeight uom="m">6</bldg:measuredHeight>
  <bldg:lod0FootPrint><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior>
  <gml:LinearRing><gml:posList srsDimension="3">356020 5645000 50 356030 5645000 50 356030 5645010 50 356020 5645010 50 356020 5645000 50</gml:posList>
  </gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod0FootPrint>
 </bldg:Building></wfs:member>
</wfs:FeatureCollection>
"#;
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("answer.xml");
    std::fs::write(&p, text).unwrap();
    let out = read(&p, &IngestOptions::default()).unwrap();
    assert_eq!(out.report.files[0].format, InputFormat::CityGml);
    assert_eq!(out.report.files[0].crs, "EPSG:25832");
    let mut got: Vec<(String, f64)> = out
        .buildings
        .iter()
        .map(|b| (b.source_id.clone(), b.height_m))
        .collect();
    got.sort_by(|a, b| a.0.cmp(&b.0));
    assert_eq!(got, vec![("W1".to_string(), 12.0), ("W2".to_string(), 6.0)]);
    // A FeatureCollection of something else is no CityGML, nor OpenStreetMap XML: refused as neither.
    std::fs::write(
        &p,
        r#"<wfs:FeatureCollection xmlns:wfs="http://www.opengis.net/wfs/2.0"><wfs:member/></wfs:FeatureCollection>"#,
    )
    .unwrap();
    let e = read(&p, &IngestOptions::default()).unwrap_err();
    assert!(matches!(e, IngestError::UnknownFormat { .. }), "{e}");
    assert!(
        e.to_string()
            .contains("<wfs:FeatureCollection>: neither CityGML"),
        "{e}"
    );
}

#[test]
fn a_composite_solid_is_its_solids_each_whole() {
    // A building whose lod1Solid is a CompositeSolid of two boxes apart, 10 m × 10 m × 6 m and 8 m × 8 m × 9 m: every
    // member solid is read, each whole.
    let bx = |x0: f64, side: f64, h: f64| -> String {
        let p = |a: f64, b: f64, z: f64| format!("{} {} {}", 85_000.0 + x0 + a, 446_000.0 + b, z);
        let s = side;
        let faces = [
            [p(0., 0., 0.), p(0., s, 0.), p(s, s, 0.), p(s, 0., 0.)],
            [p(0., 0., h), p(s, 0., h), p(s, s, h), p(0., s, h)],
            [p(0., 0., 0.), p(s, 0., 0.), p(s, 0., h), p(0., 0., h)],
            [p(s, 0., 0.), p(s, s, 0.), p(s, s, h), p(s, 0., h)],
            [p(s, s, 0.), p(0., s, 0.), p(0., s, h), p(s, s, h)],
            [p(0., s, 0.), p(0., 0., 0.), p(0., 0., h), p(0., s, h)],
        ];
        let members: String = faces
            .iter()
            .map(|f| {
                format!(
                    "<gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing><gml:posList>{} {}</gml:posList>\
                     </gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember>",
                    f.join(" "),
                    f[0]
                )
            })
            .collect();
        format!(
            "<gml:solidMember><gml:Solid><gml:exterior><gml:CompositeSurface>{members}</gml:CompositeSurface>\
             </gml:exterior></gml:Solid></gml:solidMember>"
        )
    };
    let text = format!(
        r#"<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:bldg="http://www.opengis.net/citygml/building/2.0"
 xmlns:gml="http://www.opengis.net/gml"><gml:boundedBy><gml:Envelope srsName="EPSG:28992"/></gml:boundedBy>
 <cityObjectMember><bldg:Building gml:id="C"><bldg:lod1Solid><gml:CompositeSolid>{}{}</gml:CompositeSolid></bldg:lod1Solid>
 </bldg:Building></cityObjectMember></CityModel>"#,
        bx(0.0, 10.0, 6.0),
        bx(20.0, 8.0, 9.0)
    );
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("composite.gml");
    std::fs::write(&p, text).unwrap();
    let out = read(&p, &lod2()).unwrap();
    assert!(
        out.report.mesh_issues.is_empty(),
        "{:?}",
        out.report.mesh_issues
    );
    let b = &out.buildings[0];
    let m = b.mesh.as_ref().expect("its LoD 1 model");
    assert_eq!(m.mesh.triangles.len(), 24);
    // Both boxes whole, in the frame's metres: each footprint polygon's area times its box's height.
    let mut areas: Vec<f64> = b.footprint.0.iter().map(geo::Area::unsigned_area).collect();
    areas.sort_by(f64::total_cmp);
    assert_eq!(areas.len(), 2);
    let want = areas[0] * 9.0 + areas[1] * 6.0;
    let v = citylod_mesh::topology::signed_volume_m3(&m.mesh);
    // The footprint lies in its own plane, the mesh in the frame's east-north-up metres, whose up turns by the Earth's
    // curvature across the 28 m between the boxes (a few 1e-5 of their heights); a box missing or turned inwards
    // would leave 600 m³, 576 m³ or 24 m³.
    assert!((v - want).abs() < 1e-4 * want, "{v} m³, not {want}");
}
