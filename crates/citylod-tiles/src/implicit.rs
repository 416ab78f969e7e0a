//! 3D Tiles 1.1 implicit tiling, for the reader: a tile with `implicitTiling` (or the 1.0 extension
//! `3DTILES_implicit_tiling`) stands for a quadtree or octree whose available tiles and contents are listed
//! in subtree files. [`expand`] turns it into the explicit tree those files describe, so the reader walks
//! it like any other: a tile at level L has the root's geometric error / 2^L and the root's volume split
//! 2^L ways along x and y (and z for an octree; for a `region`: longitude, latitude and, in an octree,
//! height), its content is the root's content template with `{level}`, `{x}`, `{y}` and `{z}` filled in,
//! and its children are the available ones in Morton order. Subtree files are the binary `.subtree`
//! format or JSON; bitstreams may live in the binary chunk or in external buffers, or be constant.

use crate::tileset_json as tj;
use serde::Deserialize;

/// Most tiles an implicit tree may expand to: far beyond what a checker can draw, and a bound on memory
/// whatever availability a file claims (a constant 1 over 20 levels would be 4^20 tiles). The tree read holds
/// about 1.2 kB a tile, so a file of a few hundred bytes claiming this many takes ~0.6 GB (under the former bound
/// of 2,000,000, 11 levels of a quadtree, 1.4 million tiles, took 1.6 GB).
pub const MAX_IMPLICIT_TILES: usize = 500_000;

/// Deepest level an implicit tree may claim: tile coordinates stay exact, and no real tree comes close.
pub const MAX_IMPLICIT_LEVELS: u32 = 40;

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct ImplicitTiling {
    pub subdivision_scheme: String,
    pub subtree_levels: u32,
    pub available_levels: u32,
    pub subtrees: SubtreesUri,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct SubtreesUri {
    pub uri: String,
}

/// The implicit tiling a tile declares, in the 1.1 property or the 1.0 extension; `Err` when it is malformed.
pub fn declared(t: &tj::Tile) -> Result<Option<ImplicitTiling>, String> {
    let from_ext = t
        .extensions
        .as_ref()
        .and_then(|e| e.get("3DTILES_implicit_tiling"));
    match (&t.implicit_tiling, from_ext) {
        (None, None) => Ok(None),
        (Some(v), _) | (None, Some(v)) => serde_json::from_value(v.clone())
            .map(Some)
            .map_err(|e| format!("implicitTiling: {e}")),
    }
}

/// The explicit tree of the implicit tile `t` (which declares `it`): subtree files are read through
/// `open`, which resolves a uri relative to the tileset.json holding `t` and reads the file.
pub fn expand(
    t: &tj::Tile,
    it: &ImplicitTiling,
    open: &dyn Fn(&str) -> Result<Vec<u8>, String>,
) -> Result<tj::Tile, String> {
    expand_at_most(t, it, open, MAX_IMPLICIT_TILES)
}

/// [`expand`], refusing trees of more than `max_tiles` available tiles.
fn expand_at_most(
    t: &tj::Tile,
    it: &ImplicitTiling,
    open: &dyn Fn(&str) -> Result<Vec<u8>, String>,
    max_tiles: usize,
) -> Result<tj::Tile, String> {
    let dims: u32 = match it.subdivision_scheme.as_str() {
        "QUADTREE" => 2,
        "OCTREE" => 3,
        s => {
            return Err(format!(
                "implicitTiling subdivisionScheme {s:?} is neither QUADTREE nor OCTREE"
            ))
        }
    };
    if it.subtree_levels == 0 || it.available_levels == 0 {
        return Err("implicitTiling subtreeLevels and availableLevels must be at least 1".into());
    }
    if it.available_levels > MAX_IMPLICIT_LEVELS || it.subtree_levels > MAX_IMPLICIT_LEVELS {
        return Err(format!(
            "implicitTiling claims {} levels; the reader follows at most {MAX_IMPLICIT_LEVELS}",
            it.available_levels.max(it.subtree_levels)
        ));
    }
    if !t.children.is_empty() {
        return Err("a tile with implicitTiling may not have children".into());
    }
    if t.bounding_volume.sphere.is_some() {
        return Err("implicitTiling needs a box or region bounding volume, not a sphere".into());
    }
    let templates: Vec<&str> = t
        .content
        .iter()
        .chain(&t.contents)
        .map(|c| c.uri.as_str())
        .collect();
    let mut x = Expander {
        t,
        it,
        dims,
        templates,
        open,
        n_tiles: 0,
        max_tiles,
    };
    let root = Coord {
        level: 0,
        xyz: [0; 3],
    };
    let subtree = x.subtree(root)?;
    let mut tile = x
        .tile(&subtree, root, 0, 0)?
        .ok_or("the root of the implicit tree is not available in its subtree")?;
    tile.transform = t.transform;
    tile.refine = t.refine.clone();
    Ok(tile)
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Coord {
    level: u32,
    xyz: [u64; 3],
}

impl Coord {
    fn child(self, k: u32, dims: u32) -> Coord {
        let mut xyz = self.xyz;
        for (d, v) in xyz.iter_mut().enumerate().take(dims as usize) {
            *v = 2 * *v + ((k >> d) & 1) as u64;
        }
        Coord {
            level: self.level + 1,
            xyz,
        }
    }
}

/// Morton index of `xyz` within its level (x in the lowest bit).
#[cfg(test)]
fn morton(xyz: [u64; 3], dims: u32, levels: u32) -> u64 {
    let mut m = 0u64;
    for bit in 0..levels {
        for d in 0..dims {
            m |= ((xyz[d as usize] >> bit) & 1) << (bit * dims + d);
        }
    }
    m
}

/// One availability: a constant or a bitstream (bit i is bit i % 8 of byte i / 8).
#[derive(Debug, Clone, PartialEq)]
enum Availability {
    Constant(bool),
    Bits(Vec<u8>),
}

impl Availability {
    fn get(&self, i: u64) -> bool {
        match self {
            Availability::Constant(c) => *c,
            Availability::Bits(b) => b
                .get((i / 8) as usize)
                .is_some_and(|byte| (byte >> (i % 8)) & 1 == 1),
        }
    }
}

/// A parsed subtree: the availability of its tiles, of each content, and of its child subtrees.
#[derive(Debug)]
struct Subtree {
    tiles: Availability,
    contents: Vec<Availability>,
    children: Availability,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct SubtreeJson {
    #[serde(default)]
    buffers: Vec<BufferJson>,
    #[serde(default)]
    buffer_views: Vec<BufferViewJson>,
    tile_availability: AvailabilityJson,
    #[serde(default)]
    content_availability: Vec<AvailabilityJson>,
    child_subtree_availability: AvailabilityJson,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct BufferJson {
    uri: Option<String>,
    byte_length: u64,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct BufferViewJson {
    buffer: usize,
    #[serde(default)]
    byte_offset: u64,
    byte_length: u64,
}

#[derive(Deserialize)]
struct AvailabilityJson {
    bitstream: Option<usize>,
    constant: Option<u8>,
}

/// Parses a subtree file: binary (`subt` magic) or JSON. `open` reads external buffers.
fn parse_subtree(
    bytes: &[u8],
    n_contents: usize,
    open: &dyn Fn(&str) -> Result<Vec<u8>, String>,
) -> Result<Subtree, String> {
    let (json, chunk): (&[u8], Option<&[u8]>) = if bytes.starts_with(b"subt") {
        let word = |at: usize| -> Result<u64, String> {
            let b = bytes
                .get(at..at + 8)
                .ok_or("binary subtree shorter than its header")?;
            Ok(u64::from_le_bytes(b.try_into().expect("8 bytes")))
        };
        let version =
            u32::from_le_bytes(bytes.get(4..8).ok_or("truncated")?.try_into().expect("4"));
        if version != 1 {
            return Err(format!("binary subtree version {version}, not 1"));
        }
        let (json_len, bin_len) = (word(8)?, word(16)?);
        let json_end = 24u64
            .checked_add(json_len)
            .ok_or("header lengths overflow")?;
        let bin_end = json_end
            .checked_add(bin_len)
            .ok_or("header lengths overflow")?;
        if bin_end > bytes.len() as u64 {
            return Err(format!(
                "binary subtree of {} bytes, shorter than its header says ({bin_end})",
                bytes.len()
            ));
        }
        (
            &bytes[24..json_end as usize],
            Some(&bytes[json_end as usize..bin_end as usize]),
        )
    } else {
        (bytes, None)
    };
    let s: SubtreeJson = serde_json::from_slice(json).map_err(|e| format!("subtree JSON: {e}"))?;
    let mut buffers: Vec<Option<Vec<u8>>> = vec![None; s.buffers.len()];
    let mut buffer = |i: usize| -> Result<Vec<u8>, String> {
        let b = s
            .buffers
            .get(i)
            .ok_or(format!("buffer {i} does not exist"))?;
        if buffers[i].is_none() {
            let data = match (&b.uri, chunk) {
                (Some(uri), _) => open(uri)?,
                (None, Some(c)) if i == 0 => c.to_vec(),
                (None, _) => {
                    return Err(format!(
                        "buffer {i} has no uri and is not the binary chunk of a .subtree file"
                    ))
                }
            };
            if (data.len() as u64) < b.byte_length {
                return Err(format!(
                    "buffer {i} holds {} bytes, less than its byteLength {}",
                    data.len(),
                    b.byte_length
                ));
            }
            buffers[i] = Some(data);
        }
        Ok(buffers[i].clone().expect("just filled"))
    };
    let mut availability = |a: &AvailabilityJson, what: &str| -> Result<Availability, String> {
        match (a.bitstream, a.constant) {
            (Some(v), None) => {
                let view = s
                    .buffer_views
                    .get(v)
                    .ok_or(format!("{what}: bufferView {v} does not exist"))?;
                let data = buffer(view.buffer)?;
                let end = view.byte_offset.checked_add(view.byte_length);
                match end {
                    Some(end) if end <= data.len() as u64 => Ok(Availability::Bits(
                        data[view.byte_offset as usize..end as usize].to_vec(),
                    )),
                    _ => Err(format!("{what}: bufferView {v} reaches past its buffer")),
                }
            }
            (None, Some(c)) if c <= 1 => Ok(Availability::Constant(c == 1)),
            _ => Err(format!(
                "{what}: needs one of bitstream and constant (0 or 1)"
            )),
        }
    };
    let tiles = availability(&s.tile_availability, "tileAvailability")?;
    let children = availability(&s.child_subtree_availability, "childSubtreeAvailability")?;
    if s.content_availability.len() < n_contents {
        return Err(format!(
            "contentAvailability lists {} contents, the tile has {n_contents}",
            s.content_availability.len()
        ));
    }
    let contents = s.content_availability[..n_contents]
        .iter()
        .map(|a| availability(a, "contentAvailability"))
        .collect::<Result<_, _>>()?;
    Ok(Subtree {
        tiles,
        contents,
        children,
    })
}

struct Expander<'a> {
    t: &'a tj::Tile,
    it: &'a ImplicitTiling,
    dims: u32,
    templates: Vec<&'a str>,
    open: &'a dyn Fn(&str) -> Result<Vec<u8>, String>,
    n_tiles: usize,
    max_tiles: usize,
}

fn fill(template: &str, c: Coord) -> String {
    template
        .replace("{level}", &c.level.to_string())
        .replace("{x}", &c.xyz[0].to_string())
        .replace("{y}", &c.xyz[1].to_string())
        .replace("{z}", &c.xyz[2].to_string())
}

impl Expander<'_> {
    /// Reads the subtree rooted at `root`.
    fn subtree(&self, root: Coord) -> Result<Subtree, String> {
        let uri = fill(&self.it.subtrees.uri, root);
        let bytes = (self.open)(&uri).map_err(|e| format!("subtree {uri}: {e}"))?;
        // External buffers are named relative to the subtree file.
        let dir = uri.rsplit_once('/').map(|(d, _)| d);
        let open_buffer = |b: &str| match dir {
            Some(d) => (self.open)(&format!("{d}/{b}")),
            None => (self.open)(b),
        };
        parse_subtree(&bytes, self.templates.len(), &open_buffer)
            .map_err(|e| format!("subtree {uri}: {e}"))
    }

    /// The tile at `c`, `local` levels below the root of `subtree`, with its available descendants; `None`
    /// when it is not available. `local_morton` is its Morton index within that level of the subtree.
    fn tile(
        &mut self,
        subtree: &Subtree,
        c: Coord,
        local: u32,
        local_morton: u64,
    ) -> Result<Option<tj::Tile>, String> {
        let n = 1u64 << self.dims; // children per tile
        let level_offset = (n.pow(local) - 1) / (n - 1);
        let index = level_offset + local_morton;
        if !subtree.tiles.get(index) {
            return Ok(None);
        }
        self.n_tiles += 1;
        if self.n_tiles > self.max_tiles {
            return Err(format!(
                "the implicit tree has more than {} available tiles, the most the reader expands",
                self.max_tiles
            ));
        }
        let contents: Vec<tj::Content> = self
            .templates
            .iter()
            .zip(&subtree.contents)
            .filter(|(_, a)| a.get(index))
            .map(|(tpl, _)| tj::Content { uri: fill(tpl, c) })
            .collect();
        let mut tile = tj::Tile {
            transform: None,
            bounding_volume: self.volume(c)?,
            geometric_error: self.t.geometric_error / 2f64.powi(c.level as i32),
            refine: None,
            content: None,
            contents: Vec::new(),
            children: Vec::new(),
            implicit_tiling: None,
            extensions: None,
        };
        if contents.len() == 1 && self.t.content.is_some() {
            tile.content = contents.into_iter().next();
        } else {
            tile.contents = contents;
        }
        if c.level + 1 >= self.it.available_levels {
            return Ok(Some(tile));
        }
        for k in 0..n as u32 {
            let cc = c.child(k, self.dims);
            let child_morton = local_morton * n + k as u64;
            let child = if local + 1 < self.it.subtree_levels {
                self.tile(subtree, cc, local + 1, child_morton)?
            } else if subtree.children.get(child_morton) {
                let sub = self.subtree(cc)?;
                self.tile(&sub, cc, 0, 0)?
            } else {
                None
            };
            tile.children.extend(child);
        }
        Ok(Some(tile))
    }

    /// The bounding volume of the tile at `c`: the root's, split 2^level ways along each subdivided axis.
    fn volume(&self, c: Coord) -> Result<tj::BoundingVolume, String> {
        let parts = (1u64 << c.level) as f64;
        let bv = &self.t.bounding_volume;
        if let Some(b) = bv.r#box {
            let mut out = b;
            for d in 0..3 {
                let axis = [b[3 + 3 * d], b[4 + 3 * d], b[5 + 3 * d]];
                if (d as u32) < self.dims {
                    // Centre of slice k of `parts` along this half-axis: −1 + (2k + 1) / parts.
                    let t = -1.0 + (2.0 * c.xyz[d] as f64 + 1.0) / parts;
                    for i in 0..3 {
                        out[i] += axis[i] * t;
                        out[3 + 3 * d + i] = axis[i] / parts;
                    }
                }
            }
            return Ok(tj::BoundingVolume {
                r#box: Some(out),
                region: None,
                sphere: None,
            });
        }
        if let Some(r) = bv.region {
            let [west, south, east, north, lo, hi] = r;
            // A region crossing the antimeridian has east < west.
            let width = if east < west {
                east - west + std::f64::consts::TAU
            } else {
                east - west
            };
            let mut w = west + width * c.xyz[0] as f64 / parts;
            let mut e = west + width * (c.xyz[0] + 1) as f64 / parts;
            let wrap = |a: f64| {
                if a > std::f64::consts::PI {
                    a - std::f64::consts::TAU
                } else {
                    a
                }
            };
            (w, e) = (wrap(w), wrap(e));
            let s = south + (north - south) * c.xyz[1] as f64 / parts;
            let n = south + (north - south) * (c.xyz[1] + 1) as f64 / parts;
            let (l, h) = if self.dims == 3 {
                (
                    lo + (hi - lo) * c.xyz[2] as f64 / parts,
                    lo + (hi - lo) * (c.xyz[2] + 1) as f64 / parts,
                )
            } else {
                (lo, hi)
            };
            return Ok(tj::BoundingVolume {
                r#box: None,
                region: Some([w, s, e, n, l, h]),
                sphere: None,
            });
        }
        Err("implicitTiling needs a box or region bounding volume".into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_interleaves_x_lowest() {
        assert_eq!(morton([1, 0, 0], 2, 2), 1);
        assert_eq!(morton([0, 1, 0], 2, 2), 2);
        assert_eq!(morton([3, 3, 0], 2, 2), 15);
        assert_eq!(morton([2, 1, 0], 2, 2), 6);
        assert_eq!(morton([1, 1, 1], 3, 1), 7);
        assert_eq!(morton([0, 0, 1], 3, 1), 4);
        // Children k of a tile are at Morton index parent·N + k.
        let p = Coord {
            level: 1,
            xyz: [1, 0, 0],
        };
        for k in 0..4 {
            let c = p.child(k, 2);
            assert_eq!(morton(c.xyz, 2, 2), morton(p.xyz, 2, 1) * 4 + k as u64);
        }
    }

    #[test]
    fn bitstreams_read_lowest_bit_first() {
        let a = Availability::Bits(vec![0b0000_0101, 0b1000_0000]);
        let on: Vec<u64> = (0..20).filter(|&i| a.get(i)).collect();
        assert_eq!(on, vec![0, 2, 15]);
        assert!(Availability::Constant(true).get(1_000_000));
    }

    fn implicit_root(volume: tj::BoundingVolume, tiling: serde_json::Value) -> tj::Tile {
        tj::Tile {
            transform: None,
            bounding_volume: volume,
            geometric_error: 64.0,
            refine: Some("REPLACE".into()),
            content: Some(tj::Content {
                uri: "c/{level}/{x}/{y}/{z}.glb".into(),
            }),
            contents: Vec::new(),
            children: Vec::new(),
            implicit_tiling: None,
            extensions: Some(serde_json::json!({ "3DTILES_implicit_tiling": tiling })),
        }
    }

    #[test]
    fn an_octree_over_a_region_splits_longitude_latitude_and_height() {
        // Every tile and content available (constants), two levels: the root and its 8 children.
        let t = implicit_root(
            tj::BoundingVolume {
                r#box: None,
                // Across the antimeridian.
                region: Some([3.0, 0.1, -3.1, 0.3, 0.0, 80.0]),
                sphere: None,
            },
            serde_json::json!({"subdivisionScheme": "OCTREE", "subtreeLevels": 3, "availableLevels": 2,
                "subtrees": {"uri": "s/{level}.json"}}),
        );
        let it = declared(&t).unwrap().unwrap();
        let open = |uri: &str| -> Result<Vec<u8>, String> {
            assert_eq!(uri, "s/0.json");
            Ok(
                br#"{"tileAvailability": {"constant": 1}, "contentAvailability": [{"constant": 1}],
                "childSubtreeAvailability": {"constant": 0}}"#
                    .to_vec(),
            )
        };
        let root = expand(&t, &it, &open).unwrap();
        assert_eq!(root.children.len(), 8);
        assert_eq!(root.refine.as_deref(), Some("REPLACE"));
        assert_eq!(root.content.as_ref().unwrap().uri, "c/0/0/0/0.glb");
        let last = &root.children[7];
        assert_eq!(last.content.as_ref().unwrap().uri, "c/1/1/1/1.glb");
        assert_eq!(last.geometric_error, 32.0);
        let r = last.bounding_volume.region.unwrap();
        let half_width = (std::f64::consts::TAU - 6.1) / 2.0;
        assert!((r[0] - (3.0 + half_width)).abs() < 1e-12, "{r:?}");
        assert!((r[2] - -3.1).abs() < 1e-12, "{r:?}");
        let first = root.children[0].bounding_volume.region.unwrap();
        assert!((first[0] - 3.0).abs() < 1e-12 && (first[2] - r[0]).abs() < 1e-12);
        assert_eq!([r[1], r[3], r[4], r[5]], [0.2, 0.3, 40.0, 80.0]);
        // Child 1 is x = 1, y = 0, z = 0; child 2 is x = 0, y = 1.
        assert_eq!(
            root.children[1].content.as_ref().unwrap().uri,
            "c/1/1/0/0.glb"
        );
        assert_eq!(
            root.children[2].content.as_ref().unwrap().uri,
            "c/1/0/1/0.glb"
        );
    }

    #[test]
    fn claims_beyond_the_limits_are_errors_not_allocations() {
        let volume = tj::BoundingVolume {
            r#box: Some([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
            region: None,
            sphere: None,
        };
        let everything = |_: &str| -> Result<Vec<u8>, String> {
            Ok(
                br#"{"tileAvailability": {"constant": 1}, "contentAvailability": [{"constant": 1}],
                "childSubtreeAvailability": {"constant": 1}}"#
                    .to_vec(),
            )
        };
        // 4^12 tiles claimed by constants.
        let t = implicit_root(
            volume.clone(),
            serde_json::json!({"subdivisionScheme": "QUADTREE", "subtreeLevels": 4, "availableLevels": 12,
                "subtrees": {"uri": "s/{level}/{x}/{y}.subtree"}}),
        );
        let e =
            expand_at_most(&t, &declared(&t).unwrap().unwrap(), &everything, 5_000).unwrap_err();
        assert!(e.contains("more than 5000 available tiles"), "{e}");
        for (scheme, levels) in [("QUADTREE", 41), ("HEXTREE", 2)] {
            let t = implicit_root(
                volume.clone(),
                serde_json::json!({"subdivisionScheme": scheme, "subtreeLevels": 2,
                    "availableLevels": levels, "subtrees": {"uri": "s"}}),
            );
            assert!(expand(&t, &declared(&t).unwrap().unwrap(), &everything).is_err());
        }
    }

    #[test]
    fn malformed_subtrees_are_errors() {
        let none = |_: &str| -> Result<Vec<u8>, String> { Err("no files".into()) };
        let bad: [&[u8]; 5] = [
            b"subt\x01\0\0\0\xff\xff\xff\xff\xff\xff\xff\xff\0\0\0\0\0\0\0\0",
            b"subt\x02\0\0\0",
            b"{\"tileAvailability\": {\"constant\": 1}}",
            b"{\"tileAvailability\": {\"bitstream\": 3}, \"childSubtreeAvailability\": {\"constant\": 0}}",
            b"{\"tileAvailability\": {\"constant\": 2}, \"childSubtreeAvailability\": {\"constant\": 0}}",
        ];
        for b in bad {
            assert!(
                parse_subtree(b, 0, &none).is_err(),
                "{}",
                String::from_utf8_lossy(b)
            );
        }
        // Too few content availabilities for the tile's contents.
        let one = b"{\"tileAvailability\": {\"constant\": 1}, \"childSubtreeAvailability\": {\"constant\": 0}}";
        assert!(parse_subtree(one, 0, &none).is_ok());
        assert!(parse_subtree(one, 1, &none).is_err());
    }
}
