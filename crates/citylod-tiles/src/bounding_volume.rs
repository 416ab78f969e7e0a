//! The three 3D Tiles 1.1 bounding volumes as boxes (centre, three half-axes), so that a reader can treat every
//! tile alike. `box` and `sphere` are in the tile's frame (its transform applies); a `region` (west, south, east,
//! north in radians, minimum and maximum ellipsoidal height in metres) is in WGS84 geodetic coordinates and no
//! transform applies to it. Invariant: the box returned always contains the volume (a sphere's is the cube
//! around it, a region's an upper bound of its extent along east, north and up at its centre).

use citylod_model::{geodetic_to_ecef, LocalFrame, WGS84_A_M, WGS84_F};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Which bounding volume a tile's `boundingVolume` holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VolumeKind {
    #[default]
    Box,
    Sphere,
    Region,
}

impl VolumeKind {
    /// The property name in `boundingVolume`.
    pub fn name(self) -> &'static str {
        match self {
            VolumeKind::Box => "box",
            VolumeKind::Sphere => "sphere",
            VolumeKind::Region => "region",
        }
    }
}

/// A `sphere` or `region` as written, for exact containment tests (the box the reader gives encloses it).
#[derive(Debug, Clone, PartialEq)]
pub enum ExactVolume {
    /// Centre and radius in the root frame (only when the tile's transform into it is a similarity).
    Sphere { centre: [f64; 3], radius_m: f64 },
    /// `[west, south, east, north, min height, max height]` (radians, metres); `root_to_ecef` takes a point of
    /// the root frame to ECEF (the root tile's transform).
    Region {
        region: [f64; 6],
        root_to_ecef: [f64; 16],
    },
}

/// Smallest radius of curvature of the WGS84 ellipsoid (the meridian's at the equator, b²/a): an angle
/// outside a region, times it, under-estimates the distance along the surface.
const MIN_CURVATURE_RADIUS_M: f64 = 6_335_439.0;

impl ExactVolume {
    /// How far (m) `p` (root frame) lies outside the volume, 0 inside. For a region, a lower bound along
    /// longitude and latitude (angles times the smallest curvature radius), exact in height; `geodetic` is
    /// `p` as (lon°, lat°, ellipsoidal height m), for callers that convert once for several regions.
    pub fn distance_outside(&self, p: [f64; 3], geodetic: impl FnOnce() -> [f64; 3]) -> f64 {
        match self {
            ExactVolume::Sphere { centre, radius_m } => {
                let d = [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]];
                ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - radius_m).max(0.0)
            }
            ExactVolume::Region { region, .. } => {
                let [west, south, east, north, h_min, h_max] = *region;
                let [lon, lat, h] = geodetic();
                let (lon, lat) = (lon.to_radians(), lat.to_radians());
                // Longitude outside [west, east] (east < west wraps): the angle to the nearer edge.
                let span = (east - west).rem_euclid(TAU);
                let from_west = (lon - west).rem_euclid(TAU);
                let d_lon = if from_west <= span || (west == -PI && east == PI) {
                    0.0
                } else {
                    (from_west - span).min(TAU - from_west)
                };
                let d_lat = (south - lat).max(lat - north).max(0.0);
                let d_h = (h_min - h).max(h - h_max).max(0.0);
                let along = MIN_CURVATURE_RADIUS_M * (d_lon * lat.cos().max(0.0)).hypot(d_lat);
                along.hypot(d_h)
            }
        }
    }
}

/// The uniform scale of `m` when its linear part is a rotation times a scale (columns orthogonal, of equal
/// length within 1e-9), else `None`.
pub fn similarity_scale(m: &[f64; 16]) -> Option<f64> {
    let col = |k: usize| [m[4 * k], m[4 * k + 1], m[4 * k + 2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (a, b, c) = (col(0), col(1), col(2));
    let s2 = dot(a, a);
    let tol = 1e-9 * s2;
    let ok = s2 > 0.0
        && (dot(b, b) - s2).abs() <= tol
        && (dot(c, c) - s2).abs() <= tol
        && dot(a, b).abs() <= tol
        && dot(a, c).abs() <= tol
        && dot(b, c).abs() <= tol;
    ok.then(|| s2.sqrt())
}

/// Largest angle (rad) between neighbouring samples of a region's surfaces: 0.05 rad is ~320 km on the equator,
/// so city-sized regions are bounded by their corners alone and a whole-globe region takes ~16,000 samples.
const MAX_SAMPLE_STEP_RAD: f64 = 0.05;

/// The deepest minimum height (m) a region may have: below it the offset surfaces of the ellipsoid fold over
/// (the meridian's radius of curvature is ~6,335 km at the equator) and the sampling bound no longer holds.
pub const MIN_REGION_HEIGHT_M: f64 = -1.0e6;

/// The cube enclosing a sphere `[cx, cy, cz, r]`, axes along the frame's.
pub fn sphere_box(s: [f64; 4]) -> [f64; 12] {
    let [x, y, z, r] = s;
    [x, y, z, r, 0.0, 0.0, 0.0, r, 0.0, 0.0, 0.0, r]
}

/// A box in ECEF (m) enclosing the region `[west, south, east, north, min height, max height]` (radians, metres;
/// west > east crosses the antimeridian). Its axes are east, north and up at the region's centre. Both height
/// surfaces are sampled on a grid no coarser than [`MAX_SAMPLE_STEP_RAD`] (the side surfaces are straight along
/// the height, so their edges on those two surfaces bound them), and the box grows by how far a surface can
/// bulge between samples: a planar arc whose tangent turns by Δ with curvature radius ≤ R lies within
/// R·Δ·sin Δ / 2 of its chord — once along a parallel, once along a meridian.
pub fn region_box_ecef(r: [f64; 6]) -> Result<[f64; 12], String> {
    let [west, south, east, north, h_min, h_max] = r;
    let in_range = r.iter().all(|v| v.is_finite())
        && [west, east].iter().all(|a| a.abs() <= PI)
        && [south, north].iter().all(|a| a.abs() <= FRAC_PI_2)
        && south <= north
        && h_min <= h_max;
    if !in_range {
        return Err(format!(
            "region [{}] is not west, east in [-π, π], south ≤ north in [-π/2, π/2] (radians), then minimum ≤ \
             maximum height (m)",
            r.map(|v| v.to_string()).join(", ")
        ));
    }
    if h_min < MIN_REGION_HEIGHT_M {
        return Err(format!(
            "region minimum height {h_min} m is deeper than {MIN_REGION_HEIGHT_M} m, where no enclosing box is \
             computed"
        ));
    }
    let span_lon = if east < west {
        east + TAU - west
    } else {
        east - west
    };
    let span_lat = north - south;
    let steps = |span: f64| ((span / MAX_SAMPLE_STEP_RAD).ceil() as usize).max(1);
    let (n_lon, n_lat) = (steps(span_lon), steps(span_lat));
    let (d_lon, d_lat) = (span_lon / n_lon as f64, span_lat / n_lat as f64);

    let centre = LocalFrame::new(
        (west + span_lon / 2.0).to_degrees(),
        (south + span_lat / 2.0).to_degrees(),
        0.0,
    );
    let m = centre.enu_to_ecef_column_major();
    let origin = [m[12], m[13], m[14]];
    let axes: [[f64; 3]; 3] = std::array::from_fn(|k| [m[4 * k], m[4 * k + 1], m[4 * k + 2]]);
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];

    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for i in 0..=n_lon {
        let lon = west + d_lon * i as f64;
        for j in 0..=n_lat {
            let lat = (south + d_lat * j as f64).min(north);
            for h in [h_min, h_max] {
                let p = geodetic_to_ecef(lon.to_degrees(), lat.to_degrees(), h);
                let d = [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]];
                for k in 0..3 {
                    let t = dot(d, axes[k]);
                    lo[k] = lo[k].min(t);
                    hi[k] = hi[k].max(t);
                }
            }
        }
    }
    // Largest radius of curvature of either height surface: the meridian's at the poles, a²/b, raised by the
    // height (parallels have radius (N + h)·cos φ ≤ a²/b + h).
    let b = WGS84_A_M * (1.0 - WGS84_F);
    let radius_m = WGS84_A_M * WGS84_A_M / b + h_max.max(0.0);
    let bulge = |delta: f64| radius_m * delta * delta.sin() / 2.0;
    let pad_m = bulge(d_lon) + bulge(d_lat) + 1e-3;

    let mut out = [0.0; 12];
    for k in 0..3 {
        let mid = (lo[k] + hi[k]) / 2.0;
        let half = (hi[k] - lo[k]) / 2.0 + pad_m;
        for c in 0..3 {
            out[c] += axes[k][c] * mid;
            out[3 + 3 * k + c] = axes[k][c] * half;
        }
    }
    for c in 0..3 {
        out[c] += origin[c];
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `p` lies in the box (half-axes orthogonal), within `slack_m`.
    fn inside(b: &[f64; 12], p: [f64; 3], slack_m: f64) -> bool {
        let d = [p[0] - b[0], p[1] - b[1], p[2] - b[2]];
        (0..3).all(|k| {
            let h = [b[3 + 3 * k], b[4 + 3 * k], b[5 + 3 * k]];
            let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            let t = (d[0] * h[0] + d[1] * h[1] + d[2] * h[2]) / len;
            t.abs() <= len + slack_m
        })
    }

    /// Dense samples of the whole region, inside included (a fine grid at several heights).
    fn dense(r: [f64; 6]) -> Vec<[f64; 3]> {
        let [w, s, e, n, h0, h1] = r;
        let e = if e < w { e + TAU } else { e };
        let k = 60;
        let mut out = Vec::new();
        for i in 0..=k {
            for j in 0..=k {
                for l in 0..=3 {
                    let lon = w + (e - w) * i as f64 / k as f64;
                    let lat = s + (n - s) * j as f64 / k as f64;
                    let h = h0 + (h1 - h0) * l as f64 / 3.0;
                    out.push(geodetic_to_ecef(lon.to_degrees(), lat.to_degrees(), h));
                }
            }
        }
        out
    }

    #[test]
    fn region_box_contains_every_point_of_the_region() {
        let cases = [
            // A city block in Manhattan, 0–300 m.
            [-1.2913, 0.7105, -1.2911, 0.7107, -30.0, 300.0],
            // A country-sized one, a whole hemisphere, and one across the antimeridian.
            [0.05, 0.8, 0.3, 1.0, 0.0, 5000.0],
            [-PI / 2.0, -FRAC_PI_2, PI / 2.0, FRAC_PI_2, -100.0, 1.0e5],
            [3.0, -0.2, -3.0, 0.3, 0.0, 100.0],
            // The whole globe.
            [-PI, -FRAC_PI_2, PI, FRAC_PI_2, 0.0, 0.0],
        ];
        for r in cases {
            let b = region_box_ecef(r).unwrap();
            for p in dense(r) {
                assert!(inside(&b, p, 0.0), "{r:?}: {p:?} outside {b:?}");
            }
        }
    }

    #[test]
    fn small_region_box_is_tight() {
        // ~180 m × 220 m × 330 m: the box may not be more than a few centimetres larger.
        let r = [-1.2913, 0.7105, -1.2911, 0.7107, -30.0, 300.0];
        let b = region_box_ecef(r).unwrap();
        let len = |k: usize| (0..3).map(|c| b[3 + 3 * k + c].powi(2)).sum::<f64>().sqrt();
        let north_half = 0.0001 * 6_363_000.0;
        assert!(
            (len(1) - north_half).abs() < 0.05 * north_half,
            "{}",
            len(1)
        );
        let up_half = len(2);
        assert!((165.0..168.0).contains(&up_half), "{up_half}");
    }

    #[test]
    fn region_across_the_antimeridian_is_the_short_way_round() {
        let b = region_box_ecef([3.1, 0.0, -3.1, 0.1, 0.0, 10.0]).unwrap();
        // Its centre faces lon π, not lon 0.
        assert!(b[0] < -6.0e6, "{b:?}");
        let width = (0..3).map(|c| b[3 + c].powi(2)).sum::<f64>().sqrt() * 2.0;
        assert!(width < 600_000.0, "{width}");
    }

    #[test]
    fn invalid_or_unsafe_regions_are_refused() {
        for (r, expect) in [
            ([0.0, 0.5, 0.1, 0.4, 0.0, 1.0], "south ≤ north"),
            ([0.0, 0.0, 4.0, 0.1, 0.0, 1.0], "[-π, π]"),
            ([0.0, 0.0, 0.1, 2.0, 0.0, 1.0], "[-π/2, π/2]"),
            ([0.0, 0.0, 0.1, 0.1, 5.0, 1.0], "minimum ≤"),
            (
                [0.0, 0.0, 0.1, 0.1, f64::NAN, 1.0],
                "region [0, 0, 0.1, 0.1, NaN",
            ),
            ([0.0, 0.0, 0.1, 0.1, -5.0e6, 1.0], "deeper than"),
        ] {
            let e = region_box_ecef(r).unwrap_err();
            assert!(e.contains(expect), "{expect}: {e}");
        }
    }

    #[test]
    fn sphere_box_is_the_enclosing_cube() {
        assert_eq!(
            sphere_box([1.0, 2.0, 3.0, 4.0]),
            [1.0, 2.0, 3.0, 4.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 4.0]
        );
    }
}
