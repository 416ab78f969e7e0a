//! Dev-only: where every crate's tests find the real data sets — `../shared/data` beside the repository (its
//! README lists them). A clone without that folder still runs the rest of the suite: a data test asks
//! [`shared_data`] for its file, gets `None` with a `SKIP:` line on stderr, and returns.

use std::path::{Path, PathBuf};

/// The folder holding the real data sets (it may not exist).
pub fn shared_data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")
}

/// `../shared/data/<rel>` when it exists; otherwise `None`, after printing why the caller skips.
///
/// # Examples
/// ```
/// assert!(citylod_testdata::shared_data("no/such/file.geojson").is_none());
/// ```
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let p = shared_data_dir().join(rel);
    if p.exists() {
        Some(p)
    } else {
        eprintln!(
            "SKIP: test data {} not found (../shared/data is not beside this clone)",
            p.display()
        );
        None
    }
}
