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

/// splitmix64: a tiny seeded generator for generated test and benchmark inputs (the bench's synthetic city, the
/// hostile files of the end-to-end tests): the same seed gives the same sequence everywhere.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }

    /// One of `items` (not empty).
    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[(self.next_u64() % items.len() as u64) as usize]
    }
}
