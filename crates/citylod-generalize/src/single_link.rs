//! Single-link clustering (seed 000 §3.1) as Kruskal's algorithm over the candidate edges sorted by
//! adjacent distance (m), ties broken by building indices, with a union–find. The result is the
//! dendrogram as its n − 1 merges in order, each with its distance and the spanning-tree edge that
//! caused it. Invariant: merge distances never decrease; on a connected graph there are n − 1 merges.

use crate::graph::CandidateEdge;

/// One step of the dendrogram: the clusters holding buildings `a` and `b` join at distance `d_m`
/// (m); (a, b) is the minimum-spanning-tree edge that joins them, `a < b`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Merge {
    pub d_m: f64,
    pub a: u32,
    pub b: u32,
}

/// Runs Kruskal over `edges` among `n` buildings and returns the merges in order (sorted by
/// (d, a, b)). Edges with an index ≥ n or a == b are ignored; a disconnected graph gives fewer than
/// n − 1 merges.
///
/// ```
/// use citylod_generalize::{single_link, CandidateEdge, Merge};
/// let e = |a, b, d_m| CandidateEdge { a, b, d_m };
/// let merges = single_link(3, &[e(0, 1, 5.0), e(1, 2, 1.0), e(0, 2, 7.0)]);
/// assert_eq!(merges, vec![Merge { d_m: 1.0, a: 1, b: 2 }, Merge { d_m: 5.0, a: 0, b: 1 }]);
/// ```
pub fn single_link(n: usize, edges: &[CandidateEdge]) -> Vec<Merge> {
    let mut order: Vec<&CandidateEdge> = edges
        .iter()
        .filter(|e| e.a != e.b && (e.a as usize) < n && (e.b as usize) < n)
        .collect();
    order.sort_unstable_by(|p, q| {
        p.d_m
            .total_cmp(&q.d_m)
            .then((p.a.min(p.b), p.a.max(p.b)).cmp(&(q.a.min(q.b), q.a.max(q.b))))
    });
    let mut uf = UnionFind::new(n);
    let mut merges = Vec::with_capacity(n.saturating_sub(1));
    for e in order {
        if uf.union(e.a, e.b) {
            merges.push(Merge {
                d_m: e.d_m,
                a: e.a.min(e.b),
                b: e.a.max(e.b),
            });
            if merges.len() + 1 == n {
                break;
            }
        }
    }
    debug_assert!(merges.windows(2).all(|w| w[0].d_m <= w[1].d_m));
    merges
}

/// Disjoint sets over `0..n` with path halving and union by size.
#[derive(Debug, Clone)]
pub(crate) struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    pub(crate) fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
        }
    }

    pub(crate) fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let p = self.parent[x as usize];
            self.parent[x as usize] = self.parent[p as usize];
            x = p;
        }
        x
    }

    /// Joins the sets of `a` and `b`; false when they were already one.
    pub(crate) fn union(&mut self, a: u32, b: u32) -> bool {
        let (mut ra, mut rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        if self.size[ra as usize] < self.size[rb as usize] {
            std::mem::swap(&mut ra, &mut rb);
        }
        self.parent[rb as usize] = ra;
        self.size[ra as usize] += self.size[rb as usize];
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(a: u32, b: u32, d_m: f64) -> CandidateEdge {
        CandidateEdge { a, b, d_m }
    }

    #[test]
    fn merges_form_a_minimum_spanning_tree() {
        // A square with diagonals: the MST takes the three cheapest edges that make no cycle.
        let edges = [
            e(0, 1, 1.0),
            e(1, 2, 2.0),
            e(2, 3, 1.5),
            e(3, 0, 3.0),
            e(0, 2, 1.2),
            e(1, 3, 0.5),
        ];
        let m = single_link(4, &edges);
        let pairs: Vec<(u32, u32)> = m.iter().map(|m| (m.a, m.b)).collect();
        assert_eq!(pairs, vec![(1, 3), (0, 1), (0, 2)]);
        assert_eq!(m.iter().map(|m| m.d_m).sum::<f64>(), 0.5 + 1.0 + 1.2);
    }

    #[test]
    fn ties_are_broken_by_building_index_whatever_the_input_order() {
        let edges = [e(2, 3, 0.0), e(1, 0, 0.0), e(1, 2, 0.0), e(0, 2, 0.0)];
        let mut rev = edges;
        rev.reverse();
        let m1 = single_link(4, &edges);
        assert_eq!(m1, single_link(4, &rev));
        assert_eq!((m1[0].a, m1[0].b), (0, 1));
        assert_eq!(m1.len(), 3);
    }

    #[test]
    fn disconnected_and_bad_edges_give_fewer_merges() {
        let m = single_link(4, &[e(0, 1, 1.0), e(2, 2, 0.0), e(2, 9, 0.0)]);
        assert_eq!(m.len(), 1);
        assert!(single_link(0, &[]).is_empty());
        assert!(single_link(1, &[]).is_empty());
    }
}
