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
    let to = std::env::temp_dir().join(format!("citylod-fgdb-{}-{tag}", std::process::id()));
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
