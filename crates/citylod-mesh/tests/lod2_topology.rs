//! Seed 003 acceptance on real LoD2 buildings (100 largest of Delft 3DBAG LoD2.2 and of Den Haag): at
//! 50/60/80 % no touching component pair separates with topo_qem (plain QEM is counted for comparison),
//! rates are met or explained, watertight inputs stay watertight, no degenerate or flipped triangles.

mod lod2_support;

use citylod_mesh::simplify::{simplify, Simplifier, DEFAULT_TOPO_QEM_A};
use citylod_mesh::topology::{contact_report, flipped_triangles, mesh_report, TOUCH_TOLERANCE_M};
use lod2_support::{largest, load_delft, load_denhaag, TestBuilding};
use rayon::prelude::*;

const RATES: [f64; 3] = [0.5, 0.6, 0.8];

#[derive(Default, Debug)]
struct Tally {
    buildings: usize,
    multi_component: usize,
    touching_pairs: usize,
    lost_topo: usize,
    lost_qem: usize,
    rate_ok_topo: usize,
    rate_noted_topo: usize,
    watertight_in: usize,
    watertight_kept: usize,
}

/// `contacts`: the set has touching components (Den Haag's dormers and annexes), so the contact check must have
/// something to hold: touching pairs, and plain QEM separating some of them.
fn check_set(name: &str, buildings: &[TestBuilding], contacts: bool) {
    let topo = Simplifier::TopoQem {
        a: DEFAULT_TOPO_QEM_A,
    };
    for rate in RATES {
        let rows: Vec<Tally> = buildings
            .par_iter()
            .map(|b| {
                let before = mesh_report(&b.mesh);
                let t = simplify(&b.mesh, &topo, rate);
                let q = simplify(&b.mesh, &Simplifier::Qem, rate);
                let ct = contact_report(&b.mesh, &t, TOUCH_TOLERANCE_M);
                let cq = contact_report(&b.mesh, &q, TOUCH_TOLERANCE_M);
                let after = mesh_report(&t.mesh);
                assert!(
                    ct.lost.is_empty(),
                    "{name} {} at {rate}: topo_qem separated {:?}",
                    b.id,
                    ct.lost
                );
                let rate_ok = (t.rate_reached - rate).abs() <= 0.01;
                // Past the target only by the last collapse (up to 2 triangles); short of it only when no
                // collapse was left within the error bound or keeping the mesh valid, as the note says.
                let n = b.mesh.triangles.len() as f64;
                assert!(
                    t.rate_reached <= rate + 0.01 || t.rate_reached <= rate + 2.0 / n + 1e-12,
                    "{name} {} at {rate}: removed {} of {n} triangles",
                    b.id,
                    t.rate_reached
                );
                if t.rate_reached < rate - 0.01 {
                    let note = t.note.as_deref().unwrap_or_default();
                    assert!(
                        note.contains("max_error_m") || note.contains("no collapse left"),
                        "{name} {} at {rate}: stopped at {} with the note {note:?}",
                        b.id,
                        t.rate_reached
                    );
                }
                if before.watertight {
                    assert!(
                        after.watertight,
                        "{name} {} at {rate}: lost watertightness {after:?}",
                        b.id
                    );
                }
                if before.orientation_consistent {
                    assert!(
                        after.orientation_consistent,
                        "{name} {} at {rate}: orientation broke",
                        b.id
                    );
                }
                assert!(
                    after.degenerate <= before.degenerate,
                    "{name} {}: degenerate {} > {}",
                    b.id,
                    after.degenerate,
                    before.degenerate
                );
                assert_eq!(
                    flipped_triangles(&b.mesh, &t),
                    0,
                    "{name} {} at {rate}: flipped triangles",
                    b.id
                );
                Tally {
                    buildings: 1,
                    multi_component: (ct.components > 1) as usize,
                    touching_pairs: ct.touching_before.len(),
                    lost_topo: ct.lost.len(),
                    lost_qem: cq.lost.len(),
                    rate_ok_topo: rate_ok as usize,
                    rate_noted_topo: (!rate_ok) as usize,
                    watertight_in: before.watertight as usize,
                    watertight_kept: (before.watertight && after.watertight) as usize,
                }
            })
            .collect();
        let mut s = Tally::default();
        for r in rows {
            s.buildings += r.buildings;
            s.multi_component += r.multi_component;
            s.touching_pairs += r.touching_pairs;
            s.lost_topo += r.lost_topo;
            s.lost_qem += r.lost_qem;
            s.rate_ok_topo += r.rate_ok_topo;
            s.rate_noted_topo += r.rate_noted_topo;
            s.watertight_in += r.watertight_in;
            s.watertight_kept += r.watertight_kept;
        }
        println!("{name} rate {:.0} %: {s:?}", rate * 100.0);
        assert_eq!(s.lost_topo, 0);
        assert_eq!(s.watertight_in, s.watertight_kept);
        assert!(
            s.watertight_in > 0,
            "{name}: no watertight input to keep so"
        );
        if contacts {
            assert!(s.touching_pairs > 0, "{name} at {rate}: {s:?}");
            assert!(
                s.lost_qem > 0,
                "{name} at {rate}: plain QEM separated nothing, so the contact check was not shown to catch it"
            );
        }
    }
}

#[test]
fn topo_qem_keeps_touching_components_together_on_den_haag() {
    let Some(all) = load_denhaag() else { return };
    let set = largest(all, 100);
    assert!(set
        .iter()
        .any(|b| citylod_mesh::simplify::components::components(
            b.mesh.positions.len(),
            &b.mesh.triangles
        )
        .count
            > 1));
    check_set("den-haag-100", &set, true);
}

/// Delft's 100 largest LoD2.2 solids are one component each (the contacts are Den Haag's test): topo_qem keeps them
/// closed, unflipped, and stops short of a rate only for a reason.
#[test]
fn topo_qem_keeps_delft_solids_closed_and_stops_only_for_a_reason() {
    let Some(all) = load_delft("2.2") else { return };
    check_set("delft-100", &largest(all, 100), false);
}

#[test]
#[ignore = "full data sets; run with --release -- --ignored --nocapture for the report figures"]
fn topo_qem_full_sets() {
    if let Some(all) = load_denhaag() {
        check_set("den-haag-all", &all, true);
    }
    if let Some(all) = load_delft("2.2") {
        check_set("delft-all", &all, false);
    }
}
