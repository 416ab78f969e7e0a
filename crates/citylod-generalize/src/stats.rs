//! Per-node statistics (seed 000 Eq. 5, DESIGN.md §3.7): area-weighted mean height and base, h_min, h_max,
//! Δh over the non-landmark members, and Δa = area(node footprint) − Σ area(members) ≥ 0. Metres and m².
//! Invariant: h_min ≤ height ≤ h_max, Δh ≥ 0, Δa ≥ 0.

use citylod_model::{Building, BuildingId, Footprint, Node};
use geo::Area;

/// The measured properties of one node, copied into `citylod_model::Node` by [`NodeStats::write_into`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeStats {
    /// Σ hᵢ·aᵢ / Σ aᵢ over non-landmark members (m), aᵢ = footprint area (Eq. 5).
    pub height_m: f64,
    /// Area-weighted mean base height of the same members (m).
    pub base_z_m: f64,
    pub h_min_m: f64,
    pub h_max_m: f64,
    /// h_max − h_min (m).
    pub dh_m: f64,
    /// area(footprint) − Σ area(all members, landmarks included) (m²), clamped at 0.
    pub da_m2: f64,
    /// Area of the node footprint (m²).
    pub area_m2: f64,
}

impl NodeStats {
    /// Copies the statistics into the matching fields of `node`.
    pub fn write_into(&self, node: &mut Node) {
        node.height_m = self.height_m;
        node.base_z_m = self.base_z_m;
        node.h_min_m = self.h_min_m;
        node.h_max_m = self.h_max_m;
        node.dh_m = self.dh_m;
        node.da_m2 = self.da_m2;
        node.area_m2 = self.area_m2;
    }
}

/// Statistics of a node with buildings `members` and merged footprint `footprint` (local ENU m).
/// Buildings listed in `landmarks` are left out of the height statistics (they are drawn at full detail
/// on top of the block) but count in Δa, since the footprint covers them.
///
/// Degenerate input: when every member is a landmark, all members are used for the heights; when the
/// weights sum to 0 (zero-area footprints), the plain mean is used; no members gives all zeros except
/// `area_m2`. Σ area may exceed the footprint area when members overlap (OSM building parts), hence
/// the clamp; a footprint smaller than its largest member means coverage broke (debug assertion).
///
/// # Examples
/// ```
/// use citylod_generalize::node_stats;
/// use citylod_model::{Building, BuildingId, HeightSource};
/// use geo_types::{polygon, MultiPolygon};
/// let sq = |x0: f64, w: f64| MultiPolygon(vec![polygon![(x: x0, y: 0.0), (x: x0 + w, y: 0.0),
///     (x: x0 + w, y: 10.0), (x: x0, y: 10.0)]]);
/// let b = |i: u32, fp, h| Building { id: BuildingId(i), source_id: i.to_string(), footprint: fp,
///     base_z_m: 0.0, height_m: h, height_source: HeightSource::Default,
///     attributes: Default::default(), mesh: None };
/// let (b0, b1) = (b(0, sq(0.0, 10.0), 10.0), b(1, sq(10.0, 30.0), 20.0));
/// let s = node_stats(&[&b0, &b1], &sq(0.0, 40.0), &[]);
/// assert_eq!(s.height_m, 17.5); // (10·100 + 20·300) / 400
/// assert_eq!(s.dh_m, 10.0);
/// ```
pub fn node_stats(
    members: &[&Building],
    footprint: &Footprint,
    landmarks: &[BuildingId],
) -> NodeStats {
    // Sorted landmarks (as `landmarks_of` returns them) are looked up by bisection: top nodes have thousands.
    let sorted = landmarks.windows(2).all(|w| w[0] <= w[1]);
    let is_landmark = |id: BuildingId| {
        if sorted {
            landmarks.binary_search(&id).is_ok()
        } else {
            landmarks.contains(&id)
        }
    };
    let area_m2 = footprint.unsigned_area();
    let member_area_m2: Vec<f64> = members.iter().map(|b| b.area_m2()).collect();
    let sum_area_m2: f64 = member_area_m2.iter().sum();
    let largest_m2 = member_area_m2.iter().copied().fold(0.0, f64::max);
    debug_assert!(
        area_m2 >= largest_m2 * 0.99 - 1e-6,
        "node footprint ({area_m2} m²) smaller than a member ({largest_m2} m²): coverage broke"
    );
    let mut heighted: Vec<(&Building, f64)> = members
        .iter()
        .zip(&member_area_m2)
        .filter(|(b, _)| !is_landmark(b.id))
        .map(|(b, &a)| (*b, a))
        .collect();
    if heighted.is_empty() {
        heighted = members
            .iter()
            .copied()
            .zip(member_area_m2.iter().copied())
            .collect();
    }
    let (mut w, mut wh, mut wz) = (0.0, 0.0, 0.0);
    let (mut h_min_m, mut h_max_m) = (f64::INFINITY, f64::NEG_INFINITY);
    for &(b, a) in &heighted {
        w += a;
        wh += a * b.height_m;
        wz += a * b.base_z_m;
        h_min_m = h_min_m.min(b.height_m);
        h_max_m = h_max_m.max(b.height_m);
    }
    let (height_m, base_z_m) = if heighted.is_empty() {
        (0.0, 0.0)
    } else if w > 0.0 {
        (wh / w, wz / w)
    } else {
        let n = heighted.len() as f64;
        (
            heighted.iter().map(|(b, _)| b.height_m).sum::<f64>() / n,
            heighted.iter().map(|(b, _)| b.base_z_m).sum::<f64>() / n,
        )
    };
    if heighted.is_empty() {
        h_min_m = 0.0;
        h_max_m = 0.0;
    }
    NodeStats {
        // Rounding can put the weighted mean a hair outside [h_min, h_max].
        height_m: height_m.clamp(h_min_m, h_max_m),
        base_z_m,
        h_min_m,
        h_max_m,
        dh_m: h_max_m - h_min_m,
        da_m2: (area_m2 - sum_area_m2).max(0.0),
        area_m2,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::merge::tests::rect;
    use citylod_model::HeightSource;
    use proptest::prelude::*;

    fn building(i: u32, fp: Footprint, base_z_m: f64, height_m: f64) -> Building {
        Building {
            id: BuildingId(i),
            source_id: format!("b{i}"),
            footprint: fp,
            base_z_m,
            height_m,
            height_source: HeightSource::Default,
            attributes: Default::default(),
            mesh: None,
        }
    }

    #[test]
    fn eq5_area_weighted_height_is_exact() {
        // Areas 100, 200, 50 m²; heights 10, 25, 4 m: (1000 + 5000 + 200) / 350.
        let b = [
            building(0, rect(0.0, 0.0, 10.0, 10.0), 1.0, 10.0),
            building(1, rect(12.0, 0.0, 32.0, 10.0), 2.0, 25.0),
            building(2, rect(0.0, 12.0, 5.0, 22.0), 4.0, 4.0),
        ];
        let refs: Vec<&Building> = b.iter().collect();
        let s = node_stats(&refs, &rect(0.0, 0.0, 32.0, 22.0), &[]);
        assert!((s.height_m - 6200.0 / 350.0).abs() < 1e-12);
        assert!((s.base_z_m - (100.0 + 400.0 + 200.0) / 350.0).abs() < 1e-12);
        assert_eq!((s.h_min_m, s.h_max_m, s.dh_m), (4.0, 25.0, 21.0));
        assert!((s.area_m2 - 704.0).abs() < 1e-9);
        assert!((s.da_m2 - 354.0).abs() < 1e-9);
    }

    #[test]
    fn landmarks_leave_height_stats_but_count_in_delta_a() {
        let b = [
            building(0, rect(0.0, 0.0, 10.0, 10.0), 0.0, 10.0),
            building(1, rect(10.0, 0.0, 20.0, 10.0), 0.0, 12.0),
            building(2, rect(20.0, 0.0, 22.0, 2.0), 0.0, 150.0),
        ];
        let refs: Vec<&Building> = b.iter().collect();
        let s = node_stats(&refs, &rect(0.0, 0.0, 22.0, 10.0), &[BuildingId(2)]);
        assert_eq!((s.height_m, s.h_max_m, s.dh_m), (11.0, 12.0, 2.0));
        assert!((s.da_m2 - (220.0 - 204.0)).abs() < 1e-9);
        // Only landmarks: heights fall back to all members.
        let s = node_stats(&refs[2..], &rect(20.0, 0.0, 22.0, 2.0), &[BuildingId(2)]);
        assert_eq!(s.height_m, 150.0);
    }

    #[test]
    fn overlapping_members_clamp_delta_a_at_zero() {
        let b = [
            building(0, rect(0.0, 0.0, 10.0, 10.0), 0.0, 10.0),
            building(1, rect(2.0, 2.0, 8.0, 8.0), 0.0, 20.0),
        ];
        let refs: Vec<&Building> = b.iter().collect();
        let s = node_stats(&refs, &rect(0.0, 0.0, 10.0, 10.0), &[]);
        assert_eq!(s.da_m2, 0.0);
    }

    proptest! {
        #[test]
        fn height_is_the_area_weighted_mean_and_deltas_follow_the_members(
            hs in prop::collection::vec((1.0f64..20.0, 0.5f64..80.0), 1..12)
        ) {
            // Squares of side w, 25 m apart, under a 20 m-deep block: they never overlap, so nothing clamps.
            let b: Vec<Building> = hs.iter().enumerate()
                .map(|(i, &(w, h))| building(i as u32, rect(i as f64 * 25.0, 0.0, i as f64 * 25.0 + w, w), 0.0, h))
                .collect();
            let refs: Vec<&Building> = b.iter().collect();
            let fp = rect(0.0, 0.0, hs.len() as f64 * 25.0, 20.0);
            let s = node_stats(&refs, &fp, &[]);
            let areas: f64 = hs.iter().map(|&(w, _)| w * w).sum();
            let mean = hs.iter().map(|&(w, h)| w * w * h).sum::<f64>() / areas;
            let (lo, hi) = hs.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &(_, h)| (lo.min(h), hi.max(h)));
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
            prop_assert!(close(s.height_m, mean), "height {} against {mean}", s.height_m);
            prop_assert!((s.h_min_m, s.h_max_m) == (lo, hi));
            prop_assert!(s.dh_m == hi - lo);
            let block = hs.len() as f64 * 25.0 * 20.0;
            prop_assert!(close(s.area_m2, block), "area {} against {block}", s.area_m2);
            prop_assert!(close(s.da_m2, block - areas), "Δa {} against {}", s.da_m2, block - areas);
        }
    }
}
