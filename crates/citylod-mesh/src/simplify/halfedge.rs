//! Half-edge collapse engine (seed 003 §3: a vertex `u` moves onto a neighbour `v`, no new positions).
//! A collapse is refused when it would break the link condition (so closed 2-manifolds stay closed),
//! touch a non-manifold edge, pinch two borders, flip a triangle against its current or its original
//! normal, create a degenerate triangle (see [`crate::topology::is_degenerate`]) or empty a component.
//! Collapses run cheapest first until a triangle budget is met; a [`CollapsePolicy`] prices moves, has the
//! last word on each and hears of every collapse.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::geom::{dot, normalize, tri_normal2, V3};
use super::qem::Quadric;
use crate::topology::is_degenerate;

/// A collapse may turn no triangle by more than ~75° (cos = 0.25) from its current or original normal.
pub(crate) const MIN_NORMAL_COS: f64 = 0.25;

/// Mutable triangle soup with vertex → triangle incidence, for collapses.
pub(crate) struct CollapseMesh {
    pub pos: Vec<V3>,
    pub tris: Vec<[u32; 3]>,
    pub tri_alive: Vec<bool>,
    pub vert_alive: Vec<bool>,
    /// Alive triangles around each vertex.
    pub vtris: Vec<Vec<u32>>,
    /// Vertices that must never move (they may still receive collapses).
    pub locked: Vec<bool>,
    orig_normal: Vec<V3>,
    comp_of_tri: Vec<u32>,
    /// Each component's triangles, in index order (a triangle never changes component).
    comp_tris: Vec<Vec<u32>>,
    comp_alive: Vec<usize>,
    pub alive_tris: usize,
}

impl CollapseMesh {
    pub fn new(pos: &[V3], tris: &[[u32; 3]], comp_of_tri: Vec<u32>, comp_count: usize) -> Self {
        let mut vtris = vec![Vec::new(); pos.len()];
        for (i, t) in tris.iter().enumerate() {
            for &v in t {
                if !vtris[v as usize].contains(&(i as u32)) {
                    vtris[v as usize].push(i as u32);
                }
            }
        }
        let orig_normal = tris
            .iter()
            .map(|t| {
                normalize(tri_normal2(
                    pos[t[0] as usize],
                    pos[t[1] as usize],
                    pos[t[2] as usize],
                ))
            })
            .collect();
        let mut comp_alive = vec![0; comp_count];
        let mut comp_tris = vec![Vec::new(); comp_count];
        for (t, &c) in comp_of_tri.iter().enumerate() {
            comp_alive[c as usize] += 1;
            comp_tris[c as usize].push(t as u32);
        }
        let vert_alive = vtris.iter().map(|t| !t.is_empty()).collect();
        CollapseMesh {
            pos: pos.to_vec(),
            tris: tris.to_vec(),
            tri_alive: vec![true; tris.len()],
            vert_alive,
            vtris,
            locked: vec![false; pos.len()],
            orig_normal,
            comp_of_tri,
            comp_tris,
            comp_alive,
            alive_tris: tris.len(),
        }
    }

    /// Sorted distinct neighbours of `w`.
    pub fn neighbours(&self, w: u32) -> Vec<u32> {
        let mut n: Vec<u32> = self.vtris[w as usize]
            .iter()
            .flat_map(|&t| self.tris[t as usize])
            .filter(|&x| x != w)
            .collect();
        n.sort_unstable();
        n.dedup();
        n
    }

    /// (neighbour, number of triangles on edge w–neighbour), sorted by neighbour.
    fn edge_counts(&self, w: u32) -> Vec<(u32, u32)> {
        let mut n: Vec<u32> = self.vtris[w as usize]
            .iter()
            .flat_map(|&t| self.tris[t as usize])
            .filter(|&x| x != w)
            .collect();
        n.sort_unstable();
        let mut out: Vec<(u32, u32)> = Vec::new();
        for x in n {
            match out.last_mut() {
                Some((y, c)) if *y == x => *c += 1,
                _ => out.push((x, 1)),
            }
        }
        out
    }

    /// Whether moving `u` onto `v` is allowed (see the module doc).
    pub fn can_collapse(&self, u: u32, v: u32) -> bool {
        let (ui, vi) = (u as usize, v as usize);
        if u == v || self.locked[ui] || !self.vert_alive[ui] || !self.vert_alive[vi] {
            return false;
        }
        let shared: Vec<u32> = self.vtris[ui]
            .iter()
            .copied()
            .filter(|&t| self.tris[t as usize].contains(&v))
            .collect();
        if shared.is_empty() || shared.len() > 2 {
            return false;
        }
        let eu = self.edge_counts(u);
        let ev = self.edge_counts(v);
        if eu.iter().chain(ev.iter()).any(|&(_, c)| c > 2) {
            return false;
        }
        let border_u = eu.iter().any(|&(_, c)| c == 1);
        let border_v = ev.iter().any(|&(_, c)| c == 1);
        if shared.len() == 2 && border_u && border_v {
            return false;
        }
        // Link condition: the common neighbours of u and v are exactly the apexes of the edge's triangles.
        let mut apex: Vec<u32> = shared
            .iter()
            .flat_map(|&t| self.tris[t as usize])
            .filter(|&x| x != u && x != v)
            .collect();
        apex.sort_unstable();
        apex.dedup();
        let common: Vec<u32> = eu
            .iter()
            .map(|&(x, _)| x)
            .filter(|x| ev.binary_search_by_key(x, |&(y, _)| y).is_ok())
            .collect();
        if common != apex {
            return false;
        }
        let comp = self.comp_of_tri[shared[0] as usize] as usize;
        if self.comp_alive[comp] < shared.len() + 2 {
            return false;
        }
        let pv = self.pos[vi];
        for &t in &self.vtris[ui] {
            if shared.contains(&t) {
                continue;
            }
            let tri = self.tris[t as usize];
            let p = tri.map(|x| if x == u { pv } else { self.pos[x as usize] });
            if is_degenerate(p[0], p[1], p[2]) {
                return false;
            }
            let n_new = normalize(tri_normal2(p[0], p[1], p[2]));
            let q = tri.map(|x| self.pos[x as usize]);
            let n_old = normalize(tri_normal2(q[0], q[1], q[2]));
            if dot(n_new, n_old) < MIN_NORMAL_COS
                || dot(n_new, self.orig_normal[t as usize]) < MIN_NORMAL_COS
            {
                return false;
            }
            // A triangle with the same corners already around v would make a doubled face.
            let mut key = tri.map(|x| if x == u { v } else { x });
            key.sort_unstable();
            if self.vtris[vi].iter().any(|&s| {
                let mut k = self.tris[s as usize];
                k.sort_unstable();
                k == key
            }) {
                return false;
            }
        }
        true
    }

    /// Component of triangle `t`.
    pub fn component_of_triangle(&self, t: u32) -> u32 {
        self.comp_of_tri[t as usize]
    }

    /// Corner positions of the alive triangles of component `c` as they would be after `u → v`.
    pub fn component_after(&self, c: u32, u: u32, v: u32) -> Vec<[V3; 3]> {
        // The component's own triangles, not a scan of all (which made simplifying a model of many touching parts,
        // such as a MultiPatch of loose triangles, quadratic in its triangles).
        self.comp_tris[c as usize]
            .iter()
            .map(|&t| t as usize)
            .filter(|&t| self.tri_alive[t])
            .map(|t| self.tris[t])
            .filter(|tri| !(tri.contains(&u) && tri.contains(&v)))
            .map(|tri| tri.map(|x| self.pos[if x == u { v } else { x } as usize]))
            .collect()
    }

    /// Moves `u` onto `v`; returns the number of triangles removed. Caller checked [`Self::can_collapse`].
    pub fn collapse(&mut self, u: u32, v: u32) -> usize {
        debug_assert!(self.can_collapse(u, v));
        let (ui, vi) = (u as usize, v as usize);
        let around_u = std::mem::take(&mut self.vtris[ui]);
        let mut removed = 0;
        for &t in &around_u {
            let tri = self.tris[t as usize];
            if tri.contains(&v) {
                self.tri_alive[t as usize] = false;
                for &w in &tri {
                    if w != u {
                        self.vtris[w as usize].retain(|&s| s != t);
                    }
                }
                self.comp_alive[self.comp_of_tri[t as usize] as usize] -= 1;
                self.alive_tris -= 1;
                removed += 1;
            } else {
                self.tris[t as usize] = tri.map(|x| if x == u { v } else { x });
                self.vtris[vi].push(t);
            }
        }
        self.vert_alive[ui] = false;
        removed
    }

    /// Checks the incidence lists against the triangles (tests call this after collapses).
    #[cfg(test)]
    pub fn check_invariants(&self) {
        let mut count = 0;
        for (t, tri) in self.tris.iter().enumerate() {
            if !self.tri_alive[t] {
                continue;
            }
            count += 1;
            for &w in tri {
                assert!(
                    self.vert_alive[w as usize],
                    "alive triangle {t} uses dead vertex {w}"
                );
                assert!(self.vtris[w as usize].contains(&(t as u32)));
            }
        }
        assert_eq!(count, self.alive_tris);
    }
}

/// Why a collapse run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Stop {
    Reached,
    NoValidCollapse,
}

#[derive(PartialEq)]
struct Entry {
    cost: f64,
    u: u32,
    v: u32,
    stamp: u32,
}
impl Eq for Entry {}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        // Min-heap on cost; ties broken by vertex ids so runs are deterministic.
        o.cost
            .total_cmp(&self.cost)
            .then(o.u.cmp(&self.u))
            .then(o.v.cmp(&self.v))
    }
}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// What a caller decides in a collapse run: the cost of each move, a final say on a popped move, and a
/// hook after each collapse. A plain `Fn(&CollapseMesh, &[Quadric], u, v) -> Option<f64>` is a policy
/// with only a cost.
pub(crate) trait CollapsePolicy {
    /// Cost of moving `u` onto `v` given the current quadrics; `None` forbids the move.
    fn cost(&self, m: &CollapseMesh, q: &[Quadric], u: u32, v: u32) -> Option<f64>;
    /// Final say on a cheapest move that passed [`CollapseMesh::can_collapse`] (true = do it).
    fn allow(&self, _m: &CollapseMesh, _u: u32, _v: u32) -> bool {
        true
    }
    /// Called after `u` moved onto `v` (the mesh is already updated); `star` lists the triangles that were
    /// around `u` (now moved to `v`, or removed).
    fn collapsed(&mut self, _m: &CollapseMesh, _u: u32, _v: u32, _star: &[u32]) {}
}

impl<F: Fn(&CollapseMesh, &[Quadric], u32, u32) -> Option<f64>> CollapsePolicy for F {
    fn cost(&self, m: &CollapseMesh, q: &[Quadric], u: u32, v: u32) -> Option<f64> {
        self(m, q, u, v)
    }
}

/// Collapses cheapest-first until at least `remove_target` triangles are gone or nothing valid is left.
/// Quadrics accumulate: after `u → v`, `q[v] += q[u]`.
pub(crate) fn collapse_until(
    m: &mut CollapseMesh,
    q: &mut [Quadric],
    policy: &mut dyn CollapsePolicy,
    remove_target: usize,
) -> Stop {
    let start = m.alive_tris;
    let mut stamp = vec![0u32; m.pos.len()];
    let mut heap = BinaryHeap::new();
    let push_vertex = |m: &CollapseMesh,
                       q: &[Quadric],
                       policy: &dyn CollapsePolicy,
                       heap: &mut BinaryHeap<Entry>,
                       w: u32,
                       s: u32| {
        if !m.vert_alive[w as usize] || m.locked[w as usize] {
            return;
        }
        for x in m.neighbours(w) {
            if let Some(c) = policy.cost(m, q, w, x) {
                if c.is_finite() {
                    heap.push(Entry {
                        cost: c,
                        u: w,
                        v: x,
                        stamp: s,
                    });
                }
            }
        }
    };
    loop {
        for w in 0..m.pos.len() as u32 {
            stamp[w as usize] += 1;
            push_vertex(m, q, policy, &mut heap, w, stamp[w as usize]);
        }
        let mut progressed = false;
        while let Some(e) = heap.pop() {
            if start - m.alive_tris >= remove_target {
                return Stop::Reached;
            }
            if stamp[e.u as usize] != e.stamp
                || !m.can_collapse(e.u, e.v)
                || !policy.allow(m, e.u, e.v)
            {
                continue;
            }
            q[e.v as usize] = {
                let mut s = q[e.v as usize];
                s.add(&q[e.u as usize]);
                s
            };
            let star = m.vtris[e.u as usize].clone();
            m.collapse(e.u, e.v);
            policy.collapsed(m, e.u, e.v, &star);
            progressed = true;
            // Re-price the one-ring, whose stars changed. Queued moves further out are re-validated when
            // popped; one refused earlier that became valid is found by the next full pass.
            let mut ring = m.neighbours(e.v);
            ring.push(e.v);
            for w in ring {
                stamp[w as usize] += 1;
                push_vertex(m, q, policy, &mut heap, w, stamp[w as usize]);
            }
        }
        if start - m.alive_tris >= remove_target {
            return Stop::Reached;
        }
        if !progressed {
            return Stop::NoValidCollapse;
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::simplify::components::components;
    use crate::simplify::qem::vertex_quadrics;
    use citylod_model::Mesh3d;

    /// Axis-aligned box `size_m` wide, each face split into `n × n` quads (12·n² triangles), CCW outside.
    pub(crate) fn subdivided_box(size_m: [f64; 3], n: u32) -> Mesh3d {
        let mut positions: Vec<[f64; 3]> = Vec::new();
        let mut triangles = Vec::new();
        let mut index = std::collections::BTreeMap::new();
        let mut vid = |p: [f64; 3], positions: &mut Vec<[f64; 3]>| -> u32 {
            let key = p.map(|c| (c * 1e6).round() as i64);
            *index.entry(key).or_insert_with(|| {
                positions.push(p);
                positions.len() as u32 - 1
            })
        };
        // Each face: origin, two in-plane axes whose cross product points outward.
        let faces: [([f64; 3], [f64; 3], [f64; 3]); 6] = [
            ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]), // bottom, -z
            ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), // top, +z
            ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]), // -y
            ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]), // +y
            ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]), // -x
            ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]), // +x
        ];
        for (o, a, b) in faces {
            let p = |i: u32, j: u32| -> [f64; 3] {
                let (s, t) = (i as f64 / n as f64, j as f64 / n as f64);
                [0, 1, 2].map(|k| (o[k] + a[k] * s + b[k] * t) * size_m[k])
            };
            for i in 0..n {
                for j in 0..n {
                    let v00 = vid(p(i, j), &mut positions);
                    let v10 = vid(p(i + 1, j), &mut positions);
                    let v11 = vid(p(i + 1, j + 1), &mut positions);
                    let v01 = vid(p(i, j + 1), &mut positions);
                    triangles.push([v00, v10, v11]);
                    triangles.push([v00, v11, v01]);
                }
            }
        }
        Mesh3d {
            positions,
            triangles,
        }
    }

    #[test]
    fn collapsing_a_flat_subdivided_box_keeps_it_closed_and_consistent() {
        let mesh = subdivided_box([10.0, 8.0, 6.0], 4);
        let comps = components(mesh.positions.len(), &mesh.triangles);
        let mut m = CollapseMesh::new(
            &mesh.positions,
            &mesh.triangles,
            comps.of_triangle,
            comps.count,
        );
        let mut q = vertex_quadrics(&mesh.positions, &mesh.triangles);
        let pos = mesh.positions.clone();
        let mut cost = move |_: &CollapseMesh, q: &[Quadric], u: u32, v: u32| {
            Some(q[u as usize].eval(pos[v as usize]))
        };
        let n0 = m.alive_tris;
        collapse_until(&mut m, &mut q, &mut cost, n0 - 12);
        m.check_invariants();
        let tris: Vec<[u32; 3]> = (0..m.tris.len())
            .filter(|&t| m.tri_alive[t])
            .map(|t| m.tris[t])
            .collect();
        let out = Mesh3d {
            positions: m.pos.clone(),
            triangles: tris,
        };
        let report = crate::topology::mesh_report(&out);
        assert!(report.watertight, "{report:?}");
        assert!(report.orientation_consistent);
        assert_eq!(report.degenerate, 0);
        // Flat faces cost 0 to simplify, so the box reaches its 12-triangle minimum.
        assert_eq!(out.triangles.len(), 12);
    }
}
