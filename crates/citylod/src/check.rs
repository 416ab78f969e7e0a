//! `citylod check TILESET --out DIR`: for each camera, the cut a standard 3D Tiles client draws is validated
//! (coverage, monotone errors, seed criterion with view angles), rendered beside full detail and compared;
//! PNGs per view, a contact sheet and `report.json` (schemas/check-report.schema.json). Exit 0 all checks hold,
//! 1 some check failed, 2 usage or input error.

use crate::shown;
use anyhow::{bail, Context, Result};
use citylod_check::{
    check_features_drawn, check_tree, check_view, compute_sse, contact_sheet, standard_views_over,
    Camera, CheckSettings, Finding, LoadedTileset, Renderer, Selection, Tolerances, Viewport,
    NEAR_M, SKYLINE_TOLERANCE_PX, STANDARD_FOVY_DEG,
};
use citylod_model::ecef_to_geodetic;
use clap::Args;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

#[derive(Args, Debug)]
// A negative number is a value (`--storey-height -1` is refused by its range check, naming the flag).
#[command(allow_negative_numbers = true)]
pub struct CheckArgs {
    /// Tileset folder (holding tileset.json) or the tileset.json itself.
    #[arg(value_name = "TILESET", help_heading = "Input")]
    pub tileset: PathBuf,

    /// Maximum screen-space error of the simulated client in pixels (CesiumJS `maximumScreenSpaceError`).
    /// Default: 16, as CesiumJS and 3d-tiles-renderer, or δH where that is smaller: a tileset built with a
    /// tolerance below 16 px needs a client at SSE = δH, and is checked as that client.
    #[arg(long, value_name = "PX", help_heading = "Check")]
    pub sse: Option<f64>,

    /// Height tolerance δH of the refinement criterion (Yang et al. 2011) in pixels. Default: the tileset's
    /// `extras.citylod.dh_px`, else 20.
    #[arg(long, value_name = "PX", help_heading = "Check")]
    pub dh_px: Option<f64>,

    /// Area tolerance δA of the refinement criterion (Yang et al. 2011) in pixels². Default: the tileset's
    /// `extras.citylod.da_px`, else 200.
    #[arg(long, value_name = "PX²", help_heading = "Check")]
    pub da_px: Option<f64>,

    /// Number of built-in views, from the whole city in view (view 0) down to street level (40 m above the
    /// ground, or 5 m above every roof within 25 m of the eye where one is higher); each after view 0 looks
    /// at a building.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 8,
        help_heading = "Views",
        conflicts_with = "camera"
    )]
    pub views: usize,

    /// A camera instead of the built-in views: longitude and latitude (degrees), ellipsoidal height (m),
    /// heading (degrees clockwise from north) and pitch (degrees, negative looks down) in the east-north-up
    /// frame at the eye, as CesiumJS's `Camera.setView`. Repeat for several views.
    #[arg(
        long,
        value_name = "LON,LAT,H,HEADING,PITCH",
        help_heading = "Views",
        allow_hyphen_values = true
    )]
    pub camera: Vec<String>,

    /// Vertical field of view of every camera in degrees. CesiumJS's `frustum.fov` is the field of view
    /// across the wider side: on a landscape viewport it is 2·atan(width/height · tan(fovy/2)).
    #[arg(long, value_name = "DEG", default_value_t = STANDARD_FOVY_DEG, help_heading = "Views")]
    pub fovy: f64,

    /// Width of every render in pixels (at most the device's largest texture: 8192 on lavapipe).
    #[arg(long, value_name = "PX", default_value_t = 800, help_heading = "Views")]
    pub width: u32,

    /// Height of every render in pixels (at most the device's largest texture: 8192 on lavapipe).
    #[arg(long, value_name = "PX", default_value_t = 600, help_heading = "Views")]
    pub height: u32,

    /// Output folder for view-K/{cut,full,diff}.png, views.png and report.json (created if missing; not the
    /// tileset's folder or inside it). view-K folders of an earlier run with more views are removed.
    #[arg(short, long, value_name = "DIR", help_heading = "Output")]
    pub out: PathBuf,

    /// No progress output; a failed check still prints its one-line summary.
    #[arg(short, long, help_heading = "Output")]
    pub quiet: bool,
}

/// Parses `lon,lat,height,heading,pitch` into a camera in the root frame (`root_to_ecef`: the root transform).
fn parse_camera(s: &str, fovy_deg: f64, root_to_ecef: &[f64; 16]) -> Result<Camera> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| {
            format!("--camera {s}: expected five numbers lon,lat,height,heading,pitch")
        })?;
    let [lon, lat, h, heading, pitch] = v[..] else {
        bail!(
            "--camera {s}: expected five numbers lon,lat,height,heading,pitch, got {}",
            v.len()
        );
    };
    Camera::from_geodetic(lon, lat, h, heading, pitch, fovy_deg, root_to_ecef)
        .with_context(|| format!("--camera {s}"))
}

/// The maximum screen-space error of CesiumJS and 3d-tiles-renderer unless set (px).
const DEFAULT_SSE_PX: f64 = 16.0;

/// Most built-in views `--views` takes: each is rendered twice (the cut and full detail).
const MAX_VIEWS: usize = 256;

/// δH and δA: the flags, else the tileset's `extras.citylod`, else the seed defaults; with where they came from.
fn tolerances(args: &CheckArgs, extras: Option<&Value>) -> (Tolerances, &'static str) {
    let extras = extras.map_or(&Value::Null, |e| &e["citylod"]);
    let from_ts = |k: &str| extras[k].as_f64().filter(|v| v.is_finite() && *v > 0.0);
    let d = Tolerances::default();
    let dh = args
        .dh_px
        .map(|v| (v, "flag"))
        .or(from_ts("dh_px").map(|v| (v, "tileset")))
        .unwrap_or((d.dh_px, "default"));
    let da = args
        .da_px
        .map(|v| (v, "flag"))
        .or(from_ts("da_px").map(|v| (v, "tileset")))
        .unwrap_or((d.da_px, "default"));
    let source = match (dh.1, da.1) {
        (a, b) if a == b => a,
        _ => "mixed",
    };
    (
        Tolerances {
            dh_px: dh.0,
            da_px: da.0,
        },
        source,
    )
}

/// The camera in the root frame, on the globe (heading and pitch in the east-north-up frame at the eye, as
/// `--camera` takes them) and in ECEF, as a globe client is given it.
fn camera_json(c: &Camera, root_to_ecef: &[f64; 16], source: &str) -> Value {
    let (eye, forward, up) = c.in_ecef(root_to_ecef);
    let [lon, lat, h] = ecef_to_geodetic(eye);
    let (heading_deg, pitch_deg) = c.heading_pitch_on_globe(root_to_ecef);
    json!({
        "source": source,
        "eye_enu_m": c.eye_m,
        "lon_deg": lon, "lat_deg": lat, "height_m": h,
        "heading_deg": heading_deg,
        "pitch_deg": pitch_deg,
        "fovy_deg": c.fovy_deg,
        "eye_ecef_m": eye,
        "direction_ecef": forward,
        "up_ecef": up,
    })
}

/// What the traversal did with each tile it reached, in tree order: `selected` (drawn, or
/// `selected_empty` without triangles), `refined`, or `culled`; with the distance from the eye to the tile's
/// box (m) and its screen-space error (px; null when infinite: the eye inside the box). The content URIs of
/// the selected tiles, sorted, are the set a client such as CesiumJS selects (external-tileset links and
/// tiles without content excluded).
fn traversal_json<'a>(
    ts: &'a LoadedTileset,
    sel: &Selection,
    camera: &Camera,
    viewport: Viewport,
) -> (Vec<&'a str>, Vec<Value>) {
    let mut state: BTreeMap<usize, &str> = BTreeMap::new();
    for (list, name) in [
        (&sel.selected, "selected"),
        (&sel.selected_empty, "selected_empty"),
        (&sel.refined, "refined"),
        (&sel.culled, "culled"),
    ] {
        for &i in list {
            state.insert(i, name);
        }
    }
    let mut uris: Vec<&str> = sel
        .selected
        .iter()
        .chain(&sel.selected_empty)
        .flat_map(|&i| ts.tiles[i].content_uris.iter().map(String::as_str))
        .filter(|u| !citylod_tiles::read::names_json(u))
        .collect();
    uris.sort_unstable();
    let visited = state
        .iter()
        .map(|(&i, &st)| {
            let node = &ts.tree.tiles[i];
            let distance_m = node.bounds.distance_to(camera.eye_m);
            let sse_px = compute_sse(
                node.geometric_error_m,
                distance_m,
                viewport.height_px,
                camera.fovy_deg,
            );
            json!({
                "path": ts.tiles[i].path_in_tree,
                "uri": ts.tiles[i].content_uri,
                "state": st,
                "geometric_error_m": node.geometric_error_m,
                "distance_m": distance_m,
                "sse_px": sse_px.is_finite().then_some(sse_px),
            })
        })
        .collect();
    (uris, visited)
}

/// Refuses an output folder that is a file, or the tileset's own folder or inside it: check writes report.json,
/// views.png and `view-K/` there, which would mix into (and could overwrite) the tileset it reads.
fn check_out_folder(out: &Path, tileset_json: &Path) -> Result<()> {
    if out.exists() && !out.is_dir() {
        bail!(
            "--out {} is a file, not a folder; check writes report.json, views.png and view-K/ into a folder",
            out.display()
        );
    }
    let folder = match tileset_json.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let (Ok(folder_real), Ok(out_real)) = (std::fs::canonicalize(folder), resolved(out)) else {
        return Ok(()); // a missing tileset is reported when it is read
    };
    if out_real.starts_with(&folder_real) {
        let place = if out_real == folder_real {
            "the tileset's folder".to_string()
        } else {
            format!("inside the tileset's folder {}", folder.display())
        };
        bail!(
            "--out {} is {place}; check would write report.json, views.png and view-K/ into the tileset. Give a \
             folder outside it",
            out.display()
        );
    }
    Ok(())
}

/// `p` made absolute with every symbolic link resolved, also when its last components do not exist yet (`..`
/// after a link goes up from where the link points, as the file system does).
fn resolved(p: &Path) -> std::io::Result<PathBuf> {
    let mut out = PathBuf::new();
    for c in std::path::absolute(p)?.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            c => {
                out.push(c);
                if let Ok(real) = std::fs::canonicalize(&out) {
                    out = real;
                }
            }
        }
    }
    Ok(out)
}

fn findings_json(f: &[Finding]) -> Value {
    serde_json::to_value(f).unwrap_or(Value::Null)
}

pub fn run(args: CheckArgs) -> Result<ExitCode> {
    // Silence Mesa's device-select layer before wgpu (and any thread) starts.
    std::env::set_var("NODEVICE_SELECT", "1");
    let t_all = Instant::now();
    if let Some(sse) = args.sse.filter(|v| !(v.is_finite() && *v > 0.0)) {
        bail!(
            "--sse must be a positive number of pixels, got {}",
            shown(sse)
        );
    }
    for (name, v) in [("--dh-px", args.dh_px), ("--da-px", args.da_px)] {
        if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0)) {
            bail!("{name} must be a positive number, got {}", shown(v));
        }
    }
    if args.width == 0 || args.height == 0 {
        bail!("--width and --height must be at least 1 pixel");
    }
    if !(args.fovy > 0.0 && args.fovy < 180.0) {
        bail!(
            "--fovy must be in (0, 180) degrees, got {}",
            shown(args.fovy)
        );
    }
    if args.camera.is_empty() && args.views == 0 {
        bail!("--views must be at least 1 (or give --camera)");
    }
    if args.views > MAX_VIEWS {
        bail!(
            "--views must be at most {MAX_VIEWS} (each view is rendered twice), got {}",
            args.views
        );
    }
    let path = if args.tileset.is_dir() {
        args.tileset.join("tileset.json")
    } else {
        args.tileset.clone()
    };
    if !path.is_file() {
        bail!(
            "{}: no such tileset; give the folder holding tileset.json, or the file",
            args.tileset.display()
        );
    }
    check_out_folder(&args.out, &path)?;
    let (data, ts) = LoadedTileset::read(&path).context("reading the tileset")?;
    if data.tiles.is_empty() {
        bail!("{} has no tiles", path.display());
    }
    // The cuts are REPLACE cuts: with ADD a client draws a tile and its children together, which the coverage and
    // criterion checks would misjudge.
    if let Some(t) = data.tiles.iter().find(|t| {
        // A tile without glb content draws nothing of its own: ADD on it is REPLACE (a root linking external
        // tilesets, as some tilers write).
        let draws = t
            .content_uris
            .iter()
            .any(|u| !citylod_tiles::read::names_json(u));
        t.refine_add && !t.children.is_empty() && draws
    }) {
        bail!(
            "{}: tile {} refines by ADD; citylod check simulates REPLACE refinement only (what citylod writes)",
            path.display(),
            t.path_in_tree
        );
    }
    let (tol, tol_source) = tolerances(&args, data.extras.as_ref());
    let sse_px = args.sse.unwrap_or(DEFAULT_SSE_PX.min(tol.dh_px));

    let origin = [
        data.root_transform[12],
        data.root_transform[13],
        data.root_transform[14],
    ];
    let root_to_ecef = data.root_transform;
    let georeferenced = origin.iter().map(|v| v * v).sum::<f64>().sqrt() > 1e6;
    if !georeferenced && !args.quiet {
        eprintln!(
            "citylod check: the tileset is not georeferenced (its root's transform does not reach the globe's surface): \
             a globe client (CesiumJS, Cesium for Unreal) draws it near the Earth's centre; checked in its own frame"
        );
    }
    let cameras: Vec<(Camera, &str)> = if args.camera.is_empty() {
        let (lo, hi) = ts.root_extent().context("the root tile has no bounds")?;
        // The built-in views are placed for STANDARD_FOVY_DEG; --fovy only widens or narrows them. They look at
        // buildings, and no eye stands in or against one.
        standard_views_over(lo, hi, args.views, &ts)
            .into_iter()
            .map(|c| {
                (
                    Camera {
                        fovy_deg: args.fovy,
                        ..c
                    },
                    "standard",
                )
            })
            .collect()
    } else {
        if !georeferenced {
            bail!(
                "--camera needs a georeferenced tileset (its root has no transform to the globe)"
            );
        }
        args.camera
            .iter()
            .map(|s| Ok((parse_camera(s, args.fovy, &root_to_ecef)?, "camera")))
            .collect::<Result<_>>()?
    };
    if cameras.is_empty() {
        bail!("no camera: the root bounds are not finite");
    }

    let renderer = Renderer::new().context("opening a Vulkan device for rendering")?;
    let max_px = renderer.max_size_px();
    if args.width.max(args.height) > max_px {
        bail!(
            "--width and --height must be at most {max_px} px on this device ({}), got {}×{}",
            renderer.adapter_name(),
            args.width,
            args.height
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    remove_stale_views(&args.out, cameras.len())?;
    let settings = CheckSettings {
        sse_px,
        tolerances: tol,
        viewport: Viewport::new(args.width, args.height),
        skyline_tolerance_px: SKYLINE_TOLERANCE_PX,
    };

    let mut tree_findings = check_tree(&ts);
    tree_findings.extend(check_features_drawn(&ts, tol));
    tree_findings.extend(citylod_check::check_measured(&ts, tol));
    let features: usize = ts.tiles.iter().map(|t| t.features.len()).sum();
    let identity_checked = ts.identity_checked();
    if !identity_checked && !args.quiet {
        eprintln!(
            "citylod check: not a citylod tileset, and none of its {features} feature(s) carries citylod's identity \
             (building_index, or level and node_index): whether each cut holds every building once and the Δh / Δa \
             criterion are not checked; the tree, the bounding volumes and the drawn pictures are"
        );
    }
    let mut by_kind: BTreeMap<String, usize> = BTreeMap::new();
    let count = |f: &[Finding], by_kind: &mut BTreeMap<String, usize>| {
        for f in f {
            let k = serde_json::to_value(f.kind)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            *by_kind.entry(k).or_default() += 1;
        }
    };
    count(&tree_findings, &mut by_kind);
    let mut views_json = Vec::new();
    let mut sheet_panels = Vec::new();
    let mut views_passed = 0;
    let mut findings_total = tree_findings.len();
    for (k, (camera, source)) in cameras.iter().enumerate() {
        let t = Instant::now();
        let v =
            check_view(&ts, &renderer, camera, &settings).with_context(|| format!("view {k}"))?;
        let dir = args.out.join(format!("view-{k}"));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        for (name, img) in [
            ("cut", &v.cut),
            ("full", &v.full),
            ("diff", &v.metrics.diff),
        ] {
            let p = dir.join(format!("{name}.png"));
            img.save_png(&p)
                .with_context(|| format!("writing {}", p.display()))?;
        }
        let passed = v.findings.is_empty();
        views_passed += usize::from(passed);
        findings_total += v.findings.len();
        count(&v.findings, &mut by_kind);
        let m = &v.metrics;
        let ratio = (v.cut_triangles > 0).then(|| v.full_triangles as f64 / v.cut_triangles as f64);
        let sel = &v.selection;
        let (selected_uris, traversal) = traversal_json(&ts, sel, camera, settings.viewport);
        views_json.push(json!({
            "index": k,
            "camera": camera_json(camera, &root_to_ecef, source),
            "tiles": {
                "selected": sel.selected.len(),
                "selected_empty": sel.selected_empty.len(),
                "refined": sel.refined.len(),
                "culled": sel.culled.len(),
                "full_detail_in_view": v.full_tiles,
                "selected_paths": sel.selected.iter().map(|&i| ts.tiles[i].path_in_tree.as_str()).collect::<Vec<_>>(),
                "selected_uris": selected_uris,
                "root_below_threshold": sel.root_below_threshold,
                "traversal": traversal,
            },
            "triangles": {
                "cut": v.cut_triangles,
                "full_in_view": v.full_triangles,
                "full_total": v.full_triangles_total,
                "ratio_full_to_cut": ratio,
            },
            "bytes": { "cut": v.cut_bytes, "loaded": v.loaded_bytes, "full_in_view": v.full_bytes },
            "images": {
                "cut": format!("view-{k}/cut.png"),
                "full": format!("view-{k}/full.png"),
                "diff": format!("view-{k}/diff.png"),
            },
            "metrics": {
                "changed_px": m.changed_px,
                "changed_fraction": m.changed_fraction,
                "added_px": m.added_px,
                "removed_px": m.removed_px,
                "largest_added_region_px": m.largest_added_region_px,
                "largest_removed_region_px": m.largest_removed_region_px,
                "skyline": v.skyline,
                "skyline_limit_px": tol.dh_px + settings.skyline_tolerance_px,
            },
            "criterion": v.criterion,
            "findings": findings_json(&v.findings),
            "passed": passed,
            "elapsed_s": t.elapsed().as_secs_f64(),
        }));
        if !args.quiet {
            eprintln!(
                "view {k}: {}, {} of {} triangles ({}), {} finding(s), {:.1} s{}",
                crate::build::plural(sel.selected.len(), "tile"),
                v.cut_triangles,
                v.full_triangles,
                ratio.map_or("-".into(), |r| format!("{r:.1}×")),
                v.findings.len(),
                t.elapsed().as_secs_f64(),
                if v.full_triangles == 0 {
                    " — this camera sees none of the tileset: nothing of it is checked from here"
                } else {
                    ""
                }
            );
        }
        sheet_panels.push((format!("view {k} cut"), v.cut));
        sheet_panels.push((format!("view {k} diff"), v.metrics.diff));
    }
    let panels: Vec<(&str, &citylod_check::Image)> =
        sheet_panels.iter().map(|(l, i)| (l.as_str(), i)).collect();
    let sheet = contact_sheet(&panels, 4).context("building the contact sheet")?;
    let sheet_path = args.out.join("views.png");
    sheet
        .save_png(&sheet_path)
        .with_context(|| format!("writing {}", sheet_path.display()))?;

    let passed = findings_total == 0;
    let report = json!({
        "citylod_version": env!("CARGO_PKG_VERSION"),
        "tileset": path.display().to_string(),
        "adapter": renderer.adapter_name(),
        "settings": {
            "sse_px": sse_px,
            "dh_px": tol.dh_px,
            "da_px": tol.da_px,
            "tolerance_source": tol_source,
            "width_px": args.width,
            "height_px": args.height,
            "fovy_deg": args.fovy,
            "near_m": NEAR_M,
            "skyline_tolerance_px": settings.skyline_tolerance_px,
        },
        "tileset_stats": {
            "tiles": ts.tiles.len(),
            "leaf_tiles": ts.leaf_tiles().len(),
            "buildings": ts.buildings.len(),
            "features": features,
            "identity_checked": identity_checked,
            "geometric_error_m": data.geometric_error_m,
        },
        "tileset_findings": findings_json(&tree_findings),
        "views": views_json,
        "summary": {
            "views": cameras.len(),
            "views_passed": views_passed,
            "findings": findings_total,
            "findings_by_kind": by_kind,
            "passed": passed,
            "elapsed_s": t_all.elapsed().as_secs_f64(),
        },
    });
    let report_path = args.out.join("report.json");
    std::fs::write(&report_path, serde_json::to_vec_pretty(&report)?)
        .with_context(|| format!("writing {}", report_path.display()))?;
    // A failed check says so even with --quiet (as build's errors do): the exit code alone names no report.
    if !args.quiet || !passed {
        eprintln!(
            "citylod check: {views_passed} of {} views passed, {findings_total} finding(s){}; report: {}",
            cameras.len(),
            if tree_findings.is_empty() { String::new() } else { format!(" ({} in the tree)", tree_findings.len()) },
            report_path.display()
        );
    }
    Ok(if passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// The pictures of one view, all a `view-K` folder holds when check wrote it.
const VIEW_FILES: [&str; 3] = ["cut.png", "full.png", "diff.png"];

/// Removes the `view-K` folders of an earlier check into `out` for K ≥ `views` (a run with fewer views would leave
/// them beside a report that does not list them). A folder holding anything but check's pictures is left alone.
fn remove_stale_views(out: &Path, views: usize) -> Result<()> {
    let entries = std::fs::read_dir(out).with_context(|| format!("reading {}", out.display()))?;
    for e in entries {
        let e = e.with_context(|| format!("reading {}", out.display()))?;
        let name = e.file_name();
        let Some(k) = name
            .to_str()
            .and_then(|n| n.strip_prefix("view-"))
            .filter(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()))
            .and_then(|k| k.parse::<usize>().ok())
        else {
            continue;
        };
        let dir = e.path();
        if k < views || !dir.is_dir() || std::fs::symlink_metadata(&dir)?.file_type().is_symlink() {
            continue;
        }
        let only_pictures = std::fs::read_dir(&dir)?.all(|f| {
            f.is_ok_and(|f| {
                f.file_type().is_ok_and(|t| t.is_file())
                    && f.file_name()
                        .to_str()
                        .is_some_and(|n| VIEW_FILES.contains(&n))
            })
        });
        if only_pictures {
            std::fs::remove_dir_all(&dir)
                .with_context(|| format!("removing the earlier {}", dir.display()))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_earlier_views_past_this_run_are_removed() {
        let out = tempfile::tempdir().unwrap();
        let view = |k: &str, files: &[&str]| {
            let d = out.path().join(k);
            std::fs::create_dir_all(&d).unwrap();
            for f in files {
                std::fs::write(d.join(f), "png").unwrap();
            }
        };
        view("view-1", &VIEW_FILES);
        view("view-2", &VIEW_FILES);
        view("view-10", &["cut.png"]);
        view("view-3", &["cut.png", "notes.txt"]);
        view("view-x", &VIEW_FILES);
        std::fs::write(out.path().join("view-4"), "a file").unwrap();
        remove_stale_views(out.path(), 2).unwrap();
        let mut left: Vec<String> = std::fs::read_dir(out.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["view-1", "view-3", "view-4", "view-x"]);
    }

    #[test]
    fn out_inside_the_tileset_folder_is_refused_however_it_is_spelled() {
        let root = tempfile::tempdir().unwrap();
        let ts = root.path().join("tiles");
        std::fs::create_dir_all(ts.join("tiles")).unwrap();
        std::fs::write(ts.join("tileset.json"), "{}").unwrap();
        let json = ts.join("tileset.json");
        std::os::unix::fs::symlink(&ts, root.path().join("link")).unwrap();
        for out in [
            ts.clone(),
            ts.join("check"),
            ts.join("tiles/new/deeper"),
            root.path().join("link/check"),
            root.path().join("elsewhere/../tiles/./check"),
        ] {
            let e = check_out_folder(&out, &json).unwrap_err().to_string();
            let said = if out == ts {
                format!("--out {} is the tileset's folder;", ts.display())
            } else {
                format!("is inside the tileset's folder {}", ts.display())
            };
            assert!(e.contains(&said), "{}: {e}", out.display());
        }
        std::fs::write(root.path().join("file"), "x").unwrap();
        let e = check_out_folder(&root.path().join("file"), &json)
            .unwrap_err()
            .to_string();
        assert!(e.contains("is a file"), "{e}");
        for out in [root.path().join("check"), root.path().join("tiles-check")] {
            check_out_folder(&out, &json).unwrap();
        }
        // A relative tileset path (`tileset.json` in the working folder: its parent is "") resolves too.
        let here = std::env::current_dir().unwrap();
        check_out_folder(&here.join("x"), Path::new("tileset.json")).unwrap_err();
    }
}
