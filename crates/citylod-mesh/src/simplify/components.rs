//! Component segmentation (seed 003 §3.1): breadth-first search over vertices linked by triangles; each
//! connected subgraph is one component. Deterministic: components are numbered in order of their lowest
//! vertex index. Vertices no triangle uses get no component (`u32::MAX`).

use std::collections::VecDeque;

/// Connected components of a triangle mesh.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Components {
    /// Component id per vertex (`u32::MAX` for unused vertices).
    pub of_vertex: Vec<u32>,
    /// Component id per triangle.
    pub of_triangle: Vec<u32>,
    /// Number of components.
    pub count: usize,
}

/// Components of the mesh with `vertex_count` vertices and these triangles (indices must be in range).
pub fn components(vertex_count: usize, triangles: &[[u32; 3]]) -> Components {
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); vertex_count];
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if a != b {
                adj[a as usize].push(b);
                adj[b as usize].push(a);
            }
        }
    }
    let mut of_vertex = vec![u32::MAX; vertex_count];
    let used: Vec<bool> = {
        let mut u = vec![false; vertex_count];
        for t in triangles {
            for &v in t {
                u[v as usize] = true;
            }
        }
        u
    };
    let mut count = 0u32;
    let mut queue = VecDeque::new();
    for start in 0..vertex_count {
        if !used[start] || of_vertex[start] != u32::MAX {
            continue;
        }
        of_vertex[start] = count;
        queue.push_back(start as u32);
        while let Some(v) = queue.pop_front() {
            for &w in &adj[v as usize] {
                if of_vertex[w as usize] == u32::MAX {
                    of_vertex[w as usize] = count;
                    queue.push_back(w);
                }
            }
        }
        count += 1;
    }
    let of_triangle = triangles.iter().map(|t| of_vertex[t[0] as usize]).collect();
    Components {
        of_vertex,
        of_triangle,
        count: count as usize,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_separate_triangles_and_a_shared_vertex_pair_give_two_components() {
        let tris = [[0, 1, 2], [2, 3, 4], [5, 6, 7]];
        let c = components(9, &tris);
        assert_eq!(c.count, 2);
        assert_eq!(c.of_triangle, vec![0, 0, 1]);
        assert_eq!(c.of_vertex[8], u32::MAX);
    }
}
