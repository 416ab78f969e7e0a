//! Single-building LoD2 mesh simplification (DESIGN.md §7): one entry point, [`simplify`], over three methods.
//! Meshes are [`Mesh3d`] in local ENU metres (z up), triangles counter-clockwise seen from outside.
//! Invariant of every method: the result never has more triangles than the input, and carries the rate it
//! reached (fraction of triangles removed) plus a note when it stopped short of the target.
//!
//! - [`components`] — connected components by BFS over shared vertices (seed 003 §3.1)
//! - `qem` — area-weighted quadric error metric (Garland–Heckbert, seed 003 eq. 1)
//! - `error_bound` — local two-sided Hausdorff bound on collapses (sampled input surface)
//! - `halfedge` — half-edge collapse engine with link condition, flip and degeneracy checks
//! - [`topo_qem`] — seed 003: boundary/hole/ordinary vertices and the E–C-angle cost
//! - `profile` — seed 004: horizontal profiles every `step_m`, kept where they change
//! - `baseline` — plain QEM through meshoptimizer, for comparison only
//! - [`polygon`] — triangulation of planar polygons with holes (used by `profile`, useful to readers)

pub(crate) mod baseline;
pub mod components;
pub(crate) mod error_bound;
pub(crate) mod geom;
pub(crate) mod halfedge;
pub mod polygon;
pub(crate) mod profile;
pub(crate) mod qem;
pub mod topo_qem;

use citylod_model::Mesh3d;

pub use polygon::{triangulate_polygon_2d, triangulate_polygon_3d};
pub use topo_qem::TopoQemOptions;

/// Default basic cost ratio `a` of seed 003 (§4.2 suggests [1, 3] for simple and [2, 8] for complex models).
pub const DEFAULT_TOPO_QEM_A: f64 = 2.0;

/// Default error bound (m) of [`Simplifier::TopoQem`]: no collapse takes the surface further than this from
/// the input. LoD2 buildings of 12–100 triangles are near their minimal shape, so a rate of 80 % reached at
/// any cost turns boxes into tetrahedra and opens sight lines through whole blocks (seed 003 §4.3 asks for
/// the opposite); with 0.5 m the Den Haag street-level visibility test sees no change.
pub const DEFAULT_TOPO_QEM_MAX_ERROR_M: f64 = 0.5;

/// Which simplification method to run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Simplifier {
    /// Seed 003: QEM half-edge collapse constrained by component topology; `a` is the basic cost ratio
    /// applied to boundary vertices (≥ 1; [`DEFAULT_TOPO_QEM_A`] is a good start). Collapses stay within
    /// [`DEFAULT_TOPO_QEM_MAX_ERROR_M`] of the input; [`simplify_topo_qem`] takes another bound.
    TopoQem { a: f64 },
    /// Seed 004: horizontal profiles every `step_m` metres; a profile is kept only where it differs from the
    /// last kept one by more than `threshold_m` metres (plan distance). Driven by these, not by the rate.
    Profile { step_m: f64, threshold_m: f64 },
    /// Plain QEM through meshoptimizer (`meshopt::simplify`), for comparison.
    Qem,
}

/// Output of [`simplify`].
#[derive(Debug, Clone, PartialEq)]
pub struct SimplifyResult {
    /// The simplified mesh (same frame and units as the input).
    pub mesh: Mesh3d,
    /// Fraction of the input triangles removed, in [0, 1] (0 when the input is returned unchanged).
    pub rate_reached: f64,
    /// Why the method stopped more than 1 % short of (or beyond) the target, when it did.
    pub note: Option<String>,
    /// For each output vertex, the input vertex it is (`None` for vertices the method created, e.g. by
    /// `Profile`). Collapse-based methods keep a subset of the input vertices, so every entry is `Some`.
    pub source_vertex: Vec<Option<u32>>,
    /// For each output triangle, the input triangle it descends from when the method knows (`TopoQem`:
    /// the same triangle with moved corners); `None` otherwise.
    pub source_triangle: Vec<Option<u32>>,
}

/// Simplifies one building mesh towards `target_rate` (fraction of triangles to remove, clamped to
/// [0, 1]). An empty or invalid mesh (indices out of range) is returned unchanged with a note; the
/// result never has more triangles than the input.
///
/// ```
/// use citylod_mesh::simplify::{simplify, Simplifier};
/// use citylod_model::Mesh3d;
/// // A 10 m × 10 m square roof plate split into 8 triangles around a centre vertex.
/// let positions = vec![
///     [0.0, 0.0, 5.0], [5.0, 0.0, 5.0], [10.0, 0.0, 5.0], [10.0, 5.0, 5.0],
///     [10.0, 10.0, 5.0], [5.0, 10.0, 5.0], [0.0, 10.0, 5.0], [0.0, 5.0, 5.0], [5.0, 5.0, 5.0],
/// ];
/// let triangles = (0..8).map(|i| [i, (i + 1) % 8, 8]).collect();
/// let mesh = Mesh3d { positions, triangles };
/// let out = simplify(&mesh, &Simplifier::TopoQem { a: 2.0 }, 0.5);
/// assert_eq!(out.mesh.triangles.len(), 4);
/// assert!(out.note.is_none());
/// ```
pub fn simplify(mesh: &Mesh3d, simplifier: &Simplifier, target_rate: f64) -> SimplifyResult {
    checked(mesh, target_rate, |mesh, target_rate| match *simplifier {
        Simplifier::TopoQem { a } => {
            let options = TopoQemOptions {
                a,
                ..TopoQemOptions::default()
            };
            topo_qem::simplify_topo_qem(mesh, &options, target_rate)
        }
        Simplifier::Profile {
            step_m,
            threshold_m,
        } => profile::simplify_profile(mesh, step_m, threshold_m, target_rate),
        Simplifier::Qem => baseline::simplify_meshopt(mesh, target_rate),
    })
}

/// [`simplify`] over many buildings at once, spread over all cores (rayon); results in input order,
/// identical to calling [`simplify`] on each mesh.
///
/// ```
/// use citylod_mesh::simplify::{simplify, simplify_all, Simplifier, DEFAULT_TOPO_QEM_A};
/// use citylod_model::Mesh3d;
/// let plate = Mesh3d {
///     positions: vec![[0.0, 0.0, 5.0], [10.0, 0.0, 5.0], [10.0, 10.0, 5.0], [0.0, 10.0, 5.0], [5.0, 5.0, 5.0]],
///     triangles: vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
/// };
/// let method = Simplifier::TopoQem { a: DEFAULT_TOPO_QEM_A };
/// let out = simplify_all(&[&plate, &plate], &method, 0.5);
/// assert_eq!(out, vec![simplify(&plate, &method, 0.5); 2]);
/// assert_eq!(out[0].mesh.triangles.len(), 2);
/// ```
pub fn simplify_all(
    meshes: &[&Mesh3d],
    simplifier: &Simplifier,
    target_rate: f64,
) -> Vec<SimplifyResult> {
    use rayon::prelude::*;
    meshes
        .par_iter()
        .map(|m| simplify(m, simplifier, target_rate))
        .collect()
}

/// Seed 003 with every parameter explicit; otherwise as [`simplify`] with [`Simplifier::TopoQem`]. The
/// rate stops short (with a note) where going on would move the surface more than
/// `options.max_error_m` from the input.
///
/// ```
/// use citylod_mesh::simplify::{simplify_topo_qem, TopoQemOptions};
/// use citylod_model::Mesh3d;
/// // A 10 m × 6 m × 4 m box: every collapse would cut off a corner by metres.
/// let positions = vec![
///     [0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [10.0, 6.0, 0.0], [0.0, 6.0, 0.0],
///     [0.0, 0.0, 4.0], [10.0, 0.0, 4.0], [10.0, 6.0, 4.0], [0.0, 6.0, 4.0],
/// ];
/// let triangles = vec![
///     [0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
///     [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7],
/// ];
/// let mesh = Mesh3d { positions, triangles };
/// let kept = simplify_topo_qem(&mesh, &TopoQemOptions::default(), 0.5);
/// assert_eq!(kept.mesh, mesh);
/// assert!(kept.note.unwrap().contains("max_error_m"));
/// let free = TopoQemOptions { max_error_m: f64::INFINITY, ..TopoQemOptions::default() };
/// assert_eq!(simplify_topo_qem(&mesh, &free, 0.5).mesh.triangles.len(), 6);
/// ```
pub fn simplify_topo_qem(
    mesh: &Mesh3d,
    options: &TopoQemOptions,
    target_rate: f64,
) -> SimplifyResult {
    checked(mesh, target_rate, |mesh, target_rate| {
        topo_qem::simplify_topo_qem(mesh, options, target_rate)
    })
}

/// Runs `method` on a valid mesh with the rate clamped to [0, 1]; invalid input and a result with more
/// triangles than the input give the input back with a note.
fn checked(
    mesh: &Mesh3d,
    target_rate: f64,
    method: impl FnOnce(&Mesh3d, f64) -> SimplifyResult,
) -> SimplifyResult {
    let target_rate = if target_rate.is_finite() {
        target_rate.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let n = mesh.positions.len();
    if mesh.triangles.is_empty() || mesh.triangles.iter().flatten().any(|&i| i as usize >= n) {
        return unchanged(
            mesh,
            "empty mesh or triangle index out of range: returned unchanged",
        );
    }
    if mesh.positions.iter().flatten().any(|c| !c.is_finite()) {
        return unchanged(mesh, "non-finite vertex coordinate: returned unchanged");
    }
    let result = method(mesh, target_rate);
    if result.mesh.triangles.is_empty() {
        // The profile method finds no outward section in a model wound inside out: nothing to stand in for it, and
        // an error measured against nothing is infinite.
        return unchanged(
            mesh,
            &format!(
                "the method left no triangle{}: returned unchanged, so the full model is drawn instead",
                result.note.map(|n| format!(" ({n})")).unwrap_or_default()
            ),
        );
    }
    if result.mesh.triangles.len() > mesh.triangles.len() {
        return unchanged(
            mesh,
            "the method produced more triangles than the input: returned unchanged",
        );
    }
    result
}

/// Fraction of triangles removed going from `before` to `after` triangles.
pub(crate) fn rate(before: usize, after: usize) -> f64 {
    if before == 0 {
        0.0
    } else {
        (before.saturating_sub(after)) as f64 / before as f64
    }
}

pub(crate) fn unchanged(mesh: &Mesh3d, why: &str) -> SimplifyResult {
    SimplifyResult {
        mesh: mesh.clone(),
        rate_reached: 0.0,
        note: Some(why.to_string()),
        source_vertex: (0..mesh.positions.len() as u32).map(Some).collect(),
        source_triangle: (0..mesh.triangles.len() as u32).map(Some).collect(),
    }
}

/// Drops vertices no triangle uses; returns the compacted mesh and, per new vertex, its old index.
pub(crate) fn compact(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> (Mesh3d, Vec<u32>) {
    let mut remap = vec![u32::MAX; positions.len()];
    let mut kept = Vec::new();
    let mut tris = Vec::with_capacity(triangles.len());
    for t in triangles {
        let mut nt = [0u32; 3];
        for k in 0..3 {
            let old = t[k] as usize;
            if remap[old] == u32::MAX {
                remap[old] = kept.len() as u32;
                kept.push(old as u32);
            }
            nt[k] = remap[old];
        }
        tris.push(nt);
    }
    let pos = kept.iter().map(|&o| positions[o as usize]).collect();
    (
        Mesh3d {
            positions: pos,
            triangles: tris,
        },
        kept,
    )
}

/// Note for a rate more than 1 % away from the target, if it is.
pub(crate) fn rate_note(
    target: f64,
    reached: f64,
    why_short: &str,
    n_tris: usize,
) -> Option<String> {
    if (reached - target).abs() <= 0.01 {
        return None;
    }
    if reached > target {
        Some(format!(
            "reached {:.1} % for a {:.1} % target: one collapse removes up to 2 of {} triangles",
            reached * 100.0,
            target * 100.0,
            n_tris
        ))
    } else {
        Some(format!(
            "reached {:.1} % of a {:.1} % target: {}",
            reached * 100.0,
            target * 100.0,
            why_short
        ))
    }
}
