//! The built-in camera set of `citylod check`: from a far view that holds the whole data extent to
//! street level inside it. Root ENU frame, metres, degrees. Deterministic: the same extent and count
//! give the same cameras. Invariant: eye heights decrease geometrically; pitch goes −60° → −15°; given the
//! content, views look at it and no eye stands inside it or against it ([`standard_views_over`]).

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
    standard_views_over(extent_min, extent_max, n, &NoContent)
}

/// What the built-in views need to know of the content (full detail, root frame, m).
pub trait ViewContent {
    /// The highest point (z) of the content within `radius_m` horizontally of `xy`; `None` where there is none.
    fn highest_near(&self, xy: [f64; 2], radius_m: f64) -> Option<f64>;
    /// The point (x, y) of the content horizontally nearest to `xy`; `None` without content.
    fn nearest(&self, xy: [f64; 2]) -> Option<[f64; 2]>;
}

/// No content known: the views of [`standard_views`].
pub struct NoContent;

impl ViewContent for NoContent {
    fn highest_near(&self, _: [f64; 2], _: f64) -> Option<f64> {
        None
    }
    fn nearest(&self, _: [f64; 2]) -> Option<[f64; 2]> {
        None
    }
}

/// [`standard_views`] placed on and clear of the content:
/// - every view but the far one looks at the content point nearest to its point of the sequence (on Boston one
///   looked at the middle of the Charles River, and its pictures held a strip of skyline);
/// - a camera whose eye is below the highest content within [`EYE_CLEARANCE_RADIUS_M`] plus [`EYE_CLEARANCE_M`]
///   is raised to it, keeping its position on the ground, heading and pitch: on Boston the street view's eye stood
///   at 37 m inside a 49 m building, and its cut and full-detail pictures were one wall.
///
/// # Examples
/// ```
/// use citylod_check::{standard_views, standard_views_over, ViewContent};
/// /// A 300 m tower everywhere, and content at one point.
/// struct Towers;
/// impl ViewContent for Towers {
///     fn highest_near(&self, _: [f64; 2], _: f64) -> Option<f64> { Some(300.0) }
///     fn nearest(&self, _: [f64; 2]) -> Option<[f64; 2]> { Some([100.0, 50.0]) }
/// }
/// let (lo, hi) = ([-500.0, -400.0, 0.0], [500.0, 400.0, 60.0]);
/// let views = standard_views_over(lo, hi, 6, &Towers);
/// // Every eye lower than 305 m is raised to it; the far view is high above it and looks at the centre.
/// assert!(views.iter().all(|c| c.eye_m[2] >= 305.0));
/// assert_eq!(views[0], standard_views(lo, hi, 6)[0]);
/// ```
pub fn standard_views_over(
    extent_min: Vec3,
    extent_max: Vec3,
    n: usize,
    content: &impl ViewContent,
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
            // The far view keeps the centre, so the whole extent stays in view; the others move to the nearest content.
            let (u, v) = r2(i);
            let spread = 0.6 * t;
            let mut target = [
                centre[0] + (u - 0.5) * spread * (hi[0] - lo[0]),
                centre[1] + (v - 0.5) * spread * (hi[1] - lo[1]),
                ground_m,
            ];
            if i > 0 {
                if let Some([x, y]) = content.nearest([target[0], target[1]]) {
                    target = [x, y, ground_m];
                }
            }
            let p = pitch_deg.to_radians();
            let back_m = height_m / p.tan().abs();
            let h = heading_deg.to_radians();
            let mut eye = [
                target[0] - h.sin() * back_m,
                target[1] - h.cos() * back_m,
                ground_m + height_m,
            ];
            if let Some(top) = content.highest_near([eye[0], eye[1]], EYE_CLEARANCE_RADIUS_M) {
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
        let hit = ground_hit(&street);
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

    /// Content given by two closures: the highest point near a place, the nearest point.
    struct Probe<H, N>(H, N);

    impl<H, N> ViewContent for Probe<H, N>
    where
        H: Fn([f64; 2], f64) -> Option<f64>,
        N: Fn([f64; 2]) -> Option<[f64; 2]>,
    {
        fn highest_near(&self, xy: [f64; 2], radius_m: f64) -> Option<f64> {
            (self.0)(xy, radius_m)
        }
        fn nearest(&self, xy: [f64; 2]) -> Option<[f64; 2]> {
            (self.1)(xy)
        }
    }

    /// Where a camera's look-at ray meets the ground plane z = LO[2].
    fn ground_hit(c: &Camera) -> Vec3 {
        let s = -(c.eye_m[2] - LO[2]) / c.forward[2];
        vec3::add(c.eye_m, vec3::scale(c.forward, s))
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
        let clear = standard_views_over(LO, HI, 8, &Probe(tower, Some));
        assert_eq!(clear[..7], plain[..7]);
        let raised = clear[7];
        assert!((raised.eye_m[2] - (LO[2] + 100.0 + EYE_CLEARANCE_M)).abs() < 1e-9);
        assert_eq!(raised.eye_m[..2], street.eye_m[..2]);
        assert_eq!(raised.forward, street.forward);
        // Content below the clearance leaves the eye where it was.
        let low = standard_views_over(
            LO,
            HI,
            8,
            &Probe(|_, _| Some(LO[2] + STREET_HEIGHT_M - EYE_CLEARANCE_M), Some),
        );
        assert_eq!(low, plain);
    }

    #[test]
    fn views_look_at_the_nearest_content_but_the_far_view_at_the_centre() {
        let plain = standard_views(LO, HI, 8);
        // All the content east of x = 900 m (a river or a park fills the rest).
        let east = |xy: [f64; 2]| Some([xy[0].max(900.0), xy[1]]);
        let moved = standard_views_over(LO, HI, 8, &Probe(|_, _| None, east));
        assert_eq!(moved[0], plain[0]);
        for (i, (m, p)) in moved.iter().zip(&plain).enumerate().skip(1) {
            let (hm, hp) = (ground_hit(m), ground_hit(p));
            let want = east([hp[0], hp[1]]).unwrap();
            assert!(
                (hm[0] - want[0]).abs() < 1e-6 && (hm[1] - want[1]).abs() < 1e-6,
                "view {i}: looks at {hm:?}, not {want:?}"
            );
            // Same height, pitch and heading.
            assert!((m.eye_m[2] - p.eye_m[2]).abs() < 1e-9);
            assert!(vec3::norm(vec3::sub(m.forward, p.forward)) < 1e-12);
        }
        assert!(moved[1..].iter().zip(&plain[1..]).any(|(m, p)| m != p));
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
