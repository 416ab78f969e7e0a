//! Seed 004 (Zhao & Wang, profile-based simplification): horizontal profiles (plane sections) every
//! `step_m` metres; a profile is kept only where it differs from the last kept one by more than
//! `threshold_m` (plan distance of paired vertices, §4.5); kept profiles are extruded up to the next kept
//! one ("sudden change" transition, §4.7) with closed top and bottom caps. Local metres, z up.
//! Each extruded slab is a closed solid; slabs touch along their caps.

use std::collections::BTreeMap;

use citylod_model::Mesh3d;

use super::geom::{cross, sub, V3};
use super::polygon::triangulate_polygon_2d;
use super::{rate, unchanged, SimplifyResult};

type Loop = Vec<[f64; 2]>;

/// Most profiles taken of one model; a taller model's step is widened to keep this many (4 km at 1 m).
const MAX_BANDS: usize = 4096;

pub(crate) fn simplify_profile(
    mesh: &Mesh3d,
    step_m: f64,
    threshold_m: f64,
    target_rate: f64,
) -> SimplifyResult {
    if !(step_m.is_finite() && step_m > 0.0 && threshold_m.is_finite() && threshold_m >= 0.0) {
        return unchanged(
            mesh,
            "profile step must be > 0 m and threshold ≥ 0 m: returned unchanged",
        );
    }
    let zmin = mesh
        .positions
        .iter()
        .map(|p| p[2])
        .fold(f64::INFINITY, f64::min);
    let zmax = mesh
        .positions
        .iter()
        .map(|p| p[2])
        .fold(f64::NEG_INFINITY, f64::max);
    if zmax - zmin <= 1e-6 {
        return unchanged(
            mesh,
            "flat mesh has no height to profile: returned unchanged",
        );
    }
    // Each band sections the whole mesh: a model kilometres tall (a bad vertex) would take forever at 1 m.
    let asked_step_m = step_m;
    let step_m = step_m.max((zmax - zmin) / MAX_BANDS as f64);
    let bands = ((zmax - zmin) / step_m).ceil().clamp(1.0, MAX_BANDS as f64) as usize;
    // (band bottom z, profile) for each kept profile.
    let mut kept: Vec<(f64, Vec<Loop>)> = Vec::new();
    for k in 0..bands {
        let lo = zmin + k as f64 * step_m;
        let hi = (lo + step_m).min(zmax);
        let mut profile: Vec<Loop> = section(mesh, 0.5 * (lo + hi))
            .into_iter()
            .map(|l| douglas_peucker_closed(&l, 0.5 * threshold_m))
            .filter(|l| l.len() >= 3 && signed_area(l).abs() > 1e-4)
            .collect();
        if profile.is_empty() {
            continue;
        }
        match kept.last() {
            Some((_, last)) if profile_error_m(last, &profile) <= threshold_m => {}
            Some((_, last)) => {
                snap_to(&mut profile, last, threshold_m);
                let profile = clean_profile(profile);
                if !profile.is_empty() {
                    kept.push((lo, profile));
                }
            }
            None => kept.push((zmin, profile)),
        }
    }
    if kept.is_empty() {
        return unchanged(
            mesh,
            "no closed horizontal section found (open mesh?): returned unchanged",
        );
    }
    let mut positions: Vec<V3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    for (i, (z_lo, profile)) in kept.iter().enumerate() {
        let z_hi = kept.get(i + 1).map_or(zmax, |next| next.0);
        extrude_profile(profile, *z_lo, z_hi, &mut positions, &mut triangles);
    }
    let out = Mesh3d {
        positions,
        triangles,
    };
    let reached = rate(mesh.triangles.len(), out.triangles.len());
    let widened = (step_m > asked_step_m).then(|| {
        format!(
            "; the step was widened from {asked_step_m} m to {step_m:.3} m to keep {MAX_BANDS} profiles over the \
             model's {:.0} m",
            zmax - zmin
        )
    });
    let note = ((reached - target_rate).abs() > 0.01 || widened.is_some()).then(|| {
        format!(
            "profile method reached {:.1} % (target {:.1} %): it is driven by step {step_m} m and threshold {threshold_m} m, not by a rate; {} of {bands} profiles kept{}",
            reached * 100.0,
            target_rate * 100.0,
            kept.len(),
            widened.unwrap_or_default()
        )
    });
    SimplifyResult {
        source_vertex: vec![None; out.positions.len()],
        source_triangle: vec![None; out.triangles.len()],
        mesh: out,
        rate_reached: reached,
        note,
    }
}

/// Closed loops where the plane z = `z` cuts the mesh, oriented counter-clockwise around solid material
/// (outer rings CCW, holes CW) when triangles face outward. Open chains are dropped.
fn section(mesh: &Mesh3d, z: f64) -> Vec<Loop> {
    let p = &mesh.positions;
    // Keep the plane off vertex heights so every crossing is a proper edge crossing.
    let mut z = z;
    while p.iter().any(|q| (q[2] - z).abs() < 1e-7) {
        z += 1e-6;
    }
    let cut = |a: u32, b: u32| -> [f64; 2] {
        let (a, b) = (a.min(b), a.max(b));
        let (pa, pb) = (p[a as usize], p[b as usize]);
        let t = (z - pa[2]) / (pb[2] - pa[2]);
        [pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1])]
    };
    // Directed segments keyed by the mesh edges they cross.
    let mut next: BTreeMap<(u32, u32), Vec<(u32, u32)>> = BTreeMap::new();
    let mut point: BTreeMap<(u32, u32), [f64; 2]> = BTreeMap::new();
    for t in &mesh.triangles {
        let mut crossings = Vec::new();
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if (p[a as usize][2] < z) != (p[b as usize][2] < z) {
                crossings.push((a.min(b), a.max(b)));
            }
        }
        if crossings.len() != 2 {
            continue;
        }
        let n = cross(
            sub(p[t[1] as usize], p[t[0] as usize]),
            sub(p[t[2] as usize], p[t[0] as usize]),
        );
        let dir = [-n[1], n[0]]; // ẑ × n, horizontal part
        let (e0, e1) = (crossings[0], crossings[1]);
        let (q0, q1) = (cut(e0.0, e0.1), cut(e1.0, e1.1));
        let forward = (q1[0] - q0[0]) * dir[0] + (q1[1] - q0[1]) * dir[1] >= 0.0;
        let (s, e) = if forward { (e0, e1) } else { (e1, e0) };
        point.insert(e0, q0);
        point.insert(e1, q1);
        next.entry(s).or_default().push(e);
    }
    let mut loops = Vec::new();
    let starts: Vec<(u32, u32)> = next.keys().copied().collect();
    for start in starts {
        while next.get(&start).is_some_and(|v| !v.is_empty()) {
            let mut chain = vec![start];
            let mut cur = start;
            let closed = loop {
                let Some(nx) = next.get_mut(&cur).and_then(|v| v.pop()) else {
                    break false;
                };
                if nx == start {
                    break true;
                }
                chain.push(nx);
                cur = nx;
                if chain.len() > point.len() + 1 {
                    break false;
                }
            };
            if closed && chain.len() >= 3 {
                loops.push(chain.iter().map(|e| point[e]).collect());
            }
        }
    }
    loops
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

fn d2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Distance (m) from `p` to the segment `a`–`b`.
pub(crate) fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1]];
    let l2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    d2(p, [a[0] + t * ab[0], a[1] + t * ab[1]]).sqrt()
}

/// Douglas–Peucker on a closed loop (the paper's §4.4 leaves profile simplification open).
fn douglas_peucker_closed(l: &Loop, tol_m: f64) -> Loop {
    if l.len() <= 3 || tol_m <= 0.0 {
        return l.clone();
    }
    // Start at an extreme vertex (farthest from the mean), which no simplification may drop.
    let n = l.len() as f64;
    let mean = [
        l.iter().map(|p| p[0]).sum::<f64>() / n,
        l.iter().map(|p| p[1]).sum::<f64>() / n,
    ];
    let first = (0..l.len())
        .max_by(|&i, &j| d2(mean, l[i]).total_cmp(&d2(mean, l[j])).then(j.cmp(&i)))
        .unwrap_or(0);
    let l: Loop = l[first..]
        .iter()
        .chain(l[..first].iter())
        .copied()
        .collect();
    let far = (1..l.len())
        .max_by(|&i, &j| d2(l[0], l[i]).total_cmp(&d2(l[0], l[j])).then(j.cmp(&i)))
        .unwrap_or(1);
    let mut keep = vec![false; l.len()];
    keep[0] = true;
    keep[far] = true;
    let mut closed: Vec<[f64; 2]> = l.clone();
    closed.push(l[0]);
    let mut stack = vec![(0usize, far), (far, l.len())];
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (pa, pb) = (closed[a], closed[b]);
        let (mut best, mut at) = (0.0, a);
        for (i, &q) in closed.iter().enumerate().take(b).skip(a + 1) {
            let d = seg_dist(q, pa, pb);
            if d > best {
                best = d;
                at = i;
            }
        }
        if best > tol_m {
            keep[at] = true;
            stack.push((a, at));
            stack.push((at, b));
        }
    }
    l.iter()
        .zip(keep)
        .filter(|(_, k)| *k)
        .map(|(p, _)| *p)
        .collect()
}

/// §4.5 pairing: each vertex of `a` pairs with its nearest vertex of `b`, and each vertex of `b` that got
/// no partner pairs with its nearest of `a`. The error is the largest paired plan distance (m); profiles
/// with a different number of loops differ by infinity.
fn profile_error_m(a: &[Loop], b: &[Loop]) -> f64 {
    if a.len() != b.len() {
        return f64::INFINITY;
    }
    let pa: Vec<[f64; 2]> = a.iter().flatten().copied().collect();
    let pb: Vec<[f64; 2]> = b.iter().flatten().copied().collect();
    let nearest = |p: [f64; 2], set: &[[f64; 2]]| -> (usize, f64) {
        set.iter()
            .enumerate()
            .map(|(i, q)| (i, d2(p, *q)))
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .unwrap_or((0, f64::INFINITY))
    };
    let mut paired = vec![false; pb.len()];
    let mut worst = 0.0f64;
    for &p in &pa {
        let (i, d) = nearest(p, &pb);
        if i < paired.len() {
            paired[i] = true;
        }
        worst = worst.max(d);
    }
    for (i, &q) in pb.iter().enumerate() {
        if !paired[i] {
            worst = worst.max(nearest(q, &pa).1);
        }
    }
    worst.sqrt()
}

/// §4.6: vertices of the new profile within `threshold_m` of a vertex of the old one take its position,
/// so walls that did not move stay vertical.
fn snap_to(profile: &mut [Loop], old: &[Loop], threshold_m: f64) {
    let olds: Vec<[f64; 2]> = old.iter().flatten().copied().collect();
    for l in profile.iter_mut() {
        for p in l.iter_mut() {
            if let Some(q) = olds
                .iter()
                .min_by(|x, y| d2(*p, **x).total_cmp(&d2(*p, **y)))
            {
                if d2(*p, *q) <= threshold_m * threshold_m {
                    *p = *q;
                }
            }
        }
    }
}

/// Closed slab between `z_lo` and `z_hi` over the profile: walls per loop edge, caps per outer loop with
/// the holes inside it.
fn extrude_profile(
    profile: &[Loop],
    z_lo: f64,
    z_hi: f64,
    pos: &mut Vec<V3>,
    tris: &mut Vec<[u32; 3]>,
) {
    if z_hi - z_lo <= 1e-6 {
        return;
    }
    let outers: Vec<usize> = (0..profile.len())
        .filter(|&i| signed_area(&profile[i]) > 0.0)
        .collect();
    let mut holes_of: Vec<Vec<usize>> = vec![Vec::new(); profile.len()];
    for h in (0..profile.len()).filter(|&i| signed_area(&profile[i]) < 0.0) {
        let probe = profile[h][0];
        let owner = outers
            .iter()
            .copied()
            .filter(|&o| point_in_loop(&profile[o], probe))
            .min_by(|&x, &y| signed_area(&profile[x]).total_cmp(&signed_area(&profile[y])));
        if let Some(o) = owner {
            holes_of[o].push(h);
        }
    }
    for &o in &outers {
        let rings: Vec<Loop> = std::iter::once(o)
            .chain(holes_of[o].iter().copied())
            .map(|i| profile[i].clone())
            .collect();
        let flat: Vec<[f64; 2]> = rings.iter().flatten().copied().collect();
        let base_lo = pos.len() as u32;
        pos.extend(flat.iter().map(|p| [p[0], p[1], z_lo]));
        let base_hi = pos.len() as u32;
        pos.extend(flat.iter().map(|p| [p[0], p[1], z_hi]));
        let cap = triangulate_polygon_2d(&rings);
        for t in &cap {
            tris.push([base_hi + t[0], base_hi + t[1], base_hi + t[2]]); // up
            tris.push([base_lo + t[0], base_lo + t[2], base_lo + t[1]]); // down
        }
        let mut start = 0u32;
        for r in &rings {
            let n = r.len() as u32;
            for i in 0..n {
                let (a, b) = (start + i, start + (i + 1) % n);
                tris.push([base_lo + a, base_lo + b, base_hi + b]);
                tris.push([base_lo + a, base_hi + b, base_hi + a]);
            }
            start += n;
        }
    }
}

/// Drops repeated consecutive points (snapping can merge neighbours) and loops left without area.
fn clean_profile(profile: Vec<Loop>) -> Vec<Loop> {
    profile
        .into_iter()
        .map(|mut l| {
            l.dedup();
            while l.len() > 1 && l.first() == l.last() {
                l.pop();
            }
            l
        })
        .filter(|l| l.len() >= 3 && signed_area(l).abs() > 1e-4)
        .collect()
}

fn point_in_loop(l: &Loop, p: [f64; 2]) -> bool {
    let mut inside = false;
    for i in 0..l.len() {
        let (a, b) = (l[i], l[(i + 1) % l.len()]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0])
        {
            inside = !inside;
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplify::halfedge::tests::subdivided_box;
    use crate::topology::mesh_report;

    #[test]
    fn a_finely_divided_box_becomes_one_closed_slab() {
        let m = subdivided_box([10.0, 6.0, 9.0], 4);
        let out = simplify_profile(&m, 1.0, 0.2, 0.9);
        // One profile kept: 4 walls (8 triangles) plus two 2-triangle caps.
        assert_eq!(out.mesh.triangles.len(), 12);
        let r = mesh_report(&out.mesh);
        assert!(r.orientation_consistent && r.degenerate == 0, "{r:?}");
        let h = crate::hausdorff::hausdorff_m(&m, &out.mesh, 4.0);
        assert!(h < 1e-6, "{h}");
    }

    #[test]
    fn a_setback_keeps_a_second_profile() {
        let low = subdivided_box([10.0, 10.0, 4.0], 2);
        let mut top = subdivided_box([4.0, 4.0, 4.0], 2);
        for p in &mut top.positions {
            p[2] += 4.0;
        }
        let off = low.positions.len() as u32;
        let mut m = low.clone();
        m.positions.extend(&top.positions);
        m.triangles
            .extend(top.triangles.iter().map(|t| t.map(|i| i + off)));
        let out = simplify_profile(&m, 1.0, 0.5, 0.5);
        let zs: Vec<f64> = out.mesh.positions.iter().map(|p| p[2]).collect();
        assert!(
            zs.iter().any(|&z| (z - 4.0).abs() < 1e-9)
                && zs.iter().any(|&z| (z - 8.0).abs() < 1e-9)
        );
        let h = crate::hausdorff::hausdorff_m(&m, &out.mesh, 4.0);
        assert!(h < 1.01, "{h}");
    }

    /// A box 7.6 million km tall (one bad vertex, found by fuzzing) took forever at one profile a metre; the step
    /// widens to keep MAX_BANDS profiles, and the note says so.
    #[test]
    fn a_model_reaching_into_space_is_profiled_within_the_band_limit() {
        let mut m = subdivided_box([10.0, 6.0, 9.0], 1);
        for p in &mut m.positions {
            if p[2] > 1.0 {
                p[2] = 7.6e9;
            }
        }
        let out = simplify_profile(&m, 1.0, 0.2, 0.9);
        assert_eq!(out.mesh.triangles.len(), 12);
        let note = out.note.expect("a note");
        assert!(
            note.contains("widened from 1 m") && note.contains("4096 profiles"),
            "{note}"
        );
    }
}
