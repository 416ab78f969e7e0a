//! Placement: choose the local ENU frame for the ingested buildings and map footprints into it.
//! Rule: the origin is the centre of the lon/lat bounding box of all written buildings, at the
//! lowest ground height among them. Data heights (NAP, …) are taken as ellipsoidal heights as they
//! are here; the build raises the frame by EGM96's geoid height there with `--geoid egm96` ([`crate::geoid_height_m`])
//! and by what the user gives with `--height-offset`.

use citylod_model::LocalFrame;
use geo_types::{Coord, LineString, MultiPolygon, Polygon};

use crate::repair::{wrap_lon, Plane};
use crate::IngestError;

/// The frame rule in words, for the report.
pub const FRAME_RULE: &str = "origin = centre of the lon/lat bounding box of all written buildings (longitudes \
     taken in -180..180 or 0..360 degrees, whichever box is narrower, so data across the antimeridian is centred \
     there), at the lowest ground height among them; data heights taken as heights above the WGS84 ellipsoid";

/// A lon/lat bounding box in degrees, kept with longitudes in [−180°, 180°] and again in [0°, 360°): buildings
/// on both sides of the antimeridian make a box around the world in the first and a narrow one in the second.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LonLatBox {
    /// `[min_lon, min_lat, max_lon, max_lat]`, longitudes in [−180°, 180°].
    west: [f64; 4],
    /// The same with longitudes in [0°, 360°).
    east: [f64; 4],
}

impl LonLatBox {
    pub fn point(lon: f64, lat: f64) -> Self {
        let e = lon.rem_euclid(360.0);
        LonLatBox {
            west: [lon, lat, lon, lat],
            east: [e, lat, e, lat],
        }
    }

    pub fn union(self, o: Self) -> Self {
        let u = |a: [f64; 4], b: [f64; 4]| {
            [
                a[0].min(b[0]),
                a[1].min(b[1]),
                a[2].max(b[2]),
                a[3].max(b[3]),
            ]
        };
        LonLatBox {
            west: u(self.west, o.west),
            east: u(self.east, o.east),
        }
    }

    /// `[min_lon, min_lat, max_lon, max_lat]` in whichever convention gives the narrower box (the usual
    /// [−180°, 180°] on a tie), so `min_lon` may be over 180° when the box crosses the antimeridian.
    pub fn narrow(&self) -> [f64; 4] {
        if self.east[2] - self.east[0] < self.west[2] - self.west[0] {
            self.east
        } else {
            self.west
        }
    }

    /// The centre (lon in [−180°, 180°], lat) of the narrower box.
    pub fn centre(&self) -> (f64, f64) {
        let b = self.narrow();
        (wrap_lon((b[0] + b[2]) / 2.0), (b[1] + b[3]) / 2.0)
    }

    /// The farthest (m, along the sphere) that the narrower box's corners and edge midpoints lie from `from`
    /// (lon°, lat°): for one building's box, how far from there some part of it reaches.
    pub fn reach_m(&self, from: (f64, f64)) -> f64 {
        let n = self.narrow();
        let mut far: f64 = 0.0;
        for lon in [n[0], (n[0] + n[2]) / 2.0, n[2]] {
            for lat in [n[1], (n[1] + n[3]) / 2.0, n[3]] {
                far = far.max(great_circle_m(from, (lon, lat)));
            }
        }
        far
    }
}

/// The bounding box of a plane footprint, in lon/lat degrees.
pub(crate) fn lon_lat_box(plane: &Plane, fp: &MultiPolygon<f64>) -> LonLatBox {
    let mut points = fp.0.iter().flat_map(|p| &p.exterior().0).map(|c| {
        let (lon, lat) = plane.to_lon_lat(*c);
        LonLatBox::point(lon, lat)
    });
    let first = points.next().expect("a repaired footprint has vertices");
    points.fold(first, LonLatBox::union)
}

/// The frame for buildings with the given total lon/lat box and lowest ground height (m).
/// With no buildings the frame is at (0°, 0°, 0 m).
pub(crate) fn frame_for(bbox: Option<LonLatBox>, min_ground_m: Option<f64>) -> LocalFrame {
    match bbox {
        Some(b) => {
            let (lon, lat) = b.centre();
            LocalFrame::new(lon, lat, min_ground_m.unwrap_or(0.0))
        }
        None => LocalFrame::new(0.0, 0.0, 0.0),
    }
}

/// Farthest a building may lie from the frame's origin (m). Footprints are planar in the frame and prisms rise
/// along its up axis, while the ground turns away by 1° every ~111 km: at 100 km a building leans 0.9° and a
/// 100 m footprint's ends are 1.6 m off the ground. A region wider than 200 km is tiled in parts.
pub const MAX_DISTANCE_FROM_ORIGIN_M: f64 = 100_000.0;

/// The distance (m) along a sphere of the Earth's mean radius between two (lon, lat) points in degrees.
pub(crate) fn great_circle_m(a: (f64, f64), b: (f64, f64)) -> f64 {
    const MEAN_RADIUS_M: f64 = 6_371_008.8;
    let (la, lb) = (a.1.to_radians(), b.1.to_radians());
    let h = ((lb - la) / 2.0).sin().powi(2)
        + la.cos() * lb.cos() * ((b.0 - a.0).to_radians() / 2.0).sin().powi(2);
    2.0 * MEAN_RADIUS_M * h.sqrt().min(1.0).asin()
}

/// An error when some building of `b` lies over [`MAX_DISTANCE_FROM_ORIGIN_M`] from the frame's origin.
pub(crate) fn check_extent(
    frame: &LocalFrame,
    map: &EnuMap,
    b: &LonLatBox,
) -> Result<(), IngestError> {
    let far_m = farthest_from_origin_m(map, b);
    if far_m <= MAX_DISTANCE_FROM_ORIGIN_M {
        return Ok(());
    }
    let n = b.narrow();
    Err(IngestError::TooWide {
        detail: format!(
            "the buildings span longitudes {:.4}..{:.4} and latitudes {:.4}..{:.4}, up to {:.0} km from their \
             centre ({:.4}, {:.4}); a tileset is placed in one local frame, good to {:.0} km from its centre: \
             tile each region separately",
            wrap_lon(n[0]),
            wrap_lon(n[2]),
            n[1],
            n[3],
            far_m / 1000.0,
            frame.origin_lon_deg,
            frame.origin_lat_deg,
            MAX_DISTANCE_FROM_ORIGIN_M / 1000.0
        ),
    })
}

/// The farthest (m, horizontally in the frame) that the box's corners and edge midpoints lie from the origin.
fn farthest_from_origin_m(frame: &EnuMap, b: &LonLatBox) -> f64 {
    let n = b.narrow();
    let (lons, lats) = (
        [n[0], (n[0] + n[2]) / 2.0, n[2]],
        [n[1], (n[1] + n[3]) / 2.0, n[3]],
    );
    let mut far: f64 = 0.0;
    for lon in lons {
        for lat in lats {
            let e = frame.geodetic_to_enu(lon, lat, 0.0);
            // Points past a quarter of the globe have a negative up coordinate; count them by their chord.
            far = far.max((e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt());
        }
    }
    far
}

/// `LocalFrame::geodetic_to_enu` with the frame's axes and origin computed once (same result).
pub(crate) struct EnuMap {
    /// Columns of the ENU→ECEF rotation: east, north, up unit vectors in ECEF.
    axes: [[f64; 3]; 3],
    origin_ecef: [f64; 3],
}

impl EnuMap {
    pub fn new(frame: &LocalFrame) -> Self {
        let m = frame.enu_to_ecef_column_major();
        EnuMap {
            axes: [[m[0], m[1], m[2]], [m[4], m[5], m[6]], [m[8], m[9], m[10]]],
            origin_ecef: [m[12], m[13], m[14]],
        }
    }

    pub fn geodetic_to_enu(&self, lon_deg: f64, lat_deg: f64, h_m: f64) -> [f64; 3] {
        let q = citylod_model::geodetic_to_ecef(lon_deg, lat_deg, h_m);
        let d = [
            q[0] - self.origin_ecef[0],
            q[1] - self.origin_ecef[1],
            q[2] - self.origin_ecef[2],
        ];
        self.axes.map(|a| a[0] * d[0] + a[1] * d[1] + a[2] * d[2])
    }
}

/// Maps a plane footprint to ENU metres (x east, y north) at ellipsoidal height `base_h_m`, and
/// returns it with the ENU up coordinate of its centre at that height (which includes the Earth's
/// curvature drop away from the origin).
pub(crate) fn to_enu(
    frame: &EnuMap,
    plane: &Plane,
    fp: &MultiPolygon<f64>,
    base_h_m: f64,
) -> (MultiPolygon<f64>, f64) {
    let map_ring = |r: &LineString| -> LineString {
        r.0.iter()
            .map(|c| {
                let (lon, lat) = plane.to_lon_lat(*c);
                let e = frame.geodetic_to_enu(lon, lat, base_h_m);
                Coord { x: e[0], y: e[1] }
            })
            .collect()
    };
    let out = MultiPolygon(
        fp.0.iter()
            .map(|p| {
                Polygon::new(
                    map_ring(p.exterior()),
                    p.interiors().iter().map(map_ring).collect(),
                )
            })
            .collect(),
    );
    let (lon, lat) = lon_lat_box(plane, fp).centre();
    let base_z_m = frame.geodetic_to_enu(lon, lat, base_h_m)[2];
    (out, base_z_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cached_enu_map_matches_the_model_frame() {
        let f = LocalFrame::new(-71.06, 42.35, 12.0);
        let m = EnuMap::new(&f);
        let (a, b) = (
            m.geodetic_to_enu(-71.07, 42.36, 30.0),
            f.geodetic_to_enu(-71.07, 42.36, 30.0),
        );
        assert!((0..3).all(|i| (a[i] - b[i]).abs() < 1e-6), "{a:?} {b:?}");
    }

    #[test]
    fn frame_origin_is_box_centre_at_lowest_ground() {
        let b = LonLatBox::point(4.0, 52.0).union(LonLatBox::point(4.2, 52.1));
        let f = frame_for(Some(b), Some(-2.5));
        assert!((f.origin_lon_deg - 4.1).abs() < 1e-12 && (f.origin_lat_deg - 52.05).abs() < 1e-12);
        assert_eq!(f.origin_h_m, -2.5);
    }

    #[test]
    fn enu_mapping_keeps_winding_and_drops_with_curvature() {
        let plane = Plane::new(4.0, 52.0);
        let sq = MultiPolygon(vec![Polygon::new(
            LineString::from(vec![
                (0.0, 0.0),
                (10.0, 0.0),
                (10.0, 10.0),
                (0.0, 10.0),
                (0.0, 0.0),
            ]),
            vec![],
        )]);
        // A frame 5 km east: the square lies 5 km west, and ≈ 5000²/(2·6.38e6) ≈ 2 m below the plane.
        let (lon5, _) = plane.to_lon_lat(Coord { x: 5000.0, y: 0.0 });
        let frame = LocalFrame::new(lon5, 52.0, 0.0);
        let (enu, base_z) = to_enu(&EnuMap::new(&frame), &plane, &sq, 0.0);
        let r = &enu.0[0].exterior().0;
        let twice_area: f64 = r
            .windows(2)
            .map(|w| w[0].x * w[1].y - w[1].x * w[0].y)
            .sum();
        assert!(
            (twice_area / 2.0 - 100.0).abs() < 0.1,
            "area {}",
            twice_area / 2.0
        );
        assert!((r[0].x + 5000.0).abs() < 5.0);
        assert!((base_z + 1.96).abs() < 0.1, "{base_z}");
    }
}
