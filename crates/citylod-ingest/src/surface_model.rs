//! 3D surface models read from GIS formats (a GeoPackage's PolyhedralSurface, TIN or walled MultiPolygon Z rows, a
//! shapefile's MultiPatch records): faces without semantics, from which a building's footprint, ground and top are
//! taken, and with `--lod` its model, the faces' kinds told apart by their slope.

use crate::cityjson::{horizontality, HORIZONTAL};
use crate::crs::Crs;
use crate::feature::{RawFeature, RawPolygon};
use crate::model3d::{RawModel, RawSurface};
use crate::report::IssueReason;
use citylod_mesh::signed_area2;
use citylod_model::SurfaceKind;
use std::collections::HashMap;

type Skip = (IssueReason, String);

/// One face of a 3D surface model: its rings (exterior first), open, in source x, y, z.
pub(crate) type Face = Vec<Vec<[f64; 3]>>;

/// The faces of a feature holding a 3D surface model: the feature's index, its name for a skip's detail (`FID 3`,
/// `record 4 (FID 3)`), the faces.
pub(crate) type Surfaces = (usize, String, Vec<Face>);

/// How a 3D surface model stands: its footprint, its ground faces, the heights of its base and top.
struct Standing {
    footprint: Vec<RawPolygon>,
    /// Indices of the horizontal faces at its lowest height (floors), for the model's surface kinds.
    ground: Vec<usize>,
    /// The lowest vertex, when the model reaches down to it (it has walls): a roof alone says nothing of the ground.
    ground_z: Option<f64>,
    /// The highest vertex, when the model has height (not flat).
    top_z: Option<f64>,
}

/// Faces whose normal's z share is under this are walls in a model's surface kinds (steeper than ~84°).
const WALL: f64 = 0.1;
/// A model whose highest vertex is less than this above its lowest is flat: it gives no heights and no model.
pub(crate) const FLAT_M: f64 = 0.1;

/// Gives each feature holding a 3D surface model its footprint and heights (see [`standing`]), and with `want_model` the
/// faces as its model, counted in the report's `mesh_lods` under `label` (the format's models have no LoD of
/// CityJSON's kind). The faces' slopes are judged in metres: x and y in `crs`'s degrees or linear unit. z is in metres
/// per unit of `vertical_unit_m` (a vertical CRS's), else, as ArcGIS takes a z without a vertical CRS, in a projected
/// CRS's linear unit (feet in a State Plane in feet), metres for lon/lat; a note for the file's report when z was so
/// converted.
pub(crate) fn stand(
    features: &mut [RawFeature],
    surfaces: Vec<Surfaces>,
    crs: &Crs,
    vertical_unit_m: Option<f64>,
    want_model: bool,
    label: &str,
) -> Option<String> {
    let n = surfaces.len();
    let (lon_lat, xy_to_m) = (crs.is_lon_lat(), crs.linear_unit_m());
    let z_to_m = vertical_unit_m.unwrap_or(xy_to_m);
    for (i, name, mut faces) in surfaces {
        if z_to_m != 1.0 {
            let finite =
                |faces: &[Face]| faces.iter().flatten().flatten().all(|v| v[2].is_finite());
            let was_finite = finite(&faces);
            faces
                .iter_mut()
                .flatten()
                .flatten()
                .for_each(|v| v[2] *= z_to_m);
            // Heights the unit makes infinite (a unit out of reach, e.g. a .prj's VERTCS of 1e308 m): the model has
            // no height to read, and what is left of it (its faces at z 0) would be a flat model; skipped, said.
            if was_finite && !finite(&faces) {
                features[i].skip = Some((
                    IssueReason::NonFiniteCoordinate,
                    format!(
                        "{name}: heights out of reach: its z values in units of {unit} m (its vertical CRS's \
                         unit, else its CRS's linear unit) are not finite numbers in metres; check the unit the \
                         file's CRS gives (its .prj's VERTCS)",
                        // A unit out of reach is written short (1e308, not 309 digits).
                        unit = if (1e-6..1e9).contains(&z_to_m.abs()) {
                            z_to_m.to_string()
                        } else {
                            format!("{z_to_m:e}")
                        }
                    ),
                ));
                continue;
            }
        }
        let out = &mut features[i];
        let slopes: Vec<f64> = faces
            .iter()
            .map(|f| {
                f.first()
                    .map_or(0.0, |r| horizontality(&metric(r, lon_lat, xy_to_m)))
            })
            .collect();
        match standing(&faces, &slopes) {
            Ok(s) => {
                out.polygons = s.footprint;
                out.assemble = true;
                out.footprint_min_z = s.ground_z;
                out.top_z = s.top_z;
                if want_model {
                    out.model = Some(match s.top_z {
                        Some(_) => Ok(model(&faces, &slopes, &s.ground, label)),
                        None => Err((
                            IssueReason::ModelInvalid,
                            format!(
                                "{name}: a flat 3D model (its vertices within {FLAT_M} m in height): its footprint \
                                 only"
                            ),
                        )),
                    });
                }
            }
            Err((reason, detail)) => {
                out.skip = Some((reason, format!("{name}: {detail}")));
            }
        }
    }
    (n > 0 && z_to_m != 1.0).then(|| {
        format!(
            "the heights (z) of its {n} 3D surface model(s) were read in units of {z_to_m} m (its vertical CRS's, else \
             its CRS's linear unit, as ArcGIS takes z without a vertical CRS) and converted to metres"
        )
    })
}

/// A ring with x and y in metres: along the ground near it when they are degrees, else times `xy_to_m`.
fn metric(r: &[[f64; 3]], lon_lat: bool, xy_to_m: f64) -> Vec<[f64; 3]> {
    let (kx, ky) = if lon_lat {
        let lat = r.first().map_or(0.0, |p| p[1].to_radians());
        (111_320.0 * lat.cos(), 110_574.0)
    } else {
        (xy_to_m, xy_to_m)
    };
    r.iter().map(|p| [p[0] * kx, p[1] * ky, p[2]]).collect()
}

/// The footprint of a 3D surface model: the plan of every face that is not a wall (roofs, floors, the parts of a
/// split level or a stepped or sloping floor), pieces to be unioned, each outline counter-clockwise and its holes
/// clockwise. It stands on its lowest vertex when it has walls reaching there (a roof alone floats over an unknown
/// ground) and reaches its highest, unless it is flat.
fn standing(faces: &[Face], slopes: &[f64]) -> Result<Standing, Skip> {
    let (lowest, highest) = faces
        .iter()
        .flat_map(|f| f.iter().flatten())
        .map(|v| v[2])
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), z| {
            (lo.min(z), hi.max(z))
        });
    let outline = |i: &usize| faces[*i].first().filter(|r| r.len() >= 3);
    let ground: Vec<usize> = (0..faces.len())
        .filter(|i| {
            outline(i).is_some_and(|r| {
                slopes[*i] > HORIZONTAL
                    && r.iter().map(|v| v[2]).sum::<f64>() / r.len() as f64 <= lowest + 0.05
            })
        })
        .collect();
    let plan: Vec<usize> = (0..faces.len())
        .filter(|i| outline(i).is_some() && slopes[*i] >= WALL)
        .collect();
    if plan.is_empty() {
        return Err((
            IssueReason::NoFootprint,
            "a 3D surface model of walls only: no face to take its footprint from".into(),
        ));
    }
    let walls = (0..faces.len()).any(|i| outline(&i).is_some() && slopes[i] < WALL);
    let flat = highest - lowest < FLAT_M;
    Ok(Standing {
        footprint: plan
            .iter()
            .map(|&i| {
                faces[i]
                    .iter()
                    .enumerate()
                    .map(|(k, r)| {
                        let mut ring: Vec<[f64; 2]> = r.iter().map(|v| [v[0], v[1]]).collect();
                        // Floors face down: their plans run clockwise, which is no repair to report.
                        if (signed_area2(&ring) > 0.0) != (k == 0) {
                            ring.reverse();
                        }
                        ring
                    })
                    .collect()
            })
            .collect(),
        ground,
        ground_z: (walls && !flat).then_some(lowest),
        top_z: (!flat).then_some(highest),
    })
}

/// The faces as a model: vertices at identical positions shared; the ground faces `Ground`, faces steeper than
/// ~84° `Wall`, the rest `Roof`.
fn model(faces: &[Face], slopes: &[f64], ground: &[usize], label: &str) -> RawModel {
    let mut index: HashMap<[u64; 3], u32> = HashMap::new();
    let mut positions_src = Vec::new();
    let surfaces = faces
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let kind = if ground.contains(&i) {
                SurfaceKind::Ground
            } else if slopes[i] < WALL {
                SurfaceKind::Wall
            } else {
                SurfaceKind::Roof
            };
            let rings = f
                .iter()
                .map(|r| {
                    r.iter()
                        .map(|v| {
                            *index
                                .entry(v.map(|c| (c + 0.0).to_bits()))
                                .or_insert_with(|| {
                                    positions_src.push(*v);
                                    (positions_src.len() - 1) as u32
                                })
                        })
                        .collect()
                })
                .collect();
            RawSurface { rings, kind }
        })
        .collect();
    RawModel {
        positions_src,
        surfaces,
        lod: label.into(),
        fell_back: false,
        notes: Vec::new(),
    }
}
