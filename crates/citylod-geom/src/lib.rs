//! Planar polygon operations shared by the ingest and generalize stages (local ENU metres).
//!
//! - [`union_nonzero`]: the union of polygons under the non-zero winding rule, OGC-valid.
//! - [`rebuild_even_odd`]: an invalid polygon rebuilt as the area its rings enclose an odd number of times,
//!   OGC-valid.
//!
//! The union runs i_overlay 9 itself rather than through geo's `BooleanOps`: geo 0.33 pins i_overlay 4.5,
//! whose segment splitter needs minutes for rings of long, nearly parallel edges (one union of a
//! 20,000-vertex star with spikes from 20 to 100 m: 114 s with 4.5, about 1 s here). Coordinates go through
//! the same integer grid as geo's (2²⁹ steps across the larger half-extent of the input's bounding box), so a
//! vertex moves by at most half a step, but points off that grid are rounded to the nearest step where
//! 4.5 truncated.

use geo_types::{Coord, LineString, MultiPolygon, Polygon};
use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay::ShapeType;
use i_overlay::core::overlay_rule::OverlayRule;
use i_overlay::core::solver::Solver;
use i_overlay::float::overlay::{FloatOverlay, OverlayOptions};
use i_overlay::i_float::adapter::FloatPointAdapter;

/// Union of `polys` under the non-zero winding rule: the area covered by any of them, as OGC-valid polygons
/// (exteriors counter-clockwise, holes clockwise, rings closed, no collinear vertices, polygons meeting at a
/// point kept apart). Each polygon is first oriented (exterior CCW, holes CW), so a polygon wound either way
/// counts once and its holes stay holes; a self-crossing ring keeps every lobe. Rings of fewer than three
/// points are ignored; no input gives an empty result. Coordinates must be finite.
pub fn union_nonzero(polys: &[Polygon<f64>]) -> MultiPolygon<f64> {
    let mut paths: Vec<Vec<[f64; 2]>> = Vec::new();
    for p in polys {
        if let Some(ext) = open_path(p.exterior(), Some(true)) {
            paths.push(ext);
            paths.extend(
                p.interiors()
                    .iter()
                    .filter_map(|h| open_path(h, Some(false))),
            );
        }
    }
    overlay(&paths, FillRule::NonZero)
}

/// `p` rebuilt under the even-odd rule: the area inside an odd number of its rings (shell and holes alike), as
/// OGC-valid polygons, like geo's `MakeValid` (which triangulates the rings and flood-fills the triangles
/// odd-even) but through the overlay's sweep, so a ring of thousands of vertices with a few crossings takes
/// milliseconds. A bow tie becomes two triangles, an edge drawn out and back adds nothing, a part of the shell
/// that loops over itself twice is left out. Rings of fewer than three points are ignored; coordinates must be
/// finite.
pub fn rebuild_even_odd(p: &Polygon<f64>) -> MultiPolygon<f64> {
    let paths: Vec<Vec<[f64; 2]>> = std::iter::once(p.exterior())
        .chain(p.interiors())
        .filter_map(|r| open_path(r, None))
        .collect();
    overlay(&paths, FillRule::EvenOdd)
}

/// The area `paths` cover under `fill`, as polygons: each shape's outer contour first (CCW), its holes after.
fn overlay(paths: &[Vec<[f64; 2]>], fill: FillRule) -> MultiPolygon<f64> {
    if paths.is_empty() {
        return MultiPolygon(Vec::new());
    }
    let capacity = paths.iter().map(Vec::len).sum();
    let adapter = FloatPointAdapter::<[f64; 2], i32>::with_iter(paths.iter().flatten());
    let shapes =
        FloatOverlay::new_custom(adapter, OverlayOptions::ogc(), Solver::default(), capacity)
            .unsafe_add_source(paths, ShapeType::Subject)
            .overlay(OverlayRule::Subject, fill);
    // i_overlay gives each shape's outer contour first (CCW) and its holes after (CW), open.
    MultiPolygon(
        shapes
            .into_iter()
            .filter_map(|shape| {
                let mut rings = shape.into_iter().map(closed);
                let exterior = rings.next()?;
                Some(Polygon::new(exterior, rings.collect()))
            })
            .collect(),
    )
}

/// The ring without its closing point, counter-clockwise when `ccw` is `Some(true)`, clockwise when
/// `Some(false)`, as it runs when `None`; `None` under three points.
fn open_path(ring: &LineString<f64>, ccw: Option<bool>) -> Option<Vec<[f64; 2]>> {
    let pts = &ring.0;
    let n = if pts.len() > 1 && pts.first() == pts.last() {
        pts.len() - 1
    } else {
        pts.len()
    };
    if n < 3 {
        return None;
    }
    let mut path: Vec<[f64; 2]> = pts[..n].iter().map(|c| [c.x, c.y]).collect();
    if ccw.is_some_and(|ccw| (twice_signed_area(&path) > 0.0) != ccw) {
        path.reverse();
    }
    Some(path)
}

/// Twice the signed area of an open path (> 0 counter-clockwise), about its first point.
fn twice_signed_area(path: &[[f64; 2]]) -> f64 {
    let o = path[0];
    path.windows(2)
        .map(|w| (w[0][0] - o[0]) * (w[1][1] - o[1]) - (w[1][0] - o[0]) * (w[0][1] - o[1]))
        .sum()
}

fn closed(path: Vec<[f64; 2]>) -> LineString<f64> {
    let first = path.first().copied();
    let mut coords: Vec<Coord<f64>> = path.into_iter().map(|[x, y]| Coord { x, y }).collect();
    if let Some([x, y]) = first {
        coords.push(Coord { x, y });
    }
    LineString(coords)
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo::{Area, Validation};
    use geo_types::polygon;

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Polygon<f64> {
        polygon![(x: x0, y: y0), (x: x1, y: y0), (x: x1, y: y1), (x: x0, y: y1)]
    }

    #[test]
    fn overlapping_touching_and_apart() {
        let u = union_nonzero(&[
            rect(0.0, 0.0, 10.0, 10.0),
            rect(5.0, 5.0, 15.0, 15.0),
            rect(15.0, 0.0, 20.0, 5.0), // touches the second at the point (15, 5)
            rect(30.0, 0.0, 31.0, 1.0),
        ]);
        assert!(u.is_valid());
        assert_eq!(u.0.len(), 3);
        assert!((u.unsigned_area() - (100.0 + 100.0 - 25.0 + 25.0 + 1.0)).abs() < 1e-9);
        for p in &u.0 {
            assert!(p.exterior().0.first() == p.exterior().0.last());
            assert!(
                twice_signed_area(
                    &p.exterior()
                        .0
                        .iter()
                        .map(|c| [c.x, c.y])
                        .collect::<Vec<_>>()
                ) > 0.0
            );
        }
    }

    #[test]
    fn orientation_of_the_input_does_not_matter_and_holes_stay() {
        let mut cw = rect(0.0, 0.0, 10.0, 10.0);
        cw.exterior_mut(|r| r.0.reverse());
        let hole = rect(22.0, 2.0, 28.0, 8.0).exterior().clone(); // CCW, as an exterior would be
        let with_hole = Polygon::new(rect(20.0, 0.0, 30.0, 10.0).exterior().clone(), vec![hole]);
        let u = union_nonzero(&[cw, with_hole]);
        assert!(u.is_valid());
        assert_eq!(u.0.len(), 2);
        assert!(
            (u.unsigned_area() - (100.0 + 100.0 - 36.0)).abs() < 1e-9,
            "{}",
            u.unsigned_area()
        );
        let holes: usize = u.0.iter().map(|p| p.interiors().len()).sum();
        assert_eq!(holes, 1);
    }

    #[test]
    fn degenerate_input_gives_nothing() {
        assert!(union_nonzero(&[]).0.is_empty());
        let line = Polygon::new(LineString::from(vec![(0.0, 0.0), (1.0, 1.0)]), vec![]);
        assert!(union_nonzero(&[line]).0.is_empty());
    }

    /// A star of 20,000 vertices, spikes from 20 to 100 m: every edge is long and nearly parallel to its
    /// neighbours (the input that kept i_overlay 4.5's splitter busy for minutes). Its union alone is itself;
    /// under a square that covers it, the square; beside a square touching one tip, both.
    #[test]
    fn union_of_a_spiky_star_is_exact() {
        let n = 20_000;
        let star: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                let r = if i % 2 == 0 { 100.0 } else { 20.0 };
                (r * a.cos(), r * a.sin())
            })
            .collect();
        let star = Polygon::new(LineString::from(star), vec![]);
        let star_area = star.unsigned_area();
        let alone = union_nonzero(std::slice::from_ref(&star));
        assert_eq!(alone.0.len(), 1);
        assert_eq!(
            alone.0[0].exterior().0.len(),
            n + 1,
            "every vertex kept, none added"
        );
        assert!((alone.unsigned_area() - star_area).abs() < 1e-6 * star_area);

        let covered = union_nonzero(&[star.clone(), rect(-101.0, -101.0, 101.0, 101.0)]);
        assert_eq!(covered.0.len(), 1);
        assert_eq!(
            covered.0[0].exterior().0.len(),
            5,
            "the square's four corners"
        );
        assert!((covered.unsigned_area() - 202.0 * 202.0).abs() < 1e-6);

        // The square's left side touches the star's rightmost tip (100, 0): a point contact, two polygons.
        let both = union_nonzero(&[star, rect(100.0, -5.0, 110.0, 5.0)]);
        assert_eq!(both.0.len(), 2);
        assert!((both.unsigned_area() - star_area - 100.0).abs() < 1e-6 * star_area);
    }

    /// A ring through `pts`, closed.
    fn ring_of(pts: &[(f64, f64)]) -> LineString<f64> {
        let mut v: Vec<Coord<f64>> = pts.iter().map(|&(x, y)| Coord { x, y }).collect();
        v.push(v[0]);
        LineString(v)
    }

    #[test]
    fn even_odd_rebuild_of_the_usual_faults() {
        // Bow tie: two triangles of 25 m² meeting at (5, 5).
        let bow = Polygon::new(
            ring_of(&[(0.0, 0.0), (0.0, 10.0), (10.0, 0.0), (10.0, 10.0)]),
            vec![],
        );
        let r = rebuild_even_odd(&bow);
        assert!(r.is_valid(), "{:?}", r.validation_errors());
        assert_eq!(r.0.len(), 2);
        assert!((r.unsigned_area() - 50.0).abs() < 1e-9);
        // An edge out to (15, 5) and back adds nothing.
        let spike = Polygon::new(
            ring_of(&[
                (0.0, 0.0),
                (10.0, 0.0),
                (15.0, 5.0),
                (10.0, 0.0),
                (10.0, 10.0),
                (0.0, 10.0),
            ]),
            vec![],
        );
        let r = rebuild_even_odd(&spike);
        assert!(r.is_valid());
        assert!((r.unsigned_area() - 100.0).abs() < 1e-9);
        // A hole crossing its shell: what lies inside exactly one of them.
        let shell = rect(0.0, 0.0, 10.0, 10.0).exterior().clone();
        let hole = rect(8.0, 2.0, 12.0, 4.0).exterior().clone();
        let r = rebuild_even_odd(&Polygon::new(shell, vec![hole]));
        assert!(r.is_valid());
        assert!((r.unsigned_area() - (100.0 - 4.0 + 4.0)).abs() < 1e-9);
        // Fewer than three points: nothing.
        let line = Polygon::new(LineString::from(vec![(0.0, 0.0), (1.0, 1.0)]), vec![]);
        assert!(rebuild_even_odd(&line).0.is_empty());
    }

    /// The area inside an odd number of crossings of the closed ring `pts`, by slabs: between consecutive
    /// y of vertices and crossings the covered width changes linearly, so its value at the slab's middle times
    /// the slab's height is exact up to rounding.
    fn even_odd_area_by_slabs(pts: &[(f64, f64)]) -> f64 {
        let n = pts.len();
        let edges: Vec<((f64, f64), (f64, f64))> =
            (0..n).map(|i| (pts[i], pts[(i + 1) % n])).collect();
        let mut ys: Vec<f64> = pts.iter().map(|p| p.1).collect();
        for i in 0..n {
            for j in i + 1..n {
                let ((x1, y1), (x2, y2)) = edges[i];
                let ((x3, y3), (x4, y4)) = edges[j];
                let den = (x1 - x2) * (y3 - y4) - (y1 - y2) * (x3 - x4);
                if den == 0.0 {
                    continue;
                }
                let t = ((x1 - x3) * (y3 - y4) - (y1 - y3) * (x3 - x4)) / den;
                let u = -((x1 - x2) * (y1 - y3) - (y1 - y2) * (x1 - x3)) / den;
                if (0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&u) {
                    ys.push(y1 + t * (y2 - y1));
                }
            }
        }
        ys.sort_by(f64::total_cmp);
        ys.dedup();
        ys.windows(2)
            .map(|w| {
                let y = (w[0] + w[1]) / 2.0;
                let mut xs: Vec<f64> = edges
                    .iter()
                    .filter(|((_, y1), (_, y2))| (*y1 > y) != (*y2 > y))
                    .map(|&((x1, y1), (x2, y2))| x1 + (y - y1) * (x2 - x1) / (y2 - y1))
                    .collect();
                xs.sort_by(f64::total_cmp);
                xs.chunks(2).map(|c| c[1] - c[0]).sum::<f64>() * (w[1] - w[0])
            })
            .sum()
    }

    /// Random self-crossing rings of 5–40 vertices: valid polygons of the even-odd area, computed here by
    /// slabs. (geo's `MakeValid` applies the same rule by triangulating, but its snapping is off by up to 0.75 m²
    /// on some of these rings of 100 m, where the slabs and the rebuild agree to the overlay's grid.)
    #[test]
    fn even_odd_rebuild_has_the_even_odd_area() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut crossing = 0;
        for case in 0..200 {
            let n = 5 + (next() * 36.0) as usize;
            let pts: Vec<(f64, f64)> = (0..n)
                .map(|_| ((next() * 100.0).round(), (next() * 100.0).round()))
                .collect();
            let p = Polygon::new(ring_of(&pts), vec![]);
            if p.is_valid() {
                continue;
            }
            crossing += 1;
            let ours = rebuild_even_odd(&p);
            assert!(
                ours.is_valid(),
                "case {case}: {:?}",
                ours.validation_errors()
            );
            let (a, b) = (ours.unsigned_area(), even_odd_area_by_slabs(&pts));
            // Crossings are rounded to the overlay's grid, 2²⁹ steps across the half-extent (≤ 50 m): each
            // edge may move by a step, so the area by at most the perimeter times a step.
            let perimeter: f64 = (0..n)
                .map(|i| {
                    let (p, q) = (pts[i], pts[(i + 1) % n]);
                    (q.0 - p.0).hypot(q.1 - p.1)
                })
                .sum();
            let tolerance = perimeter * 50.0 / f64::from(1u32 << 29);
            assert!(
                (a - b).abs() <= tolerance,
                "case {case}: {a} against {b} by slabs"
            );
        }
        assert!(
            crossing > 150,
            "only {crossing} of 200 rings crossed themselves"
        );
    }

    /// A circle of 5,000 vertices with two neighbouring vertices swapped (a small bow tie in its outline): the
    /// rebuild keeps the circle less the twist's sliver, with every other vertex.
    #[test]
    fn even_odd_rebuild_of_a_large_ring_with_one_twist() {
        let n = 5_000;
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                (100.0 * a.cos(), 100.0 * a.sin())
            })
            .collect();
        pts.swap(1000, 1001);
        let p = Polygon::new(ring_of(&pts), vec![]);
        assert!(!p.is_valid());
        let r = rebuild_even_odd(&p);
        assert!(r.is_valid(), "{:?}", r.validation_errors());
        let circle = std::f64::consts::PI * 100.0 * 100.0;
        assert!((r.unsigned_area() - circle).abs() < 0.01 * circle);
        let vertices: usize = r.0.iter().map(|q| q.exterior().0.len() - 1).sum();
        assert!(vertices >= n - 2 && vertices <= n + 2, "{vertices}");
    }
}
