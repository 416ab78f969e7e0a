//! `citylod` — turns a city's buildings into an OGC 3D Tiles 1.1 tileset with measured levels of detail.
//! Thin glue: flags, wiring of the stages, progress, exit codes (0 ok, 1 check failed, 2 usage or input error).

mod build;
mod check;
mod features;
mod inspect;
mod lod;
mod progress;
#[cfg(test)]
mod street_tests;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "citylod", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build a 3D Tiles tileset from building footprints (GeoJSON, Shapefile, GeoPackage, File Geodatabase,
    /// GeoParquet, OpenStreetMap) or city models (CityGML, CityJSON, CityJSONSeq, GeoPackage 3D layers, MultiPatch).
    Build(Box<build::BuildArgs>),
    /// Print what a tileset holds: tiles, triangles, bytes and geometric errors per tree depth (0 is the root,
    /// the last the buildings).
    Inspect(inspect::InspectArgs),
    /// Check a tileset: validate and render the cut a 3D Tiles client draws from several cameras against full detail.
    Check(check::CheckArgs),
}

/// Exit code for usage errors and unreadable or invalid input.
pub const EXIT_INPUT: u8 = 2;

fn main() -> ExitCode {
    if let Some(e) = single_dash_out(std::env::args_os().skip(1)) {
        eprintln!("error: {e}");
        return ExitCode::from(EXIT_INPUT);
    }
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(EXIT_INPUT)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    let result = match cli.command {
        Command::Build(args) => build::run(*args),
        Command::Inspect(args) => tileset_given(&args.tileset).and_then(|()| inspect::run(args)),
        Command::Check(args) => check::run(args),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(EXIT_INPUT)
        }
    }
}

/// `-out DIR` (one dash) is `-o ut` to clap, with DIR taken as one more input: the user would be told that DIR
/// cannot be read. Refused before parsing (arguments after `--` are paths, left alone).
fn single_dash_out(args: impl Iterator<Item = std::ffi::OsString>) -> Option<String> {
    args.take_while(|a| a != "--")
        .filter_map(|a| a.into_string().ok())
        .find(|a| a == "-out" || a.starts_with("-out="))
        .map(|_| "-out is read as -o ut; write --out DIR (or -o DIR)".to_string())
}

/// Refuses a TILESET argument that is neither a tileset.json nor a folder holding one, as `check` does.
fn tileset_given(tileset: &std::path::Path) -> anyhow::Result<()> {
    let json = if tileset.is_dir() {
        tileset.join("tileset.json")
    } else {
        tileset.to_path_buf()
    };
    if !json.is_file() {
        anyhow::bail!(
            "{}: no such tileset; give the folder holding tileset.json, or the file",
            tileset.display()
        );
    }
    Ok(())
}

/// A number as a user reads it: plain, or in exponent form when huge or tiny (1e308, not 309 digits).
pub(crate) fn shown(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-6..1e9).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}
