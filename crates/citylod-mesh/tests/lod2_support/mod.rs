//! Dev-only reader of the real LoD2 test data (3DBAG Delft CityJSONSeq, Den Haag CityJSON 0.8) into one
//! triangle mesh per building, in metres relative to a fixed per-dataset origin (z up). Surfaces are
//! triangulated on their plane; identical integer vertices are merged so touching parts that share
//! corners connect. Not the ingest stage's reader: it skips everything but solids and multi-surfaces.
#![allow(dead_code)]

use std::collections::BTreeMap;

use citylod_mesh::simplify::triangulate_polygon_3d;
use citylod_model::Mesh3d;
use serde_json::Value;

pub struct TestBuilding {
    pub id: String,
    pub mesh: Mesh3d,
}

/// Accumulates one building's surfaces, merging identical integer vertices.
struct MeshBuilder {
    index: BTreeMap<[i64; 3], u32>,
    mesh: Mesh3d,
}

impl MeshBuilder {
    fn new() -> Self {
        MeshBuilder {
            index: BTreeMap::new(),
            mesh: Mesh3d {
                positions: Vec::new(),
                triangles: Vec::new(),
            },
        }
    }

    /// `rings`: integer vertices per ring; `to_m` turns one into metres relative to the origin.
    fn add_surface(&mut self, rings: &[Vec<[i64; 3]>], to_m: &dyn Fn([i64; 3]) -> [f64; 3]) {
        let rings: Vec<Vec<[i64; 3]>> = rings
            .iter()
            .map(|r| {
                let mut r = r.clone();
                r.dedup();
                if r.len() > 1 && r.first() == r.last() {
                    r.pop();
                }
                r
            })
            .filter(|r| r.len() >= 3)
            .collect();
        if rings.is_empty() {
            return;
        }
        let metres: Vec<Vec<[f64; 3]>> = rings
            .iter()
            .map(|r| r.iter().map(|&v| to_m(v)).collect())
            .collect();
        let flat: Vec<[i64; 3]> = rings.iter().flatten().copied().collect();
        for t in triangulate_polygon_3d(&metres) {
            let ids = t.map(|i| {
                let key = flat[i as usize];
                let next = self.mesh.positions.len() as u32;
                *self.index.entry(key).or_insert_with(|| {
                    self.mesh.positions.push(to_m(key));
                    next
                })
            });
            if ids[0] != ids[1] && ids[1] != ids[2] && ids[0] != ids[2] {
                self.mesh.triangles.push(ids);
            }
        }
    }

    fn add_geometry(
        &mut self,
        g: &Value,
        verts: &dyn Fn(u64) -> Option<[i64; 3]>,
        to_m: &dyn Fn([i64; 3]) -> [f64; 3],
    ) {
        let surfaces: Vec<&Value> = match g["type"].as_str() {
            Some("Solid") => g["boundaries"]
                .as_array()
                .into_iter()
                .flatten()
                .flat_map(|sh| sh.as_array().into_iter().flatten())
                .collect(),
            Some("MultiSurface") | Some("CompositeSurface") => {
                g["boundaries"].as_array().into_iter().flatten().collect()
            }
            Some("MultiSolid") | Some("CompositeSolid") => g["boundaries"]
                .as_array()
                .into_iter()
                .flatten()
                .flat_map(|so| so.as_array().into_iter().flatten())
                .flat_map(|sh| sh.as_array().into_iter().flatten())
                .collect(),
            _ => Vec::new(),
        };
        for s in surfaces {
            let rings: Vec<Vec<[i64; 3]>> = s
                .as_array()
                .into_iter()
                .flatten()
                .map(|r| {
                    r.as_array()
                        .into_iter()
                        .flatten()
                        .filter_map(|i| i.as_u64().and_then(verts))
                        .collect()
                })
                .collect();
            self.add_surface(&rings, to_m);
        }
    }
}

fn transform(doc: &Value) -> ([f64; 3], [f64; 3]) {
    let s = &doc["transform"]["scale"];
    let t = &doc["transform"]["translate"];
    let get = |v: &Value, k: usize, d: f64| v.get(k).and_then(Value::as_f64).unwrap_or(d);
    (
        [get(s, 0, 1.0), get(s, 1, 1.0), get(s, 2, 1.0)],
        [get(t, 0, 0.0), get(t, 1, 0.0), get(t, 2, 0.0)],
    )
}

fn int_vertex(v: &Value) -> Option<[i64; 3]> {
    let a = v.as_array()?;
    let f = |k: usize| -> Option<i64> {
        a.get(k).and_then(|x| {
            x.as_i64()
                .or_else(|| x.as_f64().map(|f| (f * 1000.0).round() as i64))
        })
    };
    Some([f(0)?, f(1)?, f(2)?])
}

/// Delft 3DBAG buildings at LoD `lod` ("1.2", "1.3" or "2.2"), origin at the tile's translate.
pub fn load_delft(lod: &str) -> Option<Vec<TestBuilding>> {
    citylod_testdata::read_shared_data("delft-3dbag/delft.city.jsonl", |p| read_delft(p, lod))
}

fn read_delft(path: &std::path::Path, lod: &str) -> Option<Vec<TestBuilding>> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut lines = text.lines();
    let header: Value = serde_json::from_str(lines.next()?).ok()?;
    let (scale, _) = transform(&header);
    let to_m = |v: [i64; 3]| {
        [
            v[0] as f64 * scale[0],
            v[1] as f64 * scale[1],
            v[2] as f64 * scale[2],
        ]
    };
    let mut out = Vec::new();
    for line in lines {
        let f: Value = serde_json::from_str(line).ok()?;
        let verts: Vec<Option<[i64; 3]>> = f["vertices"]
            .as_array()
            .into_iter()
            .flatten()
            .map(int_vertex)
            .collect();
        let vget = |i: u64| verts.get(i as usize).copied().flatten();
        let mut b = MeshBuilder::new();
        let Some(objs) = f["CityObjects"].as_object() else {
            continue;
        };
        for (_, o) in objs {
            for g in o["geometry"].as_array().into_iter().flatten() {
                if g["lod"].as_str() == Some(lod) {
                    b.add_geometry(g, &vget, &to_m);
                }
            }
        }
        if !b.mesh.triangles.is_empty() {
            out.push(TestBuilding {
                id: f["id"].as_str().unwrap_or("?").to_string(),
                mesh: b.mesh,
            });
        }
    }
    Some(out)
}

/// Den Haag LoD2 buildings (each Building with its BuildingParts), origin at the file's translate.
pub fn load_denhaag() -> Option<Vec<TestBuilding>> {
    citylod_testdata::read_shared_data("denhaag-lod2/DenHaag_01.json", read_denhaag)
}

fn read_denhaag(path: &std::path::Path) -> Option<Vec<TestBuilding>> {
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()?;
    let (scale, _) = transform(&doc);
    let verts: Vec<Option<[i64; 3]>> = doc["vertices"]
        .as_array()
        .into_iter()
        .flatten()
        .map(int_vertex)
        .collect();
    let vget = |i: u64| verts.get(i as usize).copied().flatten();
    let to_m = |v: [i64; 3]| {
        [
            v[0] as f64 * scale[0],
            v[1] as f64 * scale[1],
            v[2] as f64 * scale[2],
        ]
    };
    let objs = doc["CityObjects"].as_object()?;
    let mut out = Vec::new();
    for (id, o) in objs {
        if o["type"].as_str() != Some("Building") {
            continue;
        }
        let mut b = MeshBuilder::new();
        let children: Vec<&Value> = o["children"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|c| c.as_str().and_then(|c| objs.get(c)))
            .collect();
        for part in std::iter::once(o).chain(children) {
            for g in part["geometry"].as_array().into_iter().flatten() {
                b.add_geometry(g, &vget, &to_m);
            }
        }
        if !b.mesh.triangles.is_empty() {
            out.push(TestBuilding {
                id: id.clone(),
                mesh: b.mesh,
            });
        }
    }
    Some(out)
}

/// The `n` buildings with the most triangles (ties by id), deterministic.
pub fn largest(mut buildings: Vec<TestBuilding>, n: usize) -> Vec<TestBuilding> {
    buildings.sort_by(|a, b| {
        b.mesh
            .triangles
            .len()
            .cmp(&a.mesh.triangles.len())
            .then(a.id.cmp(&b.id))
    });
    buildings.truncate(n);
    buildings
}
