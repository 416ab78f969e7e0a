//! Every roof shape over every one of Boston's 22,182 real footprints (the bundled GeoJSON as read): no
//! panic, no endless skeleton, every roof built closed and under its top, and refusals only where the shape says so.
//! Real outlines bring what random ones rarely do: corners a few centimetres apart, edges nearly in line, courtyards,
//! 6-decimal coordinates.

use citylod_ingest::IngestOptions;
use citylod_mesh::roof::{
    roof_outline_area_m2, roofed_building, RoofRise, RoofShape, RoofSpec, MAX_CORNERS,
};
use citylod_mesh::topology::{mesh_report, signed_volume_m3};
use citylod_model::{footprint_area_m2, SurfaceKind};
use geo_types::{MultiPolygon, Polygon};

/// Boston's footprints as citylod reads them (repaired, in the local ENU frame), each polygon of a multipolygon on
/// its own.
fn boston_polygons() -> Option<Vec<(String, Polygon<f64>)>> {
    citylod_testdata::read_shared_data("boston/boston_buildings.geojson", |path| {
        let ingested =
            citylod_ingest::ingest(&[path.to_path_buf()], &IngestOptions::default()).ok()?;
        let out: Vec<(String, Polygon<f64>)> = ingested
            .buildings
            .iter()
            .flat_map(|b| {
                b.footprint
                    .0
                    .iter()
                    .enumerate()
                    .map(|(k, p)| (format!("{}/{k}", b.source_id), p.clone()))
            })
            .collect();
        (out.len() >= 22_182).then_some(out)
    })
}

#[test]
fn every_roof_shape_over_every_boston_footprint_is_closed_or_refused_for_its_shape() {
    let Some(polygons) = boston_polygons() else {
        return;
    };
    let shapes = RoofShape::ALL;
    let (base, height) = (0.0, 12.0);
    // Per shape: built, refused (with the reasons seen).
    let mut built = [0usize; RoofShape::ALL.len()];
    let mut refused: [Vec<String>; RoofShape::ALL.len()] = Default::default();
    let mut outlines = 0;
    for (id, polygon) in &polygons {
        let corners: usize = polygon.exterior().0.len()
            + polygon.interiors().iter().map(|h| h.0.len()).sum::<usize>();
        let footprint = MultiPolygon(vec![polygon.clone()]);
        // Outlines a roof is refused for whatever its shape (too many corners, no width) are counted apart.
        if corners > MAX_CORNERS || footprint_area_m2(&footprint) < 4.0 {
            continue;
        }
        outlines += 1;
        for (s, &shape) in shapes.iter().enumerate() {
            let spec = RoofSpec {
                shape,
                rise: RoofRise::Default,
                direction_deg: None,
                across: false,
            };
            match roofed_building(&footprint, base, height, &spec) {
                Ok((mesh, kinds)) => {
                    built[s] += 1;
                    assert_eq!(kinds.len(), mesh.triangles.len(), "{id} {shape:?}");
                    let r = mesh_report(&mesh);
                    assert!(
                        r.watertight && r.orientation_consistent,
                        "{id} {shape:?}: {r:?}"
                    );
                    let top = mesh.positions.iter().map(|p| p[2]).fold(f64::MIN, f64::max);
                    assert!(
                        (top - (base + height)).abs() < 1e-6,
                        "{id} {shape:?}: top {top}"
                    );
                    // The eaves: the lowest corner of the roof.
                    let eaves = mesh
                        .triangles
                        .iter()
                        .zip(&kinds)
                        .filter(|(_, k)| **k == SurfaceKind::Roof)
                        .flat_map(|(t, _)| t.map(|i| mesh.positions[i as usize][2]))
                        .fold(f64::MAX, f64::min);
                    assert!(eaves > base && eaves < top, "{id} {shape:?}: eaves {eaves}");
                    // Closed and outward: the volume of walls up to the eaves and a roof between them and the top,
                    // over the outline the roof is built on.
                    let a = roof_outline_area_m2(polygon);
                    let v = signed_volume_m3(&mesh);
                    assert!(
                        v >= a * (eaves - base) * (1.0 - 1e-9)
                            && v <= a * (top - base) * (1.0 + 1e-9),
                        "{id} {shape:?}: volume {v} over {a} m² with eaves at {eaves} m"
                    );
                }
                Err(why) => refused[s].push(why),
            }
        }
    }
    let report: Vec<String> = shapes
        .iter()
        .enumerate()
        .map(|(s, shape)| format!("{shape:?} {} built, {} refused", built[s], refused[s].len()))
        .collect();
    eprintln!("{outlines} outlines: {}", report.join("; "));
    assert!(outlines > 20_000, "{outlines}");
    for (s, shape) in shapes.iter().enumerate() {
        let (built, refused) = (built[s], &refused[s]);
        let first = &refused[..refused.len().min(5)];
        match shape {
            // Spanning any outline with its courtyards.
            RoofShape::Skillion
            | RoofShape::Gabled
            | RoofShape::Gambrel
            | RoofShape::Round
            | RoofShape::HalfHipped
            // The straight skeleton of any outline with its courtyards.
            | RoofShape::Hipped
            | RoofShape::Mansard => assert!(refused.is_empty(), "{shape:?}: {first:?}"),
            // On convex outlines without courtyards only, and refused for nothing else.
            RoofShape::Pyramidal | RoofShape::Dome => {
                assert!(built > 1_000, "{shape:?}: {built}");
                for why in refused {
                    assert!(
                        why.contains("not convex") || why.contains("courtyard"),
                        "{shape:?}: {why}"
                    );
                }
            }
        }
    }
}
