//! One view of `citylod check` (DESIGN.md §6): select the cut a standard client draws, validate it
//! (coverage, seed criterion), render it and the full-detail leaves from the same camera, compare
//! them and judge the skyline. Pixels for images, metres for geometry (root frame).
//! Invariant: the same tileset, camera and settings give identical images and findings.

use serde::Serialize;

use crate::camera::{Camera, Viewport};
use crate::compare::{compare, ImageMetrics};
use crate::coverage::check_cut;
use crate::criterion::{check_criterion, CriterionStats, Tolerances};
use crate::finding::{Finding, FindingKind};
use crate::render::{RenderLayers, Renderer, NO_FEATURE, SKY};
use crate::select::{select, Selection};
use crate::tileset::{FeatureInfo, LoadedTileset, NodeRef};
use crate::{CheckError, Image, Scene};

/// Colour of every building and block, so colour changes between cut and full come from shape.
const BUILDING_COLOUR: [u8; 4] = [222, 208, 186, 255];

/// Extra skyline shift (px) allowed over δH: one pixel of rasterization on each image, plus the
/// slack between the SSE distance (to the tile box) and the true distance of the block's top.
pub const SKYLINE_TOLERANCE_PX: f64 = 4.0;

/// What one check run uses for every view.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CheckSettings {
    /// The client's maximum screen-space error (px), CesiumJS's `maximumScreenSpaceError`.
    pub sse_px: f64,
    pub tolerances: Tolerances,
    #[serde(skip)]
    pub viewport: Viewport,
    /// Skyline shift allowed over δH (px).
    pub skyline_tolerance_px: f64,
}

/// Skyline comparison over the columns where both renders show the same place on top.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Skyline {
    /// Columns where both renders have the same place on top (see [`skyline`]).
    pub columns: u32,
    /// Largest and mean |top row in cut − top row in full| over those columns (px).
    pub max_shift_px: u32,
    pub mean_shift_px: f64,
    /// Columns whose shift exceeds δH + tolerance.
    pub columns_over_limit: u32,
    /// Σ over columns of the shift beyond δH + tolerance (px²): the screen area by which the
    /// skyline breaks the height tolerance.
    pub excess_area_px2: f64,
}

/// Everything one view produced.
#[derive(Debug, Clone)]
pub struct ViewOutcome {
    pub selection: Selection,
    pub findings: Vec<Finding>,
    /// How close the drawn blocks come to δH and δA.
    pub criterion: CriterionStats,
    pub cut: Image,
    pub full: Image,
    pub metrics: ImageMetrics,
    pub skyline: Skyline,
    /// Triangles of the selected tiles' content.
    pub cut_triangles: usize,
    /// Triangles of the full-detail leaf tiles in view (frustum-culled by box), and of all leaves.
    pub full_triangles: usize,
    pub full_triangles_total: usize,
    /// Bytes of the selected tiles' content files, of those and the refined tiles' (what a client loads on its
    /// way down to the cut: CesiumJS and 3d-tiles-renderer load a tile before refining it), and of the leaf tiles
    /// in view.
    pub cut_bytes: u64,
    pub loaded_bytes: u64,
    pub full_bytes: u64,
    /// Leaf tiles drawn for full detail.
    pub full_tiles: usize,
}

/// Runs every per-view check for `camera`. Errors only when rendering fails.
pub fn check_view(
    ts: &LoadedTileset,
    renderer: &Renderer,
    camera: &Camera,
    settings: &CheckSettings,
) -> Result<ViewOutcome, CheckError> {
    let vp = settings.viewport;
    let selection = select(&ts.tree, camera, vp, settings.sse_px);
    let mut findings = check_cut(ts, &selection);
    let (criterion_findings, criterion) =
        check_criterion(ts, &selection, camera, vp, settings.tolerances);
    findings.extend(criterion_findings);

    let offsets = feature_offsets(ts);
    let leaves = ts.leaf_tiles();
    let in_view: Vec<usize> = leaves
        .iter()
        .copied()
        .filter(|&i| ts.tree.tiles[i].bounds.is_visible(camera, vp))
        .collect();
    let render = |tiles: &[usize]| render_tiles(renderer, camera, vp, ts, &offsets, tiles);
    let cut = render(&selection.selected)?;
    let full = render(&in_view)?;
    let metrics = compare(&cut.colour, &full.colour, SKY)?;

    let limit_px = settings.tolerances.dh_px + settings.skyline_tolerance_px;
    let skyline = skyline(&cut, &full, limit_px, |a, b| {
        match (feature_of(ts, &offsets, a), feature_of(ts, &offsets, b)) {
            (Some(a), Some(b)) => same_place(a, b),
            _ => false,
        }
    });
    // A narrow spike is an area change (bounded by δA), not a height error: only a skyline that
    // breaks δH + tolerance over more than δA px² is a finding.
    if skyline.excess_area_px2 > settings.tolerances.da_px {
        findings.push(
            Finding::at(
                FindingKind::SkylineShift,
                ts,
                usize::MAX,
                format!(
                    "the cut's skyline moves up to {} px from full detail's; {} of {} columns \
                     exceed δH + {} px by {:.0} px² in all (limit δA)",
                    skyline.max_shift_px,
                    skyline.columns_over_limit,
                    skyline.columns,
                    settings.skyline_tolerance_px,
                    skyline.excess_area_px2
                ),
            )
            .values(skyline.excess_area_px2, settings.tolerances.da_px),
        );
    }

    let sum = |tiles: &[usize], f: &dyn Fn(usize) -> u64| tiles.iter().map(|&i| f(i)).sum::<u64>();
    let tris = |i: usize| ts.tiles[i].triangle_count() as u64;
    let bytes = |i: usize| ts.tiles[i].content_bytes;
    let cut_bytes = sum(&selection.selected, &bytes);
    Ok(ViewOutcome {
        cut_triangles: sum(&selection.selected, &tris) as usize,
        full_triangles: sum(&in_view, &tris) as usize,
        full_triangles_total: sum(&leaves, &tris) as usize,
        cut_bytes,
        loaded_bytes: cut_bytes + sum(&selection.refined, &bytes),
        full_bytes: sum(&in_view, &bytes),
        full_tiles: in_view.len(),
        selection,
        findings,
        criterion,
        cut: cut.colour,
        full: full.colour,
        metrics,
        skyline,
    })
}

/// Id drawn for triangles without a feature.
const UNKNOWN_FEATURE: u32 = u32::MAX - 1;

/// Global feature ids: tile `i`'s feature `f` is drawn with id `offsets[i] + f`.
fn feature_offsets(ts: &LoadedTileset) -> Vec<u32> {
    let mut acc = 0u32;
    ts.tiles
        .iter()
        .map(|t| {
            let o = acc;
            acc = acc.saturating_add(t.features.len() as u32);
            o
        })
        .collect()
}

/// The feature drawn with global id `id`.
fn feature_of<'a>(ts: &'a LoadedTileset, offsets: &[u32], id: u32) -> Option<&'a FeatureInfo> {
    let i = offsets.partition_point(|&o| o <= id).checked_sub(1)?;
    ts.tiles[i].features.get((id - offsets[i]) as usize)
}

/// Triangles gathered before they are drawn and freed: full detail of a whole city does not fit in memory
/// at once (a million buildings, ~10 million triangles: ~3 GB of scene, vertices and GPU buffers).
const BATCH_TRIANGLES: usize = 1 << 20;

/// Renders the content of `tiles`, in order, in batches of about [`BATCH_TRIANGLES`] (the same layers as one
/// scene of them all, see [`crate::render::Canvas`]).
fn render_tiles(
    renderer: &Renderer,
    camera: &Camera,
    vp: Viewport,
    ts: &LoadedTileset,
    offsets: &[u32],
    tiles: &[usize],
) -> Result<RenderLayers, CheckError> {
    let mut canvas = renderer.canvas(camera, vp.width_px, vp.height_px)?;
    let mut scene = Scene::new();
    for &i in tiles {
        add_tile(&mut scene, ts, offsets, i)?;
        if scene.triangle_count() >= BATCH_TRIANGLES {
            canvas.draw(&std::mem::take(&mut scene))?;
        }
    }
    canvas.draw(&scene)?;
    canvas.finish()
}

fn add_tile(
    scene: &mut Scene,
    ts: &LoadedTileset,
    offsets: &[u32],
    i: usize,
) -> Result<(), CheckError> {
    let t = &ts.tiles[i];
    let Some(mesh) = &t.mesh else { return Ok(()) };
    let ids: Vec<u32> = (0..mesh.triangles.len())
        .map(|k| match t.triangle_features.get(k) {
            Some(&f) if f != u32::MAX => offsets[i].saturating_add(f).min(UNKNOWN_FEATURE - 1),
            _ => UNKNOWN_FEATURE,
        })
        .collect();
    scene.add_mesh_with_ids(mesh, BUILDING_COLOUR, &ids)
}

/// Whether the cut's feature and full detail's building on top of a column are the same part of the
/// city: the building is the feature itself, or stands within the block's ground extent (1 m slack).
fn same_place(cut: &FeatureInfo, full: &FeatureInfo) -> bool {
    match (cut.node, full.node, cut.bounds_m, full.bounds_m) {
        (
            NodeRef::Building { building_index: a },
            NodeRef::Building { building_index: b },
            _,
            _,
        ) => a == b,
        (_, _, Some((lo_a, hi_a)), Some((lo_b, hi_b))) => {
            (0..2).all(|k| lo_b[k] <= hi_a[k] + 1.0 && lo_a[k] <= hi_b[k] + 1.0)
        }
        _ => false,
    }
}

/// Per-column skyline comparison over columns where both renders show a building on top and
/// `same(cut_id, full_id)` says the two top pixels show the same part of the city (a block and a
/// building standing in it): that block raised or lowered the skyline. Columns where only one render
/// has a building, or the tops are different places (a gap filled by merging, a far building now
/// hidden), are area changes, measured by the compare's added and removed regions.
pub fn skyline(
    cut: &RenderLayers,
    full: &RenderLayers,
    limit_px: f64,
    same: impl Fn(u32, u32) -> bool,
) -> Skyline {
    let (w, h) = (
        cut.colour.width.min(full.colour.width),
        cut.colour.height.min(full.colour.height),
    );
    let top = |l: &RenderLayers, x: u32| -> Option<(u32, u32)> {
        (0..h).find_map(|y| {
            let id = *l.feature_ids.get((y * l.colour.width + x) as usize)?;
            (id != NO_FEATURE).then_some((y, id))
        })
    };
    let shifts: Vec<u32> = (0..w)
        .filter_map(|x| match (top(cut, x), top(full, x)) {
            (Some((a, ia)), Some((b, ib))) if same(ia, ib) => Some(a.abs_diff(b)),
            _ => None,
        })
        .collect();
    Skyline {
        columns: shifts.len() as u32,
        max_shift_px: shifts.iter().copied().max().unwrap_or(0),
        mean_shift_px: if shifts.is_empty() {
            0.0
        } else {
            shifts.iter().map(|&s| f64::from(s)).sum::<f64>() / shifts.len() as f64
        },
        columns_over_limit: shifts.iter().filter(|&&s| f64::from(s) > limit_px).count() as u32,
        excess_area_px2: shifts
            .iter()
            .map(|&s| (f64::from(s) - limit_px).max(0.0))
            .sum(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Layers whose feature id is the column's id where the image is not sky.
    fn layers(img: Image, id_of_column: [u32; 3]) -> RenderLayers {
        let n = (img.width * img.height) as usize;
        let feature_ids = (0..n)
            .map(|i| {
                let (x, y) = (i as u32 % img.width, i as u32 / img.width);
                if img.pixel(x, y) == Some(SKY) {
                    NO_FEATURE
                } else {
                    id_of_column[x as usize]
                }
            })
            .collect();
        RenderLayers {
            colour: img,
            feature_ids,
            depth_m: vec![1.0; n],
        }
    }

    #[test]
    fn skyline_ignores_columns_with_one_side_empty_or_another_place() {
        let mut cut = Image::filled(3, 10, SKY);
        let mut full = Image::filled(3, 10, SKY);
        let wall = [100, 100, 100, 255];
        for y in 2..10 {
            cut.set_pixel(0, y, wall); // column 0: cut top 2, full top 5 → shift 3
            cut.set_pixel(1, y, wall); // column 1: building in the cut only
            cut.set_pixel(2, y, wall); // column 2: another place on top in the full render
        }
        for y in 5..10 {
            full.set_pixel(0, y, wall);
            full.set_pixel(2, y, wall);
        }
        let same = |a: u32, b: u32| a == b;
        let s = skyline(&layers(cut, [7, 7, 7]), &layers(full, [7, 7, 8]), 2.5, same);
        assert_eq!((s.columns, s.max_shift_px, s.columns_over_limit), (1, 3, 1));
        assert_eq!((s.mean_shift_px, s.excess_area_px2), (3.0, 0.5));
    }

    #[test]
    fn same_place_means_same_building_or_inside_the_block() {
        let f = |node, lo: [f64; 3], hi: [f64; 3]| FeatureInfo {
            node,
            member_count: Some(1),
            members: None,
            dh_m: 0.0,
            da_m2: 0.0,
            area_m2: None,
            fallback: false,
            bounds_m: Some((lo, hi)),
            heights: None,
        };
        let b = |i| NodeRef::Building { building_index: i };
        let block = f(
            NodeRef::Cluster {
                level: 1,
                node_index: 0,
            },
            [0.0; 3],
            [50.0, 50.0, 20.0],
        );
        assert!(same_place(
            &block,
            &f(b(3), [10.0, 10.0, 0.0], [20.0, 20.0, 40.0])
        ));
        assert!(!same_place(
            &block,
            &f(b(3), [60.0, 10.0, 0.0], [70.0, 20.0, 40.0])
        ));
        assert!(!same_place(
            &f(b(2), [0.0; 3], [1.0; 3]),
            &f(b(3), [0.0; 3], [1.0; 3])
        ));
    }
}
