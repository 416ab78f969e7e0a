//! The local east-north-up frame all geometry work happens in, and its placement on the WGS84
//! ellipsoid. Angles in degrees, lengths in metres; ECEF is the WGS84 earth-centred earth-fixed frame.
//! Invariant: `enu_to_geodetic(geodetic_to_enu(p)) == p` to well under a millimetre near the origin.

/// WGS84 semi-major axis (m).
pub const WGS84_A_M: f64 = 6_378_137.0;
/// WGS84 flattening.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// Geodetic (lon°, lat°, ellipsoidal height m) → ECEF (m).
pub fn geodetic_to_ecef(lon_deg: f64, lat_deg: f64, h_m: f64) -> [f64; 3] {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let (lon, lat) = (lon_deg.to_radians(), lat_deg.to_radians());
    let n = WGS84_A_M / (1.0 - e2 * lat.sin() * lat.sin()).sqrt();
    [
        (n + h_m) * lat.cos() * lon.cos(),
        (n + h_m) * lat.cos() * lon.sin(),
        (n * (1.0 - e2) + h_m) * lat.sin(),
    ]
}

/// ECEF (m) → geodetic (lon°, lat°, ellipsoidal height m). Iterative; sub-millimetre for points
/// near the surface.
pub fn ecef_to_geodetic(p: [f64; 3]) -> [f64; 3] {
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let [x, y, z] = p;
    let lon = y.atan2(x);
    let r = (x * x + y * y).sqrt();
    let mut lat = z.atan2(r * (1.0 - e2));
    let mut h = 0.0;
    for _ in 0..8 {
        let n = WGS84_A_M / (1.0 - e2 * lat.sin() * lat.sin()).sqrt();
        h = if lat.cos().abs() > 1e-9 {
            r / lat.cos() - n
        } else {
            z.abs() - n * (1.0 - e2)
        };
        lat = z.atan2(r * (1.0 - e2 * n / (n + h)));
    }
    [lon.to_degrees(), lat.to_degrees(), h]
}

/// A local ENU frame with its origin on the ellipsoid at (lon°, lat°, h m).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LocalFrame {
    pub origin_lon_deg: f64,
    pub origin_lat_deg: f64,
    pub origin_h_m: f64,
}

impl LocalFrame {
    pub fn new(origin_lon_deg: f64, origin_lat_deg: f64, origin_h_m: f64) -> Self {
        Self {
            origin_lon_deg,
            origin_lat_deg,
            origin_h_m,
        }
    }

    /// Unit vectors east, north, up in ECEF at the origin.
    fn axes(&self) -> [[f64; 3]; 3] {
        let (lon, lat) = (
            self.origin_lon_deg.to_radians(),
            self.origin_lat_deg.to_radians(),
        );
        let (so, co, sa, ca) = (lon.sin(), lon.cos(), lat.sin(), lat.cos());
        [
            [-so, co, 0.0],
            [-sa * co, -sa * so, ca],
            [ca * co, ca * so, sa],
        ]
    }

    /// ECEF position of the origin (m).
    pub fn origin_ecef(&self) -> [f64; 3] {
        geodetic_to_ecef(self.origin_lon_deg, self.origin_lat_deg, self.origin_h_m)
    }

    /// The 4×4 ENU→ECEF matrix in column-major order, as 3D Tiles `transform` expects.
    pub fn enu_to_ecef_column_major(&self) -> [f64; 16] {
        let [e, n, u] = self.axes();
        let o = self.origin_ecef();
        [
            e[0], e[1], e[2], 0.0, n[0], n[1], n[2], 0.0, u[0], u[1], u[2], 0.0, o[0], o[1], o[2],
            1.0,
        ]
    }

    /// ENU (m) → ECEF (m).
    pub fn enu_to_ecef(&self, p: [f64; 3]) -> [f64; 3] {
        let [e, n, u] = self.axes();
        let o = self.origin_ecef();
        std::array::from_fn(|i| o[i] + p[0] * e[i] + p[1] * n[i] + p[2] * u[i])
    }

    /// ECEF (m) → ENU (m).
    pub fn ecef_to_enu(&self, q: [f64; 3]) -> [f64; 3] {
        let axes = self.axes();
        let o = self.origin_ecef();
        let d = [q[0] - o[0], q[1] - o[1], q[2] - o[2]];
        axes.map(|a| a[0] * d[0] + a[1] * d[1] + a[2] * d[2])
    }

    /// Geodetic (lon°, lat°, h m) → ENU (m).
    pub fn geodetic_to_enu(&self, lon_deg: f64, lat_deg: f64, h_m: f64) -> [f64; 3] {
        self.ecef_to_enu(geodetic_to_ecef(lon_deg, lat_deg, h_m))
    }

    /// ENU (m) → geodetic (lon°, lat°, h m).
    pub fn enu_to_geodetic(&self, p: [f64; 3]) -> [f64; 3] {
        ecef_to_geodetic(self.enu_to_ecef(p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geodetic_ecef_round_trip_is_sub_millimetre() {
        for &(lon, lat, h) in &[
            (4.36, 52.0, 0.0),
            (-71.06, 42.35, 120.0),
            (-73.98, 40.71, -30.0),
            (179.9, -89.0, 5.0),
        ] {
            let g = ecef_to_geodetic(geodetic_to_ecef(lon, lat, h));
            assert!(
                (g[0] - lon).abs() < 1e-9 && (g[1] - lat).abs() < 1e-9 && (g[2] - h).abs() < 1e-3,
                "{g:?}"
            );
        }
    }

    #[test]
    fn enu_axes_point_east_north_up() {
        let f = LocalFrame::new(-71.06, 42.35, 0.0);
        let east = f.enu_to_geodetic([100.0, 0.0, 0.0]);
        let north = f.enu_to_geodetic([0.0, 100.0, 0.0]);
        assert!(east[0] > -71.06 && (east[1] - 42.35).abs() < 1e-5);
        assert!(north[1] > 42.35 && (north[0] + 71.06).abs() < 1e-9);
        // 100 m north is about 0.0009 degrees of latitude.
        assert!((north[1] - 42.35 - 100.0 / 111_070.0).abs() < 2e-6);
    }

    #[test]
    fn column_major_matrix_matches_enu_to_ecef() {
        let f = LocalFrame::new(4.36, 52.0, 3.0);
        let m = f.enu_to_ecef_column_major();
        let p = [12.0, -40.0, 7.0];
        let q: [f64; 3] =
            std::array::from_fn(|r| m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
        let want = f.enu_to_ecef(p);
        for i in 0..3 {
            assert!((q[i] - want[i]).abs() < 1e-6);
        }
    }
}
