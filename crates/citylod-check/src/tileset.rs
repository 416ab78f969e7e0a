//! The checker's view of a decoded tileset (citylod-tiles `read`): the [`TileTree`] that selection
//! walks, and per tile its mesh, its features' identities (building index, or block level and node)
//! and the buildings below it. Buildings beside blocks in an inner tile are the blocks' landmarks
//! (members of a block, drawn at full detail). Root frame (local ENU metres, z up), as the reader returns it.
//! Invariant: `tiles[i]` describes `tree.tiles[i]`; `under` lists are sorted (duplicates kept).

use std::collections::BTreeSet;
use std::path::Path;

use citylod_model::Mesh3d;
use citylod_tiles::read::{ExactVolume, GlbData, TileData, TilesetData, VolumeKind};
use citylod_tiles::PropValue;
use citylod_tiles::TilesError;
use serde::Serialize;

use crate::select::{OrientedBox, TileNode, TileTree};
use crate::vec3::Vec3;

/// Which node of the hierarchy a feature (or finding) is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(untagged)]
pub enum NodeRef {
    /// A building (level 0), by citylod's `building_index`.
    Building { building_index: u32 },
    /// A block of level ≥ 1, by `level` and `node_index`.
    Cluster { level: u32, node_index: u32 },
    /// A feature without a recognised identity, by its row in the tile's property tables.
    Feature { feature: u32 },
}

/// One feature of a tile's content.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureInfo {
    pub node: NodeRef,
    /// `member_count` of a block; 1 for a building; `None` when a block does not say.
    pub member_count: Option<u32>,
    /// The buildings of a block when its `members` property lists them (a JSON array or
    /// comma-separated indices in a string); `[building_index]` for a building.
    pub members: Option<Vec<u32>>,
    /// Height spread Δh (m) and added ground Δa (m²) of a block; 0 for buildings.
    pub dh_m: f64,
    pub da_m2: f64,
    /// The area a block says it covers (m², its `area_m2`); `None` for buildings and blocks that do not say.
    pub area_m2: Option<f64>,
    /// A block drawn with its buildings' own meshes (exact, so no criterion applies).
    pub fallback: bool,
    /// Axis-aligned bounds (min, max) of the feature's vertices; `None` without geometry.
    pub bounds_m: Option<(Vec3, Vec3)>,
    /// The heights a block declares, when it declares all four (citylod's blocks).
    pub heights: Option<BlockHeights>,
}

impl FeatureInfo {
    /// Building `building_index` as citylod writes it: one member, no Δh or Δa, no geometry yet.
    pub fn building(building_index: u32) -> FeatureInfo {
        FeatureInfo {
            node: NodeRef::Building { building_index },
            member_count: Some(1),
            members: Some(vec![building_index]),
            dh_m: 0.0,
            da_m2: 0.0,
            area_m2: None,
            fallback: false,
            bounds_m: None,
            heights: None,
        }
    }
}

/// What a block says of its heights (m): where it stands, how high it is drawn, its buildings' lowest and highest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockHeights {
    pub ground_z_m: f64,
    pub height_m: f64,
    pub h_min_m: f64,
    pub h_max_m: f64,
}

/// One tile as the checks see it.
#[derive(Debug, Clone, PartialEq)]
pub struct TileInfo {
    /// `0`, `0/1`, … as in [`TileData::path_in_tree`].
    pub path_in_tree: String,
    /// The content's URI relative to the folder of the main `tileset.json` (`/`-separated, `.` and
    /// `..` resolved; URIs inside an external tileset are prefixed with its folder), as a client
    /// resolves it. Absolute URIs are kept as written.
    pub content_uri: Option<String>,
    /// Every content URI resolved alike: `content_uri` alone, or each of a 3D Tiles 1.1 `contents` array.
    pub content_uris: Vec<String>,
    /// Size of the content files (0 when unknown).
    pub content_bytes: u64,
    /// The bounding volume the file gives; the tree's box is exact for a `box`, encloses the others.
    pub volume_kind: VolumeKind,
    /// A `sphere` or `region` as written (see [`citylod_tiles::read::TileData::exact_volume`]).
    pub exact_volume: Option<ExactVolume>,
    /// The content as one mesh in the root frame; `None` without content.
    pub mesh: Option<Mesh3d>,
    pub features: Vec<FeatureInfo>,
    /// Per triangle of `mesh`: index into `features` (of its first vertex), `u32::MAX` for none.
    pub triangle_features: Vec<u32>,
    /// Building indices held by the leaf tiles at or below this tile, sorted, duplicates kept.
    pub under: Vec<u32>,
}

impl TileInfo {
    /// Whether the content holds blocks (level ≥ 1 features).
    pub fn has_clusters(&self) -> bool {
        self.features
            .iter()
            .any(|f| matches!(f.node, NodeRef::Cluster { .. }))
    }

    /// The buildings the content stands for: Σ member_count of its blocks when it has blocks
    /// (buildings beside blocks are their landmarks, already counted as members), else its number
    /// of buildings. `None` when a block lacks member_count or a feature has no identity.
    pub fn member_total(&self) -> Option<u64> {
        let clusters = self.has_clusters();
        self.features
            .iter()
            .filter(|f| !clusters || !matches!(f.node, NodeRef::Building { .. }))
            .map(|f| f.member_count.map(u64::from))
            .sum()
    }

    pub fn triangle_count(&self) -> usize {
        self.mesh.as_ref().map_or(0, |m| m.triangles.len())
    }
}

/// A tileset ready for selection, validation and rendering.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedTileset {
    pub tree: TileTree,
    pub tiles: Vec<TileInfo>,
    /// Every building index held by a building feature of a leaf tile.
    pub buildings: BTreeSet<u32>,
    /// Whether `tileset.json` says citylod wrote it (`extras.citylod`, or `asset.generator` "citylod …"): its
    /// features must then carry citylod's identity columns, which third-party tilesets need not have.
    pub written_by_citylod: bool,
}

impl LoadedTileset {
    /// Converts reader output. `base_dir` (the folder of `tileset.json`) is used only to measure
    /// content file sizes. A tile without a `box` gets the bounds of its content and children; a
    /// child link out of range is kept (selection reports it). Never panics on odd input.
    pub fn from_data(data: &TilesetData, base_dir: Option<&Path>) -> LoadedTileset {
        let contents = data
            .tiles
            .iter()
            .map(|t| t.content.clone().map(content_info))
            .collect();
        Self::assemble(data, contents, base_dir)
    }

    /// Reads the tileset at `path` (a `tileset.json`), keeping of each tile's content only what the checks use
    /// as it is decoded (see [`citylod_tiles::read::read_tileset_with`]): the reader's tiles come back without
    /// content. Content sizes are measured next to `path`.
    pub fn read(path: &Path) -> Result<(TilesetData, LoadedTileset), TilesError> {
        let mut contents: Vec<Option<Content>> = Vec::new();
        let data = citylod_tiles::read::read_tileset_with(path, &mut |i, t| {
            if contents.len() <= i {
                contents.resize_with(i + 1, || None);
            }
            contents[i] = t.content.take().map(content_info);
        })?;
        contents.resize_with(data.tiles.len(), || None);
        let base = path.parent().unwrap_or(Path::new("."));
        let loaded = Self::assemble(&data, contents, Some(base));
        Ok((data, loaded))
    }

    /// `contents[i]`: what is kept of `data.tiles[i]`'s content (the tile's own is not looked at).
    fn assemble(
        data: &TilesetData,
        contents: Vec<Option<Content>>,
        base_dir: Option<&Path>,
    ) -> LoadedTileset {
        let n = data.tiles.len();
        let uris = resolved_uris(data);
        let mut tiles: Vec<TileInfo> = data
            .tiles
            .iter()
            .zip(uris)
            .zip(contents)
            .map(|((t, uris), content)| tile_info(t, content, uris, base_dir))
            .collect();
        let buildings: BTreeSet<u32> = tiles
            .iter()
            .zip(&data.tiles)
            .filter(|(_, d)| d.children.is_empty())
            .flat_map(|(t, _)| &t.features)
            .filter_map(|f| match f.node {
                NodeRef::Building { building_index } => Some(building_index),
                _ => None,
            })
            .collect();
        // Pre-order (children after parents) lets a reverse sweep fill `under` bottom-up; guard
        // against links that point backwards anyway.
        for i in (0..n).rev() {
            let mut under: Vec<u32> = if data.tiles[i].children.is_empty() {
                leaf_buildings(&tiles[i])
            } else {
                data.tiles[i]
                    .children
                    .iter()
                    .filter(|&&c| c > i && c < n)
                    .flat_map(|&c| tiles[c].under.iter().copied())
                    .collect()
            };
            under.sort_unstable();
            tiles[i].under = under;
        }
        let mut nodes: Vec<TileNode> = Vec::with_capacity(n);
        for (t, info) in data.tiles.iter().zip(&tiles) {
            nodes.push(TileNode {
                bounds: t.bounding_box.map(box_from_array).unwrap_or_else(zero_box),
                geometric_error_m: t.geometric_error_m,
                children: t.children.clone(),
                has_content: info.mesh.as_ref().is_some_and(|m| !m.triangles.is_empty()),
                external_tileset: t
                    .content_uri
                    .as_deref()
                    .is_some_and(citylod_tiles::read::names_json),
            });
        }
        // Missing boxes: content bounds joined with the children's boxes, bottom-up.
        for i in (0..n).rev() {
            if data.tiles[i].bounding_box.is_some() {
                continue;
            }
            let mut lo_hi: Option<(Vec3, Vec3)> = tiles[i].mesh.as_ref().and_then(mesh_bounds);
            for &c in data.tiles[i].children.iter().filter(|&&c| c > i && c < n) {
                lo_hi = join(lo_hi, Some(box_aabb(&nodes[c].bounds)));
            }
            if let Some((lo, hi)) = lo_hi {
                nodes[i].bounds = OrientedBox::from_min_max(lo, hi);
            }
        }
        LoadedTileset {
            tree: TileTree {
                tiles: nodes,
                root: 0,
                tileset_geometric_error_m: data.geometric_error_m,
            },
            tiles,
            buildings,
            written_by_citylod: data
                .extras
                .as_ref()
                .is_some_and(|e| e.get("citylod").is_some_and(|c| c.is_object()))
                || data
                    .generator
                    .as_deref()
                    .is_some_and(citylod_tiles::written_by_citylod),
        }
    }

    /// Whether the identity checks apply: the cut's coverage of every building, member counts, and a finding for a
    /// feature without identity. They do for citylod's tilesets and for any tileset one of whose features carries
    /// citylod's identity (`building_index`, or `level` and `node_index`); a third-party tileset's features have
    /// identities of their own, which say nothing of which buildings a tile stands for.
    pub fn identity_checked(&self) -> bool {
        self.written_by_citylod
            || self
                .tiles
                .iter()
                .flat_map(|t| &t.features)
                .any(|f| !matches!(f.node, NodeRef::Feature { .. }))
    }

    /// Axis-aligned bounds (min, max) of the root's box, root frame (m); `None` without tiles.
    pub fn root_extent(&self) -> Option<(Vec3, Vec3)> {
        self.tree
            .tiles
            .get(self.tree.root)
            .map(|t| box_aabb(&t.bounds))
    }

    /// The highest point (z, m) of full detail (the leaf tiles' meshes) within `radius_m` horizontally of `xy`,
    /// counting each triangle by its top wherever its horizontal bounds come that near; `None` where nothing does.
    pub fn highest_leaf_content_near(&self, xy: [f64; 2], radius_m: f64) -> Option<f64> {
        let near = |lo: &[f64], hi: &[f64]| horizontal_gap_m(xy, lo, hi) <= radius_m;
        let mut top: Option<f64> = None;
        for i in self.leaf_tiles() {
            let (lo, hi) = box_aabb(&self.tree.tiles[i].bounds);
            let Some(mesh) = self.tiles[i].mesh.as_ref().filter(|_| near(&lo, &hi)) else {
                continue;
            };
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
                let lo = [a[0].min(b[0]).min(c[0]), a[1].min(b[1]).min(c[1])];
                let hi = [a[0].max(b[0]).max(c[0]), a[1].max(b[1]).max(c[1])];
                if near(&lo, &hi) {
                    let z = a[2].max(b[2]).max(c[2]);
                    top = Some(top.map_or(z, |t| t.max(z)));
                }
            }
        }
        top
    }

    /// The vertex (x, y) of full detail (the leaf tiles' meshes) horizontally nearest to `xy`, the first one found
    /// among equals; `None` without full detail. Tiles are visited by the horizontal distance of their boxes (then
    /// index), and the search stops at the first box farther than the nearest vertex found.
    pub fn nearest_leaf_content(&self, xy: [f64; 2]) -> Option<[f64; 2]> {
        let mut tiles: Vec<(f64, usize)> = self
            .leaf_tiles()
            .into_iter()
            .map(|i| {
                let (lo, hi) = box_aabb(&self.tree.tiles[i].bounds);
                (horizontal_gap_m(xy, &lo, &hi), i)
            })
            .collect();
        tiles.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut best: Option<(f64, [f64; 2])> = None;
        for (box_gap, i) in tiles {
            if best.is_some_and(|(d, _)| box_gap > d) {
                break;
            }
            let Some(mesh) = self.tiles[i].mesh.as_ref() else {
                continue;
            };
            for p in &mesh.positions {
                let d = (p[0] - xy[0]).hypot(p[1] - xy[1]);
                if d.is_finite() && best.is_none_or(|(b, _)| d < b) {
                    best = Some((d, [p[0], p[1]]));
                }
            }
        }
        best.map(|(_, p)| p)
    }

    /// Indices of the leaf tiles (no children) with content: full detail.
    pub fn leaf_tiles(&self) -> Vec<usize> {
        (0..self.tiles.len())
            .filter(|&i| self.tree.tiles[i].children.is_empty() && self.tiles[i].mesh.is_some())
            .collect()
    }
}

/// Horizontal distance (m) from `xy` to the box `lo..hi` (x and y of each; 0 inside it).
fn horizontal_gap_m(xy: [f64; 2], lo: &[f64], hi: &[f64]) -> f64 {
    let gap = |i: usize| (lo[i] - xy[i]).max(xy[i] - hi[i]).max(0.0);
    gap(0).hypot(gap(1))
}

/// The buildings a leaf tile holds: building features, or the `members` of its blocks.
fn leaf_buildings(t: &TileInfo) -> Vec<u32> {
    t.features
        .iter()
        .flat_map(|f| f.members.clone().unwrap_or_default())
        .collect()
}

/// Content URIs relative to the main tileset's folder: a tile inside an external tileset resolves its
/// URI against the folder of that tileset's JSON (the reader names its root `p/ext` under link `p`).
fn resolved_uris(data: &TilesetData) -> Vec<Vec<String>> {
    let n = data.tiles.len();
    let mut folder: Vec<String> = vec![String::new(); n];
    for (i, t) in data.tiles.iter().enumerate() {
        let link_folder = t
            .content_uri
            .as_deref()
            .filter(|u| citylod_tiles::read::names_json(u))
            .map(|u| join_uri(&folder[i], u.rsplit_once('/').map_or("", |(dir, _)| dir)));
        for &c in t.children.iter().filter(|&&c| c > i && c < n) {
            let is_ext_root = data.tiles[c].path_in_tree == format!("{}/ext", t.path_in_tree);
            folder[c] = match (&link_folder, is_ext_root) {
                (Some(f), true) => f.clone(),
                _ => folder[i].clone(),
            };
        }
    }
    data.tiles
        .iter()
        .zip(&folder)
        .map(|(t, f)| {
            if t.content_uris.is_empty() {
                t.content_uri.iter().map(|u| join_uri(f, u)).collect()
            } else {
                t.content_uris.iter().map(|u| join_uri(f, u)).collect()
            }
        })
        .collect()
}

/// `uri` resolved against the relative folder `folder` (`/`-separated, `.` and `..` removed where
/// possible). Absolute URIs (`scheme://…`, `/…`) are returned unchanged.
fn join_uri(folder: &str, uri: &str) -> String {
    if uri.contains("://") || uri.starts_with('/') {
        return uri.to_string();
    }
    let mut parts: Vec<&str> = Vec::new();
    for p in folder.split('/').chain(uri.split('/')) {
        match p {
            "" | "." => {}
            ".." if parts.last().is_some_and(|&l| l != "..") => {
                parts.pop();
            }
            _ => parts.push(p),
        }
    }
    parts.join("/")
}

/// What the checks keep of a tile's content: one mesh, its features, and the feature of each triangle
/// (index into `features` of its first vertex's, `u32::MAX` for none).
struct Content {
    mesh: Mesh3d,
    features: Vec<FeatureInfo>,
    triangle_features: Vec<u32>,
}

fn content_info(glb: GlbData) -> Content {
    let mut bounds: Vec<Option<(Vec3, Vec3)>> = vec![None; glb.features.len()];
    for (p, &f) in glb.positions_local.iter().zip(&glb.feature_ids) {
        if let Some(b) = bounds.get_mut(f as usize) {
            *b = join(*b, Some((*p, *p)));
        }
    }
    let features = glb
        .features
        .iter()
        .enumerate()
        .map(|(k, row)| feature_info(k as u32, &row.class, &row.values, bounds[k]))
        .collect();
    let n = glb.features.len() as u32;
    let triangle_features = glb
        .triangles
        .iter()
        .map(|t| {
            glb.feature_ids
                .get(t[0] as usize)
                .copied()
                .filter(|&f| f < n)
                .unwrap_or(u32::MAX)
        })
        .collect();
    Content {
        mesh: Mesh3d {
            positions: glb.positions_local,
            triangles: glb.triangles,
        },
        features,
        triangle_features,
    }
}

fn tile_info(
    t: &TileData,
    content: Option<Content>,
    uris: Vec<String>,
    base_dir: Option<&Path>,
) -> TileInfo {
    let content_bytes = base_dir.map_or(0, |dir| {
        uris.iter()
            .map(|u| std::fs::metadata(dir.join(u)).map_or(0, |m| m.len()))
            .sum()
    });
    let (mesh, features, triangle_features) = match content {
        None => (None, Vec::new(), Vec::new()),
        Some(c) => (Some(c.mesh), c.features, c.triangle_features),
    };
    TileInfo {
        path_in_tree: t.path_in_tree.clone(),
        content_uri: uris.first().cloned(),
        content_uris: uris,
        content_bytes,
        volume_kind: t.volume_kind,
        exact_volume: t.exact_volume.clone(),
        mesh,
        features,
        triangle_features,
        under: Vec::new(),
    }
}

fn as_u32(v: Option<&PropValue>) -> Option<u32> {
    match v? {
        PropValue::Int(i) => u32::try_from(*i).ok().filter(|&u| u != u32::MAX),
        PropValue::Float(f) if f.fract() == 0.0 && *f >= 0.0 && *f < f64::from(u32::MAX) => {
            Some(*f as u32)
        }
        _ => None,
    }
}

fn as_f64(v: Option<&PropValue>) -> Option<f64> {
    match v? {
        PropValue::Float(f) if f.is_finite() && *f != f64::MIN => Some(*f),
        PropValue::Int(i) if *i != i64::MIN => Some(*i as f64),
        _ => None,
    }
}

/// `members` as written in a string: `[1, 2, 3]` or `1,2,3`. `None` when absent or unparsable.
fn parse_members(v: Option<&PropValue>) -> Option<Vec<u32>> {
    let PropValue::Str(s) = v? else { return None };
    let inner = s.trim().trim_start_matches('[').trim_end_matches(']');
    if inner.trim().is_empty() {
        return None;
    }
    inner
        .split(',')
        .map(|x| x.trim().parse::<u32>().ok())
        .collect()
}

fn feature_info(
    k: u32,
    class: &str,
    values: &std::collections::BTreeMap<String, PropValue>,
    bounds_m: Option<(Vec3, Vec3)>,
) -> FeatureInfo {
    let get = |name: &str| values.get(name);
    // citylod writes a block's landmarks as `cluster` features flagged `landmark`; they stand for one building.
    // A b3dm's batch table has no classes: its rows are told apart by the columns they have.
    let batch = class == citylod_tiles::read::BATCH_TABLE_CLASS;
    let (level, node_index) = (as_u32(get("level")), as_u32(get("node_index")));
    let is_landmark =
        (class == "cluster" || batch) && matches!(get("landmark"), Some(PropValue::Bool(true)));
    let building = as_u32(get("building_index")).filter(|_| {
        class == "building" || is_landmark || (batch && (level.is_none() || node_index.is_none()))
    });
    let cluster = match (class == "cluster" || batch, level, node_index) {
        (true, Some(level), Some(node_index)) => Some((level, node_index)),
        _ => None,
    };
    let (node, member_count, members) = match (building, cluster) {
        (Some(b), _) => (
            NodeRef::Building { building_index: b },
            Some(1),
            Some(vec![b]),
        ),
        (None, Some((level, node_index))) => (
            NodeRef::Cluster { level, node_index },
            as_u32(get("member_count")),
            parse_members(get("members")),
        ),
        (None, None) => (NodeRef::Feature { feature: k }, None, None),
    };
    FeatureInfo {
        node,
        member_count: members
            .as_ref()
            .filter(|_| member_count.is_none())
            .map(|m| m.len() as u32)
            .or(member_count),
        members,
        dh_m: as_f64(get("dh_m")).unwrap_or(0.0).max(0.0),
        da_m2: as_f64(get("da_m2")).unwrap_or(0.0).max(0.0),
        area_m2: as_f64(get("area_m2")).filter(|a| *a >= 0.0),
        fallback: matches!(get("fallback"), Some(PropValue::Bool(true))),
        bounds_m,
        heights: match (
            matches!(node, NodeRef::Cluster { .. }),
            as_f64(get("ground_z_m")),
            as_f64(get("height_m")),
            as_f64(get("h_min_m")),
            as_f64(get("h_max_m")),
        ) {
            (true, Some(ground_z_m), Some(height_m), Some(h_min_m), Some(h_max_m)) => {
                Some(BlockHeights {
                    ground_z_m,
                    height_m,
                    h_min_m,
                    h_max_m,
                })
            }
            _ => None,
        },
    }
}

fn box_from_array(b: [f64; 12]) -> OrientedBox {
    OrientedBox {
        center_m: [b[0], b[1], b[2]],
        half_axes_m: [[b[3], b[4], b[5]], [b[6], b[7], b[8]], [b[9], b[10], b[11]]],
    }
}

fn zero_box() -> OrientedBox {
    OrientedBox::from_min_max([0.0; 3], [0.0; 3])
}

/// Axis-aligned bounds of an oriented box.
pub(crate) fn box_aabb(b: &OrientedBox) -> (Vec3, Vec3) {
    let r: Vec3 = std::array::from_fn(|i| b.half_axes_m.iter().map(|h| h[i].abs()).sum());
    (
        std::array::from_fn(|i| b.center_m[i] - r[i]),
        std::array::from_fn(|i| b.center_m[i] + r[i]),
    )
}

/// Axis-aligned bounds (min, max) of a mesh's vertices; `None` without vertices.
pub(crate) fn mesh_bounds(m: &Mesh3d) -> Option<(Vec3, Vec3)> {
    m.positions
        .iter()
        .fold(None, |acc, p| join(acc, Some((*p, *p))))
}

fn join(a: Option<(Vec3, Vec3)>, b: Option<(Vec3, Vec3)>) -> Option<(Vec3, Vec3)> {
    match (a, b) {
        (Some((l1, h1)), Some((l2, h2))) => Some((
            std::array::from_fn(|i| l1[i].min(l2[i])),
            std::array::from_fn(|i| h1[i].max(h2[i])),
        )),
        (x, None) | (None, x) => x,
    }
}

/// The built-in views of `citylod check` look at, and keep clear of, full detail.
impl crate::views::ViewContent for LoadedTileset {
    fn highest_near(&self, xy: [f64; 2], radius_m: f64) -> Option<f64> {
        self.highest_leaf_content_near(xy, radius_m)
    }
    fn nearest(&self, xy: [f64; 2]) -> Option<[f64; 2]> {
        self.nearest_leaf_content(xy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use citylod_tiles::read::GlbData;
    use citylod_tiles::FeatureRow;
    use std::collections::BTreeMap;

    fn building_row(i: i64) -> FeatureRow {
        FeatureRow {
            class: "building".into(),
            values: BTreeMap::from([("building_index".to_string(), PropValue::Int(i))]),
        }
    }

    fn content(rows: Vec<FeatureRow>) -> GlbData {
        let mut g = GlbData::default();
        for (k, _) in rows.iter().enumerate() {
            let x = k as f64 * 10.0;
            let v0 = g.positions_local.len() as u32;
            g.positions_local
                .extend([[x, 0.0, 0.0], [x + 5.0, 0.0, 0.0], [x, 5.0, 8.0]]);
            g.feature_ids.extend([k as u32; 3]);
            g.triangles.push([v0, v0 + 1, v0 + 2]);
        }
        g.features = rows;
        g
    }

    fn tile(path: &str, content_rows: Vec<FeatureRow>, children: Vec<usize>) -> TileData {
        TileData {
            path_in_tree: path.into(),
            geometric_error_m: if children.is_empty() { 0.0 } else { 10.0 },
            bounding_box: None,
            volume_kind: VolumeKind::Box,
            exact_volume: None,
            content_uri: None,
            content_uris: vec![],
            content_bytes: None,
            content: Some(content(content_rows)),
            children,
            refine_add: false,
        }
    }

    #[test]
    fn under_sets_collect_leaf_buildings_and_boxes_fill_in() {
        let cluster = FeatureRow {
            class: "cluster".into(),
            values: BTreeMap::from([
                ("level".to_string(), PropValue::Int(1)),
                ("node_index".to_string(), PropValue::Int(0)),
                ("member_count".to_string(), PropValue::Int(3)),
                ("dh_m".to_string(), PropValue::Float(4.0)),
            ]),
        };
        let data = TilesetData {
            generator: None,
            root_transform: [0.0; 16],
            geometric_error_m: 100.0,
            extras: None,
            tiles: vec![
                tile("0", vec![cluster], vec![1, 2]),
                tile("0/0", vec![building_row(2), building_row(0)], vec![]),
                tile("0/1", vec![building_row(1)], vec![]),
            ],
        };
        let t = LoadedTileset::from_data(&data, None);
        assert_eq!(t.tiles[0].under, vec![0, 1, 2]);
        assert_eq!(t.tiles[0].member_total(), Some(3));
        assert_eq!(
            t.tiles[0].features[0].node,
            NodeRef::Cluster {
                level: 1,
                node_index: 0
            }
        );
        assert_eq!(t.tiles[0].features[0].dh_m, 4.0);
        assert_eq!(t.buildings, BTreeSet::from([0, 1, 2]));
        assert_eq!(t.leaf_tiles(), vec![1, 2]);
        // Feature bounds and the filled-in box of the leaf with two features.
        assert_eq!(
            t.tiles[1].features[1].bounds_m,
            Some(([10.0, 0.0, 0.0], [15.0, 5.0, 8.0]))
        );
        let (lo, hi) = box_aabb(&t.tree.tiles[1].bounds);
        assert_eq!((lo, hi), ([0.0, 0.0, 0.0], [15.0, 5.0, 8.0]));
    }

    #[test]
    fn content_uris_inside_external_tilesets_resolve_against_their_folder() {
        let with_uri = |path: &str, uri: &str, children: Vec<usize>| TileData {
            content_uri: Some(uri.into()),
            content_bytes: None,
            content: None,
            ..tile(path, vec![], children)
        };
        // 0 (tiles/0.glb) → 0/0 links ./sub/a/tileset.json → its root 0/0/ext (../b/x.glb) → 0/0/ext/0
        // (./y.glb); 0/1 beside the link keeps the main folder.
        let data = TilesetData {
            generator: None,
            root_transform: [0.0; 16],
            geometric_error_m: 100.0,
            extras: None,
            tiles: vec![
                with_uri("0", "tiles/0.glb", vec![1, 4]),
                with_uri("0/0", "./sub/a/tileset.json", vec![2]),
                with_uri("0/0/ext", "../b/x.glb", vec![3]),
                with_uri("0/0/ext/0", "./y.glb", vec![]),
                with_uri("0/1", "tiles/1.glb", vec![]),
            ],
        };
        let t = LoadedTileset::from_data(&data, None);
        let uris: Vec<_> = t.tiles.iter().map(|t| t.content_uri.as_deref()).collect();
        assert_eq!(
            uris,
            [
                Some("tiles/0.glb"),
                Some("sub/a/tileset.json"),
                Some("sub/b/x.glb"),
                Some("sub/a/y.glb"),
                Some("tiles/1.glb")
            ]
        );
        let links: Vec<bool> = t.tree.tiles.iter().map(|n| n.external_tileset).collect();
        assert_eq!(links, [false, true, false, false, false]);
        assert_eq!(join_uri("a/b", "../../../c.glb"), "../c.glb");
        assert_eq!(join_uri("a", "https://x.org/t.glb"), "https://x.org/t.glb");
    }

    #[test]
    fn members_strings_parse_and_bad_ones_are_ignored() {
        assert_eq!(
            parse_members(Some(&PropValue::Str("[3, 1,2]".into()))),
            Some(vec![3, 1, 2])
        );
        assert_eq!(parse_members(Some(&PropValue::Str("4,x".into()))), None);
        assert_eq!(parse_members(Some(&PropValue::Int(4))), None);
        assert_eq!(as_u32(Some(&PropValue::Int(-1))), None);
    }
}
