//! Planar polygon operations shared by the ingest and generalize stages (local ENU metres).
//!
//! - [`union_nonzero`]: the union of polygons under the non-zero winding rule, OGC-valid.
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
        if let Some(ext) = open_path(p.exterior(), true) {
            paths.push(ext);
            paths.extend(p.interiors().iter().filter_map(|h| open_path(h, false)));
        }
    }
    if paths.is_empty() {
        return MultiPolygon(Vec::new());
    }
    let capacity = paths.iter().map(Vec::len).sum();
    let adapter = FloatPointAdapter::<[f64; 2], i32>::with_iter(paths.iter().flatten());
    let shapes =
        FloatOverlay::new_custom(adapter, OverlayOptions::ogc(), Solver::default(), capacity)
            .unsafe_add_source(&paths, ShapeType::Subject)
            .overlay(OverlayRule::Subject, FillRule::NonZero);
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

/// The ring without its closing point, counter-clockwise when `ccw` and clockwise otherwise; `None` under
/// three points.
fn open_path(ring: &LineString<f64>, ccw: bool) -> Option<Vec<[f64; 2]>> {
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
    if (twice_signed_area(&path) > 0.0) != ccw {
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
}
