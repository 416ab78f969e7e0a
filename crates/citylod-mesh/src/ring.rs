//! Ring clean-up before meshing: open the ring, drop near-duplicate consecutive points, drop rings
//! without area, and orient exteriors counter-clockwise and holes clockwise (seen from +z).
//! Units: local ENU metres. Invariant of the output: ≥ 3 points, no two consecutive points closer
//! than [`MERGE_DISTANCE_M`] (wrap-around included), non-zero signed area of the wanted sign.

use geo_types::LineString;

/// Consecutive ring points closer than this are merged (m): 1 µm, far below survey precision.
pub const MERGE_DISTANCE_M: f64 = 1e-6;

/// Rings with less area than this are dropped (m²).
const MIN_RING_AREA_M2: f64 = 1e-9;

/// Twice the signed area of an open ring (> 0 for counter-clockwise).
pub fn signed_area2(pts: &[[f64; 2]]) -> f64 {
    let n = pts.len();
    (0..n)
        .map(|i| {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

/// The ring as open points, cleaned and oriented (`ccw` for exteriors), or `None` when nothing with
/// area is left. Non-finite coordinates give `Err(())`.
pub fn clean_ring(ring: &LineString<f64>, ccw: bool) -> Result<Option<Vec<[f64; 2]>>, ()> {
    let mut pts: Vec<[f64; 2]> = Vec::with_capacity(ring.0.len());
    for c in &ring.0 {
        if !(c.x.is_finite() && c.y.is_finite()) {
            return Err(());
        }
        let p = [c.x, c.y];
        if pts.last().is_none_or(|q| dist(*q, p) >= MERGE_DISTANCE_M) {
            pts.push(p);
        }
    }
    while pts.len() > 1 && dist(pts[0], pts[pts.len() - 1]) < MERGE_DISTANCE_M {
        pts.pop();
    }
    if pts.len() < 3 {
        return Ok(None);
    }
    let a2 = signed_area2(&pts);
    if a2.abs() / 2.0 < MIN_RING_AREA_M2 {
        return Ok(None);
    }
    if (a2 > 0.0) != ccw {
        pts.reverse();
    }
    Ok(Some(pts))
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_duplicates_and_closing_point_are_dropped_and_orientation_fixed() {
        let r = LineString::from(vec![
            (0.0, 0.0),
            (0.0, 5.0),
            (0.0, 5.0 + 1e-9),
            (5.0, 5.0),
            (5.0, 0.0),
            (0.0, 0.0),
        ]);
        let pts = clean_ring(&r, true).unwrap().unwrap();
        assert_eq!(pts.len(), 4);
        assert!(signed_area2(&pts) > 0.0);
        let holes = clean_ring(&r, false).unwrap().unwrap();
        assert!(signed_area2(&holes) < 0.0);
    }

    #[test]
    fn collinear_ring_has_no_area_and_is_dropped() {
        let r = LineString::from(vec![(0.0, 0.0), (1.0, 1.0), (2.0, 2.0), (0.0, 0.0)]);
        assert_eq!(clean_ring(&r, true), Ok(None));
        let nan = LineString::from(vec![(0.0, 0.0), (f64::NAN, 1.0), (2.0, 0.0)]);
        assert_eq!(clean_ring(&nan, true), Err(()));
    }
}
