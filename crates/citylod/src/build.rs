//! `citylod build`: ingest → mesh → tiles, then the build report; everything lands atomically in `--out`.

use anyhow::{bail, Context, Result};
use citylod_ingest::{ingest, IngestOptions};
use citylod_ingest::{FeatureIssue, IssueReason};
use citylod_tiles::{tile_spatially, write_tileset, Compression, Staging, WriteOptions};
use clap::{Args, ValueEnum};
use rayon::prelude::*;
use serde::Serialize;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use crate::progress::Progress;

#[derive(Args, Debug)]
pub struct BuildArgs {
    /// Input files: GeoJSON (.geojson, .json), CityJSON (.city.json, .json) or CityJSONSeq (.city.jsonl, .jsonl).
    #[arg(required = true, value_name = "INPUT", help_heading = "Input")]
    pub inputs: Vec<PathBuf>,

    /// CRS of the input coordinates, e.g. EPSG:28992. Default: WGS84 lon/lat for GeoJSON (RFC 7946), the file's
    /// `referenceSystem` for CityJSON.
    #[arg(long, value_name = "EPSG:CODE", help_heading = "Input")]
    pub crs: Option<String>,

    /// Attribute holding the building height above ground, in metres (strings such as "28 m" are accepted).
    /// Default: the first of height, building:height, measuredHeight, … that a feature has.
    #[arg(long, value_name = "NAME", help_heading = "Input")]
    pub height_attr: Option<String>,

    /// Attribute holding the number of storeys, used when no height attribute is present.
    /// Default: the first of stories, storeys, building:levels, b3_bouwlagen, … that a feature has.
    #[arg(long, value_name = "NAME", help_heading = "Input")]
    pub storey_attr: Option<String>,

    /// Height of one storey in metres, used with the storey count.
    #[arg(long, value_name = "M", default_value_t = 3.0, help_heading = "Input")]
    pub storey_height: f64,

    /// Height in metres for buildings with no height information (counted in the build report).
    #[arg(long, value_name = "M", default_value_t = 10.0, help_heading = "Input")]
    pub default_height: f64,

    /// Most buildings in one leaf tile.
    #[arg(long, value_name = "N", default_value_t = 2000, help_heading = "Tiles")]
    pub tile_max_features: usize,

    /// Most triangles in one leaf tile.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 200_000,
        help_heading = "Tiles"
    )]
    pub tile_max_triangles: usize,

    /// Geometry compression of the glb content.
    #[arg(long, value_enum, default_value_t = CompressionArg::Meshopt, help_heading = "Tiles")]
    pub compression: CompressionArg,

    /// Output folder; replaced atomically when the build succeeds.
    #[arg(long, short, value_name = "DIR", help_heading = "Output")]
    pub out: PathBuf,

    /// No progress output.
    #[arg(long, short, help_heading = "Output")]
    pub quiet: bool,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum CompressionArg {
    /// EXT_meshopt_compression with an uncompressed fallback (smallest files; default)
    Meshopt,
    /// Quantized geometry without compression
    None,
}

#[derive(Serialize)]
struct BuildReport<'a> {
    citylod_version: &'static str,
    inputs: Vec<String>,
    options: serde_json::Value,
    frame: &'a citylod_model::LocalFrame,
    counts: Counts,
    ingest: &'a citylod_ingest::IngestReport,
    mesh_skipped: Vec<FeatureIssue>,
    tiles: &'a citylod_tiles::WriteStats,
    timings_ms: Timings,
}

#[derive(Serialize)]
struct Counts {
    features_read: usize,
    buildings_written: usize,
    repaired: usize,
    skipped: usize,
}

#[derive(Serialize, Default)]
struct Timings {
    ingest: u64,
    mesh: u64,
    tiles: u64,
    total: u64,
}

pub fn run(args: BuildArgs) -> Result<ExitCode> {
    for (name, v) in [
        ("--storey-height", args.storey_height),
        ("--default-height", args.default_height),
    ] {
        if !(v.is_finite() && v > 0.0) {
            bail!("{name} must be a positive number of metres, got {v}");
        }
    }
    if args.tile_max_features == 0 || args.tile_max_triangles == 0 {
        bail!("--tile-max-features and --tile-max-triangles must be at least 1");
    }
    let t_all = Instant::now();
    let progress = Progress::new(args.quiet);
    let mut timings = Timings::default();

    progress.stage("reading input");
    let t = Instant::now();
    let opts = IngestOptions {
        crs: args.crs.clone(),
        height_attr: args.height_attr.clone(),
        storey_attr: args.storey_attr.clone(),
        storey_height_m: args.storey_height,
        default_height_m: args.default_height,
    };
    let ingested = ingest(&args.inputs, &opts).context("reading the input")?;
    timings.ingest = t.elapsed().as_millis() as u64;
    if ingested.buildings.is_empty() {
        bail!(
            "no building could be read from the input ({} features read, {} skipped; see the reasons above)",
            ingested.report.features_read,
            ingested.report.skipped.len()
        );
    }

    progress.stage("meshing buildings");
    let t = Instant::now();
    let meshed: Vec<_> = ingested
        .buildings
        .par_iter()
        .map(|b| {
            citylod_mesh::extrude(&b.footprint, b.base_z_m, b.base_z_m + b.height_m)
                .map_err(|e| (b, e))
        })
        .collect();
    let table = crate::features::BuildingTable::new(&ingested.buildings);
    let mut features = Vec::with_capacity(meshed.len());
    let mut mesh_skipped = Vec::new();
    for (b, m) in ingested.buildings.iter().zip(meshed) {
        match m {
            Ok(mesh) => features.push(table.feature(b, mesh)),
            Err((b, e)) => mesh_skipped.push(FeatureIssue {
                file: String::new(),
                feature_id: b.source_id.clone(),
                reason: IssueReason::MeshFailed,
                detail: e.to_string(),
            }),
        }
    }
    timings.mesh = t.elapsed().as_millis() as u64;

    progress.stage("writing tiles");
    let t = Instant::now();
    let written = features.len();
    let root = tile_spatially(features, args.tile_max_features, args.tile_max_triangles);
    let write_opts = WriteOptions {
        compression: match args.compression {
            CompressionArg::Meshopt => Compression::Meshopt,
            CompressionArg::None => Compression::None,
        },
        ..Default::default()
    };
    let staging =
        Staging::create(&args.out).with_context(|| format!("preparing {}", args.out.display()))?;
    let stats = write_tileset(
        &staging,
        &root,
        &ingested.frame,
        &table.schema(),
        &write_opts,
    )
    .with_context(|| format!("writing the tileset to {}", args.out.display()))?;
    timings.tiles = t.elapsed().as_millis() as u64;
    timings.total = t_all.elapsed().as_millis() as u64;
    let r = &ingested.report;
    let report = BuildReport {
        citylod_version: env!("CARGO_PKG_VERSION"),
        inputs: args
            .inputs
            .iter()
            .map(|p| p.display().to_string())
            .collect(),
        options: serde_json::json!({
            "crs": args.crs, "height_attr": args.height_attr, "storey_attr": args.storey_attr,
            "storey_height_m": args.storey_height, "default_height_m": args.default_height,
            "tile_max_features": args.tile_max_features, "tile_max_triangles": args.tile_max_triangles,
            "compression": format!("{:?}", args.compression).to_lowercase(),
        }),
        frame: &ingested.frame,
        counts: Counts {
            features_read: r.features_read,
            buildings_written: written,
            repaired: r.repaired.len(),
            skipped: r.skipped.len() + mesh_skipped.len(),
        },
        ingest: r,
        mesh_skipped,
        tiles: &stats,
        timings_ms: timings,
    };
    let mut bytes = serde_json::to_vec_pretty(&report)?;
    bytes.push(b'\n');
    staging.write_file("build-report.json", &bytes)?;
    staging
        .commit()
        .with_context(|| format!("moving the tileset into {}", args.out.display()))?;
    progress.finish();

    if !args.quiet {
        eprintln!(
            "citylod: {} of {} features written as buildings ({} repaired, {} skipped) into {} tiles, {:.1} MB, in {:.2} s",
            written,
            r.features_read,
            r.repaired.len(),
            report.counts.skipped,
            stats.tiles,
            stats.glb_bytes as f64 / 1e6,
            t_all.elapsed().as_secs_f64()
        );
        for (reason, n) in &r.skipped_by_reason {
            eprintln!("  skipped {n:>6} × {reason}");
        }
        eprintln!("  tileset: {}", args.out.join("tileset.json").display());
        eprintln!(
            "  report:  {}",
            args.out.join("build-report.json").display()
        );
    }
    Ok(ExitCode::SUCCESS)
}
