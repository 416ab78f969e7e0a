//! Writes a generated grid city of box buildings and prints size and speed figures:
//! `cargo run --release -p citylod-tiles --example synthetic_city -- 100000 /tmp/city [none]`.

use citylod_model::{LocalFrame, Mesh3d};
use citylod_tiles::*;
use std::time::Instant;

fn box_mesh(x: f64, y: f64, w: f64, d: f64, h: f64) -> Mesh3d {
    let c = [[x, y], [x + w, y], [x + w, y + d], [x, y + d]];
    let mut m = Mesh3d::default();
    for i in 0..4 {
        let (a, b) = (c[i], c[(i + 1) % 4]);
        let v = m.positions.len() as u32;
        m.positions.extend_from_slice(&[
            [a[0], a[1], 0.0],
            [b[0], b[1], 0.0],
            [b[0], b[1], h],
            [a[0], a[1], h],
        ]);
        m.triangles
            .extend_from_slice(&[[v, v + 1, v + 2], [v, v + 2, v + 3]]);
    }
    let v = m.positions.len() as u32;
    m.positions.extend(c.map(|p| [p[0], p[1], h]));
    m.triangles
        .extend_from_slice(&[[v, v + 1, v + 2], [v, v + 2, v + 3]]);
    m
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(100_000);
    let dir = args
        .get(2)
        .cloned()
        .unwrap_or_else(|| "/tmp/citylod-synthetic".into());
    let compression = if args.get(3).map(String::as_str) == Some("none") {
        Compression::None
    } else {
        Compression::Meshopt
    };
    let schema = MetadataSchema {
        id: "citylod".into(),
        classes: vec![ClassDef {
            id: "building".into(),
            properties: vec![
                PropertyDef {
                    name: "source_id".into(),
                    kind: PropertyKind::String,
                    description: None,
                    nullable: false,
                    string_no_data: None,
                    input_name: None,
                },
                PropertyDef {
                    name: "height_m".into(),
                    kind: PropertyKind::Float64,
                    description: None,
                    nullable: false,
                    string_no_data: None,
                    input_name: None,
                },
            ],
        }],
    };
    let side = (n as f64).sqrt().ceil() as usize;
    let t0 = Instant::now();
    let features: Vec<ContentFeature> = (0..n)
        .map(|i| {
            let (x, y) = ((i % side) as f64 * 20.0, (i / side) as f64 * 20.0);
            let h = 5.0 + (i * 7919 % 40) as f64;
            ContentFeature {
                mesh: box_mesh(x, y, 8.0 + (i % 5) as f64, 10.0, h),
                class: 0,
                values: vec![PropValue::Str(format!("b{i}")), PropValue::Float(h)],
                max_rounding_m: 0.0,
            }
        })
        .collect();
    let root = tile_spatially(features, 2000, 40_000);
    let t1 = Instant::now();
    let out = Staging::create(std::path::Path::new(&dir)).expect("staging");
    let stats = write_tileset(
        &out,
        &root,
        &LocalFrame::new(-71.06, 42.35, 0.0),
        &schema,
        &WriteOptions {
            compression,
            ..Default::default()
        },
    )
    .expect("write");
    out.commit().expect("commit");
    let t2 = Instant::now();
    println!(
        "{n} buildings: tiling {:.2} s, writing {:.2} s; {} tiles ({} with content), {} triangles, glb {:.1} MB ({:.2} B/triangle), tileset.json {} kB",
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        stats.tiles,
        stats.content_tiles,
        stats.triangles,
        stats.glb_bytes as f64 / 1e6,
        stats.glb_bytes as f64 / stats.triangles as f64,
        stats.tileset_json_bytes / 1000
    );
}
