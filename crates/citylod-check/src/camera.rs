//! The perspective camera of the checker, in the tileset root ENU frame (x east, y north, z up, metres).
//! Heading is clockwise from north and pitch is negative looking down, as in CesiumJS; roll is 0.
//! Invariant: `forward`, `up` and `right()` are unit vectors forming a right-handed orthonormal basis
//! (right × up = −forward, i.e. the camera looks along −z of its own x-right/y-up frame as in OpenGL).

use citylod_model::LocalFrame;

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

    /// A camera placed on the globe: eye at geodetic (lon°, lat°, ellipsoidal height m), heading and
    /// pitch in the camera's own local east-north-up frame (CesiumJS convention), expressed in the
    /// tileset's root frame `root_frame`. Far from the root origin the earth's curvature tilts the
    /// axes; this is taken into account exactly. Errors as [`Camera::from_enu`].
    pub fn from_geodetic(
        lon_deg: f64,
        lat_deg: f64,
        height_m: f64,
        heading_deg: f64,
        pitch_deg: f64,
        fovy_deg: f64,
        root_frame: &LocalFrame,
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
        let (forward_local, up_local) = heading_pitch_basis(heading_deg, pitch_deg)?;
        let cam_frame = LocalFrame::new(lon_deg, lat_deg, height_m);
        let eye_m = root_frame.geodetic_to_enu(lon_deg, lat_deg, height_m);
        // A direction maps between frames by rotation only: map the tip and subtract the mapped eye.
        let rotate = |v: Vec3| {
            let tip = root_frame.ecef_to_enu(cam_frame.enu_to_ecef(v));
            vec3::sub(tip, eye_m)
        };
        Camera::new(eye_m, rotate(forward_local), rotate(up_local), fovy_deg)
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
        let frame = LocalFrame::new(-71.06, 42.35, 0.0);
        let g = Camera::from_geodetic(-71.06, 42.35, 300.0, 30.0, -45.0, 50.0, &frame).unwrap();
        let e = Camera::from_enu([0.0, 0.0, 300.0], 30.0, -45.0, 50.0).unwrap();
        assert!(
            (0..3).all(|i| (g.eye_m[i] - e.eye_m[i]).abs() < 1e-3),
            "{:?}",
            g.eye_m
        );
        assert!(
            close(g.forward, e.forward),
            "{:?} vs {:?}",
            g.forward,
            e.forward
        );
        assert!(close(g.up, e.up), "{:?} vs {:?}", g.up, e.up);
    }

    #[test]
    fn geodetic_camera_far_east_has_up_tilted_by_curvature() {
        // 0.1° of longitude east at 42°N is ~8.3 km; the local vertical tilts east-ward by that angle.
        let frame = LocalFrame::new(-71.06, 42.35, 0.0);
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
