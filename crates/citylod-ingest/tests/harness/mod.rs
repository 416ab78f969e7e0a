//! What the readers' mutation tests share (`json_mutations`, `citygml_mutations`, `binary_mutations`): running one
//! ingest on a thread of its own under a time limit, catching its panic with what it said and where, and what an
//! ingest that succeeds must satisfy whatever the reader.
#![allow(dead_code)]

use citylod_ingest::{IngestError, Ingested};
use std::time::Duration;

/// What one guarded ingest gave.
pub enum Outcome {
    /// What the panic said, and where (in the case's thread or a rayon worker).
    Panicked(String),
    Failed(IngestError),
    Read(Box<Ingested>),
}

/// Runs the ingest `f` on a thread of its own and waits up to `hang` for it ([`citylod_testdata::guard::guarded`]):
/// what it gave, or what its panic said; `Err` with the time waited when it did not answer (a hang). With `quiet`,
/// a panic is only recorded, not printed.
pub fn guarded(
    hang: Duration,
    quiet: bool,
    f: impl FnOnce() -> Result<Ingested, IngestError> + Send + 'static,
) -> Result<Outcome, Duration> {
    Ok(match citylod_testdata::guard::guarded(hang, quiet, f)? {
        Err(said) => Outcome::Panicked(said),
        Ok(Err(e)) => Outcome::Failed(e),
        Ok(Ok(out)) => Outcome::Read(Box::new(out)),
    })
}

/// What one ingest must satisfy when it succeeds: the report's invariants, as many buildings as it says written,
/// features read = written + skipped per file, every issue and building with an id, a finite frame, positive
/// finite heights on finite bases, valid non-empty footprints, and models that pass their own invariants with
/// finite vertices and are not flat.
pub fn check(out: &Ingested) -> Result<(), String> {
    let r = &out.report;
    r.check_invariants()?;
    if out.buildings.len() != r.buildings_written {
        return Err(format!(
            "{} buildings returned, report says {} written",
            out.buildings.len(),
            r.buildings_written
        ));
    }
    for f in &r.files {
        if f.features_read != f.buildings_written + f.skipped {
            return Err(format!(
                "{}: {} features read, {} written + {} skipped",
                f.path, f.features_read, f.buildings_written, f.skipped
            ));
        }
    }
    for i in r.skipped.iter().chain(&r.repaired).chain(&r.mesh_issues) {
        if i.feature_id.trim().is_empty() || i.detail.trim().is_empty() || i.file.is_empty() {
            return Err(format!(
                "an issue without its feature's id, file or detail: {i:?}"
            ));
        }
    }
    if let Some(b) = out.buildings.iter().find(|b| b.source_id.trim().is_empty()) {
        return Err(format!("a building without an id: {:?}", b.source_id));
    }
    let f = &out.frame;
    if !(f.origin_lon_deg.is_finite() && f.origin_lat_deg.is_finite() && f.origin_h_m.is_finite()) {
        return Err(format!("frame origin not finite: {f:?}"));
    }
    for b in &out.buildings {
        let id = &b.source_id;
        if !(b.height_m > 0.0 && b.height_m.is_finite() && b.base_z_m.is_finite()) {
            return Err(format!(
                "{id}: height {} on base {}",
                b.height_m, b.base_z_m
            ));
        }
        let finite = |c: &geo_types::Coord| c.x.is_finite() && c.y.is_finite();
        if b.footprint.0.is_empty()
            || !b.footprint.0.iter().all(|p| {
                p.exterior().0.iter().all(finite)
                    && p.interiors().iter().all(|r| r.0.iter().all(finite))
            })
        {
            return Err(format!("{id}: empty footprint or a coordinate not finite"));
        }
        citylod_ingest::check_footprint(&b.footprint)
            .map_err(|e| format!("{id}: footprint: {e}"))?;
        if let Some(m) = &b.mesh {
            m.check_invariants()
                .map_err(|e| format!("{id}: model: {e}"))?;
            if !m.mesh.positions.iter().flatten().all(|c| c.is_finite()) {
                return Err(format!("{id}: model vertex not finite"));
            }
            // The readers refuse a flat 3D model (its footprint then stands for it): none is written.
            let (lo, hi) = m
                .mesh
                .positions
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                    (l.min(p[2]), h.max(p[2]))
                });
            if hi - lo < 0.1 {
                return Err(format!(
                    "{id}: a flat model written (z {lo}..{hi}, {} vertices)",
                    m.mesh.positions.len()
                ));
            }
        }
    }
    Ok(())
}
