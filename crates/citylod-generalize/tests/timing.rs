//! Release timings (ignored by default; run with
//! `cargo test -p citylod-generalize --release --test timing -- --ignored --nocapture`):
//! Boston (22,186 buildings) and a generated city (`CITYLOD_SYNTH_N` buildings, default 100,000).

mod common;

use citylod_generalize::{generalize, GeneralizeOptions};
use citylod_model::{Building, BuildingId, HeightSource};
use geo_types::{LineString, MultiPolygon, Polygon};
use std::time::Instant;

/// CPU time (user + system) of this process so far (s), from /proc/self/stat; 0 where unavailable.
/// The machine may be shared, so wall time alone overstates the cost.
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = after
        .split_whitespace()
        .filter_map(|x| x.parse().ok())
        .collect();
    // After the command name: state (not a number, dropped), ppid, …, utime, stime (ticks of 1/100 s).
    if f.len() > 12 {
        (f[10] + f[11]) / 100.0
    } else {
        0.0
    }
}

#[test]
#[ignore]
fn time_boston() {
    let Some((bs, _)) = common::load_geojson("boston/boston_buildings.geojson") else {
        return;
    };
    for run in 0..2 {
        let (t, c) = (Instant::now(), cpu_s());
        let g = generalize(&bs, &GeneralizeOptions::default()).unwrap();
        let total = t.elapsed().as_secs_f64();
        eprintln!(
            "boston run {run}: {} buildings in {:.3} s wall, {:.2} s CPU; {:?}; levels {:?}; edges {} (refine {})",
            bs.len(),
            total,
            cpu_s() - c,
            g.report.timings,
            g.report.levels.iter().map(|l| l.nodes).collect::<Vec<_>>(),
            g.report.n_candidate_edges,
            g.report.graph.n_refine_pairs
        );
        assert!(g.hierarchy.check_invariants(bs.len()).is_empty());
    }
}

/// Blocks of 2 × `per_row` touching row houses (8 m × 12 m, heights vary), separated by 15 m streets,
/// with some jitter in block size so the dendrogram is not all ties.
pub fn synthetic_city(n: usize) -> Vec<Building> {
    let per_row = 10;
    let per_block = 2 * per_row;
    let blocks = n.div_ceil(per_block);
    let side = (blocks as f64).sqrt().ceil() as usize;
    let mut out = Vec::with_capacity(n);
    'outer: for bi in 0..blocks {
        let (bx, by) = (
            (bi % side) as f64 * (8.0 * per_row as f64 + 15.0),
            (bi / side) as f64 * (24.0 + 15.0 + (bi % 3) as f64),
        );
        for k in 0..per_block {
            if out.len() == n {
                break 'outer;
            }
            let (x, y) = (
                bx + (k % per_row) as f64 * 8.0,
                by + (k / per_row) as f64 * 12.0,
            );
            let ring = LineString::from(vec![
                (x, y),
                (x + 8.0, y),
                (x + 8.0, y + 12.0),
                (x, y + 12.0),
                (x, y),
            ]);
            let i = out.len();
            out.push(Building {
                id: BuildingId(i as u32),
                source_id: format!("s{i}"),
                footprint: MultiPolygon(vec![Polygon::new(ring, vec![])]),
                base_z_m: 0.0,
                height_m: 6.0 + (i * 7 % 13) as f64,
                height_source: HeightSource::Default,
                attributes: Default::default(),
                mesh: None,
            });
        }
    }
    out
}

#[test]
#[ignore]
fn time_synthetic_city() {
    let n: usize = std::env::var("CITYLOD_SYNTH_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000);
    let bs = synthetic_city(n);
    let (t, c) = (Instant::now(), cpu_s());
    let g = generalize(&bs, &GeneralizeOptions::default()).unwrap();
    eprintln!(
        "synthetic: {n} buildings in {:.3} s wall, {:.2} s CPU; {:?}; levels {:?}",
        t.elapsed().as_secs_f64(),
        cpu_s() - c,
        g.report.timings,
        g.report
            .levels
            .iter()
            .map(|l| (l.nodes, l.kind, l.tie_splits + l.budget_splits))
            .collect::<Vec<_>>()
    );
    assert!(g.hierarchy.check_invariants(n).is_empty());
}

/// CPU cost of the adjacent distance on Boston's candidate pairs, on one thread (run under `time` to
/// see CPU time apart from machine load).
#[test]
#[ignore]
fn time_adjacent_distance_single_thread() {
    use citylod_generalize::{adjacent_distance, candidate_pairs};
    let Some((bs, _)) = common::load_geojson("boston/boston_buildings.geojson") else {
        return;
    };
    let fps: Vec<&citylod_model::Footprint> = bs.iter().map(|b| &b.footprint).collect();
    let (pairs, _) = candidate_pairs(&fps, 4.4, 16);
    let t = Instant::now();
    let mut zero = 0;
    for _ in 0..5 {
        for &(a, b) in &pairs {
            if adjacent_distance(fps[a as usize], fps[b as usize], 0.6).d_m == 0.0 {
                zero += 1;
            }
        }
    }
    let per = t.elapsed().as_secs_f64() / (5 * pairs.len()) as f64;
    eprintln!(
        "adjacent distance: {} pairs, {:.2} µs per pair (wall), {} touching",
        pairs.len(),
        per * 1e6,
        zero / 5
    );
}
