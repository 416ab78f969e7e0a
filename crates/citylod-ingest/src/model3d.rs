//! A building's 3D model from CityJSON (1.1 §3 geometry objects, 0.8–2.0): the Solid, MultiSolid,
//! CompositeSolid, MultiSurface and CompositeSurface geometries of the building and its BuildingParts
//! at one LoD, merged into one mesh in local ENU metres with a surface kind per triangle.
//! Vertices at identical source positions become one vertex, so touching parts share corners.
//! Triangles wind like their source rings (CCW from outside); bad geometry is reported, never a panic.

use crate::crs::Crs;
use crate::height::MAX_HEIGHT_M;
use crate::lod::{lod_of_geometry, LodKey, Target};
use crate::place::EnuMap;
use crate::report::IssueReason;
use citylod_mesh::simplify::triangulate_polygon_3d;
use citylod_mesh::topology::{mesh_report, part_volumes_m3};
use citylod_model::{BuildingModel, Mesh3d, SurfaceKind};
use serde_json::Value;
use std::collections::HashMap;

type Issue = (IssueReason, String);

/// One surface: rings (exterior first, then holes) of vertex ids into [`RawModel::positions_src`].
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RawSurface {
    pub rings: Vec<Vec<u32>>,
    pub kind: SurfaceKind,
}

/// A building's surfaces at the chosen LoD, before CRS conversion.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RawModel {
    /// Distinct vertices in source CRS (x, y, and z in metres of the data's vertical datum).
    pub positions_src: Vec<[f64; 3]>,
    pub surfaces: Vec<RawSurface>,
    /// The LoD used, as written in the file; the lowest one when parts differ.
    pub lod: String,
    /// Some object used an LoD below the target (the asked one, or the building's highest).
    pub fell_back: bool,
    /// Non-fatal problems: a part with no geometry at or below the target.
    pub notes: Vec<Issue>,
}

/// The mesh of one written building and what went wrong on the way.
#[derive(Debug, Clone, Default)]
pub(crate) struct Meshed {
    pub model: Option<BuildingModel>,
    pub fell_back: bool,
    pub issues: Vec<Issue>,
}

/// CityJSON semantic surface type → [`SurfaceKind`] (see its doc for the table).
pub(crate) fn surface_kind(semantic: Option<&str>) -> SurfaceKind {
    match semantic {
        Some("RoofSurface" | "OuterFloorSurface") => SurfaceKind::Roof,
        Some("WallSurface" | "Window" | "Door") => SurfaceKind::Wall,
        Some("GroundSurface") => SurfaceKind::Ground,
        _ => SurfaceKind::Other,
    }
}

/// The surfaces of `members` (the building first, then its BuildingParts, as `(id, object)`) at the
/// LoD `target` picks, with vertices decoded into `vertices`. `Err` when no member has a 3D geometry
/// at or below the target, or when a chosen geometry is malformed (bad index, non-finite vertex).
pub(crate) fn collect(
    members: &[(&str, &Value)],
    vertices: &[[f64; 3]],
    target: Target,
) -> Result<RawModel, Issue> {
    // Per member: its surface-bearing geometries of LoD ≥ 1, with their LoD.
    let per_member: Vec<Vec<(LodKey, String, &Value)>> = members
        .iter()
        .map(|(_, o)| {
            o.get("geometry")
                .and_then(Value::as_array)
                .into_iter()
                .flatten()
                .filter(|g| {
                    matches!(
                        g.get("type").and_then(Value::as_str),
                        Some(
                            "Solid"
                                | "MultiSolid"
                                | "CompositeSolid"
                                | "MultiSurface"
                                | "CompositeSurface"
                        )
                    )
                })
                .filter_map(|g| lod_of_geometry(g).map(|(k, t)| (k, t, g)))
                .filter(|(k, _, _)| *k >= LodKey::ONE)
                .collect()
        })
        .collect();
    let all: Vec<LodKey> = per_member.iter().flatten().map(|g| g.0).collect();
    if all.is_empty() {
        return Err((
            IssueReason::ModelMissing,
            "no Solid or surface geometry of LoD 1 or more in the building or its parts".into(),
        ));
    }
    let target = target.for_building(&all);
    let mut model = RawModel {
        positions_src: Vec::new(),
        surfaces: Vec::new(),
        lod: String::new(),
        fell_back: false,
        notes: Vec::new(),
    };
    let mut lowest_used: Option<LodKey> = None;
    let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
    for ((name, _), geoms) in members.iter().zip(&per_member) {
        if geoms.is_empty() {
            continue;
        }
        let present: Vec<LodKey> = geoms.iter().map(|g| g.0).collect();
        let Some((used, fell_back)) = target.pick(&present) else {
            let texts: Vec<&str> = geoms.iter().map(|g| g.1.as_str()).collect();
            model.notes.push((
                IssueReason::ModelMissing,
                format!("{name}: no geometry at or below the asked LoD (has {texts:?})"),
            ));
            continue;
        };
        model.fell_back |= fell_back;
        for (_, text, g) in geoms.iter().filter(|g| g.0 == used) {
            if lowest_used.is_none_or(|l| used < l) {
                lowest_used = Some(used);
                model.lod = text.clone();
            }
            let invalid = |e: String| {
                let t = g.get("type").and_then(Value::as_str).unwrap_or("?");
                (
                    IssueReason::ModelInvalid,
                    format!("{name}: LoD {text} {t}: {e}"),
                )
            };
            for s in crate::cityjson::surfaces(g).map_err(invalid)? {
                let rings = s
                    .rings
                    .iter()
                    .map(|r| ring_ids(r, vertices, &mut ids, &mut model.positions_src))
                    .collect::<Result<_, _>>()
                    .map_err(invalid)?;
                model.surfaces.push(RawSurface {
                    rings,
                    kind: surface_kind(s.semantic),
                });
            }
        }
    }
    if model.surfaces.is_empty() {
        let mut texts: Vec<&str> = per_member.iter().flatten().map(|g| g.1.as_str()).collect();
        texts.sort_unstable();
        texts.dedup();
        return Err((
            IssueReason::ModelMissing,
            format!("no surfaces at or below the asked LoD (the building has LoD {texts:?})"),
        ));
    }
    Ok(model)
}

/// One ring's vertex ids: vertices at identical positions get one id, numbered in order of use.
fn ring_ids(
    ring: &Value,
    vertices: &[[f64; 3]],
    ids: &mut HashMap<[u64; 3], u32>,
    positions: &mut Vec<[f64; 3]>,
) -> Result<Vec<u32>, String> {
    let ring = ring
        .as_array()
        .ok_or("a ring is not an array of vertex indices")?;
    ring.iter()
        .map(|v| {
            let p = crate::cityjson::vertex(v, vertices)?;
            if !p.iter().all(|c| c.is_finite()) {
                return Err(format!("vertex {v} is not finite: {p:?}"));
            }
            // +0.0 turns −0.0 into 0.0 so equal positions have equal bits.
            let key = p.map(|c| (c + 0.0).to_bits());
            let next = positions.len() as u32;
            Ok(*ids.entry(key).or_insert_with(|| {
                positions.push(*p);
                next
            }))
        })
        .collect()
}

/// Source-CRS vertices → (lon°, lat°, h m); the height is taken as it is, like footprint heights.
pub(crate) fn geolocate(model: &RawModel, crs: &Crs) -> Result<Vec<[f64; 3]>, Issue> {
    model
        .positions_src
        .iter()
        .map(|p| {
            crs.to_lon_lat(p[0], p[1])
                .map(|(lon, lat)| [lon, lat, p[2]])
                .map_err(|e| {
                    (
                        IssueReason::ModelInvalid,
                        format!(
                            "vertex ({}, {}, {}) in {}: {e}",
                            p[0], p[1], p[2], crs.label
                        ),
                    )
                })
        })
        .collect()
}

/// Triangulates every surface (with holes) in ENU metres and merges them into one mesh.
/// Surfaces with fewer than 3 distinct points or that give no triangle are left out (and holes with
/// fewer than 3 distinct points dropped), reported as one `ModelSurfaceDropped` note;
/// `Err(ModelInvalid)` when nothing is left.
pub(crate) fn triangulate(
    model: &RawModel,
    lon_lat_h: &[[f64; 3]],
    enu: &EnuMap,
) -> Result<(BuildingModel, Vec<Issue>), Issue> {
    debug_assert_eq!(lon_lat_h.len(), model.positions_src.len());
    let pos_enu: Vec<[f64; 3]> = lon_lat_h
        .iter()
        .map(|p| enu.geodetic_to_enu(p[0], p[1], p[2]))
        .collect();
    let mut triangles = Vec::new();
    let mut surfaces = Vec::new();
    let (mut too_few, mut no_triangles, mut holes_dropped) = (0usize, 0usize, 0usize);
    for s in &model.surfaces {
        let mut rings: Vec<Vec<u32>> = Vec::with_capacity(s.rings.len());
        for (k, r) in s.rings.iter().enumerate() {
            let r = clean_ring(r);
            if distinct(&r) >= 3 {
                rings.push(r);
            } else if k == 0 {
                break;
            } else {
                holes_dropped += 1;
            }
        }
        if rings.is_empty() {
            too_few += 1;
            continue;
        }
        let pts: Vec<Vec<[f64; 3]>> = rings
            .iter()
            .map(|r| r.iter().map(|&i| pos_enu[i as usize]).collect())
            .collect();
        let flat: Vec<u32> = rings.concat();
        let before = triangles.len();
        for t in triangulate_polygon_3d(&pts) {
            let t = t.map(|i| flat[i as usize]);
            if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                triangles.push(t);
                surfaces.push(s.kind);
            }
        }
        no_triangles += usize::from(triangles.len() == before);
    }
    if triangles.is_empty() {
        return Err((
            IssueReason::ModelInvalid,
            format!(
                "none of the {} surfaces gave a triangle ({too_few} with fewer than 3 distinct points)",
                model.surfaces.len()
            ),
        ));
    }
    let mut notes = Vec::new();
    if too_few + no_triangles + holes_dropped > 0 {
        notes.push((
            IssueReason::ModelSurfaceDropped,
            format!(
                "{} of {} surfaces left out ({too_few} with fewer than 3 distinct points, {no_triangles} \
                 without area or self-intersecting); {holes_dropped} degenerate hole(s) dropped",
                too_few + no_triangles,
                model.surfaces.len()
            ),
        ));
    }
    // Keep only the vertices triangles use, numbered in order of first use.
    let mut new_id = vec![u32::MAX; pos_enu.len()];
    let mut positions = Vec::new();
    for t in &mut triangles {
        for i in t.iter_mut() {
            if new_id[*i as usize] == u32::MAX {
                new_id[*i as usize] = positions.len() as u32;
                positions.push(pos_enu[*i as usize]);
            }
            *i = new_id[*i as usize];
        }
    }
    // A model taller than any building, or with a vertex off the globe, is a data error (one bad vertex, a wrong
    // scale): the building keeps its prism rather than a mesh reaching into space, which a simplifier sectioning it
    // metre by metre would never finish.
    let (z_lo, z_hi) = positions
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[2]), hi.max(p[2]))
        });
    if let Some(p) = positions.iter().find(|p| !p.iter().all(|c| c.is_finite())) {
        return Err((
            IssueReason::ModelInvalid,
            format!("a vertex lies at {p:?} in the local frame, not a finite point"),
        ));
    }
    if z_hi - z_lo > MAX_HEIGHT_M {
        return Err((
            IssueReason::ModelInvalid,
            format!(
                "the model spans {:.0} m from its lowest vertex to its highest, more than the {MAX_HEIGHT_M} m a \
                 building may be",
                z_hi - z_lo
            ),
        ));
    }
    let mut mesh = Mesh3d {
        positions,
        triangles,
    };
    let shape = mesh_report(&mesh);
    if shape.watertight && shape.orientation_consistent {
        let (turned, parts) = turn_parts_inside_out(&mut mesh);
        if turned > 0 {
            let which = if turned == parts {
                "every triangle was turned".to_string()
            } else {
                format!("{turned} of its {parts} parts were turned")
            };
            notes.push((
                IssueReason::ModelTurnedOutward,
                format!(
                    "the closed model of {} triangles enclosed a negative volume (faces pointing inwards): {which}",
                    mesh.triangles.len()
                ),
            ));
        }
    }
    let built = BuildingModel {
        mesh,
        surfaces,
        lod: model.lod.clone(),
    };
    debug_assert_eq!(built.check_invariants(), Ok(()));
    Ok((built, notes))
}

/// Turns every connected part of a closed mesh whose faces point the wrong way. A part inside an even number of other
/// parts (none: a solid's outer shell) should enclose a positive volume and is turned when it encloses a negative
/// one. A part inside an odd number may be the shell of a cavity, which points into the cavity (a negative volume),
/// or a part overlapping a larger one (positive): it is turned only when positive inside a part that is negative,
/// as in a solid with a cavity wound inside out as a whole. Returns the parts turned and the parts in all.
fn turn_parts_inside_out(mesh: &mut Mesh3d) -> (usize, usize) {
    let parts =
        citylod_mesh::simplify::components::components(mesh.positions.len(), &mesh.triangles);
    let volumes = part_volumes_m3(mesh, &parts);
    let mut boxes = vec![[[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]]; parts.count];
    let mut a_vertex = vec![None; parts.count];
    for (v, (p, &c)) in mesh.positions.iter().zip(&parts.of_vertex).enumerate() {
        if let Some(b) = boxes.get_mut(c as usize) {
            for k in 0..3 {
                b[0][k] = b[0][k].min(p[k]);
                b[1][k] = b[1][k].max(p[k]);
            }
            a_vertex[c as usize].get_or_insert(v);
        }
    }
    let within = |a: &[[f64; 3]; 2], b: &[[f64; 3]; 2]| {
        (0..3).all(|k| b[0][k] <= a[0][k] && a[1][k] <= b[1][k])
    };
    let mut triangles_of: Vec<Vec<usize>> = vec![Vec::new(); parts.count];
    for (t, &c) in parts.of_triangle.iter().enumerate() {
        triangles_of[c as usize].push(t);
    }
    let encloses = |j: usize, p: [f64; 3]| {
        let crossings = triangles_of[j]
            .iter()
            .filter(|&&t| ray_crosses(p, mesh.triangles[t].map(|v| mesh.positions[v as usize])))
            .count();
        crossings % 2 == 1
    };
    // Below a cubic millimetre the sign says nothing.
    let signed = |i: usize| volumes[i].abs() > 1e-9;
    let turn: Vec<bool> = (0..parts.count)
        .map(|i| {
            let Some(v) = a_vertex[i].filter(|_| signed(i)) else {
                return false;
            };
            let p = mesh.positions[v];
            let around: Vec<usize> = (0..parts.count)
                .filter(|&j| j != i && within(&boxes[i], &boxes[j]) && encloses(j, p))
                .collect();
            if around.len().is_multiple_of(2) {
                volumes[i] < 0.0
            } else {
                // A cavity's shell points inwards; one that points outwards is turned only inside a shell that
                // points inwards too (a solid with a cavity wound inside out as a whole). Parts that overlap,
                // one inside the other (a dormer inside its roof's solid), both point outwards and stay.
                volumes[i] > 0.0 && around.iter().any(|&j| signed(j) && volumes[j] < 0.0)
            }
        })
        .collect();
    for (t, &c) in mesh.triangles.iter_mut().zip(&parts.of_triangle) {
        if turn[c as usize] {
            t.swap(1, 2);
        }
    }
    (turn.iter().filter(|&&t| t).count(), parts.count)
}

/// Whether the ray from `p` in a fixed direction no building's edges follow crosses triangle `t` (Möller and
/// Trumbore's test; a crossing at `p` itself does not count).
fn ray_crosses(p: [f64; 3], t: [[f64; 3]; 3]) -> bool {
    const DIR: [f64; 3] = [0.8017837, 0.5345225, 0.2672612];
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (e1, e2) = (sub(t[1], t[0]), sub(t[2], t[0]));
    let h = cross(DIR, e2);
    let det = dot(e1, h);
    if det.abs() < 1e-12 {
        return false; // the ray runs along the triangle's plane
    }
    let s = sub(p, t[0]);
    let u = dot(s, h) / det;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = cross(s, e1);
    let v = dot(DIR, q) / det;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    dot(e2, q) / det > 1e-9
}

/// The whole 3D path of one building once its frame is known: the reader's result, CRS conversion
/// (done earlier, `lon_lat_h`) and triangulation.
pub(crate) fn mesh(
    raw: Option<&Result<RawModel, Issue>>,
    lon_lat_h: Option<&Result<Vec<[f64; 3]>, Issue>>,
    enu: &EnuMap,
) -> Meshed {
    let mut out = Meshed::default();
    let model = match raw {
        None => return out,
        Some(Err(issue)) => {
            out.issues.push(issue.clone());
            return out;
        }
        Some(Ok(m)) => m,
    };
    out.issues.extend(model.notes.iter().cloned());
    let built = match lon_lat_h {
        Some(Ok(ll)) => triangulate(model, ll, enu),
        Some(Err(issue)) => Err(issue.clone()),
        None => {
            debug_assert!(false, "a raw model without its geolocated vertices");
            return out;
        }
    };
    match built {
        // A model with no height (every vertex within FLAT_M, as a building flattened onto one z) would draw the
        // building flat at full detail: its prism stands for it, said.
        Ok((model3d, _)) if flat(&model3d) => out.issues.push((
            IssueReason::ModelInvalid,
            format!(
                "a flat 3D model (its vertices within {} m in height): drawn as its prism",
                crate::surface_model::FLAT_M
            ),
        )),
        Ok((model3d, notes)) => {
            out.model = Some(model3d);
            out.fell_back = model.fell_back;
            out.issues.extend(notes);
        }
        Err(issue) => out.issues.push(issue),
    }
    out
}

/// Whether a model's vertices all lie within [`crate::surface_model::FLAT_M`] of one height.
fn flat(m: &BuildingModel) -> bool {
    let (lo, hi) = m
        .mesh
        .positions
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
            (l.min(p[2]), h.max(p[2]))
        });
    let span = hi - lo;
    span.is_nan() || span < crate::surface_model::FLAT_M
}

/// Drops consecutive repeated vertices and a closing repeat of the first.
fn clean_ring(r: &[u32]) -> Vec<u32> {
    let mut r = r.to_vec();
    r.dedup();
    while r.len() > 1 && r.first() == r.last() {
        r.pop();
    }
    r
}

fn distinct(r: &[u32]) -> usize {
    let mut s = r.to_vec();
    s.sort_unstable();
    s.dedup();
    s.len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ingest, IngestOptions, Ingested, LodChoice};
    use citylod_mesh::simplify::components::components;
    use citylod_mesh::topology::signed_volume_m3;
    use serde_json::json;

    /// Corners of a box [x0, x1] × [0, 3] × [0, 5] m, as integer vertices (scale 0.001).
    fn box_vertices(x0: i64, x1: i64) -> Vec<[i64; 3]> {
        let (a, b) = (x0 * 1000, x1 * 1000);
        vec![
            [a, 0, 0],
            [b, 0, 0],
            [b, 3000, 0],
            [a, 3000, 0],
            [a, 0, 5000],
            [b, 0, 5000],
            [b, 3000, 5000],
            [a, 3000, 5000],
        ]
    }

    /// A closed box Solid over vertices `o..o+8` (see [`box_vertices`]), faces CCW from outside,
    /// with ground, roof and wall semantics.
    fn box_solid(o: u64, lod: Value) -> Value {
        let f = |v: [u64; 4]| json!([v.map(|i| i + o)]);
        json!({"type": "Solid", "lod": lod, "boundaries": [[
            f([0, 3, 2, 1]), f([4, 5, 6, 7]), f([0, 1, 5, 4]), f([1, 2, 6, 5]), f([2, 3, 7, 6]), f([3, 0, 4, 7])
        ]], "semantics": {"surfaces": [{"type": "GroundSurface"}, {"type": "RoofSurface"},
            {"type": "WallSurface"}], "values": [[0, 1, 2, 2, 2, 2]]}})
    }

    /// A Solid with every face's ring reversed, in every shell: wound the other way.
    fn wound_back(mut solid: Value) -> Value {
        for shell in solid["boundaries"].as_array_mut().unwrap() {
            for face in shell.as_array_mut().unwrap() {
                face[0].as_array_mut().unwrap().reverse();
            }
        }
        solid
    }

    /// A CityJSON document near Delft (EPSG:7415) with these objects and integer vertices.
    fn doc(version: &str, objects: Value, vertices: &[[i64; 3]]) -> Value {
        let mut d = json!({"type": "CityJSON", "version": version,
            "transform": {"scale": [0.001, 0.001, 0.001], "translate": [85000.0, 446000.0, -1.0]},
            "CityObjects": objects, "vertices": vertices});
        if version != "0.8" {
            d["metadata"] =
                json!({"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/7415"});
        }
        d
    }

    /// The one issue of `issues`, which must be of feature `id` and `reason` with `text` in its detail.
    fn only_issue(
        issues: &[crate::report::FeatureIssue],
        id: &str,
        reason: IssueReason,
        text: &str,
    ) {
        assert_eq!(issues.len(), 1, "{issues:?}");
        let i = &issues[0];
        assert_eq!((i.feature_id.as_str(), i.reason), (id, reason));
        assert!(i.detail.contains(text), "{}", i.detail);
    }

    fn run(d: &Value, lod: Option<&str>) -> Ingested {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("city.json");
        std::fs::write(&p, d.to_string()).unwrap();
        let opts = IngestOptions {
            crs: (d["version"] == "0.8").then(|| "EPSG:28992".into()),
            lod: lod.map(|l| l.parse().unwrap()),
            ..Default::default()
        };
        let out = ingest(&[p], &opts).unwrap();
        out.report.check_invariants().unwrap();
        out
    }

    fn count(m: &BuildingModel, k: SurfaceKind) -> usize {
        m.surfaces.iter().filter(|&&s| s == k).count()
    }

    #[test]
    fn cube_solid_becomes_a_closed_outward_mesh_on_the_footprint() {
        let d = doc(
            "2.0",
            json!({"B": {"type": "Building", "geometry": [box_solid(0, json!("2.2"))]}}),
            &box_vertices(0, 4),
        );
        let out = run(&d, Some("2.2"));
        let b = &out.buildings[0];
        let m = b.mesh.as_ref().expect("a mesh");
        m.check_invariants().unwrap();
        assert_eq!(m.lod, "2.2");
        assert_eq!((m.mesh.positions.len(), m.mesh.triangles.len()), (8, 12));
        let r = mesh_report(&m.mesh);
        assert!(
            r.watertight && r.orientation_consistent && r.degenerate == 0,
            "{r:?}"
        );
        let v = signed_volume_m3(&m.mesh);
        assert!(
            (v - 60.0).abs() < 0.05,
            "volume {v} m³ (4 × 3 × 5, positive = outward)"
        );
        assert_eq!(count(m, SurfaceKind::Ground), 2);
        assert_eq!(count(m, SurfaceKind::Roof), 2);
        assert_eq!(count(m, SurfaceKind::Wall), 8);
        // Same frame as the footprint: xy on its corners, lowest z on its base.
        let min_z = m
            .mesh
            .positions
            .iter()
            .map(|p| p[2])
            .fold(f64::INFINITY, f64::min);
        assert!(
            (min_z - b.base_z_m).abs() < 1e-3,
            "{min_z} vs base {}",
            b.base_z_m
        );
        for c in &b.footprint.0[0].exterior().0 {
            let near = m
                .mesh
                .positions
                .iter()
                .any(|p| (p[0] - c.x).hypot(p[1] - c.y) < 1e-6);
            assert!(near, "footprint corner {c:?} is not a mesh corner");
        }
        let r = &out.report;
        assert_eq!(
            (
                r.buildings_with_mesh,
                r.mesh_triangles,
                r.mesh_lod_fallbacks
            ),
            (1, 12, 0)
        );
        assert_eq!(r.mesh_lods.get("2.2"), Some(&1));
        assert!(r.mesh_issues.is_empty(), "{:?}", r.mesh_issues);
        assert_eq!(r.mesh_lod_asked.as_deref(), Some("2.2"));
    }

    #[test]
    fn without_lod_option_there_is_no_mesh_and_the_footprint_is_unchanged() {
        let d = doc(
            "2.0",
            json!({"B": {"type": "Building", "geometry": [box_solid(0, json!("2.2"))]}}),
            &box_vertices(0, 4),
        );
        let (plain, with) = (run(&d, None), run(&d, Some("highest")));
        assert!(plain.buildings[0].mesh.is_none());
        assert_eq!(plain.report.buildings_with_mesh, 0);
        assert_eq!(plain.report.mesh_lod_asked, None);
        let (a, b) = (&plain.buildings[0], &with.buildings[0]);
        assert_eq!(
            (&a.footprint, a.base_z_m, a.height_m),
            (&b.footprint, b.base_z_m, b.height_m)
        );
        assert!(b.mesh.is_some());
    }

    #[test]
    fn multisurface_hole_is_left_open_and_its_area_kept() {
        // A 10 m × 10 m roof from z = 3 to 4 m (a flat one alone would be no model) with a 2 m × 2 m hole (ring
        // CW), LoD 2 as a number.
        let v: Vec<[i64; 3]> = [
            [0, 0],
            [10, 0],
            [10, 10],
            [0, 10],
            [4, 4],
            [4, 6],
            [6, 6],
            [6, 4],
        ]
        .iter()
        .map(|p| [p[0] * 1000, p[1] * 1000, 3000 + p[0] * 100])
        .collect();
        let g = json!({"type": "MultiSurface", "lod": 2,
            "boundaries": [[[0, 1, 2, 3], [4, 5, 6, 7]]],
            "semantics": {"surfaces": [{"type": "RoofSurface"}], "values": [0]}});
        let out = run(
            &doc(
                "1.1",
                json!({"B": {"type": "Building", "geometry": [g]}}),
                &v,
            ),
            Some("2"),
        );
        let m = out.buildings[0].mesh.as_ref().unwrap();
        let p = &m.mesh.positions;
        let mut area = 0.0;
        for t in &m.mesh.triangles {
            let [a, b, c] = t.map(|i| p[i as usize]);
            let z = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
            assert!(z > 0.0, "roof triangle faces down");
            area += z / 2.0;
            let centre = [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0];
            let (lo, hi) = (p[4], p[6]); // the hole's corners
            let in_hole =
                (lo[0]..hi[0]).contains(&centre[0]) && (lo[1]..hi[1]).contains(&centre[1]);
            assert!(!in_hole, "a triangle covers the hole");
        }
        assert!((area - 96.0).abs() < 0.05, "{area}");
        assert_eq!(m.lod, "2");
        assert_eq!(count(m, SurfaceKind::Roof), m.surfaces.len());
    }

    #[test]
    fn a_flat_model_is_no_model_and_said() {
        // A building whose only LoD 2 geometry is one horizontal roof (every vertex at z = 3 m, as a building
        // flattened onto one height): drawn as its prism, with the reason.
        let v: Vec<[i64; 3]> = [[0, 0], [10, 0], [10, 10], [0, 10]]
            .iter()
            .map(|p| [p[0] * 1000, p[1] * 1000, 3000])
            .collect();
        let g = json!({"type": "MultiSurface", "lod": 2, "boundaries": [[[0, 1, 2, 3]]]});
        let out = run(
            &doc(
                "2.0",
                json!({"B": {"type": "Building", "geometry": [g]}}),
                &v,
            ),
            Some("2"),
        );
        assert!(out.buildings[0].mesh.is_none());
        let issue = &out.report.mesh_issues[0];
        assert_eq!(issue.reason, IssueReason::ModelInvalid);
        assert!(issue.detail.contains("a flat 3D model"), "{}", issue.detail);
    }

    #[test]
    fn building_parts_merge_and_touching_parts_share_corners() {
        // Two boxes side by side; the second lists the shared corners again under new indices.
        let mut v = box_vertices(0, 4);
        v.extend(box_vertices(4, 9));
        let d = doc(
            "2.0",
            json!({
                "B": {"type": "Building", "children": ["P1", "P2"],
                      "geometry": [{"type": "MultiSurface", "lod": "0", "boundaries": [[[0, 1, 2, 3]]]}]},
                "P1": {"type": "BuildingPart", "parents": ["B"], "geometry": [box_solid(0, json!("2.2"))]},
                "P2": {"type": "BuildingPart", "parents": ["B"], "geometry": [box_solid(8, json!("2.2"))]}
            }),
            &v,
        );
        let out = run(&d, Some("highest"));
        assert_eq!(out.buildings.len(), 1);
        let m = out.buildings[0].mesh.as_ref().unwrap();
        assert_eq!(m.mesh.triangles.len(), 24);
        assert_eq!(
            m.mesh.positions.len(),
            12,
            "the 4 shared corners are merged"
        );
        assert_eq!(
            components(m.mesh.positions.len(), &m.mesh.triangles).count,
            1
        );
        let v = signed_volume_m3(&m.mesh);
        assert!((v - 135.0).abs() < 0.1, "{v}");
    }

    #[test]
    fn composite_solid_keeps_per_solid_semantics() {
        let mut v = box_vertices(0, 4);
        v.extend(box_vertices(4, 9));
        let (a, b) = (box_solid(0, json!("2.2")), box_solid(8, json!("2.2")));
        let g = json!({"type": "CompositeSolid", "lod": "2.2",
            "boundaries": [a["boundaries"], b["boundaries"]],
            "semantics": {"surfaces": [{"type": "GroundSurface"}, {"type": "RoofSurface"},
                {"type": "WallSurface"}, {"type": "ClosureSurface"}],
                "values": [[[0, 1, 2, 2, 2, 2]], [[0, 1, 3, 3, 3, 3]]]}});
        let out = run(
            &doc(
                "1.1",
                json!({"B": {"type": "Building", "geometry": [g]}}),
                &v,
            ),
            Some("highest"),
        );
        let m = out.buildings[0].mesh.as_ref().unwrap();
        assert_eq!((m.mesh.positions.len(), m.mesh.triangles.len()), (12, 24));
        assert_eq!(count(m, SurfaceKind::Wall), 8);
        assert_eq!(count(m, SurfaceKind::Other), 8);
        assert_eq!(count(m, SurfaceKind::Roof), 4);
    }

    #[test]
    fn cityjson_08_numeric_lods_fall_back_below_and_never_above() {
        let d = doc(
            "0.8",
            json!({"B": {"type": "Building", "geometry": [box_solid(0, json!(2))]}}),
            &box_vertices(0, 4),
        );
        let r = run(&d, Some("2.2")).report;
        assert_eq!((r.buildings_with_mesh, r.mesh_lod_fallbacks), (1, 1));
        assert_eq!(r.mesh_lods.get("2"), Some(&1));
        let r = run(&d, Some("highest")).report;
        assert_eq!((r.buildings_with_mesh, r.mesh_lod_fallbacks), (1, 0));
        let out = run(&d, Some("1.3"));
        assert_eq!(out.buildings.len(), 1, "the building keeps its footprint");
        assert!(out.buildings[0].mesh.is_none());
        assert_eq!(out.report.mesh_issues[0].reason, IssueReason::ModelMissing);
        assert_eq!(out.report.mesh_issues[0].feature_id, "B");
    }

    #[test]
    fn with_highest_a_part_lacking_it_uses_its_own_highest_and_counts_as_fallback() {
        let mut v = box_vertices(0, 4);
        v.extend(box_vertices(4, 9));
        let d = doc(
            "2.0",
            json!({
                "B": {"type": "Building", "children": ["P1", "P2"]},
                "P1": {"type": "BuildingPart", "parents": ["B"],
                       "geometry": [box_solid(0, json!("1.2")), box_solid(0, json!("2.2"))]},
                "P2": {"type": "BuildingPart", "parents": ["B"], "geometry": [box_solid(8, json!("1.2"))]}
            }),
            &v,
        );
        let out = run(&d, Some("highest"));
        let m = out.buildings[0].mesh.as_ref().unwrap();
        assert_eq!(m.mesh.triangles.len(), 24, "both parts are in the mesh");
        assert_eq!(m.lod, "1.2", "the lowest LoD used names the mesh");
        assert_eq!(out.report.mesh_lod_fallbacks, 1);
    }

    #[test]
    fn bad_vertex_index_keeps_the_footprint_and_records_the_mesh_issue() {
        let mut g = box_solid(0, json!("2.2"));
        g["boundaries"][0][1][0][2] = json!(99);
        let d = doc(
            "2.0",
            json!({
                "A": {"type": "Building", "geometry": [box_solid(0, json!("1.2")), g]},
                "B": {"type": "Building", "geometry": [box_solid(0, json!("2.2"))]}
            }),
            &box_vertices(0, 4),
        );
        let out = run(&d, Some("2.2"));
        assert_eq!(out.buildings.len(), 2);
        let a = out.buildings.iter().find(|b| b.source_id == "A").unwrap();
        assert!(a.mesh.is_none() && a.height_m > 0.0);
        let r = &out.report;
        assert_eq!(r.buildings_with_mesh, 1);
        assert_eq!(r.mesh_issues.len(), 1, "{:?}", r.mesh_issues);
        let i = &r.mesh_issues[0];
        assert_eq!(
            (i.feature_id.as_str(), i.reason),
            ("A", IssueReason::ModelInvalid)
        );
        assert!(
            i.detail.contains("99") && i.detail.contains("2.2"),
            "{}",
            i.detail
        );
        assert_eq!(r.mesh_issues_by_reason.get("model_invalid"), Some(&1));
    }

    /// One roof corner 7.6 million km up (found by fuzzing: the profile simplifier, sectioning the model metre by
    /// metre, never finished): the model is refused, the building keeps its prism, the reason names the span.
    #[test]
    fn a_model_taller_than_any_building_keeps_the_prism() {
        let mut v = box_vertices(0, 4);
        v[6][2] = 7_589_093_562_108;
        let d = doc(
            "2.0",
            json!({
                "A": {"type": "Building", "geometry": [box_solid(0, json!("2.2"))]},
                "B": {"type": "Building", "geometry": [box_solid(8, json!("2.2"))]}
            }),
            &[v, box_vertices(10, 14)].concat(),
        );
        let out = run(&d, Some("2.2"));
        assert_eq!(out.buildings.len(), 2);
        let a = out.buildings.iter().find(|b| b.source_id == "A").unwrap();
        assert!(a.mesh.is_none() && a.height_m > 0.0 && a.height_m <= MAX_HEIGHT_M);
        let b = out.buildings.iter().find(|b| b.source_id == "B").unwrap();
        assert!(b.mesh.is_some());
        only_issue(
            &out.report.mesh_issues,
            "A",
            IssueReason::ModelInvalid,
            "more than the 1000 m",
        );
        // 999 m is still a building.
        let mut v = box_vertices(0, 4);
        v[6][2] = 999_000;
        let d = doc(
            "2.0",
            json!({"A": {"type": "Building", "geometry": [box_solid(0, json!("2.2"))]}}),
            &v,
        );
        assert!(run(&d, Some("2.2")).buildings[0].mesh.is_some());
    }

    /// A box Solid whose faces all point inwards (found by fuzzing: back-face culling clients would not draw it,
    /// and the profile simplifier found no section of it) is turned outward and the turn reported.
    #[test]
    fn a_solid_wound_inside_out_is_turned_outward() {
        let g = wound_back(box_solid(0, json!("2.2")));
        let d = doc(
            "2.0",
            json!({"A": {"type": "Building", "geometry": [g]}}),
            &box_vertices(0, 4),
        );
        let out = run(&d, Some("2.2"));
        let m = &out.buildings[0].mesh.as_ref().expect("a mesh").mesh;
        assert!(signed_volume_m3(m) > 59.9, "{}", signed_volume_m3(m));
        let i = &out.report.mesh_issues;
        assert_eq!(i.len(), 1, "{i:?}");
        assert_eq!(i[0].reason, IssueReason::ModelTurnedOutward);
        // Two parts side by side, one wound inwards and twice the other's size: that one is turned (a rule on the
        // whole mesh's volume would turn the right part inside out instead), and the turn reported.
        let right = box_solid(8, json!("2.2"));
        let wrong = wound_back(box_solid(0, json!("2.2")));
        let two = json!({"type": "MultiSolid", "lod": "2.2",
            "boundaries": [wrong["boundaries"].clone(), right["boundaries"].clone()]});
        let d = doc(
            "2.0",
            json!({"A": {"type": "Building", "geometry": [two]}}),
            &[box_vertices(0, 8), box_vertices(10, 14)].concat(),
        );
        let out = run(&d, Some("2.2"));
        only_issue(
            &out.report.mesh_issues,
            "A",
            IssueReason::ModelTurnedOutward,
            "1 of its 2 parts",
        );
        let m = &out.buildings[0].mesh.as_ref().expect("a mesh").mesh;
        // 120 m³ and 60 m³, both outward (to the projection's scale, RD to the local frame).
        assert!(
            (signed_volume_m3(m) - 180.0).abs() < 0.2,
            "{}",
            signed_volume_m3(m)
        );
        // A solid with a cavity: its inner shell points into the cavity (a negative volume) inside the outer shell,
        // so it stays as it is; the same solid wound inside out as a whole has both shells turned.
        let mut inner_vertices = box_vertices(1, 3);
        for v in &mut inner_vertices {
            v[1] = if v[1] == 0 { 1000 } else { 2000 };
            v[2] = if v[2] == 0 { 1000 } else { 4000 };
        }
        let outer = box_solid(0, json!("2.2"));
        let inner = wound_back(box_solid(8, json!("2.2")));
        let cavity = json!({"type": "Solid", "lod": "2.2",
            "boundaries": [outer["boundaries"][0].clone(), inner["boundaries"][0].clone()]});
        let inverted = wound_back(cavity.clone());
        // The inner box as a part of its own, wound outwards like the outer one: parts that overlap (Den Haag has
        // dormers inside their roof's solid), not a cavity; nothing is turned.
        let inner_out = wound_back(inner.clone());
        let overlapping = json!({"type": "MultiSolid", "lod": "2.2",
            "boundaries": [outer["boundaries"].clone(), inner_out["boundaries"].clone()]});
        let d = doc(
            "2.0",
            json!({"A": {"type": "Building", "geometry": [overlapping]}}),
            &[box_vertices(0, 4), inner_vertices.clone()].concat(),
        );
        let out = run(&d, Some("2.2"));
        assert!(
            out.report.mesh_issues.is_empty(),
            "{:?}",
            out.report.mesh_issues
        );
        let m = &out.buildings[0].mesh.as_ref().expect("a mesh").mesh;
        assert!(
            (signed_volume_m3(m) - 66.0).abs() < 0.1,
            "{}",
            signed_volume_m3(m)
        );
        for (solid, turned) in [(cavity, 0), (inverted, 2)] {
            let d = doc(
                "2.0",
                json!({"A": {"type": "Building", "geometry": [solid]}}),
                &[box_vertices(0, 4), inner_vertices.clone()].concat(),
            );
            let out = run(&d, Some("2.2"));
            let i = &out.report.mesh_issues;
            assert_eq!(i.len(), usize::from(turned > 0), "{i:?}");
            if turned > 0 {
                assert!(
                    i[0].detail.contains("every triangle was turned"),
                    "{}",
                    i[0].detail
                );
            }
            let m = &out.buildings[0].mesh.as_ref().expect("a mesh").mesh;
            // 60 m³ less the 2 × 1 × 3 m cavity.
            assert!(
                (signed_volume_m3(m) - 54.0).abs() < 0.1,
                "{}",
                signed_volume_m3(m)
            );
        }
        // An L-shaped part and a small box in its notch, outside it but inside its box: the small box is not a
        // cavity. Wound outward it is left alone; wound inwards it is turned.
        let mut l_vertices: Vec<[i64; 3]> = Vec::new();
        for z in [0, 5000] {
            for (x, y) in [(0, 0), (4, 0), (4, 1), (1, 1), (1, 3), (0, 3)] {
                l_vertices.push([x * 1000, y * 1000, z]);
            }
        }
        let mut notch = box_vertices(2, 3);
        for v in &mut notch {
            v[1] = if v[1] == 0 { 2000 } else { 2800 };
            v[2] = if v[2] == 0 { 0 } else { 2000 };
        }
        let face = |v: &[u64]| json!([v]);
        let mut l_faces = vec![face(&[5, 4, 3, 2, 1, 0]), face(&[6, 7, 8, 9, 10, 11])];
        for k in 0..6u64 {
            let n = (k + 1) % 6;
            l_faces.push(face(&[k, n, n + 6, k + 6]));
        }
        for (wound_in, turned) in [(false, 0), (true, 1)] {
            let small = box_solid(12, json!("2.2"));
            let small = if wound_in { wound_back(small) } else { small };
            let two = json!({"type": "MultiSolid", "lod": "2.2",
                "boundaries": [[l_faces.clone()], small["boundaries"].clone()]});
            let d = doc(
                "2.0",
                json!({"A": {"type": "Building", "geometry": [two]}}),
                &[l_vertices.clone(), notch.clone()].concat(),
            );
            let out = run(&d, Some("2.2"));
            let i = &out.report.mesh_issues;
            assert_eq!(i.len(), turned, "{i:?}");
            let m = &out.buildings[0].mesh.as_ref().expect("a mesh").mesh;
            // The L: 1 × 4 + 1 × 2 m² × 5 m; the small box 1 × 0.8 × 2 m, outward either way.
            assert!(
                (signed_volume_m3(m) - 31.6).abs() < 0.1,
                "{}",
                signed_volume_m3(m)
            );
        }
        // Wound outward, nothing is turned or reported.
        let d = doc(
            "2.0",
            json!({"A": {"type": "Building", "geometry": [box_solid(0, json!("2.2"))]}}),
            &box_vertices(0, 4),
        );
        let out = run(&d, Some("2.2"));
        assert!(out.report.mesh_issues.is_empty());
        assert!(signed_volume_m3(&out.buildings[0].mesh.as_ref().unwrap().mesh) > 59.9);
    }

    /// A building standing 10⁹ m up (a bad vertex or translate, found by fuzzing) put the whole tileset's frame
    /// there, and the error blamed the others' extent ("up to inf km", "0 km away"). It is skipped, named.
    /// Building A on the ground and B 10⁹ m up, with these attributes.
    fn one_off_the_globe(b_attributes: Value) -> Value {
        let mut far = box_vertices(10, 14);
        for v in &mut far {
            v[2] += 1_000_000_000_000;
        }
        doc(
            "2.0",
            json!({
                "A": {"type": "Building", "geometry": [box_solid(0, json!("2.2"))]},
                "B": {"type": "Building", "geometry": [box_solid(8, json!("2.2"))], "attributes": b_attributes}
            }),
            &[box_vertices(0, 4), far].concat(),
        )
    }

    #[test]
    fn a_building_whose_ground_is_off_the_globe_is_skipped_by_name() {
        let out = run(&one_off_the_globe(json!({})), None);
        assert_eq!(out.buildings.len(), 1);
        assert_eq!(out.buildings[0].source_id, "A");
        only_issue(
            &out.report.skipped,
            "B",
            IssueReason::CoordinateOutOfRange,
            "at 999999999.0 m",
        );
    }

    /// The same building off the globe, but with a usable 3DBAG ground attribute: it stands on that as a prism, and
    /// its geometry's heights (ground, top, model) are not used, each loss reported under its name.
    #[test]
    fn a_building_off_the_globe_with_a_ground_attribute_stands_on_it() {
        let d = one_off_the_globe(json!({"b3_h_maaiveld": -0.5, "b3_bouwlagen": 2}));
        for lod in [None, Some("2.2")] {
            let out = run(&d, lod);
            assert!(out.report.skipped.is_empty(), "{:?}", out.report.skipped);
            assert_eq!(out.buildings.len(), 2);
            let (a, b) = (&out.buildings[0], &out.buildings[1]);
            assert_eq!(b.source_id, "B");
            // A stands on its geometry (z −1 m), B on its attribute (−0.5 m); B's height from its storeys, not
            // from its geometry's top.
            assert!(
                (b.base_z_m - a.base_z_m - 0.5).abs() < 0.01,
                "{} {}",
                a.base_z_m,
                b.base_z_m
            );
            assert!((b.height_m - 6.0).abs() < 1e-9, "{}", b.height_m);
            assert_eq!(a.mesh.is_some(), lod.is_some());
            assert!(b.mesh.is_none());
            only_issue(
                &out.report.repaired,
                "B",
                IssueReason::GeometryHeightsIgnored,
                "b3_h_maaiveld = -0.5 m",
            );
            let m = &out.report.mesh_issues;
            if lod.is_some() {
                only_issue(m, "B", IssueReason::ModelInvalid, "3D model");
            } else {
                assert!(m.is_empty(), "{m:?}");
            }
        }
    }

    #[test]
    fn degenerate_surfaces_are_left_out_and_reported() {
        let mut g = box_solid(0, json!("2.2"));
        let shell = g["boundaries"][0].as_array_mut().unwrap();
        shell.push(json!([[0, 1, 1, 0]])); // two distinct points
        shell.push(json!([[0, 1, 1]]));
        shell.push(json!([[4, 5, 6, 7], [0, 0, 1]])); // a good roof with a degenerate hole
        let d = doc(
            "2.0",
            json!({"B": {"type": "Building", "geometry": [g]}}),
            &box_vertices(0, 4),
        );
        let out = run(&d, Some("2.2"));
        let m = out.buildings[0].mesh.as_ref().unwrap();
        assert_eq!(m.mesh.triangles.len(), 14);
        m.check_invariants().unwrap();
        let i = &out.report.mesh_issues;
        assert_eq!(i.len(), 1, "{i:?}");
        assert_eq!(i[0].reason, IssueReason::ModelSurfaceDropped);
        assert!(
            i[0].detail.starts_with("2 of 9 surfaces"),
            "{}",
            i[0].detail
        );
        assert!(i[0].detail.contains("1 degenerate hole"), "{}", i[0].detail);
    }

    #[test]
    fn malformed_boundaries_are_model_issues_not_panics() {
        let bad = [
            json!("nope"),
            json!([["x"]]),
            json!([[[[0, 1, -1]]]]),
            json!([[[[0.5, 1, 2]]]]),
            json!([[[[18446744073709551615u64, 1, 2]]]]),
            json!([[[]]]),
            json!([]),
        ];
        for b in bad {
            let g = json!({"type": "Solid", "lod": "2.2", "boundaries": b});
            let d = doc(
                "2.0",
                json!({"B": {"type": "Building", "geometry": [box_solid(0, json!("1.2")), g]}}),
                &box_vertices(0, 4),
            );
            let out = run(&d, Some("2.2"));
            assert_eq!(out.buildings.len(), 1, "{b}");
            assert!(out.buildings[0].mesh.is_none(), "{b}");
            let reasons: Vec<IssueReason> =
                out.report.mesh_issues.iter().map(|i| i.reason).collect();
            assert!(
                matches!(
                    reasons.as_slice(),
                    [IssueReason::ModelInvalid] | [IssueReason::ModelMissing]
                ),
                "{b}: {reasons:?}"
            );
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]
        /// Random rings over 8 vertices with indices up to 11: the building is always written, and
        /// either carries a valid mesh or has a mesh issue.
        #[test]
        fn random_surfaces_give_a_valid_mesh_or_an_issue_never_a_panic(
            surfaces in proptest::collection::vec(
                proptest::collection::vec(proptest::collection::vec(0u64..12, 0..7), 1..3), 0..8),
        ) {
            let g = json!({"type": "Solid", "lod": "2.2", "boundaries": [surfaces]});
            let d = doc(
                "2.0",
                json!({"B": {"type": "Building", "geometry": [box_solid(0, json!("1.2")), g]}}),
                &box_vertices(0, 4),
            );
            let out = run(&d, Some("2.2"));
            proptest::prop_assert_eq!(out.buildings.len(), 1);
            match &out.buildings[0].mesh {
                Some(m) => {
                    proptest::prop_assert!(m.check_invariants().is_ok());
                    proptest::prop_assert!(m.mesh.triangles.iter().all(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]));
                }
                None => proptest::prop_assert!(!out.report.mesh_issues.is_empty()),
            }
        }
    }

    #[test]
    fn semantic_types_map_to_surface_kinds() {
        use SurfaceKind::*;
        for (t, k) in [
            ("RoofSurface", Roof),
            ("OuterFloorSurface", Roof),
            ("WallSurface", Wall),
            ("Window", Wall),
            ("Door", Wall),
            ("GroundSurface", Ground),
            ("ClosureSurface", Other),
            ("OuterCeilingSurface", Other),
            ("InteriorWallSurface", Other),
            ("+Custom", Other),
        ] {
            assert_eq!(surface_kind(Some(t)), k, "{t}");
        }
        assert_eq!(surface_kind(None), Other);
    }

    #[test]
    fn geojson_input_ignores_the_lod_option() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("b.geojson");
        std::fs::write(&p, r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},
            "geometry":{"type":"Polygon","coordinates":[[[4.36,52.0],[4.3601,52.0],[4.3601,52.0001],[4.36,52.0]]]}}]}"#).unwrap();
        let opts = IngestOptions {
            lod: Some(LodChoice::Highest),
            ..Default::default()
        };
        let out = ingest(&[p], &opts).unwrap();
        assert_eq!(out.buildings.len(), 1);
        assert!(out.buildings[0].mesh.is_none() && out.report.mesh_issues.is_empty());
    }

    #[test]
    fn an_unreadable_lod_option_is_an_option_error() {
        let opts = IngestOptions {
            lod: Some(LodChoice::Exact("2,2".into())),
            ..Default::default()
        };
        let e = ingest(&[], &opts).unwrap_err();
        assert!(
            matches!(e, crate::IngestError::InvalidOption { name: "lod", .. }),
            "{e}"
        );
    }
}
