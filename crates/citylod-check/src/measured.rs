//! What the coarse tiles draw, measured against the full detail below them, view-independent: the criterion and the
//! tiles' errors rest on what a tileset declares (each block's Δh, Δa, heights), so these checks hold the declared
//! values to the geometry itself, and a tileset cannot pass by drawing less or otherwise than it says.
//!
//! - Buildings of the leaves that a tile above them does not draw at all (no feature of the tile covers any point of
//!   their roofs, seen from above) vanish where the tile is drawn: allowed only when κ·√area ≤ the tile's
//!   geometricError (their area then counts in a Δa within the error), κ = δH/√δA — for each group of such buildings
//!   within 0.5 m of each other ([`LINK_M`]), so that a block left out whole is not excused building by building.
//! - A block is drawn from its `ground_z_m` up by its `height_m` (within the tile's rounding), its `h_min_m` ≤
//!   `height_m` ≤ `h_max_m`, and its `dh_m` is at least `h_max_m − h_min_m`.
//! - A building drawn in a tile above its leaf (a prism, a simplified model, a landmark) lies within the tile's
//!   geometricError of its leaf geometry: measured vertex to surface both ways, a lower bound of the Hausdorff
//!   distance, so no tolerance beyond rounding is needed.
//!
//! Roofs are the upward-facing triangles (the root frame's z up). Applies to tilesets whose features carry citylod's
//! identity ([`LoadedTileset::identity_checked`]). Not measured: a block's Δa against its buildings' areas, and its
//! buildings' heights against its h_min_m..h_max_m (which buildings a block stands for is not in the tileset, and
//! seen from above a block's outline may cover neighbours' buildings within its error, or parts standing on it).

use std::collections::{BTreeMap, HashMap};

use rayon::prelude::*;

use crate::finding::{Finding, FindingKind};
use crate::tileset::{LoadedTileset, NodeRef, TileInfo};
use crate::vec3::{self, Vec3};
use crate::Tolerances;
use citylod_mesh::hausdorff::{subdivision_centroids, MeshBvh};
use citylod_model::Mesh3d;

/// Least |n_z| / |n| of a triangle that counts as facing up (roofs to ~75° steep).
const UP_COSINE: f64 = 0.25;

/// About how many points of a leaf building's roof are looked for in the tiles above (see
/// [`LeafBuilding::roof_points`]): a building counts as drawn by a tile when one of them is covered.
const SAMPLES_PER_BUILDING: usize = 64;

/// Relative slack on values the writer stores as FLOAT32.
const F32_SLACK: f64 = 2.0 * f32::EPSILON as f64;

/// Rounding of the positions of a tile of error `e` (m) near `at` (m from the origin): coarse tiles put their
/// vertices on a grid of at most e/16 (within e/32 of where they were), leaves on 2 cm (1 cm), plus FLOAT32 noise.
fn rounding_m(e: f64, at: f64) -> f64 {
    e / 32.0 + 0.011 + 1e-6 * at.abs()
}

/// A leaf building as the checks see it.
struct LeafBuilding {
    /// Area of its upward-facing triangles seen from above (its footprint for a prism), m².
    roof_area_m2: f64,
    /// Highest z drawn.
    top_z: f64,
    /// Its box seen from above (min, max).
    xy: ([f64; 2], [f64; 2]),
    /// Its leaf tile and its triangles there.
    tile: usize,
    triangles: Vec<u32>,
    /// Its roof faces down by its winding (a writer that turned every triangle: clients draw both sides).
    flip: bool,
}

impl LeafBuilding {
    /// Points spread over its roof seen from above: each upward triangle cut into m × m similar ones (m by its share
    /// of the roof, about [`SAMPLES_PER_BUILDING`] points in all), their centroids.
    fn roof_points<'a>(&'a self, mesh: &'a Mesh3d) -> impl Iterator<Item = [f64; 2]> + 'a {
        self.triangles.iter().flat_map(move |&k| {
            let up = normal_of(mesh, mesh.triangles[k as usize])
                .map(|(p, n)| (p, if self.flip { vec3::scale(n, -1.0) } else { n }))
                .filter(|(_, n)| faces_up(*n));
            let (p, m) = match up {
                Some((p, n)) => {
                    let share = n[2] / 2.0 / self.roof_area_m2.max(1e-12);
                    let m = (SAMPLES_PER_BUILDING as f64 * share)
                        .sqrt()
                        .ceil()
                        .clamp(1.0, 16.0) as usize;
                    (p, m)
                }
                None => ([[0.0; 3]; 3], 0),
            };
            subdivision_centroids(p, m).map(|q| [q[0], q[1]])
        })
    }
}

/// The cross product of a triangle's edges (twice its area along its normal); `None` for a bad index.
fn normal_of(mesh: &Mesh3d, tri: [u32; 3]) -> Option<([Vec3; 3], Vec3)> {
    let p = tri.map(|v| mesh.positions.get(v as usize).copied());
    let [Some(a), Some(b), Some(c)] = p else {
        return None;
    };
    let n = vec3::cross(vec3::sub(b, a), vec3::sub(c, a));
    vec3::is_finite(n).then_some(([a, b, c], n))
}

/// Whether a triangle with normal `n` faces up.
fn faces_up(n: Vec3) -> bool {
    n[2] > 0.0 && n[2] >= UP_COSINE * vec3::norm(n)
}

/// Every building of the leaf tiles, by building index.
fn leaf_buildings(ts: &LoadedTileset) -> HashMap<u32, LeafBuilding> {
    let mut out: HashMap<u32, LeafBuilding> = HashMap::new();
    for i in ts.leaf_tiles() {
        let t = &ts.tiles[i];
        let Some(mesh) = &t.mesh else { continue };
        let mut per_feature: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
        for (k, &f) in t.triangle_features.iter().enumerate() {
            per_feature.entry(f).or_default().push(k as u32);
        }
        for (f, tris) in per_feature {
            let Some(NodeRef::Building { building_index }) =
                t.features.get(f as usize).map(|f| f.node)
            else {
                continue;
            };
            // A building in two leaves is a finding of its own (check_tree); the first is kept.
            if out.contains_key(&building_index) {
                continue;
            }
            let (mut roof_area_m2, mut floor_area_m2) = (0.0, 0.0);
            let mut top_z = f64::NEG_INFINITY;
            let mut xy = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for &k in &tris {
                let Some((p, n)) = normal_of(mesh, mesh.triangles[k as usize]) else {
                    continue;
                };
                top_z = p.iter().fold(top_z, |z, q| z.max(q[2]));
                for q in p {
                    xy = (
                        [xy.0[0].min(q[0]), xy.0[1].min(q[1])],
                        [xy.1[0].max(q[0]), xy.1[1].max(q[1])],
                    );
                }
                if faces_up(n) {
                    roof_area_m2 += n[2] / 2.0;
                } else if faces_up(vec3::scale(n, -1.0)) {
                    floor_area_m2 -= n[2] / 2.0;
                }
            }
            // Without a triangle facing up, its roof is what faces down (turned the other way round).
            let flip = roof_area_m2 <= 0.0;
            if flip {
                roof_area_m2 = floor_area_m2;
            }
            if roof_area_m2 <= 0.0 {
                continue;
            }
            out.insert(
                building_index,
                LeafBuilding {
                    roof_area_m2,
                    top_z,
                    xy,
                    tile: i,
                    triangles: tris,
                    flip,
                },
            );
        }
    }
    out
}

/// The upward-facing triangles of one tile seen from above, on a grid, for finding which feature covers a point.
struct TopView {
    triangles: Vec<([[f64; 2]; 3], u32)>,
    origin: [f64; 2],
    cell_m: f64,
    columns: usize,
    rows: usize,
    cells: Vec<Vec<u32>>,
}

impl TopView {
    fn new(t: &TileInfo) -> TopView {
        let mut triangles = Vec::new();
        if let Some(mesh) = &t.mesh {
            for (&tri, &f) in mesh.triangles.iter().zip(&t.triangle_features) {
                // Facing up or down: clients draw both sides (a cap turned by its winding still covers).
                if let Some((p, n)) = normal_of(mesh, tri) {
                    if faces_up(n) || faces_up(vec3::scale(n, -1.0)) {
                        triangles.push((p.map(|q| [q[0], q[1]]), f));
                    }
                }
            }
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (p, _) in &triangles {
            for q in p {
                for a in 0..2 {
                    lo[a] = lo[a].min(q[a]);
                    hi[a] = hi[a].max(q[a]);
                }
            }
        }
        let n = triangles.len().max(1) as f64;
        let (w, h) = ((hi[0] - lo[0]).max(1e-3), (hi[1] - lo[1]).max(1e-3));
        // About two triangles a cell, at most 4 million cells.
        let cell_m = ((w * h) / n * 2.0)
            .sqrt()
            .max((w * h / 4e6).sqrt())
            .max(1e-3);
        let columns = if triangles.is_empty() {
            0
        } else {
            (w / cell_m) as usize + 1
        };
        let rows = if triangles.is_empty() {
            0
        } else {
            (h / cell_m) as usize + 1
        };
        let mut view = TopView {
            triangles,
            origin: lo,
            cell_m,
            columns,
            rows,
            cells: vec![Vec::new(); columns * rows],
        };
        for (k, (p, _)) in view.triangles.iter().enumerate() {
            let (c0, r0) = view.cell(
                p.iter()
                    .fold([f64::INFINITY; 2], |m, q| [m[0].min(q[0]), m[1].min(q[1])]),
            );
            let (c1, r1) = view.cell(p.iter().fold([f64::NEG_INFINITY; 2], |m, q| {
                [m[0].max(q[0]), m[1].max(q[1])]
            }));
            for r in r0..=r1 {
                for c in c0..=c1 {
                    view.cells[r * view.columns + c].push(k as u32);
                }
            }
        }
        view
    }

    /// The cell holding `p`, clamped to the grid.
    fn cell(&self, p: [f64; 2]) -> (usize, usize) {
        let at = |v: f64, o: f64, n: usize| {
            (((v - o) / self.cell_m).max(0.0) as usize).min(n.saturating_sub(1))
        };
        (
            at(p[0], self.origin[0], self.columns),
            at(p[1], self.origin[1], self.rows),
        )
    }

    /// The feature of a triangle covering `p` (seen from above), if any.
    fn feature_at(&self, p: [f64; 2]) -> Option<u32> {
        if self.cells.is_empty() || !p.iter().all(|v| v.is_finite()) {
            return None;
        }
        let (c, r) = self.cell(p);
        self.cells[r * self.columns + c].iter().find_map(|&k| {
            let (t, f) = &self.triangles[k as usize];
            inside(p, t).then_some(*f)
        })
    }
}

/// Whether `p` lies in the triangle `t` (either winding; on an edge counts).
fn inside(p: [f64; 2], t: &[[f64; 2]; 3]) -> bool {
    let side =
        |a: [f64; 2], b: [f64; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    let s = [side(t[0], t[1]), side(t[1], t[2]), side(t[2], t[0])];
    let scale = 1e-12
        * (1.0
            + t.iter()
                .map(|q| q[0].abs() + q[1].abs())
                .fold(0.0, f64::max))
        .powi(2);
    s.iter().all(|&v| v >= -scale) || s.iter().all(|&v| v <= scale)
}

/// The triangles `tris` of `mesh` as a mesh of their own, with only the positions they use (a triangle with an
/// index out of range left out).
fn sub_mesh(mesh: &Mesh3d, tris: &[u32]) -> Mesh3d {
    let mut index: HashMap<u32, u32> = HashMap::new();
    let mut out = Mesh3d {
        positions: Vec::new(),
        triangles: Vec::new(),
    };
    for t in tris.iter().filter_map(|&k| mesh.triangles.get(k as usize)) {
        if t.iter().any(|&v| v as usize >= mesh.positions.len()) {
            continue;
        }
        let tri = t.map(|v| {
            *index.entry(v).or_insert_with(|| {
                out.positions.push(mesh.positions[v as usize]);
                out.positions.len() as u32 - 1
            })
        });
        out.triangles.push(tri);
    }
    out
}

/// Largest distance from a vertex of `from` to the surface of `to` (0 when `to` has no triangle): a lower bound of
/// the one-sided Hausdorff distance.
fn farthest_vertex_m(from: &Mesh3d, to: &Mesh3d) -> f64 {
    let bvh = MeshBvh::new(to);
    from.positions
        .iter()
        .filter_map(|&p| bvh.closest(p).map(|(d, _)| d))
        .fold(0.0, f64::max)
}

/// The view-independent measurements of the module's doc, one finding per tile and kind.
pub fn check_measured(ts: &LoadedTileset, tol: Tolerances) -> Vec<Finding> {
    if !ts.identity_checked() {
        return Vec::new();
    }
    let kappa = tol.dh_px / tol.da_px.sqrt();
    let leaves = leaf_buildings(ts);
    // Tile by tile, in parallel; the findings in tile order.
    (0..ts.tiles.len())
        .into_par_iter()
        .map(|i| {
            let mut out = Vec::new();
            tile_measured(ts, i, kappa, &leaves, &mut out);
            out
        })
        .collect::<Vec<Vec<Finding>>>()
        .into_iter()
        .flatten()
        .collect()
}

/// [`check_measured`] of tile `i`.
fn tile_measured(
    ts: &LoadedTileset,
    i: usize,
    kappa: f64,
    leaves: &HashMap<u32, LeafBuilding>,
    out: &mut Vec<Finding>,
) {
    let t = &ts.tiles[i];
    let node = &ts.tree.tiles[i];
    let Some(mesh) = &t.mesh else { return };
    if node.children.is_empty() || mesh.triangles.is_empty() {
        return;
    }
    let e = node.geometric_error_m;
    let top = TopView::new(t);
    // Buildings the tile draws as themselves.
    let mut own: HashMap<u32, usize> = HashMap::new();
    for (k, f) in t.features.iter().enumerate() {
        if let NodeRef::Building { building_index } = f.node {
            own.entry(building_index).or_insert(k);
        }
    }
    // The buildings below that no feature of the tile draws, seen from above, in groups of neighbours.
    let mut under = t.under.clone();
    under.dedup();
    let uncovered: Vec<u32> = under
        .iter()
        .copied()
        .filter(|b| !own.contains_key(b))
        .filter(|b| {
            leaves.get(b).is_some_and(|leaf| {
                ts.tiles[leaf.tile]
                    .mesh
                    .as_ref()
                    .is_some_and(|m| !leaf.roof_points(m).any(|p| top.feature_at(p).is_some()))
            })
        })
        .collect();
    let mut groups: Vec<(f64, Vec<u32>)> = neighbours(&uncovered, leaves, LINK_M)
        .into_iter()
        .map(|g| {
            (
                kappa * g.iter().map(|b| leaves[b].roof_area_m2).sum::<f64>().sqrt(),
                g,
            )
        })
        .filter(|(error, _)| *error > e * (1.0 + F32_SLACK))
        .collect();
    if !groups.is_empty() {
        groups.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let list: Vec<u32> = groups.iter().flat_map(|g| g.1.iter().copied()).collect();
        let (error, first) = (groups[0].0, &groups[0].1);
        out.push(
                Finding::at(
                    FindingKind::BuildingVanishes,
                    ts,
                    i,
                    format!(
                        "{} building(s) below the tile are not drawn by it (no feature of it covers their roofs), in \
                         {} group(s) of neighbours too large to vanish: the largest, of {} building(s), with \
                         κ·√area = {error:.2} m, beyond the tile's geometricError {e} m",
                        list.len(),
                        groups.len(),
                        first.len()
                    ),
                )
                .node(NodeRef::Building { building_index: first[0] })
                .values(error, e)
                .buildings(&list),
            );
    }
    check_blocks(ts, i, out);
    check_buildings_drawn_coarse(ts, i, leaves, &own, out);
}

/// Buildings left out of a tile count as one group when their boxes seen from above lie within 0.5 m of each other:
/// buildings that share walls or nearly do, which every level merges first, so that one block left out whole is not
/// excused building by building. (Farther links join buildings of different blocks: at 1 m, a row of a generated
/// city's buildings 0.76 m apart; at the tile's e/16, the coarse tiles' scattered small buildings, across kilometres.)
const LINK_M: f64 = 0.5;

/// Side (m) of the cells that find buildings near each other: about a building's size.
const CELL_M: f64 = 32.0;

/// `buildings` in groups of neighbours: linked when their roofs' boxes seen from above are within `link_m`, each
/// group sorted.
fn neighbours(
    buildings: &[u32],
    leaves: &HashMap<u32, LeafBuilding>,
    link_m: f64,
) -> Vec<Vec<u32>> {
    let n = buildings.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut a: usize) -> usize {
        while parent[a] != a {
            parent[a] = parent[parent[a]];
            a = parent[a];
        }
        a
    }
    let boxes: Vec<([f64; 2], [f64; 2])> = buildings.iter().map(|b| leaves[b].xy).collect();
    // Boxes grown by half the link on a grid of cells (of the link, at least CELL_M): linked boxes share a cell.
    let size = link_m.max(CELL_M);
    let mut cells: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (k, (lo, hi)) in boxes.iter().enumerate() {
        let cell = |v: f64| ((v / size).floor()).clamp(-1e12, 1e12) as i64;
        let (c0, c1) = (cell(lo[0] - link_m / 2.0), cell(hi[0] + link_m / 2.0));
        let (r0, r1) = (cell(lo[1] - link_m / 2.0), cell(hi[1] + link_m / 2.0));
        // A building spanning more than 64 × 64 cells is registered along its box's edges only (whatever links to it
        // from outside comes through them).
        let wide = (c1 - c0) > 64 || (r1 - r0) > 64;
        for c in c0..=c1 {
            for r in r0..=r1 {
                if !wide || c == c0 || c == c1 || r == r0 || r == r1 {
                    cells.entry((c, r)).or_default().push(k);
                }
            }
        }
    }
    let gap = |a: usize, b: usize| {
        let ((alo, ahi), (blo, bhi)) = (boxes[a], boxes[b]);
        let d = |i: usize| (blo[i] - ahi[i]).max(alo[i] - bhi[i]).max(0.0);
        d(0).hypot(d(1))
    };
    let mut keys: Vec<&(i64, i64)> = cells.keys().collect();
    keys.sort_unstable();
    for key in keys {
        let members = &cells[key];
        for (x, &a) in members.iter().enumerate() {
            for &b in &members[x + 1..] {
                let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                if ra != rb && gap(a, b) <= link_m {
                    parent[ra.max(rb)] = ra.min(rb);
                }
            }
        }
    }
    let mut groups: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
    for (k, &b) in buildings.iter().enumerate() {
        let r = root(&mut parent, k);
        groups.entry(r).or_default().push(b);
    }
    groups
        .into_values()
        .map(|mut g| {
            g.sort_unstable();
            g
        })
        .collect()
}

/// A tile's blocks against their declared heights.
fn check_blocks(ts: &LoadedTileset, i: usize, out: &mut Vec<Finding>) {
    let t = &ts.tiles[i];
    let e = ts.tree.tiles[i].geometric_error_m;
    let mut misdrawn: Vec<(usize, String)> = Vec::new();
    let mut understated: Vec<(usize, f64, f64, String)> = Vec::new();
    // Features drawn as prisms: every vertex at their lowest or highest z (within the rounding). A block of one
    // building may be drawn as its 3D model instead, whose heights are not the block's.
    let mut prism = vec![true; t.features.len()];
    if let Some(mesh) = &t.mesh {
        for (tri, &f) in mesh.triangles.iter().zip(&t.triangle_features) {
            let Some(feature) = t.features.get(f as usize) else {
                continue;
            };
            let Some((lo, hi)) = feature.bounds_m else {
                continue;
            };
            let r = rounding_m(e, hi[2]);
            let off = tri
                .iter()
                .filter_map(|&v| mesh.positions.get(v as usize))
                .any(|p| (p[2] - lo[2]).abs() > r && (p[2] - hi[2]).abs() > r);
            if off {
                prism[f as usize] = false;
            }
        }
    }
    for (k, f) in t.features.iter().enumerate() {
        if !matches!(f.node, NodeRef::Cluster { .. }) || f.fallback {
            continue;
        }
        let Some(h) = f.heights else { continue };
        let top = h.ground_z_m + h.height_m;
        if let Some((lo, hi)) = f.bounds_m.filter(|_| prism[k]) {
            let r = rounding_m(e, top);
            if (lo[2] - h.ground_z_m).abs() > r || (hi[2] - top).abs() > r {
                misdrawn.push((
                    k,
                    format!(
                        "is drawn from z {:.2} to {:.2} m where its ground_z_m and height_m say {:.2} to {:.2} m",
                        lo[2], hi[2], h.ground_z_m, top
                    ),
                ));
            }
        }
        // FLOAT32 values: each within a relative 2^-24 of what was meant.
        let slack =
            F32_SLACK * (h.h_max_m.abs() + h.h_min_m.abs() + h.height_m.abs() + f.dh_m + 1.0);
        let spread = h.h_max_m - h.h_min_m;
        if h.h_min_m > h.height_m + slack || h.height_m > h.h_max_m + slack {
            misdrawn.push((
                k,
                format!(
                    "has a height_m of {:.2} m outside its h_min_m..h_max_m {:.2}..{:.2} m",
                    h.height_m, h.h_min_m, h.h_max_m
                ),
            ));
        }
        if f.dh_m + slack < spread {
            understated.push((
                k,
                spread,
                f.dh_m,
                format!(
                    "its dh_m {:.2} m is less than its h_max_m − h_min_m = {spread:.2} m",
                    f.dh_m
                ),
            ));
        }
    }
    if let Some((k, why)) = misdrawn.first() {
        out.push(
            Finding::at(
                FindingKind::BlockMisdrawn,
                ts,
                i,
                format!(
                    "{} block(s) of the tile disagree with their metadata; the first {why}",
                    misdrawn.len()
                ),
            )
            .node(t.features[*k].node),
        );
    }
    if let Some((k, measured, declared, why)) = understated.first() {
        out.push(
            Finding::at(
                FindingKind::ErrorUnderstated,
                ts,
                i,
                format!(
                    "{} block(s) of the tile declare a Δh below their buildings' spread of heights; the first: {why}",
                    understated.len()
                ),
            )
            .node(t.features[*k].node)
            .values(*measured, *declared),
        );
    }
}

/// Buildings a tile above their leaf draws as themselves (prisms, simplified models, landmarks): within the tile's
/// geometricError of their leaf geometry.
fn check_buildings_drawn_coarse(
    ts: &LoadedTileset,
    i: usize,
    leaves: &HashMap<u32, LeafBuilding>,
    own: &HashMap<u32, usize>,
    out: &mut Vec<Finding>,
) {
    let t = &ts.tiles[i];
    let e = ts.tree.tiles[i].geometric_error_m;
    let Some(mesh) = &t.mesh else { return };
    let mut per_feature: HashMap<u32, Vec<u32>> = HashMap::new();
    for (k, &f) in t.triangle_features.iter().enumerate() {
        per_feature.entry(f).or_default().push(k as u32);
    }
    let mut far: Vec<(u32, f64)> = Vec::new();
    let mut unheld: Vec<u32> = Vec::new();
    let mut own: Vec<(&u32, &usize)> = own.iter().collect();
    own.sort_unstable();
    for (&b, &k) in own {
        let Some(coarse) = per_feature.get(&(k as u32)) else {
            continue;
        };
        if !ts.buildings.contains(&b) {
            unheld.push(b);
            continue;
        }
        let Some(leaf) = leaves.get(&b) else { continue };
        let Some(leaf_mesh) = &ts.tiles[leaf.tile].mesh else {
            continue;
        };
        let reach = e + rounding_m(e, leaf.top_z) + 0.011;
        let (coarse, full) = (sub_mesh(mesh, coarse), sub_mesh(leaf_mesh, &leaf.triangles));
        let d = farthest_vertex_m(&coarse, &full);
        let d = if d > reach {
            d
        } else {
            d.max(farthest_vertex_m(&full, &coarse))
        };
        if d > reach {
            far.push((b, d));
        }
    }
    if !unheld.is_empty() {
        out.push(
            Finding::at(
                FindingKind::ErrorUnderstated,
                ts,
                i,
                format!(
                    "{} building(s) the tile draws as themselves are held by no leaf (building_index {}…): how far \
                     they lie from full detail cannot be measured, and what they stand for is not drawn below",
                    unheld.len(),
                    unheld[0]
                ),
            )
            .node(NodeRef::Building { building_index: unheld[0] })
            .buildings(&unheld),
        );
    }
    if far.is_empty() {
        return;
    }
    far.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    let list: Vec<u32> = far.iter().map(|f| f.0).collect();
    out.push(
        Finding::at(
            FindingKind::ErrorUnderstated,
            ts,
            i,
            format!(
                "{} building(s) the tile draws as themselves lie farther from their leaf geometry than its \
                 geometricError {e} m allows: the farthest {:.2} m (vertex to surface)",
                far.len(),
                far[0].1
            ),
        )
        .node(NodeRef::Building { building_index: far[0].0 })
        .values(far[0].1, e)
        .buildings(&list),
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::box_mesh;
    use crate::select::{OrientedBox, TileNode, TileTree};
    use crate::tileset::{BlockHeights, FeatureInfo};

    /// Boxes as one tile's content: each (feature, min, max).
    fn content(boxes: &[(FeatureInfo, Vec3, Vec3)]) -> (Mesh3d, Vec<FeatureInfo>, Vec<u32>) {
        let mut mesh = Mesh3d {
            positions: Vec::new(),
            triangles: Vec::new(),
        };
        let mut features = Vec::new();
        let mut triangle_features = Vec::new();
        for (k, (f, lo, hi)) in boxes.iter().enumerate() {
            let b = box_mesh(*lo, *hi);
            let base = mesh.positions.len() as u32;
            mesh.positions.extend(&b.positions);
            mesh.triangles
                .extend(b.triangles.iter().map(|t| t.map(|v| v + base)));
            triangle_features.extend(std::iter::repeat_n(k as u32, b.triangles.len()));
            features.push(FeatureInfo {
                bounds_m: Some((*lo, *hi)),
                ..f.clone()
            });
        }
        (mesh, features, triangle_features)
    }

    fn building(b: u32) -> FeatureInfo {
        FeatureInfo::building(b)
    }

    /// A block standing from 0 to `height` with heights `h_min..h_max` and Δh `dh`.
    fn block(members: u32, height: f64, h: (f64, f64), dh: f64) -> FeatureInfo {
        FeatureInfo {
            node: NodeRef::Cluster {
                level: 1,
                node_index: 0,
            },
            member_count: Some(members),
            members: None,
            dh_m: dh,
            da_m2: 0.0,
            area_m2: None,
            fallback: false,
            bounds_m: None,
            heights: Some(BlockHeights {
                ground_z_m: 0.0,
                height_m: height,
                h_min_m: h.0,
                h_max_m: h.1,
            }),
        }
    }

    /// A root of error `e` drawing `root` above one leaf drawing `leaf` (buildings only).
    fn tileset(
        e: f64,
        root: &[(FeatureInfo, Vec3, Vec3)],
        leaf: &[(FeatureInfo, Vec3, Vec3)],
    ) -> LoadedTileset {
        let tile = |path: &str, boxes: &[(FeatureInfo, Vec3, Vec3)]| {
            let (mesh, features, triangle_features) = content(boxes);
            TileInfo {
                path_in_tree: path.into(),
                content_uri: Some(format!("tiles/{path}.glb")),
                content_bytes: 0,
                content_uris: vec![],
                volume_kind: Default::default(),
                exact_volume: None,
                mesh: Some(mesh),
                features,
                triangle_features,
                under: Vec::new(),
            }
        };
        let mut tiles = vec![tile("0", root), tile("0/0", leaf)];
        let mut under: Vec<u32> = leaf
            .iter()
            .filter_map(|(f, _, _)| match f.node {
                NodeRef::Building { building_index } => Some(building_index),
                _ => None,
            })
            .collect();
        under.sort_unstable();
        tiles[0].under = under.clone();
        tiles[1].under = under.clone();
        let node = |e: f64, children: Vec<usize>| TileNode {
            bounds: OrientedBox::from_min_max([-1e3; 3], [1e3; 3]),
            geometric_error_m: e,
            children,
            has_content: true,
            external_tileset: false,
        };
        LoadedTileset {
            tree: TileTree {
                tiles: vec![node(e, vec![1]), node(0.0, vec![])],
                root: 0,
                tileset_geometric_error_m: 100.0,
            },
            tiles,
            buildings: under.into_iter().collect(),
            written_by_citylod: true,
        }
    }

    fn kinds(ts: &LoadedTileset) -> Vec<FindingKind> {
        check_measured(ts, Tolerances::default())
            .iter()
            .map(|f| f.kind)
            .collect()
    }

    /// Two 10 m × 10 m buildings, 10 and 14 m high, 2 m apart (κ·√100 ≈ 14.1 m each).
    fn two_buildings() -> Vec<(FeatureInfo, Vec3, Vec3)> {
        vec![
            (building(0), [0.0, 0.0, 0.0], [10.0, 10.0, 10.0]),
            (building(1), [12.0, 0.0, 0.0], [22.0, 10.0, 14.0]),
        ]
    }

    #[test]
    fn a_block_over_its_buildings_passes_and_one_shrunk_to_a_speck_lets_them_vanish() {
        let leaf = two_buildings();
        let honest = tileset(
            4.0,
            &[(
                block(2, 12.0, (10.0, 14.0), 4.0),
                [0.0, 0.0, 0.0],
                [22.0, 10.0, 12.0],
            )],
            &leaf,
        );
        assert_eq!(kinds(&honest), []);
        // The same block drawn 1 m wide: both buildings' roofs uncovered, each too large for an error of 4 m.
        let speck = tileset(
            4.0,
            &[(
                block(2, 12.0, (10.0, 14.0), 4.0),
                [0.0, 0.0, 0.0],
                [1.0, 1.0, 12.0],
            )],
            &leaf,
        );
        let found = check_measured(&speck, Tolerances::default());
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].kind, FindingKind::BuildingVanishes);
        assert_eq!(found[0].buildings, [0, 1]);
        // Half of each building drawn: not vanished (a simplified outline is Δa's business, within the error).
        let half = tileset(
            4.0,
            &[
                (
                    block(1, 12.0, (10.0, 14.0), 4.0),
                    [0.0, 0.0, 0.0],
                    [5.0, 10.0, 12.0],
                ),
                (
                    block(1, 12.0, (10.0, 14.0), 4.0),
                    [12.0, 0.0, 0.0],
                    [17.0, 10.0, 12.0],
                ),
            ],
            &leaf,
        );
        assert_eq!(kinds(&half), []);
        // An error of 15 m lets each vanish alone, but not both together when they stand 0.3 m apart (within
        // LINK_M): one loss of 200 m² (κ·√200 = 20 m).
        let close = vec![
            (building(0), [0.0, 0.0, 0.0], [10.0, 10.0, 10.0]),
            (building(1), [10.3, 0.0, 0.0], [20.3, 10.0, 14.0]),
        ];
        let none = tileset(
            15.0,
            &[(
                block(2, 12.0, (10.0, 14.0), 4.0),
                [100.0, 0.0, 0.0],
                [101.0, 1.0, 12.0],
            )],
            &close,
        );
        let found = check_measured(&none, Tolerances::default());
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].kind, FindingKind::BuildingVanishes);
        assert!(
            (found[0].measured.unwrap() - 20.0).abs() < 1e-9,
            "{found:?}"
        );
        // 2 m apart (beyond the link) they are two losses, each within the error.
        let none = tileset(
            15.0,
            &[(
                block(2, 12.0, (10.0, 14.0), 4.0),
                [100.0, 0.0, 0.0],
                [101.0, 1.0, 12.0],
            )],
            &leaf,
        );
        assert_eq!(kinds(&none), []);
    }

    #[test]
    fn a_block_drawn_otherwise_than_its_heights_or_understating_its_spread_is_found() {
        let leaf = two_buildings();
        let drawn = |b: FeatureInfo, top: f64| {
            tileset(4.0, &[(b, [0.0, 0.0, 0.0], [22.0, 10.0, top])], &leaf)
        };
        // Drawn 6 m high where it says 12 m (beyond the rounding of an error of 4 m: 0.135 m).
        assert_eq!(
            kinds(&drawn(block(2, 12.0, (10.0, 14.0), 4.0), 6.0)),
            [FindingKind::BlockMisdrawn]
        );
        assert_eq!(kinds(&drawn(block(2, 12.0, (10.0, 14.0), 4.0), 12.1)), []);
        // A height outside its own range.
        assert_eq!(
            kinds(&drawn(block(2, 16.0, (10.0, 14.0), 4.0), 16.0)),
            [FindingKind::BlockMisdrawn]
        );
        // Δh below h_max − h_min.
        let found = check_measured(
            &drawn(block(2, 12.0, (10.0, 14.0), 1.0), 12.0),
            Tolerances::default(),
        );
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].kind, FindingKind::ErrorUnderstated);
        assert_eq!((found[0].measured, found[0].limit), (Some(4.0), Some(1.0)));
    }

    #[test]
    fn roofs_turned_the_other_way_round_still_count_and_a_block_drawn_as_a_model_is_not_held_to_a_prism(
    ) {
        // Leaves whose every triangle is turned (clients draw both sides): their roofs face down by their winding,
        // and a block shrunk to a speck still lets them vanish.
        let mut speck = tileset(
            4.0,
            &[(
                block(2, 12.0, (10.0, 14.0), 4.0),
                [0.0, 0.0, 0.0],
                [1.0, 1.0, 12.0],
            )],
            &two_buildings(),
        );
        // (Without their floors, as citylod writes buildings: box_mesh's first two triangles of each twelve.)
        let leaf = &mut speck.tiles[1];
        let keep = |k: &usize| k % 12 >= 2;
        let mesh = leaf.mesh.as_mut().unwrap();
        mesh.triangles = mesh
            .triangles
            .iter()
            .enumerate()
            .filter(|(k, _)| keep(k))
            .map(|(_, t)| [t[0], t[2], t[1]])
            .collect();
        leaf.triangle_features = leaf
            .triangle_features
            .iter()
            .enumerate()
            .filter(|(k, _)| keep(k))
            .map(|(_, f)| *f)
            .collect();
        assert_eq!(kinds(&speck), [FindingKind::BuildingVanishes]);
        // A block of one building drawn as its model (a gable: vertices between its lowest and highest z), its
        // metadata the building's attribute height: not a block drawn otherwise than it says.
        let mut model = tileset(
            4.0,
            &[(
                block(1, 8.0, (8.0, 8.0), 0.0),
                [0.0, 0.0, 0.0],
                [10.0, 10.0, 8.0],
            )],
            &[(building(0), [0.0, 0.0, 0.0], [10.0, 10.0, 8.0])],
        );
        let coarse = model.tiles[0].mesh.as_mut().unwrap();
        for p in coarse
            .positions
            .iter_mut()
            .filter(|p| p[2] == 8.0 && p[0] == 10.0)
        {
            p[2] = 20.0; // the roof rises to 20 m along one side ...
        }
        coarse.positions.push([5.0, 5.0, 14.0]); // ... through a point at 14 m
        let n = coarse.positions.len() as u32 - 1;
        coarse.triangles.push([0, 1, n]);
        model.tiles[0].triangle_features.push(0);
        model.tiles[0].features[0].bounds_m = Some(([0.0; 3], [10.0, 10.0, 20.0]));
        assert_eq!(kinds(&model), []);
        // The same drawn as a prism 20 m high: found.
        let prism = tileset(
            4.0,
            &[(
                block(1, 8.0, (8.0, 8.0), 0.0),
                [0.0, 0.0, 0.0],
                [10.0, 10.0, 20.0],
            )],
            &[(building(0), [0.0, 0.0, 0.0], [10.0, 10.0, 8.0])],
        );
        assert_eq!(kinds(&prism), [FindingKind::BlockMisdrawn]);
    }

    #[test]
    fn a_building_drawn_above_the_leaves_that_no_leaf_holds_is_found() {
        let leaf = vec![(building(0), [0.0, 0.0, 0.0], [10.0, 10.0, 20.0])];
        let coarse = vec![
            (building(0), [0.0, 0.0, 0.0], [10.0, 10.0, 20.0]),
            (building(7), [20.0, 0.0, 0.0], [30.0, 10.0, 20.0]),
        ];
        let found = check_measured(&tileset(5.0, &coarse, &leaf), Tolerances::default());
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].kind, FindingKind::ErrorUnderstated);
        assert_eq!(found[0].buildings, [7]);
    }

    #[test]
    fn a_building_drawn_above_its_leaf_must_lie_within_the_error_of_its_leaf_geometry() {
        // The leaf draws building 0 20 m high; the root draws it as a 12 m prism.
        let leaf = vec![(building(0), [0.0, 0.0, 0.0], [10.0, 10.0, 20.0])];
        let coarse = vec![(building(0), [0.0, 0.0, 0.0], [10.0, 10.0, 12.0])];
        let found = check_measured(&tileset(5.0, &coarse, &leaf), Tolerances::default());
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].kind, FindingKind::ErrorUnderstated);
        assert!((found[0].measured.unwrap() - 8.0).abs() < 1e-9, "{found:?}");
        assert_eq!(kinds(&tileset(8.0, &coarse, &leaf)), []);
        // The same building drawn whole above its leaf (a landmark) is exact.
        assert_eq!(kinds(&tileset(0.5, &leaf, &leaf)), []);
    }

    #[test]
    fn points_in_triangles_either_way_round() {
        let t = [[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]];
        let r = [t[0], t[2], t[1]];
        for tri in [t, r] {
            assert!(inside([1.0, 1.0], &tri));
            assert!(inside([2.0, 0.0], &tri));
            assert!(!inside([3.0, 3.0], &tri));
            assert!(!inside([-0.1, 1.0], &tri));
        }
    }

    #[test]
    fn distances_to_a_triangle_from_above_beside_and_beyond_a_corner() {
        // The distance of one point from one triangle, as farthest_vertex_m measures it.
        let point_triangle_m = |p: Vec3, t: [Vec3; 3]| {
            let one = |positions: Vec<Vec3>, triangles| Mesh3d {
                positions,
                triangles,
            };
            farthest_vertex_m(&one(vec![p], vec![]), &one(t.to_vec(), vec![[0, 1, 2]]))
        };
        let t = [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0]];
        assert!((point_triangle_m([1.0, 1.0, 3.0], t) - 3.0).abs() < 1e-12);
        assert!((point_triangle_m([2.0, -2.0, 0.0], t) - 2.0).abs() < 1e-12);
        assert!((point_triangle_m([-3.0, -4.0, 0.0], t) - 5.0).abs() < 1e-12);
        assert!((point_triangle_m([3.0, 3.0, 0.0], t) - 2.0f64.sqrt()).abs() < 1e-12);
    }
}
