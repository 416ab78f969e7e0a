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
    Ok(Run {
        wall_s,
        peak_rss_mb: usage.ru_maxrss as f64 / 1024.0,
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// `citylod build INPUTS ARGS --out OUT --quiet`, timed.
fn run_build(citylod: &Path, inputs: &[&Path], args: &[&str], out: &Path) -> Result<Run> {
    measure(
        Command::new(citylod)
            .arg("build")
            .args(inputs)
            .args(args)
            .arg("--out")
            .arg(out)
            .arg("--quiet"),
    )
}

/// `citylod check TILES --views 8 --out OUT --quiet` (fails unless every view passes), timed, and its report.
fn run_check(citylod: &Path, tiles: &Path, out: &Path) -> Result<(Run, serde_json::Value)> {
    let r = measure(
        Command::new(citylod)
            .env("NODEVICE_SELECT", "1")
            .args(["check", "--views", "8", "--quiet", "--out"])
            .arg(out)
            .arg(tiles),
    )?;
    let report = serde_json::from_slice(
        &std::fs::read(out.join("report.json")).context("reading the check report")?,
    )?;
    Ok((r, report))
}

fn bench_build(
    citylod: &Path,
    name: &str,
    inputs: &[PathBuf],
    extra: &[&str],
    runs: usize,
) -> Result<()> {
    if let Some(dir) = bench_build_kept(citylod, name, inputs, extra, runs)? {
        let _ = std::fs::remove_dir_all(dir);
    }
    Ok(())
}

/// [`bench_build`], returning the tileset's folder (for the caller to remove); `None` when the input is missing.
fn bench_build_kept(
    citylod: &Path,
    name: &str,
    inputs: &[PathBuf],
    extra: &[&str],
    runs: usize,
) -> Result<Option<PathBuf>> {
    if let Some(missing) = inputs.iter().find(|p| !p.exists()) {
        println!("{name:<44} skipped: {} not found", missing.display());
        return Ok(None);
    }
    let out = std::env::temp_dir().join(format!("citylod-bench-{}-{name}", std::process::id()));
    let mut times = Vec::new();
    let mut rss = Vec::new();
    let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    for _ in 0..runs {
        let r = run_build(citylod, &inputs, extra, &out)?;
        times.push(r.wall_s);
        rss.push(r.peak_rss_mb);
    }
    let report: serde_json::Value = serde_json::from_slice(
        &std::fs::read(out.join("build-report.json")).context("reading build-report.json")?,
    )?;
    let n = report["counts"]["buildings_written"].as_u64().unwrap_or(0);
    let bytes = report["tiles"]["glb_bytes"].as_u64().unwrap_or(0);
    let t = median(times);
    println!(
        "{name:<44} {n:>9} buildings  {t:>7.3} s (median of {runs})  {:>9.0} buildings/s  peak RSS {:>7.1} MB  glb {:>6.1} MB",
        n as f64 / t,
        rss.iter().cloned().fold(0.0, f64::max),
        bytes as f64 / 1e6
    );
    Ok(Some(out))
}

/// Runs inside a child process: reads the LoD2.2 models of `path` and simplifies all of them with topo-qem at
/// the seed's rates; prints `{"n": …, "triangles": …, "seconds": {rate: s}}` on stdout.
fn run_simplify_case(path: &str) -> Result<()> {
    use citylod_mesh::simplify::{simplify_all, Simplifier, DEFAULT_TOPO_QEM_A};
    let opts = citylod_ingest::IngestOptions {
        lod: Some("2.2".parse().map_err(|e: String| anyhow::anyhow!(e))?),
        ..Default::default()
    };
    let buildings = citylod_ingest::ingest(&[PathBuf::from(path)], &opts)?.buildings;
    let meshes: Vec<&citylod_model::Mesh3d> = buildings
        .iter()
        .filter_map(|b| b.mesh.as_ref().map(|m| &m.mesh))
        .collect();
    let triangles: usize = meshes.iter().map(|m| m.triangles.len()).sum();
    let mut seconds = serde_json::Map::new();
    for rate in [0.5, 0.6, 0.8] {
        let t = Instant::now();
        let simplifier = Simplifier::TopoQem {
            a: DEFAULT_TOPO_QEM_A,
        };
        let out: usize = simplify_all(&meshes, &simplifier, rate)
            .iter()
            .map(|r| r.mesh.triangles.len())
            .sum();
        seconds.insert(
            format!("{rate}"),
            serde_json::json!({"seconds": t.elapsed().as_secs_f64(), "triangles_out": out}),
        );
    }
    println!(
        "{}",
        serde_json::json!({"n": meshes.len(), "triangles": triangles, "rates": seconds})
    );
    Ok(())
}

/// Runs inside a child process: generalizes one input and prints `{"n": …, "seconds": …}` on stdout.
fn run_case(kind: &str, arg: &str) -> Result<()> {
    if kind == "simplify" {
        return run_simplify_case(arg);
    }
    let buildings = match kind {
        "synth" => synth::city(
            arg.parse().context("case synth needs a building count")?,
            42,
        ),
        "file" => {
            let opts = citylod_ingest::IngestOptions {
                storey_height_m: 3.5,
                ..Default::default()
            };
            citylod_ingest::ingest(&[PathBuf::from(arg)], &opts)?.buildings
        }
        other => bail!("unknown case {other}"),
    };
    let t = Instant::now();
    let g = citylod_generalize::generalize(&buildings, &Default::default())?;
    let seconds = t.elapsed().as_secs_f64();
    println!(
        "{}",
        serde_json::json!({"n": buildings.len(), "seconds": seconds, "levels": g.hierarchy.levels.len()})
    );
    Ok(())
}

/// Generalizes in a child process (so its peak RSS is its own) and returns (n, seconds, peak RSS MB, levels).
fn bench_generalize(kind: &str, arg: &str) -> Result<(usize, f64, f64, usize)> {
    let out = std::env::temp_dir().join(format!("citylod-bench-case-{}.json", std::process::id()));
    let file = std::fs::File::create(&out)?;
    let me = std::env::current_exe()?;
    let r = measure(Command::new(me).args(["case", kind, arg]).stdout(file))?;
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out)?)?;
    let _ = std::fs::remove_file(&out);
    Ok((
        v["n"].as_u64().unwrap_or(0) as usize,
        v["seconds"].as_f64().unwrap_or(f64::NAN),
        r.peak_rss_mb,
        v["levels"].as_u64().unwrap_or(0) as usize,
    ))
}

/// Writes the generated city of `n` buildings (seed 42, as the generalization cases) to `path` as GeoJSON in
/// [`synth::UTM_CRS`], atomically (a temporary file renamed).
fn write_synth_geojson(n: usize, path: &Path) -> Result<()> {
    let buildings = synth::city(n, 42);
    let tmp = path.with_extension("geojson.part");
    let mut w = std::io::BufWriter::with_capacity(1 << 20, std::fs::File::create(&tmp)?);
    synth::write_geojson(&buildings, &mut w)?;
    w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// Least-squares slope of log(time) against log(n): time ∝ n^slope.
fn fitted_exponent(points: &[(usize, f64)]) -> f64 {
    let xs: Vec<f64> = points.iter().map(|p| (p.0 as f64).ln()).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.1.ln()).collect();
    let (mx, my) = (
        xs.iter().sum::<f64>() / xs.len() as f64,
        ys.iter().sum::<f64>() / ys.len() as f64,
    );
    let cov: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let var: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    cov / var
}

fn main() -> Result<()> {
    let argv: Vec<String> = std::env::args().collect();
    if argv.get(1).map(String::as_str) == Some("case") && argv.len() == 4 {
        return run_case(&argv[2], &argv[3]);
    }
    if argv.get(1).map(String::as_str) == Some("synth-gdb") && argv.len() == 4 {
        let n: usize = argv[2]
            .parse()
            .context("synth-gdb N DIR: N is a building count")?;
        return synth::write_gdb(&synth::city(n, 42), Path::new(&argv[3]))
            .with_context(|| format!("writing {}", argv[3]));
    }
    // Real data written COPIES times side by side in another format: SOURCE is a CityJSON file for CityGML, a GeoJSON
    // FeatureCollection in lon/lat for OpenStreetMap XML and GeoParquet.
    if let (
        Some(writer @ ("synth-citygml" | "synth-osm" | "synth-geoparquet" | "synth-hipped")),
        5,
    ) = (argv.get(1).map(String::as_str), argv.len())
    {
        let copies: usize = argv[3]
            .parse()
            .with_context(|| format!("{writer} SOURCE COPIES FILE: COPIES is a count"))?;
        let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&argv[2])?)?;
        let mut out = std::io::BufWriter::new(std::fs::File::create(&argv[4])?);
        match writer {
            // Each copy 3 km east of the last; RD New with NAP heights, as a compound URN names it.
            "synth-citygml" => citylod_testdata::citygml::from_cityjson(
                &doc,
                copies,
                3000.0,
                "urn:ogc:def:crs,crs:EPSG::28992,crs:EPSG::5109",
                &mut out,
            )?,
            // Each copy 0.06° (~5 km) east of the last.
            "synth-osm" => citylod_testdata::osm_xml::write_xml(
                &citylod_testdata::osm_xml::from_geojson(&doc, copies, 0.06),
                &mut out,
            )?,
            // Every building tagged roof:shape=hipped (COPIES must be 1): the straight skeleton of every outline.
            "synth-hipped" => {
                anyhow::ensure!(copies == 1, "synth-hipped writes the source once");
                let mut doc = doc;
                for f in doc["features"].as_array_mut().context("no features")? {
                    f["properties"]["roof:shape"] = "hipped".into();
                }
                serde_json::to_writer(&mut out, &doc)?;
            }
            // As above, in row groups of 50,000.
            _ => {
                citylod_testdata::geoparquet::write_buildings(&doc, copies, 0.06, 50_000, &mut out)?
            }
        }
        return Ok(std::io::Write::flush(&mut out)?);
    }
    if argv.get(1).map(String::as_str) == Some("synth-geojson") && argv.len() == 4 {
        let n: usize = argv[2]
            .parse()
            .context("synth-geojson N FILE: N is a building count")?;
        return write_synth_geojson(n, Path::new(&argv[3]));
    }
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
    println!(
        "citylod-bench on {} cores; targets: DESIGN.md §9",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    println!("== citylod build (ingest → mesh → tiles), end to end (targets: Boston under 2 s; a generated city of 1,000,000 buildings under 90 s and 4 GB) ==");
    bench_build(
        &citylod,
        "boston (GeoJSON)",
        &[data.join("boston/boston_buildings.geojson")],
        &["--storey-height", "3.5"],
        runs,
    )?;
    bench_build(
        &citylod,
        "delft (CityJSONSeq)",
        &[data.join("delft-3dbag/delft.city.jsonl")],
        &[],
        runs,
    )?;
    bench_build(
        &citylod,
        "nyc-les (GeoJSON)",
        &[data.join("nyc-les/les_buildings.geojson")],
        &[],
        runs,
    )?;
    let pbf = data.join("nyc-les/ny-access-restriction.osm.pbf");
    bench_build(
        &citylod,
        "nyc-les (OpenStreetMap PBF, its streets too)",
        std::slice::from_ref(&pbf),
        &["--streets", &pbf.to_string_lossy()],
        runs,
    )?;
    // Real data written in other formats by this benchmark's writers (in a child process, as below), copies side by
    // side, then built: Boston's footprints ten times as OpenStreetMap XML (221,860 buildings, ~230 MB, as the API
    // writes it: the reader streams the text) and as GeoParquet (Overture's layout: WKB, id, num_floors,
    // names.primary; ZSTD; row groups read in parallel); Den Haag's LoD 2 city model twenty times as CityGML 2.0
    // (16,880 buildings, ~234 MB; solids as xlink:hrefs to their thematic surfaces, as the 3D City Database exports
    // them), built as footprints. And Boston with every building tagged `roof:shape=hipped`, built at LoD 2: the
    // straight skeleton of all 22,182 outlines, courtyards and 200-corner blocks included.
    let boston = data.join("boston/boston_buildings.geojson");
    let den_haag = data.join("denhaag-lod2/DenHaag_01.json");
    for (label, writer, source, copies, ext, flags, n) in [
        (
            "boston ×10 (OpenStreetMap XML)",
            "synth-osm",
            &boston,
            "10",
            "osm",
            &["--storey-height", "3.5"][..],
            1,
        ),
        (
            "boston ×10 (GeoParquet)",
            "synth-geoparquet",
            &boston,
            "10",
            "parquet",
            &["--storey-height", "3.5"][..],
            1,
        ),
        (
            "boston, every roof hipped (--lod 2)",
            "synth-hipped",
            &boston,
            "1",
            "geojson",
            &["--storey-height", "3.5", "--lod", "2"][..],
            1,
        ),
        (
            "den haag ×20 (CityGML 2.0)",
            "synth-citygml",
            &den_haag,
            "20",
            "gml",
            &[][..],
            runs,
        ),
    ] {
        if !source.exists() {
            println!("{label:<44} skipped: {} not found", source.display());
            continue;
        }
        let file = std::env::temp_dir().join(format!(
            "citylod-bench-{writer}-{}.{ext}",
            std::process::id()
        ));
        measure(
            Command::new(std::env::current_exe()?)
                .arg(writer)
                .arg(source)
                .arg(copies)
                .arg(&file),
        )?;
        let built = bench_build(&citylod, label, std::slice::from_ref(&file), flags, n);
        let _ = std::fs::remove_file(&file);
        built?;
    }
    // 300,000 buildings of the generated city as a File Geodatabase (written by the test writer, in a child process
    // as below).
    let gdb = std::env::temp_dir().join(format!("citylod-bench-city-{}.gdb", std::process::id()));
    measure(
        Command::new(std::env::current_exe()?)
            .arg("synth-gdb")
            .arg("300000")
            .arg(&gdb),
    )?;
    let built = bench_build(
        &citylod,
        "generated 300,000 (File Geodatabase)",
        std::slice::from_ref(&gdb),
        &["--crs", synth::UTM_CRS],
        1,
    );
    let _ = std::fs::remove_dir_all(&gdb);
    built?;
    // The generated city of the generalization benchmark below, written as a 236 MB GeoJSON in UTM and built
    // once (~45 s). Written by a child process: Linux counts the RSS a child inherits at fork in its peak, so this
    // process must stay small for the peaks measured after it.
    let city =
        std::env::temp_dir().join(format!("citylod-bench-city-{}.geojson", std::process::id()));
    measure(
        Command::new(std::env::current_exe()?)
            .arg("synth-geojson")
            .arg("1000000")
            .arg(&city),
    )?;
    // Kept for `citylod check` below.
    let built = bench_build_kept(
        &citylod,
        "generated city (GeoJSON)",
        std::slice::from_ref(&city),
        &["--crs", synth::UTM_CRS],
        1,
    );
    let _ = std::fs::remove_file(&city);
    let city_tiles = built?;

    println!("== coarse levels cost: total glb bytes, levels of detail vs buildings only (target ≤ 1.25×), and the bytes of the 8 views of citylod check (800×600): the cut / the cut and every tile refined on the way down, which clients load too ==");
    for (name, rel, extra) in [
        (
            "boston",
            "boston/boston_buildings.geojson",
            &["--storey-height", "3.5"][..],
        ),
        ("delft", "delft-3dbag/delft.city.jsonl", &[][..]),
        ("nyc-les", "nyc-les/les_buildings.geojson", &[][..]),
    ] {
        let input = data.join(rel);
        if !input.exists() {
            println!("{name:<28} skipped: {} not found", input.display());
            continue;
        }
        // (tileset glb bytes, bytes of the tiles the 8 built-in views select, and of those and the tiles they refine,
        // summed over the views)
        let bytes = |flags: &[&str]| -> Result<(u64, u64, u64)> {
            let out =
                std::env::temp_dir().join(format!("citylod-bench-bytes-{}", std::process::id()));
            let check =
                std::env::temp_dir().join(format!("citylod-bench-views-{}", std::process::id()));
            let args: Vec<&str> = extra.iter().chain(flags).copied().collect();
            run_build(&citylod, &[&input], &args, &out)?;
            let (_, views) = run_check(&citylod, &out, &check)?;
            let report: serde_json::Value =
                serde_json::from_slice(&std::fs::read(out.join("build-report.json"))?)?;
            let _ = std::fs::remove_dir_all(&out);
            let _ = std::fs::remove_dir_all(&check);
            let views_sum = |key: &str| -> u64 {
                views["views"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .filter_map(|v| v["bytes"][key].as_u64())
                    .sum()
            };
            Ok((
                report["tiles"]["glb_bytes"].as_u64().unwrap_or(0),
                views_sum("cut"),
                views_sum("loaded"),
            ))
        };
        let (lod, lean, leaves) = (
            bytes(&[])?,
            bytes(&["--level-ratio", "0.25"])?,
            bytes(&["--leaves-only"])?,
        );
        let mb = |b: u64| b as f64 / 1e6;
        println!(
            "{name:<28} default {:>6.2} MB ({:.2}×), views {:>6.2} / {:>6.2} MB   --level-ratio 0.25 {:>6.2} MB ({:.2}×), views {:>6.2} / {:>6.2} MB   buildings only {:>6.2} MB, views {:>6.2} / {:>6.2} MB",
            mb(lod.0),
            lod.0 as f64 / leaves.0 as f64,
            mb(lod.1),
            mb(lod.2),
            mb(lean.0),
            lean.0 as f64 / leaves.0 as f64,
            mb(lean.1),
            mb(lean.2),
            mb(leaves.0),
            mb(leaves.1),
            mb(leaves.2),
        );
    }

    println!("== 3D buildings: simplify every Delft LoD2.2 model with topo-qem (target ≤ 5 s on 2 cores) ==");
    let delft = data.join("delft-3dbag/delft.city.jsonl");
    if delft.exists() {
        let out = std::env::temp_dir().join(format!(
            "citylod-bench-simplify-{}.json",
            std::process::id()
        ));
        let me = std::env::current_exe()?;
        let r = measure(
            Command::new(me)
                .args(["case", "simplify"])
                .arg(&delft)
                .stdout(std::fs::File::create(&out)?),
        )?;
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out)?)?;
        let _ = std::fs::remove_file(&out);
        for (rate, x) in v["rates"].as_object().into_iter().flatten() {
            println!(
                "delft LoD2.2 at {:>3.0} %{:>12} {} models, {} → {} triangles  {:>7.3} s  (child peak RSS {:.1} MB)",
                rate.parse::<f64>().unwrap_or(0.0) * 100.0,
                "",
                v["n"],
                v["triangles"],
                x["triangles_out"],
                x["seconds"].as_f64().unwrap_or(f64::NAN),
                r.peak_rss_mb
            );
        }
        bench_build(
            &citylod,
            "delft --lod 2.2 (end to end)",
            std::slice::from_ref(&delft),
            &["--lod", "2.2"],
            runs,
        )?;
    } else {
        println!(
            "delft LoD2.2                 skipped: {} not found",
            delft.display()
        );
    }

    println!("== citylod check, 8 built-in views at 800×600 (target for Boston ≤ 30 s; every view passes, else the bench fails), and on the generated city ==");
    for (name, rel, extra) in [
        (
            "boston",
            "boston/boston_buildings.geojson",
            &["--storey-height", "3.5"][..],
        ),
        ("delft", "delft-3dbag/delft.city.jsonl", &[][..]),
        ("nyc-les", "nyc-les/les_buildings.geojson", &[][..]),
    ] {
        let input = data.join(rel);
        if !input.exists() {
            println!("{name:<28} skipped: {} not found", input.display());
            continue;
        }
        let tiles =
            std::env::temp_dir().join(format!("citylod-bench-check-tiles-{}", std::process::id()));
        let out =
            std::env::temp_dir().join(format!("citylod-bench-check-out-{}", std::process::id()));
        run_build(&citylod, &[&input], extra, &tiles)?;
        let (r, report) = run_check(&citylod, &tiles, &out)?;
        let triangles = |v: usize| -> String {
            let t = &report["views"][v]["triangles"];
            match (t["cut"].as_f64(), t["full_in_view"].as_f64()) {
                (Some(c), Some(f)) if c > 0.0 => format!("{:.1}×", f / c),
                _ => "-".into(),
            }
        };
        println!(
            "{name:<28} {:>7.3} s  peak RSS {:>7.1} MB  full-detail / cut triangles: far view {}, views 1–3 {} {} {}",
            r.wall_s,
            r.peak_rss_mb,
            triangles(0),
            triangles(1),
            triangles(2),
            triangles(3)
        );
        let _ = std::fs::remove_dir_all(&tiles);
        let _ = std::fs::remove_dir_all(&out);
    }
    // The checker on the generated city's tileset: its far view's full detail is every leaf, ~10 million triangles,
    // drawn in batches (no target in DESIGN.md; 8.6 GB and 40 s before the batches and the streaming reader).
    if let Some(tiles) = city_tiles {
        let out =
            std::env::temp_dir().join(format!("citylod-bench-check-city-{}", std::process::id()));
        let checked = run_check(&citylod, &tiles, &out);
        let _ = std::fs::remove_dir_all(&tiles);
        let _ = std::fs::remove_dir_all(&out);
        let (r, report) = checked?;
        let far = &report["views"][0]["triangles"];
        println!(
            "{:<28} {:>7.3} s  peak RSS {:>7.1} MB  far view: {} full-detail triangles, {} in the cut",
            "generated city (1,000,000)",
            r.wall_s,
            r.peak_rss_mb,
            far["full_in_view"],
            far["cut"]
        );
    }

    println!("== generalization alone (target: Boston ≤ 1 s; 1M ≤ 60 s and ≤ 4 GB; time ∝ n^k with k ≤ 1.2) ==");
    let boston = data.join("boston/boston_buildings.geojson");
    if boston.exists() {
        let (n, t, rss, levels) = bench_generalize("file", boston.to_str().context("path")?)?;
        println!("{:<28} {n:>9} buildings  {t:>7.3} s  {:>9.0} buildings/s  peak RSS {rss:>7.1} MB  {levels} levels", "boston", n as f64 / t);
    }
    let mut points = Vec::new();
    for n in [10_000usize, 100_000, 1_000_000] {
        let (n, t, rss, levels) = bench_generalize("synth", &n.to_string())?;
        println!("{:<28} {n:>9} buildings  {t:>7.3} s  {:>9.0} buildings/s  peak RSS {rss:>7.1} MB  {levels} levels", format!("generated city {n}"), n as f64 / t);
        points.push((n, t));
    }
    println!(
        "fitted exponent of time versus n (generated cities): {:.2}",
        fitted_exponent(&points)
    );
    Ok(())
}
