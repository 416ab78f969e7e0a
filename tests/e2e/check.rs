//! citylod check on real tilesets: every view passes, report.json validates against its schema, far views
//! draw far fewer triangles than full detail, renders are deterministic; and on deliberately damaged copies
//! (tileset.json edited with serde_json) the matching finding is reported with exit status 1.

use crate::common::*;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Small renders and few views keep the suite quick in debug builds.
const SIZE: [&str; 4] = ["--width", "400", "--height", "300"];

/// `target/e2e/<name>-<pid>`: nextest runs each test in a process of its own, and processes building or checking
/// into one shared folder at the same time would see each other's half-swapped output.
fn process_dir(name: &str) -> PathBuf {
    e2e_dir(&format!("{name}-{}", std::process::id()))
}

/// NYC Lower East Side (bundled), with small tiles so levels have siblings to damage.
fn nyc() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let out = process_dir("check-nyc");
        let input = repo_root().join("examples/nyc-les/les_buildings.geojson");
        build(&[&input], &out, &["--tile-max-features", "100"]);
        out
    })
}

fn boston() -> Option<&'static Path> {
    static DIR: OnceLock<Option<PathBuf>> = OnceLock::new();
    DIR.get_or_init(|| {
        let input = shared_data("boston/boston_buildings.geojson")?;
        let out = process_dir("check-boston");
        build(&[&input], &out, &["--storey-height", "3.5"]);
        Some(out)
    })
    .as_deref()
}

fn delft() -> Option<&'static Path> {
    static DIR: OnceLock<Option<PathBuf>> = OnceLock::new();
    DIR.get_or_init(|| {
        let input = shared_data("delft-3dbag/delft.city.jsonl")?;
        let out = process_dir("check-delft");
        build(&[&input], &out, &[]);
        Some(out)
    })
    .as_deref()
}

/// Runs `citylod check` and returns (exit code, report).
fn check(tileset: &Path, out: &Path, extra: &[&str]) -> (i32, Value) {
    let mut args = vec!["check".to_string(), tileset.display().to_string()];
    args.extend(SIZE.iter().chain(extra).map(|s| s.to_string()));
    args.extend(["--out".into(), out.display().to_string(), "--quiet".into()]);
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = citylod(&a);
    let code = o.status.code().expect("exit code");
    assert!(
        code == 0 || code == 1,
        "citylod check failed to run ({code}):\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // --quiet: nothing on success, the one-line summary on a failure.
    let stderr = String::from_utf8_lossy(&o.stderr);
    if code == 0 {
        // (The Vulkan driver may print its own warnings.)
        assert!(
            !stderr.contains("citylod check:"),
            "--quiet printed:\n{stderr}"
        );
    } else {
        assert!(
            stderr.contains("citylod check:") && stderr.contains("finding(s)"),
            "a failed check printed no summary under --quiet:\n{stderr}"
        );
    }
    let report = read_json(&out.join("report.json"));
    let errors = schema_errors("check-report.schema.json", &report);
    assert!(
        errors.is_empty(),
        "report.json breaks its schema:\n{}",
        errors.join("\n")
    );
    (code, report)
}

/// Every finding of the report (tileset-wide and per view) as (kind, tile).
fn findings(report: &Value) -> Vec<(String, String)> {
    let views = report["views"].as_array().unwrap();
    report["tileset_findings"]
        .as_array()
        .unwrap()
        .iter()
        .chain(views.iter().flat_map(|v| v["findings"].as_array().unwrap()))
        .map(|f| {
            (
                f["kind"].as_str().unwrap().to_string(),
                f["tile"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

/// The report of 4 built-in views on a real tileset, run once per data set and test process into
/// `check-<name>-<test>`: nextest runs every test in a process of its own, so two tests must not share a folder.
fn real_report(name: &'static str, test: &str) -> Option<&'static (i32, Value)> {
    static NYC: OnceLock<(i32, Value)> = OnceLock::new();
    static BOSTON: OnceLock<(i32, Value)> = OnceLock::new();
    static DELFT: OnceLock<(i32, Value)> = OnceLock::new();
    let (dir, cell) = match name {
        "nyc" => (nyc(), &NYC),
        "boston" => (boston()?, &BOSTON),
        _ => (delft()?, &DELFT),
    };
    Some(cell.get_or_init(|| {
        let out = process_dir(&format!("check-{name}-{test}"));
        let _ = std::fs::remove_dir_all(&out);
        check(dir, &out, &["--views", "4"])
    }))
}

/// Every view passes (exit 0) and every picture is written.
fn assert_all_views_pass(name: &'static str) {
    let Some((code, report)) = real_report(name, "views") else {
        return;
    };
    assert_eq!(*code, 0, "{name}: findings {:?}", findings(report));
    assert_eq!(report["summary"]["views_passed"], 4);
    let out = process_dir(&format!("check-{name}-views"));
    for k in 0..4 {
        for img in ["cut", "full", "diff"] {
            assert!(
                out.join(format!("view-{k}/{img}.png")).is_file(),
                "{name}: view-{k}/{img}.png"
            );
        }
    }
    assert!(out.join("views.png").is_file());
}

/// The far view (view 0, whole extent in view) must draw ≥ 10× fewer triangles than full detail.
fn assert_far_view_is_ten_times_lighter(name: &'static str) {
    let Some((_, report)) = real_report(name, "far") else {
        return;
    };
    let v0 = &report["views"][0]["triangles"];
    let (cut, full) = (
        v0["cut"].as_u64().unwrap(),
        v0["full_in_view"].as_u64().unwrap(),
    );
    assert!(
        cut * 10 <= full,
        "{name}: the far view draws {cut} of {full} triangles ({:.2}× fewer), not ≥ 10× fewer",
        full as f64 / cut.max(1) as f64
    );
}

#[test]
fn nyc_every_view_passes_and_report_validates() {
    assert_all_views_pass("nyc");
    let (_, report) = real_report("nyc", "views").unwrap();
    // citylod build records δH and δA in extras.citylod; the checker takes them from there.
    let settings = &report["settings"];
    assert_eq!(settings["tolerance_source"], "tileset", "{settings}");
    assert_eq!(
        (settings["dh_px"].as_f64(), settings["da_px"].as_f64()),
        (Some(20.0), Some(200.0))
    );
    assert!(report["tileset_stats"]["buildings"].as_u64().unwrap() > 1000);
    // What a client loads: the cut and every tile refined on the way down; NYC's root has content and every view
    // refines it.
    for v in report["views"].as_array().unwrap() {
        let b = &v["bytes"];
        let (cut, loaded) = (b["cut"].as_u64().unwrap(), b["loaded"].as_u64().unwrap());
        let refined = v["tiles"]["refined"].as_u64().unwrap();
        assert!(
            loaded > cut && refined > 0,
            "view {}: loaded {loaded} B, cut {cut} B, {refined} tiles refined",
            v["index"]
        );
    }
}

#[test]
fn nyc_far_view_draws_ten_times_fewer_triangles() {
    assert_far_view_is_ten_times_lighter("nyc");
}

#[test]
fn boston_every_view_passes() {
    assert_all_views_pass("boston");
}

#[test]
fn boston_far_view_draws_ten_times_fewer_triangles() {
    assert_far_view_is_ten_times_lighter("boston");
}

/// The 8 built-in views (the default) of Boston stand outside every building: no roof of full detail lies over an
/// eye and above it. The street view's eye stood at 37 m inside a 14-storey (49 m) building, and its cut and
/// full-detail pictures were one wall. And every view but the far one looks at a building.
#[test]
fn boston_views_look_at_buildings_and_do_not_stand_inside_them() {
    let Some(dir) = boston() else { return };
    let out = process_dir("check-boston-eyes");
    let _ = std::fs::remove_dir_all(&out);
    let (code, report) = check(dir, &out, &["--views", "8"]);
    assert_eq!(code, 0, "{:#}", report["summary"]);
    let (data, ts) = citylod_check::LoadedTileset::read(&dir.join("tileset.json")).unwrap();
    let meshes: Vec<&citylod_model::Mesh3d> = ts
        .leaf_tiles()
        .into_iter()
        .filter_map(|i| ts.tiles[i].mesh.as_ref())
        .collect();
    // Whether the point (x, y) is inside the triangle's ground projection (a wall's is a segment: never).
    let covers = |[a, b, c]: [[f64; 3]; 3], x: f64, y: f64| {
        let side =
            |p: [f64; 3], q: [f64; 3]| (q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0]);
        let s = [side(a, b), side(b, c), side(c, a)];
        s.iter().all(|v| *v > 0.0) || s.iter().all(|v| *v < 0.0)
    };
    let views = report["views"].as_array().unwrap();
    assert_eq!(views.len(), 8);
    for v in views {
        let eye: Vec<f64> = v["camera"]["eye_enu_m"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_f64().unwrap())
            .collect();
        let above = meshes.iter().find_map(|m| {
            m.triangles.iter().find_map(|t| {
                let p = t.map(|i| m.positions[i as usize]);
                (covers(p, eye[0], eye[1]) && p.iter().any(|q| q[2] > eye[2])).then_some(p)
            })
        });
        assert!(
            above.is_none(),
            "view {}: the eye {eye:?} is under the roof {above:?}",
            v["index"]
        );
        // Every view but the far one (which looks at the centre) looks at a building: its heading passes over a
        // vertex of full detail, in front of the eye. Without the rule one of Boston's looked at the Charles River.
        if v["index"] == 0 {
            continue;
        }
        // The report's heading is the globe's at the eye; the direction in the root frame comes from ECEF.
        let dir: Vec<f64> = v["camera"]["direction_ecef"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_f64().unwrap())
            .collect();
        let axis = |k: usize| {
            (0..3)
                .map(|r| dir[r] * data.root_transform[4 * k + r])
                .sum::<f64>()
        };
        let (dx, dy) = (axis(0), axis(1));
        let len = dx.hypot(dy);
        let (dx, dy) = (dx / len, dy / len);
        let on_heading = meshes.iter().flat_map(|m| &m.positions).any(|p| {
            let (vx, vy) = (p[0] - eye[0], p[1] - eye[1]);
            (vx * dy - vy * dx).abs() < 1e-6 && vx * dx + vy * dy > 0.0
        });
        assert!(
            on_heading,
            "view {}: the eye {eye:?} looks at no building along ({dx}, {dy})",
            v["index"]
        );
    }
}

/// A buildings-only tileset (`--leaves-only`: inner tiles without content over the leaves) passes every built-in
/// view. Its inner tiles had been given the root's box, so a client could not cull them by their own and chose them
/// (drawing nothing) where their children were out of view, and `citylod check` (so `make bench`) failed 3 of 8
/// views: the writer's `a_tile_without_content_below_its_parents_error_keeps_its_own_box` holds the boxes now, and
/// select's `an_empty_tile_whose_children_are_out_of_view_is_told_apart` the check's side (no hole is lost there).
#[test]
fn boston_buildings_only_tileset_passes_every_view() {
    let Some(input) = shared_data("boston/boston_buildings.geojson") else {
        return;
    };
    let dir = process_dir("check-boston-leaves");
    build(
        &[&input],
        &dir,
        &["--storey-height", "3.5", "--leaves-only"],
    );
    let out = process_dir("check-boston-leaves-views");
    let _ = std::fs::remove_dir_all(&out);
    let (code, report) = check(&dir, &out, &["--views", "8"]);
    assert_eq!(code, 0, "{:#}", report["summary"]);
    assert_eq!(report["summary"]["views_passed"], 8);
}

#[test]
fn delft_every_view_passes() {
    assert_all_views_pass("delft");
}

#[test]
fn delft_far_view_draws_ten_times_fewer_triangles() {
    assert_far_view_is_ten_times_lighter("delft");
}

#[test]
fn renders_are_deterministic() {
    let (a, b) = (scratch_dir("check-det-a"), scratch_dir("check-det-b"));
    check(nyc(), &a, &["--views", "2"]);
    check(nyc(), &b, &["--views", "2"]);
    for k in 0..2 {
        for img in ["cut", "full", "diff"] {
            let p = format!("view-{k}/{img}.png");
            assert!(
                std::fs::read(a.join(&p)).unwrap() == std::fs::read(b.join(&p)).unwrap(),
                "{p} differs"
            );
        }
    }
    assert!(
        std::fs::read(a.join("views.png")).unwrap() == std::fs::read(b.join("views.png")).unwrap()
    );
}

#[test]
fn explicit_camera_is_used_and_unreadable_tileset_is_exit_2() {
    let out = scratch_dir("check-camera");
    // Above the Lower East Side looking north-east and down.
    let (code, report) = check(nyc(), &out, &["--camera", "-73.985,40.715,600,30,-45"]);
    assert_eq!(code, 0, "{:?}", findings(&report));
    assert_eq!(report["views"].as_array().unwrap().len(), 1);
    assert_eq!(report["views"][0]["camera"]["source"], "camera");
    assert!((report["views"][0]["camera"]["height_m"].as_f64().unwrap() - 600.0).abs() < 1e-3);

    let out = scratch_dir("check-flags");
    let (_, flags) = check(
        nyc(),
        &out,
        &["--views", "1", "--dh-px", "25", "--da-px", "300"],
    );
    assert_eq!(flags["settings"]["tolerance_source"], "flag");
    assert_eq!(flags["settings"]["dh_px"], 25.0);

    let missing = citylod(&[
        "check",
        "/nonexistent/tileset.json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(missing.status.code(), Some(2));
    // A tileset that is not there is named as such, also when --out lies in the folder it would be in.
    let beside = citylod(&[
        "check",
        out.join("nonexistent").to_str().unwrap(),
        "--out",
        out.join("c1").to_str().unwrap(),
    ]);
    assert_eq!(beside.status.code(), Some(2));
    let e = String::from_utf8_lossy(&beside.stderr);
    assert!(e.contains("no such tileset"), "{e}");
    let many = citylod(&[
        "check",
        nyc().to_str().unwrap(),
        "--views",
        "99999999999",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(many.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&many.stderr).contains("--views must be at most 256"));
    for camera in ["1,2,3", "-73.985,40.715,-7000000,30,-45"] {
        let bad = citylod(&[
            "check",
            nyc().to_str().unwrap(),
            "--camera",
            camera,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(bad.status.code(), Some(2), "--camera {camera}");
    }
}

/// A tileset built for a tolerance δH below the clients' 16 px needs a client at SSE = δH, and check simulates that
/// client unless told otherwise (found by fuzzing: `build --dh-px 1` then `check` failed with 68 findings).
#[test]
fn check_simulates_a_client_at_the_tilesets_height_tolerance_when_it_is_below_16_px() {
    let dir = damaged("dh-8", |ts| ts["extras"]["citylod"]["dh_px"] = 8.0.into());
    let out = scratch_dir("check-dh-8");
    let (code, report) = check(&dir, &out, &["--views", "2"]);
    assert_eq!(code, 0, "{}", report["summary"]["findings_by_kind"]);
    let s = &report["settings"];
    assert_eq!(
        (s["sse_px"].as_f64(), s["dh_px"].as_f64()),
        (Some(8.0), Some(8.0)),
        "{s}"
    );
    let (_, flagged) = check(
        &dir,
        &scratch_dir("check-dh-8-sse"),
        &["--views", "1", "--sse", "12"],
    );
    assert_eq!(flagged["settings"]["sse_px"], 12.0);
    let (_, stock) = check(nyc(), &scratch_dir("check-dh-20"), &["--views", "1"]);
    assert_eq!(stock["settings"]["sse_px"], 16.0);
}

/// Check simulates REPLACE cuts: a tileset refining by ADD is refused with the reason, not misjudged.
#[test]
fn a_tileset_refining_by_add_is_refused_with_the_reason() {
    let dir = damaged("add", |ts| ts["root"]["refine"] = "ADD".into());
    let out = scratch_dir("check-add");
    let o = citylod(&[
        "check",
        dir.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    let named = format!(
        "{}: tile 0 refines by ADD",
        dir.join("tileset.json").display()
    );
    assert!(e.contains(&named), "{e}");
}

/// A copy of the NYC tileset with `edit` applied to its tileset.json.
fn damaged(name: &str, edit: impl FnOnce(&mut Value)) -> PathBuf {
    let dir = scratch_dir(&format!("damaged-{name}"));
    for (rel, bytes) in tree_bytes(nyc()) {
        let p = dir.join(&rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }
    let mut ts = read_json(&dir.join("tileset.json"));
    edit(&mut ts);
    std::fs::write(dir.join("tileset.json"), serde_json::to_vec(&ts).unwrap()).unwrap();
    dir
}

/// (path in the tree `0/…/k`, JSON pointer) of every tile, pre-order.
fn tile_pointers(ts: &Value) -> Vec<(String, String)> {
    fn walk(t: &Value, path: String, ptr: String, out: &mut Vec<(String, String)>) {
        out.push((path.clone(), ptr.clone()));
        for (k, c) in t["children"].as_array().into_iter().flatten().enumerate() {
            walk(c, format!("{path}/{k}"), format!("{ptr}/children/{k}"), out);
        }
    }
    let mut out = Vec::new();
    walk(&ts["root"], "0".into(), "/root".into(), &mut out);
    out
}

fn children_len(t: &Value) -> usize {
    t["children"].as_array().map_or(0, Vec::len)
}

/// Whether every child of `t` is a leaf (and it has at least `min` children).
fn parents_leaves(t: &Value, min: usize) -> bool {
    t["children"]
        .as_array()
        .is_some_and(|c| c.len() >= min && c.iter().all(|c| children_len(c) == 0))
}

/// Path and JSON pointer of the first tile with at least two children, all leaves.
fn parent_of_leaves(ts: &Value) -> (String, String) {
    tile_pointers(ts)
        .into_iter()
        .find(|(_, ptr)| parents_leaves(ts.pointer(ptr).unwrap(), 2))
        .expect("a tile with two leaf children")
}

fn run_damaged(name: &str, dir: &Path) -> Vec<(String, String)> {
    let out = scratch_dir(&format!("damaged-{name}-out"));
    let (code, report) = check(dir, &out, &["--views", "6"]);
    let f = findings(&report);
    assert_eq!(code, 1, "{name}: a damaged tileset must fail the check");
    assert_eq!(report["summary"]["passed"], false);
    f
}

#[test]
fn too_small_geometric_error_violates_the_criterion() {
    let dir = damaged("small-error", |ts| {
        for (_, ptr) in tile_pointers(ts) {
            let t = ts.pointer_mut(&ptr).unwrap();
            if parents_leaves(t, 1) {
                t["geometricError"] = Value::from(0.001);
            }
        }
    });
    let f = run_damaged("small-error", &dir);
    assert!(
        f.iter()
            .any(|(k, _)| k == "height_criterion" || k == "area_criterion"),
        "expected a criterion finding, got {f:?}"
    );
    assert!(!f.iter().any(|(k, _)| k == "error_grows"), "{f:?}");
}

#[test]
fn removed_child_is_a_coverage_gap() {
    let mut parent_path = String::new();
    let dir = damaged("removed-child", |ts| {
        let (path, ptr) = parent_of_leaves(ts);
        parent_path = path;
        ts.pointer_mut(&ptr).unwrap()["children"]
            .as_array_mut()
            .unwrap()
            .pop();
    });
    let f = run_damaged("removed-child", &dir);
    assert!(
        f.contains(&("member_count_mismatch".to_string(), parent_path.clone())),
        "expected member_count_mismatch at {parent_path}, got {f:?}"
    );
}

#[test]
fn content_duplicated_into_a_sibling_is_covered_twice() {
    let dir = damaged("duplicate", |ts| {
        let (_, ptr) = parent_of_leaves(ts);
        let c = ts.pointer_mut(&ptr).unwrap()["children"]
            .as_array_mut()
            .unwrap();
        c[1]["content"]["uri"] = c[0]["content"]["uri"].clone();
    });
    let f = run_damaged("duplicate", &dir);
    assert!(
        f.iter().any(|(k, _)| k == "building_in_two_leaves"),
        "{f:?}"
    );
    assert!(
        f.iter().any(|(k, _)| k == "building_twice"),
        "expected a view to cover a building twice: {f:?}"
    );
}

#[test]
fn child_error_above_parent_is_found() {
    let mut child_path = String::new();
    let dir = damaged("error-grows", |ts| {
        let (path, ptr) = parent_of_leaves(ts);
        let parent = ts.pointer_mut(&ptr).unwrap();
        let e = parent["geometricError"].as_f64().unwrap();
        parent["children"][0]["geometricError"] = Value::from(e + 100.0);
        child_path = format!("{path}/0");
    });
    let f = run_damaged("error-grows", &dir);
    assert!(
        f.contains(&("error_grows".to_string(), child_path.clone())),
        "expected error_grows at {child_path}: {f:?}"
    );
}

#[test]
fn content_outside_its_box_is_found() {
    // A leaf's box shrunk to a tenth of its half-axes around its centre: most of its buildings now lie outside
    // it and outside nothing else (its parent's box is untouched).
    let mut leaf_path = String::new();
    let dir = damaged("outside-box", |ts| {
        let (path, ptr) = parent_of_leaves(ts);
        leaf_path = format!("{path}/0");
        let b = ts
            .pointer_mut(&format!("{ptr}/children/0/boundingVolume/box"))
            .unwrap();
        for k in 3..12 {
            b[k] = Value::from(b[k].as_f64().unwrap() / 10.0);
        }
    });
    let f = run_damaged("outside-box", &dir);
    assert!(
        f.contains(&("content_outside_volume".to_string(), leaf_path.clone())),
        "expected content_outside_volume at {leaf_path}: {f:?}"
    );
    assert_eq!(
        f.iter()
            .filter(|(k, _)| k == "content_outside_volume")
            .count(),
        1,
        "only the shrunk box: {f:?}"
    );
}

/// The checker reads a tileset tile by tile, keeping of each content only what the checks use (a million
/// buildings' decoded property rows would take gigabytes); what it keeps is what converting the whole decoded
/// tileset gives — here on NYC split into external tilesets, so content URIs resolve through their folders.
#[test]
fn the_checker_reading_tile_by_tile_keeps_what_a_whole_read_gives() {
    let out = process_dir("check-stream");
    let input = repo_root().join("examples/nyc-les/les_buildings.geojson");
    build(
        &[&input],
        &out,
        &[
            "--tile-max-features",
            "100",
            "--max-tileset-json-bytes",
            "3000",
        ],
    );
    let path = out.join("tileset.json");
    let whole = citylod_tiles::read::read_tileset(&path).unwrap();
    assert!(
        whole.tiles.iter().any(|t| t
            .content_uri
            .as_deref()
            .is_some_and(|u| u.ends_with(".json"))),
        "expected external tilesets"
    );
    let (data, streamed) = citylod_check::LoadedTileset::read(&path).unwrap();
    assert_eq!(data.tiles.len(), whole.tiles.len());
    assert!(data.tiles.iter().all(|t| t.content.is_none()));
    let expected = citylod_check::LoadedTileset::from_data(&whole, Some(&out));
    assert!(expected.tiles.iter().filter(|t| t.mesh.is_some()).count() > 10);
    assert!(expected
        .tiles
        .iter()
        .all(|t| t.content_uri.is_none() || t.content_bytes > 0));
    assert_eq!(streamed, expected);
}

/// `inspect --json` gives the table's figures as JSON valid against schemas/inspect.schema.json: every building
/// once in the last depth, every content byte counted, and the same rows the table prints.
#[test]
fn inspect_json_matches_the_table_and_the_files() {
    let dir = nyc();
    let o = citylod(&["inspect", dir.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: Value = serde_json::from_slice(&o.stdout).unwrap();
    let errors = schema_errors("inspect.schema.json", &report);
    assert!(errors.is_empty(), "{}", errors.join("\n"));
    let depths = report["depths"].as_array().unwrap();
    assert_eq!(depths.last().unwrap()["features"], 1403);
    assert_eq!(depths.last().unwrap()["geometric_error_m"]["max"], 0.0);
    // Content bytes: every glb of the tileset, once.
    let glb_bytes: u64 = tree_bytes(dir)
        .iter()
        .filter(|(rel, _)| rel.ends_with(".glb"))
        .map(|(_, b)| b.len() as u64)
        .sum();
    assert_eq!(report["total"]["bytes"], glb_bytes);
    let sum = |key: &str| depths.iter().map(|d| d[key].as_u64().unwrap()).sum::<u64>();
    for key in ["tiles", "features", "triangles", "bytes"] {
        assert_eq!(report["total"][key], sum(key), "{key}");
    }
    // The table: one row per depth with the same tiles, features, triangles and bytes.
    let o = citylod(&["inspect", dir.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    let rows: Vec<Vec<u64>> = text
        .lines()
        .skip(1)
        .map(|l| {
            l.split_whitespace()
                .take(6)
                .map(|x| x.parse().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), depths.len());
    for (row, d) in rows.iter().zip(depths) {
        let json: Vec<u64> = [
            "depth",
            "tiles",
            "tiles_with_content",
            "features",
            "triangles",
            "bytes",
        ]
        .iter()
        .map(|k| d[*k].as_u64().unwrap())
        .collect();
        assert_eq!(row, &json);
    }
}

/// The 8 corners of a `box` (centre, three half-axes), in its frame.
fn box_corners(b: &[f64]) -> Vec<[f64; 3]> {
    (0..8)
        .map(|c: usize| {
            std::array::from_fn(|i| {
                b[i] + (0..3)
                    .map(|k| if c >> k & 1 == 1 { 1.0 } else { -1.0 } * b[3 + 3 * k + i])
                    .sum::<f64>()
            })
        })
        .collect()
}

/// A `region` (radians, metres) holding the root box of `ts`, with a metre to spare.
fn region_around_root(ts: &Value) -> Value {
    let m: Vec<f64> = serde_json::from_value(ts["root"]["transform"].clone()).unwrap();
    let b: Vec<f64> = serde_json::from_value(ts["root"]["boundingVolume"]["box"].clone()).unwrap();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in box_corners(&b) {
        let ecef: [f64; 3] =
            std::array::from_fn(|r| m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
        let g = citylod_model::ecef_to_geodetic(ecef);
        for k in 0..3 {
            lo[k] = lo[k].min(g[k]);
            hi[k] = hi[k].max(g[k]);
        }
    }
    let pad = 1e-5; // degrees, ~1 m
    serde_json::json!({"region": [
        (lo[0] - pad).to_radians(), (lo[1] - pad).to_radians(),
        (hi[0] + pad).to_radians(), (hi[1] + pad).to_radians(), lo[2] - 1.0, hi[2] + 1.0]})
}

/// 3D Tiles 1.1 allows `region` and `sphere` volumes: the check bounds content by the boxes enclosing them, so a
/// region around the city and spheres around the leaves' boxes pass, and volumes far from the content fail.
#[test]
fn region_and_sphere_volumes_are_checked() {
    let dir = damaged("region-sphere-ok", |ts| {
        let region = region_around_root(ts);
        ts["root"]["boundingVolume"] = region;
        for (_, ptr) in tile_pointers(ts) {
            let t = ts.pointer_mut(&ptr).unwrap();
            if children_len(t) == 0 {
                let b: Vec<f64> =
                    serde_json::from_value(t["boundingVolume"]["box"].clone()).unwrap();
                let r = (3..12).map(|k| b[k] * b[k]).sum::<f64>().sqrt();
                t["boundingVolume"] = serde_json::json!({"sphere": [b[0], b[1], b[2], r]});
            }
        }
    });
    let out = scratch_dir("region-sphere-ok-out");
    let (code, report) = check(&dir, &out, &["--views", "2"]);
    assert_eq!(code, 0, "{:?}", findings(&report));

    // The reviewer's case: the root volume a region (or sphere) nowhere near the buildings.
    for (name, volume) in [
        (
            "region",
            serde_json::json!({"region": [0, 0, 0.01, 0.01, 0, 10]}),
        ),
        ("sphere", serde_json::json!({"sphere": [5000, 5000, 0, 10]})),
    ] {
        let dir = damaged(&format!("far-{name}"), |ts| {
            ts["root"]["boundingVolume"] = volume
        });
        let out = scratch_dir(&format!("far-{name}-out"));
        let (code, report) = check(&dir, &out, &["--views", "1"]);
        assert_eq!(code, 1, "{name}: {:?}", findings(&report));
        let root_finding = report["tileset_findings"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["kind"] == "content_outside_volume" && f["tile"] == "0")
            .unwrap_or_else(|| panic!("{name}: no finding at the root: {:?}", findings(&report)));
        let msg = root_finding["message"].as_str().unwrap();
        assert!(msg.contains(&format!("bounding {name}")), "{msg}");
    }
}

/// 3D Tiles 1.1 `contents`: every content of the array is read, so a tile that lists its glb there is checked
/// like one with `content`, and two contents add up.
#[test]
fn multiple_contents_are_read() {
    let dir = damaged("contents", |ts| {
        let c = ts["root"]["content"].take();
        ts["root"].as_object_mut().unwrap().remove("content");
        ts["root"]["contents"] = serde_json::json!([c]);
    });
    let out = scratch_dir("contents-out");
    let (code, report) = check(&dir, &out, &["--views", "2"]);
    assert_eq!(code, 0, "{:?}", findings(&report));

    let root_row = |dir: &Path| -> Vec<String> {
        let o = citylod(&["inspect", dir.to_str().unwrap()]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let text = String::from_utf8_lossy(&o.stdout).to_string();
        let row = text.lines().nth(1).unwrap().to_string();
        row.split_whitespace().map(str::to_string).collect()
    };
    let plain = root_row(nyc());
    // Root and its first child's content on the root: contents, features and triangles add up.
    let two = damaged("contents-two", |ts| {
        let c = ts["root"]["content"].take();
        let child = ts["root"]["children"][0]["content"].clone();
        ts["root"].as_object_mut().unwrap().remove("content");
        ts["root"]["contents"] = serde_json::json!([c, child]);
    });
    let merged = root_row(&two);
    let ts = read_json(&nyc().join("tileset.json"));
    let child_uri = ts["root"]["children"][0]["content"]["uri"]
        .as_str()
        .unwrap();
    let child = citylod_tiles::read::read_glb(
        &std::fs::read(nyc().join(child_uri)).unwrap(),
        &nyc().join(child_uri),
    )
    .unwrap();
    let num = |row: &[String], k: usize| row[k].parse::<usize>().unwrap();
    assert_eq!(num(&merged, 2), 1, "{merged:?}");
    assert_eq!(num(&merged, 3), num(&plain, 3) + child.features.len());
    assert_eq!(num(&merged, 4), num(&plain, 4) + child.triangles.len());
}

/// `glb` with `edit` applied to its JSON chunk (re-padded with spaces; the BIN chunk kept as it is).
fn edit_glb_json(glb: &[u8], edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let u32_at = |k: usize| u32::from_le_bytes(glb[k..k + 4].try_into().unwrap()) as usize;
    let json_len = u32_at(12);
    let mut json: Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    edit(&mut json);
    let mut text = serde_json::to_vec(&json).unwrap();
    text.resize(text.len().next_multiple_of(4), b' ');
    let rest = &glb[20 + json_len..];
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(((20 + text.len() + rest.len()) as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    out.extend(rest);
    out
}

/// Applies `edit` to the JSON chunk of every glb under `dir`; returns how many there were.
fn edit_every_glb(dir: &Path, edit: impl Fn(&mut Value)) -> usize {
    let mut glbs = 0;
    for (rel, bytes) in tree_bytes(dir) {
        if rel.ends_with(".glb") {
            std::fs::write(dir.join(&rel), edit_glb_json(&bytes, &edit)).unwrap();
            glbs += 1;
        }
    }
    glbs
}

/// Removes a glb's metadata (JSON chunk only): EXT_structural_metadata and its primitives' EXT_mesh_features, and
/// both from the extension lists.
fn strip_metadata(g: &mut Value) {
    for mesh in g["meshes"].as_array_mut().unwrap() {
        for prim in mesh["primitives"].as_array_mut().unwrap() {
            prim.as_object_mut().unwrap().remove("extensions");
        }
    }
    g["extensions"]
        .as_object_mut()
        .unwrap()
        .remove("EXT_structural_metadata");
    for list in ["extensionsUsed", "extensionsRequired"] {
        if let Some(l) = g[list].as_array_mut() {
            l.retain(|x| {
                let x = x.as_str().unwrap();
                x != "EXT_mesh_features" && x != "EXT_structural_metadata"
            });
        }
    }
}

/// A third-party tileset (no `extras.citylod`, no citylod `asset.generator`) whose features have identities of their own is checked by its tree,
/// volumes and pictures, and says that coverage by identity was not checked; the same content in a tileset citylod
/// says it wrote is a finding at every tile (its features lost the identity every citylod tileset carries).
#[test]
fn third_party_features_are_not_held_to_citylods_identity() {
    let renamed = |name: &str| match name {
        "building_index" => "objectid".to_string(),
        "node_index" => "block_no".to_string(),
        "level" => "lod_level".to_string(),
        "members" => "member_list".to_string(),
        other => other.to_string(),
    };
    fn rename_keys(m: &mut serde_json::Map<String, Value>, f: &dyn Fn(&str) -> String) {
        *m = std::mem::take(m)
            .into_iter()
            .map(|(k, v)| (f(&k), v))
            .collect();
    }
    let third_party = |keep_extras: bool| {
        let name = if keep_extras {
            "renamed-ours"
        } else {
            "renamed-theirs"
        };
        let dir = damaged(name, |ts| {
            if !keep_extras {
                ts.as_object_mut().unwrap().remove("extras");
                ts["asset"].as_object_mut().unwrap().remove("generator");
            }
        });
        let glbs = edit_every_glb(&dir, |g| {
            let meta = &mut g["extensions"]["EXT_structural_metadata"];
            for class in meta["schema"]["classes"]
                .as_object_mut()
                .unwrap()
                .values_mut()
            {
                rename_keys(class["properties"].as_object_mut().unwrap(), &renamed);
            }
            for table in meta["propertyTables"].as_array_mut().unwrap() {
                rename_keys(table["properties"].as_object_mut().unwrap(), &renamed);
            }
        });
        assert!(glbs > 3, "{glbs} glbs");
        dir
    };
    let out = scratch_dir("renamed-theirs-out");
    let (code, report) = check(&third_party(false), &out, &["--views", "3"]);
    assert_eq!(code, 0, "{:?}", findings(&report));
    let stats = &report["tileset_stats"];
    assert_eq!(stats["identity_checked"], false, "{stats}");
    assert_eq!(stats["buildings"], 0, "{stats}");
    assert!(stats["features"].as_u64().unwrap() > 1000, "{stats}");
    for v in report["views"].as_array().unwrap() {
        assert_eq!(v["criterion"]["blocks_checked"], 0);
    }

    // citylod's tileset with every glb's metadata removed: no feature left to hold, and every triangle is one no
    // building stands for.
    let bare = damaged("bare", |_| {});
    assert!(edit_every_glb(&bare, strip_metadata) > 3);
    let out = scratch_dir("bare-out");
    let (code, report) = check(&bare, &out, &["--views", "2"]);
    assert_eq!(code, 1, "a citylod tileset without features must fail");
    assert_eq!(report["tileset_stats"]["features"], 0);
    let tiles = report["tileset_stats"]["tiles"].as_u64().unwrap() as usize;
    let orphans = findings(&report)
        .into_iter()
        .filter(|(kind, _)| kind == "unknown_feature")
        .count();
    assert_eq!(orphans, tiles, "{:?}", findings(&report));

    let out = scratch_dir("renamed-ours-out");
    let (code, report) = check(&third_party(true), &out, &["--views", "3"]);
    assert_eq!(code, 1);
    assert_eq!(report["tileset_stats"]["identity_checked"], true);
    let unknown = findings(&report)
        .into_iter()
        .filter(|(kind, _)| kind == "unknown_feature")
        .count();
    let tiles = report["tileset_stats"]["tiles"].as_u64().unwrap() as usize;
    assert_eq!(unknown, tiles, "{:?}", findings(&report));
}

/// `glb` as the b3dm a 3D Tiles 1.0 writer would make of it: its property table as the batch table (JSON arrays),
/// its feature ids as `_BATCHID`, its own metadata removed; the binary parts 8-byte aligned.
fn as_b3dm(glb: &[u8], path: &Path) -> Vec<u8> {
    use citylod_tiles::PropValue;
    let features = citylod_tiles::read::read_glb(glb, path).unwrap().features;
    let mut columns: std::collections::BTreeMap<String, Vec<Value>> = Default::default();
    for (k, f) in features.iter().enumerate() {
        for (name, v) in &f.values {
            let column = columns
                .entry(name.clone())
                .or_insert_with(|| vec![Value::Null; features.len()]);
            column[k] = match v {
                PropValue::Null => Value::Null,
                PropValue::Bool(b) => (*b).into(),
                PropValue::Int(i) => (*i).into(),
                PropValue::Float(x) => (*x).into(),
                PropValue::Str(t) => t.as_str().into(),
            };
        }
    }
    let glb = edit_glb_json(glb, |g| {
        for mesh in g["meshes"].as_array_mut().unwrap() {
            for prim in mesh["primitives"].as_array_mut().unwrap() {
                let attrs = prim["attributes"].as_object_mut().unwrap();
                let ids = attrs.remove("_FEATURE_ID_0").unwrap();
                attrs.insert("_BATCHID".into(), ids);
            }
        }
        strip_metadata(g);
    });
    let padded = |v: Value, at: usize| {
        let mut t = serde_json::to_vec(&v).unwrap();
        t.resize((at + t.len()).next_multiple_of(8) - at, b' ');
        t
    };
    let ft = padded(serde_json::json!({"BATCH_LENGTH": features.len()}), 28);
    let bt = padded(serde_json::to_value(&columns).unwrap(), 28 + ft.len());
    let total = 28 + ft.len() + bt.len() + glb.len();
    let mut out = b"b3dm".to_vec();
    for v in [1, total, ft.len(), 0, bt.len(), 0] {
        out.extend((v as u32).to_le_bytes());
    }
    out.extend(ft);
    out.extend(bt);
    out.extend(glb);
    out
}

/// NYC rewritten as 3D Tiles 1.0 (b3dm content, citylod's columns in the batch tables) is checked in full: the
/// batch tables' `building_index`, `level` and `node_index` identify buildings and blocks as the glb's property
/// tables did, whether or not `tileset.json` says citylod wrote it.
#[test]
fn a_tileset_rewritten_as_b3dm_is_checked_by_its_batch_tables() {
    for keep_extras in [true, false] {
        let name = if keep_extras {
            "b3dm-ours"
        } else {
            "b3dm-theirs"
        };
        let dir = damaged(name, |ts| {
            if !keep_extras {
                ts.as_object_mut().unwrap().remove("extras");
                ts["asset"].as_object_mut().unwrap().remove("generator");
            }
            fn rename(t: &mut Value) {
                if let Some(uri) = t["content"]["uri"].as_str() {
                    t["content"]["uri"] = uri.replace(".glb", ".b3dm").into();
                }
                for c in t
                    .get_mut("children")
                    .and_then(Value::as_array_mut)
                    .into_iter()
                    .flatten()
                {
                    rename(c);
                }
            }
            rename(&mut ts["root"]);
        });
        for (rel, bytes) in tree_bytes(&dir) {
            if let Some(stem) = rel.strip_suffix(".glb") {
                let b3dm = as_b3dm(&bytes, &dir.join(&rel));
                std::fs::write(dir.join(format!("{stem}.b3dm")), b3dm).unwrap();
                std::fs::remove_file(dir.join(&rel)).unwrap();
            }
        }
        let out = scratch_dir(&format!("{name}-out"));
        let (code, report) = check(&dir, &out, &["--views", "3"]);
        assert_eq!(code, 0, "{name}: {:?}", findings(&report));
        let stats = &report["tileset_stats"];
        assert_eq!(stats["identity_checked"], true, "{name}: {stats}");
        assert_eq!(stats["buildings"], 1403, "{name}: {stats}");
        let blocks: u64 = report["views"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v["criterion"]["blocks_checked"].as_u64().unwrap())
            .sum();
        assert!(blocks > 0, "{name}: the Δh / Δa criterion checked no block");
    }
}

/// Input the reader cannot use is exit 2 with the file and what is wrong: a glb cut short of the length its
/// header gives, and a tree nested deeper than one tileset.json holds.
#[test]
fn truncated_glb_and_too_deep_tree_are_exit_2() {
    let dir = damaged("glb-len", |_| {});
    let ts = read_json(&dir.join("tileset.json"));
    let uri = ts["root"]["content"]["uri"].as_str().unwrap().to_string();
    let glb = dir.join(&uri);
    let mut bytes = std::fs::read(&glb).unwrap();
    let claimed = bytes.len() as u32 + 64;
    bytes[8..12].copy_from_slice(&claimed.to_le_bytes());
    std::fs::write(&glb, &bytes).unwrap();
    for cmd in ["inspect", "check"] {
        let out = scratch_dir("glb-len-out");
        let mut args = vec![cmd, dir.to_str().unwrap()];
        if cmd == "check" {
            args.extend(["--out", out.to_str().unwrap()]);
        }
        let o = citylod(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {err}");
        assert!(err.contains(glb.to_str().unwrap()), "{cmd}: {err}");
        assert!(
            err.contains(&format!(
                "truncated: the header gives a length of {claimed} bytes"
            )),
            "{err}"
        );
    }

    let deep = scratch_dir("deep-tree");
    let bx = serde_json::json!({"box": [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]});
    let mut t = serde_json::json!({"boundingVolume": bx, "geometricError": 0});
    for _ in 0..70 {
        t = serde_json::json!({"boundingVolume": bx, "geometricError": 0, "children": [t]});
    }
    let ts = serde_json::json!({"asset": {"version": "1.1"}, "geometricError": 1, "root": t});
    std::fs::write(deep.join("tileset.json"), ts.to_string()).unwrap();
    let o = citylod(&["inspect", deep.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(&format!("tile 0{}", "/0".repeat(62))), "{err}");
    assert!(err.contains("holds tiles down to level 61"), "{err}");
    assert!(
        err.contains(deep.join("tileset.json").to_str().unwrap()),
        "{err}"
    );
}

/// Option errors print plain values, and `--out` may not be the tileset's folder or inside it (nothing is
/// written there).
#[test]
fn bad_options_and_out_inside_the_tileset_are_exit_2() {
    let dir = damaged("out-inside", |_| {});
    let out = scratch_dir("bad-options-out");
    // `--flag=value`, or the value as the next argument (a negative one too).
    for (flag, value, joined) in [
        ("--dh-px", "0", true),
        ("--da-px", "-3", true),
        ("--sse", "0", true),
        ("--sse", "-2", false),
    ] {
        let arg = format!("{flag}={value}");
        let mut args = vec!["check", dir.to_str().unwrap()];
        if joined {
            args.push(&arg);
        } else {
            args.extend([flag, value]);
        }
        args.extend(["--out", out.to_str().unwrap()]);
        let o = citylod(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flag}: {err}");
        assert!(
            err.contains(&format!("{flag} must be a positive number")),
            "{err}"
        );
        assert!(
            err.contains(&format!("got {value}")) && !err.contains("Some("),
            "{err}"
        );
    }
    // A render larger than the device allows is refused by the flags' names, before any view is drawn.
    let o = citylod(&[
        "check",
        dir.to_str().unwrap(),
        "--width",
        "100000",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--width and --height must be at most") && err.contains("got 100000×600"),
        "{err}"
    );
    assert!(!out.join("view-0").exists());
    let before = tree_bytes(&dir);
    for inside in [dir.clone(), dir.join("check"), dir.join("tiles")] {
        let o = citylod(&[
            "check",
            dir.to_str().unwrap(),
            "--out",
            inside.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{}: {err}", inside.display());
        let said = if inside == dir {
            "is the tileset's folder;"
        } else {
            "inside the tileset's folder"
        };
        assert!(err.contains(said), "{err}");
    }
    assert_eq!(
        tree_bytes(&dir),
        before,
        "the tileset's folder was written to"
    );
}

/// The root's content edited in its glb node's transform (its quantization scale): blocks flattened to half their
/// height are drawn otherwise than their ground_z_m and height_m say, and blocks shrunk to a twentieth across leave
/// their buildings undrawn — whatever the metadata and the errors declare (views may pass or not: the tree's
/// measurements alone find both).
#[test]
fn coarse_content_drawn_otherwise_than_it_declares_is_found() {
    let root_glb = |dir: &Path| {
        let ts = read_json(&dir.join("tileset.json"));
        dir.join(ts["root"]["content"]["uri"].as_str().unwrap())
    };
    let rescale = |name: &str, axes: [f64; 3]| {
        let dir = damaged(name, |_| {});
        let glb = root_glb(&dir);
        let bytes = std::fs::read(&glb).unwrap();
        std::fs::write(
            &glb,
            edit_glb_json(&bytes, |g| {
                let scale = g["nodes"][0]["scale"].as_array_mut().unwrap();
                for (s, f) in scale.iter_mut().zip(axes) {
                    *s = Value::from(s.as_f64().unwrap() * f);
                }
            }),
        )
        .unwrap();
        run_damaged(name, &dir)
    };
    let root = |kind: &str| (kind.to_string(), "0".to_string());
    // glTF is y-up: y is the height.
    let flat = rescale("flattened", [1.0, 0.5, 1.0]);
    assert!(flat.contains(&root("block_misdrawn")), "{flat:?}");
    let specks = rescale("specks", [0.05, 1.0, 0.05]);
    assert!(specks.contains(&root("building_vanishes")), "{specks:?}");
    // Untouched, neither is found (nyc_every_view_passes_and_report_validates holds the whole report to no finding).
    let (code, report) = check(
        nyc(),
        &scratch_dir("check-measured-untouched"),
        &["--views", "1"],
    );
    assert_eq!(code, 0, "{:?}", findings(&report));
}

/// Delft read at LoD 2.2 draws each building as a prism and a simplified model above its full model, each tile's
/// error the distance between them: those tiles given an error of 0 (still monotone) claim the prisms are exact,
/// which the distance from each prism to its full model, measured, denies.
#[test]
fn building_tiles_claiming_less_error_than_their_models_differ_by_are_found() {
    let Some(input) = shared_data("delft-3dbag/delft.city.jsonl") else {
        return;
    };
    let tiles = process_dir("check-delft-lod22");
    build(&[&input], &tiles, &["--lod", "2.2"]);
    let (code, report) = check(
        &tiles,
        &scratch_dir("check-delft-lod22-out"),
        &["--views", "1"],
    );
    assert_eq!(code, 0, "{:?}", findings(&report));
    // The tiles of buildings drawn as themselves above their leaves: those whose glb has a `building` property table
    // and that have children.
    let dir = scratch_dir("damaged-delft-exact-prisms");
    for (rel, bytes) in tree_bytes(&tiles) {
        let p = dir.join(&rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }
    let mut ts = read_json(&dir.join("tileset.json"));
    let mut zeroed = 0;
    for (_, ptr) in tile_pointers(&ts) {
        let t = ts.pointer_mut(&ptr).unwrap();
        let Some(uri) = t["content"]["uri"].as_str() else {
            continue;
        };
        if children_len(t) == 0 {
            continue;
        }
        let glb = std::fs::read(dir.join(uri)).unwrap();
        let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
        let g: Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
        let classes = &g["extensions"]["EXT_structural_metadata"]["propertyTables"];
        if classes
            .as_array()
            .unwrap()
            .iter()
            .all(|t| t["class"] == "building")
        {
            t["geometricError"] = Value::from(0.0);
            zeroed += 1;
        }
    }
    assert!(zeroed > 0, "no tile of buildings above the leaves");
    std::fs::write(dir.join("tileset.json"), serde_json::to_vec(&ts).unwrap()).unwrap();
    let f = run_damaged("delft-exact-prisms", &dir);
    assert!(f.iter().any(|(k, _)| k == "error_understated"), "{f:?}");
}
