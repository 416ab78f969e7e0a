//! The seed criterion for drawing a block (seed 002 §3.2.2) with its view-angle factors:
//! ΔH_view = Δh·(k/d)·cos θ ≤ δH and ΔA_view = Δa·(k/d)²·sin θ ≤ δA, k = H/(2·tan(fovy/2)) px.
//! d (m) is the distance from the eye to the block's bounding box (nearest point) and θ the
//! elevation angle of the line of sight to that point (0 level, 90° straight down or up).
//! Buildings are exact and blocks drawn with their buildings' own meshes (`fallback`) too.

use serde::Serialize;

use crate::camera::{Camera, Viewport};
use crate::finding::{Finding, FindingKind};
use crate::select::{OrientedBox, Selection};
use crate::tileset::{LoadedTileset, NodeRef, TileInfo};
use crate::vec3::{self, Vec3};

/// The screen tolerances of the criterion: δH in pixels, δA in pixels².
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Tolerances {
    pub dh_px: f64,
    pub da_px: f64,
}

impl Default for Tolerances {
    /// The seed's defaults, also citylod build's: δH = 20 px, δA = 200 px².
    fn default() -> Self {
        Tolerances {
            dh_px: 20.0,
            da_px: 200.0,
        }
    }
}

/// How one block appears from one camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewError {
    /// Distance (m) from the eye to the nearest point of the block's box; 0 inside it.
    pub distance_m: f64,
    /// Elevation angle (degrees, 0–90) of the line of sight to that point; 90 when inside.
    pub elevation_deg: f64,
    /// ΔH_view (px) and ΔA_view (px²); +∞ inside the box for a positive Δh or Δa.
    pub dh_view_px: f64,
    pub da_view_px: f64,
}

/// ΔH_view and ΔA_view of a block with height spread `dh_m` and added ground `da_m2` whose mesh
/// spans `bounds_m` (min, max; root frame, z up), seen by `camera` through `viewport`.
///
/// # Examples
/// ```
/// use citylod_check::{view_error, Camera, Viewport};
/// // Eye 100 m south of a block at its roof height: θ = 0, so ΔA_view = 0 and ΔH_view = Δh·k/d.
/// let cam = Camera::from_enu([0.0, -100.0, 10.0], 0.0, 0.0, 90.0).unwrap();
/// let e = view_error(5.0, 400.0, ([-5.0, 0.0, 0.0], [5.0, 10.0, 10.0]), &cam, Viewport::new(400, 200));
/// assert!((e.dh_view_px - 5.0).abs() < 1e-9 && e.da_view_px == 0.0); // k = 100 px
/// ```
pub fn view_error(
    dh_m: f64,
    da_m2: f64,
    bounds_m: (Vec3, Vec3),
    camera: &Camera,
    viewport: Viewport,
) -> ViewError {
    let (lo, hi) = bounds_m;
    let eye = camera.eye_m;
    // max and min, not clamp: bounds that are not numbers (hand-made content) must not panic.
    let nearest: Vec3 = std::array::from_fn(|i| eye[i].max(lo[i].min(hi[i])).min(hi[i].max(lo[i])));
    let to = vec3::sub(nearest, eye);
    let d = vec3::norm(to);
    let k = f64::from(viewport.height_px) / (2.0 * camera.tan_half_fovy());
    if d <= 0.0 {
        let inf = |x: f64| if x > 0.0 { f64::INFINITY } else { 0.0 };
        return ViewError {
            distance_m: 0.0,
            elevation_deg: 90.0,
            dh_view_px: inf(dh_m),
            da_view_px: inf(da_m2),
        };
    }
    let sin_t = (to[2].abs() / d).min(1.0);
    let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
    ViewError {
        distance_m: d,
        elevation_deg: sin_t.asin().to_degrees(),
        dh_view_px: dh_m * (k / d) * cos_t,
        da_view_px: da_m2 * (k / d) * (k / d) * sin_t,
    }
}

/// How close the drawn blocks of one cut come to the tolerances.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct CriterionStats {
    /// Blocks of the selected tiles that are in view and not exact (checked).
    pub blocks_checked: u32,
    /// Largest ΔH_view (px) and ΔA_view (px²) among them; 0 when none.
    pub max_dh_view_px: f64,
    pub max_da_view_px: f64,
}

/// Per feature of `tile`: whether one of its triangles may be in view, i.e. is not wholly outside one plane of
/// the frustum (conservative: a triangle that straddles two planes' outsides counts as in view). A block's box
/// can reach into the view while the block does not: a long L-shaped block's empty corner.
fn features_in_view(tile: &TileInfo, planes: &[crate::camera::Plane]) -> Vec<bool> {
    let mut seen = vec![false; tile.features.len()];
    let Some(mesh) = &tile.mesh else {
        return seen;
    };
    for (tri, &f) in mesh.triangles.iter().zip(&tile.triangle_features) {
        let Some(s) = seen.get_mut(f as usize).filter(|s| !**s) else {
            continue;
        };
        let p = tri.map(|v| mesh.positions.get(v as usize).copied());
        let [Some(a), Some(b), Some(c)] = p else {
            continue;
        };
        let outside = planes
            .iter()
            .any(|pl| [a, b, c].iter().all(|v| vec3::dot(pl.n, *v) + pl.d < 0.0));
        *s = !outside;
    }
    seen
}

/// Every block of every selected tile that is in view (its box and one of its triangles reach into the
/// frustum) and breaks δH or δA, and the largest ΔH_view and ΔA_view seen.
pub fn check_criterion(
    ts: &LoadedTileset,
    sel: &Selection,
    camera: &Camera,
    viewport: Viewport,
    tol: Tolerances,
) -> (Vec<Finding>, CriterionStats) {
    let mut out = Vec::new();
    let mut stats = CriterionStats::default();
    let planes = camera.frustum_planes(viewport);
    for &i in &sel.selected {
        let in_view = features_in_view(&ts.tiles[i], &planes);
        for (fi, f) in ts.tiles[i].features.iter().enumerate() {
            let NodeRef::Cluster { .. } = f.node else {
                continue;
            };
            let Some(bounds) = f.bounds_m.filter(|_| !f.fallback) else {
                continue;
            };
            if !OrientedBox::from_min_max(bounds.0, bounds.1).is_visible(camera, viewport)
                || !in_view[fi]
            {
                continue;
            }
            let e = view_error(f.dh_m, f.da_m2, bounds, camera, viewport);
            stats.blocks_checked += 1;
            stats.max_dh_view_px = stats.max_dh_view_px.max(e.dh_view_px);
            stats.max_da_view_px = stats.max_da_view_px.max(e.da_view_px);
            let what = format!(
                "at {:.1} m, line of sight {:.1}° below or above level",
                e.distance_m, e.elevation_deg
            );
            if e.dh_view_px > tol.dh_px * (1.0 + 1e-9) {
                out.push(
                    Finding::at(
                        FindingKind::HeightCriterion,
                        ts,
                        i,
                        format!(
                            "block with Δh {:.2} m appears {:.1} px > δH {} px ({what})",
                            f.dh_m, e.dh_view_px, tol.dh_px
                        ),
                    )
                    .node(f.node)
                    .values(e.dh_view_px, tol.dh_px),
                );
            }
            if e.da_view_px > tol.da_px * (1.0 + 1e-9) {
                out.push(
                    Finding::at(
                        FindingKind::AreaCriterion,
                        ts,
                        i,
                        format!(
                            "block with Δa {:.1} m² appears {:.1} px² > δA {} px² ({what})",
                            f.da_m2, e.da_view_px, tol.da_px
                        ),
                    )
                    .node(f.node)
                    .values(e.da_view_px, tol.da_px),
                );
            }
        }
    }
    (out, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tileset::FeatureInfo;

    const VIEW: Viewport = Viewport {
        width_px: 400,
        height_px: 200,
    };

    fn cam(eye: Vec3) -> Camera {
        // 90° fov on 200 rows: k = 100 px.
        Camera::from_enu(eye, 0.0, -45.0, 90.0).unwrap()
    }

    const BLOCK: (Vec3, Vec3) = ([-5.0, 0.0, 0.0], [5.0, 10.0, 10.0]);

    #[test]
    fn a_block_counts_as_in_view_only_when_one_of_its_triangles_is() {
        // An L of two flat strips, x ∈ [0, 100] × y ∈ [0, 10] and x ∈ [0, 10] × y ∈ [0, 100]: its box
        // [0, 100]² holds the empty corner around (80, 80). A camera 20 m above that corner looking straight
        // down with a 45° fov sees ±8 m: inside the box, but no triangle of the L.
        let strip = |x0: f64, y0: f64, x1: f64, y1: f64, base: u32| {
            (
                vec![[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]],
                vec![[base, base + 1, base + 2], [base, base + 2, base + 3]],
            )
        };
        let (mut positions, mut triangles) = strip(0.0, 0.0, 100.0, 10.0, 0);
        let (p2, t2) = strip(0.0, 0.0, 10.0, 100.0, 4);
        positions.extend(p2);
        triangles.extend(t2);
        let tile = TileInfo {
            path_in_tree: "0".into(),
            content_uri: None,
            content_bytes: 0,
            content_uris: vec![],
            volume_kind: Default::default(),
            exact_volume: None,
            mesh: Some(citylod_model::Mesh3d {
                positions,
                triangles,
            }),
            features: vec![FeatureInfo {
                node: NodeRef::Cluster {
                    level: 1,
                    node_index: 0,
                },
                member_count: Some(2),
                members: None,
                dh_m: 0.0,
                da_m2: 50.0,
                area_m2: None,
                fallback: false,
                bounds_m: Some(([0.0; 3], [100.0, 100.0, 0.0])),
                heights: None,
            }],
            triangle_features: vec![0; 4],
            under: Vec::new(),
        };
        let view = Viewport::new(300, 300);
        let over_corner = Camera::from_enu([80.0, 80.0, 20.0], 0.0, -90.0, 45.0).unwrap();
        let b = tile.features[0].bounds_m.unwrap();
        assert!(OrientedBox::from_min_max(b.0, b.1).is_visible(&over_corner, view));
        assert_eq!(
            features_in_view(&tile, &over_corner.frustum_planes(view)),
            vec![false]
        );
        let over_strip = Camera::from_enu([50.0, 5.0, 20.0], 0.0, -90.0, 45.0).unwrap();
        assert_eq!(
            features_in_view(&tile, &over_strip.frustum_planes(view)),
            vec![true]
        );
    }

    #[test]
    fn straight_down_shows_area_not_height() {
        let e = view_error(4.0, 50.0, BLOCK, &cam([0.0, 5.0, 110.0]), VIEW);
        assert!((e.distance_m - 100.0).abs() < 1e-12);
        assert!((e.elevation_deg - 90.0).abs() < 1e-9);
        assert!(e.dh_view_px.abs() < 1e-12);
        assert!((e.da_view_px - 50.0).abs() < 1e-9); // 50 · (100/100)² · 1
    }

    #[test]
    fn oblique_view_splits_by_cos_and_sin() {
        // Nearest point (0, 0, 10) seen from (0, -30, 50): d = 50, sin θ = 0.8, cos θ = 0.6.
        let e = view_error(10.0, 25.0, BLOCK, &cam([0.0, -30.0, 50.0]), VIEW);
        assert!((e.distance_m - 50.0).abs() < 1e-9);
        assert!((e.dh_view_px - 10.0 * 2.0 * 0.6).abs() < 1e-9);
        assert!((e.da_view_px - 25.0 * 4.0 * 0.8).abs() < 1e-9);
    }

    #[test]
    fn eye_inside_the_block_is_infinite_unless_exact() {
        let e = view_error(1.0, 0.0, BLOCK, &cam([0.0, 5.0, 5.0]), VIEW);
        assert_eq!(e.dh_view_px, f64::INFINITY);
        assert_eq!(e.da_view_px, 0.0);
    }

    /// Bounds that are not numbers (a panic in `f64::clamp`, found by fuzzing) count as holding the eye: the error is
    /// infinite, so the criterion fails rather than the checker.
    #[test]
    fn bounds_that_are_not_numbers_fail_the_criterion_without_panicking() {
        let nan = [f64::NAN; 3];
        let e = view_error(1.0, 1.0, (nan, nan), &cam([0.0, 5.0, 5.0]), VIEW);
        assert_eq!((e.dh_view_px, e.da_view_px), (f64::INFINITY, f64::INFINITY));
    }
}
