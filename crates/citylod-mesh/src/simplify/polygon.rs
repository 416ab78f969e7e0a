//! Triangulation of planar polygons with holes (ring 0 outer, the others inner) by spade's constrained
//! Delaunay triangulation; triangles are kept when their centroid is inside by the even-odd rule.
//! 3D rings are projected on their Newell-normal plane; output triangles wind like ring 0.
//! Bad input (fewer than 3 distinct points, non-finite values) gives no triangles, never a panic.

use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

use super::geom::{add, cross, dot, normalize, sub, tri_normal2, V3};

/// Triangles over the concatenated ring vertices (indices count ring 0's vertices first). Rings are open
/// (no repeated closing vertex needed; one is ignored). Vertices at identical positions share an index.
pub fn triangulate_polygon_2d(rings: &[Vec<[f64; 2]>]) -> Vec<[u32; 3]> {
    let all: Vec<[f64; 2]> = rings.iter().flatten().copied().collect();
    if all.len() < 3 || all.iter().flatten().any(|c| !c.is_finite()) {
        return Vec::new();
    }
    // Work relative to the first vertex so large map coordinates keep their precision.
    let o = all[0];
    let mut cdt: ConstrainedDelaunayTriangulation<Point2<f64>> =
        ConstrainedDelaunayTriangulation::new();
    let mut handle_to_index: Vec<u32> = Vec::new();
    let mut handles: Vec<Vec<FixedVertexHandle>> = Vec::new();
    let mut base = 0u32;
    for ring in rings {
        let mut hs = Vec::with_capacity(ring.len());
        for (i, p) in ring.iter().enumerate() {
            let Ok(h) = cdt.insert(Point2::new(p[0] - o[0], p[1] - o[1])) else {
                return Vec::new();
            };
            if h.index() >= handle_to_index.len() {
                handle_to_index.resize(h.index() + 1, u32::MAX);
            }
            if handle_to_index[h.index()] == u32::MAX {
                handle_to_index[h.index()] = base + i as u32;
            }
            hs.push(h);
        }
        base += ring.len() as u32;
        handles.push(hs);
    }
    for hs in &handles {
        for i in 0..hs.len() {
            let (a, b) = (hs[i], hs[(i + 1) % hs.len()]);
            if a != b {
                cdt.try_add_constraint(a, b);
            }
        }
    }
    let rel: Vec<Vec<[f64; 2]>> = rings
        .iter()
        .map(|r| r.iter().map(|p| [p[0] - o[0], p[1] - o[1]]).collect())
        .collect();
    let mut out = Vec::new();
    for face in cdt.inner_faces() {
        let vs = face.vertices();
        let pts = vs.map(|v| {
            let p = v.position();
            [p.x, p.y]
        });
        let c = [
            (pts[0][0] + pts[1][0] + pts[2][0]) / 3.0,
            (pts[0][1] + pts[1][1] + pts[2][1]) / 3.0,
        ];
        if !inside_even_odd(&rel, c) {
            continue;
        }
        let idx = vs.map(|v| {
            handle_to_index
                .get(v.fix().index())
                .copied()
                .unwrap_or(u32::MAX)
        });
        if idx.contains(&u32::MAX) {
            // A vertex spade created at a constraint crossing: not one of ours; skip (self-intersecting ring).
            continue;
        }
        out.push(idx);
    }
    // Spade's faces are counter-clockwise; match ring 0's winding.
    if signed_area(&rel[0]) < 0.0 {
        for t in &mut out {
            t.swap(1, 2);
        }
    }
    out.sort_unstable();
    out
}

/// Triangulates a planar (or nearly planar) 3D polygon; triangles wind like ring 0 (so a face given
/// counter-clockwise from outside yields outward-facing triangles). Indices as in [`triangulate_polygon_2d`].
pub fn triangulate_polygon_3d(rings: &[Vec<[f64; 3]>]) -> Vec<[u32; 3]> {
    let Some(outer) = rings.first() else {
        return Vec::new();
    };
    if outer.len() < 3 {
        return Vec::new();
    }
    // Newell normal of ring 0.
    let mut n = [0.0; 3];
    for i in 0..outer.len() {
        let (a, b) = (outer[i], outer[(i + 1) % outer.len()]);
        n = add(n, cross(a, b));
    }
    let n = normalize(n);
    if n == [0.0; 3] {
        return Vec::new();
    }
    let helper = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u = normalize(cross(helper, n));
    let v = cross(n, u);
    let o = outer[0];
    let rings2: Vec<Vec<[f64; 2]>> = rings
        .iter()
        .map(|r| {
            r.iter()
                .map(|p| [dot(sub(*p, o), u), dot(sub(*p, o), v)])
                .collect()
        })
        .collect();
    let mut tris = triangulate_polygon_2d(&rings2);
    let all: Vec<V3> = rings.iter().flatten().copied().collect();
    for t in &mut tris {
        let tn = tri_normal2(all[t[0] as usize], all[t[1] as usize], all[t[2] as usize]);
        if dot(tn, n) < 0.0 {
            t.swap(1, 2);
        }
    }
    tris
}

fn signed_area(r: &[[f64; 2]]) -> f64 {
    (0..r.len())
        .map(|i| {
            let (a, b) = (r[i], r[(i + 1) % r.len()]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        / 2.0
}

/// Whether `p` is inside the rings by the even-odd rule (inside an outer ring, outside its holes).
pub(crate) fn inside_even_odd(rings: &[Vec<[f64; 2]>], p: [f64; 2]) -> bool {
    let mut inside = false;
    for r in rings {
        for i in 0..r.len() {
            let (a, b) = (r[i], r[(i + 1) % r.len()]);
            if (a[1] > p[1]) != (b[1] > p[1]) {
                let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
                if p[0] < x {
                    inside = !inside;
                }
            }
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_with_hole_covers_its_area() {
        let outer = vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let hole = vec![[4.0, 4.0], [4.0, 6.0], [6.0, 6.0], [6.0, 4.0]];
        let rings = vec![outer, hole];
        let tris = triangulate_polygon_2d(&rings);
        let all: Vec<[f64; 2]> = rings.iter().flatten().copied().collect();
        let area: f64 = tris
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| all[i as usize]);
                ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])) / 2.0
            })
            .sum();
        assert!((area - 96.0).abs() < 1e-9, "{area}");
    }

    #[test]
    fn vertical_wall_triangles_face_like_the_ring() {
        // A wall in the plane y = 0, counter-clockwise seen from -y: normal -y.
        let ring = vec![
            [0.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
            [4.0, 0.0, 3.0],
            [2.0, 0.0, 4.0],
            [0.0, 0.0, 3.0],
        ];
        let tris = triangulate_polygon_3d(std::slice::from_ref(&ring));
        assert_eq!(tris.len(), 3);
        for t in tris {
            let n = tri_normal2(
                ring[t[0] as usize],
                ring[t[1] as usize],
                ring[t[2] as usize],
            );
            assert!(n[1] < 0.0);
        }
    }
}
