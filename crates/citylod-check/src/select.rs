//! The standard 3D Tiles REPLACE selection, as CesiumJS 1.140's base traversal (no skip-LOD) once every
//! tile is loaded: frustum culling of oriented boxes (with its parent plane masks and children-bounds
//! culling), SSE = geometricError·H/(2·d·tan(fovy/2)), d the distance from the eye to the box (0 inside),
//! refine while SSE > threshold, always through external-tileset links. See SELECTION.md.
//! Frame: boxes in the tileset root frame, metres; SSE in pixels. Invariant: no tile is both selected and
//! refined; every tile reported is reachable from the root.

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

    /// Whether any part of the box may be inside the view frustum of `camera` (near plane and four
    /// sides, no far plane): the plane test of [`select`] on its own, without the parent's plane mask
    /// or children's bounds; conservative near frustum corners.
    pub fn is_visible(&self, camera: &Camera, viewport: Viewport) -> bool {
        !camera
            .frustum_planes(viewport)
            .iter()
            .any(|p| self.outside(p))
    }

    /// Which side of `plane` the box is on, as CesiumJS's `OrientedBoundingBox.intersectPlane`: with s
    /// the signed distance of the centre and r = Σ|n·hᵢ|, outside when s ≤ −r, inside when s ≥ r.
    fn side(&self, plane: &Plane) -> Side {
        let s = vec3::dot(plane.n, self.center_m) + plane.d;
        let r: f64 = self
            .half_axes_m
            .iter()
            .map(|h| vec3::dot(plane.n, *h).abs())
            .sum();
        if s <= -r {
            Side::Outside
        } else if s >= r {
            Side::Inside
        } else {
            Side::Straddling
        }
    }

    fn outside(&self, plane: &Plane) -> bool {
        self.side(plane) == Side::Outside
    }

    /// Bit k set when the box straddles plane k, testing only the planes set in `parent_mask` (the box
    /// counts as inside the others, as its parent is: CesiumJS's plane-mask shortcut). `None` when it
    /// is outside one of them.
    fn plane_mask(&self, planes: &[Plane], parent_mask: u8) -> Option<u8> {
        let mut mask = 0;
        for (k, plane) in planes.iter().enumerate() {
            if parent_mask & (1 << k) == 0 {
                continue;
            }
            match self.side(plane) {
                Side::Outside => return None,
                Side::Straddling => mask |= 1 << k,
                Side::Inside => {}
            }
        }
        Some(mask)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    Outside,
    Straddling,
    Inside,
}

/// Whether a tile may be culled when none of its children is visible: CesiumJS's children-within-parent
/// hint (`Cesium3DTileOptimizations.checkChildrenWithinParent`, on with `cullWithChildrenBounds`). For each
/// child, along the unit axis a from the parent's centre to the child's, the parent's reach Σ|a·hᵢ| must
/// exceed the child's reach plus the centres' distance — strictly: a child touching the parent's boundary
/// where that axis leaves it (a child in a corner of its parent, or a half of it) turns the hint off. Such
/// touching is common in tight trees and then rounding decides: CesiumJS computes in ECEF (≈1e-9 m of noise),
/// this in the root frame, so the two may differ there (tests/browser/selection.test.mjs explains such
/// differences). A child with the parent's centre passes (CesiumJS's axis is then NaN and its test fails
/// to reject). True without children.
pub fn children_within_parent(parent: &OrientedBox, children: &[&OrientedBox]) -> bool {
    children.iter().all(|child| {
        let axis = vec3::sub(child.center_m, parent.center_m);
        let len = vec3::norm(axis);
        if len == 0.0 {
            return true;
        }
        let a = vec3::scale(axis, 1.0 / len);
        let reach =
            |b: &OrientedBox| -> f64 { b.half_axes_m.iter().map(|h| vec3::dot(a, *h).abs()).sum() };
        reach(parent) > reach(child) + len
    })
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
    /// Whether the content is an external tileset: a client always descends into it (its one child
    /// is that tileset's root), whatever its own screen-space error.
    pub external_tileset: bool,
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
    /// Of [`Selection::selected_empty`], those chosen only because none of their children is in the frustum (a
    /// client refines them but finds nothing below to draw): nothing below them is in view, so they leave no hole.
    pub selected_empty_out_of_view: Vec<usize>,
    /// Tiles replaced by their visible children.
    pub refined: Vec<usize>,
    /// Tiles outside the frustum, or culled because none of their children is in it and the children
    /// lie within them ([`children_within_parent`], CesiumJS `cullWithChildrenBounds`); their subtrees
    /// are not visited.
    pub culled: Vec<usize>,
    /// SSE (px) of every visible tile visited, selected or refined (an external-tileset link's is listed
    /// but not used).
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
    if tree.root >= tree.tiles.len() {
        return out;
    }
    let walk = Walk {
        tree,
        planes: camera.frustum_planes(viewport),
    };
    let sse_of = |error_m: f64, t: &TileNode| {
        compute_sse(
            error_m,
            t.bounds.distance_to(camera.eye_m),
            viewport.height_px,
            camera.fovy_deg,
        )
    };

    let root_mask = match walk.visibility(tree.root, ALL_PLANES, 0) {
        Visibility::Visible(mask) => mask,
        _ => {
            out.culled.push(tree.root);
            return out;
        }
    };
    let root = &tree.tiles[tree.root];
    if meets_threshold(
        sse_of(tree.tileset_geometric_error_m, root),
        sse_threshold_px,
    ) {
        out.root_below_threshold = true;
        return out;
    }

    let mut seen = vec![false; tree.tiles.len()];
    seen[tree.root] = true;
    let mut stack = vec![(tree.root, root_mask)];
    while let Some((i, mask)) = stack.pop() {
        let tile = &tree.tiles[i];
        let sse = sse_of(tile.geometric_error_m, tile);
        out.sse_px.insert(i, sse);
        // A client always descends through an external-tileset link; other tiles stop at the threshold.
        let descend = !tile.children.is_empty()
            && (tile.external_tileset || !meets_threshold(sse, sse_threshold_px));
        let mut visible_children = Vec::new();
        let mut invisible_children = Vec::new();
        if descend {
            for &c in &tile.children {
                if c >= tree.tiles.len() || seen[c] {
                    out.bad_links.push((i, c));
                    continue;
                }
                seen[c] = true;
                match walk.visibility(c, mask, 0) {
                    Visibility::Visible(m) => visible_children.push((c, m)),
                    _ => invisible_children.push(c),
                }
            }
        }
        // A tile none of whose children is visible is drawn itself, as CesiumJS does.
        if visible_children.is_empty() {
            if tile.has_content {
                out.selected.push(i);
            } else {
                out.selected_empty.push(i);
                if descend {
                    out.selected_empty_out_of_view.push(i);
                }
            }
        } else {
            out.refined.push(i);
            out.culled.extend(invisible_children);
            stack.extend(visible_children.into_iter().rev());
        }
    }
    out.selected.sort_unstable();
    out.selected_empty.sort_unstable();
    out.selected_empty_out_of_view.sort_unstable();
    out.refined.sort_unstable();
    out.culled.sort_unstable();
    debug_assert!(out
        .selected
        .iter()
        .all(|s| out.refined.binary_search(s).is_err()));
    out
}

/// Plane masks cover the five frustum planes of [`Camera::frustum_planes`].
const ALL_PLANES: u8 = 0b1_1111;

/// A tile's visibility for the traversal: in the frustum with the mask of planes its box straddles, or
/// culled by the frustum, or culled by its children's bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Visibility {
    Visible(u8),
    OutsideFrustum,
    ChildrenOutside,
}

struct Walk<'a> {
    tree: &'a TileTree,
    planes: [Plane; 5],
}

impl Walk<'_> {
    /// CesiumJS's `updateTileVisibility`: the tile's box against the planes its parent straddles; an
    /// external-tileset link is as visible as the root it links to; a tile with children within its
    /// bounds ([`children_within_parent`]), none of them in the frustum, is culled. `depth` guards
    /// against chains of links that loop.
    fn visibility(&self, i: usize, parent_mask: u8, depth: usize) -> Visibility {
        let tiles = &self.tree.tiles;
        let tile = &tiles[i];
        let Some(mask) = tile.bounds.plane_mask(&self.planes, parent_mask) else {
            return Visibility::OutsideFrustum;
        };
        let children: Vec<&TileNode> = tile.children.iter().filter_map(|&c| tiles.get(c)).collect();
        if tile.external_tileset {
            return match tile.children.first() {
                Some(&c) if c < tiles.len() && c != i && depth < MAX_LINK_DEPTH => {
                    match self.visibility(c, mask, depth + 1) {
                        Visibility::Visible(_) => Visibility::Visible(mask),
                        other => other,
                    }
                }
                _ => Visibility::Visible(mask),
            };
        }
        let boxes: Vec<&OrientedBox> = children.iter().map(|c| &c.bounds).collect();
        if !children.is_empty()
            && children_within_parent(&tile.bounds, &boxes)
            && children
                .iter()
                .all(|c| c.bounds.plane_mask(&self.planes, mask).is_none())
        {
            return Visibility::ChildrenOutside;
        }
        Visibility::Visible(mask)
    }
}

/// Nested external-tileset links followed when judging a link's visibility.
const MAX_LINK_DEPTH: usize = 64;

#[cfg(test)]
mod tests {
    use super::*;

    /// A tile with content: its box, geometric error (m) and children.
    fn t(bounds: OrientedBox, geometric_error_m: f64, children: Vec<usize>) -> TileNode {
        TileNode {
            bounds,
            geometric_error_m,
            children,
            has_content: true,
            external_tileset: false,
        }
    }

    /// Root 0 (1000 m box, error 64 m) → tiles 1, 2 (500 m halves, error 8 m) → leaves 3,4 under 1 and
    /// 5,6 under 2 (error 0). The city spans x ∈ [−500, 500], y ∈ [−500, 500], z ∈ [0, 50].
    fn tree() -> TileTree {
        let b = |x0: f64, x1: f64, y0: f64, y1: f64| {
            OrientedBox::from_min_max([x0, y0, 0.0], [x1, y1, 50.0])
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

    /// Looking north at the horizon from 170 m with a 10° fov, from 100 m south of the root box: the
    /// root (made 200 m tall) is seen, none of its children (≤ 50 m high) is.
    fn above_children_camera() -> Camera {
        Camera::from_enu([0.0, -700.0, 170.0], 0.0, 0.0, 10.0).unwrap()
    }

    #[test]
    fn tile_with_only_invisible_children_strictly_inside_it_is_culled() {
        let mut t = tree();
        t.tiles[0].bounds =
            OrientedBox::from_min_max([-600.0, -600.0, -10.0], [600.0, 600.0, 200.0]);
        let s = select(&t, &above_children_camera(), VIEW, 16.0);
        assert!(s.selected.is_empty(), "{s:?}");
        assert_eq!(s.culled, vec![0]);
    }

    #[test]
    fn tile_whose_children_touch_its_faces_is_drawn_when_they_are_invisible() {
        // Children at both ends of the root in x, touching its faces where their axes (±x) leave it: the
        // children-within-parent hint is off, so the root, seen only through the gap between them,
        // draws itself rather than being culled.
        let b = |x0: f64, x1: f64| OrientedBox::from_min_max([x0, -500.0, 0.0], [x1, 500.0, 50.0]);
        let mut tree = TileTree {
            tiles: vec![
                t(b(-500.0, 500.0), 64.0, vec![1, 2]),
                t(b(-500.0, -100.0), 0.0, vec![]),
                t(b(100.0, 500.0), 0.0, vec![]),
            ],
            root: 0,
            tileset_geometric_error_m: 1000.0,
        };
        let cam = Camera::from_enu([0.0, 0.0, 300.0], 0.0, -90.0, 10.0).unwrap();
        let s = select(&tree, &cam, VIEW, 16.0);
        assert_eq!(s.selected, vec![0], "{s:?}");
        assert!(s.culled.is_empty() && s.refined.is_empty()); // children of a drawn tile are not listed
        assert!(s.sse_px[&0] > 16.0);
        // Shrunk by a metre, the children lie strictly within the root, which is then culled.
        tree.tiles[1].bounds = b(-499.0, -100.0);
        tree.tiles[2].bounds = b(100.0, 499.0);
        let s = select(&tree, &cam, VIEW, 16.0);
        assert!(s.selected.is_empty(), "{s:?}");
        assert_eq!(s.culled, vec![0]);
    }

    #[test]
    fn child_culled_by_its_own_children_bounds_counts_as_invisible() {
        // 0 (tall) → 1 (tall, strictly inside 0) → leaves 2, 3 (low, strictly inside 1, out of view):
        // 1 is culled by its children's bounds, so 0 has no visible child and is drawn.
        let b = OrientedBox::from_min_max;
        let tree = TileTree {
            tiles: vec![
                t(
                    b([-600.0, -600.0, -10.0], [600.0, 600.0, 200.0]),
                    64.0,
                    vec![1],
                ),
                t(
                    b([-550.0, -550.0, -5.0], [550.0, 550.0, 190.0]),
                    32.0,
                    vec![2, 3],
                ),
                t(b([-500.0, -500.0, 0.0], [-10.0, 500.0, 50.0]), 0.0, vec![]),
                t(b([10.0, -500.0, 0.0], [500.0, 500.0, 50.0]), 0.0, vec![]),
            ],
            root: 0,
            tileset_geometric_error_m: 1000.0,
        };
        let cam = above_children_camera();
        assert!(tree.tiles[1].bounds.is_visible(&cam, VIEW));
        assert!(!tree.tiles[2].bounds.is_visible(&cam, VIEW));
        let s = select(&tree, &cam, VIEW, 16.0);
        assert_eq!(s.selected, vec![0], "{s:?}");
        assert!(s.refined.is_empty() && s.sse_px[&0] > 16.0);
    }

    #[test]
    fn children_within_parent_is_strict_and_passes_concentric_children() {
        let parent = OrientedBox::from_min_max([0.0; 3], [10.0; 3]);
        let within = |lo: [f64; 3], hi: [f64; 3]| {
            children_within_parent(&parent, &[&OrientedBox::from_min_max(lo, hi)])
        };
        assert!(within([1.0, 1.0, 1.0], [9.0, 9.0, 5.0]));
        assert!(!within([0.0; 3], [5.0, 10.0, 10.0])); // a half: touches where its axis leaves
        assert!(!within([0.0, 1.0, 1.0], [5.0, 9.0, 9.0])); // axis along x, touching x = 0
        assert!(within([1.0, 0.0, 0.0], [4.0, 5.0, 6.0])); // touching faces away from its axis
        assert!(!within([8.0, 8.0, 8.0], [12.0, 12.0, 12.0])); // sticking out
        assert!(within([-5.0; 3], [15.0; 3])); // concentric, even larger
        assert!(children_within_parent(&parent, &[]));
    }

    #[test]
    fn external_tileset_link_is_always_descended_and_as_visible_as_its_root() {
        // 0 → 1 (link to an external tileset, error 8 m: within the threshold 600 m up) → 2 (its root) → 3.
        // From 600 m the 1 km wide root straddles the frustum's sides, so its children are tested.
        let b = |x: f64| OrientedBox::from_min_max([-x, -x, 0.0], [x, x, 50.0]);
        let t = |bounds, e, children: Vec<usize>, link: bool| TileNode {
            bounds,
            geometric_error_m: e,
            children,
            has_content: !link,
            external_tileset: link,
        };
        let mut tree = TileTree {
            tiles: vec![
                t(b(500.0), 64.0, vec![1], false),
                t(b(500.0), 8.0, vec![2], true),
                t(b(400.0), 8.0, vec![3], false),
                t(b(400.0), 0.0, vec![], false),
            ],
            root: 0,
            tileset_geometric_error_m: 1000.0,
        };
        let s = select(&tree, &down_at(600.0), VIEW, 16.0);
        assert_eq!(
            (s.selected.clone(), s.refined.clone()),
            (vec![2], vec![0, 1]),
            "{s:?}"
        );
        assert!(s.sse_px[&1] <= 16.0);
        // The linked root out of view hides the link, though the link's own box is in view.
        tree.tiles[2].bounds =
            OrientedBox::from_min_max([5_000.0, 5_000.0, 0.0], [5_100.0, 5_100.0, 50.0]);
        tree.tiles[3].bounds = tree.tiles[2].bounds;
        let s = select(&tree, &down_at(600.0), VIEW, 16.0);
        assert_eq!(
            (s.selected.clone(), s.refined.clone()),
            (vec![0], vec![]),
            "{s:?}"
        );
    }

    #[test]
    fn child_of_a_tile_wholly_in_view_counts_as_in_view() {
        // CesiumJS tests a child only against the planes its parent straddles: a (malformed) child far
        // outside its parent, whose parent is wholly in view, is drawn.
        let b = OrientedBox::from_min_max;
        let tree = TileTree {
            tiles: vec![
                t(b([-10.0, -10.0, 0.0], [10.0, 10.0, 10.0]), 64.0, vec![1]),
                t(
                    b([5_000.0, 5_000.0, 0.0], [5_100.0, 5_100.0, 10.0]),
                    0.0,
                    vec![],
                ),
            ],
            root: 0,
            tileset_geometric_error_m: 1000.0,
        };
        let s = select(&tree, &down_at(1_000.0), VIEW, 16.0);
        assert!(!tree.tiles[1].bounds.is_visible(&down_at(1_000.0), VIEW));
        assert_eq!(s.selected, vec![1], "{s:?}");
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
    fn an_empty_tile_whose_children_are_out_of_view_is_told_apart() {
        // At 300 m tile 2 refines (8 m: 21 px) but is empty, and its children lie east of the view. At 2 km the
        // empty tiles 1 and 2 meet the threshold (2.7 px) themselves: holes, wherever their children are.
        let mut t = tree();
        t.tiles[2].has_content = false;
        let east =
            |y0: f64, y1: f64| OrientedBox::from_min_max([5_000.0, y0, 0.0], [5_500.0, y1, 50.0]);
        t.tiles[5].bounds = east(-500.0, 0.0);
        t.tiles[6].bounds = east(0.0, 500.0);
        let s = select(&t, &down_at(300.0), VIEW, 16.0);
        assert_eq!(s.selected_empty, vec![2]);
        assert_eq!(s.selected_empty_out_of_view, vec![2]);
        t.tiles[1].has_content = false;
        let s = select(&t, &down_at(2_000.0), VIEW, 16.0);
        assert_eq!(s.selected_empty, vec![1, 2]);
        assert!(s.selected_empty_out_of_view.is_empty());
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
