//! The generalization on real cities (Delft 3DBAG, NYC Lower East Side, Boston): every level is a
//! partition of all buildings, no node has more than δp children, the level count follows the formula,
//! Δh and Δa are non-negative and Δh never decreases going up.

mod common;

use citylod_generalize::{generalize, target_levels, GeneralizeOptions, Generalized, LevelKind};
use citylod_model::Building;

fn check_hierarchy(name: &str, buildings: &[Building]) -> Generalized {
    let n = buildings.len();
    let g = generalize(buildings, &GeneralizeOptions::default()).expect("generalize");
    let h = &g.hierarchy;
    let r = &g.report;
    eprintln!(
        "{name}: {n} buildings, {} candidate edges, levels (nodes): {:?}, tie splits {}, budget splits {}, \
         multipolygon nodes {}, footprint fallbacks {}, timings {:?}",
        r.n_candidate_edges,
        r.levels.iter().map(|l| l.nodes).collect::<Vec<_>>(),
        r.tie_splits,
        r.budget_splits,
        r.multipolygon_nodes,
        r.footprint_fallbacks,
        r.timings
    );
    for l in &r.levels {
        eprintln!("  level {} {:?}: {} nodes, threshold {:.3} m, max children {}, tie splits {}, budget splits {}",
            l.index, l.kind, l.nodes, l.threshold_m, l.max_children, l.tie_splits, l.budget_splits);
    }

    let errs = h.check_invariants(n);
    assert!(errs.is_empty(), "{name}: {:?}", &errs[..errs.len().min(10)]);
    assert_eq!(h.levels[0].nodes.len(), n);
    assert_eq!(
        h.levels.last().unwrap().nodes.len(),
        1,
        "{name}: one top node"
    );

    // Number of levels: L from the formula, rate levels = min(L − 1, …), plus inserted, top, extra.
    assert_eq!(r.target_levels, target_levels(n, 1.5));
    assert!(r.rate_levels < r.target_levels.max(1));
    let count = |k: LevelKind| r.levels.iter().filter(|l| l.kind == Some(k)).count();
    assert_eq!(
        count(LevelKind::Rate),
        r.rate_levels - r.rate_levels_skipped
    );
    assert_eq!(count(LevelKind::Top), 1);
    assert_eq!(
        h.levels.len() - 1,
        r.rate_levels - r.rate_levels_skipped
            + count(LevelKind::Inserted)
            + 1
            + count(LevelKind::ExtraTop)
    );
    assert!(
        count(LevelKind::Inserted) <= r.target_levels * 2,
        "insertions are bounded per interval"
    );

    for (li, lv) in h.levels.iter().enumerate().skip(1) {
        let below = &h.levels[li - 1];
        assert!(
            lv.nodes.len() < below.nodes.len(),
            "{name}: level {li} is coarser than the one below"
        );
        for node in &lv.nodes {
            assert!(
                node.children.len() <= r.delta_p,
                "{name}: level {li}: {} children",
                node.children.len()
            );
            assert!(
                node.dh_m >= 0.0 && node.da_m2 >= 0.0,
                "{name}: level {li}: Δh {} Δa {}",
                node.dh_m,
                node.da_m2
            );
            // Δh is the spread of the non-landmark members, so it grows going up once the node's landmarks
            // (drawn apart) leave the children's spread too.
            let heights = || {
                node.members
                    .iter()
                    .filter(|b| !node.landmarks.contains(b))
                    .map(|b| buildings[b.0 as usize].height_m)
            };
            let spread = heights().fold(f64::NEG_INFINITY, f64::max)
                - heights().fold(f64::INFINITY, f64::min);
            assert!(
                (node.dh_m - spread).abs() < 1e-9,
                "{name}: level {li}: Δh {} is not the spread {spread} of the non-landmarks",
                node.dh_m
            );
            assert!(!node.footprint.0.is_empty());
        }
    }
    g
}

#[test]
fn delft_hierarchy_is_sound() {
    let Some(bs) = common::load_cityjsonseq("delft-3dbag/delft.city.jsonl") else {
        return;
    };
    assert!(bs.len() > 1000);
    check_hierarchy("delft", &bs);
}

#[test]
fn nyc_les_hierarchy_is_sound() {
    let Some((bs, _skipped)) = common::load_geojson("nyc-les/les_buildings.geojson") else {
        return;
    };
    assert!(bs.len() > 1400);
    check_hierarchy("nyc-les", &bs);
}

#[test]
fn boston_hierarchy_is_sound() {
    let Some((bs, _skipped)) = common::load_geojson("boston/boston_buildings.geojson") else {
        return;
    };
    assert!(bs.len() > 22_000);
    let g = check_hierarchy("boston", &bs);
    // Touching row houses of Back Bay and the South End must have needed spatial splits.
    assert!(g.report.tie_splits > 0);
}

/// With landmarks off, Δh is the spread of all members, so it never decreases from a node to its parent.
#[test]
fn dh_never_decreases_going_up_without_landmarks() {
    let opts = GeneralizeOptions {
        landmark_min_excess_m: f64::INFINITY,
        ..Default::default()
    };
    let sets = [
        (
            "nyc-les",
            common::load_geojson("nyc-les/les_buildings.geojson").map(|(bs, _)| bs),
        ),
        (
            "delft",
            common::load_cityjsonseq("delft-3dbag/delft.city.jsonl"),
        ),
    ];
    for (name, bs) in sets {
        let Some(bs) = bs else { continue };
        let h = generalize(&bs, &opts).unwrap().hierarchy;
        let mut checked = 0;
        for li in 1..h.levels.len() {
            for node in &h.levels[li].nodes {
                assert!(node.landmarks.is_empty());
                for c in &node.children {
                    let child = &h.levels[li - 1].nodes[c.0 as usize];
                    assert!(
                        node.dh_m >= child.dh_m,
                        "{name}: level {li}: Δh {} below a child's {}",
                        node.dh_m,
                        child.dh_m
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000, "{name}: only {checked} parent–child pairs");
    }
}
