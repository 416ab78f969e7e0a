//! The built-in camera set of `citylod check`: from a far view that holds the whole data extent to
//! street level inside it. Root ENU frame, metres, degrees. Deterministic: the same extent and count
//! give the same cameras. Invariant: eye heights decrease geometrically; pitch goes −60° → −15°; given the
//! content, no eye stands inside it or against it ([`standard_views_clear_of`]).

use crate::camera::Camera;
use crate::vec3::{self, Vec3};

/// Vertical field of view (degrees) of the built-in views: CesiumJS's default 60° horizontal fov on
/// a 4:3 image is about 47° vertically.
pub const STANDARD_FOVY_DEG: f64 = 45.0;
/// Eye height above the ground (m) of the nearest built-in view.
pub const STREET_HEIGHT_M: f64 = 40.0;
/// A built-in view's eye stands at least [`EYE_CLEARANCE_M`] above everything within this horizontal
/// distance (m) of it: an eye in a tower, or beside its wall, would see one wall and test nothing.
pub const EYE_CLEARANCE_RADIUS_M: f64 = 25.0;
/// How far (m) a built-in view's eye stays above the content around it (see [`EYE_CLEARANCE_RADIUS_M`]).
pub const EYE_CLEARANCE_M: f64 = 5.0;
const FAR_PITCH_DEG: f64 = -60.0;
const NEAR_PITCH_DEG: f64 = -15.0;
const GOLDEN_ANGLE_DEG: f64 = 137.507_764_050_037_85;

/// `n` cameras over the box `extent_min..extent_max` (root frame, m; z is ground to roof): view 0
/// looks at the centre from far enough that the whole extent is in view, later views come closer
/// with heights decreasing geometrically to [`STREET_HEIGHT_M`] above the ground (`extent_min[2]`),
/// pitch easing from −60° to −15°, headings turning by the golden angle, and the look-at points
/// spread over the middle of the extent by a low-discrepancy sequence. Returns no cameras when
/// `n == 0` or the extent is not finite; swapped corners are reordered.
///
/// # Examples
/// ```
/// let views = citylod_check::standard_views([-500.0, -400.0, 0.0], [500.0, 400.0, 60.0], 6);
/// assert_eq!(views.len(), 6);
/// assert!(views[0].eye_m[2] > views[5].eye_m[2]);
/// ```
pub fn standard_views(extent_min: Vec3, extent_max: Vec3, n: usize) -> Vec<Camera> {
    standard_views_clear_of(extent_min, extent_max, n, |_, _| None)
}

/// [`standard_views`] kept clear of the content: `highest_near(xy, r)` is the highest point (root frame z, m)
/// of the content within `r` m horizontally of `xy`, `None` where there is none. A camera whose eye is below
/// that (within [`EYE_CLEARANCE_RADIUS_M`]) plus [`EYE_CLEARANCE_M`] is raised to it, keeping its position on
/// the ground, heading and pitch: on Boston the street view's eye stood at 37 m inside a 49 m building, and its
/// cut and full-detail pictures were one wall.
///
/// # Examples
/// ```
/// use citylod_check::{standard_views, standard_views_clear_of};
/// let (lo, hi) = ([-500.0, -400.0, 0.0], [500.0, 400.0, 60.0]);
/// // A 300 m tower everywhere: every eye lower than 305 m is raised to it.
/// let views = standard_views_clear_of(lo, hi, 6, |_, _| Some(300.0));
/// assert!(views.iter().all(|c| c.eye_m[2] >= 305.0));
/// assert_eq!(views[0], standard_views(lo, hi, 6)[0]); // the far view is high above it
/// ```
pub fn standard_views_clear_of(
    extent_min: Vec3,
    extent_max: Vec3,
    n: usize,
    highest_near: impl Fn([f64; 2], f64) -> Option<f64>,
) -> Vec<Camera> {
    if n == 0 || !vec3::is_finite(extent_min) || !vec3::is_finite(extent_max) {
        return Vec::new();
    }
    let lo: Vec3 = std::array::from_fn(|i| extent_min[i].min(extent_max[i]));
    let hi: Vec3 = std::array::from_fn(|i| extent_min[i].max(extent_max[i]));
    let ground_m = lo[2];
    let centre = [(lo[0] + hi[0]) * 0.5, (lo[1] + hi[1]) * 0.5, ground_m];
    // Radius of the sphere around the ground centre holding the extent; the far camera stands where that sphere fills the
    // vertical field of view (the horizontal one is wider), with 10 % margin.
    let reach = [(hi[0] - lo[0]) * 0.5, (hi[1] - lo[1]) * 0.5, hi[2] - lo[2]];
    let radius_m = vec3::norm(reach).max(50.0);
    let half_fovy = (STANDARD_FOVY_DEG * 0.5).to_radians();
    let far_distance_m = 1.1 * radius_m / half_fovy.sin();
    let far_height_m = far_distance_m * (-FAR_PITCH_DEG).to_radians().sin();
    let near_height_m = STREET_HEIGHT_M.min(far_height_m);

    (0..n)
        .filter_map(|i| {
            let t = if n == 1 {
                0.0
            } else {
                i as f64 / (n - 1) as f64
            };
            let height_m = far_height_m * (near_height_m / far_height_m).powf(t);
            let pitch_deg = FAR_PITCH_DEG + (NEAR_PITCH_DEG - FAR_PITCH_DEG) * t;
            let heading_deg = (i as f64 * GOLDEN_ANGLE_DEG) % 360.0;
            // Look-at point: the centre for the far view, then points of the R2 sequence over the
            // middle 60 % of the extent, pulled towards the centre while the camera is high.
            let (u, v) = r2(i);
            let spread = 0.6 * t;
            let target = [
                centre[0] + (u - 0.5) * spread * (hi[0] - lo[0]),
                centre[1] + (v - 0.5) * spread * (hi[1] - lo[1]),
                ground_m,
            ];
            let p = pitch_deg.to_radians();
            let back_m = height_m / p.tan().abs();
            let h = heading_deg.to_radians();
            let mut eye = [
                target[0] - h.sin() * back_m,
                target[1] - h.cos() * back_m,
                ground_m + height_m,
            ];
            if let Some(top) = highest_near([eye[0], eye[1]], EYE_CLEARANCE_RADIUS_M) {
                eye[2] = eye[2].max(top + EYE_CLEARANCE_M);
            }
            // Finite eye and a pitch within [−90, 90] always make a camera.
            Camera::from_enu(eye, heading_deg, pitch_deg, STANDARD_FOVY_DEG).ok()
        })
        .collect()
}

/// The i-th point of Roberts' R2 low-discrepancy sequence in the unit square.
fn r2(i: usize) -> (f64, f64) {
    const G: f64 = 1.324_717_957_244_746; // plastic number
    let k = i as f64;
    ((0.5 + k / G).fract(), (0.5 + k / (G * G)).fract())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Viewport;
    use crate::select::OrientedBox;

    const LO: Vec3 = [-1200.0, -800.0, 0.0];
    const HI: Vec3 = [1200.0, 800.0, 90.0];

    #[test]
    fn far_view_holds_the_whole_extent() {
        let cams = standard_views(LO, HI, 8);
        let planes = cams[0].frustum_planes(Viewport::new(1024, 768));
        for corner in 0..8 {
            let p = [
                if corner & 1 == 0 { LO[0] } else { HI[0] },
                if corner & 2 == 0 { LO[1] } else { HI[1] },
                if corner & 4 == 0 { LO[2] } else { HI[2] },
            ];
            for pl in &planes {
                assert!(vec3::dot(pl.n, p) + pl.d >= 0.0, "corner {p:?} outside");
            }
        }
    }

    #[test]
    fn heights_decrease_geometrically_to_street_level_and_pitch_rises() {
        let cams = standard_views(LO, HI, 8);
        let heights: Vec<f64> = cams.iter().map(|c| c.eye_m[2] - LO[2]).collect();
        let ratios: Vec<f64> = heights.windows(2).map(|w| w[1] / w[0]).collect();
        assert!(
            ratios
                .iter()
                .all(|r| (r - ratios[0]).abs() < 1e-9 && *r < 1.0),
            "{ratios:?}"
        );
        assert!((heights[7] - STREET_HEIGHT_M).abs() < 1e-9);
        let pitch = |c: &Camera| c.forward[2].asin().to_degrees();
        assert!((pitch(&cams[0]) + 60.0).abs() < 1e-9);
        assert!((pitch(&cams[7]) + 15.0).abs() < 1e-9);
    }

    #[test]
    fn street_view_looks_into_the_city() {
        let cams = standard_views(LO, HI, 8);
        let street = cams[7];
        let city = OrientedBox::from_min_max(LO, HI);
        // The look-at ray hits the ground inside the extent.
        let s = -(street.eye_m[2] - LO[2]) / street.forward[2];
        let hit = vec3::add(street.eye_m, vec3::scale(street.forward, s));
        assert!(city.distance_to(hit) < 1e-9, "{hit:?}");
    }

    #[test]
    fn views_are_deterministic_and_headings_vary() {
        let a = standard_views(LO, HI, 10);
        assert_eq!(a, standard_views(LO, HI, 10));
        let mut headings: Vec<i64> = a
            .iter()
            .map(|c| c.forward[0].atan2(c.forward[1]).to_degrees().round() as i64)
            .collect();
        headings.sort_unstable();
        headings.dedup();
        assert_eq!(headings.len(), 10);
    }

    #[test]
    fn an_eye_among_content_rises_above_it_and_keeps_its_bearing() {
        let plain = standard_views(LO, HI, 8);
        let street = plain[7];
        // A 100 m tower within the clearance radius of the street view's eye only.
        let tower = |xy: [f64; 2], r: f64| {
            let d = (xy[0] - street.eye_m[0]).hypot(xy[1] - street.eye_m[1]);
            (d <= r && r >= EYE_CLEARANCE_RADIUS_M).then_some(LO[2] + 100.0)
        };
        let clear = standard_views_clear_of(LO, HI, 8, tower);
        assert_eq!(clear[..7], plain[..7]);
        let raised = clear[7];
        assert!((raised.eye_m[2] - (LO[2] + 100.0 + EYE_CLEARANCE_M)).abs() < 1e-9);
        assert_eq!(raised.eye_m[..2], street.eye_m[..2]);
        assert_eq!(raised.forward, street.forward);
        // Content below the clearance leaves the eye where it was.
        let low = standard_views_clear_of(LO, HI, 8, |_, _| {
            Some(LO[2] + STREET_HEIGHT_M - EYE_CLEARANCE_M)
        });
        assert_eq!(low, plain);
    }

    #[test]
    fn degenerate_inputs_give_no_or_sane_views() {
        assert!(standard_views(LO, HI, 0).is_empty());
        assert!(standard_views([f64::NAN; 3], HI, 4).is_empty());
        let point = standard_views([5.0, 5.0, 0.0], [5.0, 5.0, 0.0], 3);
        assert_eq!(point.len(), 3);
        assert!(point.iter().all(|c| vec3::is_finite(c.eye_m)));
    }
}
