//! A seeded generator of city-like building footprints for scaling benchmarks: a street grid of blocks, each block
//! lined with touching row houses along its edges (gaps and L-shapes now and then), courtyards left open, towers
//! here and there, and a small rotation per district. Local ENU metres; same seed and size → same city.

use citylod_model::{Attributes, Building, BuildingId, HeightSource};
use citylod_testdata::SplitMix64 as Rng;
use geo_types::{Coord, LineString, MultiPolygon, Polygon};

/// About `n` buildings (exactly `n`: generation stops there), seeded.
pub fn city(n: usize, seed: u64) -> Vec<Building> {
    let mut rng = Rng(seed);
    let mut out: Vec<Building> = Vec::with_capacity(n);
    // A block holds ~26 buildings; the grid is sized for 20 so it always has room, and filled row by row
    // (districts of 8×8 blocks) until n buildings are placed.
    let blocks_per_side = ((n as f64 / 20.0).sqrt().ceil() as usize).max(1);
    let (block_w, block_h, street) = (110.0, 90.0, 18.0);
    'grid: for by in 0..blocks_per_side {
        for bx in 0..blocks_per_side {
            let district = (bx / 8, by / 8);
            let mut drng = Rng(seed
                ^ ((district.0 as u64) << 32 | district.1 as u64)
                    .wrapping_mul(0x2545_F491_4F6C_DD1D));
            let angle = drng.range(-0.12, 0.12);
            let x0 = bx as f64 * (block_w + street);
            let y0 = by as f64 * (block_h + street);
            for fp in block(&mut rng, block_w, block_h) {
                if out.len() == n {
                    break 'grid;
                }
                let (s, c) = angle.sin_cos();
                let ring: Vec<Coord<f64>> = fp
                    .iter()
                    .map(|&(x, y)| {
                        let (x, y) = (x + x0, y + y0);
                        Coord {
                            x: c * x - s * y,
                            y: s * x + c * y,
                        }
                    })
                    .collect();
                let tower = rng.chance(0.01);
                let height_m = if tower {
                    rng.range(60.0, 180.0)
                } else {
                    (rng.range(2.0, 8.0)).floor() * 3.2 + 1.0
                };
                out.push(Building {
                    id: BuildingId(out.len() as u32),
                    source_id: format!("synth-{}", out.len()),
                    footprint: MultiPolygon(vec![Polygon::new(LineString(ring), vec![])]),
                    base_z_m: 0.0,
                    height_m,
                    height_source: HeightSource::NamedAttribute,
                    attributes: Attributes::new(),
                    mesh: None,
                });
            }
        }
    }
    out
}

/// Where the generated city is put when written as GeoJSON: UTM zone 18N (EPSG:32618), metres, around lower
/// Manhattan, so `citylod build --crs EPSG:32618` reads it like any projected city.
pub const UTM_CRS: &str = "EPSG:32618";
const UTM_ORIGIN: (f64, f64) = (580_000.0, 4_500_000.0);

/// Writes `buildings` (from [`city`]) as a GeoJSON FeatureCollection in [`UTM_CRS`]: one Polygon per building,
/// properties `id` and `height` (m), coordinates at 1 cm. Streams to `out`; the caller buffers.
pub fn write_geojson(buildings: &[Building], out: &mut impl std::io::Write) -> std::io::Result<()> {
    out.write_all(b"{\"type\":\"FeatureCollection\",\"features\":[\n")?;
    for (i, b) in buildings.iter().enumerate() {
        if i > 0 {
            out.write_all(b",\n")?;
        }
        write!(
            out,
            "{{\"type\":\"Feature\",\"properties\":{{\"id\":\"{}\",\"height\":{:.2}}},\"geometry\":{{\"type\":\"Polygon\",\"coordinates\":[",
            b.source_id, b.height_m
        )?;
        let poly = &b.footprint.0[0];
        for (r, ring) in std::iter::once(poly.exterior())
            .chain(poly.interiors())
            .enumerate()
        {
            out.write_all(if r > 0 { b",[" } else { b"[" })?;
            for (k, c) in ring.0.iter().enumerate() {
                if k > 0 {
                    out.write_all(b",")?;
                }
                write!(out, "[{:.2},{:.2}]", c.x + UTM_ORIGIN.0, c.y + UTM_ORIGIN.1)?;
            }
            out.write_all(b"]")?;
        }
        out.write_all(b"]}}")?;
    }
    out.write_all(b"\n]}\n")
}

/// Row houses along the four edges of a `w × h` block with its origin at (0, 0); closed CCW rings.
fn block(rng: &mut Rng, w: f64, h: f64) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let depth = rng.range(10.0, 18.0);
    // Each edge: start, direction (unit), inward normal, length (corners belong to the south and north edges).
    let edges = [
        ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), w),
        ((w, depth), (0.0, 1.0), (-1.0, 0.0), h - 2.0 * depth),
        ((w, h), (-1.0, 0.0), (0.0, -1.0), w),
        ((0.0, h - depth), (0.0, -1.0), (1.0, 0.0), h - 2.0 * depth),
    ];
    for &((sx, sy), (dx, dy), (nx, ny), len) in &edges {
        let mut t = 0.0;
        while t < len - 4.0 {
            let front = rng.range(6.0, 20.0).min(len - t);
            let d = if rng.chance(0.15) {
                depth * rng.range(0.5, 0.9)
            } else {
                depth
            };
            let p = |a: f64, b: f64| (sx + dx * a + nx * b, sy + dy * a + ny * b);
            let mut ring = if rng.chance(0.1) && front > 10.0 {
                // An L-shape: a rear wing on half of the frontage.
                let half = front / 2.0;
                vec![
                    p(t, 0.0),
                    p(t + front, 0.0),
                    p(t + front, d * 0.6),
                    p(t + half, d * 0.6),
                    p(t + half, d),
                    p(t, d),
                ]
            } else {
                vec![p(t, 0.0), p(t + front, 0.0), p(t + front, d), p(t, d)]
            };
            // The edge frames are chosen so these rings come out counter-clockwise; keep that true.
            if signed_area(&ring) < 0.0 {
                ring.reverse();
            }
            ring.push(ring[0]);
            out.push(ring);
            // Mostly touching neighbours; sometimes a gap (a passage or an alley).
            t += front
                + if rng.chance(0.2) {
                    rng.range(1.0, 6.0)
                } else {
                    0.0
                };
        }
    }
    out
}

fn signed_area(r: &[(f64, f64)]) -> f64 {
    let n = r.len();
    (0..n)
        .map(|i| r[i].0 * r[(i + 1) % n].1 - r[(i + 1) % n].0 * r[i].1)
        .sum::<f64>()
        / 2.0
}

/// Writes `buildings` (from [`city`]) as a File Geodatabase folder `dir` (feature class `buildings`, in [`UTM_CRS`]
/// without a spatial reference, so read with `--crs`): outer rings clockwise as Esri's rule has them, coordinates on
/// GDAL's default grid of 1/10,000 m, a `height` (m) and a `name` per row.
pub fn write_gdb(buildings: &[Building], dir: &std::path::Path) -> std::io::Result<()> {
    use citylod_testdata::fgdb::{write_gdb, GdbOptions, Row};
    let rows: Vec<Row> = buildings
        .iter()
        .map(|b| {
            let poly = &b.footprint.0[0];
            let rings = std::iter::once(poly.exterior())
                .chain(poly.interiors())
                .enumerate()
                .map(|(k, r)| {
                    let mut ring: Vec<[f64; 2]> =
                        r.0.iter()
                            .map(|c| [c.x + UTM_ORIGIN.0, c.y + UTM_ORIGIN.1])
                            .collect();
                    // The generator's rings run counter-clockwise: outer rings reversed, holes kept.
                    if k == 0 {
                        ring.reverse();
                    }
                    ring
                })
                .collect();
            Row {
                rings,
                height: Some(b.height_m),
                name: Some(b.source_id.clone()),
            }
        })
        .collect();
    write_gdb(dir, "buildings", &rows, &GdbOptions::default())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_count_deterministic_and_ccw() {
        let a = city(5000, 7);
        let b = city(5000, 7);
        assert_eq!(a.len(), 5000);
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.footprint, y.footprint);
        }
        for bld in &a {
            let ring: Vec<(f64, f64)> = bld.footprint.0[0]
                .exterior()
                .0
                .iter()
                .map(|c| (c.x, c.y))
                .collect();
            assert!(
                signed_area(&ring[..ring.len() - 1]) > 10.0,
                "{} not CCW or tiny",
                bld.source_id
            );
            assert!(bld.height_m > 0.0);
        }
        assert_ne!(city(100, 1)[5].footprint, city(100, 2)[5].footprint);
    }
}
