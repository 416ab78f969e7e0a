//! Minimal readers of the real test data (without the ingest crate): GeoJSON lon/lat projected into a
//! local ENU frame, and the LoD0 footprints of a CityJSONSeq file with its transform. Heights are only
//! rough (storeys × 3.5 m, a `height` tag, or 3DBAG roof − ground, else 10 m): enough for Δh tests.
#![allow(dead_code)]

use citylod_model::{Building, BuildingId, Footprint, HeightSource, LocalFrame};
use geo_types::{Coord, LineString, MultiPolygon, Polygon};
use serde_json::Value;

/// Closes the ring, drops repeated points, orients it (exterior CCW, holes CW); `None` if < 3 points.
fn ring(pts: impl Iterator<Item = (f64, f64)>, exterior: bool) -> Option<LineString<f64>> {
    let mut v: Vec<Coord<f64>> = Vec::new();
    for (x, y) in pts {
        let c = Coord { x, y };
        if v.last() != Some(&c) {
            v.push(c);
        }
    }
    while v.len() > 1 && v.first() == v.last() {
        v.pop();
    }
    if v.len() < 3 {
        return None;
    }
    let area2: f64 = (0..v.len())
        .map(|i| {
            let (p, q) = (v[i], v[(i + 1) % v.len()]);
            p.x * q.y - q.x * p.y
        })
        .sum();
    if area2 == 0.0 {
        return None;
    }
    if (area2 > 0.0) != exterior {
        v.reverse();
    }
    v.push(v[0]);
    Some(LineString(v))
}

fn building(i: usize, source_id: String, footprint: Footprint, height_m: f64) -> Building {
    Building {
        id: BuildingId(i as u32),
        source_id,
        footprint,
        base_z_m: 0.0,
        height_m,
        height_source: HeightSource::Default,
        attributes: Default::default(),
        mesh: None,
    }
}

/// Reads a GeoJSON FeatureCollection of (Multi)Polygons in lon/lat into buildings in a local frame
/// centred on the mean vertex. Features without a usable polygon are skipped (counted in the result).
pub fn load_geojson(rel: &str) -> Option<(Vec<Building>, usize)> {
    citylod_testdata::read_shared_data(rel, |p| read_geojson(p, false))
}

/// [`load_geojson`] as a File Geodatabase written by GDAL gives the same file back: every ring
/// starting at its second vertex, and every longitude and latitude moved by up to 3e-14° (its
/// coordinate grid; ~3 nm).
pub fn load_geojson_as_from_a_geodatabase(rel: &str) -> Option<(Vec<Building>, usize)> {
    citylod_testdata::read_shared_data(rel, |p| read_geojson(p, true))
}

fn read_geojson(path: &std::path::Path, rotate: bool) -> Option<(Vec<Building>, usize)> {
    // The same value always moves alike, so vertices shared by touching buildings stay shared.
    let nudge = |v: f64| {
        if !rotate {
            return v;
        }
        let h = (v.to_bits() ^ 0x2545_f491_4f6c_dd1d)
            .wrapping_mul(6_364_136_223_846_793_005)
            .rotate_left(29)
            .wrapping_mul(1_442_695_040_888_963_407);
        v + ((h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * 3e-14
    };
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()?;
    let feats = doc["features"].as_array()?;
    let polys_of = |g: &Value| -> Vec<Value> {
        match g["type"].as_str() {
            Some("Polygon") => vec![g["coordinates"].clone()],
            Some("MultiPolygon") => g["coordinates"].as_array().cloned().unwrap_or_default(),
            _ => vec![],
        }
    };
    let (mut slon, mut slat, mut cnt) = (0.0, 0.0, 0.0);
    for f in feats {
        for p in polys_of(&f["geometry"]) {
            for c in p[0].as_array().into_iter().flatten() {
                slon += c[0].as_f64().unwrap_or(0.0);
                slat += c[1].as_f64().unwrap_or(0.0);
                cnt += 1.0;
            }
        }
    }
    let frame = LocalFrame::new(slon / cnt, slat / cnt, 0.0);
    let mut out = Vec::new();
    let mut skipped = 0;
    for (fi, f) in feats.iter().enumerate() {
        let mut polys = Vec::new();
        for p in polys_of(&f["geometry"]) {
            let rings: Vec<Option<LineString<f64>>> = p
                .as_array()
                .into_iter()
                .flatten()
                .enumerate()
                .map(|(k, r)| {
                    let pts = r.as_array().into_iter().flatten().map(|c| {
                        let e = frame.geodetic_to_enu(
                            nudge(c[0].as_f64().unwrap_or(0.0)),
                            nudge(c[1].as_f64().unwrap_or(0.0)),
                            0.0,
                        );
                        (e[0], e[1])
                    });
                    let mut pts: Vec<(f64, f64)> = pts.collect();
                    if rotate && pts.len() > 2 && pts.first() == pts.last() {
                        pts.pop();
                        pts.rotate_left(1);
                        pts.push(pts[0]);
                    }
                    ring(pts.into_iter(), k == 0)
                })
                .collect();
            if let Some(Some(ext)) = rings.first().cloned() {
                polys.push(Polygon::new(
                    ext,
                    rings.into_iter().skip(1).flatten().collect(),
                ));
            }
        }
        if polys.is_empty() {
            skipped += 1;
            continue;
        }
        let props = &f["properties"];
        let num = |v: &Value| {
            v.as_f64()
                .or_else(|| v.as_str().and_then(|s| s.trim().parse().ok()))
        };
        let height_m = num(&props["height"])
            .or_else(|| num(&props["stories"]).map(|s| s * 3.5))
            .filter(|h| *h > 0.0)
            .unwrap_or(10.0);
        out.push(building(
            out.len(),
            format!("feature-{fi}"),
            MultiPolygon(polys),
            height_m,
        ));
    }
    Some((out, skipped))
}

/// Reads the LoD0 footprints of the Buildings of a CityJSONSeq file (metric CRS), centred on the
/// mean vertex; height = `b3_h_dak_70p − b3_h_maaiveld` (10 m when missing).
pub fn load_cityjsonseq(rel: &str) -> Option<Vec<Building>> {
    citylod_testdata::read_shared_data(rel, read_cityjsonseq)
}

fn read_cityjsonseq(path: &std::path::Path) -> Option<Vec<Building>> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut lines = text.lines();
    let header: Value = serde_json::from_str(lines.next()?).ok()?;
    let scale: Vec<f64> = header["transform"]["scale"]
        .as_array()?
        .iter()
        .filter_map(|v| v.as_f64())
        .collect();
    let translate: Vec<f64> = header["transform"]["translate"]
        .as_array()?
        .iter()
        .filter_map(|v| v.as_f64())
        .collect();
    type Surfaces = Vec<Vec<Vec<(f64, f64)>>>;
    let mut raw: Vec<(String, Surfaces, f64)> = Vec::new();
    for line in lines {
        let f: Value = serde_json::from_str(line).ok()?;
        let verts: Vec<(f64, f64)> = f["vertices"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|v| {
                (
                    v[0].as_f64().unwrap_or(0.0) * scale[0] + translate[0],
                    v[1].as_f64().unwrap_or(0.0) * scale[1] + translate[1],
                )
            })
            .collect();
        let Some(objs) = f["CityObjects"].as_object() else {
            continue;
        };
        for (id, o) in objs {
            if o["type"] != "Building" {
                continue;
            }
            let Some(g) = o["geometry"]
                .as_array()
                .and_then(|gs| gs.iter().find(|g| g["lod"] == "0"))
            else {
                continue;
            };
            let surfaces: Vec<Vec<Vec<(f64, f64)>>> = g["boundaries"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|surface| {
                    surface
                        .as_array()
                        .into_iter()
                        .flatten()
                        .map(|r| {
                            r.as_array()
                                .into_iter()
                                .flatten()
                                .filter_map(|i| verts.get(i.as_u64()? as usize).copied())
                                .collect()
                        })
                        .collect()
                })
                .collect();
            let a = &o["attributes"];
            let h = match (a["b3_h_dak_70p"].as_f64(), a["b3_h_maaiveld"].as_f64()) {
                (Some(r), Some(g)) if r > g => r - g,
                _ => 10.0,
            };
            raw.push((id.clone(), surfaces, h));
        }
    }
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
    for (_, s, _) in &raw {
        for r in s.iter().flatten() {
            for &(x, y) in r {
                sx += x;
                sy += y;
                n += 1.0;
            }
        }
    }
    let (cx, cy) = (sx / n, sy / n);
    let mut out = Vec::new();
    for (id, surfaces, h) in raw {
        let polys: Vec<Polygon<f64>> = surfaces
            .iter()
            .filter_map(|s| {
                let mut rings = s
                    .iter()
                    .enumerate()
                    .map(|(k, r)| ring(r.iter().map(|&(x, y)| (x - cx, y - cy)), k == 0));
                let ext = rings.next()??;
                Some(Polygon::new(ext, rings.flatten().collect()))
            })
            .collect();
        if !polys.is_empty() {
            out.push(building(out.len(), id, MultiPolygon(polys), h));
        }
    }
    Some(out)
}

/// The `k` buildings whose first vertex is nearest to the data's centre (a compact real piece),
/// renumbered 0..k in their input order.
pub fn central_piece(buildings: &[Building], k: usize) -> Vec<Building> {
    let first = |b: &Building| b.footprint.0[0].exterior().0[0];
    let mut order: Vec<usize> = (0..buildings.len()).collect();
    order.sort_by(|&i, &j| {
        let (p, q) = (first(&buildings[i]), first(&buildings[j]));
        (p.x * p.x + p.y * p.y)
            .total_cmp(&(q.x * q.x + q.y * q.y))
            .then(i.cmp(&j))
    });
    order.truncate(k);
    order.sort_unstable();
    order
        .iter()
        .enumerate()
        .map(|(new, &old)| {
            let mut b = buildings[old].clone();
            b.id = BuildingId(new as u32);
            b
        })
        .collect()
}
