//! Minimal f64 3-vector helpers for camera and culling maths in the tileset root frame (metres).
//! Invariant: `normalize` never divides by zero (a zero vector stays zero).

pub type Vec3 = [f64; 3];

pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// Unit vector along `a`; the zero vector for a (near-)zero input.
pub fn normalize(a: Vec3) -> Vec3 {
    let n = norm(a);
    if n > 1e-300 {
        scale(a, 1.0 / n)
    } else {
        [0.0; 3]
    }
}

pub fn is_finite(a: Vec3) -> bool {
    a.iter().all(|v| v.is_finite())
}
