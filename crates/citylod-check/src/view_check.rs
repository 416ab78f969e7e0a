//! One view of `citylod check` (DESIGN.md §6): select the cut a standard client draws, validate it
//! (coverage, seed criterion), render it and the full-detail leaves from the same camera, compare
//! them and judge the skyline. Pixels for images, metres for geometry (root frame).
//! Invariant: the same tileset, camera and settings give identical images and findings.

use serde::Serialize;

use crate::camera::{Camera, Viewport};
use crate::compare::{compare, ImageMetrics};
use crate::coverage::check_cut;
use crate::criterion::{check_criterion, Tolerances};
use crate::finding::{Finding, FindingKind};
use crate::render::{RenderLayers, Renderer, SKY};
use crate::select::{select, Selection};
use crate::tileset::LoadedTileset;
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

/// Skyline comparison over the columns where both renders show the same surface on top.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Skyline {
    /// Columns where both renders have a building on top at about the same depth.
    pub columns: u32,
    /// Largest and mean |top row in cut − top row in full| over those columns (px).
    pub max_shift_px: u32,
    pub mean_shift_px: f64,
    /// Columns whose shift exceeds δH + tolerance.
    pub columns_over_limit: u32,
}

/// Everything one view produced.
#[derive(Debug, Clone)]
pub struct ViewOutcome {
    pub selection: Selection,
    pub findings: Vec<Finding>,
    pub cut: Image,
    pub full: Image,
    pub metrics: ImageMetrics,
    pub skyline: Skyline,
    /// Triangles of the selected tiles' content.
    pub cut_triangles: usize,
    /// Triangles of the full-detail leaf tiles in view (frustum-culled by box), and of all leaves.
    pub full_triangles: usize,
    pub full_triangles_total: usize,
    /// Bytes of the selected tiles' content files, and of the leaf tiles in view.
    pub cut_bytes: u64,
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
    findings.extend(check_criterion(
        ts,
        &selection,
        camera,
        vp,
        settings.tolerances,
    ));

    let mut cut_scene = Scene::new();
    for &i in &selection.selected {
        add_tile(&mut cut_scene, ts, i)?;
    }
    let leaves = ts.leaf_tiles();
    let in_view: Vec<usize> = leaves
        .iter()
        .copied()
        .filter(|&i| ts.tree.tiles[i].bounds.is_visible(camera, vp))
        .collect();
    let mut full_scene = Scene::new();
    for &i in &in_view {
        add_tile(&mut full_scene, ts, i)?;
    }
    let cut = renderer.render_layers(&cut_scene, camera, vp.width_px, vp.height_px)?;
    let full = renderer.render_layers(&full_scene, camera, vp.width_px, vp.height_px)?;
    let metrics = compare(&cut.colour, &full.colour, SKY)?;

    let limit_px = settings.tolerances.dh_px + settings.skyline_tolerance_px;
    let skyline = skyline(&cut, &full, limit_px);
    if f64::from(skyline.max_shift_px) > limit_px {
        findings.push(Finding {
            measured: Some(f64::from(skyline.max_shift_px)),
            limit: Some(limit_px),
            ..Finding::at(
                FindingKind::SkylineShift,
                ts,
                usize::MAX,
                format!(
                    "the cut's skyline moves up to {} px from full detail's in {} of {} columns \
                     (limit δH + {} px)",
                    skyline.max_shift_px,
                    skyline.columns_over_limit,
                    skyline.columns,
                    settings.skyline_tolerance_px
                ),
            )
        });
    }

    let sum = |tiles: &[usize], f: &dyn Fn(usize) -> u64| tiles.iter().map(|&i| f(i)).sum::<u64>();
    let tris = |i: usize| ts.tiles[i].triangle_count() as u64;
    let bytes = |i: usize| ts.tiles[i].content_bytes;
    Ok(ViewOutcome {
        cut_triangles: sum(&selection.selected, &tris) as usize,
        full_triangles: sum(&in_view, &tris) as usize,
        full_triangles_total: sum(&leaves, &tris) as usize,
        cut_bytes: sum(&selection.selected, &bytes),
        full_bytes: sum(&in_view, &bytes),
        full_tiles: in_view.len(),
        selection,
        findings,
        cut: cut.colour,
        full: full.colour,
        metrics,
        skyline,
    })
}

fn add_tile(scene: &mut Scene, ts: &LoadedTileset, i: usize) -> Result<(), CheckError> {
    match &ts.tiles[i].mesh {
        Some(mesh) => scene.add_mesh(mesh, BUILDING_COLOUR, i as u32),
        None => Ok(()),
    }
}

/// Two skyline pixels belong to the same surface when their depths differ by at most this share.
pub const SAME_SURFACE_DEPTH_SHARE: f64 = 0.03;

/// Per-column skyline comparison over columns where both renders show a building and the top
/// pixels lie at about the same depth (within [`SAME_SURFACE_DEPTH_SHARE`]): the same part of the
/// city, raised or lowered. Columns where only one render has a building, or the tops are different
/// surfaces (a gap filled by merging, a far building now hidden), are area changes: the compare's
/// added and removed regions measure those.
pub fn skyline(cut: &RenderLayers, full: &RenderLayers, limit_px: f64) -> Skyline {
    let (w, h) = (
        cut.colour.width.min(full.colour.width),
        cut.colour.height.min(full.colour.height),
    );
    let top = |l: &RenderLayers, x: u32| -> Option<(u32, f64)> {
        (0..h).find_map(|y| {
            let i = (y * l.colour.width + x) as usize;
            let d = f64::from(*l.depth_m.get(i)?);
            (l.colour.pixel(x, y).is_some_and(|p| p != SKY) && d.is_finite()).then_some((y, d))
        })
    };
    let shifts: Vec<u32> = (0..w)
        .filter_map(|x| match (top(cut, x), top(full, x)) {
            (Some((a, da)), Some((b, db)))
                if (da - db).abs() <= SAME_SURFACE_DEPTH_SHARE * da.min(db) =>
            {
                Some(a.abs_diff(b))
            }
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
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layers(img: Image, depth_m: f32) -> RenderLayers {
        let n = (img.width * img.height) as usize;
        let depth_m = (0..n)
            .map(|i| {
                let (x, y) = (i as u32 % img.width, i as u32 / img.width);
                if img.pixel(x, y) == Some(SKY) {
                    f32::INFINITY
                } else {
                    depth_m
                }
            })
            .collect();
        RenderLayers {
            colour: img,
            feature_ids: vec![0; n],
            depth_m,
        }
    }

    #[test]
    fn skyline_ignores_columns_with_one_side_empty_or_another_surface() {
        let mut cut = Image::filled(3, 10, SKY);
        let mut full = Image::filled(3, 10, SKY);
        let wall = [100, 100, 100, 255];
        for y in 2..10 {
            cut.set_pixel(0, y, wall); // column 0: cut top 2, full top 5 → shift 3
            cut.set_pixel(1, y, wall); // column 1: building in the cut only
        }
        for y in 5..10 {
            full.set_pixel(0, y, wall);
        }
        let s = skyline(&layers(cut.clone(), 100.0), &layers(full.clone(), 102.0), 2.5);
        assert_eq!((s.columns, s.max_shift_px, s.columns_over_limit), (1, 3, 1));
        assert_eq!(s.mean_shift_px, 3.0);
        // The full render's top is twice as far: a different surface, not a skyline shift.
        let s = skyline(&layers(cut, 100.0), &layers(full, 200.0), 2.5);
        assert_eq!(s.columns, 0);
    }
}
