//! `citylod-bench`: times citylod on real data and prints throughput and peak memory. Each case runs as its own
//! child process, so the peak resident set size (from `wait4`'s rusage) belongs to that case alone.
//! Benchmarks are not tests: they print figures against the targets of DESIGN.md §9 and never fail on time.

mod synth;

use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

struct Run {
    wall_s: f64,
    peak_rss_mb: f64,
}

/// Runs `cmd` to completion and measures its wall time and peak RSS.
fn measure(cmd: &mut Command) -> Result<Run> {
    let t = Instant::now();
    let child = cmd.spawn().with_context(|| format!("starting {cmd:?}"))?;
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: plain FFI calls on a zeroed rusage and our own child's pid; std's Child is not waited on after this.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    let wall_s = t.elapsed().as_secs_f64();
    if r != pid {
        bail!("wait4 failed for {cmd:?}");
    }
    if !(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0) {
        bail!("{cmd:?} failed (status {status})");
    }
    std::mem::forget(child);
    Ok(Run { wall_s, peak_rss_mb: usage.ru_maxrss as f64 / 1024.0 })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn bench_build(citylod: &Path, name: &str, inputs: &[PathBuf], extra: &[&str], runs: usize) -> Result<()> {
    if let Some(missing) = inputs.iter().find(|p| !p.exists()) {
        println!("{name:<28} skipped: {} not found", missing.display());
        return Ok(());
    }
    let out = std::env::temp_dir().join(format!("citylod-bench-{}-{name}", std::process::id()));
    let mut times = Vec::new();
    let mut rss = Vec::new();
    for _ in 0..runs {
        let mut cmd = Command::new(citylod);
        cmd.arg("build").args(inputs).args(extra).arg("--out").arg(&out).arg("--quiet");
        let r = measure(&mut cmd)?;
        times.push(r.wall_s);
        rss.push(r.peak_rss_mb);
    }
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("build-report.json")).context("reading build-report.json")?)?;
    let n = report["counts"]["buildings_written"].as_u64().unwrap_or(0);
    let bytes = report["tiles"]["glb_bytes"].as_u64().unwrap_or(0);
    let t = median(times);
    println!(
        "{name:<28} {n:>9} buildings  {t:>7.3} s (median of {runs})  {:>9.0} buildings/s  peak RSS {:>7.1} MB  glb {:>6.1} MB",
        n as f64 / t,
        rss.iter().cloned().fold(0.0, f64::max),
        bytes as f64 / 1e6
    );
    let _ = std::fs::remove_dir_all(&out);
    Ok(())
}

fn main() -> Result<()> {
    let mut citylod = PathBuf::from("target/release/citylod");
    let mut data = PathBuf::from("../shared/data");
    let mut runs = 3usize;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--citylod" => citylod = args.next().context("--citylod needs a path")?.into(),
            "--data" => data = args.next().context("--data needs a path")?.into(),
            "--runs" => runs = args.next().context("--runs needs a number")?.parse()?,
            other => bail!("unknown argument {other} (use --citylod BIN --data DIR --runs N)"),
        }
    }
    println!("citylod-bench on {} cores; targets: DESIGN.md §9", std::thread::available_parallelism().map_or(1, |n| n.get()));
    println!("== citylod build (ingest → mesh → tiles), end to end ==");
    bench_build(&citylod, "boston (GeoJSON)", &[data.join("boston/boston_buildings.geojson")], &["--storey-height", "3.5"], runs)?;
    bench_build(&citylod, "delft (CityJSONSeq)", &[data.join("delft-3dbag/delft.city.jsonl")], &[], runs)?;
    bench_build(&citylod, "nyc-les (GeoJSON)", &[data.join("nyc-les/les_buildings.geojson")], &[], runs)?;
    Ok(())
}
