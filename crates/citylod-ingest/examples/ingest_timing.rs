//! Times `ingest` on the files given on the command line and prints the report summary.
//! `cargo run -p citylod-ingest --release --example ingest_timing -- FILE… [--crs EPSG:N]`

use citylod_ingest::{ingest, IngestOptions};
use std::time::Instant;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut opts = IngestOptions::default();
    if let Some(i) = args.iter().position(|a| a == "--crs") {
        opts.crs = args.get(i + 1).cloned();
        args.drain(i..(i + 2).min(args.len()));
    }
    let paths: Vec<_> = args.iter().map(Into::into).collect();
    let t = Instant::now();
    match ingest(&paths, &opts) {
        Ok(out) => {
            let r = &out.report;
            println!(
                "{:.3} s: read {} written {} skipped {:?} repaired {:?} heights {:?}",
                t.elapsed().as_secs_f64(),
                r.features_read,
                r.buildings_written,
                r.skipped_by_reason,
                r.repaired_by_reason,
                r.height_sources
            );
            for i in r.repaired.iter().chain(&r.skipped).take(12) {
                println!("  {} {} {:?}: {}", i.file, i.feature_id, i.reason, i.detail);
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            let mut cause = std::error::Error::source(&e);
            while let Some(c) = cause {
                eprintln!("  caused by: {c}");
                cause = c.source();
            }
            std::process::exit(2);
        }
    }
}
