//! A tileset reader for tests and the checker: walks `tileset.json` (and external tilesets named by
//! `content.uri` ending in `.json`), decodes glb content (plain or EXT_meshopt_compression buffers, KHR_draco_mesh_compression primitives,
//! any quantized or float positions, node transforms, feature ids, property tables), and the 3D Tiles 1.0 b3dm and cmpt
//! around glb (`legacy.rs`).
//! Output positions are in the root tile's frame (z up; for citylod: local ENU metres), and so is every tile's
//! bounding volume, as a box (a `sphere` or `region` as the box enclosing it). 3D Tiles 1.1 `contents` (several
//! glbs on one tile) are appended into one content; implicit tiling is expanded into the explicit tree its
//! subtree files describe (`implicit.rs`). Input it cannot use is an error naming the file and the tile.

use crate::bounding_volume::{region_box_ecef, similarity_scale, sphere_box};
pub use crate::bounding_volume::{ExactVolume, VolumeKind};
use crate::glb::parse_glb;
use crate::gltf_json::{self as gj, Gltf};
use crate::metadata::{decode_column, FeatureRow};
use crate::tileset_json as tj;
use crate::TilesError;
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// A whole tileset, tiles in pre-order (`tiles[0]` is the root).
#[derive(Debug, Clone, PartialEq)]
pub struct TilesetData {
    /// `asset.generator` of the root tileset (citylod writes `citylod <version>`).
    pub generator: Option<String>,
    /// The root tile's `transform` (column-major; identity when absent): root frame → ECEF.
    pub root_transform: [f64; 16],
    /// `tileset.geometricError` (m).
    pub geometric_error_m: f64,
    /// The main `tileset.json`'s top-level `extras` (citylod writes `{"citylod": {…}}`), if any.
    pub extras: Option<serde_json::Value>,
    pub tiles: Vec<TileData>,
}

/// One tile.
#[derive(Debug, Clone, PartialEq)]
pub struct TileData {
    /// `0` for the root, `p/k` for child k of `p`; the root of an external tileset under `p` is `p/ext`.
    pub path_in_tree: String,
    pub geometric_error_m: f64,
    /// The bounding volume as a box in the root frame: a `box` as written (when no tile below the root has a
    /// `transform`), the cube around a `sphere`, or a box enclosing a `region` (see [`VolumeKind`]). The reader
    /// always sets it; `None` only in hand-made data.
    pub bounding_box: Option<[f64; 12]>,
    /// Which volume the file gives (`bounding_box` is exact only for a `box`).
    pub volume_kind: VolumeKind,
    /// A `sphere` or `region` as written, for exact tests (`None` for a `box`, and for a sphere under a
    /// transform that is not a similarity: then only `bounding_box` is known).
    pub exact_volume: Option<ExactVolume>,
    /// The first of `content_uris` (the only one unless the tile has 3D Tiles 1.1 `contents`).
    pub content_uri: Option<String>,
    /// Every content URI: `content.uri`, or each `contents[].uri` in order.
    pub content_uris: Vec<String>,
    /// Size of the content files (glbs or external tileset.json), bytes, summed over `content_uris`.
    pub content_bytes: Option<u64>,
    /// Decoded glb content, several `contents` appended into one (`None` without content or for
    /// external-tileset links).
    pub content: Option<GlbData>,
    /// Indices into `TilesetData::tiles`.
    pub children: Vec<usize>,
    /// The tile refines by `ADD` (its own or inherited `refine`): its children draw with it, not instead of it.
    pub refine_add: bool,
}

/// Decoded glb content.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GlbData {
    /// Vertex positions in the root frame (z up; local ENU metres for citylod tilesets).
    pub positions_local: Vec<[f64; 3]>,
    /// Unit vertex normals in the root frame, one per vertex; empty when the content has none.
    pub normals_local: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
    /// Per vertex: index into `features`, or `u32::MAX` when the vertex has no feature.
    pub feature_ids: Vec<u32>,
    /// Property-table rows of every table, tables in order.
    pub features: Vec<FeatureRow>,
}

/// Sanity limits against hostile or corrupt files (allocation happens before data is checked).
const MAX_ELEMENTS: usize = 1 << 28;

/// Most vertices one glb may draw in all: nodes sharing a mesh repeat it at no cost in the file.
const MAX_GLB_VERTICES: usize = 1 << 24;

/// Most values one content's property tables (or a b3dm's batch table) may hold in all, rows × properties, a
/// composite's tiles together: each becomes a decoded value in memory, while properties may share their bytes.
pub(crate) const MAX_TABLE_CELLS: usize = 1 << 24;

/// Most elements of a sparse accessor without a buffer view (whose zeros no bytes of the file back).
const MAX_ZERO_BASE_ELEMENTS: usize = 1 << 22;
const MAX_VIEW_BYTES: usize = 1 << 31;

const IDENTITY: [f64; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

/// Reads a tileset and all its content. Errors name the file that failed.
pub fn read_tileset(path: &Path) -> Result<TilesetData, TilesError> {
    read_tileset_with(path, &mut |_, _| {})
}

/// [`read_tileset`], handing each tile to `visit` (with its index in [`TilesetData::tiles`]) as soon as its
/// content is decoded, before the next file is read. A caller that takes the content out
/// ([`Option::take`] on [`TileData::content`]) and keeps only what it needs never holds the whole tileset
/// decoded: a million buildings' property rows alone take gigabytes.
pub fn read_tileset_with(
    path: &Path,
    visit: &mut dyn FnMut(usize, &mut TileData),
) -> Result<TilesetData, TilesError> {
    let ts = load_json(path, "0")?;
    // Before 3D Tiles 1.0 a tileset could say its glTF was z-up (`asset.gltfUpAxis`); as in CesiumJS, the root
    // tileset's word holds for all its content.
    let z_up = match ts.asset.gltf_up_axis.as_deref() {
        None => false,
        Some(a) if a.eq_ignore_ascii_case("y") => false,
        Some(a) if a.eq_ignore_ascii_case("z") => true,
        Some(a) => {
            return Err(TilesError::Tile {
                tile: format!("0 ({})", path.display()),
                msg: format!("asset.gltfUpAxis is {a:?}: only Y (glTF's own) and Z are read"),
            })
        }
    };
    // `tileset.json` alone has the parent "", which is the current folder.
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    let folder =
        std::fs::canonicalize(parent.unwrap_or(Path::new("."))).map_err(TilesError::io(path))?;
    let root_transform = ts.root.transform.unwrap_or(IDENTITY);
    let mut tiles = Vec::new();
    // The root frame: positions and boxes are expressed relative to the root's own transform, which must
    // therefore be invertible (regions, in ECEF, come in through its inverse).
    let Some(ecef_to_root) = check_tile_transform(&root_transform) else {
        return Err(TilesError::Tile {
            tile: format!("0 ({})", path.display()),
            msg: "root transform is not an invertible affine transform".into(),
        });
    };
    let place = Place {
        json: path,
        path: "0".into(),
        external_depth: 0,
        level: 0,
        add: false,
    };
    walk(
        &ts.root,
        place,
        None,
        &mut Walk {
            out: &mut tiles,
            visit,
            folder: &folder,
            ecef_to_root,
            root_to_ecef: root_transform,
            external: Default::default(),
            z_up,
        },
    )?;
    Ok(TilesetData {
        generator: ts.asset.generator.clone(),
        root_transform,
        geometric_error_m: ts.geometric_error,
        extras: ts.extras,
        tiles,
    })
}

/// Largest file the reader opens: a glb's length field is 32 bits.
const MAX_FILE_BYTES: u64 = u32::MAX as u64;

/// Reads a regular file of at most [`MAX_FILE_BYTES`] (not a device or pipe, which could be endless).
fn read_file(path: &Path) -> Result<Vec<u8>, TilesError> {
    let meta = std::fs::metadata(path).map_err(TilesError::io(path))?;
    if !meta.is_file() || meta.len() > MAX_FILE_BYTES {
        return Err(TilesError::File {
            path: path.to_path_buf(),
            msg: if meta.is_file() {
                format!(
                    "{} bytes: larger than any glb or tileset.json can be",
                    meta.len()
                )
            } else {
                "not a regular file".into()
            },
        });
    }
    std::fs::read(path).map_err(TilesError::io(path))
}

/// An error of a tile's content file told with the tile that names it (a third-party tileset's file names need not
/// follow its tree, and one file may hang under several tiles); errors that already name a tile stay as they are.
fn named_by_tile(e: TilesError, fail: &dyn Fn(String) -> TilesError) -> TilesError {
    if matches!(e, TilesError::Tile { .. } | TilesError::Feature { .. }) {
        return e;
    }
    let mut msg = e.to_string();
    let mut source = std::error::Error::source(&e);
    while let Some(s) = source {
        msg.push_str(&format!(": {s}"));
        source = s.source();
    }
    fail(format!("its content {msg}"))
}

/// 3D Tiles versions (`asset.version`) the reader reads: CesiumJS refuses a tileset.json of any other (its
/// `Cesium3DTileset.loadTileset` takes "0.0", the version of the drafts before 1.0, as well).
const KNOWN_VERSIONS: &[&str] = &["1.0", "1.1", "0.0"];

/// 3D Tiles extensions a tileset.json may require (`extensionsRequired`) of the reader, each read as its 3D Tiles
/// 1.1 core feature: implicit tiling (`implicit.rs` reads the extension's object on a tile) and glTF content (glb;
/// `.gltf` JSON content is refused by name). A tileset requiring any other is refused, as a client that does not
/// support a required extension must. Not among them: `3DTILES_multiple_contents` (the reader reads 1.1
/// `contents`, not the extension's object on a tile), `3DTILES_bounding_volume_S2`, `3DTILES_batch_table_hierarchy`
/// (inherited properties are not read), `3DTILES_draco_point_compression` (point clouds are refused).
const READ_TILES_EXTENSIONS: &[&str] = &["3DTILES_implicit_tiling", "3DTILES_content_gltf"];

/// 3D Tiles extensions the reader skips as it skips their 1.1 core form: `3DTILES_metadata` (the schema,
/// groups and tileset, tile and content metadata of a tileset.json) changes neither geometry nor the glb's
/// features, which are all the reader reads.
const SKIPPED_TILES_EXTENSIONS: &[&str] = &["3DTILES_metadata"];

/// A tileset.json as [`load_json`] reads it: [`tj::Tileset`] and the extensions it requires.
#[derive(serde::Deserialize)]
#[serde(rename_all = "camelCase")]
struct TilesetFile {
    asset: tj::Asset,
    geometric_error: f64,
    #[serde(default)]
    extras: Option<serde_json::Value>,
    root: tj::Tile,
    #[serde(default)]
    extensions_required: Vec<String>,
}

/// What a tileset.json says it is, read alone when the whole does not parse: a file of another version, or
/// requiring an extension, need not have the shape the reader expects, and that is the error to tell.
#[derive(serde::Deserialize)]
#[serde(rename_all = "camelCase")]
struct TilesetHead {
    asset: HeadAsset,
    #[serde(default)]
    extensions_required: Vec<String>,
}

#[derive(serde::Deserialize)]
struct HeadAsset {
    version: String,
}

/// Why a tileset.json of `version` requiring `required` is not read (`None` when it is).
fn unread_version_or_extension(version: &str, required: &[String]) -> Option<String> {
    if !KNOWN_VERSIONS.contains(&version) {
        return Some(format!(
            "asset.version {version:?}: 3D Tiles 1.0 and 1.1 are known (and \"0.0\", of the drafts before 1.0); \
             CesiumJS refuses other versions"
        ));
    }
    let x = required.iter().find(|x| {
        !(READ_TILES_EXTENSIONS.contains(&x.as_str())
            || SKIPPED_TILES_EXTENSIONS.contains(&x.as_str()))
    })?;
    Some(format!(
        "it requires the 3D Tiles extension {x:?}, which citylod's reader does not read (the required extensions \
         it takes: {})",
        READ_TILES_EXTENSIONS
            .iter()
            .chain(SKIPPED_TILES_EXTENSIONS)
            .copied()
            .collect::<Vec<_>>()
            .join(", ")
    ))
}

/// Parses a `tileset.json` (the main one or an external one) whose root is tile `root_path` of the whole tree:
/// refuses versions and required extensions the reader does not know, before anything else of the file.
fn load_json(path: &Path, root_path: &str) -> Result<tj::Tileset, TilesError> {
    let bytes = read_file(path)?;
    let unread = |version: &str, required: &[String]| {
        unread_version_or_extension(version, required).map(|msg| TilesError::File {
            path: path.to_path_buf(),
            msg,
        })
    };
    let ts: TilesetFile = serde_json::from_slice(&bytes).map_err(|source| {
        if let Some(e) = serde_json::from_slice::<TilesetHead>(&bytes)
            .ok()
            .and_then(|h| unread(&h.asset.version, &h.extensions_required))
        {
            e
        } else if source.to_string().starts_with("recursion limit exceeded") {
            too_deep(&bytes, path, root_path, &source)
        } else {
            TilesError::Json {
                path: path.to_path_buf(),
                source,
            }
        }
    })?;
    if let Some(e) = unread(&ts.asset.version, &ts.extensions_required) {
        return Err(e);
    }
    check_error(ts.geometric_error).map_err(|msg| TilesError::File {
        path: path.to_path_buf(),
        msg: format!("the tileset's own geometricError (beside its root tile's): {msg}"),
    })?;
    Ok(tj::Tileset {
        asset: ts.asset,
        geometric_error: ts.geometric_error,
        extras: ts.extras,
        root: ts.root,
    })
}

/// How deep JSON may nest in one file: serde_json's limit. A tile at level L below its file's root opens its
/// `boundingVolume` array at nesting 4 + 2·L, so one file holds tiles down to level [`MAX_TILE_LEVEL_PER_FILE`].
const JSON_NESTING_LIMIT: usize = 127;
const MAX_TILE_LEVEL_PER_FILE: usize = (JSON_NESTING_LIMIT - 4) / 2;

/// The error for a tree nested deeper than the JSON parser allows, naming the tile where it stopped.
fn too_deep(bytes: &[u8], path: &Path, root_path: &str, e: &serde_json::Error) -> TilesError {
    let line_start = bytes
        .split_inclusive(|&b| b == b'\n')
        .take(e.line().saturating_sub(1))
        .map(<[u8]>::len)
        .sum::<usize>();
    let levels = tile_path_at(bytes, line_start + e.column().saturating_sub(1));
    let mut tile = root_path.to_string();
    for k in &levels {
        tile.push_str(&format!("/{k}"));
    }
    TilesError::Tile {
        tile: format!("{tile} ({}, line {} column {})", path.display(), e.line(), e.column()),
        msg: format!(
            "this tile is {} levels below its tileset.json's root; one tileset.json holds tiles down to level \
             {MAX_TILE_LEVEL_PER_FILE} (JSON nesting limit {JSON_NESTING_LIMIT}). Split deeper trees into external \
             tilesets",
            levels.len()
        ),
    }
}

/// The child indices leading from the root tile to the tile whose JSON text holds byte `at` of a `tileset.json`
/// (a light scan of brackets, strings and keys: it works on text the parser gave up on).
fn tile_path_at(text: &[u8], at: usize) -> Vec<usize> {
    struct Frame {
        array: bool,
        /// Objects: the last key read, and whether the next string is a key.
        key: Vec<u8>,
        expect_key: bool,
        /// Arrays: the index of the current element.
        index: usize,
    }
    let mut stack: Vec<Frame> = Vec::new();
    let mut string: Option<Vec<u8>> = None;
    let mut escaped = false;
    for &b in &text[..at.min(text.len())] {
        if let Some(s) = string.as_mut() {
            if escaped {
                escaped = false;
            } else if b == b'\\' {
                escaped = true;
            } else if b == b'"' {
                let s = string.take().unwrap_or_default();
                if let Some(f) = stack.last_mut().filter(|f| !f.array && f.expect_key) {
                    f.key = s;
                }
            } else {
                s.push(b);
            }
            continue;
        }
        match b {
            b'"' => string = Some(Vec::new()),
            b'{' | b'[' => stack.push(Frame {
                array: b == b'[',
                key: Vec::new(),
                expect_key: b == b'{',
                index: 0,
            }),
            b'}' | b']' => {
                stack.pop();
            }
            b':' => {
                if let Some(f) = stack.last_mut() {
                    f.expect_key = false;
                }
            }
            b',' => {
                if let Some(f) = stack.last_mut() {
                    f.index += 1;
                    f.expect_key = !f.array;
                }
            }
            _ => {}
        }
    }
    stack
        .windows(2)
        .filter(|w| !w[0].array && w[0].key == b"children" && w[1].array)
        .map(|w| w[1].index)
        .collect()
}

/// A geometricError must be a finite number ≥ 0.
fn check_error(e: f64) -> Result<(), String> {
    if e.is_finite() && e >= 0.0 {
        Ok(())
    } else {
        Err(format!("geometricError {e} is not a non-negative number"))
    }
}

/// What 3D Tiles 1.1 asks of one tile that the serde structs cannot say: one bounding volume with sane values,
/// a non-negative geometricError, `refine` ADD or REPLACE, not both `content` and `contents`. Returns the volume
/// as a box in the tile's frame (`box`, `sphere`) or in ECEF (`region`).
fn check_tile(t: &tj::Tile) -> Result<(VolumeKind, [f64; 12]), String> {
    let bv = &t.bounding_volume;
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    let plain = |v: &[f64]| v.iter().map(f64::to_string).collect::<Vec<_>>().join(", ");
    let volume = match (bv.r#box, bv.region, bv.sphere) {
        (None, None, None) => {
            return Err("boundingVolume has none of box, region and sphere".into())
        }
        (Some(b), None, None) if finite(&b) => (VolumeKind::Box, b),
        (Some(b), None, None) => {
            return Err(format!(
                "boundingVolume box [{}] has invalid values: not all finite",
                plain(&b)
            ))
        }
        (None, Some(r), None) => (
            VolumeKind::Region,
            region_box_ecef(r).map_err(|e| format!("boundingVolume {e}"))?,
        ),
        (None, None, Some(s)) if finite(&s) && s[3] >= 0.0 => (VolumeKind::Sphere, sphere_box(s)),
        (None, None, Some(s)) => {
            return Err(format!(
                "boundingVolume sphere [{}] has invalid values: centre and radius must be finite, the radius ≥ 0",
                plain(&s)
            ))
        }
        _ => return Err("boundingVolume has more than one of box, region and sphere".into()),
    };
    check_error(t.geometric_error)?;
    if t.content.is_some() && !t.contents.is_empty() {
        return Err("has both `content` and `contents` (3D Tiles 1.1 allows one of them)".into());
    }
    match t.refine.as_deref() {
        None | Some("ADD") | Some("REPLACE") => Ok(volume),
        Some(r) => Err(format!("refine is \"{r}\", not ADD or REPLACE")),
    }
}

/// A content or buffer URI as the relative file path it names (RFC 3986, as 3D Tiles and glTF use it): its query and
/// fragment dropped and its `%XX` escapes decoded. URIs with a scheme are kept as written (and refused where read).
pub fn uri_file_path(uri: &str) -> Result<String, String> {
    if uri.contains("://") || uri.starts_with("data:") {
        return Ok(uri.to_string());
    }
    let path = uri.split(['?', '#']).next().unwrap_or("");
    let mut bytes = Vec::with_capacity(path.len());
    let mut rest = path.as_bytes();
    while let Some((&b, tail)) = rest.split_first() {
        let hex = |c: u8| (c as char).to_digit(16);
        match (b, tail) {
            (b'%', [h, l, more @ ..]) if hex(*h).is_some() && hex(*l).is_some() => {
                bytes.push((hex(*h).unwrap_or(0) * 16 + hex(*l).unwrap_or(0)) as u8);
                rest = more;
            }
            _ => {
                bytes.push(b);
                rest = tail;
            }
        }
    }
    String::from_utf8(bytes).map_err(|_| format!("uri {uri:?} decodes to bytes that are not UTF-8"))
}

/// Whether a content path names a JSON file (an external tileset), whatever the case of its extension.
pub fn names_json(path: &str) -> bool {
    let b = path.as_bytes();
    b.len() >= 5 && b[b.len() - 5..].eq_ignore_ascii_case(b".json")
}

/// The file a content uri names, which must stay inside the tileset's folder (`folder`, canonical).
fn content_file(base: &Path, uri: &str, folder: &Path) -> Result<std::path::PathBuf, String> {
    local_file("content", base, uri, folder)
}

/// The file a uri of `what` (content, subtree) names, which must stay inside the tileset's folder (`folder`,
/// canonical).
fn local_file(
    what: &str,
    base: &Path,
    uri: &str,
    folder: &Path,
) -> Result<std::path::PathBuf, String> {
    if uri.contains("://") || uri.starts_with("data:") {
        return Err(format!(
            "{what} uri {uri:?} is not a relative file path (only local tilesets are read)"
        ));
    }
    let file = base.join(uri);
    let real =
        std::fs::canonicalize(&file).map_err(|e| format!("{what} {}: {e}", file.display()))?;
    if !real.starts_with(folder) {
        return Err(format!(
            "{what} uri {uri:?} points outside the tileset's folder"
        ));
    }
    Ok(file)
}

/// The explicit tree of `t` when it declares implicit tiling (`None` when it does not); subtree files are read
/// relative to `json`, the tileset.json holding `t`, and must lie inside `folder`.
fn expand_implicit(t: &tj::Tile, json: &Path, folder: &Path) -> Result<Option<tj::Tile>, String> {
    let Some(it) = crate::implicit::declared(t)? else {
        return Ok(None);
    };
    let base = json.parent().unwrap_or(Path::new(""));
    let open = |uri: &str| -> Result<Vec<u8>, String> {
        let file = local_file("file", base, uri, folder)?;
        read_file(&file).map_err(|e| e.to_string())
    };
    crate::implicit::expand(t, &it, &open).map(Some)
}

/// Where [`walk`] puts the tiles, and who sees each one first.
struct Walk<'a> {
    out: &'a mut Vec<TileData>,
    visit: &'a mut dyn FnMut(usize, &mut TileData),
    /// The root tileset's folder, canonical: content must lie inside it.
    folder: &'a Path,
    /// The inverse of the root transform: where `region` volumes (ECEF) go.
    ecef_to_root: [f64; 16],
    /// The root transform.
    root_to_ecef: [f64; 16],
    /// How often each external tileset (canonical path) has been followed so far.
    external: std::collections::HashMap<PathBuf, usize>,
    /// The content's glTF is z-up (the root tileset's `asset.gltfUpAxis`).
    z_up: bool,
}

/// Deepest tile the reader follows, counted in tiles below the root across external tilesets (an external
/// tileset's root is one level below its link): far beyond any real tree, well within the stack.
pub const MAX_TREE_LEVEL: usize = 512;

/// Most tiles one external tileset may hang under.
pub const MAX_EXTERNAL_COPIES: usize = 1024;

/// Where a tile sits: the tileset.json holding it, its path, how many external tilesets and how many tiles lie
/// above it.
struct Place<'a> {
    json: &'a Path,
    path: String,
    external_depth: usize,
    level: usize,
    /// The parent refines by ADD (a tile without `refine` takes its parent's).
    add: bool,
}

/// `parent_to_root` maps the parent tile's frame to the root frame (the product of the transforms below the
/// root's); `None` for the root itself, whose frame is the root frame whatever its transform.
fn walk(
    t: &tj::Tile,
    at: Place,
    parent_to_root: Option<&[f64; 16]>,
    w: &mut Walk,
) -> Result<usize, TilesError> {
    let explicit = expand_implicit(t, at.json, w.folder).map_err(|msg| TilesError::Tile {
        tile: format!("{} ({})", at.path, at.json.display()),
        msg,
    })?;
    if let Some(explicit) = explicit {
        return walk(&explicit, at, parent_to_root, w);
    }
    let Place {
        json,
        path,
        external_depth,
        level,
        add,
    } = at;
    let add = match t.refine.as_deref() {
        Some(r) => r == "ADD",
        None => add,
    };
    let fail = |msg: String| TilesError::Tile {
        tile: format!("{path} ({})", json.display()),
        msg,
    };
    if external_depth > 64 {
        return Err(fail(
            "external tilesets nested deeper than 64 (a cycle of external tilesets?)".into(),
        ));
    }
    if level > MAX_TREE_LEVEL {
        return Err(fail(format!(
            "the tree is deeper than {MAX_TREE_LEVEL} levels of tiles (across external tilesets), the most the \
             reader follows"
        )));
    }
    let (volume_kind, volume) = check_tile(t).map_err(fail)?;
    let to_root = match (parent_to_root, t.transform) {
        (None, _) => IDENTITY,
        (Some(p), None) => *p,
        (Some(p), Some(own)) => {
            if check_tile_transform(&own).is_none() {
                return Err(fail(
                    "transform is not an invertible affine transform: its content and children would not keep \
                     their shape"
                        .into(),
                ));
            }
            mul(p, &own)
        }
    };
    let bounding_box = match volume_kind {
        VolumeKind::Region => box_to_root(&w.ecef_to_root, volume),
        VolumeKind::Box | VolumeKind::Sphere => box_to_root(&to_root, volume),
    };
    if !bounding_box.iter().all(|v| v.is_finite()) {
        return Err(fail(format!(
            "boundingVolume {} is not finite in the root frame",
            volume_kind.name()
        )));
    }
    let uris: Vec<String> = t
        .content
        .iter()
        .chain(&t.contents)
        .map(|c| uri_file_path(&c.uri))
        .collect::<Result<_, _>>()
        .map_err(fail)?;
    if uris.len() > 1 {
        if let Some(u) = uris.iter().find(|u| names_json(u)) {
            return Err(fail(format!(
                "`contents` (multiple contents) names the external tileset {u:?}; only glb contents are \
                 supported in `contents`"
            )));
        }
    }
    let base = json.parent().unwrap_or(Path::new(""));
    let files = uris
        .iter()
        .map(|u| content_file(base, u, w.folder))
        .collect::<Result<Vec<_>, _>>()
        .map_err(fail)?;
    let exact_volume = match (t.bounding_volume.sphere, t.bounding_volume.region) {
        (Some(s), _) if volume_kind == VolumeKind::Sphere => {
            similarity_scale(&to_root).map(|k| ExactVolume::Sphere {
                centre: apply(&to_root, [s[0], s[1], s[2]]),
                radius_m: s[3] * k,
            })
        }
        (_, Some(region)) if volume_kind == VolumeKind::Region => Some(ExactVolume::Region {
            region,
            root_to_ecef: w.root_to_ecef,
        }),
        _ => None,
    };
    let me = w.out.len();
    w.out.push(TileData {
        path_in_tree: path.clone(),
        geometric_error_m: t.geometric_error,
        bounding_box: Some(bounding_box),
        volume_kind,
        exact_volume,
        content_uri: uris.first().cloned(),
        content_bytes: (!files.is_empty()).then(|| {
            files
                .iter()
                .filter_map(|f| std::fs::metadata(f).ok())
                .map(|m| m.len())
                .sum()
        }),
        content_uris: uris.clone(),
        content: None,
        children: Vec::new(),
        refine_add: add,
    });
    let mut children = Vec::new();
    if let [ext] = &files[..] {
        if names_json(&uris[0]) {
            // One external tileset may hang under several tiles (copies placed by their transforms), but a chain
            // of tilesets each naming the next twice is read 2ⁿ times: each file is followed a bounded number of
            // times.
            let canonical = std::fs::canonicalize(ext).unwrap_or_else(|_| ext.clone());
            let copies = w.external.entry(canonical).or_insert(0);
            *copies += 1;
            if *copies > MAX_EXTERNAL_COPIES {
                return Err(fail(format!(
                    "its content {:?} is an external tileset more than {MAX_EXTERNAL_COPIES} tiles name, the most \
                     the reader follows (tilesets that each name the next several times multiply)",
                    uris[0]
                )));
            }
            let ext_path = format!("{path}/ext");
            let ts = load_json(ext, &ext_path).map_err(|e| named_by_tile(e, &fail))?;
            let place = Place {
                json: ext,
                path: ext_path,
                external_depth: external_depth + 1,
                level: level + 1,
                add,
            };
            children.push(walk(&ts.root, place, Some(&to_root), w)?);
        }
    }
    if children.is_empty() && !files.is_empty() {
        let mut glb = GlbData::default();
        for file in &files {
            let bytes = read_file(file).map_err(|e| named_by_tile(e, &fail))?;
            glb.append(
                content_at_depth(&bytes, file, 0, w.z_up).map_err(|e| named_by_tile(e, &fail))?,
            );
        }
        for p in &mut glb.positions_local {
            *p = apply(&to_root, *p);
            if !p.iter().all(|c| c.is_finite()) {
                return Err(fail(
                    "a vertex of its content is not a finite point in the root frame (the tile transforms \
                     overflow)"
                        .into(),
                ));
            }
        }
        let nm = normal_matrix(&to_root);
        for n in &mut glb.normals_local {
            *n = transform_normal(&nm, *n);
        }
        w.out[me].content = Some(glb);
    }
    (w.visit)(me, &mut w.out[me]);
    for (k, c) in t.children.iter().enumerate() {
        let place = Place {
            json,
            path: format!("{path}/{k}"),
            external_depth,
            level: level + 1,
            add,
        };
        children.push(walk(c, place, Some(&to_root), w)?);
    }
    w.out[me].children = children;
    Ok(me)
}

impl GlbData {
    /// Appends another content's vertices, triangles and features (its feature ids and vertex indices shifted
    /// past this one's). Normals are kept only when both have them for every vertex.
    pub fn append(&mut self, other: GlbData) {
        let had_normals = self.normals_local.len() == self.positions_local.len();
        let vertex_base = self.positions_local.len() as u32;
        let feature_base = self.features.len() as u32;
        let keep_normals = (self.positions_local.is_empty() || had_normals)
            && other.normals_local.len() == other.positions_local.len();
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| t.map(|v| v.saturating_add(vertex_base))),
        );
        self.feature_ids.extend(other.feature_ids.iter().map(|&f| {
            if f == u32::MAX {
                f
            } else {
                f.saturating_add(feature_base)
            }
        }));
        self.positions_local.extend(other.positions_local);
        if keep_normals {
            self.normals_local.extend(other.normals_local);
        } else {
            self.normals_local.clear();
        }
        self.features.extend(other.features);
    }
}

/// Decodes a glb; positions are in the tile's frame (glTF y-up converted to z-up). `path` is only
/// used in errors and to resolve external buffer uris.
pub fn read_glb(bytes: &[u8], path: &Path) -> Result<GlbData, TilesError> {
    decode_glb(bytes, path, None, false)
}

/// Decodes tile content by its magic: glb, or the 3D Tiles 1.0 formats b3dm and cmpt ([`crate::legacy`]), `depth`
/// composites deep; i3dm, pnts and glTF JSON are refused by name. Positions in the tile's frame, as [`read_glb`].
/// `z_up`: the glTF inside is z-up (a tileset's `asset.gltfUpAxis` "Z"), not y-up as glTF itself has it.
fn content_at_depth(
    bytes: &[u8],
    path: &Path,
    depth: usize,
    z_up: bool,
) -> Result<GlbData, TilesError> {
    let err = |msg: String| TilesError::Glb {
        path: path.to_path_buf(),
        msg,
    };
    // JSON may open with a byte-order mark or white space.
    let json_start = bytes
        .strip_prefix("\u{feff}".as_bytes())
        .unwrap_or(bytes)
        .iter()
        .find(|b| !b.is_ascii_whitespace());
    match bytes.get(..4).unwrap_or(bytes) {
        b"b3dm" => {
            let b = crate::legacy::parse_b3dm(bytes).map_err(|m| err(format!("b3dm: {m}")))?;
            let mut glb = decode_glb(b.glb, path, Some(b.batch_length), z_up).map_err(|e| match e {
                TilesError::Glb { path, msg } => TilesError::Glb {
                    path,
                    msg: format!("b3dm: its glb: {msg}"),
                },
                e => e,
            })?;
            // Every feature is a model of the batch with at least one vertex of its own: a BATCH_LENGTH above the
            // vertex count is a count no glb backs (and would fill memory with empty rows).
            if b.batch_length > glb.positions_local.len() {
                return Err(err(format!(
                    "b3dm: its feature table's BATCH_LENGTH {} is more than the {} vertices of its glb",
                    b.batch_length,
                    glb.positions_local.len()
                )));
            }
            if let Some(c) = b.rtc_center {
                translate(&mut glb.positions_local, c);
            }
            let rows = b.rows().map_err(|m| err(format!("b3dm: {m}")))?;
            glb.features
                .extend(rows.into_iter().map(|values| FeatureRow {
                    class: BATCH_TABLE_CLASS.into(),
                    values,
                }));
            Ok(glb)
        }
        b"cmpt" => {
            if depth >= crate::legacy::MAX_COMPOSITE_DEPTH {
                return Err(err(format!(
                    "composite tiles nested deeper than {}",
                    crate::legacy::MAX_COMPOSITE_DEPTH
                )));
            }
            let mut out = GlbData::default();
            let mut cells = 0usize;
            for inner in crate::legacy::parse_cmpt(bytes).map_err(|m| err(format!("cmpt: {m}")))? {
                let tile = content_at_depth(inner, path, depth + 1, z_up)?;
                // The limits of one glb hold for the composite as a whole.
                cells += tile.features.iter().map(|f| f.values.len().max(1)).sum::<usize>();
                out.append(tile);
                if out.positions_local.len() > MAX_GLB_VERTICES
                    || cells > MAX_TABLE_CELLS
                {
                    return Err(err(format!(
                        "cmpt: its tiles hold more than {MAX_GLB_VERTICES} vertices or {} property values in all",
                        MAX_TABLE_CELLS
                    )));
                }
            }
            Ok(out)
        }
        b"i3dm" => Err(err(
            "instanced 3D model (i3dm) content is not read by citylod (it reads glb, b3dm and cmpt)".into(),
        )),
        b"pnts" => Err(err(
            "point cloud (pnts) content has no surfaces; citylod reads glb, b3dm and cmpt".into(),
        )),
        _ if json_start == Some(&b'{') => Err(err(
            "glTF JSON content (.gltf) is not read by citylod; write it as glb (e.g. gltf-pipeline -b)".into(),
        )),
        _ => decode_glb(bytes, path, None, z_up),
    }
}

/// Moves every point by `c` (a relative-to-centre offset: CESIUM_RTC, a b3dm's RTC_CENTER).
fn translate(points: &mut [[f64; 3]], c: [f64; 3]) {
    for p in points {
        *p = [p[0] + c[0], p[1] + c[1], p[2] + c[2]];
    }
}

/// The class of a b3dm's batch-table rows in [`GlbData::features`].
pub const BATCH_TABLE_CLASS: &str = "b3dm batch table";

/// `batch_length`: inside a b3dm, the features of its batch table, which the vertices' `_BATCHID` indexes.
fn decode_glb(
    bytes: &[u8],
    path: &Path,
    batch_length: Option<usize>,
    z_up: bool,
) -> Result<GlbData, TilesError> {
    let err = |msg: String| TilesError::Glb {
        path: path.to_path_buf(),
        msg,
    };
    let (json, bin) = parse_glb(bytes).map_err(err)?;
    let doc: Gltf = serde_json::from_slice(json).map_err(|source| TilesError::Json {
        path: path.to_path_buf(),
        source,
    })?;
    let base = path.parent().unwrap_or(Path::new("")).to_path_buf();
    Decoder {
        doc: &doc,
        bin,
        base,
        batch_length,
        z_up,
    }
    .decode()
    .map_err(err)
}

struct Decoder<'a> {
    doc: &'a Gltf,
    bin: &'a [u8],
    base: PathBuf,
    batch_length: Option<usize>,
    /// The glTF is z-up (`asset.gltfUpAxis` "Z" in its tileset), so positions are not turned from y-up.
    z_up: bool,
}

impl Decoder<'_> {
    fn decode(&self) -> Result<GlbData, String> {
        // glTF: a loader must not load an asset whose required extensions it does not support. Those that only
        // change materials, textures or lights leave the geometry as read.
        if let Some(x) = self.doc.extensions_required.iter().find(|x| {
            !(READ_EXTENSIONS.contains(&x.as_str())
                || APPEARANCE_PREFIXES.iter().any(|p| x.starts_with(p)))
        }) {
            return Err(format!(
                "it requires the glTF extension {x}, which citylod's reader does not decode"
            ));
        }
        let mut out = GlbData::default();
        let meta = self
            .doc
            .extensions
            .as_ref()
            .and_then(|e| e.structural_metadata.as_ref());
        let mut table_offsets = Vec::new();
        if let Some(meta) = meta {
            let schema = meta
                .schema
                .as_ref()
                .ok_or("property tables without an inline schema")?;
            for table in &meta.property_tables {
                table_offsets.push(out.features.len() as u32);
                let class = schema
                    .classes
                    .get(&table.class)
                    .ok_or_else(|| format!("class {} not in schema", table.class))?;
                if table.count > MAX_ELEMENTS
                    || table.count.saturating_mul(class.properties.len().max(1)) > MAX_TABLE_CELLS
                {
                    return Err(format!(
                        "property table of {} rows of {} properties: more than the {} values citylod's reader \
                         holds",
                        table.count,
                        class.properties.len(),
                        MAX_TABLE_CELLS
                    ));
                }
                let mut rows = vec![std::collections::BTreeMap::new(); table.count];
                for (name, col) in &table.properties {
                    let prop = class
                        .properties
                        .get(name)
                        .ok_or_else(|| format!("property {name} not in class {}", table.class))?;
                    if col.offset.is_some() || col.scale.is_some() {
                        return Err(format!(
                            "property table {}.{name}: offset or scaled properties are not supported by this reader",
                            table.class
                        ));
                    }
                    let values = self.view(col.values)?;
                    let offsets = match col.string_offsets {
                        Some(v) => Some(self.view(v)?),
                        None => None,
                    };
                    let ty = col.string_offset_type.as_deref().unwrap_or("UINT32");
                    let decoded = decode_column(
                        prop,
                        table.count,
                        &values,
                        offsets.as_deref().map(|o| (o, ty)),
                    )
                    .map_err(|m| format!("property table {}.{name}: {m}", table.class))?;
                    for (row, v) in rows.iter_mut().zip(decoded) {
                        row.insert(name.clone(), v);
                    }
                }
                // A property a table leaves out has no value for any of its features.
                for name in class.properties.keys() {
                    for row in rows.iter_mut() {
                        row.entry(name.clone()).or_insert(crate::PropValue::Null);
                    }
                }
                out.features
                    .extend(rows.into_iter().map(|values| FeatureRow {
                        class: table.class.clone(),
                        values,
                    }));
            }
        }
        let scene = self.doc.scenes.get(self.doc.scene.unwrap_or(0));
        let roots = scene.map(|s| s.nodes.clone()).unwrap_or_default();
        // glTF's nodes form trees: a node has one parent at most and a scene's roots none, else its meshes would be
        // read (and drawn) twice.
        let mut named = vec![false; self.doc.nodes.len()];
        for &c in roots
            .iter()
            .chain(self.doc.nodes.iter().flat_map(|n| &n.children))
        {
            if let Some(seen) = named.get_mut(c) {
                if std::mem::replace(seen, true) {
                    return Err(format!(
                        "node {c} has two parents (or is a scene root and a child)"
                    ));
                }
            }
        }
        for n in roots {
            self.node(n, &IDENTITY, &table_offsets, &mut out, 0)?;
        }
        // CESIUM_RTC: the positions (after glTF's y-up turn to z-up) are relative to a centre in the tile's frame.
        if let Some(rtc) = self
            .doc
            .extensions
            .as_ref()
            .and_then(|e| e.cesium_rtc.as_ref())
        {
            let c = rtc.center;
            if !c.iter().all(|v| v.is_finite()) {
                return Err(format!("CESIUM_RTC centre {c:?} is not a finite point"));
            }
            translate(&mut out.positions_local, c);
        }
        Ok(out)
    }

    /// glTF's y-up axes turned to the tile's z-up ones (x stays, −z is north, y is up); z-up glTF as it is.
    fn to_z_up(&self, g: [f64; 3]) -> [f64; 3] {
        if self.z_up {
            g
        } else {
            [g[0], -g[2], g[1]]
        }
    }

    fn node(
        &self,
        n: usize,
        parent: &[f64; 16],
        table_offsets: &[u32],
        out: &mut GlbData,
        depth: usize,
    ) -> Result<(), String> {
        let node = self.doc.nodes.get(n).ok_or("node index out of range")?;
        if depth > 64 {
            return Err("node hierarchy deeper than 64".into());
        }
        check_node_transform(node).map_err(|e| format!("node {n}: {e}"))?;
        let m = mul(parent, &node_matrix(node));
        // Numbers that overflow once squared (a scale of 1e300) are no transform.
        let big = m[..12].iter().fold(0.0f64, |b, v| b.max(v.abs()));
        if big.is_nan() || big >= 1e100 {
            return Err(format!(
                "node {n}: its transform with its parents' is not finite or too large ({big:e})"
            ));
        }
        // A singular transform (a scale of 0 hides a node, which glTF allows) flattens the mesh: it draws nothing.
        let flattened = affine_inverse(&m).is_none();
        if let Some(mi) = node.mesh.filter(|_| !flattened) {
            let mesh = self.doc.meshes.get(mi).ok_or("mesh index out of range")?;
            for prim in &mesh.primitives {
                let mode = prim.mode.unwrap_or(gj::MODE_TRIANGLES);
                if !(gj::MODE_TRIANGLES..=gj::MODE_TRIANGLE_FAN).contains(&mode) {
                    continue; // points and lines draw no surface
                }
                // Draco primitives: accessor values come from the decoded mesh, whose indices list triangles.
                let draco = self.draco(prim)?;
                let mode = if draco.is_some() {
                    gj::MODE_TRIANGLES
                } else {
                    mode
                };
                let get = |a: usize| -> Result<Vec<f64>, String> {
                    match draco.as_ref().and_then(|d| d.get(&a)) {
                        Some(v) => Ok(v.clone()),
                        None => self.accessor(a),
                    }
                };
                let pos_acc = *prim
                    .attributes
                    .get("POSITION")
                    .ok_or("primitive without POSITION")?;
                self.expect_kind(pos_acc, "POSITION", "VEC3", POSITION_TYPES)?;
                if let Some(&a) = prim.attributes.get("NORMAL") {
                    self.expect_kind(a, "NORMAL", "VEC3", NORMAL_TYPES)?;
                }
                if let Some(a) = prim.indices {
                    self.expect_kind(a, "indices", "SCALAR", INDEX_TYPES)?;
                }
                let pos = get(pos_acc)?;
                let v0 = out.positions_local.len() as u32;
                let nm = normal_matrix(&m);
                match prim.attributes.get("NORMAL") {
                    Some(&a) if out.normals_local.len() == out.positions_local.len() => {
                        for n in get(a)?.chunks_exact(3) {
                            let g = transform_normal(&nm, [n[0], n[1], n[2]]);
                            out.normals_local.push(self.to_z_up(g));
                        }
                    }
                    // A primitive without normals after one with: drop them all (mixed content).
                    _ => out.normals_local.clear(),
                }
                if out.positions_local.len() + pos.len() / 3 > MAX_GLB_VERTICES {
                    return Err(format!(
                        "more than {MAX_GLB_VERTICES} vertices in one glb (nodes drawing one mesh many times?)"
                    ));
                }
                for p in pos.chunks_exact(3) {
                    let g = apply(&m, [p[0], p[1], p[2]]);
                    if !g.iter().all(|c| c.is_finite()) {
                        return Err(format!(
                            "mesh {mi}: a vertex at {p:?} lies at {g:?} after its node's transform, not a finite point"
                        ));
                    }
                    out.positions_local.push(self.to_z_up(g));
                }
                let n_vertices = pos.len() / 3;
                if !out.normals_local.is_empty()
                    && out.normals_local.len() != out.positions_local.len()
                {
                    return Err(format!(
                        "mesh {mi}: its NORMAL accessor has another count than its POSITION accessor"
                    ));
                }
                let idx: Vec<u32> = match prim.indices {
                    Some(a) => get(a)?.iter().map(|&i| i as u32).collect(),
                    None => (0..n_vertices as u32).collect(),
                };
                if idx.iter().any(|&i| i as usize >= n_vertices) {
                    return Err("index out of range".into());
                }
                out.triangles
                    .extend(triangles_of(mode, &idx).map(|t| [t[0] + v0, t[1] + v0, t[2] + v0]));
                let fid_set = prim
                    .extensions
                    .as_ref()
                    .and_then(|e| e.mesh_features.as_ref())
                    .and_then(|f| f.feature_ids.first());
                let ids: Vec<u32> = match fid_set {
                    Some(set) => {
                        if set.texture.is_some() {
                            return Err("feature ids from a texture are not supported".into());
                        }
                        if set.offset.is_some() || set.repeat.is_some() {
                            return Err(
                                "feature ids with offset or repeat (a draft of EXT_mesh_features) are not supported"
                                    .into(),
                            );
                        }
                        // Where the table's rows start among the features, and how many it has: an id past them
                        // (a featureCount over the table's count) names no row.
                        let (offset, rows) = match set.property_table {
                            Some(t) => {
                                let start =
                                    *table_offsets.get(t).ok_or("property table out of range")?;
                                let end = table_offsets
                                    .get(t + 1)
                                    .copied()
                                    .unwrap_or(out.features.len() as u32);
                                (start, end.saturating_sub(start) as usize)
                            }
                            None => (0, usize::MAX),
                        };
                        // Without an attribute (or texture) the ids are implicit: each vertex's index.
                        let raw: Vec<f64> = match set.attribute {
                            Some(attr) => get(*prim
                                .attributes
                                .get(&format!("_FEATURE_ID_{attr}"))
                                .ok_or("feature id attribute missing")?)?,
                            None => (0..n_vertices).map(|v| v as f64).collect(),
                        };
                        raw.iter()
                            .map(|&f| {
                                let id = f as u32;
                                if Some(id) == set.null_feature_id
                                    || id as usize >= set.feature_count.min(rows)
                                {
                                    u32::MAX
                                } else {
                                    id.saturating_add(offset)
                                }
                            })
                            .collect()
                    }
                    // In a b3dm, `_BATCHID` (`BATCHID` before 3D Tiles 1.0) indexes the batch table, which follows
                    // any property tables of the glb's own.
                    None => match (
                        self.batch_length,
                        prim.attributes
                            .get("_BATCHID")
                            .or_else(|| prim.attributes.get("BATCHID")),
                    ) {
                        (Some(len), Some(&a)) => {
                            self.expect_kind(a, "_BATCHID", "SCALAR", BATCH_ID_TYPES)?;
                            let offset = out.features.len() as u32;
                            // 3D Tiles 1.0: every _BATCHID is a feature of the batch, 0 ≤ id < BATCH_LENGTH.
                            get(a)?
                                .iter()
                                .map(|&f| {
                                    if f >= 0.0 && f < len as f64 && f.fract() == 0.0 {
                                        Ok(f as u32 + offset)
                                    } else {
                                        Err(format!(
                                            "mesh {mi}: a vertex's _BATCHID {f} is not a feature of the batch \
                                             (0 to BATCH_LENGTH {len} − 1)"
                                        ))
                                    }
                                })
                                .collect::<Result<_, _>>()?
                        }
                        _ => vec![u32::MAX; n_vertices],
                    },
                };
                if ids.len() != n_vertices {
                    return Err("feature id count differs from vertex count".into());
                }
                out.feature_ids.extend(ids);
            }
        }
        for &c in &node.children {
            self.node(c, &m, table_offsets, out, depth + 1)?;
        }
        Ok(())
    }

    fn buffer(&self, i: usize) -> Result<Cow<'_, [u8]>, String> {
        let b = self.doc.buffers.get(i).ok_or("buffer index out of range")?;
        match &b.uri {
            // The BIN chunk may be padded past the buffer's length, never short of it.
            None if i == 0 => self
                .bin
                .get(..b.byte_length)
                .map(Cow::Borrowed)
                .ok_or_else(|| {
                    format!(
                        "buffer 0 claims {} bytes, the BIN chunk holds {}",
                        b.byte_length,
                        self.bin.len()
                    )
                }),
            None => Err(format!("buffer {i} has no data")),
            Some(uri) => {
                // Judged as the path it decodes to (`%2E%2E/` is `../`).
                let path = uri_file_path(uri)?;
                let p = Path::new(&path);
                if path.contains("://")
                    || path.starts_with("data:")
                    || p.is_absolute()
                    || p.components().any(|c| c == std::path::Component::ParentDir)
                {
                    return Err(format!("buffer uri {uri:?} is not a file beside the glb"));
                }
                read_file(&self.base.join(p))
                    .map(Cow::Owned)
                    .map_err(|e| format!("buffer {uri}: {e}"))
            }
        }
    }

    /// The bytes of a buffer view, decompressed when it uses EXT_meshopt_compression.
    fn view(&self, i: usize) -> Result<Vec<u8>, String> {
        let bv = self
            .doc
            .buffer_views
            .get(i)
            .ok_or("buffer view index out of range")?;
        if let Some(mo) = bv.extensions.as_ref().and_then(|e| e.meshopt.as_ref()) {
            let src = self.buffer(mo.buffer)?;
            let data = src
                .get(mo.byte_offset..mo.byte_offset.saturating_add(mo.byte_length))
                .ok_or("compressed view out of range")?;

            if mo.count.checked_mul(mo.byte_stride) != Some(bv.byte_length)
                || bv.byte_length > MAX_VIEW_BYTES
            {
                return Err(format!(
                    "compressed view {i}: count × stride does not match its length"
                ));
            }
            let mut bytes = decode_meshopt(data, &mo.mode, mo.byte_stride, mo.count)?;
            if let Some(filter) = mo.filter.as_deref().filter(|f| *f != "NONE") {
                unfilter_meshopt(&mut bytes, filter, mo.byte_stride)
                    .map_err(|e| format!("compressed view {i}: {e}"))?;
            }
            if bytes.len() != bv.byte_length {
                return Err("decompressed length differs from the buffer view length".into());
            }
            return Ok(bytes);
        }
        let src = self.buffer(bv.buffer)?;
        src.get(bv.byte_offset..bv.byte_offset.saturating_add(bv.byte_length))
            .map(<[u8]>::to_vec)
            .ok_or_else(|| format!("buffer view {i} out of range"))
    }

    /// For a KHR_draco_mesh_compression primitive, the decoded values of its attribute accessors
    /// and its index accessor (by accessor index; normalization applied); `None` otherwise.
    fn draco(
        &self,
        prim: &gj::Primitive,
    ) -> Result<Option<std::collections::BTreeMap<usize, Vec<f64>>>, String> {
        let Some(ext) = prim.extensions.as_ref().and_then(|e| e.draco.as_ref()) else {
            return Ok(None);
        };
        let bytes = self.view(ext.buffer_view)?;
        let names: Vec<&String> = ext.attributes.keys().collect();
        let ids: Vec<u32> = ext.attributes.values().copied().collect();
        let mesh = crate::draco::decode(&bytes, &ids)?;
        let mut out = std::collections::BTreeMap::new();
        for (name, values) in names.into_iter().zip(mesh.attributes) {
            let Some(&a) = prim.attributes.get(name) else {
                return Err(format!(
                    "Draco attribute {name} is not an attribute of the primitive"
                ));
            };
            let acc = self
                .doc
                .accessors
                .get(a)
                .ok_or("accessor index out of range")?;
            if acc.count != mesh.vertices {
                return Err(format!(
                    "Draco {name}: {} vertices, accessor says {}",
                    mesh.vertices, acc.count
                ));
            }
            let v = values
                .into_iter()
                .map(|x| normalize(acc.component_type, acc.normalized, x as f64))
                .collect();
            out.insert(a, v);
        }
        if let Some(i) = prim.indices {
            out.insert(i, mesh.indices.iter().map(|&k| k as f64).collect());
        }
        Ok(Some(out))
    }

    /// Fails unless accessor `i`, read as `what`, has this type and one of these component types (unnormalized
    /// integers or floats as listed; `true` for normalized).
    fn expect_kind(
        &self,
        i: usize,
        what: &str,
        r#type: &str,
        components: &[(u32, bool)],
    ) -> Result<(), String> {
        let a = self
            .doc
            .accessors
            .get(i)
            .ok_or("accessor index out of range")?;
        if a.r#type != r#type || !components.contains(&(a.component_type, a.normalized)) {
            return Err(format!(
                "accessor {i} ({what}) is {}{} of component type {}: {what} must be {type}{}",
                a.r#type,
                if a.normalized { ", normalized," } else { "" },
                a.component_type,
                if r#type == "SCALAR" {
                    " of unsigned integers"
                } else {
                    ""
                },
            ));
        }
        Ok(())
    }

    /// Accessor elements as f64, components flattened, normalization applied.
    fn accessor(&self, i: usize) -> Result<Vec<f64>, String> {
        let a = self
            .doc
            .accessors
            .get(i)
            .ok_or("accessor index out of range")?;
        let ncomp = match a.r#type.as_str() {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            t => return Err(format!("accessor type {t} not supported")),
        };
        let size = match a.component_type {
            gj::BYTE | gj::UNSIGNED_BYTE => 1,
            gj::SHORT | gj::UNSIGNED_SHORT => 2,
            gj::UNSIGNED_INT | gj::FLOAT => 4,
            c => return Err(format!("component type {c}")),
        };
        let value = |b: &[u8]| -> f64 {
            match a.component_type {
                gj::BYTE => {
                    let x = b[0] as i8 as f64;
                    if a.normalized {
                        (x / 127.0).max(-1.0)
                    } else {
                        x
                    }
                }
                gj::UNSIGNED_BYTE => b[0] as f64 / if a.normalized { 255.0 } else { 1.0 },
                gj::SHORT => {
                    let x = i16::from_le_bytes([b[0], b[1]]) as f64;
                    if a.normalized {
                        (x / 32767.0).max(-1.0)
                    } else {
                        x
                    }
                }
                gj::UNSIGNED_SHORT => {
                    u16::from_le_bytes([b[0], b[1]]) as f64
                        / if a.normalized { 65535.0 } else { 1.0 }
                }
                gj::UNSIGNED_INT => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                _ => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            }
        };
        let mut out = match a.buffer_view {
            Some(bv_index) => {
                let data = self.view(bv_index)?;
                let stride = self.doc.buffer_views[bv_index]
                    .byte_stride
                    .unwrap_or(ncomp * size);
                if stride < ncomp * size || stride > 252 {
                    return Err(format!(
                        "accessor {i}: byteStride {stride} lies outside {}–252 bytes (its elements' size to glTF's \
                         largest)",
                        ncomp * size
                    ));
                }
                let mut out =
                    Vec::with_capacity((a.count.min(MAX_ELEMENTS) * ncomp).min(data.len()));
                for e in 0..a.count {
                    for c in 0..ncomp {
                        let b = at(&data, a.byte_offset, e * stride + c * size, size)
                            .ok_or("accessor reads past its buffer view")?;
                        out.push(value(b));
                    }
                }
                out
            }
            // A sparse accessor without a buffer view starts from zeros (as many as a file could hold without one:
            // its count is not backed by bytes).
            None if a.sparse.is_some() && a.count <= MAX_ZERO_BASE_ELEMENTS => {
                vec![0.0; a.count * ncomp]
            }
            None if a.sparse.is_some() => {
                return Err(format!(
                    "accessor {i}: sparse without a buffer view and {} elements, more than the {MAX_ZERO_BASE_ELEMENTS} \
                     the reader makes from nothing",
                    a.count
                ))
            }
            None => return Err(format!("accessor {i} without buffer view")),
        };
        if let Some(sp) = &a.sparse {
            let isize = match sp.indices.component_type {
                gj::UNSIGNED_BYTE => 1,
                gj::UNSIGNED_SHORT => 2,
                gj::UNSIGNED_INT => 4,
                c => {
                    return Err(format!(
                        "accessor {i}: sparse indices of component type {c}"
                    ))
                }
            };
            let (indices, values) = (
                self.view(sp.indices.buffer_view)?,
                self.view(sp.values.buffer_view)?,
            );
            for k in 0..sp.count {
                let e = at(&indices, sp.indices.byte_offset, k * isize, isize)
                    .ok_or("sparse indices read past their buffer view")?
                    .iter()
                    .rev()
                    .fold(0usize, |acc, &b| acc << 8 | b as usize);
                if e >= a.count {
                    return Err(format!(
                        "accessor {i}: sparse index {e} past its {} elements",
                        a.count
                    ));
                }
                for c in 0..ncomp {
                    let b = at(&values, sp.values.byte_offset, (k * ncomp + c) * size, size)
                        .ok_or("sparse values read past their buffer view")?;
                    out[e * ncomp + c] = value(b);
                }
            }
        }
        Ok(out)
    }
}

/// A stored component value as the glTF accessor presents it (normalized integers to −1…1 or 0…1).
fn normalize(component_type: u32, normalized: bool, x: f64) -> f64 {
    if !normalized {
        return x;
    }
    match component_type {
        gj::BYTE => (x / 127.0).max(-1.0),
        gj::UNSIGNED_BYTE => x / 255.0,
        gj::SHORT => (x / 32767.0).max(-1.0),
        gj::UNSIGNED_SHORT => x / 65535.0,
        _ => x,
    }
}

/// The `len` bytes of `data` at `offset + pos`, `None` when they lie past its end or the sum overflows (offsets come
/// from the file). `pos` is bounded by the loops that make it (elements read so far times a small stride).
fn at(data: &[u8], offset: usize, pos: usize, len: usize) -> Option<&[u8]> {
    let start = offset.checked_add(pos)?;
    data.get(start..start.checked_add(len)?)
}

/// Undoes an EXT_meshopt_compression filter on decoded attribute bytes (little-endian elements of `stride` bytes):
/// octahedral unit vectors (4 × 8 or 16 bits), quaternions (4 × 16 bits), exponential floats (32-bit words) or
/// KHR_meshopt_compression's colours (4 × 8 or 16 bits).
fn unfilter_meshopt(bytes: &mut [u8], filter: &str, stride: usize) -> Result<(), String> {
    match (filter, stride) {
        ("OCTAHEDRAL", 4) => {
            let mut v: Vec<[i8; 4]> = bytes
                .chunks_exact(4)
                .map(|c| std::array::from_fn(|k| c[k] as i8))
                .collect();
            meshopt::decode_filter_oct(&mut v);
            bytes.copy_from_slice(&v.iter().flatten().map(|&b| b as u8).collect::<Vec<_>>());
        }
        ("OCTAHEDRAL" | "QUATERNION", 8) => {
            let mut v: Vec<[i16; 4]> = bytes
                .chunks_exact(8)
                .map(|c| std::array::from_fn(|k| i16::from_le_bytes([c[2 * k], c[2 * k + 1]])))
                .collect();
            if filter == "OCTAHEDRAL" {
                meshopt::decode_filter_oct(&mut v);
            } else {
                meshopt::decode_filter_quat(&mut v);
            }
            let out: Vec<u8> = v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
            bytes.copy_from_slice(&out);
        }
        ("COLOR", 4) => {
            let mut v: Vec<[u8; 4]> = bytes
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect();
            meshopt::decode_filter_color(&mut v);
            bytes.copy_from_slice(&v.concat());
        }
        ("COLOR", 8) => {
            let mut v: Vec<[u16; 4]> = bytes
                .chunks_exact(8)
                .map(|c| std::array::from_fn(|k| u16::from_le_bytes([c[2 * k], c[2 * k + 1]])))
                .collect();
            meshopt::decode_filter_color(&mut v);
            let out: Vec<u8> = v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
            bytes.copy_from_slice(&out);
        }
        ("EXPONENTIAL", s) if s % 4 == 0 => {
            // Each 32-bit word is decoded on its own, whatever the element it belongs to.
            let mut v: Vec<[u32; 1]> = bytes
                .chunks_exact(4)
                .map(|c| [u32::from_le_bytes([c[0], c[1], c[2], c[3]])])
                .collect();
            meshopt::decode_filter_exp(&mut v);
            let out: Vec<u8> = v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
            bytes.copy_from_slice(&out);
        }
        _ => {
            return Err(format!(
                "meshopt filter {filter} with stride {stride} is not supported"
            ))
        }
    }
    Ok(())
}

/// Decompresses one EXT_meshopt_compression view into `count × stride` bytes.
fn decode_meshopt(data: &[u8], mode: &str, stride: usize, count: usize) -> Result<Vec<u8>, String> {
    let fail = |e: meshopt::Error| format!("meshopt {mode} decoding failed: {e:?}");
    // Elements decoded as arrays of stride/4 words (the codec copies raw bytes; native order keeps them).
    macro_rules! attributes {
        ($($n:literal)*) => {
            match stride / 4 {
                $($n if stride % 4 == 0 => meshopt::decode_vertex_buffer::<[u32; $n]>(data, count)
                    .map_err(fail)?
                    .iter()
                    .flatten()
                    .flat_map(|w| w.to_ne_bytes())
                    .collect(),)*
                _ => return Err(format!("meshopt stride {stride} not supported")),
            }
        };
    }
    Ok(match (mode, stride) {
        ("ATTRIBUTES", _) => attributes!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16),
        ("TRIANGLES", 2) => meshopt::decode_index_buffer::<u16>(data, count)
            .map_err(fail)?
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect(),
        ("TRIANGLES", 4) => meshopt::decode_index_buffer::<u32>(data, count)
            .map_err(fail)?
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect(),
        ("INDICES", 2) => meshopt::decode_index_sequence::<u16>(data, count)
            .map_err(fail)?
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect(),
        ("INDICES", 4) => meshopt::decode_index_sequence::<u32>(data, count)
            .map_err(fail)?
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect(),
        _ => {
            return Err(format!(
                "meshopt mode {mode} with stride {stride} not supported"
            ))
        }
    })
}

/// Column-major 4×4 product a·b.
fn mul(a: &[f64; 16], b: &[f64; 16]) -> [f64; 16] {
    std::array::from_fn(|k| {
        let (col, row) = (k / 4, k % 4);
        (0..4).map(|i| a[i * 4 + row] * b[col * 4 + i]).sum()
    })
}

fn apply(m: &[f64; 16], p: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r])
}

/// A `box` bounding volume (centre, three half-axes) mapped by `m`: the centre moved, the half-axes by the
/// linear part. Exact for the identity.
fn box_to_root(m: &[f64; 16], b: [f64; 12]) -> [f64; 12] {
    if *m == IDENTITY {
        return b;
    }
    let c = apply(m, [b[0], b[1], b[2]]);
    let axis = |k: usize| -> [f64; 3] {
        let h = [b[3 + 3 * k], b[4 + 3 * k], b[5 + 3 * k]];
        std::array::from_fn(|r| m[r] * h[0] + m[4 + r] * h[1] + m[8 + r] * h[2])
    };
    let (x, y, z) = (axis(0), axis(1), axis(2));
    [
        c[0], c[1], c[2], x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2],
    ]
}

/// Whether a column-major 4×4 matrix has finite numbers and the last row 0 0 0 1.
fn is_finite_affine(m: &[f64; 16]) -> bool {
    m.iter().all(|v| v.is_finite()) && [m[3], m[7], m[11], m[15]] == [0.0, 0.0, 0.0, 1.0]
}

/// The inverse of a tile's `transform` when it is what 3D Tiles asks: finite, affine (last row 0 0 0 1) and
/// invertible.
fn check_tile_transform(m: &[f64; 16]) -> Option<[f64; 16]> {
    is_finite_affine(m).then(|| affine_inverse(m)).flatten()
}

/// Inverse of an affine column-major matrix (last row 0 0 0 1), `None` when singular or when its numbers overflow.
fn affine_inverse(m: &[f64; 16]) -> Option<[f64; 16]> {
    let a = |r: usize, c: usize| m[c * 4 + r];
    let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
        - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
    // Singular relative to the columns' lengths (Hadamard's bound), so that a tiny uniform scale still inverts.
    let column = |c: usize| a(0, c).hypot(a(1, c)).hypot(a(2, c));
    let bound = column(0) * column(1) * column(2);
    if !(det.is_finite() && bound.is_finite()) || det.abs() <= 1e-12 * bound {
        return None;
    }
    // Inverse of the 3×3 block by cofactors.
    let mut inv = [0.0; 16];
    for r in 0..3 {
        for c in 0..3 {
            let (r1, r2) = ((c + 1) % 3, (c + 2) % 3);
            let (c1, c2) = ((r + 1) % 3, (r + 2) % 3);
            inv[c * 4 + r] = (a(r1, c1) * a(r2, c2) - a(r1, c2) * a(r2, c1)) / det;
        }
    }
    let t = [a(0, 3), a(1, 3), a(2, 3)];
    for r in 0..3 {
        inv[12 + r] = -(0..3).map(|c| inv[c * 4 + r] * t[c]).sum::<f64>();
    }
    inv[15] = 1.0;
    Some(inv)
}

/// The inverse transpose of the linear part (column-major 4×4 with zero translation), which maps
/// normals; identity when singular.
fn normal_matrix(m: &[f64; 16]) -> [f64; 16] {
    let mut lin = *m;
    lin[12..15].fill(0.0);
    let inv = affine_inverse(&lin).unwrap_or(IDENTITY);
    std::array::from_fn(|k| {
        if k % 4 < 3 && k < 12 {
            inv[(k % 4) * 4 + k / 4]
        } else {
            IDENTITY[k]
        }
    })
}

fn transform_normal(nm: &[f64; 16], n: [f64; 3]) -> [f64; 3] {
    let v = apply(nm, n);
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if len > 0.0 {
        v.map(|c| c / len)
    } else {
        v
    }
}

/// glTF extensions the reader decodes or reads.
const READ_EXTENSIONS: &[&str] = &[
    "KHR_mesh_quantization",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_draco_mesh_compression",
    "EXT_mesh_features",
    "EXT_structural_metadata",
    "CESIUM_RTC",
];

/// Prefixes of glTF extensions that change only how surfaces look, which the reader does not need.
const APPEARANCE_PREFIXES: &[&str] = &[
    "KHR_materials_",
    "KHR_techniques_",
    "KHR_texture_",
    "EXT_texture_",
    "KHR_lights_",
];

/// Component types (with `normalized`) glTF and KHR_mesh_quantization allow for positions, normals and indices.
const POSITION_TYPES: &[(u32, bool)] = &[
    (gj::FLOAT, false),
    (gj::BYTE, false),
    (gj::BYTE, true),
    (gj::UNSIGNED_BYTE, false),
    (gj::UNSIGNED_BYTE, true),
    (gj::SHORT, false),
    (gj::SHORT, true),
    (gj::UNSIGNED_SHORT, false),
    (gj::UNSIGNED_SHORT, true),
];
const NORMAL_TYPES: &[(u32, bool)] = &[(gj::FLOAT, false), (gj::BYTE, true), (gj::SHORT, true)];
/// `_BATCHID`: unsigned integers (3D Tiles 1.0 b3dm), or signed ones and floats holding them (what some exporters
/// wrote; a value outside the batch is no feature).
const BATCH_ID_TYPES: &[(u32, bool)] = &[
    (gj::BYTE, false),
    (gj::SHORT, false),
    (gj::UNSIGNED_BYTE, false),
    (gj::UNSIGNED_SHORT, false),
    (gj::UNSIGNED_INT, false),
    (gj::FLOAT, false),
];
const INDEX_TYPES: &[(u32, bool)] = &[
    (gj::UNSIGNED_BYTE, false),
    (gj::UNSIGNED_SHORT, false),
    (gj::UNSIGNED_INT, false),
];

/// What glTF asks of a node's own transform: finite numbers, a `matrix` that is affine (last row 0 0 0 1) or a
/// translation, unit quaternion and scale, not both.
fn check_node_transform(n: &gj::Node) -> Result<(), String> {
    let trs = n.translation.is_some() || n.rotation.is_some() || n.scale.is_some();
    if let Some(m) = n.matrix {
        if trs {
            return Err("both a matrix and a translation, rotation or scale".into());
        }
        if !is_finite_affine(&m) {
            return Err(format!("matrix {m:?} is not a finite affine transform"));
        }
    }
    let finite = |v: &[f64]| v.iter().all(|c| c.is_finite());
    if !n.translation.is_none_or(|t| finite(&t)) || !n.scale.is_none_or(|s| finite(&s)) {
        return Err("a translation or scale that is not finite".into());
    }
    if let Some(q) = n.rotation {
        let len = q.iter().map(|c| c * c).sum::<f64>().sqrt();
        // Unit as glTF-Validator takes it (its tolerance for a unit-length 4-vector); `node_matrix` normalises.
        if (len - 1.0).abs().is_nan() || (len - 1.0).abs() > 0.00769 {
            return Err(format!("rotation {q:?} is not a unit quaternion"));
        }
    }
    Ok(())
}

/// The triangles of a primitive's index list in glTF's winding: as listed, or unrolled from a strip (every other
/// triangle turned back) or a fan.
fn triangles_of(mode: u32, idx: &[u32]) -> Box<dyn Iterator<Item = [u32; 3]> + '_> {
    match mode {
        gj::MODE_TRIANGLE_STRIP => Box::new(idx.windows(3).enumerate().map(|(k, w)| {
            if k % 2 == 0 {
                [w[0], w[1], w[2]]
            } else {
                [w[1], w[0], w[2]]
            }
        })),
        gj::MODE_TRIANGLE_FAN => {
            Box::new(idx.windows(2).skip(1).map(move |w| [idx[0], w[0], w[1]]))
        }
        _ => Box::new(idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]])),
    }
}

/// A node's local matrix: `matrix`, or translation · rotation · scale.
fn node_matrix(n: &gj::Node) -> [f64; 16] {
    if let Some(m) = n.matrix {
        return m;
    }
    let t = n.translation.unwrap_or([0.0; 3]);
    let q = n.rotation.unwrap_or([0.0, 0.0, 0.0, 1.0]);
    let len = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    let [x, y, z, w] = if len > 0.0 { q.map(|c| c / len) } else { q };
    let s = n.scale.unwrap_or([1.0; 3]);
    let r = [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y + z * w),
            2.0 * (x * z - y * w),
        ],
        [
            2.0 * (x * y - z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z + x * w),
        ],
        [
            2.0 * (x * z + y * w),
            2.0 * (y * z - x * w),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ];
    // r[c] is column c of the rotation.
    let mut m = IDENTITY;
    for c in 0..3 {
        for row in 0..3 {
            m[c * 4 + row] = r[c][row] * s[c];
        }
        m[12 + c] = t[c];
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn affine_inverse_undoes_enu_to_ecef() {
        let f = citylod_model::LocalFrame::new(4.36, 52.0, 3.0);
        let m = f.enu_to_ecef_column_major();
        let inv = affine_inverse(&m).unwrap();
        let p = [12.0, -40.0, 7.0];
        let q = apply(&inv, apply(&m, p));
        assert!((0..3).all(|i| (q[i] - p[i]).abs() < 1e-6), "{q:?}");
        let id = mul(&inv, &m);
        assert!((0..16).all(|i| (id[i] - IDENTITY[i]).abs() < 1e-9));
    }

    #[test]
    fn node_rotation_about_z_turns_x_into_y() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let n = gj::Node {
            rotation: Some([0.0, 0.0, h, h]),
            translation: Some([1.0, 2.0, 3.0]),
            ..Default::default()
        };
        let p = apply(&node_matrix(&n), [1.0, 0.0, 0.0]);
        assert!(
            (p[0] - 1.0).abs() < 1e-12 && (p[1] - 3.0).abs() < 1e-12 && (p[2] - 3.0).abs() < 1e-12,
            "{p:?}"
        );
    }

    #[test]
    fn invalid_tiles_and_content_outside_the_folder_are_errors() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("ts");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(root.path().join("outside.glb"), b"glTF").unwrap();
        let bx = serde_json::json!({"box": [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]});
        let cases = [
            (serde_json::json!({}), "REPLACE", None, "none of box"),
            (
                serde_json::json!({"sphere": [0, 0, 0, -5]}),
                "REPLACE",
                None,
                "invalid values",
            ),
            (
                serde_json::json!({"region": [0.1, 0.5, 0.2, 0.4, 0, 10]}),
                "REPLACE",
                None,
                "south ≤ north",
            ),
            (
                serde_json::json!({"box": [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1], "sphere": [0, 0, 0, 1]}),
                "ADD",
                None,
                "more than one",
            ),
            (bx.clone(), "FOO", None, "not ADD or REPLACE"),
            (
                bx.clone(),
                "REPLACE",
                Some("../outside.glb"),
                "outside the tileset's folder",
            ),
            (
                bx.clone(),
                "REPLACE",
                Some("/dev/zero"),
                "outside the tileset's folder",
            ),
            (
                bx.clone(),
                "REPLACE",
                Some("https://example.com/a.glb"),
                "not a relative file path",
            ),
        ];
        for (bv, refine, uri, expect) in cases {
            let mut tile =
                serde_json::json!({"boundingVolume": bv, "geometricError": 0, "refine": refine});
            if let Some(u) = uri {
                tile["content"] = serde_json::json!({"uri": u});
            }
            let ts =
                serde_json::json!({"asset": {"version": "1.1"}, "geometricError": 1, "root": tile});
            std::fs::write(dir.join("tileset.json"), ts.to_string()).unwrap();
            let e = read_tileset(&dir.join("tileset.json"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(expect), "{expect}: {e}");
        }
        // A well-formed one reads.
        let ts = serde_json::json!({"asset": {"version": "1.1"}, "geometricError": 1,
            "root": {"boundingVolume": bx, "geometricError": 0, "refine": "REPLACE"}});
        std::fs::write(dir.join("tileset.json"), ts.to_string()).unwrap();
        assert_eq!(
            read_tileset(&dir.join("tileset.json")).unwrap().tiles.len(),
            1
        );
    }

    /// Tile transforms that are not invertible affine maps (found by fuzzing: a child's zero transform collapsed its
    /// content unnoticed, where the root's was refused) are errors, and so is an external tileset followed too often
    /// (a chain of files naming the next twice is read 2ⁿ times: 25 files hung `inspect` and ate memory).
    #[test]
    fn bad_tile_transforms_and_external_tilesets_followed_too_often_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let bx = serde_json::json!({"box": [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]});
        let write = |name: &str, root: serde_json::Value| {
            let ts =
                serde_json::json!({"asset": {"version": "1.1"}, "geometricError": 1, "root": root});
            std::fs::write(dir.path().join(name), ts.to_string()).unwrap();
            dir.path().join(name)
        };
        let leaf = |transform: serde_json::Value| serde_json::json!({"boundingVolume": bx, "geometricError": 0, "transform": transform});
        let mut projective: Vec<f64> = IDENTITY.to_vec();
        projective[15] = 0.0;
        let zero = vec![0.0; 16];
        let error = |p: &Path| read_tileset(p).unwrap_err().to_string();
        for (name, t) in [("zero", &zero), ("projective", &projective)] {
            let child = write(
                &format!("child-{name}.json"),
                serde_json::json!({"boundingVolume": bx, "geometricError": 1, "children": [leaf(serde_json::json!(t))]}),
            );
            let e = error(&child);
            assert!(
                e.contains("tile 0/0") && e.contains("not an invertible affine transform"),
                "{e}"
            );
            let root = write(&format!("root-{name}.json"), leaf(serde_json::json!(t)));
            assert!(error(&root).contains("root transform is not an invertible affine transform"));
        }
        // One external tileset under two tiles (copies placed by their transforms) reads, twice.
        write(
            "ext.json",
            serde_json::json!({"boundingVolume": bx, "geometricError": 0}),
        );
        let under = |uri: &str, east: f64| {
            let mut t: Vec<f64> = IDENTITY.to_vec();
            t[12] = east;
            serde_json::json!({"boundingVolume": bx, "geometricError": 0.5, "transform": t, "content": {"uri": uri}})
        };
        let twice = write(
            "twice.json",
            serde_json::json!({"boundingVolume": bx, "geometricError": 1,
                "children": [under("ext.json", 0.0), under("./ext.json", 100.0)]}),
        );
        let tiles = read_tileset(&twice).unwrap().tiles;
        assert_eq!(tiles.len(), 5);
        assert_eq!(
            tiles
                .iter()
                .filter(|t| t.path_in_tree.ends_with("/ext"))
                .count(),
            2
        );
        // A chain of twelve files, each naming the next twice, would be read 2¹¹ times at its end: refused once a
        // file is followed more than MAX_EXTERNAL_COPIES times.
        write(
            "c11.json",
            serde_json::json!({"boundingVolume": bx, "geometricError": 0}),
        );
        for k in (0..11).rev() {
            let next = format!("c{}.json", k + 1);
            write(
                &format!("c{k}.json"),
                serde_json::json!({"boundingVolume": bx, "geometricError": 1,
                    "children": [under(&next, 0.0), under(&next, 0.0)]}),
            );
        }
        let e = error(&dir.path().join("c0.json"));
        assert!(
            e.contains("\"c11.json\" is an external tileset more than 1024 tiles name"),
            "{e}"
        );
        assert!(read_tileset(&dir.path().join("c2.json")).is_ok());
    }

    #[test]
    fn boxes_come_in_the_root_frame_through_inner_transforms() {
        let dir = tempfile::tempdir().unwrap();
        let bx = |c: f64| serde_json::json!({"box": [c, 0, 0, 2, 0, 0, 0, 1, 0, 0, 0, 1]});
        // The root's own transform (far from the origin) defines the root frame; the child turns by 90° about z
        // and moves 100 m east, the grandchild another 10 m along the child's x (north in the root frame).
        let mut far = IDENTITY;
        far[12..15].copy_from_slice(&[1.3e6, -4.6e6, 4.1e6]);
        let turn = [
            0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 100.0, 0.0, 0.0, 1.0,
        ];
        let ts = serde_json::json!({"asset": {"version": "1.1"}, "geometricError": 1, "root": {
            "boundingVolume": bx(5.0), "geometricError": 1, "refine": "REPLACE", "transform": far,
            "children": [{"boundingVolume": bx(0.0), "geometricError": 0, "transform": turn,
                "children": [{"boundingVolume": bx(10.0), "geometricError": 0}]}]}});
        std::fs::write(dir.path().join("tileset.json"), ts.to_string()).unwrap();
        let back = read_tileset(&dir.path().join("tileset.json")).unwrap();
        let b: Vec<[f64; 12]> = back.tiles.iter().map(|t| t.bounding_box.unwrap()).collect();
        assert_eq!(
            b[0],
            [5.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        );
        let close =
            |a: [f64; 12], e: [f64; 12]| a.iter().zip(e).all(|(x, y)| (x - y).abs() < 1e-12);
        let turned = |cy: f64| [100.0, cy, 0.0, 0.0, 2.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        assert!(close(b[1], turned(0.0)), "{:?}", b[1]);
        assert!(close(b[2], turned(10.0)), "{:?}", b[2]);
    }

    /// A glb of two triangles, one feature, in this compression.
    fn two_triangles(c: crate::Compression) -> Vec<u8> {
        use crate::spec::*;
        let schema = MetadataSchema {
            id: "s".into(),
            classes: vec![ClassDef {
                id: "c".into(),
                properties: vec![PropertyDef {
                    name: "n".into(),
                    kind: PropertyKind::String,
                    description: None,
                    nullable: true,
                    string_no_data: None,
                    input_name: None,
                }],
            }],
        };
        let mesh = citylod_model::Mesh3d {
            positions: vec![
                [0.0, 0.0, 0.0],
                [4.0, 0.0, 0.0],
                [0.0, 4.0, 2.0],
                [4.0, 4.0, 2.0],
            ],
            triangles: vec![[0, 1, 2], [1, 3, 2]],
        };
        let f = ContentFeature {
            mesh,
            class: 0,
            values: vec![PropValue::Str("x".into())],
            max_rounding_m: 0.0,
        };
        crate::content::encode_content(
            "0",
            std::slice::from_ref(&f),
            &schema,
            &crate::content::ContentOptions {
                compression: c,
                normals: true,
                quantization_step_m: 0.02,
            },
            "t",
        )
        .unwrap()
        .unwrap()
        .glb
    }

    /// `refine` is inherited: a tile without one refines as its parent does.
    #[test]
    fn refine_add_is_read_and_inherited() {
        let dir = tempfile::tempdir().unwrap();
        let bx = serde_json::json!({"box": [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]});
        let leaf = serde_json::json!({"boundingVolume": bx, "geometricError": 0});
        let mut replace = leaf.clone();
        replace["refine"] = "REPLACE".into();
        replace["children"] = serde_json::json!([leaf]);
        let ts = serde_json::json!({"asset": {"version": "1.1"}, "geometricError": 1,
            "root": {"boundingVolume": bx, "geometricError": 1, "refine": "ADD", "children": [leaf, replace]}});
        let p = dir.path().join("tileset.json");
        std::fs::write(&p, ts.to_string()).unwrap();
        let add: Vec<(String, bool)> = read_tileset(&p)
            .unwrap()
            .tiles
            .into_iter()
            .map(|t| (t.path_in_tree, t.refine_add))
            .collect();
        let want = [("0", true), ("0/0", true), ("0/1", false), ("0/1/0", false)];
        assert_eq!(add, want.map(|(p, a)| (p.to_string(), a)));
    }

    /// URIs name files as RFC 3986 has it: query and fragment dropped, `%XX` decoded; `.JSON` is JSON too.
    #[test]
    fn uris_become_file_paths() {
        assert_eq!(
            uri_file_path("tiles/a%20b.glb?v=2#x").unwrap(),
            "tiles/a b.glb"
        );
        assert_eq!(uri_file_path("caf%C3%A9.glb").unwrap(), "café.glb");
        assert_eq!(uri_file_path("100%.glb").unwrap(), "100%.glb");
        assert!(uri_file_path("%FF.glb").is_err());
        assert_eq!(
            uri_file_path("https://x/a%20b.glb").unwrap(),
            "https://x/a%20b.glb"
        );
        assert!(names_json("ext/EXT.JSON") && names_json("a.json") && !names_json("a.glb"));
        assert!(!names_json("é") && !names_json("ééé.glb"));
    }

    /// EXT_meshopt_compression's filters undone as meshoptimizer encodes them: octahedral normals (8 and 16 bits),
    /// exponential floats, KHR_meshopt_compression's colours; a filter the reader does not know is refused.
    #[test]
    fn meshopt_filters_are_undone() {
        let n = [0.6f32, 0.0, 0.8, 0.0];
        let oct8: Vec<[i8; 4]> = meshopt::encode_filter_oct(&[n], 8);
        let mut b: Vec<u8> = oct8[0].iter().map(|&x| x as u8).collect();
        unfilter_meshopt(&mut b, "OCTAHEDRAL", 4).unwrap();
        let got: Vec<f64> = b[..3].iter().map(|&x| f64::from(x as i8) / 127.0).collect();
        assert!(
            got.iter()
                .zip(&n)
                .all(|(g, w)| (g - f64::from(*w)).abs() < 0.02),
            "{got:?}"
        );
        let oct16: Vec<[i16; 4]> = meshopt::encode_filter_oct(&[n], 16);
        let mut b: Vec<u8> = oct16[0].iter().flat_map(|x| x.to_le_bytes()).collect();
        unfilter_meshopt(&mut b, "OCTAHEDRAL", 8).unwrap();
        let z = f64::from(i16::from_le_bytes([b[4], b[5]])) / 32767.0;
        assert!((z - 0.8).abs() < 1e-3, "{z}");
        let floats = [[1234.5f32, -0.001, 7.0]];
        let exp = meshopt::encode_filter_exp(&floats, 24, meshopt::EncodeExpMode::Separate);
        let mut b: Vec<u8> = exp[0].iter().flat_map(|x| x.to_le_bytes()).collect();
        unfilter_meshopt(&mut b, "EXPONENTIAL", 12).unwrap();
        let got: Vec<f32> = b
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert!(
            got.iter()
                .zip(&floats[0])
                .all(|(g, w)| (g - w).abs() <= w.abs() * 1e-5),
            "{got:?}"
        );
        let rgba = [0.8f32, 0.4, 0.2, 1.0];
        let col: Vec<[u8; 4]> = meshopt::encode_filter_color(&[rgba], 8);
        let mut c = col[0].to_vec();
        unfilter_meshopt(&mut c, "COLOR", 4).unwrap();
        assert!(
            c.iter()
                .zip(&rgba)
                .all(|(&g, &w)| (f32::from(g) / 255.0 - w).abs() < 0.02),
            "{c:?}"
        );
        assert!(unfilter_meshopt(&mut b, "COLOR", 12).is_err());
        assert!(unfilter_meshopt(&mut b, "WAVELET", 4).is_err());
    }

    /// Strips and fans unroll into glTF's triangles, all wound like the first.
    #[test]
    fn strips_and_fans_unroll_into_triangles() {
        let idx = [0, 1, 2, 3, 4];
        let list = |mode| triangles_of(mode, &idx).collect::<Vec<_>>();
        assert_eq!(list(gj::MODE_TRIANGLES), vec![[0, 1, 2]]);
        assert_eq!(
            list(gj::MODE_TRIANGLE_STRIP),
            vec![[0, 1, 2], [2, 1, 3], [2, 3, 4]]
        );
        assert_eq!(
            list(gj::MODE_TRIANGLE_FAN),
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]
        );
        assert!(triangles_of(gj::MODE_TRIANGLE_STRIP, &idx[..2])
            .next()
            .is_none());
    }

    /// A sparse accessor replaces the elements it lists: vertex 1 given vertex 3's stored position reads there.
    #[test]
    fn sparse_accessors_replace_the_elements_they_list() {
        let glb = two_triangles(crate::Compression::None);
        let (json, bin) = crate::glb::parse_glb(&glb).unwrap();
        let mut d: serde_json::Value = serde_json::from_slice(json).unwrap();
        let pos = d["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
            .as_u64()
            .unwrap() as usize;
        let acc = d["accessors"][pos].clone();
        assert!(acc.get("sparse").is_none());
        let bv = &d["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
        let size = match acc["componentType"].as_u64().unwrap() {
            5126 => 4,
            5122 | 5123 => 2,
            _ => 1,
        };
        let stride = bv["byteStride"].as_u64().map_or(3 * size, |s| s as usize);
        let at = bv["byteOffset"].as_u64().unwrap_or(0) as usize
            + acc["byteOffset"].as_u64().unwrap_or(0) as usize
            + 3 * stride;
        let mut bin = bin.to_vec();
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let (idx_at, val_at) = (bin.len(), bin.len() + 4);
        bin.extend([1u8, 0, 0, 0]); // index 1 as u16, padded
        let stored = bin[at..at + 3 * size].to_vec();
        bin.extend(&stored);
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let views = d["bufferViews"].as_array_mut().unwrap();
        views.push(serde_json::json!({"buffer": 0, "byteOffset": idx_at, "byteLength": 2}));
        views.push(serde_json::json!({"buffer": 0, "byteOffset": val_at, "byteLength": 3 * size}));
        let n = views.len();
        d["accessors"][pos]["sparse"] = serde_json::json!({"count": 1,
            "indices": {"bufferView": n - 2, "componentType": 5123}, "values": {"bufferView": n - 1}});
        d["buffers"][0]["byteLength"] = bin.len().into();
        let read = read_glb(
            &crate::glb::write_glb(d.to_string().as_bytes(), &bin),
            Path::new("t.glb"),
        )
        .unwrap();
        let plain = read_glb(&glb, Path::new("t.glb")).unwrap();
        assert_ne!(plain.positions_local[1], plain.positions_local[3]);
        assert_eq!(read.positions_local[1], plain.positions_local[3]);
        assert_eq!(read.positions_local[0], plain.positions_local[0]);
    }

    /// glTF that parses but breaks the format's rules, each found by fuzzing `citylod check` (a panic on a NaN, or
    /// content silently collapsed, garbled or thrown to infinity): an error naming what is wrong.
    #[test]
    fn glbs_with_broken_transforms_or_accessors_are_errors() {
        let glb = two_triangles(crate::Compression::None);
        let path = Path::new("t.glb");
        let (json, bin) = crate::glb::parse_glb(&glb).unwrap();
        let doc: serde_json::Value = serde_json::from_slice(json).unwrap();
        let with = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut d = doc.clone();
            edit(&mut d);
            read_glb(&crate::glb::write_glb(d.to_string().as_bytes(), bin), path)
        };
        let identity: Vec<f64> = IDENTITY.to_vec();
        let turn = [0.0, 0.0, 0.5f64.sqrt(), 0.5f64.sqrt()];
        // As written, and under a proper rotation and matrix, the content reads.
        assert_eq!(with(&|_| {}).unwrap().triangles.len(), 2);
        assert!(with(&|d| d["nodes"][0]["rotation"] = serde_json::json!(turn)).is_ok());
        // A quaternion a little off unit length, as exporters write them (as glTF-Validator allows), and a tiny
        // uniform scale: both read.
        assert!(
            with(&|d| d["nodes"][0]["rotation"] = serde_json::json!([0, 0, 0.707, 0.707])).is_ok()
        );
        assert!(
            with(&|d| d["nodes"][0]["scale"] = serde_json::json!([1e-100, 1e-100, 1e-100])).is_ok()
        );
        // The node's translation and scale as one matrix.
        let as_matrix = |d: &mut serde_json::Value| {
            let node = d["nodes"][0].as_object_mut().unwrap();
            let t = node
                .remove("translation")
                .map_or(vec![0.0; 3], |v| serde_json::from_value(v).unwrap());
            let s = node
                .remove("scale")
                .map_or(vec![1.0; 3], |v| serde_json::from_value(v).unwrap());
            let mut m = identity.clone();
            (0..3).for_each(|k| (m[5 * k], m[12 + k]) = (s[k], t[k]));
            node.insert("matrix".into(), serde_json::json!(m));
        };
        let by_matrix = with(&as_matrix).unwrap();
        assert_eq!(
            by_matrix.positions_local,
            with(&|_| {}).unwrap().positions_local
        );
        // A scale of 0 (glTF's way to hide a node) flattens the mesh: it draws nothing. Materials read with glTF's
        // defaults for what they leave out; extensions required only for looks do not stop the reader.
        assert!(
            with(&|d| d["nodes"][0]["scale"] = serde_json::json!([1, 0, 1]))
                .unwrap()
                .triangles
                .is_empty()
        );
        // (KHR_techniques_webgl: the shaders of b3dm content upgraded from glTF 1.0.)
        for looks in ["KHR_materials_unlit", "KHR_techniques_webgl"] {
            let plain = with(&|d| {
                d["materials"] = serde_json::json!([{}, {"pbrMetallicRoughness": {}}]);
                d["extensionsUsed"] = serde_json::json!([looks]);
                d["extensionsRequired"] = serde_json::json!([looks]);
            });
            assert_eq!(plain.unwrap().triangles.len(), 2, "{looks}");
        }
        // CESIUM_RTC moves every position by its centre (z up, after glTF's y-up turn), required or not.
        let base = with(&|_| {}).unwrap();
        for required in [false, true] {
            let rtc = with(&|d| {
                d["extensions"]["CESIUM_RTC"] =
                    serde_json::json!({"center": [100.0, 200.0, 300.0]});
                d["extensionsUsed"]
                    .as_array_mut()
                    .unwrap()
                    .push("CESIUM_RTC".into());
                if required {
                    d["extensionsRequired"] = serde_json::json!(["CESIUM_RTC"]);
                }
            })
            .unwrap();
            for (p, q) in rtc.positions_local.iter().zip(&base.positions_local) {
                assert_eq!(*p, [q[0] + 100.0, q[1] + 200.0, q[2] + 300.0]);
            }
        }
        // Feature ids without an attribute are implicit, the vertex index (ids past feature_count 1 are none);
        // ids from a texture are refused.
        let fids = "/meshes/0/primitives/0/extensions/EXT_mesh_features/featureIds/0";
        let implicit = with(&|d| {
            d.pointer_mut(fids)
                .unwrap()
                .as_object_mut()
                .unwrap()
                .remove("attribute");
        })
        .unwrap();
        assert_eq!(implicit.feature_ids, vec![0, u32::MAX, u32::MAX, u32::MAX]);
        let texture = with(&|d| {
            let f = d.pointer_mut(fids).unwrap().as_object_mut().unwrap();
            f.remove("attribute");
            f.insert("texture".into(), serde_json::json!({"index": 0}));
        });
        assert!(texture.unwrap_err().to_string().contains("from a texture"));
        let msg = |edit: &dyn Fn(&mut serde_json::Value)| with(edit).unwrap_err().to_string();
        for (edit, says) in [
            (
                Box::new(|d: &mut serde_json::Value| {
                    d["nodes"][0]["rotation"] = serde_json::json!([1e300, 0, 0, 1e300])
                }) as Box<dyn Fn(&mut serde_json::Value)>,
                "not a unit quaternion",
            ),
            (
                Box::new(|d: &mut serde_json::Value| {
                    d["nodes"][0]["scale"] = serde_json::json!([1e300, 1e300, 1e300])
                }),
                "not finite or too large",
            ),
            (
                Box::new(|d: &mut serde_json::Value| {
                    d["extensionsRequired"] = serde_json::json!(["EXT_mesh_gpu_instancing"])
                }),
                "requires the glTF extension EXT_mesh_gpu_instancing",
            ),
            (
                Box::new(|d: &mut serde_json::Value| {
                    d["nodes"] = serde_json::json!([{"children": [2]}, {"children": [2]}, d["nodes"][0].clone()]);
                    d["scenes"][0]["nodes"] = serde_json::json!([0, 1]);
                }),
                "node 2 has two parents",
            ),
            (
                Box::new(|d: &mut serde_json::Value| {
                    d["bufferViews"][0]["byteStride"] = serde_json::json!(0)
                }),
                "byteStride 0 lies outside",
            ),
            // A buffer outside the glb's folder, however its URI spells `..`.
            (
                Box::new(|d: &mut serde_json::Value| {
                    d["buffers"][0]["uri"] = "%2E%2E/secret.bin".into()
                }),
                "is not a file beside the glb",
            ),
            // The draft extension's feature ids.
            (
                Box::new(|d: &mut serde_json::Value| {
                    let f = d
                        .pointer_mut(
                            "/meshes/0/primitives/0/extensions/EXT_mesh_features/featureIds/0",
                        )
                        .unwrap();
                    f["offset"] = 0.into();
                    f["repeat"] = 1.into();
                }),
                "offset or repeat",
            ),
            // Metadata the reader would misread as plain values.
            (
                Box::new(|d: &mut serde_json::Value| {
                    let m = &mut d["extensions"]["EXT_structural_metadata"];
                    m["schema"]["classes"]["c"]["properties"]["n"]["array"] = true.into();
                }),
                "array properties are not supported",
            ),
            (
                Box::new(|d: &mut serde_json::Value| {
                    let m = &mut d["extensions"]["EXT_structural_metadata"];
                    m["propertyTables"][0]["properties"]["n"]["offset"] = 1.into();
                }),
                "offset or scaled properties are not supported",
            ),
            (
                Box::new(move |d: &mut serde_json::Value| {
                    as_matrix(d);
                    d["nodes"][0]["matrix"] = serde_json::json!([1e308f64; 16].to_vec())
                }),
                "not a finite affine transform",
            ),
            (
                Box::new(move |d: &mut serde_json::Value| {
                    as_matrix(d);
                    let mut m = IDENTITY;
                    m[3] = 1.0; // projective
                    d["nodes"][0]["matrix"] = serde_json::json!(m);
                }),
                "not a finite affine transform",
            ),
            (
                Box::new(move |d: &mut serde_json::Value| {
                    as_matrix(d);
                    d["nodes"][0]["translation"] = serde_json::json!([1, 2, 3]);
                }),
                "both a matrix and",
            ),
            (
                Box::new(|d: &mut serde_json::Value| {
                    d["nodes"][0]["scale"] = serde_json::json!([1e308, 1, 1])
                }),
                "not finite or too large",
            ),
            (
                Box::new(|d: &mut serde_json::Value| {
                    let prim = &mut d["meshes"][0]["primitives"][0];
                    prim["indices"] = prim["attributes"]["POSITION"].clone();
                }),
                "indices must be SCALAR of unsigned integers",
            ),
            (
                Box::new(|d: &mut serde_json::Value| {
                    d["buffers"][0]["byteLength"] = serde_json::json!(1_000_000_000)
                }),
                "the BIN chunk holds",
            ),
            (
                Box::new(|d: &mut serde_json::Value| {
                    d["buffers"][0]["byteLength"] = serde_json::json!(0)
                }),
                "out of range",
            ),
        ] {
            let m = msg(&*edit);
            assert!(m.contains(says), "{m}");
        }
    }

    #[test]
    fn corrupt_glbs_give_errors_not_panics() {
        for c in [
            crate::Compression::Meshopt,
            crate::Compression::None,
            crate::Compression::Draco,
        ] {
            let glb = two_triangles(c);
            let path = Path::new("t.glb");
            assert_eq!(read_glb(&glb, path).unwrap().triangles.len(), 2);
            // Every cut is shorter than the length the header gives: always an error.
            for cut in (0..glb.len()).step_by(7) {
                assert!(read_glb(&glb[..cut], path).is_err(), "{c:?} cut at {cut}");
            }
            let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
            for at in (20 + json_len..glb.len()).step_by(3) {
                let mut bad = glb.clone();
                bad[at] ^= 0x5a;
                let _ = read_glb(&bad, path);
            }
            let (json, bin) = crate::glb::parse_glb(&glb).unwrap();
            let text = String::from_utf8_lossy(json).to_string();
            for (from, to) in [
                ("\"count\":4,", "\"count\":4000000000000,"),
                ("\"count\":1,", "\"count\":4000000000000,"),
            ] {
                assert!(text.contains(from), "{text}");
                let hostile = text.replacen(from, to, 1);
                assert!(read_glb(&crate::glb::write_glb(hostile.as_bytes(), bin), path).is_err());
            }
        }
    }
}

#[cfg(test)]
mod volume_and_contents_tests {
    use super::*;
    use crate::PropValue;
    use serde_json::json;

    fn write_tileset(dir: &Path, root: serde_json::Value) -> PathBuf {
        let ts = json!({"asset": {"version": "1.1"}, "geometricError": 100, "root": root});
        let p = dir.join("tileset.json");
        std::fs::write(&p, ts.to_string()).unwrap();
        p
    }

    /// A glb of one triangle feature per entry of `names` (class `c`, property `n`).
    fn glb_of(names: &[&str]) -> Vec<u8> {
        use crate::spec::*;
        let schema = MetadataSchema {
            id: "s".into(),
            classes: vec![ClassDef {
                id: "c".into(),
                properties: vec![PropertyDef {
                    name: "n".into(),
                    kind: PropertyKind::String,
                    description: None,
                    nullable: false,
                    string_no_data: None,
                    input_name: None,
                }],
            }],
        };
        let features: Vec<ContentFeature> = names
            .iter()
            .enumerate()
            .map(|(k, n)| {
                let x = 10.0 * k as f64;
                ContentFeature {
                    mesh: citylod_model::Mesh3d {
                        positions: vec![[x, 0.0, 0.0], [x + 4.0, 0.0, 0.0], [x, 4.0, 2.0]],
                        triangles: vec![[0, 1, 2]],
                    },
                    class: 0,
                    values: vec![PropValue::Str((*n).into())],
                    max_rounding_m: 0.0,
                }
            })
            .collect();
        crate::content::encode_content(
            "0",
            &features,
            &schema,
            &crate::content::ContentOptions {
                compression: crate::Compression::None,
                normals: false,
                quantization_step_m: 0.01,
            },
            "t",
        )
        .unwrap()
        .unwrap()
        .glb
    }

    fn contains(b: &[f64; 12], p: [f64; 3]) -> bool {
        (0..3).all(|k| {
            let h = [b[3 + 3 * k], b[4 + 3 * k], b[5 + 3 * k]];
            let len2 = h.iter().map(|v| v * v).sum::<f64>();
            let t = (0..3).map(|c| (p[c] - b[c]) * h[c]).sum::<f64>() / len2;
            t.abs() <= 1.0 + 1e-9
        })
    }

    #[test]
    fn region_and_sphere_volumes_become_boxes_in_the_root_frame() {
        let dir = tempfile::tempdir().unwrap();
        // The root frame is east-north-up at (-73.99°, 40.71°): a region of ±0.001° around it, 0–50 m, comes in as
        // a box about the root frame's origin; a child sphere under a transform moving 100 m east is moved too.
        let frame = citylod_model::LocalFrame::new(-73.99, 40.71, 0.0);
        let (lon, lat) = (-73.99f64.to_radians(), 40.71f64.to_radians());
        let d = 0.001f64.to_radians();
        let mut east = IDENTITY;
        east[12] = 100.0;
        let root = json!({
            "transform": frame.enu_to_ecef_column_major(),
            "boundingVolume": {"region": [lon - d, lat - d, lon + d, lat + d, 0, 50]},
            "geometricError": 10, "refine": "REPLACE",
            "children": [{"transform": east, "boundingVolume": {"sphere": [0, 0, 5, 20]}, "geometricError": 0}]
        });
        let back = read_tileset(&write_tileset(dir.path(), root)).unwrap();
        let (r, s) = (&back.tiles[0], &back.tiles[1]);
        assert_eq!(
            (r.volume_kind, s.volume_kind),
            (VolumeKind::Region, VolumeKind::Sphere)
        );
        let rb = r.bounding_box.unwrap();
        // ±0.001° is ±84 m east and ±111 m north; 0–50 m up, less the curvature over 111 m (1 mm).
        for p in [[80.0, 108.0, 1.0], [-80.0, -108.0, 49.0], [0.0, 0.0, 25.0]] {
            assert!(contains(&rb, p), "{p:?} not in {rb:?}");
        }
        for p in [
            [90.0, 0.0, 25.0],
            [0.0, 115.0, 25.0],
            [0.0, 0.0, 52.0],
            [0.0, 0.0, -2.0],
        ] {
            assert!(!contains(&rb, p), "{p:?} in {rb:?}");
        }
        let sb = s.bounding_box.unwrap();
        let expect = [
            100.0, 0.0, 5.0, 20.0, 0.0, 0.0, 0.0, 20.0, 0.0, 0.0, 0.0, 20.0,
        ];
        assert!(
            sb.iter().zip(expect).all(|(a, b)| (a - b).abs() < 1e-9),
            "{sb:?}"
        );
    }

    #[test]
    fn region_the_reader_cannot_bound_is_an_error_naming_tile_and_volume() {
        let dir = tempfile::tempdir().unwrap();
        let root = json!({"boundingVolume": {"box": [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]}, "geometricError": 1,
            "children": [{"boundingVolume": {"region": [0, 0, 0.1, 0.1, -2e6, 0]}, "geometricError": 0}]});
        let e = read_tileset(&write_tileset(dir.path(), root))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("tile 0/0 ("), "{e}");
        assert!(e.contains("tileset.json): boundingVolume region"), "{e}");
        assert!(e.contains("deeper than"), "{e}");
    }

    #[test]
    fn multiple_contents_are_read_into_one_content() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a.glb"), glb_of(&["a0", "a1"])).unwrap();
        std::fs::write(dir.path().join("b.glb"), glb_of(&["b0"])).unwrap();
        let bx = json!({"box": [0, 0, 0, 50, 0, 0, 0, 50, 0, 0, 0, 50]});
        let root = json!({"boundingVolume": bx, "geometricError": 0,
            "contents": [{"uri": "a.glb"}, {"uri": "b.glb"}]});
        let back = read_tileset(&write_tileset(dir.path(), root)).unwrap();
        let t = &back.tiles[0];
        assert_eq!(t.content_uris, vec!["a.glb", "b.glb"]);
        assert_eq!(t.content_uri.as_deref(), Some("a.glb"));
        let sizes =
            ["a.glb", "b.glb"].map(|f| std::fs::metadata(dir.path().join(f)).unwrap().len());
        assert_eq!(t.content_bytes, Some(sizes[0] + sizes[1]));
        let c = t.content.as_ref().unwrap();
        assert_eq!(c.triangles.len(), 3);
        let names: Vec<_> = c.features.iter().map(|f| f.values["n"].clone()).collect();
        assert_eq!(
            names,
            ["a0", "a1", "b0"]
                .map(|n| PropValue::Str(n.into()))
                .to_vec()
        );
        // The second content's triangle uses its own vertices and its feature (index 2 after appending).
        let last = c.triangles[2];
        assert!(last
            .iter()
            .all(|&v| v as usize >= 6 && (v as usize) < c.positions_local.len()));
        assert!(
            last.iter().all(|&v| c.feature_ids[v as usize] == 2),
            "{:?}",
            c.feature_ids
        );
        assert!((c.positions_local[last[0] as usize][0] - 0.0).abs() < 0.02);
    }

    /// `glb` as a b3dm's glb: its feature ids become `_BATCHID`, its own metadata is removed.
    fn batched_glb(glb: &[u8]) -> Vec<u8> {
        let (json, bin) = parse_glb(glb).unwrap();
        let mut doc: serde_json::Value = serde_json::from_slice(json).unwrap();
        for mesh in doc["meshes"].as_array_mut().unwrap() {
            for prim in mesh["primitives"].as_array_mut().unwrap() {
                let attrs = prim["attributes"].as_object_mut().unwrap();
                let fid = attrs.remove("_FEATURE_ID_0").unwrap();
                attrs.insert("_BATCHID".into(), fid);
                prim.as_object_mut().unwrap().remove("extensions");
            }
        }
        doc.as_object_mut().unwrap().remove("extensions");
        for list in ["extensionsUsed", "extensionsRequired"] {
            if let Some(l) = doc[list].as_array_mut() {
                l.retain(|x| !x.as_str().unwrap().starts_with("EXT_"));
            }
        }
        crate::glb::write_glb(&serde_json::to_vec(&doc).unwrap(), bin)
    }

    #[test]
    fn b3dm_and_cmpt_content_is_read_with_its_batch_table_and_centre() {
        use crate::legacy::tests::{b3dm, cmpt};
        let dir = tempfile::tempdir().unwrap();
        let glb = batched_glb(&glb_of(&["x", "y"]));
        let ft = json!({"BATCH_LENGTH": 2, "RTC_CENTER": [1000.0, 2000.0, 30.0]});
        let bt = json!({"name": ["p", "q"], "height": [12.5, 40]});
        let one = b3dm(&ft, &[], Some(&bt), &[], &glb);
        std::fs::write(dir.path().join("a.b3dm"), &one).unwrap();
        let bx = json!({"box": [1000, 2000, 30, 50, 0, 0, 0, 50, 0, 0, 0, 50]});
        let root = json!({"boundingVolume": bx, "geometricError": 0, "content": {"uri": "a.b3dm"}});
        let back = read_tileset(&write_tileset(dir.path(), root.clone())).unwrap();
        let c = back.tiles[0].content.as_ref().unwrap();
        assert_eq!(c.triangles.len(), 2);
        let rows: Vec<_> = c
            .features
            .iter()
            .map(|f| {
                (
                    f.class.as_str(),
                    f.values["name"].clone(),
                    f.values["height"].clone(),
                )
            })
            .collect();
        assert_eq!(
            rows,
            vec![
                (
                    BATCH_TABLE_CLASS,
                    PropValue::Str("p".into()),
                    PropValue::Float(12.5)
                ),
                (
                    BATCH_TABLE_CLASS,
                    PropValue::Str("q".into()),
                    PropValue::Int(40)
                ),
            ]
        );
        // The second triangle (feature 1 of the glb, written at x = 10 m) is `q`, moved by RTC_CENTER.
        let t = c.triangles[1];
        assert!(
            t.iter().all(|&v| c.feature_ids[v as usize] == 1),
            "{:?}",
            c.feature_ids
        );
        let p = c.positions_local[t[0] as usize];
        for (got, want) in p.iter().zip([1010.0, 2000.0, 30.0]) {
            assert!((got - want).abs() < 0.02, "{p:?}");
        }

        // A composite of the b3dm twice: the second's ids index its own rows, after the first's.
        std::fs::write(dir.path().join("a.cmpt"), cmpt(&[&one, &one])).unwrap();
        let root_c =
            json!({"boundingVolume": bx, "geometricError": 0, "content": {"uri": "a.cmpt"}});
        let back = read_tileset(&write_tileset(dir.path(), root_c)).unwrap();
        let c = back.tiles[0].content.as_ref().unwrap();
        assert_eq!((c.triangles.len(), c.features.len()), (4, 4));
        let ids: std::collections::BTreeSet<u32> = c.feature_ids.iter().copied().collect();
        assert_eq!(ids.into_iter().collect::<Vec<_>>(), vec![0, 1, 2, 3]);

        // A _BATCHID past BATCH_LENGTH is no feature of the batch: the file is broken (3D Tiles 1.0 asks every id
        // to be one), and a b3dm whose glb is broken names the file.
        let short = b3dm(&json!({"BATCH_LENGTH": 1}), &[], None, &[], &glb);
        std::fs::write(dir.path().join("a.b3dm"), &short).unwrap();
        let e = read_tileset(&write_tileset(dir.path(), root.clone()))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("a.b3dm")
                && e.contains("its glb")
                && e.contains("_BATCHID 1 is not a feature"),
            "{e}"
        );
        // A BATCH_LENGTH no glb backs (one feature per vertex at most) is refused before its rows are made.
        let inflated = b3dm(&json!({"BATCH_LENGTH": 1_000_000}), &[], None, &[], &glb);
        std::fs::write(dir.path().join("a.b3dm"), &inflated).unwrap();
        let e = read_tileset(&write_tileset(dir.path(), root.clone()))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("BATCH_LENGTH 1000000 is more than the 6 vertices"),
            "{e}"
        );
        let broken = b3dm(
            &json!({"BATCH_LENGTH": 1}),
            &[],
            None,
            &[],
            &glb[..glb.len() - 8],
        );
        std::fs::write(dir.path().join("a.b3dm"), &broken).unwrap();
        let e = read_tileset(&write_tileset(dir.path(), root.clone()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("a.b3dm") && e.contains("truncated"), "{e}");
    }

    #[test]
    fn content_citylod_does_not_read_is_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let bx = json!({"box": [0, 0, 0, 50, 0, 0, 0, 50, 0, 0, 0, 50]});
        for (bytes, want) in [
            (b"i3dm\x01\0\0\0".to_vec(), "i3dm"),
            (b"pnts\x01\0\0\0".to_vec(), "pnts"),
            (br#"{"asset": {"version": "2.0"}}"#.to_vec(), ".gltf"),
            (b"\xef\xbb\xbf \n{\"asset\": {}}".to_vec(), ".gltf"),
            (b"XXXX\x01\0\0\0".to_vec(), "not a glb"),
        ] {
            std::fs::write(dir.path().join("c.bin"), &bytes).unwrap();
            let root =
                json!({"boundingVolume": bx, "geometricError": 0, "content": {"uri": "c.bin"}});
            let e = read_tileset(&write_tileset(dir.path(), root))
                .unwrap_err()
                .to_string();
            assert!(e.contains(want) && e.contains("c.bin"), "{want}: {e}");
        }
        // asset.gltfUpAxis of the root tileset: Y (glTF's own) turns content to z-up, Z takes it as it is, X is
        // refused.
        std::fs::write(dir.path().join("a.glb"), glb_of(&["a"])).unwrap();
        let p = dir.path().join("tileset.json");
        let positions = |axis: &str| {
            let ts = json!({"asset": {"version": "1.0", "gltfUpAxis": axis}, "geometricError": 1,
                "root": {"boundingVolume": bx, "geometricError": 0, "content": {"uri": "a.glb"}}});
            std::fs::write(&p, ts.to_string()).unwrap();
            read_tileset(&p).map(|t| t.tiles[0].content.clone().unwrap().positions_local)
        };
        // glb_of's triangle has a corner at (0, 4, 2) east-north-up, written y-up as (0, 2, −4).
        let near = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 0.01);
        for axis in ["Y", "y"] {
            let v = positions(axis).unwrap();
            assert!(v.iter().any(|&p| near(p, [0.0, 4.0, 2.0])), "{axis}: {v:?}");
        }
        let v = positions("Z").unwrap();
        assert!(v.iter().any(|&p| near(p, [0.0, 2.0, -4.0])), "Z: {v:?}");
        let e = positions("X").unwrap_err().to_string();
        assert!(e.contains("gltfUpAxis is \"X\""), "{e}");
    }

    /// A binary `.subtree`: header, JSON padded to 8 bytes, binary chunk.
    fn binary_subtree(json: serde_json::Value, bin: &[u8]) -> Vec<u8> {
        let mut j = json.to_string().into_bytes();
        j.resize(j.len().next_multiple_of(8), b' ');
        let mut out = b"subt".to_vec();
        out.extend(1u32.to_le_bytes());
        out.extend((j.len() as u64).to_le_bytes());
        out.extend((bin.len() as u64).to_le_bytes());
        out.extend(j);
        out.extend(bin);
        out
    }

    #[test]
    fn implicit_quadtrees_are_read_as_the_tree_their_subtrees_describe() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for (k, name) in ["0/0/0", "1/0/0", "1/1/1", "2/2/2"].iter().enumerate() {
            let f = d.join(format!("tiles/{name}.glb"));
            std::fs::create_dir_all(f.parent().unwrap()).unwrap();
            std::fs::write(f, glb_of(&[&format!("t{k}")])).unwrap();
        }
        // Root subtree (levels 0 and 1): the root and children 0 (x 0, y 0) and 3 (x 1, y 1) available,
        // with content; below child 3, the subtree rooted at level 2, x 2, y 2 (Morton index 12).
        let mut bin = vec![0u8; 24];
        bin[0] = 0b1_0011; // tiles: index 0 (root), 1 + 0 and 1 + 3
        bin[8] = 0b1_0011; // content: the same
        bin[16 + 1] = 0b0001_0000; // child subtrees: bit 12
        let root_subtree = json!({
            "buffers": [{"byteLength": 24}],
            "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 1},
                {"buffer": 0, "byteOffset": 8, "byteLength": 1},
                {"buffer": 0, "byteOffset": 16, "byteLength": 2}],
            "tileAvailability": {"bitstream": 0, "availableCount": 3},
            "contentAvailability": [{"bitstream": 1}],
            "childSubtreeAvailability": {"bitstream": 2}});
        std::fs::create_dir_all(d.join("subtrees/0/0")).unwrap();
        std::fs::write(
            d.join("subtrees/0/0/0.subtree"),
            binary_subtree(root_subtree, &bin),
        )
        .unwrap();
        // The child subtree is JSON with its bitstream in an external buffer: only its root available.
        std::fs::create_dir_all(d.join("subtrees/2/2")).unwrap();
        std::fs::write(d.join("subtrees/2/2/bits.bin"), [0b1u8]).unwrap();
        let child_subtree = json!({
            "buffers": [{"uri": "bits.bin", "byteLength": 1}],
            "bufferViews": [{"buffer": 0, "byteLength": 1}],
            "tileAvailability": {"bitstream": 0},
            "contentAvailability": [{"constant": 1}],
            "childSubtreeAvailability": {"constant": 0}});
        std::fs::write(d.join("subtrees/2/2/2.subtree"), child_subtree.to_string()).unwrap();
        let root = json!({"boundingVolume": {"box": [0, 0, 0, 100, 0, 0, 0, 100, 0, 0, 0, 10]},
            "geometricError": 100, "refine": "REPLACE", "content": {"uri": "tiles/{level}/{x}/{y}.glb"},
            "implicitTiling": {"subdivisionScheme": "QUADTREE", "subtreeLevels": 2, "availableLevels": 4,
                "subtrees": {"uri": "subtrees/{level}/{x}/{y}.subtree"}}});
        let back = read_tileset(&write_tileset(d, root)).unwrap();
        let got: Vec<_> = back
            .tiles
            .iter()
            .map(|t| {
                let c = t.content.as_ref().unwrap();
                (
                    t.path_in_tree.as_str(),
                    t.content_uri.as_deref().unwrap(),
                    t.geometric_error_m,
                    c.features[0].values["n"].clone(),
                )
            })
            .collect();
        let name = |s: &str| PropValue::Str(s.into());
        assert_eq!(
            got,
            vec![
                ("0", "tiles/0/0/0.glb", 100.0, name("t0")),
                ("0/0", "tiles/1/0/0.glb", 50.0, name("t1")),
                ("0/1", "tiles/1/1/1.glb", 50.0, name("t2")),
                ("0/1/0", "tiles/2/2/2.glb", 25.0, name("t3")),
            ]
        );
        let boxes: Vec<[f64; 12]> = back.tiles.iter().map(|t| t.bounding_box.unwrap()).collect();
        assert_eq!(
            boxes[1],
            [-50.0, -50.0, 0.0, 50.0, 0.0, 0.0, 0.0, 50.0, 0.0, 0.0, 0.0, 10.0]
        );
        assert_eq!(
            boxes[3],
            [25.0, 25.0, 0.0, 25.0, 0.0, 0.0, 0.0, 25.0, 0.0, 0.0, 0.0, 10.0]
        );
        assert_eq!(back.tiles[0].children, vec![1, 2]);
        assert_eq!(back.tiles[2].children, vec![3]);

        // A subtree file that is missing is an error naming the tile and the file.
        std::fs::remove_file(d.join("subtrees/2/2/2.subtree")).unwrap();
        let e = read_tileset(&d.join("tileset.json"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("tile 0 (") && e.contains("subtree subtrees/2/2/2.subtree: file "),
            "{e}"
        );
        // And so is a content template whose tile has children of its own.
        let root = json!({"boundingVolume": {"box": [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]},
            "geometricError": 1, "children": [{"boundingVolume": {"box": [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]},
                "geometricError": 0}],
            "implicitTiling": {"subdivisionScheme": "QUADTREE", "subtreeLevels": 2, "availableLevels": 2,
                "subtrees": {"uri": "subtrees/{level}/{x}/{y}.subtree"}}});
        let e = read_tileset(&write_tileset(d, root))
            .unwrap_err()
            .to_string();
        assert!(e.contains("may not have children"), "{e}");
    }

    #[test]
    fn contents_with_an_external_tileset_or_beside_content_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a.glb"), glb_of(&["a0"])).unwrap();
        let bx = json!({"box": [0, 0, 0, 50, 0, 0, 0, 50, 0, 0, 0, 50]});
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        write_tileset(
            &dir.path().join("sub"),
            json!({"boundingVolume": bx, "geometricError": 0}),
        );
        for (tile, expect) in [
            (
                json!({"boundingVolume": bx, "geometricError": 1, "children": [{"boundingVolume": bx,
                    "geometricError": 0, "contents": [{"uri": "a.glb"}, {"uri": "sub/tileset.json"}]}]}),
                "tile 0/0 (",
            ),
            (
                json!({"boundingVolume": bx, "geometricError": 0, "content": {"uri": "a.glb"},
                    "contents": [{"uri": "a.glb"}]}),
                "both `content` and `contents`",
            ),
        ] {
            let e = read_tileset(&write_tileset(dir.path(), tile))
                .unwrap_err()
                .to_string();
            assert!(e.contains(expect), "{expect}: {e}");
        }
        // One external tileset in `contents` is the same as `content` naming it.
        let back = read_tileset(&write_tileset(
            dir.path(),
            json!({"boundingVolume": bx, "geometricError": 1, "contents": [{"uri": "sub/tileset.json"}]}),
        ))
        .unwrap();
        assert_eq!(back.tiles[1].path_in_tree, "0/ext");
    }

    /// A chain of `levels` tiles below the root.
    fn chain(levels: usize) -> serde_json::Value {
        let bx = json!({"box": [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1]});
        let mut t = json!({"boundingVolume": bx, "geometricError": 0});
        for _ in 0..levels {
            t = json!({"boundingVolume": bx, "geometricError": 0, "children": [{"boundingVolume": bx,
                "geometricError": 0}, t]});
        }
        t
    }

    #[test]
    fn trees_deeper_than_one_file_holds_name_the_limit_and_the_tile() {
        let dir = tempfile::tempdir().unwrap();
        let ok = read_tileset(&write_tileset(dir.path(), chain(MAX_TILE_LEVEL_PER_FILE))).unwrap();
        assert_eq!(ok.tiles.len(), 2 * MAX_TILE_LEVEL_PER_FILE + 1);
        let e = read_tileset(&write_tileset(
            dir.path(),
            chain(MAX_TILE_LEVEL_PER_FILE + 5),
        ))
        .unwrap_err()
        .to_string();
        // Each level's second child carries on, so parsing stops at the first child one level too deep.
        let tile = format!("tile 0{}/0 (", "/1".repeat(MAX_TILE_LEVEL_PER_FILE));
        assert!(e.starts_with(&tile), "{e}");
        assert!(
            e.contains(&format!("down to level {MAX_TILE_LEVEL_PER_FILE}")),
            "{e}"
        );
        assert!(e.contains("JSON nesting limit 127"), "{e}");
        assert!(e.contains("external tilesets"), "{e}");
    }

    #[test]
    fn unknown_versions_are_refused_and_known_ones_read() {
        let dir = tempfile::tempdir().unwrap();
        let bx = json!({"box": [0, 0, 0, 50, 0, 0, 0, 50, 0, 0, 0, 50]});
        let p = dir.path().join("tileset.json");
        let with_version = |v: &str| {
            json!({"asset": {"version": v}, "geometricError": 1,
                "root": {"boundingVolume": bx, "geometricError": 0}})
        };
        for v in ["1.0", "1.1", "0.0"] {
            std::fs::write(&p, with_version(v).to_string()).unwrap();
            assert_eq!(read_tileset(&p).unwrap().tiles.len(), 1, "{v}");
        }
        for v in ["7.3", "1.2", "1", "2.0.0", ""] {
            std::fs::write(&p, with_version(v).to_string()).unwrap();
            let e = read_tileset(&p).unwrap_err().to_string();
            let want = format!(
                "{}: asset.version {v:?}: 3D Tiles 1.0 and 1.1 are known (and \"0.0\", of the drafts before \
                 1.0); CesiumJS refuses other versions",
                p.display()
            );
            assert_eq!(e, want);
        }
        // A file of another version need not have the shape of 1.x: its version is the error, not its shape.
        std::fs::write(&p, r#"{"asset": {"version": "7.3"}, "root": []}"#).unwrap();
        let e = read_tileset(&p).unwrap_err().to_string();
        assert!(e.contains(r#"asset.version "7.3""#), "{e}");
        // Without asset.version the file is not a tileset.
        std::fs::write(&p, r#"{"asset": {}, "geometricError": 1, "root": {}}"#).unwrap();
        let e = read_tileset(&p).unwrap_err().to_string();
        assert!(e.contains("invalid JSON"), "{e}");
    }

    #[test]
    fn required_3d_tiles_extensions_the_reader_does_not_read_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let bx = json!({"box": [0, 0, 0, 50, 0, 0, 0, 50, 0, 0, 0, 50]});
        std::fs::write(dir.path().join("a.glb"), glb_of(&["a0"])).unwrap();
        let leaf = json!({"boundingVolume": bx, "geometricError": 0, "content": {"uri": "a.glb"}});
        let with = |used: &[&str], required: &[&str], root: &serde_json::Value| {
            json!({"asset": {"version": "1.0"}, "geometricError": 1, "extensionsUsed": used,
                "extensionsRequired": required, "root": root})
            .to_string()
        };
        let p = dir.path().join("tileset.json");
        let refused = |x: &str| {
            format!(
                "it requires the 3D Tiles extension {x:?}, which citylod's reader does not read (the required \
                 extensions it takes: 3DTILES_implicit_tiling, 3DTILES_content_gltf, 3DTILES_metadata)"
            )
        };
        // The root tileset.
        for x in [
            "FOO_unknown",
            "3DTILES_multiple_contents",
            "3DTILES_bounding_volume_S2",
        ] {
            std::fs::write(&p, with(&[x], &["3DTILES_content_gltf", x], &leaf)).unwrap();
            let e = read_tileset(&p).unwrap_err().to_string();
            assert_eq!(e, format!("{}: {}", p.display(), refused(x)));
        }
        // Extensions only used, and required ones the reader takes, read.
        let takes = [
            "3DTILES_content_gltf",
            "3DTILES_implicit_tiling",
            "3DTILES_metadata",
        ];
        for (used, required) in [(&["FOO_unknown"][..], &[][..]), (&takes[..], &takes[..])] {
            std::fs::write(&p, with(used, required, &leaf)).unwrap();
            let back = read_tileset(&p).unwrap();
            assert_eq!(back.tiles[0].content.as_ref().unwrap().features.len(), 1);
        }
        // An external tileset: its own file is named, under the tile that names it.
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        std::fs::write(dir.path().join("sub/a.glb"), glb_of(&["a0"])).unwrap();
        let ext = dir.path().join("sub").join("tileset.json");
        let outer = json!({"boundingVolume": bx, "geometricError": 1,
            "children": [{"boundingVolume": bx, "geometricError": 1, "content": {"uri": "sub/tileset.json"}}]});
        std::fs::write(&p, with(&[], &[], &outer)).unwrap();
        std::fs::write(&ext, with(&["FOO_unknown"], &["FOO_unknown"], &leaf)).unwrap();
        let e = read_tileset(&p).unwrap_err().to_string();
        assert!(e.starts_with("tile 0/0"), "{e}");
        assert!(e.contains(&ext.display().to_string()), "{e}");
        assert!(e.contains(&refused("FOO_unknown")), "{e}");
        std::fs::write(&ext, with_version_of(&with(&[], &[], &leaf), "7.3")).unwrap();
        let e = read_tileset(&p).unwrap_err().to_string();
        assert!(
            e.starts_with("tile 0/0") && e.contains(&ext.display().to_string()),
            "{e}"
        );
        assert!(
            e.contains(r#"asset.version "7.3": 3D Tiles 1.0 and 1.1 are known"#),
            "{e}"
        );
        // Only used there, it reads.
        std::fs::write(&ext, with(&["FOO_unknown"], &[], &leaf)).unwrap();
        let back = read_tileset(&p).unwrap();
        assert_eq!(back.tiles[2].path_in_tree, "0/0/ext");
        assert!(back.tiles[2].content.is_some());
    }

    /// `tileset` (JSON text) with its `asset.version` set to `v`.
    fn with_version_of(tileset: &str, v: &str) -> String {
        let mut t: serde_json::Value = serde_json::from_str(tileset).unwrap();
        t["asset"]["version"] = json!(v);
        t.to_string()
    }

    #[test]
    fn tile_path_at_follows_children_arrays_past_strings_and_other_keys() {
        let text = br#"{"root": {"extras": {"children": ["x\"]{,", 1]}, "children": [{}, {"children": [{"a": ["#;
        assert_eq!(tile_path_at(text, text.len()), vec![1, 0]);
    }
}
