//! Pictures of the hierarchy: per level an RFC 7946 GeoJSON of the node footprints (WGS84 lon/lat, CCW
//! exteriors) with their statistics, a PNG of the footprints filled by node, and `levels.png` with all
//! levels in one grid. Input in local ENU metres. Invariant: the same hierarchy gives byte-identical files.

use citylod_model::{Building, Footprint, Hierarchy, LocalFrame};
use serde_json::{json, Value};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Long side of `level-<k>.png` (px).
const LEVEL_PX: u32 = 2048;
/// Long side of one level's picture in `levels.png` (px).
const TILE_PX: u32 = 1024;
/// Levels per row in `levels.png`.
const GRID_COLS: usize = 3;
const MARGIN_PX: f64 = 16.0;
const GAP_PX: u32 = 16;

/// What went wrong writing the dump; each variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum DumpError {
    #[error("cannot write {path}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot encode PNG {path}")]
    Png {
        path: PathBuf,
        #[source]
        source: png::EncodingError,
    },
}

/// A file name a dump writes, or removes as an earlier dump's: `level-<digits>.geojson` / `.png`, `levels.png`.
pub fn is_dump_file_name(name: &str) -> bool {
    name == "levels.png"
        || name
            .strip_prefix("level-")
            .and_then(|r| {
                r.strip_suffix(".geojson")
                    .or_else(|| r.strip_suffix(".png"))
            })
            .is_some_and(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()))
}

/// Removes the files a dump writes ([`is_dump_file_name`]) from `dir`.
fn remove_earlier_dump(dir: &Path) -> Result<(), DumpError> {
    let io = |source| DumpError::Io {
        path: dir.to_path_buf(),
        source,
    };
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let entry = entry.map_err(io)?;
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if is_dump_file_name(&name) && entry.file_type().map_err(io)?.is_file() {
            std::fs::remove_file(entry.path()).map_err(|source| DumpError::Io {
                path: entry.path(),
                source,
            })?;
        }
    }
    Ok(())
}

/// Writes into `dir` (created if missing), for every level k of `hierarchy`: `level-<k>.geojson` (one
/// Feature per node: MultiPolygon in WGS84 lon/lat through `frame`, coordinates rounded to 1e-8°, and
/// properties `level`, `node`, `members`, `landmarks`, `height_m`, `h_min_m`, `h_max_m`, `dh_m`, `da_m2`,
/// `area_m2`) and `level-<k>.png` (2048 px on the long side, white background, footprints filled with a
/// colour derived from the node index, outlines darker, holes left white); then `levels.png` with all
/// levels in a grid of 3 per row, each labelled with its level number. All pictures share the extent of
/// `buildings` (or of the nodes when `buildings` is empty). Returns the paths written, in order.
/// An empty hierarchy writes only `levels.png` (a blank 1 × 1 image). Files of an earlier dump in `dir`
/// (`level-<k>.geojson`, `level-<k>.png`, `levels.png`) are removed first, so no level of another build is left
/// beside these; other files are left alone.
pub fn dump_levels(
    dir: &Path,
    hierarchy: &Hierarchy,
    buildings: &[Building],
    frame: &LocalFrame,
) -> Result<Vec<PathBuf>, DumpError> {
    std::fs::create_dir_all(dir).map_err(|source| DumpError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    remove_earlier_dump(dir)?;
    let extent = Extent::of(buildings.iter().map(|b| &b.footprint)).or_else(|| {
        Extent::of(
            hierarchy
                .levels
                .iter()
                .flat_map(|l| l.nodes.iter().map(|n| &n.footprint)),
        )
    });
    let mut written = Vec::new();
    let mut tiles = Vec::new();
    for (k, level) in hierarchy.levels.iter().enumerate() {
        let path = dir.join(format!("level-{k}.geojson"));
        write_file(&path, |w| {
            serde_json::to_writer(&mut *w, &level_geojson(k, hierarchy, frame))
                .map_err(std::io::Error::from)?;
            w.write_all(b"\n")
        })?;
        written.push(path);
        let fps: Vec<&Footprint> = level.nodes.iter().map(|n| &n.footprint).collect();
        let path = dir.join(format!("level-{k}.png"));
        write_png(&path, &draw(&fps, extent, LEVEL_PX))?;
        written.push(path);
        let mut tile = draw(&fps, extent, TILE_PX);
        tile.label(k);
        tiles.push(tile);
    }
    let path = dir.join("levels.png");
    write_png(&path, &Image::grid(&tiles))?;
    written.push(path);
    Ok(written)
}

fn level_geojson(k: usize, hierarchy: &Hierarchy, frame: &LocalFrame) -> Value {
    let lonlat = |x: f64, y: f64| {
        let g = frame.enu_to_geodetic([x, y, 0.0]);
        [(g[0] * 1e8).round() / 1e8, (g[1] * 1e8).round() / 1e8]
    };
    let ring = |ls: &geo_types::LineString<f64>, exterior: bool| -> Vec<[f64; 2]> {
        let mut pts: Vec<[f64; 2]> = ls.0.iter().map(|c| lonlat(c.x, c.y)).collect();
        let ccw = crate::merge::signed_area2(&pts) > 0.0;
        if ccw != exterior {
            pts.reverse();
        }
        pts
    };
    let features: Vec<Value> = hierarchy.levels[k]
        .nodes
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let coords: Vec<Vec<Vec<[f64; 2]>>> = n
                .footprint
                .0
                .iter()
                .map(|p| {
                    std::iter::once(ring(p.exterior(), true))
                        .chain(p.interiors().iter().map(|h| ring(h, false)))
                        .collect()
                })
                .collect();
            json!({
                "type": "Feature",
                "properties": {
                    "level": k,
                    "node": i,
                    "members": n.members.len(),
                    "landmarks": n.landmarks.len(),
                    "height_m": n.height_m,
                    "h_min_m": n.h_min_m,
                    "h_max_m": n.h_max_m,
                    "dh_m": n.dh_m,
                    "da_m2": n.da_m2,
                    "area_m2": n.area_m2,
                },
                "geometry": { "type": "MultiPolygon", "coordinates": coords },
            })
        })
        .collect();
    json!({ "type": "FeatureCollection", "features": features })
}

fn write_file(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<(), DumpError> {
    let io = |source| DumpError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut w = BufWriter::new(std::fs::File::create(path).map_err(io)?);
    body(&mut w).map_err(io)?;
    w.flush().map_err(io)
}

fn write_png(path: &Path, img: &Image) -> Result<(), DumpError> {
    let io = |source| DumpError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::create(path).map_err(io)?;
    let png_err = |source| DumpError::Png {
        path: path.to_path_buf(),
        source,
    };
    let mut enc = png::Encoder::new(BufWriter::new(file), img.w, img.h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(png_err)?;
    writer.write_image_data(&img.rgb).map_err(png_err)?;
    writer.finish().map_err(png_err)
}

/// Bounding box (local ENU m) of some footprints.
#[derive(Debug, Clone, Copy)]
struct Extent {
    min: [f64; 2],
    max: [f64; 2],
}

impl Extent {
    fn of<'a>(fps: impl Iterator<Item = &'a Footprint>) -> Option<Extent> {
        let mut e: Option<Extent> = None;
        for c in fps.flat_map(|f| f.0.iter().flat_map(|p| p.exterior().0.iter())) {
            if !(c.x.is_finite() && c.y.is_finite()) {
                continue;
            }
            let x = e.get_or_insert(Extent {
                min: [c.x, c.y],
                max: [c.x, c.y],
            });
            x.min = [x.min[0].min(c.x), x.min[1].min(c.y)];
            x.max = [x.max[0].max(c.x), x.max[1].max(c.y)];
        }
        e
    }
}

/// An 8-bit RGB raster, row-major from the top.
struct Image {
    w: u32,
    h: u32,
    rgb: Vec<u8>,
}

/// Draws footprints (local ENU m) with `long_px` pixels on the long side of `extent`.
fn draw(fps: &[&Footprint], extent: Option<Extent>, long_px: u32) -> Image {
    let Some(e) = extent else {
        return Image::blank(long_px, long_px);
    };
    let span = (e.max[0] - e.min[0]).max(e.max[1] - e.min[1]).max(1e-9);
    let scale = (long_px as f64 - 2.0 * MARGIN_PX) / span;
    let w = ((e.max[0] - e.min[0]) * scale + 2.0 * MARGIN_PX)
        .ceil()
        .max(1.0) as u32;
    let h = ((e.max[1] - e.min[1]) * scale + 2.0 * MARGIN_PX)
        .ceil()
        .max(1.0) as u32;
    let mut img = Image::blank(w.min(long_px), h.min(long_px));
    let to_px = |x: f64, y: f64| {
        [
            MARGIN_PX + (x - e.min[0]) * scale,
            img.h as f64 - MARGIN_PX - (y - e.min[1]) * scale,
        ]
    };
    let rings_px: Vec<Vec<Vec<[f64; 2]>>> = fps
        .iter()
        .map(|fp| {
            fp.0.iter()
                .flat_map(|p| std::iter::once(p.exterior()).chain(p.interiors()))
                .map(|r| r.0.iter().map(|c| to_px(c.x, c.y)).collect())
                .collect()
        })
        .collect();
    // Later nodes are drawn over earlier ones: filled last to first, each pixel only once, so footprints stacked on
    // one another (thousands of copies of a building) cost their area once, not once each.
    let mut free = Unpainted::new(img.w, img.h);
    for (i, rings) in rings_px.iter().enumerate().rev() {
        img.fill_even_odd(rings, node_colour(i), &mut free);
    }
    for (i, rings) in rings_px.iter().enumerate() {
        let c = node_colour(i).map(|v| (v as f64 * 0.55) as u8);
        for r in rings {
            for s in r.windows(2) {
                img.line(s[0], s[1], c);
            }
        }
    }
    img
}

/// A deterministic colour per node index: hues a golden-ratio step apart so consecutive nodes differ.
fn node_colour(i: usize) -> [u8; 3] {
    let frac = |x: f64| x - x.floor();
    let h = frac(i as f64 * 0.618_033_988_749_895) * 6.0;
    let s = 0.45 + 0.3 * frac(i as f64 * 0.377);
    let v = 0.78 + 0.17 * frac(i as f64 * 0.754_877_666);
    let c = v * s;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [r, g, b].map(|t| ((t + m) * 255.0).round().clamp(0.0, 255.0) as u8)
}

/// 3 × 5 bitmaps of the digits 0–9, one row per 3 bits (top first).
const DIGITS: [[u8; 5]; 10] = [
    [7, 5, 5, 5, 7],
    [2, 6, 2, 2, 7],
    [7, 1, 7, 4, 7],
    [7, 1, 7, 1, 7],
    [5, 5, 7, 1, 1],
    [7, 4, 7, 1, 7],
    [7, 4, 7, 5, 7],
    [7, 1, 1, 1, 1],
    [7, 5, 7, 5, 7],
    [7, 5, 7, 1, 7],
];

/// The pixels of an image not painted yet: per row, a pointer from each column towards the first unpainted column at
/// or after it (a disjoint-set forest over the columns, the row's end as the last set), so a fill skips painted runs.
struct Unpainted {
    w: u32,
    next: Vec<u32>,
}

impl Unpainted {
    fn new(w: u32, h: u32) -> Unpainted {
        let stride = w as usize + 1;
        Unpainted {
            w,
            next: (0..stride * h as usize)
                .map(|i| (i % stride) as u32)
                .collect(),
        }
    }

    /// The first unpainted column at or after `x` in row `y` (`w` when none is).
    fn first_at_or_after(&mut self, y: u32, x: u32) -> u32 {
        let row = y as usize * (self.w as usize + 1);
        let mut x = x.min(self.w);
        while self.next[row + x as usize] != x {
            let up = self.next[row + x as usize];
            // Path splitting: each column passed points past its next step.
            self.next[row + x as usize] = self.next[row + up as usize];
            x = up;
        }
        x
    }

    /// Marks column `x` of row `y` (unpainted, below `w`) as painted.
    fn take(&mut self, y: u32, x: u32) {
        self.next[y as usize * (self.w as usize + 1) + x as usize] = x + 1;
    }
}

impl Image {
    fn blank(w: u32, h: u32) -> Image {
        Image {
            w,
            h,
            rgb: vec![255; w as usize * h as usize * 3],
        }
    }

    fn set(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as u32) < self.w && (y as u32) < self.h {
            let i = (y as usize * self.w as usize + x as usize) * 3;
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    /// Scanline fill of closed rings with the even-odd rule (holes stay unfilled), sampling pixel centres; only pixels
    /// `free` still holds are painted, and they are taken from it.
    fn fill_even_odd(&mut self, rings: &[Vec<[f64; 2]>], c: [u8; 3], free: &mut Unpainted) {
        let mut edges: Vec<([f64; 2], [f64; 2])> = Vec::new();
        for r in rings {
            for s in r.windows(2) {
                if s[0][1] != s[1][1] {
                    let (a, b) = if s[0][1] < s[1][1] {
                        (s[0], s[1])
                    } else {
                        (s[1], s[0])
                    };
                    edges.push((a, b));
                }
            }
        }
        if edges.is_empty() {
            return;
        }
        edges.sort_by(|p, q| p.0[1].total_cmp(&q.0[1]));
        let y_lo = edges[0].0[1].floor().max(0.0) as i64;
        let y_hi = edges
            .iter()
            .map(|e| e.1[1])
            .fold(f64::NEG_INFINITY, f64::max)
            .ceil()
            .min(self.h as f64) as i64;
        let mut next = 0;
        let mut active: Vec<([f64; 2], [f64; 2])> = Vec::new();
        let mut xs: Vec<f64> = Vec::new();
        for y in y_lo..y_hi {
            let ys = y as f64 + 0.5;
            while next < edges.len() && edges[next].0[1] <= ys {
                active.push(edges[next]);
                next += 1;
            }
            active.retain(|e| e.1[1] > ys);
            xs.clear();
            for (a, b) in active.iter().filter(|e| e.0[1] <= ys) {
                xs.push(a[0] + (ys - a[1]) / (b[1] - a[1]) * (b[0] - a[0]));
            }
            xs.sort_by(f64::total_cmp);
            for pair in xs.chunks_exact(2) {
                let x0 = (pair[0] - 0.5).ceil().max(0.0) as i64;
                let x1 = (pair[1] - 0.5).ceil().min(self.w as f64) as i64;
                if y < 0 || x0 >= x1 {
                    continue;
                }
                let mut x = free.first_at_or_after(y as u32, x0 as u32);
                while (x as i64) < x1 {
                    self.set(x as i64, y, c);
                    free.take(y as u32, x);
                    x = free.first_at_or_after(y as u32, x + 1);
                }
            }
        }
    }

    /// A one-pixel line (DDA) from a to b.
    fn line(&mut self, a: [f64; 2], b: [f64; 2], c: [u8; 3]) {
        let steps = (b[0] - a[0])
            .abs()
            .max((b[1] - a[1]).abs())
            .ceil()
            .clamp(1.0, 1e6) as usize;
        for i in 0..=steps {
            let t = i as f64 / steps as f64;
            let x = a[0] + t * (b[0] - a[0]);
            let y = a[1] + t * (b[1] - a[1]);
            self.set(x.floor() as i64, y.floor() as i64, c);
        }
    }

    /// Writes the number `k` in the top-left corner, 6 px per font pixel.
    fn label(&mut self, k: usize) {
        const PX: i64 = 6;
        for (d, ch) in k.to_string().bytes().enumerate() {
            let glyph = DIGITS[(ch - b'0') as usize];
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..3 {
                    if bits & (4 >> col) != 0 {
                        for dy in 0..PX {
                            for dx in 0..PX {
                                let x = 8 + d as i64 * 4 * PX + col as i64 * PX + dx;
                                self.set(x, 8 + row as i64 * PX + dy, [0, 0, 0]);
                            }
                        }
                    }
                }
            }
        }
    }

    /// Tiles side by side, `GRID_COLS` per row, each framed in grey, on white.
    fn grid(tiles: &[Image]) -> Image {
        if tiles.is_empty() {
            return Image::blank(1, 1);
        }
        let cols = GRID_COLS.min(tiles.len());
        let rows = tiles.len().div_ceil(cols);
        let cw = tiles.iter().map(|t| t.w).max().unwrap_or(1);
        let ch = tiles.iter().map(|t| t.h).max().unwrap_or(1);
        let w = cols as u32 * (cw + GAP_PX) + GAP_PX;
        let h = rows as u32 * (ch + GAP_PX) + GAP_PX;
        let mut out = Image::blank(w, h);
        for (i, t) in tiles.iter().enumerate() {
            let ox = GAP_PX + (i % cols) as u32 * (cw + GAP_PX);
            let oy = GAP_PX + (i / cols) as u32 * (ch + GAP_PX);
            for y in 0..t.h {
                let src = (y * t.w * 3) as usize;
                let dst = (((oy + y) * w + ox) * 3) as usize;
                out.rgb[dst..dst + (t.w * 3) as usize]
                    .copy_from_slice(&t.rgb[src..src + (t.w * 3) as usize]);
            }
            let grey = [160, 160, 160];
            let (x0, y0) = (ox as f64 - 1.0, oy as f64 - 1.0);
            let (x1, y1) = ((ox + t.w) as f64, (oy + t.h) as f64);
            out.line([x0, y0], [x1, y0], grey);
            out.line([x1, y0], [x1, y1], grey);
            out.line([x1, y1], [x0, y1], grey);
            out.line([x0, y1], [x0, y0], grey);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::merge::tests::rect;
    use citylod_model::{BuildingId, HeightSource, Level, Node, NodeId};

    fn node(fp: Footprint, members: Vec<u32>, children: Vec<u32>) -> Node {
        Node {
            children: children.into_iter().map(NodeId).collect(),
            members: members.into_iter().map(BuildingId).collect(),
            footprint: fp,
            height_m: 10.0,
            base_z_m: 0.0,
            h_min_m: 8.0,
            h_max_m: 12.0,
            dh_m: 4.0,
            da_m2: 3.0,
            area_m2: 100.0,
            landmarks: Vec::new(),
        }
    }

    /// Twelve buildings in a row (level 0), paired (level 1), all in one block (level 2).
    fn sample() -> (Vec<Building>, Hierarchy) {
        let fps: Vec<Footprint> = (0..12)
            .map(|i| rect(i as f64 * 12.0, 0.0, i as f64 * 12.0 + 10.0, 30.0))
            .collect();
        let buildings: Vec<Building> = fps
            .iter()
            .enumerate()
            .map(|(i, fp)| Building {
                id: BuildingId(i as u32),
                source_id: format!("b{i}"),
                footprint: fp.clone(),
                base_z_m: 0.0,
                height_m: 10.0,
                height_source: HeightSource::Default,
                attributes: Default::default(),
                mesh: None,
            })
            .collect();
        let l0 = Level {
            threshold_m: 0.0,
            nodes: (0..12)
                .map(|i| node(fps[i].clone(), vec![i as u32], vec![]))
                .collect(),
        };
        let l1 = Level {
            threshold_m: 2.0,
            nodes: (0..6)
                .map(|k| {
                    let x = k as f64 * 24.0;
                    node(
                        rect(x, 0.0, x + 22.0, 30.0),
                        vec![2 * k, 2 * k + 1],
                        vec![2 * k, 2 * k + 1],
                    )
                })
                .collect(),
        };
        let mut block = rect(0.0, 0.0, 142.0, 30.0);
        block.0[0].interiors_push(vec![
            (60.0, 10.0),
            (60.0, 20.0),
            (80.0, 20.0),
            (80.0, 10.0),
            (60.0, 10.0),
        ]);
        let l2 = Level {
            threshold_m: 10.0,
            nodes: vec![node(block, (0..12).collect(), (0..6).collect())],
        };
        (
            buildings,
            Hierarchy {
                levels: vec![l0, l1, l2],
            },
        )
    }

    fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
        let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
        let mut reader = dec.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        buf.truncate(info.buffer_size());
        (info.width, info.height, buf)
    }

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("citylod-dump-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn dump_writes_parseable_geojson_and_decodable_pngs() {
        let (buildings, h) = sample();
        let frame = LocalFrame::new(-71.06, 42.35, 0.0);
        let dir = scratch("files");
        // An earlier dump of more levels, and a file of the user's.
        for f in ["level-7.geojson", "level-7.png", "level-x.png", "notes.txt"] {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(dir.join(f), b"old").unwrap();
        }
        let written = dump_levels(&dir, &h, &buildings, &frame).unwrap();
        assert_eq!(written.len(), 3 * 2 + 1);
        assert!(!dir.join("level-7.geojson").exists() && !dir.join("level-7.png").exists());
        assert!(dir.join("level-x.png").exists() && dir.join("notes.txt").exists());
        for (k, want) in [(0, 12), (1, 6), (2, 1)] {
            let text = std::fs::read_to_string(dir.join(format!("level-{k}.geojson"))).unwrap();
            let v: Value = serde_json::from_str(&text).unwrap();
            let feats = v["features"].as_array().unwrap();
            assert_eq!(feats.len(), want);
            assert_eq!(feats[0]["properties"]["members"], 12 / want);
            let ring = &feats[0]["geometry"]["coordinates"][0][0];
            let lon = ring[0][0].as_f64().unwrap();
            assert!((lon + 71.06).abs() < 0.01, "{lon}");
            let pts: Vec<[f64; 2]> = ring
                .as_array()
                .unwrap()
                .iter()
                .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
                .collect();
            assert!(
                crate::merge::signed_area2(&pts) > 0.0,
                "exterior must be CCW"
            );
        }
        let hole = &serde_json::from_str::<Value>(
            &std::fs::read_to_string(dir.join("level-2.geojson")).unwrap(),
        )
        .unwrap()["features"][0]["geometry"]["coordinates"][0][1];
        assert_eq!(hole.as_array().unwrap().len(), 5);

        let (w, hgt, px) = decode(&dir.join("level-0.png"));
        assert_eq!(w.max(hgt), LEVEL_PX);
        let colours: std::collections::BTreeSet<[u8; 3]> =
            px.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        assert!(colours.len() > 12, "{} colours", colours.len());
        // Level 2: the courtyard centre stays white, the block around it is filled.
        let (w2, h2, px2) = decode(&dir.join("level-2.png"));
        let at = |x: f64, y: f64| {
            let scale = (LEVEL_PX as f64 - 2.0 * MARGIN_PX) / 142.0;
            let (i, j) = (
                (MARGIN_PX + x * scale) as usize,
                (h2 as f64 - MARGIN_PX - y * scale) as usize,
            );
            let o = (j * w2 as usize + i) * 3;
            [px2[o], px2[o + 1], px2[o + 2]]
        };
        assert_eq!(at(70.0, 15.0), [255, 255, 255]);
        assert_ne!(at(30.0, 15.0), [255, 255, 255]);
        let (gw, gh, _) = decode(&dir.join("levels.png"));
        assert!(gw > 3 * TILE_PX && gh > 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Boston's 1000 central buildings as three levels: the buildings, 80 m grid blocks, one block.
    /// Set `CITYLOD_DUMP_DIR` to keep the pictures.
    #[test]
    fn boston_levels_dump_draws_every_level() {
        use crate::merge::tests::{boston_sample, gap_mst_hints, grid_groups};
        let Some(fps) = boston_sample(1000) else {
            return;
        };
        let buildings: Vec<Building> = fps
            .iter()
            .enumerate()
            .map(|(i, fp)| Building {
                id: BuildingId(i as u32),
                source_id: format!("b{i}"),
                footprint: fp.clone(),
                base_z_m: 0.0,
                height_m: 10.0 + (i % 7) as f64 * 3.0,
                height_source: HeightSource::Default,
                attributes: Default::default(),
                mesh: None,
            })
            .collect();
        let a_avg_m2 = buildings.iter().map(|b| b.area_m2()).sum::<f64>() / buildings.len() as f64;
        let make = |members: Vec<u32>, children: Vec<u32>, fp: Footprint| {
            let refs: Vec<&Building> = members.iter().map(|&m| &buildings[m as usize]).collect();
            let mut n = node(fp, members.clone(), children);
            crate::node_stats(&refs, &n.footprint, &[]).write_into(&mut n);
            n
        };
        let l0: Vec<Node> = (0..fps.len() as u32)
            .map(|i| make(vec![i], vec![], fps[i as usize].clone()))
            .collect();
        let l1: Vec<Node> = grid_groups(&fps, 80.0)
            .into_iter()
            .map(|g| {
                let parts: Vec<&Footprint> = g.iter().map(|&i| &fps[i]).collect();
                let m = crate::merge_footprints(&parts, &gap_mst_hints(&parts)).footprint;
                let fp = crate::simplify_footprint(&m, a_avg_m2 / 50.0, 175.0);
                let mut members: Vec<u32> = g.iter().map(|&i| i as u32).collect();
                members.sort();
                make(members.clone(), members, fp)
            })
            .collect();
        let parts: Vec<&Footprint> = l1.iter().map(|n| &n.footprint).collect();
        let m = crate::merge_footprints(&parts, &gap_mst_hints(&parts)).footprint;
        let top = crate::simplify_footprint(&m, a_avg_m2 * 20.0 / 50.0, 175.0);
        let l2 = vec![make(
            (0..fps.len() as u32).collect(),
            (0..l1.len() as u32).collect(),
            top,
        )];
        let n1 = l1.len();
        let h = Hierarchy {
            levels: [l0, l1, l2]
                .into_iter()
                .map(|nodes| Level {
                    threshold_m: 0.0,
                    nodes,
                })
                .collect(),
        };
        assert!(
            h.check_invariants(fps.len()).is_empty(),
            "{:?}",
            h.check_invariants(fps.len())
        );
        let keep = std::env::var_os("CITYLOD_DUMP_DIR").map(PathBuf::from);
        let dir = keep.clone().unwrap_or_else(|| scratch("boston"));
        let frame = LocalFrame::new(-71.07, 42.35, 0.0);
        dump_levels(&dir, &h, &buildings, &frame).unwrap();
        for (k, want) in [(0, 1000), (1, n1), (2, 1)] {
            let v: Value = serde_json::from_str(
                &std::fs::read_to_string(dir.join(format!("level-{k}.geojson"))).unwrap(),
            )
            .unwrap();
            assert_eq!(v["features"].as_array().unwrap().len(), want);
            let (_, _, px) = decode(&dir.join(format!("level-{k}.png")));
            let colours: std::collections::BTreeSet<[u8; 3]> =
                px.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            assert!(
                colours.len() > want.min(20),
                "level {k}: {} colours",
                colours.len()
            );
        }
        if keep.is_none() {
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }

    #[test]
    fn dump_is_byte_identical_across_runs() {
        let (buildings, h) = sample();
        let frame = LocalFrame::new(4.36, 52.0, 0.0);
        let (d1, d2) = (scratch("det1"), scratch("det2"));
        let f1 = dump_levels(&d1, &h, &buildings, &frame).unwrap();
        let f2 = dump_levels(&d2, &h, &buildings, &frame).unwrap();
        assert!(!f1.is_empty() && f1.len() == f2.len(), "{f1:?} / {f2:?}");
        for (a, b) in f1.iter().zip(&f2) {
            assert_eq!(
                std::fs::read(a).unwrap(),
                std::fs::read(b).unwrap(),
                "{}",
                a.display()
            );
        }
        std::fs::remove_dir_all(&d1).unwrap();
        std::fs::remove_dir_all(&d2).unwrap();
    }

    /// Later nodes lie over earlier ones, as a painter drawing in order would leave them, though fills run last to
    /// first and paint each pixel once; 500 copies of one square cost its area once.
    #[test]
    fn later_footprints_cover_earlier_ones() {
        let a = rect(0.0, 0.0, 60.0, 100.0);
        let b = rect(40.0, 0.0, 100.0, 100.0);
        let mut fps: Vec<&Footprint> = vec![&a; 500];
        fps.push(&b);
        let e = Extent {
            min: [0.0, 0.0],
            max: [100.0, 100.0],
        };
        let img = draw(&fps, Some(e), 132);
        // 1 px a metre inside the 16 px margin; rows counted from the top.
        let at = |x: f64, y: f64| {
            let (px, py) = ((16.0 + x) as usize, (116.0 - y) as usize);
            let i = (py * img.w as usize + px) * 3;
            [img.rgb[i], img.rgb[i + 1], img.rgb[i + 2]]
        };
        assert_eq!(at(20.0, 50.0), node_colour(499));
        assert_eq!(at(50.0, 50.0), node_colour(500));
        assert_eq!(at(80.0, 50.0), node_colour(500));
        assert_eq!(at(-8.0, 50.0), [255; 3]);
        assert_ne!(node_colour(499), node_colour(500));
    }

    #[test]
    fn neighbouring_node_colours_differ() {
        for i in 0..100 {
            let (a, b) = (node_colour(i), node_colour(i + 1));
            let d: i32 = a
                .iter()
                .zip(&b)
                .map(|(x, y)| (*x as i32 - *y as i32).abs())
                .sum();
            assert!(d > 40, "{i}: {a:?} vs {b:?}");
        }
    }
}
