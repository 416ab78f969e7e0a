//! Pitched roofs from OpenStreetMap's Simple 3D Buildings tags (`roof:shape`, `roof:height`, `roof:levels`,
//! `roof:angle`, `roof:direction`, `roof:orientation`), in whatever format the tags come (an OSM file, its export to
//! GeoJSON, GeoPackage or Shapefile, with names as GDAL launders them, `roof_shape`, or cut to a shapefile's 10
//! characters, `roof:heigh`): with `--lod 2` (or `highest`, or a 2.x) a building whose `roof:shape` is
//! skillion, gabled, gambrel, round, half-hipped, hipped, mansard, pyramidal (cone), dome or onion (drawn as a dome) gets a 3D model of LoD 2 — walls up to the eaves, the roof up to the
//! building's height — and is drawn with it at full detail, its prism and the simplified model above it as for a
//! CityJSON LoD2 building. Other shapes, and outlines a shape cannot be pitched over, keep the flat prism, listed
//! in the report's mesh issues with the reason.

use crate::model3d::Meshed;
use crate::osm::exported_tag as tag;
use crate::report::IssueReason;
use citylod_mesh::roof::{roofed, RoofRise, RoofShape, RoofSpec, MIN_WALL_M};
use citylod_model::{AttrValue, Attributes, BuildingModel, Footprint};

/// The LoD a modelled roof is written as (`mesh_lods` in the report).
pub(crate) const ROOF_LOD: &str = "2";

/// Gives `meshed` the roofed model of a building tagged with a pitched `roof:shape`, or lists why it keeps a flat
/// roof; nothing for a building without `roof:shape` or with a flat one. `fell_back`: LoD 2 is below the LoD asked.
pub(crate) fn roof_model(
    attrs: &Attributes,
    footprint: &Footprint,
    base_z_m: f64,
    height_m: f64,
    opts: &crate::IngestOptions,
    fell_back: bool,
    meshed: &mut Meshed,
) {
    let Some(shape_value) = text(attrs, "roof:shape") else {
        return;
    };
    if matches!(shape_value.to_ascii_lowercase().as_str(), "flat" | "") {
        return;
    }
    let flat = |why: String| {
        (
            IssueReason::ModelMissing,
            format!("roof:shape={shape_value}: {why}; drawn with a flat roof"),
        )
    };
    let Some(shape) = RoofShape::from_osm(&shape_value) else {
        meshed.issues.push(flat(
            "this shape is not modelled (skillion, gabled, gambrel, round, half-hipped, hipped, mansard, pyramidal, cone, dome and onion are)"
                .into(),
        ));
        return;
    };
    let mut rejected = Vec::new();
    let mut value =
        |name: &str, metres: &dyn Fn(&AttrValue) -> Option<f64>, ok: &dyn Fn(f64) -> bool| {
            let v = tag(attrs, name).filter(|v| !matches!(v, AttrValue::Null))?;
            match metres(v).filter(|m| m.is_finite() && ok(*m)) {
                Some(m) => Some(m),
                None => {
                    rejected.push(format!("{name} = {}", crate::height::shown(Some(v))));
                    None
                }
            }
        };
    let rise = value(
        "roof:height",
        &|v| crate::height::length_m(v, opts.height_unit_m.unwrap_or(1.0)),
        &|m| m >= 0.0,
    )
    .map(RoofRise::Metres)
    .or_else(|| {
        value("roof:levels", &|v| v.as_number(), &|n| n >= 0.0)
            .map(|n| RoofRise::Metres(n * opts.storey_height_m))
    })
    .or_else(|| {
        // 0° is a flat roof, as a roof:height of 0 is.
        value("roof:angle", &|v| v.as_number(), &|a| {
            (0.0..89.0).contains(&a)
        })
        .map(|a| {
            if a == 0.0 {
                RoofRise::Metres(0.0)
            } else {
                RoofRise::AngleDeg(a)
            }
        })
    })
    .unwrap_or(RoofRise::Default);
    let direction_deg = value("roof:direction", &|v| direction(v), &|d| d.abs() <= 1e6);
    let orientation = text(attrs, "roof:orientation");
    let across = orientation
        .as_deref()
        .is_some_and(|o| o.eq_ignore_ascii_case("across"));
    if let Some(o) = orientation
        .filter(|o| !(o.eq_ignore_ascii_case("across") || o.eq_ignore_ascii_case("along")))
    {
        rejected.push(format!("roof:orientation = {o:?} (along or across)"));
    }
    if !rejected.is_empty() {
        meshed.issues.push((
            IssueReason::RoofTagAdjusted,
            format!(
                "{}: not usable for the roof, which takes the next rule (or its default)",
                rejected.join(", ")
            ),
        ));
    }
    let spec = RoofSpec {
        shape,
        rise,
        direction_deg,
        across,
    };
    match roofed(footprint, base_z_m, height_m, &spec) {
        Ok(built) => {
            // A roof asked higher than its building (roof:height or roof:levels over the height, or a steep
            // roof:angle over a wide outline) was lowered to leave the walls their least height: said, with what
            // it became. One exactly as high is a roof-only part (OSM's building:part from the eaves up, min_height
            // at the eaves), as mapped: not said.
            let cm = |m: f64| crate::height::trim_float((m * 100.0).round() / 100.0);
            let asked = match spec.rise {
                RoofRise::Metres(m) if m > height_m + ROOF_OVER_M => {
                    Some(format!("a roof of {} m", crate::height::trim_float(m)))
                }
                RoofRise::AngleDeg(a) if built.asked_rise_m > built.rise_m + ROOF_OVER_M => {
                    Some(format!(
                        "roof:angle = {}° asks a roof of {} m over this outline,",
                        crate::height::trim_float(a),
                        cm(built.asked_rise_m)
                    ))
                }
                _ => None,
            };
            if let Some(asked) = asked {
                meshed.issues.push((
                    IssueReason::RoofTagAdjusted,
                    format!(
                        "{asked} on a building {} m high: lowered to {} m, over walls of {MIN_WALL_M} m",
                        crate::height::trim_float(height_m),
                        cm(built.rise_m)
                    ),
                ));
            }
            meshed.model = Some(BuildingModel {
                mesh: built.mesh,
                surfaces: built.kinds,
                lod: ROOF_LOD.into(),
            });
            meshed.fell_back = fell_back;
        }
        Err(why) => meshed.issues.push(flat(why)),
    }
}

/// A roof higher than its building by more than this (m) is said to be lowered; up to it, it is the building (a
/// roof-only part) and rounding.
const ROOF_OVER_M: f64 = 0.01;

fn text(attrs: &Attributes, name: &str) -> Option<String> {
    match tag(attrs, name)? {
        AttrValue::String(s) => Some(s.trim().to_string()),
        _ => None,
    }
}

/// `roof:direction` as compass degrees: a number, or a compass point (`N`, `NNE`, …, `NW`).
fn direction(v: &AttrValue) -> Option<f64> {
    if let Some(d) = v.as_number() {
        return Some(d.rem_euclid(360.0));
    }
    const POINTS: [&str; 16] = [
        "N", "NNE", "NE", "ENE", "E", "ESE", "SE", "SSE", "S", "SSW", "SW", "WSW", "W", "WNW",
        "NW", "NNW",
    ];
    let AttrValue::String(s) = v else {
        return None;
    };
    POINTS
        .iter()
        .position(|p| p.eq_ignore_ascii_case(s.trim()))
        .map(|i| i as f64 * 22.5)
}

#[cfg(test)]
mod tests {
    use crate::{ingest, IngestOptions, Ingested, IssueReason};
    use citylod_mesh::topology::mesh_report;
    use serde_json::{json, Value};

    /// A 12 m × 8 m building at the `i`-th place of a row, as an OpenStreetMap export to GeoJSON writes it.
    fn house(i: usize, tags: Value) -> Value {
        let (lon, lat) = (4.0 + i as f64 * 0.001, 52.0);
        let (dx, dy) = (12.0 / 68_600.0, 8.0 / 111_250.0);
        let mut properties = json!({ "building": "house", "height": "10" });
        for (k, v) in tags.as_object().unwrap() {
            properties[k] = v.clone();
        }
        json!({ "type": "Feature", "id": format!("way/{i}"), "properties": properties, "geometry": {
            "type": "Polygon",
            "coordinates": [[[lon, lat], [lon + dx, lat], [lon + dx, lat + dy], [lon, lat + dy], [lon, lat]]] } })
    }

    fn run(features: Vec<Value>, lod: Option<&str>) -> Ingested {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("osm-export.geojson");
        std::fs::write(
            &p,
            json!({ "type": "FeatureCollection", "features": features }).to_string(),
        )
        .unwrap();
        let opts = IngestOptions {
            lod: lod.map(|l| l.parse().unwrap()),
            ..Default::default()
        };
        let out = ingest(&[p], &opts).unwrap();
        out.report.check_invariants().unwrap();
        out
    }

    /// Distinct heights of a building's model corners above its base, in cm.
    fn levels(out: &Ingested, i: usize) -> Vec<i64> {
        let b = &out.buildings[i];
        let m = b
            .mesh
            .as_ref()
            .unwrap_or_else(|| panic!("{} has no model", b.source_id));
        assert!(mesh_report(&m.mesh).watertight, "{}", b.source_id);
        let mut z: Vec<i64> = m
            .mesh
            .positions
            .iter()
            .map(|p| ((p[2] - b.base_z_m) * 100.0).round() as i64)
            .collect();
        z.sort_unstable();
        z.dedup();
        z
    }

    #[test]
    fn roof_tags_of_an_osm_export_give_each_building_its_roof() {
        let features = vec![
            house(0, json!({ "roof:shape": "gabled", "roof:height": "3" })),
            house(1, json!({ "roof:shape": "hipped", "roof:levels": "1" })),
            house(
                2,
                json!({ "roof:shape": "skillion", "roof:angle": "20", "roof:direction": "NE" }),
            ),
            house(3, json!({ "roof:shape": "saltbox" })),
            house(4, json!({ "roof:shape": "gabled", "roof:height": "steep" })),
            house(5, json!({ "roof:shape": "flat" })),
            house(6, json!({})),
            house(
                7,
                json!({ "roof:shape": "pyramidal", "roof:height": "12 m" }),
            ),
            // As GDAL launders OSM keys, and as a shapefile cuts them.
            house(8, json!({ "roof_shape": "hipped", "roof_heigh": 2.5 })),
            house(9, json!({ "roof:shape": "onion", "roof:height": 4 })),
            house(10, json!({ "roof:shape": "gambrel", "roof:height": 3 })),
            house(11, json!({ "roof:shape": "mansard", "roof:height": 3 })),
            house(12, json!({ "roof:shape": "round", "roof:height": 4 })),
            house(13, json!({ "roof:shape": "half-hipped", "roof:height": 4 })),
            house(14, json!({ "roof:shape": "cone", "roof:height": 2 })),
            // 0° is flat, as a roof:height of 0 is.
            house(15, json!({ "roof:shape": "gabled", "roof:angle": "0" })),
            // An orientation that is neither along nor across: said, the ridge along the long side.
            house(
                16,
                json!({ "roof:shape": "gabled", "roof:height": 2, "roof:orientation": "sideways" }),
            ),
            // Three storeys under a roof storey (OSM counts them apart): 12 m, eaves at 9 m.
            house(
                17,
                json!({ "roof:shape": "gabled", "height": null, "building:levels": "3", "roof:levels": "1" }),
            ),
            // 80° over the 4 m half width asks 22.69 m of a 10 m building: lowered, and said.
            house(18, json!({ "roof:shape": "gabled", "roof:angle": "80" })),
            // 40° asks 3.36 m: built as asked, nothing said.
            house(19, json!({ "roof:shape": "gabled", "roof:angle": 40 })),
        ];
        let out = run(features.clone(), Some("2"));
        // Gabled: eaves at 7 m, ridge at 10 m.
        assert_eq!(levels(&out, 0), [0, 700, 1000]);
        // One roof storey of the default 3 m.
        assert_eq!(levels(&out, 1), [0, 700, 1000]);
        // A skillion at 20° descending towards the north-east: the corners at several heights, the highest the top.
        let z = levels(&out, 2);
        assert_eq!((z[0], *z.last().unwrap()), (0, 1000));
        assert!(
            z.len() >= 4,
            "a skillion towards NE has corners at several heights: {z:?}"
        );
        // A 12 m roof on a 10 m building keeps 10 cm of wall (and says so, below).
        assert_eq!(levels(&out, 7), [0, 10, 1000]);
        assert_eq!(levels(&out, 16), [0, 800, 1000]);
        assert_eq!(levels(&out, 17), [0, 900, 1200]);
        assert_eq!(levels(&out, 18), [0, 10, 1000]);
        assert_eq!(levels(&out, 19), [0, 664, 1000]);
        assert_eq!(levels(&out, 8), [0, 750, 1000]);
        // An onion as a dome: eaves at 6 m, then the bands of a quarter circle to the top.
        let z = levels(&out, 9);
        assert_eq!(
            (z[1], z.len(), *z.last().unwrap()),
            (600, 2 + 6, 1000),
            "{z:?}"
        );
        // Gambrel and mansard: eaves at 7 m, the slope changing two thirds of the way up, at 9 m.
        assert_eq!(levels(&out, 10), [0, 700, 900, 1000]);
        assert_eq!(levels(&out, 11), [0, 700, 900, 1000]);
        // Round: eaves at 6 m, then the bands of a quarter circle to the ridge.
        let z = levels(&out, 12);
        assert_eq!(
            (z[1], z.len(), *z.last().unwrap()),
            (600, 2 + 6, 1000),
            "{z:?}"
        );
        // Half-hipped: eaves at 6 m, the gable walls up to 8 m, the ridge at 10 m.
        assert_eq!(levels(&out, 13), [0, 600, 800, 1000]);
        // A cone is the pyramid over the outline's corners.
        assert_eq!(levels(&out, 14), [0, 800, 1000]);
        for i in [3, 5, 6, 15] {
            assert!(out.buildings[i].mesh.is_none(), "{i}");
        }
        // Steep is no height: the default 30° over the 4 m half width, 2.31 m.
        assert_eq!(levels(&out, 4), [0, 769, 1000]);
        let issues: Vec<(&str, IssueReason, &str)> = out
            .report
            .mesh_issues
            .iter()
            .map(|i| (i.feature_id.as_str(), i.reason, i.detail.as_str()))
            .collect();
        let said = |id: &str, reason: IssueReason, text: &str| {
            assert!(
                issues
                    .iter()
                    .any(|i| i.0 == id && i.1 == reason && i.2.contains(text)),
                "{id}: no {reason:?} saying {text:?} in {issues:#?}"
            );
        };
        said(
            "way/3",
            IssueReason::ModelMissing,
            "roof:shape=saltbox: this shape is not modelled",
        );
        said(
            "way/4",
            IssueReason::RoofTagAdjusted,
            "roof:height = \"steep\"",
        );
        said(
            "way/7",
            IssueReason::RoofTagAdjusted,
            "a roof of 12 m on a building 10 m high: lowered to 9.9 m, over walls of 0.1 m",
        );
        said("way/15", IssueReason::ModelMissing, "a roof rise of 0 m");
        said(
            "way/16",
            IssueReason::RoofTagAdjusted,
            "roof:orientation = \"sideways\"",
        );
        said(
            "way/18",
            IssueReason::RoofTagAdjusted,
            "roof:angle = 80° asks a roof of 22.69 m over this outline, on a building 10 m high: lowered to 9.9 m, \
             over walls of 0.1 m",
        );
        assert_eq!(issues.len(), 6, "{issues:#?}");
        assert_eq!(out.report.mesh_lods.get("2"), Some(&16));

        // Roofs are LoD 2: none without --lod or at LoD 1.x; at 2.2 they are the fall-back below it.
        for lod in [None, Some("1.2")] {
            let out = run(features.clone(), lod);
            assert!(out.buildings.iter().all(|b| b.mesh.is_none()), "{lod:?}");
        }
        let out = run(features, Some("2.2"));
        assert_eq!(out.report.mesh_lod_fallbacks, 16);
    }
}
