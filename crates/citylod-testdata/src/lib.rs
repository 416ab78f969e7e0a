//! Dev-only: where every crate's tests find the real data sets — `../shared/data` beside the repository (its
//! README lists them). A clone without that folder still runs the rest of the suite: a data test asks
//! [`shared_data`] for its file, gets `None` with a `SKIP:` line on stderr, and returns. Where the folder is there,
//! a file missing from it fails the test instead.

use std::path::{Path, PathBuf};

pub mod citygml;
pub mod fgdb;
pub mod geopackage;
pub mod geoparquet;
pub mod guard;
pub mod osm_pbf;
pub mod osm_xml;
pub mod shapefile;
pub mod zip;

/// The folder holding the real data sets (it may not exist).
pub fn shared_data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")
}

/// `../shared/data/<rel>` when it exists; `None`, after printing why the caller skips, when `../shared/data` is not
/// beside this clone at all (a user's clone).
///
/// # Panics
/// When `../shared/data` is there but `<rel>` is not: a file renamed or moved would otherwise turn every test that
/// reads it green without running it.
///
/// # Examples
/// ```
/// if let Some(p) = citylod_testdata::shared_data("boston/boston_buildings.geojson") {
///     assert!(p.is_file());
/// }
/// ```
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let dir = shared_data_dir();
    let p = dir.join(rel);
    if p.exists() {
        Some(p)
    } else if dir.is_dir() {
        panic!(
            "test data {} not found, though {} is there: was it renamed or moved?",
            p.display(),
            dir.display()
        );
    } else {
        eprintln!(
            "SKIP: test data {} not found (../shared/data is not beside this clone)",
            p.display()
        );
        None
    }
}

/// `../shared/data/<rel>` as `read` makes it: `None` when `../shared/data` is not beside this clone (as
/// [`shared_data`]).
///
/// # Panics
/// When the folder is there but the file is not, or `read` cannot make of it what the test expects (`None`): a test
/// must not pass on data it never read.
pub fn read_shared_data<T>(rel: &str, read: impl FnOnce(&Path) -> Option<T>) -> Option<T> {
    let path = shared_data(rel)?;
    Some(read(&path).unwrap_or_else(|| {
        panic!(
            "{}: present but not readable as the test expects",
            path.display()
        )
    }))
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

    /// Uniform in 0..n (0 when n is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next_u64() % n as u64) as usize
        }
    }

    /// One of `items` (not empty).
    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// FNV-1a of a text: a seed from a name (an input's, a reader's), the same on every machine.
pub fn fnv1a(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}
