//! The standard 3D Tiles REPLACE selection (as CesiumJS's base traversal, without skip-LOD), assuming
//! every tile is loaded: frustum culling against oriented boxes, SSE = geometricError·H/(2·d·tan(fovy/2))
//! with d the distance from the eye to the box (0 inside), refine while SSE > threshold.
//! Frame: boxes are in the tileset root frame, metres; SSE in pixels.
//! Invariant: no tile is both selected and refined; every tile reported is reachable from the root.

use std::collections::BTreeMap;

use crate::camera::{Camera, Plane, Viewport};
use crate::vec3::{self, Vec3};

/// A 3D Tiles `box` bounding volume: centre and three half-axis vectors, root frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedBox {
    pub center_m: Vec3,
    pub half_axes_m: [Vec3; 3],
}

impl OrientedBox {
    /// An axis-aligned box from its minimum and maximum corners.
    pub fn from_min_max(min_m: Vec3, max_m: Vec3) -> OrientedBox {
        let c = vec3::scale(vec3::add(min_m, max_m), 0.5);
        let h = vec3::scale(vec3::sub(max_m, min_m), 0.5);
        OrientedBox {
            center_m: c,
            half_axes_m: [[h[0], 0.0, 0.0], [0.0, h[1], 0.0], [0.0, 0.0, h[2]]],
        }
    }

    /// Euclidean distance (m) from `p_m` to the box; 0 inside or on it. Half-axes are treated as
    /// orthogonal (3D Tiles requires it); a zero-length half-axis gives a flat or degenerate box.
    pub fn distance_to(&self, p_m: Vec3) -> f64 {
        let d = vec3::sub(p_m, self.center_m);
        let mut excess_sq = 0.0;
        let mut along_sq = 0.0; // squared length of `d` explained by the non-degenerate axes
        for h in self.half_axes_m {
            let len = vec3::norm(h);
            if len > 0.0 {
                let t = vec3::dot(d, h) / len;
                along_sq += t * t;
                let e = (t.abs() - len).max(0.0);
                excess_sq += e * e;
            }
        }
        // Components along degenerate axes are the remainder of |d|² (orthogonal axes).
        let rest_sq = (vec3::dot(d, d) - along_sq).max(0.0);
        (excess_sq + rest_sq).sqrt()
    }

    /// Whether `inner` lies inside this box, within 1 µm per metre of half-axis (CesiumJS's
    /// children-within-parent test). False when this box has more than one zero-length half-axis.
    pub fn contains(&self, inner: &OrientedBox) -> bool {
        let lens = self.half_axes_m.map(vec3::norm);
        let mut units = self.half_axes_m.map(vec3::normalize);
        match lens.iter().filter(|&&l| l == 0.0).count() {
            0 => {}
            1 => {
                let k = lens.iter().position(|&l| l == 0.0).unwrap_or(0);
                units[k] = vec3::normalize(vec3::cross(units[(k + 1) % 3], units[(k + 2) % 3]));
            }
            _ => return false,
        }
        let offset = vec3::sub(inner.center_m, self.center_m);
        (0..3).all(|i| {
            let reach: f64 = vec3::dot(offset, units[i]).abs()
                + inner
                    .half_axes_m
                    .iter()
                    .map(|h| vec3::dot(*h, units[i]).abs())
                    .sum::<f64>();
            reach <= lens[i] + 1e-6 * lens[i].max(1.0)
        })
    }

    /// Whether any part of the box may be inside the view frustum of `camera` (near plane and four
    /// sides, no far plane) — the culling test of [`select`]; conservative near frustum corners.
    pub fn is_visible(&self, camera: &Camera, viewport: Viewport) -> bool {
        !camera
            .frustum_planes(viewport)
            .iter()
            .any(|p| self.outside(p))
    }

    /// Whether the box lies entirely on the outside of `plane`.
    fn outside(&self, plane: &Plane) -> bool {
        let s = vec3::dot(plane.n, self.center_m) + plane.d;
        let r: f64 = self
            .half_axes_m
            .iter()
            .map(|h| vec3::dot(plane.n, *h).abs())
            .sum();
        s < -r
    }
}

/// One tile as the selection sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct TileNode {
    /// Bounding volume in the root frame.
    pub bounds: OrientedBox,
    /// The tile's `geometricError` (m), ≥ 0.
    pub geometric_error_m: f64,
    /// Indices of the children in [`TileTree::tiles`].
    pub children: Vec<usize>,
    /// Whether the tile has content to draw (an empty tile that is selected draws nothing).
    pub has_content: bool,
}

/// A minimal view of a tileset for selection: tiles in a flat list, the root index, and the
/// tileset-level `geometricError` (m) that decides whether the root is drawn at all.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TileTree {
    pub tiles: Vec<TileNode>,
    pub root: usize,
    pub tileset_geometric_error_m: f64,
}

/// The cut a standard client draws for one camera. Tile lists are sorted by index.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Selection {
    /// Tiles drawn: visible, with content, and either leaves, within the threshold, or with no
    /// visible child.
    pub selected: Vec<usize>,
    /// Tiles that would be drawn but have no content (a hole in the cut unless intended).
    pub selected_empty: Vec<usize>,
    /// Tiles replaced by their visible children.
    pub refined: Vec<usize>,
    /// Tiles outside the frustum, or culled because all their children are invisible and inside
    /// them (CesiumJS `cullWithChildrenBounds`); their subtrees are not visited.
    pub culled: Vec<usize>,
    /// SSE (px) of every visible tile visited, selected or refined.
    pub sse_px: BTreeMap<usize, f64>,
    /// True when the tileset's own geometricError, seen at the root's distance, already meets the
    /// threshold: a client then draws nothing (CesiumJS does this).
    pub root_below_threshold: bool,
    /// Child links that point outside the tile list or back to a visited tile (ignored).
    pub bad_links: Vec<(usize, usize)>,
}

/// Screen-space error (px) of an error `geometric_error_m` seen at `distance_m` through a viewport of
/// `viewport_height_px` rows and vertical fov `fovy_deg`. A zero error gives 0; a zero distance
/// (eye inside the volume) gives +∞ for a positive error.
///
/// # Examples
/// ```
/// // 16 m at 100 m through a 90° fov on 200 rows: 16·200/(2·100·1) = 16 px.
/// let sse = citylod_check::compute_sse(16.0, 100.0, 200, 90.0);
/// assert!((sse - 16.0).abs() < 1e-9);
/// ```
pub fn compute_sse(
    geometric_error_m: f64,
    distance_m: f64,
    viewport_height_px: u32,
    fovy_deg: f64,
) -> f64 {
    if geometric_error_m <= 0.0 || geometric_error_m.is_nan() {
        return 0.0;
    }
    let denom = 2.0 * distance_m.max(0.0) * (fovy_deg.to_radians() * 0.5).tan();
    if denom <= 0.0 {
        return f64::INFINITY;
    }
    geometric_error_m * f64::from(viewport_height_px) / denom
}

/// Whether a tile with screen-space error `sse_px` is good enough to draw without refining
/// (CesiumJS refines only when SSE is strictly greater than the threshold).
pub fn meets_threshold(sse_px: f64, sse_threshold_px: f64) -> bool {
    sse_px <= sse_threshold_px
}

/// Runs the REPLACE traversal from the root. Never panics on a malformed tree: bad child links are
/// skipped and listed in [`Selection::bad_links`]; an out-of-range root gives an empty selection.
pub fn select(
    tree: &TileTree,
    camera: &Camera,
    viewport: Viewport,
    sse_threshold_px: f64,
) -> Selection {
    let mut out = Selection::default();
    let Some(root) = tree.tiles.get(tree.root) else {
        return out;
    };
    let planes = camera.frustum_planes(viewport);
    let visible = |t: &TileNode| !planes.iter().any(|p| t.bounds.outside(p));
    let sse_of = |error_m: f64, t: &TileNode| {
        compute_sse(
            error_m,
            t.bounds.distance_to(camera.eye_m),
            viewport.height_px,
            camera.fovy_deg,
        )
    };

    if !visible(root) {
        out.culled.push(tree.root);
        return out;
    }
    if meets_threshold(
        sse_of(tree.tileset_geometric_error_m, root),
        sse_threshold_px,
    ) {
        out.root_below_threshold = true;
        return out;
    }

    let mut seen = vec![false; tree.tiles.len()];
    seen[tree.root] = true;
    let mut stack = vec![tree.root];
    while let Some(i) = stack.pop() {
        let tile = &tree.tiles[i];
        let mut children = Vec::with_capacity(tile.children.len());
        for &c in &tile.children {
            if c >= tree.tiles.len() || seen[c] {
                out.bad_links.push((i, c));
            } else {
                seen[c] = true;
                children.push((c, visible(&tree.tiles[c])));
            }
        }
        let any_child_visible = children.iter().any(|&(_, v)| v);
        // CesiumJS's cullWithChildrenBounds (on by default): a tile whose children's boxes lie inside
        // its own and are all invisible is culled, whatever its SSE.
        if !children.is_empty()
            && !any_child_visible
            && children
                .iter()
                .all(|&(c, _)| tile.bounds.contains(&tree.tiles[c].bounds))
        {
            out.culled.push(i);
            continue;
        }
        let sse = sse_of(tile.geometric_error_m, tile);
        out.sse_px.insert(i, sse);
        // A tile whose children are all invisible (but not inside it) is drawn itself.
        if meets_threshold(sse, sse_threshold_px) || !any_child_visible {
            if tile.has_content {
                out.selected.push(i);
            } else {
                out.selected_empty.push(i);
            }
        } else {
            out.refined.push(i);
            for &(c, v) in children.iter().rev() {
                if v {
                    stack.push(c);
                } else {
                    out.culled.push(c);
                }
            }
        }
    }
    out.selected.sort_unstable();
    out.selected_empty.sort_unstable();
    out.refined.sort_unstable();
    out.culled.sort_unstable();
    debug_assert!(out
        .selected
        .iter()
        .all(|s| out.refined.binary_search(s).is_err()));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Root 0 (1000 m box, error 64 m) → tiles 1, 2 (500 m halves, error 8 m) → leaves 3,4 under 1 and
    /// 5,6 under 2 (error 0). The city spans x ∈ [−500, 500], y ∈ [−500, 500], z ∈ [0, 50].
    fn tree() -> TileTree {
        let b = |x0: f64, x1: f64, y0: f64, y1: f64| {
            OrientedBox::from_min_max([x0, y0, 0.0], [x1, y1, 50.0])
        };
        let t = |bounds, e, children: Vec<usize>| TileNode {
            bounds,
            geometric_error_m: e,
            children,
            has_content: true,
        };
        TileTree {
            tiles: vec![
                t(b(-500.0, 500.0, -500.0, 500.0), 64.0, vec![1, 2]),
                t(b(-500.0, 0.0, -500.0, 500.0), 8.0, vec![3, 4]),
                t(b(0.0, 500.0, -500.0, 500.0), 8.0, vec![5, 6]),
                t(b(-500.0, 0.0, -500.0, 0.0), 0.0, vec![]),
                t(b(-500.0, 0.0, 0.0, 500.0), 0.0, vec![]),
                t(b(0.0, 500.0, -500.0, 0.0), 0.0, vec![]),
                t(b(0.0, 500.0, 0.0, 500.0), 0.0, vec![]),
            ],
            root: 0,
            tileset_geometric_error_m: 1000.0,
        }
    }

    const VIEW: Viewport = Viewport {
        width_px: 1024,
        height_px: 768,
    };

    fn down_at(height_m: f64) -> Camera {
        Camera::from_enu([0.0, 0.0, height_m], 0.0, -90.0, 60.0).unwrap()
    }

    #[test]
    fn sse_formula_matches_hand_computation() {
        // 10 m at 500 m, 768 rows, fov 60°: 10·768 / (2·500·tan 30°) = 7680 / 577.350 = 13.3022 px.
        let sse = compute_sse(10.0, 500.0, 768, 60.0);
        assert!((sse - 13.302_2).abs() < 1e-4, "{sse}");
        assert_eq!(compute_sse(0.0, 0.0, 768, 60.0), 0.0);
        assert_eq!(compute_sse(5.0, 0.0, 768, 60.0), f64::INFINITY);
        assert!(meets_threshold(16.0, 16.0) && !meets_threshold(16.000_001, 16.0));
    }

    #[test]
    fn box_distance_is_zero_inside_and_euclidean_outside() {
        let b = OrientedBox::from_min_max([0.0, 0.0, 0.0], [10.0, 10.0, 10.0]);
        assert_eq!(b.distance_to([5.0, 5.0, 5.0]), 0.0);
        assert!((b.distance_to([13.0, 14.0, 5.0]) - 5.0).abs() < 1e-12);
        // Rotated 45° about z: a unit cube's corner direction.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let r = OrientedBox {
            center_m: [0.0; 3],
            half_axes_m: [[s, s, 0.0], [-s, s, 0.0], [0.0, 0.0, 1.0]],
        };
        assert!((r.distance_to([3.0, 0.0, 0.0]) - (3.0 - 2f64.sqrt())).abs() < 1e-12);
        // Flat box (zero height): distance above it is the height.
        let flat = OrientedBox::from_min_max([0.0, 0.0, 0.0], [10.0, 10.0, 0.0]);
        assert!((flat.distance_to([5.0, 5.0, 7.0]) - 7.0).abs() < 1e-12);
    }

    #[test]
    fn far_camera_selects_the_root() {
        // At 20 km: root SSE = 64·768/(2·19950·0.577) ≈ 2.1 px ≤ 16.
        let s = select(&tree(), &down_at(20_000.0), VIEW, 16.0);
        assert_eq!(s.selected, vec![0]);
        assert!(s.refined.is_empty() && s.culled.is_empty());
        assert!(s.sse_px[&0] < 16.0);
    }

    #[test]
    fn close_camera_refines_to_leaves() {
        let s = select(&tree(), &down_at(300.0), VIEW, 16.0);
        assert_eq!(s.selected, vec![3, 4, 5, 6]);
        assert_eq!(s.refined, vec![0, 1, 2]);
        assert!(s.selected_empty.is_empty());
    }

    #[test]
    fn middle_distance_stops_at_the_middle_level() {
        // At 2 km up: root SSE ≈ 64·768/(2·1950·0.577) ≈ 21.8 > 16, children ≈ 2.7 ≤ 16.
        let s = select(&tree(), &down_at(2_000.0), VIEW, 16.0);
        assert_eq!(s.selected, vec![1, 2]);
        assert_eq!(s.refined, vec![0]);
    }

    #[test]
    fn tile_behind_the_camera_is_culled() {
        // Standing at the east edge (x = 400, inside tile 2) looking east at street height: tile 1
        // (x ≤ 0) is behind and must be culled.
        let cam = Camera::from_enu([400.0, 0.0, 30.0], 90.0, -10.0, 60.0).unwrap();
        let s = select(&tree(), &cam, VIEW, 16.0);
        assert!(s.culled.contains(&1), "{s:?}");
        assert!(s.selected.iter().all(|&t| t == 5 || t == 6), "{s:?}");
        assert!(!s.selected.is_empty());
    }

    /// Looking north at the horizon from 150 m with a 10° fov: the root box (made 200 m tall) is seen,
    /// none of its children (≤ 50 m) is.
    fn above_children_camera() -> (TileTree, Camera) {
        let mut t = tree();
        t.tiles[0].bounds = OrientedBox::from_min_max([-500.0, -500.0, 0.0], [500.0, 500.0, 200.0]);
        let cam = Camera::from_enu([0.0, -600.0, 150.0], 0.0, 0.0, 10.0).unwrap();
        (t, cam)
    }

    #[test]
    fn tile_with_only_invisible_children_inside_it_is_culled() {
        let (t, cam) = above_children_camera();
        let s = select(&t, &cam, VIEW, 16.0);
        assert!(s.selected.is_empty(), "{s:?}");
        assert_eq!(s.culled, vec![0]);
    }

    #[test]
    fn tile_with_invisible_children_reaching_outside_it_is_drawn() {
        let (mut t, cam) = above_children_camera();
        t.tiles[1].bounds = OrientedBox::from_min_max([-600.0, -500.0, 0.0], [0.0, 500.0, 50.0]);
        let s = select(&t, &cam, VIEW, 16.0);
        assert_eq!(s.selected, vec![0], "{s:?}");
        assert!(s.sse_px[&0] > 16.0);
    }

    #[test]
    fn box_containment_allows_shared_faces_only() {
        let outer = OrientedBox::from_min_max([0.0; 3], [10.0; 3]);
        assert!(outer.contains(&OrientedBox::from_min_max([0.0; 3], [5.0, 10.0, 10.0])));
        assert!(!outer.contains(&OrientedBox::from_min_max([0.0; 3], [5.0, 10.0, 10.01])));
        let flat = OrientedBox::from_min_max([0.0; 3], [10.0, 10.0, 0.0]);
        assert!(flat.contains(&OrientedBox::from_min_max([1.0, 1.0, 0.0], [2.0, 2.0, 0.0])));
        assert!(!flat.contains(&OrientedBox::from_min_max([1.0, 1.0, 0.0], [2.0, 2.0, 1.0])));
    }

    #[test]
    fn root_outside_the_frustum_draws_nothing() {
        let cam = Camera::from_enu([0.0, 0.0, 5_000.0], 0.0, 0.0, 60.0).unwrap(); // looks at the horizon
        let s = select(&tree(), &cam, VIEW, 16.0);
        assert_eq!(s.culled, vec![0]);
        assert!(s.selected.is_empty());
    }

    #[test]
    fn tileset_error_below_threshold_draws_nothing() {
        let mut t = tree();
        t.tileset_geometric_error_m = 1.0;
        let s = select(&t, &down_at(20_000.0), VIEW, 16.0);
        assert!(s.root_below_threshold && s.selected.is_empty());
    }

    #[test]
    fn empty_tiles_are_reported_not_drawn() {
        let mut t = tree();
        t.tiles[1].has_content = false;
        let s = select(&t, &down_at(2_000.0), VIEW, 16.0);
        assert_eq!(s.selected, vec![2]);
        assert_eq!(s.selected_empty, vec![1]);
    }

    #[test]
    fn malformed_tree_does_not_panic() {
        let mut t = tree();
        t.tiles[1].children.push(99);
        t.tiles[2].children.push(0);
        let s = select(&t, &down_at(300.0), VIEW, 16.0);
        assert!(s.bad_links.contains(&(1, 99)) && s.bad_links.contains(&(2, 0)));
        assert_eq!(s.selected, vec![3, 4, 5, 6]);
        let empty = TileTree::default();
        assert_eq!(
            select(&empty, &down_at(300.0), VIEW, 16.0),
            Selection::default()
        );
    }
}
