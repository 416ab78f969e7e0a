//! The sparse candidate graph against all pairs on a real 1,000-building piece of Boston: single-link
//! on the sparse graph must give the same clusters as single-link on every pair (O(n²) adjacent
//! distances). Measure: for every distinct merge distance t of the brute-force dendrogram, is the
//! partition "components of merges with d ≤ t" identical for both? (This does not depend on how
//! ties are ordered.) The fraction of identical partitions must be ≥ 99 %.

mod common;

use citylod_generalize::{
    auto_reach_m, candidate_graph, cluster, single_link, weigh_pairs, GeneralizeOptions, Merge,
};
use citylod_model::Footprint;

struct Dsu(Vec<u32>);
impl Dsu {
    fn find(&mut self, mut x: u32) -> u32 {
        while self.0[x as usize] != x {
            let p = self.0[x as usize];
            self.0[x as usize] = self.0[p as usize];
            x = p;
        }
        x
    }
    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.0[ra.max(rb) as usize] = ra.min(rb);
        }
    }
    /// Each element labelled by the smallest element of its set.
    fn labels(&mut self) -> Vec<u32> {
        let n = self.0.len();
        let mut min_of = vec![u32::MAX; n];
        let roots: Vec<u32> = (0..n as u32).map(|i| self.find(i)).collect();
        for (i, &r) in roots.iter().enumerate() {
            min_of[r as usize] = min_of[r as usize].min(i as u32);
        }
        roots.iter().map(|&r| min_of[r as usize]).collect()
    }
}

/// Fraction of the distinct merge distances of `reference` at which both dendrograms give the same
/// partition.
fn identical_partition_fraction(n: usize, reference: &[Merge], other: &[Merge]) -> (f64, usize) {
    let mut ts: Vec<f64> = reference.iter().map(|m| m.d_m).collect();
    ts.dedup();
    let (mut ua, mut ub) = (Dsu((0..n as u32).collect()), Dsu((0..n as u32).collect()));
    let (mut ia, mut ib) = (0, 0);
    let mut same = 0;
    for &t in &ts {
        while ia < reference.len() && reference[ia].d_m <= t {
            ua.union(reference[ia].a, reference[ia].b);
            ia += 1;
        }
        while ib < other.len() && other[ib].d_m <= t {
            ub.union(other[ib].a, other[ib].b);
            ib += 1;
        }
        if ua.labels() == ub.labels() {
            same += 1;
        }
    }
    (same as f64 / ts.len() as f64, ts.len())
}

#[test]
fn sparse_single_link_matches_brute_force_on_boston() {
    let Some((all, _)) = common::load_geojson("boston/boston_buildings.geojson") else {
        return;
    };
    let piece = common::central_piece(&all, 1000);
    let n = piece.len();
    let fps: Vec<&Footprint> = piece.iter().map(|b| &b.footprint).collect();

    let reach = auto_reach_m(&fps, 0.5);
    let (sparse_edges, _) = candidate_graph(&fps, reach, 0.6, 16);
    let first_pass = single_link(n, &sparse_edges);
    let (sparse, stats) = cluster(&fps, &GeneralizeOptions::default(), &mut Default::default());

    let all_pairs: Vec<(u32, u32)> = (0..n as u32)
        .flat_map(|a| (a + 1..n as u32).map(move |b| (a, b)))
        .collect();
    let brute_edges = weigh_pairs(&fps, &all_pairs, 0.6);
    let brute = single_link(n, &brute_edges);
    assert_eq!(brute.len(), n - 1);
    assert_eq!(sparse.len(), n - 1);

    let (fraction, steps) = identical_partition_fraction(n, &brute, &sparse);
    let (fraction_first, _) = identical_partition_fraction(n, &brute, &first_pass);
    for factor in [2.0, 3.0, 5.0, 10.0] {
        let opts = GeneralizeOptions {
            reach_far_factor: factor,
            ..Default::default()
        };
        let (m, st) = cluster(&fps, &opts, &mut Default::default());
        let (f, _) = identical_partition_fraction(n, &brute, &m);
        eprintln!(
            "reach_far_factor {factor}: identical partitions {:.2} %, {} refinement pairs",
            f * 100.0,
            st.n_refine_pairs
        );
    }
    eprintln!(
        "without the refinement pass: identical partitions at {:.2} %; refinement added {} pairs (reach far {:.1} m)",
        fraction_first * 100.0,
        stats.n_refine_pairs,
        stats.reach_far_m
    );
    let mut pairs_b: Vec<(u32, u32)> = brute.iter().map(|m| (m.a, m.b)).collect();
    let mut pairs_s: Vec<(u32, u32)> = sparse.iter().map(|m| (m.a, m.b)).collect();
    pairs_b.sort_unstable();
    pairs_s.sort_unstable();
    let shared = pairs_b
        .iter()
        .filter(|p| pairs_s.binary_search(p).is_ok())
        .count();
    let weight = |ms: &[Merge]| ms.iter().map(|m| m.d_m).sum::<f64>();
    eprintln!(
        "boston 1000-building piece: reach {:.2} m, {} sparse edges vs {} pairs; identical partitions at \
         {:.2} % of {} distinct merge distances; {} of {} spanning-tree edges shared; MST weight sparse/brute = {:.6}",
        reach,
        stats.n_edges,
        all_pairs.len(),
        fraction * 100.0,
        steps,
        shared,
        n - 1,
        weight(&sparse) / weight(&brute)
    );
    if std::env::var("CITYLOD_DEBUG").is_ok() {
        for m in &brute {
            if pairs_s.binary_search(&(m.a, m.b)).is_err() {
                let adj = citylod_generalize::adjacent_distance(
                    fps[m.a as usize],
                    fps[m.b as usize],
                    0.6,
                );
                let bb = |f: &Footprint| {
                    use geo::BoundingRect;
                    f.bounding_rect().unwrap()
                };
                let (ba, bbb) = (bb(fps[m.a as usize]), bb(fps[m.b as usize]));
                let gx = (ba.min().x - bbb.max().x)
                    .max(bbb.min().x - ba.max().x)
                    .max(0.0);
                let gy = (ba.min().y - bbb.max().y)
                    .max(bbb.min().y - ba.max().y)
                    .max(0.0);
                eprintln!("missing MST edge {:?} d {:.3} d_min {:.3} N {:.3} bbox gap ({gx:.2},{gy:.2}) nverts {} {}", (m.a, m.b), m.d_m, adj.d_min_m, adj.n_factor,
                    fps[m.a as usize].0[0].exterior().0.len(), fps[m.b as usize].0[0].exterior().0.len());
            }
        }
    }
    assert!(fraction >= 0.99, "only {:.2} % identical", fraction * 100.0);
    // A sparse graph can only miss edges: its spanning tree can never be lighter.
    assert!(weight(&sparse) >= weight(&brute) - 1e-6);
}
