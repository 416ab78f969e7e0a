//! `citylod inspect DIR`: per tree depth, the tiles, features, triangles, bytes and the spread of geometricError, as
//! a table or (`--json`) as JSON for scripts (schemas/inspect.schema.json).

use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Args, Debug)]
pub struct InspectArgs {
    /// Tileset folder (holding tileset.json) or the tileset.json itself.
    #[arg(value_name = "TILESET")]
    pub tileset: PathBuf,

    /// Print JSON (schemas/inspect.schema.json) instead of the table: the same figures per depth, and their totals.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: InspectArgs) -> Result<ExitCode> {
    let path = if args.tileset.is_dir() {
        args.tileset.join("tileset.json")
    } else {
        args.tileset.clone()
    };
    // (features, triangles) of each tile's content, counted as it is decoded and then dropped: a city's decoded
    // tiles would take gigabytes.
    let mut counts: Vec<Option<(u64, u64)>> = Vec::new();
    let ts = citylod_tiles::read::read_tileset_with(&path, &mut |i, tile| {
        if counts.len() <= i {
            counts.resize(i + 1, None);
        }
        counts[i] = tile
            .content
            .take()
            .map(|c| (c.features.len() as u64, c.triangles.len() as u64));
    })
    .context("reading the tileset")?;
    let mut rows: Vec<Row> = Vec::new();
    let mut stack = vec![(0usize, 0usize)];
    while let Some((i, depth)) = stack.pop() {
        if rows.len() <= depth {
            rows.resize_with(depth + 1, Row::default);
        }
        let tile = &ts.tiles[i];
        let row = &mut rows[depth];
        row.tiles += 1;
        row.errors.push(tile.geometric_error_m);
        row.bytes += tile.content_bytes.unwrap_or(0);
        if let Some(Some((features, triangles))) = counts.get(i) {
            row.with_content += 1;
            row.triangles += triangles;
            row.features += features;
        }
        stack.extend(tile.children.iter().map(|&c| (c, depth + 1)));
    }
    for r in &mut rows {
        r.errors.sort_by(f64::total_cmp);
    }
    // Every depth has a tile, so its errors are never empty.
    let spread = |r: &Row| {
        (
            r.errors[0],
            r.errors[r.errors.len() / 2],
            r.errors[r.errors.len() - 1],
        )
    };
    if args.json {
        let depths: Vec<serde_json::Value> = rows
            .iter()
            .enumerate()
            .map(|(d, r)| {
                let (lo, med, hi) = spread(r);
                serde_json::json!({
                    "depth": d,
                    "tiles": r.tiles,
                    "tiles_with_content": r.with_content,
                    "features": r.features,
                    "triangles": r.triangles,
                    "bytes": r.bytes,
                    "geometric_error_m": {"min": lo, "median": med, "max": hi},
                })
            })
            .collect();
        let sum = |f: &dyn Fn(&Row) -> u64| rows.iter().map(f).sum::<u64>();
        let report = serde_json::json!({
            "tileset": path.display().to_string(),
            "geometric_error_m": ts.geometric_error_m,
            "depths": depths,
            "total": {
                "tiles": sum(&|r| r.tiles as u64),
                "tiles_with_content": sum(&|r| r.with_content as u64),
                "features": sum(&|r| r.features),
                "triangles": sum(&|r| r.triangles),
                "bytes": sum(&|r| r.bytes),
            },
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "{:>5} {:>7} {:>8} {:>9} {:>11} {:>11}  geometricError min / median / max (m)",
        "depth", "tiles", "content", "features", "triangles", "bytes"
    );
    for (d, r) in rows.iter().enumerate() {
        let (lo, med, hi) = spread(r);
        println!(
            "{d:>5} {:>7} {:>8} {:>9} {:>11} {:>11}  {lo:.2} / {med:.2} / {hi:.2}",
            r.tiles, r.with_content, r.features, r.triangles, r.bytes
        );
    }
    Ok(ExitCode::SUCCESS)
}

#[derive(Default)]
struct Row {
    tiles: usize,
    with_content: usize,
    features: u64,
    triangles: u64,
    bytes: u64,
    errors: Vec<f64>,
}
