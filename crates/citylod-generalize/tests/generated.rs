//! Property tests of the whole generalization on generated cities: rows of touching houses, free
//! standing buildings at random spacing, duplicates and slivers. Every level partitions all buildings,
//! children ≤ δp, one top node, Δh and Δa ≥ 0, and Δh never decreases going up.

use citylod_generalize::{generalize, GeneralizeOptions};
use citylod_model::{Building, BuildingId, HeightSource};
use geo_types::{LineString, MultiPolygon, Polygon};
use proptest::prelude::*;

fn rect(x: f64, y: f64, w: f64, h: f64, rot: f64) -> MultiPolygon<f64> {
    let (c, s) = (rot.cos(), rot.sin());
    let pts: Vec<(f64, f64)> = [(0.0, 0.0), (w, 0.0), (w, h), (0.0, h), (0.0, 0.0)]
        .iter()
        .map(|&(u, v)| (x + u * c - v * s, y + u * s + v * c))
        .collect();
    MultiPolygon(vec![Polygon::new(LineString::from(pts), vec![])])
}

/// (kind, x, y, w, h, rotation, row length, height): kind 0 = free standing, 1 = a row of touching houses.
fn city() -> impl Strategy<Value = Vec<Building>> {
    prop::collection::vec(
        (
            0..2u8,
            0.0f64..400.0,
            0.0f64..400.0,
            3.0f64..30.0,
            3.0f64..30.0,
            0.0f64..1.6,
            1..25usize,
            3.0f64..60.0,
        ),
        1..60,
    )
    .prop_map(|specs| {
        let mut out = Vec::new();
        for (kind, x, y, w, h, rot, row, height_m) in specs {
            let count = if kind == 1 { row } else { 1 };
            for k in 0..count {
                let fp = rect(x + k as f64 * w, y, w, h, if kind == 1 { 0.0 } else { rot });
                let i = out.len();
                out.push(Building {
                    id: BuildingId(i as u32),
                    source_id: format!("g{i}"),
                    footprint: fp,
                    base_z_m: 0.0,
                    height_m: height_m + k as f64,
                    height_source: HeightSource::Default,
                    attributes: Default::default(),
                    mesh: None,
                });
            }
        }
        out
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn every_level_partitions_the_buildings(bs in city()) {
        let n = bs.len();
        let g = generalize(&bs, &GeneralizeOptions::default()).unwrap();
        let h = &g.hierarchy;
        prop_assert!(h.check_invariants(n).is_empty(), "{:?}", h.check_invariants(n));
        prop_assert_eq!(h.levels.last().unwrap().nodes.len(), 1);
        for li in 1..h.levels.len() {
            let (lv, below) = (&h.levels[li], &h.levels[li - 1]);
            prop_assert!(lv.nodes.len() < below.nodes.len() || n == 1);
            for node in &lv.nodes {
                prop_assert!(node.children.len() <= g.report.delta_p);
                // Δh is the spread of the members it keeps (landmarks are drawn apart), h_min / h_max its ends.
                let kept: Vec<f64> = node.members.iter()
                    .filter(|b| !node.landmarks.contains(b))
                    .map(|b| bs[b.0 as usize].height_m)
                    .collect();
                let (lo, hi) = kept.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
                prop_assert!(!kept.is_empty(), "a node of landmarks only");
                prop_assert_eq!((node.h_min_m, node.h_max_m), (lo, hi));
                prop_assert_eq!(node.dh_m, hi - lo);
                prop_assert!(node.da_m2 >= 0.0 && node.da_m2 <= node.area_m2);
                // Δh grows up the tree once the node's landmarks (drawn apart) leave the child's spread too.
                for c in &node.children {
                    let hs: Vec<f64> = below.nodes[c.0 as usize].members.iter()
                        .filter(|b| !node.landmarks.contains(b))
                        .map(|b| bs[b.0 as usize].height_m)
                        .collect();
                    let spread = hs.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                        - hs.iter().copied().fold(f64::INFINITY, f64::min);
                    prop_assert!(hs.is_empty() || node.dh_m >= spread - 1e-9);
                }
            }
        }
    }
}
