//! Footprint repair, done per feature in a local metric plane (an affine image of lon/lat, so
//! validity and winding are the same as on the globe): drop repeated points and degenerate rings,
//! drop holes outside their shell, rebuild self-intersecting rings (even-odd, `citylod_geom::rebuild_even_odd`), union
//! overlapping or assembled pieces (`citylod_geom::union_nonzero`), drop parts under 0.01 m², and wind
//! exteriors CCW, holes CW. Placed in the local frame, which is no affine image of lon/lat, a footprint is checked
//! once more there and repaired again if it needs it ([`valid_in_frame`]).

use crate::report::IssueReason;
use crate::valid;
use geo::{Area, BooleanOps, Validation};
use geo_types::{Coord, LineString, MultiPolygon, Polygon};

/// Footprints (and parts, holes) smaller than this are degenerate (m²).
pub const MIN_AREA_M2: f64 = 0.01;

/// An equirectangular plane around (lon0, lat0) with WGS84 radii of curvature: x east, y north in
/// metres. Exactly invertible; scale error < 1e-3 within a few km, far below what repair needs.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Plane {
    lon0: f64,
    lat0: f64,
    m_per_deg_lon: f64,
    m_per_deg_lat: f64,
}

/// A longitude (or difference of longitudes) in degrees brought into [−180°, 180°] by whole turns; one already
/// there is returned as it is, bit for bit.
pub(crate) fn wrap_lon(lon: f64) -> f64 {
    if (-180.0..=180.0).contains(&lon) {
        lon
    } else {
        (lon + 180.0).rem_euclid(360.0) - 180.0
    }
}

impl Plane {
    pub fn new(lon0: f64, lat0: f64) -> Self {
        use citylod_model::{WGS84_A_M, WGS84_F};
        let e2 = WGS84_F * (2.0 - WGS84_F);
        let s = lat0.to_radians().sin();
        let w = (1.0 - e2 * s * s).sqrt();
        let n = WGS84_A_M / w;
        let m = WGS84_A_M * (1.0 - e2) / (w * w * w);
        Plane {
            lon0,
            lat0,
            m_per_deg_lon: n * lat0.to_radians().cos() * std::f64::consts::PI / 180.0,
            m_per_deg_lat: m * std::f64::consts::PI / 180.0,
        }
    }

    /// Longitudes are taken the short way round from `lon0`, so a ring across the antimeridian stays small.
    pub fn to_xy(self, lon: f64, lat: f64) -> Coord {
        Coord {
            x: wrap_lon(lon - self.lon0) * self.m_per_deg_lon,
            y: (lat - self.lat0) * self.m_per_deg_lat,
        }
    }

    pub fn to_lon_lat(self, c: Coord) -> (f64, f64) {
        (
            self.lon0 + c.x / self.m_per_deg_lon,
            self.lat0 + c.y / self.m_per_deg_lat,
        )
    }
}

/// Removes consecutive repeated points of an open ring, including last == first; returns how many.
pub(crate) fn drop_repeated_points(ring: &mut Vec<[f64; 2]>) -> usize {
    let before = ring.len();
    ring.dedup();
    while ring.len() > 1 && ring.first() == ring.last() {
        ring.pop();
    }
    before - ring.len()
}

fn distinct_points(ring: &[Coord]) -> usize {
    let mut keys: Vec<(u64, u64)> = ring
        .iter()
        .map(|c| (c.x.to_bits(), c.y.to_bits()))
        .collect();
    keys.sort_unstable();
    keys.dedup();
    keys.len()
}

fn signed_area(ring: &LineString) -> f64 {
    ring.0
        .windows(2)
        .map(|w| w[0].x * w[1].y - w[1].x * w[0].y)
        .sum::<f64>()
        / 2.0
}

/// A repaired footprint in the plane, the repairs made, and how many rings were rewound.
#[derive(Debug)]
pub(crate) struct Repaired {
    pub footprint: MultiPolygon<f64>,
    pub issues: Vec<(IssueReason, String)>,
    pub rings_reoriented: usize,
}

type Skip = (IssueReason, String);

/// Most pairs of segments of an invalid polygon that may cross or touch for `repair` to rebuild it: each crossing
/// becomes a vertex of the rebuilt parts, and a footprint drawn wrong has a few (Boston's eight self-crossing
/// footprints come out as one to three parts each). A ring that crosses itself everywhere — a star whose every
/// other point lies across the centre, n²/4 crossings — is skipped with the reason instead. Below the cap the
/// rebuild stays fast: stars of 161–181 points with 6,000–9,700 crossing pairs took 40–215 ms (into up to 2,636
/// parts).
pub(crate) const MAX_REPAIR_CROSSINGS: usize = 10_000;

/// Most pairs of segments with overlapping boxes the crossing count tests before giving up (the polygon is then
/// skipped): a comb of 8,000 parallel teeth 4 km long, with one twist, has hundreds of millions and one crossing
/// (counting them all took 14 s; giving up at this budget 1.2–1.3 s, on a busy machine).
const MAX_CROSSING_TESTS: usize = 20_000_000;

/// Up to this many vertices an invalid polygon's repair entry quotes geo's reason (`Validation`), which
/// compares every pair of segments; above it, the entry counts the crossings instead.
const DESCRIBE_MAX_VERTICES: usize = 1_000;

/// Repairs polygons given as open rings (`[exterior, holes…]`) in plane metres. `assemble`: the
/// polygons are pieces of one outline (always unioned, not reported). `Err` = skip with reason.
pub(crate) fn repair(polygons: Vec<Vec<Vec<Coord>>>, assemble: bool) -> Result<Repaired, Skip> {
    let mut issues = Vec::new();
    let n_in = polygons.len();
    let mut polys: Vec<Polygon> = Vec::with_capacity(n_in);
    for (pi, mut rings) in polygons.into_iter().enumerate() {
        if rings.is_empty() || distinct_points(&rings[0]) < 3 {
            if n_in > 1 && !assemble {
                issues.push((
                    IssueReason::DegeneratePartDropped,
                    format!("part {pi} has fewer than 3 distinct points"),
                ));
            }
            continue;
        }
        let exterior = LineString::from(rings.remove(0));
        let mut holes = Vec::with_capacity(rings.len());
        for (hi, h) in rings.into_iter().enumerate() {
            if distinct_points(&h) < 3 {
                issues.push((
                    IssueReason::DegenerateHoleDropped,
                    format!("hole {} has fewer than 3 distinct points", hi + 1),
                ));
            } else {
                holes.push(LineString::from(h));
            }
        }
        polys.push(Polygon::new(exterior, holes));
    }
    if polys.is_empty() {
        return Err((
            IssueReason::TooFewPoints,
            "no ring has 3 distinct points".into(),
        ));
    }

    let mut rebuilt = false;
    let mut parts: Vec<Polygon> = Vec::with_capacity(polys.len());
    for p in polys {
        if valid::polygon_is_valid(&p) {
            parts.push(p);
            continue;
        }
        let holes = p.interiors().len();
        let p = drop_holes_outside_shell(p, &mut issues);
        if p.interiors().len() < holes && valid::polygon_is_valid(&p) {
            parts.push(p);
            continue;
        }
        let vertices = valid::vertex_count(&p);
        let crossings =
            match valid::crossings_up_to(&p, MAX_REPAIR_CROSSINGS + 1, MAX_CROSSING_TESTS) {
                Some(c) if c <= MAX_REPAIR_CROSSINGS => c,
                Some(_) => {
                    return Err((
                        IssueReason::RepairFailed,
                        format!(
                            "invalid: over {MAX_REPAIR_CROSSINGS} pairs of its segments cross or touch \
                             ({vertices} vertices); not rebuilt"
                        ),
                    ))
                }
                None => {
                    return Err((
                        IssueReason::RepairFailed,
                        format!(
                            "invalid, and too many of its {vertices} segments lie side by side to find where \
                             they cross (over {MAX_CROSSING_TESTS} pairs to test); not rebuilt"
                        ),
                    ))
                }
            };
        let why = match (vertices <= DESCRIBE_MAX_VERTICES).then(|| p.check_validation()) {
            // geo finds it valid where the segment tree did not: keep it as it is.
            Some(Ok(())) => {
                parts.push(p);
                continue;
            }
            Some(Err(why)) => why.to_string(),
            None if crossings > 0 => {
                format!("{crossings} pair(s) of its segments cross or touch")
            }
            None => "its holes overlap or lie inside one another".to_string(),
        };
        let area_before = p.unsigned_area();
        let fixed = citylod_geom::rebuild_even_odd(&p);
        issues.push((
            IssueReason::SelfIntersection,
            format!(
                "{why}; rebuilt as {} polygon(s), area {:.2} → {:.2} m²",
                fixed.0.len(),
                area_before,
                fixed.unsigned_area()
            ),
        ));
        rebuilt = true;
        parts.extend(fixed.0);
    }

    let mut footprint = MultiPolygon(parts);
    // Whether `footprint` is known valid: parts that were valid alone, checked together.
    let mut known_valid = false;
    if footprint.0.len() > 1
        && (assemble || {
            known_valid = valid::multipolygon_is_valid(&footprint);
            !known_valid
        })
    {
        let n = footprint.0.len();
        let merged = citylod_geom::union_nonzero(&footprint.0);
        if !assemble {
            issues.push((
                IssueReason::OverlappingPartsMerged,
                format!(
                    "{n} overlapping or edge-sharing polygons merged into {}",
                    merged.0.len()
                ),
            ));
        }
        footprint = merged;
        rebuilt = true;
    }

    // The rebuild and the union round to their grid; re-check what they built and give up cleanly if needed.
    if rebuilt && !known_valid && !valid::multipolygon_is_valid(&footprint) {
        footprint = citylod_geom::union_nonzero(&footprint.0);
        if !valid::multipolygon_is_valid(&footprint) {
            let vertices: usize = footprint.0.iter().map(valid::vertex_count).sum();
            let why =
                match (vertices <= DESCRIBE_MAX_VERTICES).then(|| footprint.check_validation()) {
                    Some(Err(e)) => e.to_string(),
                    _ => "its parts cross or overlap".to_string(),
                };
            return Err((
                IssueReason::RepairFailed,
                format!("repaired footprint still invalid: {why}"),
            ));
        }
    }

    let n_parts = footprint.0.len();
    let mut kept = Vec::with_capacity(n_parts);
    for (i, mut p) in footprint.0.into_iter().enumerate() {
        let a = p.unsigned_area();
        if a < MIN_AREA_M2 {
            if n_parts > 1 && !rebuilt {
                issues.push((
                    IssueReason::DegeneratePartDropped,
                    format!("part {i} has area {a:.4} m²"),
                ));
            }
            continue;
        }
        let small_holes = p
            .interiors()
            .iter()
            .filter(|h| signed_area(h).abs() < MIN_AREA_M2)
            .count();
        if small_holes > 0 {
            let (ext, mut holes) = p.into_inner();
            holes.retain(|h| signed_area(h).abs() >= MIN_AREA_M2);
            p = Polygon::new(ext, holes);
            issues.push((
                IssueReason::DegenerateHoleDropped,
                format!("{small_holes} hole(s) under {MIN_AREA_M2} m²"),
            ));
        }
        kept.push(p);
    }
    if kept.is_empty() {
        return Err((
            IssueReason::ZeroArea,
            format!("footprint area below {MIN_AREA_M2} m²"),
        ));
    }
    let mut rings_reoriented = 0;
    for p in &mut kept {
        rings_reoriented += orient(p);
    }
    if rebuilt {
        rings_reoriented = 0; // rebuilt rings have no input winding to compare with
        kept = canonical(kept);
    }
    Ok(Repaired {
        footprint: MultiPolygon(kept),
        issues,
        rings_reoriented,
    })
}

/// A footprint placed in the local frame and the repairs that took ([`valid_in_frame`]).
pub(crate) type Placed = (MultiPolygon<f64>, Vec<(IssueReason, String)>);

/// A footprint repaired in its feature's plane, as placed in the local frame (`place::to_enu`): as it is while it
/// still meets [`check_footprint`]'s conditions there, else repaired once more there, with what that took (each
/// detail saying so). The plane is an affine image of lon/lat and the frame is not: over a building's length they
/// bend a straight line apart by micrometres to millimetres, so a footprint with a vertex that close to an edge not
/// its own can cross itself in the frame, and a sliver that thin can turn over or shrink below [`MIN_AREA_M2`],
/// though it did neither in the plane. `Err` = skip with reason, as from [`repair`].
pub(crate) fn valid_in_frame(footprint: MultiPolygon<f64>) -> Result<Placed, Skip> {
    let shaped = |p: &Polygon| {
        signed_area(p.exterior()) > 0.0
            && p.interiors().iter().all(|h| signed_area(h) < 0.0)
            && p.unsigned_area() >= MIN_AREA_M2
    };
    if footprint.0.iter().all(shaped) && valid::multipolygon_is_valid(&footprint) {
        return Ok((footprint, Vec::new()));
    }
    const PLACED: &str =
        "as placed in the local frame, which bends the repair plane's straight lines by up to millimetres";
    let open = |r: LineString| {
        let mut c = r.0;
        if c.len() > 1 && c.first() == c.last() {
            c.pop();
        }
        c
    };
    let rings = footprint
        .0
        .into_iter()
        .map(|p| {
            let (exterior, holes) = p.into_inner();
            std::iter::once(exterior).chain(holes).map(open).collect()
        })
        .collect();
    let fixed =
        repair(rings, false).map_err(|(reason, why)| (reason, format!("{PLACED}: {why}")))?;
    let issues = fixed
        .issues
        .into_iter()
        .map(|(reason, why)| (reason, format!("{PLACED}: {why}")))
        .collect();
    Ok((fixed.footprint, issues))
}

/// The overlays behind the rebuild and the union do not promise where a ring starts nor in
/// which order parts and holes come out, and in practice that varies from run to run. Rotate every ring to start
/// at its smallest vertex (x, then y; winding kept) and sort holes and parts, so the same input always gives the
/// same footprint.
fn canonical(polygons: Vec<Polygon>) -> Vec<Polygon> {
    fn key(c: &Coord) -> (u64, u64) {
        // Total order on finite floats through their bit patterns, made monotone for negatives.
        let k = |v: f64| {
            let b = v.to_bits();
            if b >> 63 == 1 {
                !b
            } else {
                b | (1 << 63)
            }
        };
        (k(c.x), k(c.y))
    }
    fn ring(r: &LineString) -> LineString {
        let open = &r.0[..r.0.len().saturating_sub(1)];
        let Some(start) = (0..open.len()).min_by_key(|&i| key(&open[i])) else {
            return r.clone();
        };
        let mut pts: Vec<Coord> = open[start..]
            .iter()
            .chain(&open[..start])
            .copied()
            .collect();
        pts.push(pts[0]);
        LineString(pts)
    }
    let first = |r: &LineString| r.0.first().map(key).unwrap_or((0, 0));
    let mut out: Vec<Polygon> = polygons
        .iter()
        .map(|p| {
            let mut holes: Vec<LineString> = p.interiors().iter().map(ring).collect();
            holes.sort_by_key(first);
            Polygon::new(ring(p.exterior()), holes)
        })
        .collect();
    out.sort_by_key(|p| first(p.exterior()));
    out
}

/// Drops holes that do not overlap their shell (recording each); other holes are kept.
fn drop_holes_outside_shell(p: Polygon, issues: &mut Vec<(IssueReason, String)>) -> Polygon {
    if p.interiors().is_empty() {
        return p;
    }
    let (exterior, holes) = p.into_inner();
    let shell = Polygon::new(exterior, vec![]);
    let mut kept = Vec::with_capacity(holes.len());
    for (i, h) in holes.into_iter().enumerate() {
        let hp = Polygon::new(h, vec![]);
        let overlap_m2 = shell.intersection(&hp).unsigned_area();
        if overlap_m2 < MIN_AREA_M2 {
            issues.push((
                IssueReason::HoleOutsideShell,
                format!("hole {} lies outside the exterior ring; dropped", i + 1),
            ));
        } else {
            kept.push(hp.into_inner().0);
        }
    }
    Polygon::new(shell.into_inner().0, kept)
}

/// Winds the exterior CCW and the holes CW; returns the number of rings reversed.
fn orient(p: &mut Polygon) -> usize {
    let mut n = 0;
    p.exterior_mut(|r| {
        if signed_area(r) < 0.0 {
            r.0.reverse();
            n += 1;
        }
    });
    p.interiors_mut(|hs| {
        for h in hs {
            if signed_area(h) > 0.0 {
                h.0.reverse();
                n += 1;
            }
        }
    });
    n
}

/// Checks the footprint invariant of `citylod_model::Footprint`: valid, closed, CCW exteriors,
/// CW holes, every part at least `MIN_AREA_M2`. Tests call it.
pub fn check_footprint(fp: &MultiPolygon<f64>) -> Result<(), String> {
    if fp.0.is_empty() {
        return Err("empty footprint".into());
    }
    for (i, p) in fp.0.iter().enumerate() {
        if let Err(e) = p.check_validation() {
            return Err(format!("part {i}: {e}"));
        }
        if signed_area(p.exterior()) <= 0.0 || p.interiors().iter().any(|h| signed_area(h) >= 0.0) {
            return Err(format!("part {i}: wrong winding"));
        }
        if p.unsigned_area() < MIN_AREA_M2 {
            return Err(format!("part {i}: area below {MIN_AREA_M2} m²"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(pts: &[(f64, f64)]) -> Vec<Coord> {
        pts.iter().map(|&(x, y)| Coord { x, y }).collect()
    }

    #[test]
    fn a_footprint_placed_in_the_frame_is_kept_repaired_or_skipped_there() {
        let poly = |pts: &[(f64, f64)]| {
            MultiPolygon(vec![Polygon::new(LineString::from(ring(pts)), vec![])])
        };
        // Valid, counter-clockwise, large enough: kept as it is.
        let square = poly(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]);
        let (kept, issues) = valid_in_frame(square.clone()).unwrap();
        assert_eq!((kept, issues.len()), (square, 0));
        // Crossing itself 10 µm from a corner (as a plane-valid footprint can once placed): rebuilt, said so.
        let crossing = poly(&[(0.0, 0.0), (100.0, 1e-4), (10.0, 0.0), (10.0, 10.0)]);
        let (fixed, issues) = valid_in_frame(crossing).unwrap();
        assert!(check_footprint(&fixed).is_ok(), "{fixed:?}");
        assert_eq!(issues.len(), 1, "{issues:?}");
        assert_eq!(issues[0].0, IssueReason::SelfIntersection);
        assert!(
            issues[0].1.starts_with("as placed in the local frame"),
            "{}",
            issues[0].1
        );
        // A sliver turned over and under 0.01 m²: skipped, saying where.
        let sliver = poly(&[(0.0, 0.0), (180.0, 1e-5), (10.0, 0.0)]);
        let (reason, why) = valid_in_frame(sliver).unwrap_err();
        assert_eq!(reason, IssueReason::ZeroArea);
        assert!(why.starts_with("as placed in the local frame"), "{why}");
        // Turned over but large: wound counter-clockwise again.
        let clockwise = poly(&[(0.0, 0.0), (0.0, 10.0), (10.0, 10.0), (10.0, 0.0)]);
        let (turned, _) = valid_in_frame(clockwise).unwrap();
        assert!(check_footprint(&turned).is_ok(), "{turned:?}");
    }

    #[test]
    fn bowtie_becomes_two_triangles_reported_as_repaired() {
        let bowtie = ring(&[(0.0, 0.0), (10.0, 10.0), (10.0, 0.0), (0.0, 10.0)]);
        let r = repair(vec![vec![bowtie]], false).unwrap();
        assert_eq!(r.footprint.0.len(), 2);
        assert!((r.footprint.unsigned_area() - 50.0).abs() < 1e-6);
        assert_eq!(r.issues[0].0, IssueReason::SelfIntersection);
        check_footprint(&r.footprint).unwrap();
    }

    #[test]
    fn clockwise_exterior_and_ccw_hole_are_rewound() {
        let ext = ring(&[(0.0, 0.0), (0.0, 10.0), (10.0, 10.0), (10.0, 0.0)]);
        let hole = ring(&[(2.0, 2.0), (4.0, 2.0), (4.0, 4.0), (2.0, 4.0)]);
        let r = repair(vec![vec![ext, hole]], false).unwrap();
        assert_eq!(r.rings_reoriented, 2);
        assert!(r.issues.is_empty());
        check_footprint(&r.footprint).unwrap();
        assert!((r.footprint.unsigned_area() - 96.0).abs() < 1e-9);
    }

    #[test]
    fn canonical_form_ignores_ring_start_and_part_order() {
        let sq = |x: f64, start: usize| {
            let mut pts = vec![
                Coord { x, y: 0.0 },
                Coord { x: x + 1.0, y: 0.0 },
                Coord { x: x + 1.0, y: 1.0 },
                Coord { x, y: 1.0 },
            ];
            pts.rotate_left(start);
            pts.push(pts[0]);
            Polygon::new(LineString(pts), vec![])
        };
        let a = canonical(vec![sq(0.0, 0), sq(-5.0, 2)]);
        let b = canonical(vec![sq(-5.0, 3), sq(0.0, 1)]);
        assert_eq!(a, b);
        assert_eq!(a[0].exterior().0[0], Coord { x: -5.0, y: 0.0 });
        // Winding is kept: the exterior stays counter-clockwise.
        assert!(signed_area(a[1].exterior()) > 0.0);
    }

    #[test]
    fn rings_crossing_everywhere_are_skipped_not_rebuilt() {
        // A star whose every other point lies across the centre: its 1,001 edges cross ~250,000 times.
        let n = 1_001;
        let pts: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU * 0.37;
                let r = if i % 2 == 0 { 50.0 } else { 20.0 };
                (r * a.cos(), r * a.sin())
            })
            .collect();
        let e = repair(vec![vec![ring(&pts)]], false).err().unwrap();
        assert_eq!(e.0, IssueReason::RepairFailed);
        assert!(
            e.1.contains(&format!("over {MAX_REPAIR_CROSSINGS} pairs"))
                && e.1.contains("1002 vertices"),
            "{}",
            e.1
        );
    }

    /// A traced outline of 4,000 vertices (a wavy circle of ~100 m) with two neighbouring vertices swapped and a
    /// hole that crosses it: rebuilt, not skipped — the circle less the twist's sliver and what the hole takes
    /// from it, plus the part of the hole outside the shell (inside exactly one ring).
    #[test]
    fn large_rings_with_a_few_crossings_are_rebuilt() {
        let n = 4_000;
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                let r = 100.0 * (1.0 + 0.02 * (40.0 * a).sin());
                (r * a.cos(), r * a.sin())
            })
            .collect();
        pts.swap(1_400, 1_401);
        let hole = ring(&[(90.0, -5.0), (90.0, 5.0), (110.0, 5.0), (110.0, -5.0)]);
        let shell = Polygon::new(LineString(ring(&pts)), vec![]);
        let shell_area = shell.unsigned_area();
        let r = repair(vec![vec![ring(&pts), hole]], false).unwrap();
        assert_eq!(r.issues.len(), 1, "{:?}", r.issues);
        assert_eq!(r.issues[0].0, IssueReason::SelfIntersection);
        assert!(
            r.issues[0]
                .1
                .starts_with("3 pair(s) of its segments cross or touch; rebuilt as"),
            "{}",
            r.issues[0].1
        );
        check_footprint(&r.footprint).unwrap();
        // The hole's 200 m² straddle the outline (x ≈ 100 at y ≈ 0): what lies inside the shell is cut out, what
        // lies outside is added; both are about half the square.
        let area = r.footprint.unsigned_area();
        assert!(
            (area - shell_area).abs() < 50.0,
            "{area} against {shell_area}"
        );
        assert!(r.footprint.0.iter().any(|p| !p.interiors().is_empty()) || r.footprint.0.len() > 1);
        let vertices: usize = r.footprint.0.iter().map(valid::vertex_count).sum();
        assert!(vertices > n - 10, "{vertices} vertices kept of {n}");
    }

    #[test]
    fn hole_outside_shell_is_dropped() {
        let ext = ring(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]);
        let hole = ring(&[(20.0, 20.0), (22.0, 20.0), (22.0, 22.0), (20.0, 22.0)]);
        let r = repair(vec![vec![ext, hole]], false).unwrap();
        assert_eq!(r.issues[0].0, IssueReason::HoleOutsideShell);
        assert!(r.footprint.0[0].interiors().is_empty());
        assert!((r.footprint.unsigned_area() - 100.0).abs() < 1e-9);
    }

    #[test]
    fn degenerate_inputs_are_skipped_with_the_right_reason() {
        let two = ring(&[(0.0, 0.0), (1.0, 1.0)]);
        assert_eq!(
            repair(vec![vec![two]], false).unwrap_err().0,
            IssueReason::TooFewPoints
        );
        let collinear = ring(&[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)]);
        assert_eq!(
            repair(vec![vec![collinear]], false).unwrap_err().0,
            IssueReason::ZeroArea
        );
        let tiny = ring(&[(0.0, 0.0), (0.05, 0.0), (0.05, 0.05), (0.0, 0.05)]);
        assert_eq!(
            repair(vec![vec![tiny]], false).unwrap_err().0,
            IssueReason::ZeroArea
        );
    }

    #[test]
    fn assembled_pieces_are_unioned_without_a_repair_entry() {
        let a = ring(&[(0.0, 0.0), (5.0, 0.0), (5.0, 5.0), (0.0, 5.0)]);
        let b = ring(&[(5.0, 0.0), (10.0, 0.0), (10.0, 5.0), (5.0, 5.0)]);
        let r = repair(vec![vec![a.clone()], vec![b.clone()]], true).unwrap();
        assert_eq!(r.footprint.0.len(), 1);
        assert!(r.issues.is_empty());
        let r = repair(vec![vec![a], vec![b]], false).unwrap();
        assert_eq!(r.issues[0].0, IssueReason::OverlappingPartsMerged);
        assert!((r.footprint.unsigned_area() - 50.0).abs() < 1e-9);
    }

    #[test]
    fn repeated_points_are_dropped_including_the_wrap() {
        let mut r = vec![
            [0.0, 0.0],
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [1.0, 1.0],
            [0.0, 0.0],
        ];
        assert_eq!(drop_repeated_points(&mut r), 3);
        assert_eq!(r, vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]);
    }

    proptest::proptest! {
        /// Any ring of small integer points either repairs into a valid CCW footprint or is
        /// skipped with a reason; never a panic, never an invalid footprint.
        #[test]
        fn random_rings_repair_to_valid_footprints_or_skip(
            pts in proptest::collection::vec((0i32..8, 0i32..8), 0..12),
            hole in proptest::collection::vec((0i32..8, 0i32..8), 0..6),
            assemble in proptest::bool::ANY,
        ) {
            let r: Vec<Coord> = pts.iter().map(|&(x, y)| Coord { x: x as f64, y: y as f64 }).collect();
            let h: Vec<Coord> = hole.iter().map(|&(x, y)| Coord { x: x as f64 + 0.5, y: y as f64 + 0.25 }).collect();
            let rings = if h.is_empty() { vec![r] } else { vec![r, h] };
            match repair(vec![rings], assemble) {
                Ok(out) => {
                    if let Err(e) = check_footprint(&out.footprint) {
                        panic!("{e}: {:?} from {pts:?} / {hole:?}", out.footprint);
                    }
                }
                Err((reason, _)) => proptest::prop_assert!(matches!(
                    reason,
                    IssueReason::TooFewPoints | IssueReason::ZeroArea | IssueReason::RepairFailed
                )),
            }
        }
    }

    #[test]
    fn plane_round_trips_exactly_and_has_metric_scale() {
        let p = Plane::new(-71.06, 42.35);
        let c = p.to_xy(-71.05, 42.36);
        let (lon, lat) = p.to_lon_lat(c);
        assert!((lon + 71.05).abs() < 1e-12 && (lat - 42.36).abs() < 1e-12);
        // 0.01° of latitude ≈ 1111 m; 0.01° of longitude at 42.35° ≈ 823 m.
        assert!(
            (c.y - 1111.0).abs() < 3.0 && (c.x - 823.0).abs() < 3.0,
            "{c:?}"
        );
        // Across the antimeridian the short way round: 0.0001° east of 179.99995° is −179.99995°.
        let p = Plane::new(179.99995, -16.5);
        let c = p.to_xy(-179.99995, -16.5);
        assert!(c.x > 10.0 && c.x < 11.0, "{c:?}");
        assert!(p.to_xy(179.9999, -16.5).x < 0.0);
        let (lon, _) = p.to_lon_lat(c);
        assert!((lon - 180.00005).abs() < 1e-9, "{lon}");
    }
}
