//! Helpers shared by the end-to-end tests: running the CLI, locating data, validating output.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("repo root")
}

pub use citylod_testdata::shared_data;

/// Where a named tileset is kept for the browser tests: `target/e2e/<name>`.
pub fn e2e_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("../e2e")
        .join(name)
}

pub fn scratch_dir(name: &str) -> PathBuf {
    let d =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("e2e-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn citylod(args: &[&str]) -> Output {
    citylod_with_env(args, &[])
}

/// [`citylod`] with extra environment variables.
pub fn citylod_with_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_citylod"))
        .args(args)
        .envs(env.iter().copied())
        .output()
        .expect("run citylod")
}

/// Runs `citylod build` and panics with its stderr when it does not exit 0.
pub fn build(inputs: &[&Path], out: &Path, extra: &[&str]) -> Value {
    build_with_env(inputs, out, extra, &[])
}

/// [`build`] with extra environment variables (`RAYON_NUM_THREADS`: the output must not depend on it).
pub fn build_with_env(inputs: &[&Path], out: &Path, extra: &[&str], env: &[(&str, &str)]) -> Value {
    let mut args: Vec<String> = vec!["build".into()];
    args.extend(inputs.iter().map(|p| p.display().to_string()));
    args.extend(extra.iter().map(|s| s.to_string()));
    args.extend(["--out".into(), out.display().to_string(), "--quiet".into()]);
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = citylod_with_env(&a, env);
    assert!(
        o.status.success(),
        "citylod build failed ({:?}):\n{}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    read_json(&out.join("build-report.json"))
}

pub fn read_json(p: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display())))
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Validates `instance` against `schemas/<schema>` and returns every error as "path: message".
pub fn schema_errors(schema: &str, instance: &Value) -> Vec<String> {
    let schema = read_json(&repo_root().join("schemas").join(schema));
    let validator = jsonschema::validator_for(&schema).expect("schema compiles");
    validator
        .iter_errors(instance)
        .map(|e| format!("{}: {}", e.instance_path(), e))
        .collect()
}

/// Runs the Khronos glTF-Validator (npm `gltf-validator`, installed by `make setup`) on every glb of a tileset.
pub fn gltf_validator(dir: &Path) -> Value {
    let root = repo_root();
    assert!(
        root.join("node_modules/gltf-validator").exists(),
        "node_modules/gltf-validator is missing: run `make setup` (or `make test`, which runs it) first"
    );
    let o = Command::new("node")
        .arg(root.join("tools/validate-gltf.mjs"))
        .arg(dir)
        .output()
        .expect("run node");
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| {
        panic!(
            "validator output is not JSON ({e}); stderr:\n{}",
            String::from_utf8_lossy(&o.stderr)
        )
    })
}

/// Every file under `dir`, relative path → bytes, sorted.
pub fn tree_bytes(dir: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(base: &Path, d: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.push((
                    p.strip_prefix(base).unwrap().display().to_string(),
                    std::fs::read(&p).unwrap(),
                ));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// Panics unless the folders `a` and `b` hold the same files with the same bytes; `why` says what differed between
/// the two runs that wrote them.
pub fn assert_same_files(a: &Path, b: &Path, why: &str) {
    let (ta, tb) = (tree_bytes(a), tree_bytes(b));
    let names = |t: &[(String, Vec<u8>)]| t.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&ta), names(&tb), "{why}: different files");
    for ((name, ba), (_, bb)) in ta.iter().zip(&tb) {
        assert!(ba == bb, "{name} differs between two builds ({why})");
    }
}
