//! Quadric error metric (Garland & Heckbert 1997; seed 003 eq. 1): per vertex, the area-weighted sum of the
//! squared distances to the planes of its triangles. Positions in metres, so `eval` is in m²·m² (area ×
//! squared distance). A zero-area triangle contributes nothing.

use super::geom::{cross, dot, norm, sub, V3};

/// Symmetric 4×4 quadric stored as its 10 upper-triangle coefficients.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Quadric([f64; 10]);

impl Quadric {
    /// Quadric of the plane through `a, b, c`, weighted by the triangle's area (m²).
    pub fn from_triangle(a: V3, b: V3, c: V3) -> Quadric {
        let n2 = cross(sub(b, a), sub(c, a));
        let len = norm(n2);
        if len <= 0.0 {
            return Quadric::default();
        }
        let area = 0.5 * len;
        let n = [n2[0] / len, n2[1] / len, n2[2] / len];
        Quadric::from_plane(n, -dot(n, a), area)
    }

    /// Quadric of the plane `n·x + d = 0` (`n` unit) with weight `w`.
    pub fn from_plane(n: V3, d: f64, w: f64) -> Quadric {
        let [a, b, c] = n;
        Quadric([
            w * a * a,
            w * a * b,
            w * a * c,
            w * a * d,
            w * b * b,
            w * b * c,
            w * b * d,
            w * c * c,
            w * c * d,
            w * d * d,
        ])
    }

    pub fn add(&mut self, o: &Quadric) {
        for k in 0..10 {
            self.0[k] += o.0[k];
        }
    }

    /// vᵀQv for v = (p, 1); clamped at 0 against rounding.
    pub fn eval(&self, p: V3) -> f64 {
        let q = &self.0;
        let [x, y, z] = p;
        let v = q[0] * x * x
            + 2.0 * q[1] * x * y
            + 2.0 * q[2] * x * z
            + 2.0 * q[3] * x
            + q[4] * y * y
            + 2.0 * q[5] * y * z
            + 2.0 * q[6] * y
            + q[7] * z * z
            + 2.0 * q[8] * z
            + q[9];
        v.max(0.0)
    }
}

/// Per-vertex quadrics of a triangle mesh (eq. 1).
pub fn vertex_quadrics(positions: &[V3], triangles: &[[u32; 3]]) -> Vec<Quadric> {
    let mut q = vec![Quadric::default(); positions.len()];
    for t in triangles {
        let tq = Quadric::from_triangle(
            positions[t[0] as usize],
            positions[t[1] as usize],
            positions[t[2] as usize],
        );
        for &v in t {
            q[v as usize].add(&tq);
        }
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadric_is_area_times_squared_plane_distance() {
        // Right triangle of area 2 m² in z = 0.
        let q = Quadric::from_triangle([0.0; 3], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        assert!((q.eval([5.0, -3.0, 3.0]) - 2.0 * 9.0).abs() < 1e-9);
        assert!(q.eval([7.0, 7.0, 0.0]).abs() < 1e-12);
    }
}
