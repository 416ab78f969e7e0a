//! The perspective camera of the checker, in the tileset root ENU frame (x east, y north, z up, metres).
//! Heading is clockwise from north and pitch is negative looking down, as in CesiumJS; roll is 0.
//! Invariant: `forward`, `up` and `right()` are unit vectors forming a right-handed orthonormal basis
//! (right × up = −forward, i.e. the camera looks along −z of its own x-right/y-up frame as in OpenGL).

use citylod_model::{geodetic_to_ecef, LocalFrame, WGS84_A_M, WGS84_F};

use crate::vec3::{self, Vec3};
use crate::CheckError;

/// Near plane distance (m) used for culling and rendering, as CesiumJS's default frustum.
pub const NEAR_M: f64 = 1.0;

/// Size of the image a camera draws into, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Viewport {
    pub width_px: u32,
    pub height_px: u32,
}

impl Viewport {
    pub fn new(width_px: u32, height_px: u32) -> Self {
        Self {
            width_px,
            height_px,
        }
    }

    /// Width over height; 1 for a degenerate (zero) size.
    pub fn aspect(&self) -> f64 {
        if self.width_px == 0 || self.height_px == 0 {
            1.0
        } else {
            f64::from(self.width_px) / f64::from(self.height_px)
        }
    }
}

/// A pinhole camera: eye position and orientation in the root ENU frame, vertical field of view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position in the root frame (m).
    pub eye_m: Vec3,
    /// Unit view direction in the root frame.
    pub forward: Vec3,
    /// Unit up direction of the image in the root frame, orthogonal to `forward`.
    pub up: Vec3,
    /// Vertical field of view (degrees), in (0, 180).
    pub fovy_deg: f64,
}

/// A plane `n·p + d ≥ 0` on the inside; `n` is a unit vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Plane {
    pub n: Vec3,
    pub d: f64,
}

/// Lowest eye height `--camera` accepts (m above the ellipsoid): below the deepest ocean floor (−10.9 km) an eye
/// is inside the solid Earth and sees nothing of a city.
pub const LOWEST_EYE_M: f64 = -12_000.0;

impl Camera {
    /// A camera at `eye_m` in the root frame looking along heading/pitch measured in the root frame's
    /// own east-north-up axes. Heading 0 looks north, 90 east; pitch −90 looks straight down (image up is
    /// then the heading direction). Errors on non-finite input or a field of view outside (0, 180).
    ///
    /// # Examples
    /// ```
    /// let cam = citylod_check::Camera::from_enu([0.0, 0.0, 100.0], 90.0, 0.0, 45.0).unwrap();
    /// assert!((cam.forward[0] - 1.0).abs() < 1e-12); // looks east
    /// ```
    pub fn from_enu(
        eye_m: Vec3,
        heading_deg: f64,
        pitch_deg: f64,
        fovy_deg: f64,
    ) -> Result<Camera, CheckError> {
        let (forward, up) = heading_pitch_basis(heading_deg, pitch_deg)?;
        Camera::new(eye_m, forward, up, fovy_deg)
    }

    /// A camera placed on the globe as CesiumJS's `Camera.setView` places it: eye at geodetic WGS84
    /// (lon°, lat°, ellipsoidal height m), heading and pitch in the east-north-up frame at the eye
    /// ([`globe_enu_axes`]), expressed in the tileset's root frame, whose points map to ECEF by
    /// `root_to_ecef` (the root tile's `transform`, column-major). Far from the root origin the earth's
    /// curvature tilts the axes; this is taken into account exactly. Errors as [`Camera::from_enu`],
    /// and when `root_to_ecef` is not invertible.
    #[allow(clippy::too_many_arguments)]
    pub fn from_geodetic(
        lon_deg: f64,
        lat_deg: f64,
        height_m: f64,
        heading_deg: f64,
        pitch_deg: f64,
        fovy_deg: f64,
        root_to_ecef: &[f64; 16],
    ) -> Result<Camera, CheckError> {
        if !(lon_deg.is_finite() && lat_deg.is_finite() && height_m.is_finite()) {
            return Err(CheckError::Camera(format!(
                "position ({lon_deg}, {lat_deg}, {height_m}) is not finite"
            )));
        }
        if !(-90.0..=90.0).contains(&lat_deg) {
            return Err(CheckError::Camera(format!(
                "latitude {lat_deg}° out of range"
            )));
        }
        if height_m < LOWEST_EYE_M {
            return Err(CheckError::Camera(format!(
                "height {height_m} m is inside the Earth (below {LOWEST_EYE_M} m, deeper than any ocean floor)"
            )));
        }
        let (forward_local, up_local) = heading_pitch_basis(heading_deg, pitch_deg)?;
        let ecef_to_root = affine_inverse(root_to_ecef)
            .ok_or_else(|| CheckError::Camera("the root transform is not invertible".into()))?;
        let eye_ecef = geodetic_to_ecef(lon_deg, lat_deg, height_m);
        let [east, north, up] = globe_enu_axes(eye_ecef, lon_deg, lat_deg);
        let eye_m = apply_point(&ecef_to_root, eye_ecef);
        // Directions map by the linear part only.
        let rotate = |v: Vec3| {
            let v_ecef = vec3::add(
                vec3::add(vec3::scale(east, v[0]), vec3::scale(north, v[1])),
                vec3::scale(up, v[2]),
            );
            apply_vector(&ecef_to_root, v_ecef)
        };
        Camera::new(eye_m, rotate(forward_local), rotate(up_local), fovy_deg)
    }

    /// Eye (m), unit view direction and unit image-up direction in ECEF, for a root frame that maps to
    /// ECEF by `root_to_ecef` (column-major) — the camera a globe client such as CesiumJS would be given.
    pub fn in_ecef(&self, root_to_ecef: &[f64; 16]) -> (Vec3, Vec3, Vec3) {
        (
            apply_point(root_to_ecef, self.eye_m),
            vec3::normalize(apply_vector(root_to_ecef, self.forward)),
            vec3::normalize(apply_vector(root_to_ecef, self.up)),
        )
    }

    /// A camera from an eye and two directions; `up` is made orthogonal to `forward`. Errors when the
    /// input is not finite, `forward` is zero, `up` is parallel to it, or the fov is outside (0, 180).
    pub fn new(eye_m: Vec3, forward: Vec3, up: Vec3, fovy_deg: f64) -> Result<Camera, CheckError> {
        if !(vec3::is_finite(eye_m) && vec3::is_finite(forward) && vec3::is_finite(up)) {
            return Err(CheckError::Camera("eye or direction is not finite".into()));
        }
        if !(fovy_deg > 0.0 && fovy_deg < 180.0) {
            return Err(CheckError::Camera(format!(
                "vertical field of view {fovy_deg}° is not in (0, 180)"
            )));
        }
        let forward = vec3::normalize(forward);
        let right = vec3::normalize(vec3::cross(forward, up));
        if vec3::norm(forward) == 0.0 || vec3::norm(right) == 0.0 {
            return Err(CheckError::Camera(
                "view direction is zero or parallel to the up direction".into(),
            ));
        }
        let up = vec3::cross(right, forward);
        Ok(Camera {
            eye_m,
            forward,
            up,
            fovy_deg,
        })
    }

    /// Heading (degrees clockwise from north, in [0, 360)) and pitch (degrees, negative looking down) of
    /// the view direction in the east-north-up frame at the eye ([`globe_enu_axes`]): the numbers
    /// [`Camera::from_geodetic`] takes, so they round-trip.
    pub fn heading_pitch_on_globe(&self, root_to_ecef: &[f64; 16]) -> (f64, f64) {
        let (eye, forward, _) = self.in_ecef(root_to_ecef);
        let [lon, lat, _] = citylod_model::ecef_to_geodetic(eye);
        let [e, n, u] = globe_enu_axes(eye, lon, lat);
        let f = [
            vec3::dot(forward, e),
            vec3::dot(forward, n),
            vec3::dot(forward, u),
        ];
        (
            f[0].atan2(f[1]).to_degrees().rem_euclid(360.0),
            f[2].clamp(-1.0, 1.0).asin().to_degrees(),
        )
    }

    /// Unit vector to the right of the image, in the root frame.
    pub fn right(&self) -> Vec3 {
        vec3::cross(self.forward, self.up)
    }

    /// `tan(fovy / 2)`.
    pub fn tan_half_fovy(&self) -> f64 {
        (self.fovy_deg.to_radians() * 0.5).tan()
    }

    /// Converts a root-frame point to camera coordinates (x right, y up, z along the view, metres).
    pub fn to_view(&self, p_m: Vec3) -> Vec3 {
        let d = vec3::sub(p_m, self.eye_m);
        [
            vec3::dot(d, self.right()),
            vec3::dot(d, self.up),
            vec3::dot(d, self.forward),
        ]
    }

    /// The near plane and the four side planes of the view frustum (no far plane), normals inward.
    pub(crate) fn frustum_planes(&self, viewport: Viewport) -> [Plane; 5] {
        let ty = self.tan_half_fovy();
        let tx = ty * viewport.aspect();
        let (r, u, f) = (self.right(), self.up, self.forward);
        // Inside the left plane: x + tx·z ≥ 0 in view coordinates, and so on.
        let side = |a: Vec3, t: f64| {
            let n = vec3::normalize(vec3::add(a, vec3::scale(f, t)));
            Plane {
                n,
                d: -vec3::dot(n, self.eye_m),
            }
        };
        [
            Plane {
                n: f,
                d: -vec3::dot(f, self.eye_m) - NEAR_M,
            },
            side(r, tx),
            side(vec3::scale(r, -1.0), tx),
            side(u, ty),
            side(vec3::scale(u, -1.0), ty),
        ]
    }
}

/// Forward and up unit vectors for a heading (clockwise from north) and pitch (negative down) in ENU.
fn heading_pitch_basis(heading_deg: f64, pitch_deg: f64) -> Result<(Vec3, Vec3), CheckError> {
    if !(heading_deg.is_finite() && pitch_deg.is_finite()) {
        return Err(CheckError::Camera(format!(
            "heading {heading_deg}° or pitch {pitch_deg}° is not finite"
        )));
    }
    if !(-90.0..=90.0).contains(&pitch_deg) {
        return Err(CheckError::Camera(format!(
            "pitch {pitch_deg}° is not in [-90, 90]"
        )));
    }
    let (sh, ch) = heading_deg.to_radians().sin_cos();
    let (sp, cp) = pitch_deg.to_radians().sin_cos();
    let forward = [sh * cp, ch * cp, sp];
    // Roll 0: the image's right is horizontal, so up = right × forward, defined even at pitch ±90.
    let right = [ch, -sh, 0.0];
    Ok((forward, vec3::cross(right, forward)))
}

/// East, north and up unit vectors (ECEF) at the point `p_ecef` (m), as CesiumJS's
/// `Transforms.eastNorthUpToFixedFrame` builds them for `Camera.setView`: up is the WGS84 ellipsoid's
/// `geodeticSurfaceNormal` evaluated at the point itself, normalize(x/a², y/a², z/b²), which above the
/// ellipsoid differs from the geodetic vertical by about e²·h/R·sin 2φ/2 (1 µrad at 1.5 km height);
/// east is normalize(−y, x, 0), north = up × east. On the polar axis, where east is undefined, the
/// geodetic frame of (`lon_deg`, `lat_deg`) is used.
pub fn globe_enu_axes(p_ecef: Vec3, lon_deg: f64, lat_deg: f64) -> [Vec3; 3] {
    let b = WGS84_A_M * (1.0 - WGS84_F);
    let up = vec3::normalize([
        p_ecef[0] / (WGS84_A_M * WGS84_A_M),
        p_ecef[1] / (WGS84_A_M * WGS84_A_M),
        p_ecef[2] / (b * b),
    ]);
    let east = vec3::normalize([-p_ecef[1], p_ecef[0], 0.0]);
    if vec3::norm(east) == 0.0 || vec3::norm(up) == 0.0 {
        let f = LocalFrame::new(lon_deg, lat_deg, 0.0);
        let o = f.origin_ecef();
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
            .map(|a| vec3::sub(f.enu_to_ecef(a), o));
    }
    [east, vec3::cross(up, east), up]
}

/// `m · p` for a column-major affine 4×4 matrix (the last row is taken as 0 0 0 1).
pub(crate) fn apply_point(m: &[f64; 16], p: Vec3) -> Vec3 {
    vec3::add(apply_vector(m, p), [m[12], m[13], m[14]])
}

/// The linear part of a column-major 4×4 matrix applied to `v`.
fn apply_vector(m: &[f64; 16], v: Vec3) -> Vec3 {
    std::array::from_fn(|r| m[r] * v[0] + m[4 + r] * v[1] + m[8 + r] * v[2])
}

/// Inverse of a column-major affine 4×4 matrix; `None` when its linear part is singular or not finite.
fn affine_inverse(m: &[f64; 16]) -> Option<[f64; 16]> {
    let col = |c: usize| -> Vec3 { [m[4 * c], m[4 * c + 1], m[4 * c + 2]] };
    let (a, b, c) = (col(0), col(1), col(2));
    let det = vec3::dot(a, vec3::cross(b, c));
    if !(det.is_finite() && det.abs() > 1e-300) {
        return None;
    }
    // Rows of the inverse of [a b c] are (b×c, c×a, a×b) / det.
    let rows = [vec3::cross(b, c), vec3::cross(c, a), vec3::cross(a, b)]
        .map(|r| vec3::scale(r, 1.0 / det));
    let t = [m[12], m[13], m[14]];
    let mut inv = [0.0; 16];
    for (r, row) in rows.iter().enumerate() {
        for k in 0..3 {
            inv[4 * k + r] = row[k];
        }
        inv[12 + r] = -vec3::dot(*row, t);
    }
    inv[15] = 1.0;
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-9)
    }

    #[test]
    fn heading_zero_looks_north_and_ninety_east() {
        let north = Camera::from_enu([0.0; 3], 0.0, 0.0, 45.0).unwrap();
        assert!(close(north.forward, [0.0, 1.0, 0.0]), "{:?}", north.forward);
        assert!(close(north.up, [0.0, 0.0, 1.0]));
        assert!(close(north.right(), [1.0, 0.0, 0.0]));
        let east = Camera::from_enu([0.0; 3], 90.0, 0.0, 45.0).unwrap();
        assert!(close(east.forward, [1.0, 0.0, 0.0]), "{:?}", east.forward);
        assert!(close(east.right(), [0.0, -1.0, 0.0]));
    }

    #[test]
    fn pitch_minus_ninety_looks_straight_down_with_north_up() {
        let cam = Camera::from_enu([0.0, 0.0, 500.0], 0.0, -90.0, 45.0).unwrap();
        assert!(close(cam.forward, [0.0, 0.0, -1.0]), "{:?}", cam.forward);
        assert!(close(cam.up, [0.0, 1.0, 0.0]), "{:?}", cam.up);
        assert!(close(cam.right(), [1.0, 0.0, 0.0]));
    }

    #[test]
    fn negative_pitch_looks_down() {
        let cam = Camera::from_enu([0.0; 3], 45.0, -30.0, 45.0).unwrap();
        assert!(cam.forward[2] < -0.49 && cam.forward[0] > 0.0 && cam.forward[1] > 0.0);
        assert!(cam.up[2] > 0.0);
    }

    #[test]
    fn geodetic_camera_at_root_origin_matches_enu_camera() {
        let frame = LocalFrame::new(-71.06, 42.35, 0.0).enu_to_ecef_column_major();
        let g = Camera::from_geodetic(-71.06, 42.35, 300.0, 30.0, -45.0, 50.0, &frame).unwrap();
        let e = Camera::from_enu([0.0, 0.0, 300.0], 30.0, -45.0, 50.0).unwrap();
        assert!(
            (0..3).all(|i| (g.eye_m[i] - e.eye_m[i]).abs() < 1e-3),
            "{:?}",
            g.eye_m
        );
        // 300 m up, the globe frame's vertical leans ~0.15 µrad off the geodetic one (globe_enu_axes).
        let near = |a: Vec3, b: Vec3| (0..3).all(|i| (a[i] - b[i]).abs() < 1e-6);
        assert!(
            near(g.forward, e.forward),
            "{:?} vs {:?}",
            g.forward,
            e.forward
        );
        assert!(near(g.up, e.up), "{:?} vs {:?}", g.up, e.up);
    }

    #[test]
    fn geodetic_camera_far_east_has_up_tilted_by_curvature() {
        // 0.1° of longitude east at 42°N is ~8.3 km; the local vertical tilts east-ward by that angle.
        let frame = LocalFrame::new(-71.06, 42.35, 0.0).enu_to_ecef_column_major();
        let g = Camera::from_geodetic(-70.96, 42.35, 100.0, 0.0, -90.0, 50.0, &frame).unwrap();
        assert!(g.eye_m[0] > 8000.0 && g.eye_m[0] < 8600.0, "{:?}", g.eye_m);
        let tilt_rad = (-g.forward[0]).asin().abs();
        let want_rad = g.eye_m[0] / 6.37e6;
        assert!(
            (tilt_rad - want_rad).abs() < 2e-4,
            "tilt {tilt_rad} want {want_rad}"
        );
    }

    #[test]
    fn geodetic_camera_is_the_same_in_ecef_whatever_the_root_transform() {
        // CesiumJS's setView at (lon, lat, h) with heading 30°, pitch −20°: eye at the geodetic point,
        // direction (E, N, U) = (sin 30° cos 20°, cos 30° cos 20°, −sin 20°) in the ENU frame at the eye.
        let (lon, lat, h) = (-73.98, 40.715, 250.0);
        let want_eye = geodetic_to_ecef(lon, lat, h);
        let [e, n, u] = globe_enu_axes(want_eye, lon, lat);
        let (sh, ch) = 30f64.to_radians().sin_cos();
        let (sp, cp) = (-20f64).to_radians().sin_cos();
        let want_dir: Vec3 = std::array::from_fn(|i| e[i] * sh * cp + n[i] * ch * cp + u[i] * sp);
        let enu_root = LocalFrame::new(-73.99, 40.71, 0.0).enu_to_ecef_column_major();
        let mut shifted_root = [0.0; 16]; // a plain translation: the root frame is ECEF minus an offset
        for k in [0, 5, 10, 15] {
            shifted_root[k] = 1.0;
        }
        shifted_root[12..15].copy_from_slice(&[1.3e6, -4.6e6, 4.1e6]);
        for root in [enu_root, shifted_root] {
            let cam = Camera::from_geodetic(lon, lat, h, 30.0, -20.0, 45.0, &root).unwrap();
            let (eye, dir, up) = cam.in_ecef(&root);
            assert!(
                (0..3).all(|i| (eye[i] - want_eye[i]).abs() < 1e-6),
                "{eye:?} vs {want_eye:?}"
            );
            assert!(close(dir, want_dir), "{dir:?} vs {want_dir:?}");
            assert!(vec3::dot(dir, up).abs() < 1e-12);
            let (heading, pitch) = cam.heading_pitch_on_globe(&root);
            assert!(
                (heading - 30.0).abs() < 1e-9 && (pitch + 20.0).abs() < 1e-9,
                "{heading} {pitch}"
            );
        }
        let singular = [0.0; 16];
        assert!(Camera::from_geodetic(lon, lat, h, 0.0, 0.0, 45.0, &singular).is_err());
        // Inside the Earth.
        assert!(Camera::from_geodetic(lon, lat, -6.0e6, 0.0, 0.0, 45.0, &enu_root).is_err());
        assert!(Camera::from_geodetic(lon, lat, -400.0, 0.0, 0.0, 45.0, &enu_root).is_ok());
    }

    #[test]
    fn globe_up_is_the_ellipsoid_normal_through_the_point_as_cesium_uses() {
        // At the surface it is the geodetic vertical; 1.5 km up at 40.7°N it leans ~1 µrad towards the
        // equator (CesiumJS's direction for heading 20°, pitch −45° there differs from the geodetic
        // frame's by 7.6e-7 in z, measured in CesiumJS 1.140).
        let (lon, lat) = (-73.985, 40.715);
        let geodetic_up = |h: f64| {
            let f = LocalFrame::new(lon, lat, h);
            vec3::sub(f.enu_to_ecef([0.0, 0.0, 1.0]), f.origin_ecef())
        };
        let at = |h: f64| globe_enu_axes(geodetic_to_ecef(lon, lat, h), lon, lat)[2];
        assert!(close(at(0.0), geodetic_up(0.0)));
        let tilt_rad = vec3::norm(vec3::cross(at(1500.0), geodetic_up(1500.0)));
        assert!(tilt_rad > 5e-7 && tilt_rad < 2e-6, "{tilt_rad}");
        // The pole has a frame too.
        let pole = globe_enu_axes(geodetic_to_ecef(0.0, 90.0, 10.0), 0.0, 90.0);
        assert!(pole.iter().all(|a| (vec3::norm(*a) - 1.0).abs() < 1e-12));
    }

    #[test]
    fn bad_camera_input_is_an_error_not_a_panic() {
        assert!(Camera::from_enu([f64::NAN, 0.0, 0.0], 0.0, 0.0, 45.0).is_err());
        assert!(Camera::from_enu([0.0; 3], 0.0, -120.0, 45.0).is_err());
        assert!(Camera::from_enu([0.0; 3], 0.0, 0.0, 0.0).is_err());
        assert!(Camera::new([0.0; 3], [0.0, 0.0, 1.0], [0.0, 0.0, 2.0], 45.0).is_err());
    }

    #[test]
    fn frustum_contains_point_ahead_and_excludes_point_behind() {
        let cam = Camera::from_enu([0.0; 3], 0.0, 0.0, 60.0).unwrap();
        let planes = cam.frustum_planes(Viewport::new(800, 600));
        let inside = |p: Vec3| planes.iter().all(|pl| vec3::dot(pl.n, p) + pl.d >= 0.0);
        assert!(inside([0.0, 100.0, 0.0]));
        assert!(!inside([0.0, -100.0, 0.0]));
        assert!(!inside([0.0, 100.0, 80.0])); // 38.7° up, outside a 30° half-fov
        assert!(inside([0.0, 100.0, 50.0])); // 26.6° up
    }
}
