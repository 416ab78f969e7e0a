//! Measured error of the simplifiers on real LoD2 buildings: every one of the largest buildings changes and the
//! sampled Hausdorff distance sees it (above its resolution), its mean does not decrease as the rate grows (50 → 60 → 80 %), and topo_qem keeps
//! within its error bound. Also (ignored) the timing of simplifying every Delft LoD2.2 building.

mod lod2_support;

use citylod_mesh::hausdorff::{hausdorff_m, RESOLUTION_M};
use citylod_mesh::simplify::{
    simplify, simplify_all, Simplifier, DEFAULT_TOPO_QEM_A, DEFAULT_TOPO_QEM_MAX_ERROR_M,
};
use lod2_support::{largest, load_delft, load_denhaag, TestBuilding};
use rayon::prelude::*;

fn errors(set: &[TestBuilding], method: Simplifier, rate: f64) -> Vec<(f64, f64, bool)> {
    set.par_iter()
        .map(|b| {
            let out = simplify(&b.mesh, &method, rate);
            // 0.5 samples per m² keep the debug-build test fast; measured_error_m uses 4.
            let changed = out.mesh != b.mesh;
            let e = if changed {
                hausdorff_m(&b.mesh, &out.mesh, 0.5)
            } else {
                0.0
            };
            (e, out.rate_reached, changed)
        })
        .collect()
}

fn check(name: &str, set: &[TestBuilding]) {
    for (mname, method) in [
        (
            "topo_qem",
            Simplifier::TopoQem {
                a: DEFAULT_TOPO_QEM_A,
            },
        ),
        ("qem", Simplifier::Qem),
    ] {
        let mut last_mean = 0.0;
        for rate in [0.5, 0.6, 0.8] {
            let rows = errors(set, method, rate);
            // The largest buildings all simplify, and the sampled distance sees every change (raw, not floored at
            // the resolution the tile errors use): on these sets it is at least 6.7 cm.
            for (i, (e, _, changed)) in rows.iter().enumerate() {
                assert!(
                    *changed,
                    "{name} {mname} {} at {rate}: unchanged",
                    set[i].id
                );
                assert!(
                    *e > RESOLUTION_M,
                    "{name} {mname} {} at {rate}: changed mesh measured {e} m from its input",
                    set[i].id
                );
            }
            let n = rows.len() as f64;
            let mean = rows.iter().map(|r| r.0).sum::<f64>() / n;
            let max = rows.iter().map(|r| r.0).fold(0.0, f64::max);
            let mean_rate = rows.iter().map(|r| r.1).sum::<f64>() / n;
            println!("{name} {mname} target {:.0} %: mean rate reached {:.1} %, Hausdorff mean {mean:.3} m, max {max:.3} m", rate * 100.0, mean_rate * 100.0);
            if mname == "topo_qem" {
                // The bound is checked on samples about 2 × bound apart, so allow some overshoot.
                assert!(
                    max <= 1.5 * DEFAULT_TOPO_QEM_MAX_ERROR_M,
                    "{name} topo_qem at {rate}: Hausdorff {max} m over its {DEFAULT_TOPO_QEM_MAX_ERROR_M} m bound"
                );
            }
            assert!(
                mean >= last_mean,
                "{name} {mname}: mean error fell from {last_mean} to {mean} at {rate}"
            );
            last_mean = mean;
        }
    }
}

#[test]
fn hausdorff_error_is_positive_and_grows_with_rate_on_delft() {
    let Some(all) = load_delft("2.2") else { return };
    check("delft-10", &largest(all, 10));
}

#[test]
fn hausdorff_error_is_positive_and_grows_with_rate_on_den_haag() {
    let Some(all) = load_denhaag() else { return };
    check("den-haag-10", &largest(all, 10));
}

/// What `make bench` reports: every Delft LoD2.2 building through [`simplify_all`] at the paper's rates.
/// Issue 6 targets ≤ 5 s per run on 2 cores; `make bench` measures it (tests assert no times).
#[test]
#[ignore = "timing on the full Delft set; run with --release -- --ignored --nocapture"]
fn time_all_delft_lod22() {
    let Some(all) = load_delft("2.2") else { return };
    let meshes: Vec<&citylod_model::Mesh3d> = all.iter().map(|b| &b.mesh).collect();
    let tris: usize = meshes.iter().map(|m| m.triangles.len()).sum();
    for (name, method) in [
        (
            "topo_qem",
            Simplifier::TopoQem {
                a: DEFAULT_TOPO_QEM_A,
            },
        ),
        ("qem", Simplifier::Qem),
        (
            "profile",
            Simplifier::Profile {
                step_m: 1.0,
                threshold_m: 0.5,
            },
        ),
    ] {
        for rate in [0.5, 0.6, 0.8] {
            let t0 = std::time::Instant::now();
            let out = simplify_all(&meshes, &method, rate);
            let secs = t0.elapsed().as_secs_f64();
            let kept: usize = out.iter().map(|r| r.mesh.triangles.len()).sum();
            println!("delft all {} buildings, {tris} triangles, {name} at {:.0} %: {secs:.2} s on {} threads, {kept} triangles out ({:.1} % removed)", all.len(), rate * 100.0, rayon::current_num_threads(), 100.0 * (1.0 - kept as f64 / tris as f64));
            assert_eq!(out.len(), meshes.len());
            assert!(kept < tris);
        }
    }
}

#[test]
fn profile_simplifier_changes_real_buildings_within_its_step_and_threshold() {
    let Some(all) = load_delft("2.2") else { return };
    let set = largest(all, 20);
    let (step_m, threshold_m) = (3.0, 1.0);
    let method = Simplifier::Profile {
        step_m,
        threshold_m,
    };
    let rows: Vec<(bool, f64, f64, bool)> = set
        .par_iter()
        .map(|b| {
            let out = simplify(&b.mesh, &method, 0.5);
            let changed = out.mesh != b.mesh;
            let e = if changed {
                hausdorff_m(&b.mesh, &out.mesh, 0.5)
            } else {
                0.0
            };
            let r = citylod_mesh::topology::mesh_report(&out.mesh);
            assert!(out.mesh.triangles.len() <= b.mesh.triangles.len());
            (
                changed,
                out.rate_reached,
                e,
                r.orientation_consistent && r.degenerate == 0,
            )
        })
        .collect();
    let changed = rows.iter().filter(|r| r.0).count();
    let mean_rate = rows.iter().map(|r| r.1).sum::<f64>() / rows.len() as f64;
    let max_e = rows.iter().map(|r| r.2).fold(0.0, f64::max);
    println!("profile step {step_m} m threshold {threshold_m} m on delft-20: {changed} changed, mean rate {:.1} %, max Hausdorff {max_e:.2} m, clean {}", mean_rate * 100.0, rows.iter().filter(|r| r.3).count());
    assert!(changed > 0, "profile changed no building");
    assert!(rows.iter().filter(|r| r.0).all(|r| r.1 > 0.0));
    // Known limitation: a few sections yield overlapping loops whose caps leave slivers; most are clean.
    assert!(rows.iter().filter(|r| r.3).count() * 5 >= rows.len() * 4);
}
