//! Small 3D vector and primitive-distance helpers shared by the simplifiers, the Hausdorff error and the
//! topology checks. Units are whatever the caller uses (local metres everywhere in this crate).
//! Degenerate inputs (zero-length segments, zero-area triangles) give finite, conservative answers.

pub(crate) type V3 = [f64; 3];

#[inline]
pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
pub(crate) fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline]
pub(crate) fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
#[inline]
pub(crate) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
#[inline]
pub(crate) fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
#[inline]
pub(crate) fn dist2(a: V3, b: V3) -> f64 {
    let d = sub(a, b);
    dot(d, d)
}
/// Unit vector, or zero for a zero vector.
pub(crate) fn normalize(a: V3) -> V3 {
    let n = norm(a);
    if n > 0.0 {
        scale(a, 1.0 / n)
    } else {
        [0.0; 3]
    }
}
/// Twice-area normal (not unit) of triangle abc, counter-clockwise seen from its front.
#[inline]
pub(crate) fn tri_normal2(a: V3, b: V3, c: V3) -> V3 {
    cross(sub(b, a), sub(c, a))
}
/// Triangle area (m²).
#[inline]
pub(crate) fn tri_area(a: V3, b: V3, c: V3) -> f64 {
    0.5 * norm(tri_normal2(a, b, c))
}

/// Margin of [`Reach`]'s shortcuts (m): a point's distance to a triangle's plane, as computed, may be off by
/// rounding (~1e-11 m at city coordinates); a shortcut decides only when the point is clear of the radius by more
/// than this, so it never decides otherwise than the closest-point search would.
const PLANE_MARGIN_M: f64 = 1e-6;

/// Barycentric margin of [`Reach::decide`]'s inside test: a point nearer a triangle's edge than this share of it
/// is left to the closest-point search.
const INSIDE_MARGIN: f64 = 1e-7;

/// A squared radius `r2` (m²) for "within" tests against many triangles, with the bounds of its shortcuts.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Reach {
    pub r2: f64,
    /// (√r2 + [`PLANE_MARGIN_M`])²: farther from a triangle's plane is farther from the triangle.
    beyond2: f64,
    /// (√r2 − [`PLANE_MARGIN_M`])², or −1 when that is not positive: nearer the plane and over the triangle is
    /// within.
    inside2: f64,
}

impl Reach {
    pub fn new(r2: f64) -> Self {
        let r = r2.max(0.0).sqrt();
        let inside = r - PLANE_MARGIN_M;
        Reach {
            r2,
            beyond2: (r + PLANE_MARGIN_M) * (r + PLANE_MARGIN_M),
            inside2: if inside > 0.0 { inside * inside } else { -1.0 },
        }
    }

    /// Whether `p` lies within the radius of the triangle `f` was made of, when its plane tells: `Some(false)`
    /// farther than the radius from the plane, `Some(true)` over the triangle's inside and near enough to the
    /// plane; `None` otherwise, for [`closest_point_on_triangle`] to say. Exact in effect: see
    /// [`PLANE_MARGIN_M`].
    #[inline]
    pub fn decide(&self, p: V3, f: &PlaneFrame) -> Option<bool> {
        let v = sub(p, f.a);
        let h = dot(f.n, v);
        let h2 = h * h;
        if h2 > self.beyond2 {
            return Some(false);
        }
        if h2 <= self.inside2 {
            let (s, t) = (dot(f.u, v), dot(f.w, v));
            if s >= INSIDE_MARGIN && t >= INSIDE_MARGIN && s + t <= 1.0 - INSIDE_MARGIN {
                return Some(true);
            }
        }
        None
    }
}

/// A triangle's plane and barycentric frame for [`Reach::decide`]: corner `a`, unit normal `n`, and the dual
/// vectors `u`, `w` of its edges from `a` (a point a + s·(b − a) + t·(c − a) + h·n has s = u·(p − a),
/// t = w·(p − a), h = n·(p − a)). All zero for a degenerate triangle, which then decides nothing.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlaneFrame {
    a: V3,
    n: V3,
    u: V3,
    w: V3,
}

impl PlaneFrame {
    pub fn new(a: V3, b: V3, c: V3) -> Self {
        let (e0, e1) = (sub(b, a), sub(c, a));
        let n = normalize(cross(e0, e1));
        let (c0, c1) = (cross(e1, n), cross(n, e0));
        let (d0, d1) = (dot(e0, c0), dot(e1, c1));
        if n == [0.0; 3] || !(d0.abs() > 1e-300 && d1.abs() > 1e-300) {
            return PlaneFrame {
                a,
                n: [0.0; 3],
                u: [0.0; 3],
                w: [0.0; 3],
            };
        }
        PlaneFrame {
            a,
            n,
            u: scale(c0, 1.0 / d0),
            w: scale(c1, 1.0 / d1),
        }
    }
}

/// Closest point to `p` on triangle abc (Ericson, Real-Time Collision Detection §5.1.5 regions).
pub(crate) fn closest_point_on_triangle(p: V3, a: V3, b: V3, c: V3) -> V3 {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return add(a, scale(ab, v));
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return add(a, scale(ac, w));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return add(b, scale(sub(c, b), w));
    }
    let denom = va + vb + vc;
    if denom.abs() < 1e-300 {
        // Degenerate triangle: fall back to the closest of its edges.
        let cands = [
            closest_point_on_segment(p, a, b),
            closest_point_on_segment(p, b, c),
            closest_point_on_segment(p, c, a),
        ];
        return *cands
            .iter()
            .min_by(|x, y| dist2(p, **x).total_cmp(&dist2(p, **y)))
            .unwrap_or(&a);
    }
    let v = vb / denom;
    let w = vc / denom;
    add(a, add(scale(ab, v), scale(ac, w)))
}

pub(crate) fn closest_point_on_segment(p: V3, a: V3, b: V3) -> V3 {
    let ab = sub(b, a);
    let l2 = dot(ab, ab);
    if l2 <= 0.0 {
        return a;
    }
    let t = (dot(sub(p, a), ab) / l2).clamp(0.0, 1.0);
    add(a, scale(ab, t))
}

/// Squared distance between segments p1q1 and p2q2 (Ericson §5.1.9).
pub(crate) fn segment_segment_dist2(p1: V3, q1: V3, p2: V3, q2: V3) -> f64 {
    let d1 = sub(q1, p1);
    let d2 = sub(q2, p2);
    let r = sub(p1, p2);
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    let eps = 1e-18;
    let (s, t);
    if a <= eps && e <= eps {
        return dot(r, r);
    }
    if a <= eps {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = dot(d1, r);
        if e <= eps {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = dot(d1, d2);
            let denom = a * e - b * b;
            let mut s0 = if denom > eps * a * e {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t0 = 0.0;
                s0 = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t0 = 1.0;
                s0 = ((b - c) / a).clamp(0.0, 1.0);
            }
            s = s0;
            t = t0;
        }
    }
    dist2(add(p1, scale(d1, s)), add(p2, scale(d2, t)))
}

/// Parameter `t` along `p + t·d` where the segment meets triangle abc (Möller–Trumbore), if it does for
/// `t` in `[t_min, t_max]`. Edges parallel to the triangle's plane never meet it.
pub(crate) fn segment_triangle_hit(
    p: V3,
    d: V3,
    a: V3,
    b: V3,
    c: V3,
    t_min: f64,
    t_max: f64,
) -> Option<f64> {
    let e1 = sub(b, a);
    let e2 = sub(c, a);
    let h = cross(d, e2);
    let det = dot(e1, h);
    let scale_ref = norm(d) * norm(e1) * norm(e2);
    if det.abs() <= 1e-12 * scale_ref || scale_ref == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(p, a);
    let u = inv * dot(s, h);
    let tol = 1e-9;
    if u < -tol || u > 1.0 + tol {
        return None;
    }
    let q = cross(s, e1);
    let v = inv * dot(d, q);
    if v < -tol || u + v > 1.0 + tol {
        return None;
    }
    let t = inv * dot(e2, q);
    (t >= t_min && t <= t_max).then_some(t)
}

/// Squared distance between two triangles: 0 when they intersect, else the least vertex–triangle or
/// edge–edge distance.
pub(crate) fn triangle_triangle_dist2(t1: [V3; 3], t2: [V3; 3]) -> f64 {
    for (s, o) in [(t1, t2), (t2, t1)] {
        for i in 0..3 {
            let p = s[i];
            let q = s[(i + 1) % 3];
            if segment_triangle_hit(p, sub(q, p), o[0], o[1], o[2], 0.0, 1.0).is_some() {
                return 0.0;
            }
        }
    }
    let mut best = f64::INFINITY;
    for (s, o) in [(t1, t2), (t2, t1)] {
        for p in s {
            best = best.min(dist2(p, closest_point_on_triangle(p, o[0], o[1], o[2])));
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            best = best.min(segment_segment_dist2(
                t1[i],
                t1[(i + 1) % 3],
                t2[j],
                t2[(j + 1) % 3],
            ));
        }
    }
    best
}

/// Axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Aabb {
    pub min: V3,
    pub max: V3,
}

#[allow(clippy::needless_range_loop)]
impl Aabb {
    pub fn empty() -> Self {
        Aabb {
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
        }
    }
    pub fn add(&mut self, p: V3) {
        for k in 0..3 {
            self.min[k] = self.min[k].min(p[k]);
            self.max[k] = self.max[k].max(p[k]);
        }
    }
    pub fn of(points: impl IntoIterator<Item = V3>) -> Self {
        let mut b = Aabb::empty();
        for p in points {
            b.add(p);
        }
        b
    }
    pub fn expanded(&self, by: f64) -> Self {
        Aabb {
            min: [self.min[0] - by, self.min[1] - by, self.min[2] - by],
            max: [self.max[0] + by, self.max[1] + by, self.max[2] + by],
        }
    }
    pub fn overlaps(&self, o: &Aabb) -> bool {
        (0..3).all(|k| self.min[k] <= o.max[k] && o.min[k] <= self.max[k])
    }
    pub fn diagonal(&self) -> f64 {
        if self.min[0] > self.max[0] {
            return 0.0;
        }
        norm(sub(self.max, self.min))
    }
    /// Squared distance from `p` to the box (0 inside).
    pub fn dist2(&self, p: V3) -> f64 {
        let mut s = 0.0;
        for k in 0..3 {
            let d = (self.min[k] - p[k]).max(0.0).max(p[k] - self.max[k]);
            s += d * d;
        }
        s
    }
    /// Whether segment p→q (t in [0,1]) passes through the box (slab test).
    pub fn hits_segment(&self, p: V3, q: V3) -> bool {
        let d = sub(q, p);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for k in 0..3 {
            if d[k].abs() < 1e-300 {
                if p[k] < self.min[k] || p[k] > self.max[k] {
                    return false;
                }
            } else {
                let inv = 1.0 / d[k];
                let (mut a, mut b) = ((self.min[k] - p[k]) * inv, (self.max[k] - p[k]) * inv);
                if a > b {
                    std::mem::swap(&mut a, &mut b);
                }
                t0 = t0.max(a);
                t1 = t1.min(b);
                if t0 > t1 {
                    return false;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_inside_face_is_the_projection() {
        let q =
            closest_point_on_triangle([0.2, 0.2, 5.0], [0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        assert!(dist2(q, [0.2, 0.2, 0.0]) < 1e-20);
    }

    #[test]
    fn touching_triangles_have_zero_distance_and_apart_ones_do_not() {
        let a = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let b = [[0.5, 0.2, -1.0], [0.5, 0.2, 1.0], [0.6, 0.3, 1.0]];
        assert_eq!(triangle_triangle_dist2(a, b), 0.0);
        let c = [[0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [0.0, 1.0, 2.0]];
        assert!((triangle_triangle_dist2(a, c) - 4.0).abs() < 1e-12);
    }

    proptest::proptest! {
        /// Where the plane decides, it decides as the closest point does: triangles at city coordinates (a few km
        /// from the origin), points on, near and off their plane, over and beside them, radii from none to metres;
        /// and it does decide often (the shortcut is taken).
        #[test]
        fn the_plane_shortcut_decides_as_the_closest_point_does(
            origin in proptest::array::uniform3(-5000.0f64..5000.0),
            corners in proptest::array::uniform3(proptest::array::uniform3(-10.0f64..10.0)),
            flat in proptest::bool::ANY,
            points in proptest::collection::vec((0.0f64..1.0, 0.0f64..1.0, -1.0f64..1.0, 0u8..4), 40),
            radius in proptest::sample::select(vec![0.0, 1e-7, 1e-3, 0.05, 0.5, 3.0]),
        ) {
            let mut t = corners.map(|c| add(origin, c));
            if flat {
                // A roof or floor: the z of its first corner.
                t[1][2] = t[0][2];
                t[2][2] = t[0][2];
            }
            let f = PlaneFrame::new(t[0], t[1], t[2]);
            let n = normalize(tri_normal2(t[0], t[1], t[2]));
            let reach = Reach::new(radius * radius);
            let mut decided = 0;
            for (s, r, h, kind) in points {
                // Over the triangle (s + r ≤ 1 folded in), beside it, exactly on a corner, or on an edge.
                let (s, r) = if s + r > 1.0 { (1.0 - s, 1.0 - r) } else { (s, r) };
                let (s, r) = match kind {
                    0 => (s, r),
                    1 => (s * 3.0 - 1.0, r * 3.0 - 1.0),
                    2 => (0.0, 0.0),
                    _ => (s, 0.0),
                };
                let on = [0, 1, 2].map(|k| t[0][k] + (t[1][k] - t[0][k]) * s + (t[2][k] - t[0][k]) * r);
                // Off the plane by up to twice the radius (or on it).
                let p = add(on, scale(n, h * 2.0 * radius));
                let truth = dist2(p, closest_point_on_triangle(p, t[0], t[1], t[2])) <= reach.r2;
                if let Some(d) = reach.decide(p, &f) {
                    decided += 1;
                    proptest::prop_assert_eq!(d, truth, "{:?} at {:?} within {}", t, p, radius);
                }
            }
            if radius >= 0.05 && n != [0.0; 3] {
                proptest::prop_assert!(decided > 0);
            }
        }
    }
}
