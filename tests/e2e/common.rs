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

/// Every glb's metadata follows EXT_structural_metadata and EXT_mesh_features as written, which glTF-Validator does
/// not check (it reports both as unsupported): identifiers, property types, property tables (count ≥ 1, only their
/// class's properties, value buffer views 8-byte aligned, uncompressed and long enough, string offsets from 0 rising
/// to the end of valid UTF-8 text), and every primitive's feature ids (an attribute the primitive has, a table whose
/// count is the feature count). Returns the property tables checked.
pub fn glb_metadata_follows_the_extensions(name: &str, out: &Path) -> usize {
    let identifier = |s: &str| {
        let mut b = s.bytes();
        b.next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == b'_')
            && b.all(|c| c.is_ascii_alphanumeric() || c == b'_')
    };
    let mut tables_checked = 0;
    for (rel, bytes) in tree_bytes(out) {
        if !rel.ends_with(".glb") {
            continue;
        }
        let at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
        let json_len = at(12);
        let gltf: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
        let bin_start = 20 + json_len + 8;
        let bin = &bytes[bin_start..bin_start + at(20 + json_len)];
        let views = gltf["bufferViews"].as_array().unwrap();
        let meta = &gltf["extensions"]["EXT_structural_metadata"];
        let classes = meta["schema"]["classes"].as_object().unwrap();
        for (cid, class) in classes {
            assert!(identifier(cid), "{name}: {rel}: class id {cid:?}");
            for (pid, p) in class["properties"].as_object().unwrap() {
                assert!(
                    identifier(pid),
                    "{name}: {rel}: {cid}.{pid} is no identifier"
                );
                let ty = p["type"].as_str().unwrap();
                match ty {
                    "SCALAR" => assert!(
                        [
                            "INT8", "UINT8", "INT16", "UINT16", "INT32", "UINT32", "INT64",
                            "UINT64", "FLOAT32", "FLOAT64"
                        ]
                        .contains(&p["componentType"].as_str().unwrap_or("")),
                        "{name}: {rel}: {cid}.{pid}: componentType {}",
                        p["componentType"]
                    ),
                    "STRING" | "BOOLEAN" => assert!(
                        p.get("componentType").is_none()
                            && p.get("noData").is_none_or(|_| ty == "STRING"),
                        "{name}: {rel}: {cid}.{pid}: {ty} with {p}"
                    ),
                    other => {
                        panic!("{name}: {rel}: {cid}.{pid}: type {other} is not one citylod writes")
                    }
                }
                if let Some(n) = p.get("name") {
                    assert!(
                        n.as_str().is_some_and(|n| !n.is_empty()),
                        "{name}: {rel}: {cid}.{pid}: name {n}"
                    );
                }
            }
        }
        let tables = meta["propertyTables"].as_array().unwrap();
        for t in tables {
            let cid = t["class"].as_str().unwrap();
            let count = t["count"].as_u64().unwrap() as usize;
            assert!(
                count >= 1,
                "{name}: {rel}: a property table of {cid} with count 0"
            );
            let props = classes[cid]["properties"].as_object().unwrap();
            for (pid, col) in t["properties"].as_object().unwrap() {
                let def = props
                    .get(pid)
                    .unwrap_or_else(|| panic!("{name}: {rel}: {cid} has no property {pid}"));
                let view = |key: &str| -> &[u8] {
                    let v = &views[col[key].as_u64().unwrap() as usize];
                    assert_eq!(
                        v["buffer"], 0,
                        "{name}: {rel}: {cid}.{pid}.{key} outside the BIN chunk"
                    );
                    assert!(
                        v.get("extensions").is_none() && v.get("byteStride").is_none(),
                        "{name}: {rel}: {cid}.{pid}.{key}: a compressed or strided view: {v}"
                    );
                    let off = v["byteOffset"].as_u64().unwrap_or(0) as usize;
                    assert_eq!(off % 8, 0, "{name}: {rel}: {cid}.{pid}.{key} at byte {off}");
                    &bin[off..off + v["byteLength"].as_u64().unwrap() as usize]
                };
                let values = view("values");
                match def["type"].as_str().unwrap() {
                    "BOOLEAN" => assert!(
                        values.len() >= count.div_ceil(8),
                        "{name}: {rel}: {cid}.{pid}"
                    ),
                    "SCALAR" => {
                        let size = match def["componentType"].as_str().unwrap() {
                            "INT8" | "UINT8" => 1,
                            "INT16" | "UINT16" => 2,
                            "INT32" | "UINT32" | "FLOAT32" => 4,
                            _ => 8,
                        };
                        assert!(
                            values.len() >= count * size,
                            "{name}: {rel}: {cid}.{pid}: {} B",
                            values.len()
                        );
                    }
                    _ => {
                        let kind = col["stringOffsetType"].as_str().unwrap_or("UINT32");
                        let raw = view("stringOffsets");
                        let offsets: Vec<usize> = match kind {
                            "UINT32" => raw
                                .chunks_exact(4)
                                .map(|c| u32::from_le_bytes(c.try_into().unwrap()) as usize)
                                .collect(),
                            "UINT16" => raw
                                .chunks_exact(2)
                                .map(|c| u16::from_le_bytes(c.try_into().unwrap()) as usize)
                                .collect(),
                            "UINT8" => raw.iter().map(|&c| c as usize).collect(),
                            other => panic!("{name}: {rel}: {cid}.{pid}: offsets of {other}"),
                        };
                        assert!(
                            offsets.len() > count,
                            "{name}: {rel}: {cid}.{pid}: {} offsets",
                            offsets.len()
                        );
                        let offsets = &offsets[..count + 1];
                        assert!(
                            offsets[0] == 0
                                && offsets.windows(2).all(|w| w[0] <= w[1])
                                && offsets[count] <= values.len(),
                            "{name}: {rel}: {cid}.{pid}: string offsets {:?}…",
                            &offsets[..offsets.len().min(5)]
                        );
                        assert!(
                            std::str::from_utf8(&values[..offsets[count]]).is_ok(),
                            "{name}: {rel}: {cid}.{pid}: text that is not UTF-8"
                        );
                    }
                }
            }
            tables_checked += 1;
        }
        for mesh in gltf["meshes"].as_array().unwrap() {
            for prim in mesh["primitives"].as_array().unwrap() {
                let ids = prim["extensions"]["EXT_mesh_features"]["featureIds"]
                    .as_array()
                    .unwrap_or_else(|| panic!("{name}: {rel}: a primitive without feature ids"));
                for f in ids {
                    let attr = format!("_FEATURE_ID_{}", f["attribute"].as_u64().unwrap());
                    assert!(
                        prim["attributes"].get(&attr).is_some(),
                        "{name}: {rel}: no {attr}"
                    );
                    let t = &tables[f["propertyTable"].as_u64().unwrap() as usize];
                    assert_eq!(
                        f["featureCount"], t["count"],
                        "{name}: {rel}: featureCount against the table"
                    );
                }
            }
        }
    }
    tables_checked
}
