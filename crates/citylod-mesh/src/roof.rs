//! Buildings with pitched roofs from a footprint, its heights and a roof shape, as OpenStreetMap's Simple 3D
//! Buildings tags describe them (`roof:shape`, `roof:height`, `roof:angle`, `roof:direction`, `roof:orientation`):
//! a closed mesh of ground, walls up to the roof and the roof faces, each face planar, in local ENU metres.
//!
//! - **skillion**: one plane descending towards the roof direction, over any outline and its courtyards;
//! - **gabled**: two planes meeting at a ridge through the middle of the outline, the gable ends walls, over any
//!   outline and its courtyards; **gambrel**: the same with each side in two slopes, steep below [`BREAK`] and
//!   shallow above it; **round**: the same with a quarter circle's profile (an ellipse when the rise is not the
//!   run), in [`DOME_BANDS`] planar bands each side; **half-hipped**: the same with a hip over each gable from
//!   [`HALF_HIP_FROM`] of the rise up. Each is the lowest of its planes (`ridged`, `lowest_of`);
//! - **hipped**: a plane rising from every outline edge at one slope: the straight skeleton (for a convex outline
//!   the face of an edge is where that edge is the nearest; for a concave one, or one with courtyards, the outline is
//!   shrunk and the courtyards grown from event to event, `skeleton`); **mansard**: the same with every face in
//!   two slopes, steep below [`BREAK`] and shallow above it;
//! - **pyramidal**: a triangle from every outline edge to an apex above the outline's centroid;
//! - **dome** (also for an onion, whose bulge beyond the walls is not drawn): the outline shrunk towards its centroid
//!   in [`DOME_BANDS`] bands whose heights follow a quarter circle (an ellipse when the rise is not the radius).
//!
//! Pyramidal and dome roofs need a convex outline without courtyards; a footprint of several polygons has no
//! pitched roof here. Those cases are errors with the reason, for the caller to keep its flat prism.

use crate::simplify::polygon::inside_even_odd;
use citylod_model::{Mesh3d, SurfaceKind};
use geo_types::MultiPolygon;
use std::collections::BTreeMap;

/// The shapes modelled (OpenStreetMap `roof:shape` values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RoofShape {
    Skillion,
    Gabled,
    /// Gabled, each side steep up to [`BREAK`] and shallow above it (a barn's roof).
    Gambrel,
    /// Gabled with a quarter circle's profile (a barrel roof).
    Round,
    /// Gabled, each gable wall up to [`HALF_HIP_FROM`] of the rise and a hip above it.
    HalfHipped,
    Hipped,
    /// Hipped, every face steep up to [`BREAK`] and shallow above it.
    Mansard,
    Pyramidal,
    /// A dome over a convex outline: the outline shrunk towards its centroid in bands, as a quarter circle rises.
    Dome,
}

impl RoofShape {
    /// Every shape modelled.
    pub const ALL: [RoofShape; 9] = [
        RoofShape::Skillion,
        RoofShape::Gabled,
        RoofShape::Gambrel,
        RoofShape::Round,
        RoofShape::HalfHipped,
        RoofShape::Hipped,
        RoofShape::Mansard,
        RoofShape::Pyramidal,
        RoofShape::Dome,
    ];

    /// Whether the shape rises to one apex over the outline's centroid, so needs a convex outline without
    /// courtyards (pyramidal and dome); the others span any outline and its courtyards.
    pub fn needs_convex(self) -> bool {
        matches!(self, RoofShape::Pyramidal | RoofShape::Dome)
    }

    /// The shape an OpenStreetMap `roof:shape` value names, if modelled here.
    pub fn from_osm(value: &str) -> Option<RoofShape> {
        match value.trim().to_ascii_lowercase().as_str() {
            "skillion" | "lean_to" | "shed" => Some(RoofShape::Skillion),
            "gabled" | "pitched" => Some(RoofShape::Gabled),
            "gambrel" => Some(RoofShape::Gambrel),
            "round" => Some(RoofShape::Round),
            // half_hipped as Overture Maps writes it.
            "half-hipped" | "half_hipped" => Some(RoofShape::HalfHipped),
            "hipped" => Some(RoofShape::Hipped),
            "mansard" => Some(RoofShape::Mansard),
            // A cone over a round outline is the pyramid over its corners.
            "pyramidal" | "cone" => Some(RoofShape::Pyramidal),
            // An onion's bulge beyond its walls cannot stand on them: drawn as the dome under it.
            // Overture Maps' spherical roof too.
            "dome" | "onion" | "spherical" => Some(RoofShape::Dome),
            _ => None,
        }
    }
}

/// How high the roof rises from its eaves to its top.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RoofRise {
    /// Metres (`roof:height`, or `roof:levels` storeys).
    Metres(f64),
    /// The slope in degrees (`roof:angle`): the rise over the run from the eaves to the ridge or apex (for a roof of
    /// several slopes, their mean).
    AngleDeg(f64),
    /// Nothing given: a slope of [`DEFAULT_ANGLE_DEG`], at most half of the building's height.
    Default,
}

/// The slope of a roof whose height is not given.
pub const DEFAULT_ANGLE_DEG: f64 = 30.0;

/// Where a gambrel or mansard roof changes slope: (share of the run in from the eaves, share of the rise). A third of
/// the way in and two thirds of the way up, the lower slope is four times the upper (at the default mean slope of
/// 30°, 49° below and 16° above).
pub const BREAK: [f64; 2] = [1.0 / 3.0, 2.0 / 3.0];

/// A roof below this rise is flat.
pub const MIN_RISE_M: f64 = 0.05;

/// The least wall under a roof (m): a roof asked as high as its building or higher is lowered to leave this.
pub const MIN_WALL_M: f64 = 0.1;

/// Outlines with more corners than this are not roofed (a hipped roof clips every face by every edge).
pub const MAX_CORNERS: usize = 256;

/// A pitched roof.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoofSpec {
    pub shape: RoofShape,
    pub rise: RoofRise,
    /// Compass degrees (clockwise from north) the roof's slopes face (`roof:direction`): a skillion descends
    /// towards it, a gabled roof's ridge runs across it. Without it a skillion descends across the longest edge and
    /// a gabled ridge runs along the longest edge.
    pub direction_deg: Option<f64>,
    /// A gabled ridge across the longest edge instead of along it (`roof:orientation=across`).
    pub across: bool,
}

type P2 = [f64; 2];

/// The mesh of a building of `footprint` standing from `base_z` to `base_z + height` (the top of its roof) with
/// the roof `spec`, and the kind of every triangle; or why this roof cannot be built on this footprint.
pub fn roofed_building(
    footprint: &MultiPolygon<f64>,
    base_z: f64,
    height: f64,
    spec: &RoofSpec,
) -> Result<(Mesh3d, Vec<SurfaceKind>), String> {
    roofed(footprint, base_z, height, spec).map(|r| (r.mesh, r.kinds))
}

/// A roofed building and the rise its roof was asked and given.
#[derive(Debug, Clone)]
pub struct Roofed {
    pub mesh: Mesh3d,
    /// The kind of every triangle.
    pub kinds: Vec<SurfaceKind>,
    /// The rise the spec asked (m): its height, or its angle over this outline's run; for the default, what the
    /// default rule gives (at most half the building).
    pub asked_rise_m: f64,
    /// The rise built (m): the asked one, lowered where the walls would keep less than [`MIN_WALL_M`].
    pub rise_m: f64,
}

/// [`roofed_building`] with the rise asked and built, so that a caller can say when a roof was lowered.
pub fn roofed(
    footprint: &MultiPolygon<f64>,
    base_z: f64,
    height: f64,
    spec: &RoofSpec,
) -> Result<Roofed, String> {
    let [polygon] = footprint.0.as_slice() else {
        return Err(format!(
            "a footprint of {} polygons has no single roof",
            footprint.0.len()
        ));
    };
    if !(base_z.is_finite() && height.is_finite() && height > 0.0) {
        return Err(format!("heights {base_z} + {height} m are not usable"));
    }
    // The outline and its courtyards: a skillion or gabled roof spans them, the others need a convex outline.
    let (o, rings) = roof_rings(polygon);
    let ring = rings[0].clone();
    if ring.len() < 3 {
        return Err("the outline has fewer than 3 corners".into());
    }
    if ring.len() > MAX_CORNERS {
        return Err(format!(
            "an outline of {} corners (more than {MAX_CORNERS})",
            ring.len()
        ));
    }
    if spec.shape.needs_convex() && rings.len() > 1 {
        return Err("a footprint with a courtyard (a hole) takes no pyramidal or dome roof".into());
    }
    if spec.shape.needs_convex() && !is_convex(&ring) {
        return Err(
            "the outline is not convex (pyramidal and dome roofs need a convex one)".into(),
        );
    }
    let corner_count: usize = rings.iter().map(Vec::len).sum();
    if corner_count > MAX_CORNERS {
        return Err(format!(
            "an outline of {corner_count} corners with its courtyards (more than {MAX_CORNERS})"
        ));
    }
    let top = base_z + height;
    let longest = longest_edge(&ring);
    let profile = profile(spec.shape);
    let (faces, run) = match spec.shape {
        RoofShape::Skillion => {
            let down = spec
                .direction_deg
                .map_or([-longest[1], longest[0]], compass);
            skillion(&rings, down)
        }
        RoofShape::Gabled | RoofShape::Gambrel | RoofShape::Round | RoofShape::HalfHipped => {
            let along = match spec.direction_deg {
                Some(d) => {
                    let c = compass(d);
                    [-c[1], c[0]]
                }
                None if spec.across => [-longest[1], longest[0]],
                None => longest,
            };
            ridged(&rings, along, &profile, spec.shape == RoofShape::HalfHipped)
        }
        RoofShape::Hipped | RoofShape::Mansard => {
            let (faces, run) = if rings.len() == 1 && is_convex(&ring) {
                hipped(&ring)
            } else {
                skeleton(&rings).ok_or_else(|| {
                    "the outline's straight skeleton could not be built".to_string()
                })?
            };
            let breaks: Vec<f64> = profile.iter().map(|b| b[0]).collect();
            (banded(faces, &breaks), run)
        }
        RoofShape::Pyramidal => pyramidal(&ring),
        RoofShape::Dome => dome(&ring),
    };
    if !(run.is_finite() && run > 1e-6) {
        return Err("the outline has no width to pitch a roof over".into());
    }
    let rise = match spec.rise {
        RoofRise::Metres(m) if m.is_finite() => m,
        RoofRise::Metres(m) => return Err(format!("a roof height of {m} m")),
        RoofRise::AngleDeg(a) if a > 0.0 && a < 89.0 => a.to_radians().tan() * run,
        RoofRise::AngleDeg(a) => return Err(format!("a roof angle of {a}° is not a slope")),
        // A dome or a round roof as high as it is wide; other roofs at the default slope.
        RoofRise::Default if matches!(spec.shape, RoofShape::Dome | RoofShape::Round) => {
            run.min(0.5 * height)
        }
        RoofRise::Default => (DEFAULT_ANGLE_DEG.to_radians().tan() * run).min(0.5 * height),
    };
    // The walls keep at least MIN_WALL_M (a roof as high as the building would meet the ground).
    let asked_rise_m = rise;
    let rise = rise.min(height - MIN_WALL_M);
    if !(rise.is_finite() && rise >= MIN_RISE_M) {
        return Err(format!(
            "a roof rise of {} m on a building {height} m high is flat",
            trim(rise)
        ));
    }
    let eaves = top - rise;
    let (points, roof) = plan(&faces, &rings)
        .filter(|(_, roof)| !roof.is_empty())
        .ok_or_else(|| "the roof's faces could not be triangulated".to_string())?;
    // A ridged roof's faces carry their share of the rise; a mansard's their share of the run, lifted along its profile.
    let lifted: &[[f64; 2]] = if spec.shape == RoofShape::Mansard {
        &profile
    } else {
        &[]
    };
    // Vertex i is point i on the roof, vertex n + i the same point on the ground.
    let n = points.len() as u32;
    let mut positions: Vec<[f64; 3]> = points
        .iter()
        .map(|p| [p[0] + o[0], p[1] + o[1], eaves + rise * lift(lifted, p[2])])
        .collect();
    positions.extend(points.iter().map(|p| [p[0] + o[0], p[1] + o[1], base_z]));
    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(roof.len() * 3);
    let mut kinds = Vec::with_capacity(roof.len() * 3);
    // The roof, seen from above counter-clockwise; the ground, the same triangles turned to face down.
    for t in &roof {
        triangles.push(*t);
        // A triangle of the roof standing upright (between a gable's foot on its rim, in line by rounding, and its
        // ridge) is wall.
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let (u, v) = (
            [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
            [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
        );
        let normal = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let upright = normal[2].abs() < 0.1 * normal[0].hypot(normal[1]).hypot(normal[2]);
        kinds.push(if upright {
            SurfaceKind::Wall
        } else {
            SurfaceKind::Roof
        });
        triangles.push([t[0] + n, t[2] + n, t[1] + n]);
        kinds.push(SurfaceKind::Ground);
    }
    // A wall under every edge of the roof's rim (an edge of one roof triangle only), from the ground up to the roof.
    let mut used: std::collections::HashSet<(u32, u32)> = std::collections::HashSet::new();
    for t in &roof {
        for k in 0..3 {
            used.insert((t[k], t[(k + 1) % 3]));
        }
    }
    let mut rim: Vec<(u32, u32)> = used
        .iter()
        .copied()
        .filter(|&(a, b)| !used.contains(&(b, a)))
        .collect();
    rim.sort_unstable();
    for (a, b) in rim {
        triangles.push([a + n, b + n, b]);
        triangles.push([a + n, b, a]);
        kinds.extend([SurfaceKind::Wall; 2]);
    }
    Ok(Roofed {
        mesh: Mesh3d {
            positions,
            triangles,
        },
        kinds,
        asked_rise_m,
        rise_m: rise,
    })
}

/// Points (x, y, share of the rise) and triangles over them.
type RoofPlan = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// The roof as one triangulation: every corner of every face once (corners closer than [`WELD_M`], directly or
/// through others, are one: where faces of a hipped roof meet, each face computes the point anew), with its share
/// of the rise (the highest of its copies'), and the triangles of a Delaunay triangulation constrained by every
/// face's edges, kept where they lie inside the outline, counter-clockwise from above. One triangulation for all
/// faces leaves no crack where two faces' corners differ by rounding, and its rim is the walls' top. `None` if the
/// triangulation fails or two faces' edges cross (triangles would span both faces, at neither's slope).
fn plan(faces: &[Face], rings: &[Vec<P2>]) -> Option<RoofPlan> {
    use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};
    // Every face corner's point: corners within WELD_M of each other, directly or through others, are one point
    // (a simultaneous event's corners, each from another pair of lines, scatter by more than that in all).
    let all: Vec<[f64; 3]> = faces.iter().flatten().copied().collect();
    let mut parent: Vec<usize> = (0..all.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut by_x: Vec<usize> = (0..all.len()).collect();
    by_x.sort_by(|&a, &b| all[a][0].total_cmp(&all[b][0]).then(a.cmp(&b)));
    for (n, &a) in by_x.iter().enumerate() {
        for &b in by_x[n + 1..]
            .iter()
            .take_while(|&&b| all[b][0] - all[a][0] < WELD_M)
        {
            if (all[a][1] - all[b][1]).abs() < WELD_M {
                let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
                // The first corner met stands for its group.
                parent[ra.max(rb)] = ra.min(rb);
            }
        }
    }
    // Point i of the plan for each group, at its first corner, with the highest share among its corners (the ridge
    // or apex reaches the top exactly).
    let mut point_of: Vec<usize> = vec![usize::MAX; all.len()];
    let mut points: Vec<[f64; 3]> = Vec::new();
    let mut cdt: ConstrainedDelaunayTriangulation<Point2<f64>> =
        ConstrainedDelaunayTriangulation::new();
    // Spade's vertex → point.
    let mut of_handle: Vec<u32> = Vec::new();
    let mut handles = Vec::new();
    for i in 0..all.len() {
        let r = root(&mut parent, i);
        if point_of[r] == usize::MAX {
            let q = all[r];
            let h = cdt.insert(Point2::new(q[0], q[1])).ok()?;
            if of_handle.len() <= h.index() {
                of_handle.resize(h.index() + 1, u32::MAX);
            }
            if of_handle[h.index()] != u32::MAX {
                // Spade merged it with a point of another group (or of the frame): they are too close to be two.
                return None;
            }
            of_handle[h.index()] = points.len() as u32;
            point_of[r] = points.len();
            points.push(q);
            handles.push(h);
        }
        let p = point_of[r];
        points[p][2] = points[p][2].max(all[i][2]);
    }
    let mut next = 0;
    for face in faces {
        let hs: Vec<_> = (next..next + face.len())
            .map(|i| handles[point_of[root(&mut parent, i)]])
            .collect();
        next += face.len();
        for k in 0..hs.len() {
            let (a, b) = (hs[k], hs[(k + 1) % hs.len()]);
            // A constraint crossing another: two faces overlap, and triangles would span them.
            if a != b && cdt.try_add_constraint(a, b).is_empty() {
                return None;
            }
        }
    }
    // Four points well outside the outline, so that no edge of it stays on the hull of the points: a chain of points
    // along an outline edge (where lines cross it) bends by rounding, and on the hull its bends would be filled with
    // slivers whose centroids, on the edge, tell inside from outside by rounding too. Added after the constraints,
    // which wall the outline's inside off from them: only triangles outside it change.
    for [x, y] in frame(&rings[0]) {
        let h = cdt.insert(Point2::new(x, y)).ok()?;
        if of_handle.len() <= h.index() {
            of_handle.resize(h.index() + 1, u32::MAX);
        }
        of_handle[h.index()] = FRAME;
    }
    let mut triangles = Vec::new();
    for f in cdt.inner_faces() {
        let vs = f.vertices();
        let ps = vs.map(|v| [v.position().x, v.position().y]);
        let c = [
            (ps[0][0] + ps[1][0] + ps[2][0]) / 3.0,
            (ps[0][1] + ps[1][1] + ps[2][1]) / 3.0,
        ];
        if !inside_even_odd(rings, c) {
            continue;
        }
        let ids = vs.map(|v| of_handle.get(v.fix().index()).copied().unwrap_or(u32::MAX));
        if ids.iter().any(|&i| i == u32::MAX || i == FRAME) {
            // A point spade added where two constraints cross: faces that overlap.
            return None;
        }
        triangles.push(ids);
    }
    Some((points, triangles))
}

/// A square-cornered frame around `ring` (counter-clockwise), as far from it as the ring is wide, and at least 1 m.
fn frame(ring: &[P2]) -> [P2; 4] {
    let (lo, hi) = ring.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    );
    let m = 1.0 + (hi[0] - lo[0]).max(hi[1] - lo[1]);
    [
        [lo[0] - m, lo[1] - m],
        [hi[0] + m, lo[1] - m],
        [hi[0] + m, hi[1] + m],
        [lo[0] - m, hi[1] + m],
    ]
}

/// `of_handle` of the frame's points in [`plan`].
const FRAME: u32 = u32::MAX - 1;

fn trim(m: f64) -> String {
    let t = format!("{m:.2}");
    t.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// Compass degrees (clockwise from north) as an east-north unit vector.
fn compass(deg: f64) -> P2 {
    let r = deg.to_radians();
    [r.sin(), r.cos()]
}

fn sub(a: P2, b: P2) -> P2 {
    [a[0] - b[0], a[1] - b[1]]
}

fn dot(a: P2, b: P2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

fn cross(a: P2, b: P2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// The area (m²) of the outline a roof over `polygon` is built on, its courtyards taken out: the footprint less its
/// corners that turn by under 0.5° ([`roofed_building`] drops them: a vertex on a straight edge would give a hipped
/// roof two faces for one edge), so within a few square metres of the footprint's.
pub fn roof_outline_area_m2(polygon: &geo_types::Polygon<f64>) -> f64 {
    let (_, rings) = roof_rings(polygon);
    if rings[0].len() < 3 {
        return 0.0;
    }
    let area = |r: &Vec<P2>| (crate::ring::signed_area2(r) / 2.0).abs();
    area(&rings[0]) - rings[1..].iter().map(area).sum::<f64>()
}

/// The rings a roof over `polygon` is built on, as [`corners`]: the outline first (whatever it has left), then each
/// courtyard of three corners or more; in metres from the outline's first corner (returned), so a roof's rounding is
/// the same wherever the building stands (ENU metres reach tens of kilometres across a city).
fn roof_rings(polygon: &geo_types::Polygon<f64>) -> (P2, Vec<Vec<P2>>) {
    let o = polygon
        .exterior()
        .0
        .first()
        .map_or([0.0, 0.0], |c| [c.x, c.y]);
    let local = |ls: &geo_types::LineString<f64>| -> Vec<P2> {
        corners(ls.0.iter().map(|c| [c.x - o[0], c.y - o[1]]).collect())
    };
    let mut rings = vec![local(polygon.exterior())];
    rings.extend(
        polygon
            .interiors()
            .iter()
            .map(local)
            .filter(|h| h.len() >= 3),
    );
    (o, rings)
}

/// The open ring's corners: no closing repeat, no repeated points, no corner turning by less than 0.5° (a vertex on a
/// straight edge would give a hipped roof two faces for one edge).
fn corners(mut ring: Vec<P2>) -> Vec<P2> {
    ring.dedup_by(|a, b| (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-6);
    while ring.len() > 1 && {
        let (f, l) = (ring[0], ring[ring.len() - 1]);
        (f[0] - l[0]).hypot(f[1] - l[1]) < 1e-6
    } {
        ring.pop();
    }
    let min_turn = 0.5f64.to_radians().sin();
    loop {
        let n = ring.len();
        if n < 3 {
            return ring;
        }
        let straight = (0..n).find(|&i| {
            let (a, b, c) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
            let (u, v) = (sub(b, a), sub(c, b));
            let lu = u[0].hypot(u[1]);
            let lv = v[0].hypot(v[1]);
            cross(u, v).abs() <= min_turn * lu * lv && dot(u, v) > 0.0
        });
        match straight {
            Some(i) => {
                ring.remove(i);
            }
            None => return ring,
        }
    }
}

/// Every corner turns left (the ring is counter-clockwise, as footprints are).
fn is_convex(ring: &[P2]) -> bool {
    let n = ring.len();
    (0..n).all(|i| {
        let (a, b, c) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
        cross(sub(b, a), sub(c, b)) > 0.0
    })
}

/// The unit direction of the longest edge.
fn longest_edge(ring: &[P2]) -> P2 {
    let n = ring.len();
    let (mut best, mut len) = ([1.0, 0.0], -1.0);
    for i in 0..n {
        let d = sub(ring[(i + 1) % n], ring[i]);
        let l = d[0].hypot(d[1]);
        if l > len {
            len = l;
            best = [d[0] / l, d[1] / l];
        }
    }
    best
}

/// A roof face: corners as (x, y, share of the rise above the eaves).
type Face = Vec<[f64; 3]>;

/// One plane over the whole outline (its rings the faces), its share of the rise 1 at the highest corner and 0 at
/// the lowest along `down`; the run is that extent.
fn skillion(rings: &[Vec<P2>], down: P2) -> (Vec<Face>, f64) {
    let s: Vec<f64> = rings[0].iter().map(|&p| dot(p, down)).collect();
    let lo = s.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = s.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let run = hi - lo;
    let faces = rings
        .iter()
        .map(|r| {
            r.iter()
                .map(|&p| [p[0], p[1], ((hi - dot(p, down)) / run).clamp(0.0, 1.0)])
                .collect()
        })
        .collect();
    (faces, run)
}

/// The roof of a ridge along `along` through the middle of the outline's extent across it (across the whole outline,
/// as Simple 3D Buildings renderers draw a gabled roof over a concave one), falling to both sides along `profile` (see
/// [`profile`]; none for one slope); with `hips`, also a plane over each end of the outline along the ridge, rising at
/// the roof's slope from [`HALF_HIP_FROM`] of the rise. The run is half the extent across. A profile's slope never
/// grows towards the ridge, so the roof is the lowest of its planes ([`lowest_of`]).
fn ridged(rings: &[Vec<P2>], along: P2, profile: &[[f64; 2]], hips: bool) -> (Vec<Face>, f64) {
    let across = [-along[1], along[0]];
    let extent = |d: P2| {
        rings[0]
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(dot(p, d)), hi.max(dot(p, d)))
            })
    };
    let ((lo, hi), (first, last)) = (extent(across), extent(along));
    let half = 0.5 * (hi - lo);
    let k = 1.0 / half;
    // Each plane's share of the rise as n · p + c. A piece of the profile from (s0, h0) to (s1, h1) rises h0 + slope ·
    // (s − s0) at share s of the run from either side: s = (t − lo) / half on one, (hi − t) / half on the other.
    let corners: Vec<[f64; 2]> = std::iter::once([0.0, 0.0])
        .chain(profile.iter().copied())
        .chain(std::iter::once([1.0, 1.0]))
        .collect();
    let mut planes = Vec::with_capacity(2 * corners.len() + 2);
    for w in corners.windows(2) {
        let slope = (w[1][1] - w[0][1]) / (w[1][0] - w[0][0]);
        let (g, c) = (slope * k, w[0][1] - slope * w[0][0]);
        planes.push(([g * across[0], g * across[1]], c - g * lo));
        planes.push(([-g * across[0], -g * across[1]], c + g * hi));
    }
    if hips {
        planes.push(([k * along[0], k * along[1]], HALF_HIP_FROM - first * k));
        planes.push(([-k * along[0], -k * along[1]], HALF_HIP_FROM + last * k));
    }
    (lowest_of(rings, &planes), half)
}

/// Where a half-hipped roof's hips begin, as a share of the rise: the gable walls rise to half the roof.
pub const HALF_HIP_FROM: f64 = 0.5;

/// The roof that is everywhere the lowest of `planes` (shares of the rise, `n · p + c`, clamped to [0, 1] and scaled
/// so that the highest corner is 1), over any outline and its courtyards. Faces: the rings with the points where
/// creases (where two planes are the lowest together) cross them inserted, and the creases' pieces inside the
/// outline, so that every triangle lies on one plane.
fn lowest_of(rings: &[Vec<P2>], planes: &[(P2, f64)]) -> Vec<Face> {
    let at = |i: usize, p: P2| dot(planes[i].0, p) + planes[i].1;
    let lowest = |p: P2| {
        (0..planes.len())
            .map(|i| at(i, p))
            .fold(f64::INFINITY, f64::min)
    };
    // Each plane's cell (where it is the lowest) within a frame around the outline; its edges with a later plane's
    // cell are the creases.
    let frame = frame(&rings[0]);
    let mut creases: Vec<[P2; 2]> = Vec::new();
    for i in 0..planes.len() {
        let mut cell = frame.to_vec();
        for j in (0..planes.len()).filter(|&j| j != i) {
            cell = clip(&cell, |p| at(i, p) - at(j, p));
        }
        for e in 0..cell.len() {
            let (a, b) = (cell[e], cell[(e + 1) % cell.len()]);
            let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
            let d = sub(b, a);
            if d[0].hypot(d[1]) > WELD_M
                && (i + 1..planes.len()).any(|j| (at(i, mid) - at(j, mid)).abs() < 1e-9)
            {
                creases.push([a, b]);
            }
        }
    }
    // Where each crease crosses the rings: the point on the ring's edge, inserted there, and the crease cut there.
    let mut crossings: Vec<Vec<Vec<(f64, P2)>>> =
        rings.iter().map(|r| vec![Vec::new(); r.len()]).collect();
    let mut pieces: Vec<[P2; 2]> = Vec::new();
    for &[p, q] in &creases {
        let d = sub(q, p);
        let mut cuts: Vec<(f64, P2)> = vec![(0.0, p), (1.0, q)];
        for (r, ring) in rings.iter().enumerate() {
            for e in 0..ring.len() {
                let (a, b) = (ring[e], ring[(e + 1) % ring.len()]);
                let f = sub(b, a);
                let den = cross(d, f);
                if den.abs() < 1e-12 * (dot(d, d) * dot(f, f)).sqrt() {
                    continue;
                }
                let w = sub(a, p);
                let (tc, te) = (cross(w, f) / den, cross(w, d) / den);
                if !((0.0..=1.0).contains(&tc) && (0.0..=1.0).contains(&te)) {
                    continue;
                }
                let x = [a[0] + te * f[0], a[1] + te * f[1]];
                let len = f[0].hypot(f[1]);
                if te * len > WELD_M && (1.0 - te) * len > WELD_M {
                    crossings[r][e].push((te, x));
                    cuts.push((tc, x));
                } else {
                    cuts.push((tc, if te < 0.5 { a } else { b }));
                }
            }
        }
        cuts.sort_by(|x, y| x.0.total_cmp(&y.0));
        for w in cuts.windows(2) {
            let (x, y) = (w[0].1, w[1].1);
            if (w[1].0 - w[0].0) * d[0].hypot(d[1]) > WELD_M
                && inside_even_odd(rings, [0.5 * (x[0] + y[0]), 0.5 * (x[1] + y[1])])
            {
                pieces.push([x, y]);
            }
        }
    }
    let mut faces: Vec<Face> = Vec::with_capacity(rings.len() + pieces.len());
    for (r, ring) in rings.iter().enumerate() {
        let mut face = Vec::with_capacity(ring.len());
        for (e, &a) in ring.iter().enumerate() {
            face.push(a);
            let mut on = std::mem::take(&mut crossings[r][e]);
            on.sort_by(|x, y| x.0.total_cmp(&y.0));
            face.extend(on.into_iter().map(|(_, x)| x));
        }
        faces.push(face.into_iter().map(|p| [p[0], p[1], lowest(p)]).collect());
    }
    faces.extend(
        pieces
            .into_iter()
            .map(|pq| pq.map(|p| [p[0], p[1], lowest(p)]).to_vec()),
    );
    // The highest corner reaches the top (the ridge, or where the hips of a short outline meet below it).
    let top = faces.iter().flatten().map(|c| c[2]).fold(0.0, f64::max);
    for c in faces.iter_mut().flatten() {
        c[2] = if top > 0.0 {
            (c[2] / top).clamp(0.0, 1.0)
        } else {
            0.0
        };
    }
    faces
}

/// The profile of a roof across its run: the corners (share of the run from the eaves, share of the rise) between
/// (0, 0) and (1, 1) where its slope changes; none for one slope.
fn profile(shape: RoofShape) -> Vec<[f64; 2]> {
    match shape {
        RoofShape::Gambrel | RoofShape::Mansard => vec![BREAK],
        // A quarter circle from the eaves (θ = 0) to the ridge (θ = 90°): in cos θ of the run from the ridge, sin θ of
        // the rise up.
        RoofShape::Round => (1..DOME_BANDS)
            .map(|j| {
                let (up, inward) =
                    (std::f64::consts::FRAC_PI_2 * j as f64 / DOME_BANDS as f64).sin_cos();
                [1.0 - inward, up]
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// The share of the rise at share `s` of the run, along `profile` (see [`profile`]).
fn lift(profile: &[[f64; 2]], s: f64) -> f64 {
    let mut from = [0.0, 0.0];
    for &to in profile.iter().chain(std::iter::once(&[1.0, 1.0])) {
        if s <= to[0] {
            let f = if to[0] > from[0] {
                (s - from[0]) / (to[0] - from[0])
            } else {
                1.0
            };
            return from[1] + f * (to[1] - from[1]);
        }
        from = to;
    }
    1.0
}

/// Convex faces whose share of the run is linear over them (a hipped roof's), cut where it crosses a share of
/// `breaks`, so that each piece lies on one slope of the profile.
fn banded(faces: Vec<Face>, breaks: &[f64]) -> Vec<Face> {
    if breaks.is_empty() {
        return faces;
    }
    let mut out = Vec::with_capacity(faces.len() * (breaks.len() + 1));
    for face in faces {
        let mut rest = face;
        for &b in breaks {
            let below = clip(&rest, |c| c[2] - b);
            rest = clip(&rest, |c| b - c[2]);
            if below.len() >= 3 {
                out.push(below);
            }
        }
        if rest.len() >= 3 {
            out.push(rest);
        }
    }
    out
}

/// The face of every edge: where that edge's line is the nearest of all (a convex outline's straight skeleton);
/// each rises at one slope, so the share of the rise is the distance to its edge over the largest such distance.
fn hipped(ring: &[P2]) -> (Vec<Face>, f64) {
    let n = ring.len();
    // Inward unit normals and offsets: the distance of p inside from edge i is normal_i · p − offset_i.
    let lines: Vec<(P2, f64)> = (0..n)
        .map(|i| {
            let d = sub(ring[(i + 1) % n], ring[i]);
            let l = d[0].hypot(d[1]);
            let normal = [-d[1] / l, d[0] / l];
            (normal, dot(normal, ring[i]))
        })
        .collect();
    let dist = |i: usize, p: P2| dot(lines[i].0, p) - lines[i].1;
    let mut faces: Vec<Vec<P2>> = Vec::with_capacity(n);
    for i in 0..n {
        let mut poly: Vec<P2> = ring.to_vec();
        for j in (0..n).filter(|&j| j != i) {
            // Keep where dist_i ≤ dist_j.
            poly = clip(&poly, |p| dist(i, p) - dist(j, p));
            if poly.len() < 3 {
                break;
            }
        }
        faces.push(poly);
    }
    let run = faces
        .iter()
        .enumerate()
        .flat_map(|(i, f)| f.iter().map(move |&p| (i, p)))
        .map(|(i, p)| dist(i, p))
        .fold(0.0, f64::max);
    let faces = faces
        .into_iter()
        .enumerate()
        .filter(|(_, f)| f.len() >= 3)
        .map(|(i, f)| {
            f.iter()
                .map(|&p| [p[0], p[1], (dist(i, p) / run).clamp(0.0, 1.0)])
                .collect()
        })
        .collect();
    (faces, run)
}

/// An edge line of the shrinking outline at time t: the points p with `normal · p = offset + t` (`normal` the unit
/// normal pointing inside). Every edge moves inwards at unit speed, so t is the distance travelled: the height of
/// the hipped roof above it, in units of the run.
#[derive(Clone, Copy, Debug)]
struct Wave {
    normal: P2,
    offset: f64,
    /// The outline edge the line is (the pieces of a split edge share it).
    id: u32,
}

impl Wave {
    /// The corner of `a` followed by `b` at time t, and its velocity; `None` for parallel lines.
    fn corner(a: Wave, b: Wave, t: f64) -> Option<(P2, P2)> {
        let det = cross(a.normal, b.normal);
        if det.abs() < 1e-9 {
            return None;
        }
        let solve = |ra: f64, rb: f64| {
            [
                (ra * b.normal[1] - rb * a.normal[1]) / det,
                (a.normal[0] * rb - b.normal[0] * ra) / det,
            ]
        };
        Some((solve(a.offset + t, b.offset + t), solve(1.0, 1.0)))
    }

    /// The edge's direction along the outline (counter-clockwise, inside on the left).
    fn along(self) -> P2 {
        [self.normal[1], -self.normal[0]]
    }
}

/// Distances under this are one point, in the wavefront's events (m).
const WAVE_EPS: f64 = 1e-7;

/// The hipped roof of any simple outline and its courtyards (`rings`: the outline first): the straight skeleton,
/// built by moving every edge into the building at one speed — the outline shrinking, the courtyards growing — from
/// event to event: an edge shrinking to nothing (its neighbours then meet), a reflex corner reaching another edge
/// (its wavefront splits in two there, or two wavefronts, a courtyard's and the outline's, join). While an edge keeps
/// its two neighbouring lines it sweeps one trapezoid of its own plane (events elsewhere do not cut it: a face per
/// neighbourhood, not per event, which took a 208-corner outline of Boston from 5.4 s to 12 ms); those bands are
/// the faces, their corners' share of the rise the time at them over the time the last part of the outline vanishes
/// (the run). `None` when the events do not end (a degenerate outline), for the caller to keep a flat roof.
fn skeleton(rings: &[Vec<P2>]) -> Option<(Vec<Face>, f64)> {
    // The outline counter-clockwise, its courtyards clockwise: the building on the left of every edge.
    let mut next_id = 0u32;
    let mut lines = |ring: &[P2], outer: bool| -> Vec<Wave> {
        let mut ring = ring.to_vec();
        if (crate::ring::signed_area2(&ring) > 0.0) != outer {
            ring.reverse();
        }
        let n = ring.len();
        (0..n)
            .map(|i| {
                let d = sub(ring[(i + 1) % n], ring[i]);
                let l = d[0].hypot(d[1]);
                let normal = [-d[1] / l, d[0] / l];
                next_id += 1;
                Wave {
                    normal,
                    offset: dot(normal, ring[i]),
                    id: next_id,
                }
            })
            .collect()
    };
    let mut cycles: Vec<Vec<Wave>> = rings
        .iter()
        .enumerate()
        .map(|(i, r)| lines(r, i == 0))
        .collect();
    let n: usize = rings.iter().map(Vec::len).sum();
    let mut bands: Vec<Vec<[f64; 3]>> = Vec::new();
    // An edge's band runs from when its line got its two neighbours to when it loses one: its corners then move in
    // straight lines. Open bands by (previous, own, next) line, with their lines and start time.
    let mut open: BTreeMap<(u32, u32, u32), OpenBand> = BTreeMap::new();
    let mut t = 0.0;
    for _ in 0..(8 * n + 32) {
        cycles = settle(cycles, t)?;
        // Bands whose edge lost a neighbour (or vanished) end at t; edges with new neighbours start one.
        let mut now: BTreeMap<(u32, u32, u32), (Wave, Wave, Wave)> = BTreeMap::new();
        for c in &cycles {
            let m = c.len();
            for k in 0..m {
                let (a, b, d) = (c[(k + m - 1) % m], c[k], c[(k + 1) % m]);
                now.insert((a.id, b.id, d.id), (a, b, d));
            }
        }
        let ended: Vec<(u32, u32, u32)> = open
            .keys()
            .filter(|key| !now.contains_key(key))
            .copied()
            .collect();
        for key in ended {
            let (a, b, d, from) = open.remove(&key).expect("listed above");
            bands.push(band(a, b, d, from, t)?);
        }
        for (key, (a, b, d)) in now {
            open.entry(key).or_insert((a, b, d, t));
        }
        if cycles.is_empty() {
            // Two events a rounding error apart in time (1e-8 of the run) leave a band of no width between them that
            // runs out along a line and back; its long sides lie on its neighbours' edges and would cross them in
            // the triangulation by rounding. It is no face: dropped.
            let faces = bands
                .into_iter()
                .filter(|f| !is_sliver(f))
                .map(|f| {
                    f.into_iter()
                        .map(|[x, y, z]| [x, y, (z / t).clamp(0.0, 1.0)])
                        .collect()
                })
                .collect();
            return Some((with_t_junctions(faces), t));
        }
        // The next event of any cycle.
        let mut next = f64::INFINITY;
        for (ci, c) in cycles.iter().enumerate() {
            let m = c.len();
            let cs = corners_at(c, t)?;
            for k in 0..m {
                let (p, w) = cs[k];
                let (q, v) = cs[(k + 1) % m];
                // Edge k, from corner k to corner k + 1, shrinking to nothing.
                let d = c[k].along();
                let (len, rate) = (dot(d, sub(q, p)), dot(d, sub(w, v)));
                if rate > 1e-12 {
                    next = next.min(t + len.max(0.0) / rate);
                }
                // Reflex corner k reaching edge j of its own cycle or another's.
                if !reflex(c, k) {
                    continue;
                }
                for (di, d) in cycles.iter().enumerate() {
                    let md = d.len();
                    for j in (0..md).filter(|&j| {
                        di != ci || (j != k && (j + 1) % m != k && j != (k + m - 1) % m)
                    }) {
                        let approach = dot(d[j].normal, w) - 1.0;
                        if approach >= -1e-12 {
                            continue;
                        }
                        // The corner's distance inside edge j's line: a corner behind the line (outside the
                        // edge's half-plane) only draws away from it.
                        let gap = dot(d[j].normal, p) - d[j].offset - t;
                        if gap < -WAVE_EPS {
                            continue;
                        }
                        let te = t + gap.max(0.0) / -approach;
                        if te < next {
                            let hit = [p[0] + (te - t) * w[0], p[1] + (te - t) * w[1]];
                            let (a, _) = Wave::corner(d[(j + md - 1) % md], d[j], te)?;
                            let (b, _) = Wave::corner(d[j], d[(j + 1) % md], te)?;
                            if on_edge(d[j], a, b, hit, te) {
                                next = te;
                            }
                        }
                    }
                }
            }
        }
        if !next.is_finite() {
            return None;
        }
        t = next;
    }
    None
}

/// Bands narrower than this (twice their area over their perimeter) have no width (m).
const SLIVER_M: f64 = 1e-3 * WELD_M;

/// A face of no width in plan: [`SLIVER_M`].
fn is_sliver(f: &[[f64; 3]]) -> bool {
    let m = f.len();
    let (mut area2, mut perimeter) = (0.0, 0.0);
    for k in 0..m {
        let (a, b) = (f[k], f[(k + 1) % m]);
        area2 += a[0] * b[1] - b[0] * a[1];
        perimeter += (b[0] - a[0]).hypot(b[1] - a[1]);
    }
    area2.abs() < SLIVER_M * perimeter
}

/// A band being swept: the edge's previous line, its own, its next, and when it started.
type OpenBand = (Wave, Wave, Wave, f64);

/// The band swept by line `b` between its neighbours `a` and `d` from time `from` to `to`: its corners at both
/// times, as (x, y, time).
fn band(a: Wave, b: Wave, d: Wave, from: f64, to: f64) -> Option<Face> {
    let (p, _) = Wave::corner(a, b, from)?;
    let (q, _) = Wave::corner(b, d, from)?;
    let (qq, _) = Wave::corner(b, d, to)?;
    let (pp, _) = Wave::corner(a, b, to)?;
    Some(vec![
        [p[0], p[1], from],
        [q[0], q[1], from],
        [qq[0], qq[1], to],
        [pp[0], pp[1], to],
    ])
}

/// Faces with every other face's corner that lies inside one of their edges added to that edge: where the outline
/// split, the split point lies on the edge of a band below it, and the triangulation needs it as a corner of both
/// (a constraint passing through a point it does not end at is refused).
fn with_t_junctions(faces: Vec<Face>) -> Vec<Face> {
    let points: Vec<[f64; 3]> = faces.iter().flatten().copied().collect();
    faces
        .iter()
        .map(|f| {
            let mut out = Vec::with_capacity(f.len());
            for k in 0..f.len() {
                let (a, b) = (f[k], f[(k + 1) % f.len()]);
                out.push(a);
                let d = [b[0] - a[0], b[1] - a[1]];
                let len2 = dot(d, d);
                if len2 < WELD_M * WELD_M {
                    continue;
                }
                let mut inside: Vec<(f64, [f64; 3])> = points
                    .iter()
                    .filter_map(|p| {
                        let q = [p[0] - a[0], p[1] - a[1]];
                        let s = dot(q, d) / len2;
                        let off = cross(d, q).abs() / len2.sqrt();
                        let len = len2.sqrt();
                        (off < 0.1 * WELD_M && s * len > WELD_M && (1.0 - s) * len > WELD_M)
                            .then(|| (s, [p[0], p[1], a[2] + s * (b[2] - a[2])]))
                    })
                    .collect();
                inside.sort_by(|x, y| x.0.total_cmp(&y.0));
                inside.dedup_by(|x, y| (x.0 - y.0).abs() * len2.sqrt() < WELD_M);
                out.extend(inside.into_iter().map(|(_, p)| p));
            }
            out
        })
        .collect()
}

/// The cycles at time t after its events: edges of no length dropped (their neighbours meet), a reflex corner on
/// another edge of its cycle splitting the cycle in two, or on an edge of another cycle (a courtyard's growing
/// wavefront meeting the outline's) joining the two, cycles of no area gone. `None` for parallel neighbours that do
/// not meet (a degenerate outline).
fn settle(cycles: Vec<Vec<Wave>>, t: f64) -> Option<Vec<Vec<Wave>>> {
    let mut out = settle_each(cycles, t)?;
    // Corner k of cycle a on edge j of cycle b: one cycle, a's lines from k round to k − 1, then b's from j round
    // to j again (its two pieces). Every join takes one courtyard's cycle away, so there are at most as many joins
    // as cycles; more would be a join undone by a split (rounding), for the caller to give up on.
    let mut joins = out.len();
    while let Some((a, k, b, j)) = meeting(&out, t)? {
        joins = joins.checked_sub(1)?;
        let (ca, cb) = (&out[a], &out[b]);
        let mut joined: Vec<Wave> = (0..ca.len()).map(|i| ca[(k + i) % ca.len()]).collect();
        joined.extend((0..=cb.len()).map(|i| cb[(j + i) % cb.len()]));
        out.remove(a.max(b));
        out.remove(a.min(b));
        out.extend(settle_each(vec![joined], t)?);
    }
    Some(out)
}

/// The corners of a cycle at time t, and their velocities: corner k joins line k − 1 and line k. `None` for
/// parallel neighbours.
fn corners_at(c: &[Wave], t: f64) -> Option<Vec<(P2, P2)>> {
    let m = c.len();
    (0..m)
        .map(|k| Wave::corner(c[(k + m - 1) % m], c[k], t))
        .collect()
}

/// Corner k of a cycle turns right: it cuts into the building.
fn reflex(c: &[Wave], k: usize) -> bool {
    let m = c.len();
    cross(c[(k + m - 1) % m].along(), c[k].along()) < 0.0
}

/// Point p lies at time t on the edge of `line` from corner a to corner b.
fn on_edge(line: Wave, a: P2, b: P2, p: P2, t: f64) -> bool {
    let d = line.along();
    let off = dot(line.normal, p) - line.offset - t;
    let s = dot(d, sub(p, a));
    off.abs() <= 1e3 * WAVE_EPS && s >= -WAVE_EPS && s <= dot(d, sub(b, a)) + WAVE_EPS
}

/// A reflex corner of one cycle lying on an edge of another, at least one of them a courtyard's (clockwise: it
/// grows): (cycle, corner, other cycle, edge). A courtyard's wavefront meets the outline's, or another courtyard's
/// (two courtyards closer to each other than to the street: the two become one). Two pieces of a split outline
/// shrink each into its own part and never join; at the point they split from each other, rounding may leave one's
/// corner on the other's edge.
fn meeting(cycles: &[Vec<Wave>], t: f64) -> Option<Option<(usize, usize, usize, usize)>> {
    let corners: Vec<Vec<(P2, P2)>> = cycles
        .iter()
        .map(|c| corners_at(c, t))
        .collect::<Option<_>>()?;
    let courtyard: Vec<bool> = corners
        .iter()
        .map(|cs| {
            let (m, o) = (cs.len(), cs[0].0);
            (0..m)
                .map(|k| cross(sub(cs[k].0, o), sub(cs[(k + 1) % m].0, o)))
                .sum::<f64>()
                < 0.0
        })
        .collect();
    for (a, c) in cycles.iter().enumerate() {
        for k in (0..c.len()).filter(|&k| reflex(c, k)) {
            let p = corners[a][k].0;
            for (b, d) in cycles
                .iter()
                .enumerate()
                .filter(|&(b, _)| b != a && (courtyard[a] || courtyard[b]))
            {
                let md = d.len();
                for j in 0..md {
                    if on_edge(d[j], corners[b][j].0, corners[b][(j + 1) % md].0, p, t) {
                        return Some(Some((a, k, b, j)));
                    }
                }
            }
        }
    }
    Some(None)
}

/// [`settle`] within each cycle: its edges of no length, its splits, its area.
fn settle_each(mut cycles: Vec<Vec<Wave>>, t: f64) -> Option<Vec<Vec<Wave>>> {
    let mut out = Vec::new();
    'cycles: while let Some(mut c) = cycles.pop() {
        loop {
            let m = c.len();
            if m < 3 {
                continue 'cycles;
            }
            // Neighbours on one line: a corner that is no corner (the same direction: one edge), or two edges that
            // met head on (opposite directions: where a wing of the outline has just shrunk away). Those run out
            // along the line and back: what is left of them is the line from the first's other corner to the
            // second's, the first's piece if it runs the first's way, the second's if it runs back (where the wing
            // met the rest at a step), nothing if the two corners are one (a straight wall).
            let parallel =
                (0..m).find(|&k| cross(c[(k + m - 1) % m].normal, c[k].normal).abs() < 1e-9);
            if let Some(k) = parallel {
                let prev = (k + m - 1) % m;
                if dot(c[prev].normal, c[k].normal) > 0.0 {
                    c.remove(k);
                } else {
                    let before = c[(prev + m - 1) % m];
                    let after = c[(k + 1) % m];
                    let left = match (
                        Wave::corner(before, c[prev], t),
                        Wave::corner(c[k], after, t),
                    ) {
                        (Some((p, _)), Some((q, _))) => dot(c[prev].along(), sub(q, p)),
                        _ => 0.0,
                    };
                    let (hi, lo) = (prev.max(k), prev.min(k));
                    if left > WAVE_EPS {
                        c.remove(k);
                    } else if left < -WAVE_EPS {
                        c.remove(prev);
                    } else {
                        c.remove(hi);
                        c.remove(lo);
                    }
                }
                continue;
            }
            let cs: Vec<P2> = corners_at(&c, t)?.into_iter().map(|x| x.0).collect();
            // An edge of no length (or turned over: it passed its event).
            let gone = (0..m).find(|&k| dot(c[k].along(), sub(cs[(k + 1) % m], cs[k])) <= WAVE_EPS);
            if let Some(k) = gone {
                c.remove(k);
                continue;
            }
            // A courtyard's cycle runs clockwise (negative area) and grows; an outline's shrinks to nothing.
            let area: f64 = (0..m).map(|k| cross(cs[k], cs[(k + 1) % m])).sum::<f64>() / 2.0;
            if area.abs() <= WAVE_EPS * WAVE_EPS {
                continue 'cycles;
            }
            // A reflex corner k lying on edge j: two cycles, lines k ..= j and j ..= k − 1.
            let mut split = None;
            'find: for k in (0..m).filter(|&k| reflex(&c, k)) {
                for j in (0..m).filter(|&j| j != k && (j + 1) % m != k && j != (k + m - 1) % m) {
                    if on_edge(c[j], cs[j], cs[(j + 1) % m], cs[k], t) {
                        split = Some((k, j));
                        break 'find;
                    }
                }
            }
            let Some((k, j)) = split else {
                out.push(c);
                continue 'cycles;
            };
            let walk = |from: usize, to: usize| {
                let mut v = vec![c[from]];
                let mut i = from;
                while i != to {
                    i = (i + 1) % m;
                    v.push(c[i]);
                }
                v
            };
            cycles.push(walk(k, j));
            c = walk(j, (k + m - 1) % m);
        }
    }
    out.reverse();
    Some(out)
}

/// A triangle from every edge to the apex above the outline's centroid; the run is the apex's distance from the
/// nearest edge line.
fn pyramidal(ring: &[P2]) -> (Vec<Face>, f64) {
    let n = ring.len();
    let (c, run) = apex(ring);
    let faces = (0..n)
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            vec![[a[0], a[1], 0.0], [b[0], b[1], 0.0], [c[0], c[1], 1.0]]
        })
        .collect();
    (faces, run)
}

/// The outline's centroid, under a pyramid's or dome's apex, and its distance from the nearest edge line (the run
/// of the roof's slope; not positive when the centroid is not inside).
fn apex(ring: &[P2]) -> (P2, f64) {
    let n = ring.len();
    let c = centroid(ring);
    let run = (0..n)
        .map(|i| {
            let d = sub(ring[(i + 1) % n], ring[i]);
            cross(d, sub(c, ring[i])) / d[0].hypot(d[1])
        })
        .fold(f64::INFINITY, f64::min);
    (c, run)
}

/// Bands of a dome.
pub const DOME_BANDS: usize = 6;

/// Bands between copies of the outline shrunk towards its centroid by cos θ and raised by sin θ of the rise, θ in
/// [`DOME_BANDS`] equal steps to 90° (the last band's triangles meet at the apex); the run is the apex's distance
/// from the nearest edge line. A band's face between two copies of an edge is a trapezoid, so planar.
fn dome(ring: &[P2]) -> (Vec<Face>, f64) {
    let n = ring.len();
    let (c, run) = apex(ring);
    let copy = |j: usize, p: P2| {
        let t = std::f64::consts::FRAC_PI_2 * j as f64 / DOME_BANDS as f64;
        let (up, inward) = if j == DOME_BANDS {
            (1.0, 0.0)
        } else {
            t.sin_cos()
        };
        [
            c[0] + inward * (p[0] - c[0]),
            c[1] + inward * (p[1] - c[1]),
            up,
        ]
    };
    let mut faces = Vec::with_capacity(n * DOME_BANDS);
    for j in 0..DOME_BANDS {
        for i in 0..n {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            faces.push(if j + 1 == DOME_BANDS {
                vec![copy(j, a), copy(j, b), copy(j + 1, a)]
            } else {
                vec![copy(j, a), copy(j, b), copy(j + 1, b), copy(j + 1, a)]
            });
        }
    }
    (faces, run)
}

fn centroid(ring: &[P2]) -> P2 {
    let n = ring.len();
    let o = ring[0];
    let (mut a2, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let p = sub(ring[i], o);
        let q = sub(ring[(i + 1) % n], o);
        let w = cross(p, q);
        a2 += w;
        cx += (p[0] + q[0]) * w;
        cy += (p[1] + q[1]) * w;
    }
    [o[0] + cx / (3.0 * a2), o[1] + cy / (3.0 * a2)]
}

/// The part of a convex polygon where `f` ≤ 0 (`f` linear; every coordinate of a crossing interpolated).
fn clip<const N: usize>(poly: &[[f64; N]], f: impl Fn([f64; N]) -> f64) -> Vec<[f64; N]> {
    let n = poly.len();
    let mut out = Vec::with_capacity(n + 1);
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        let (fa, fb) = (f(a), f(b));
        if fa <= 0.0 {
            out.push(a);
        }
        if (fa < 0.0 && fb > 0.0) || (fa > 0.0 && fb < 0.0) {
            let t = fa / (fa - fb);
            out.push(std::array::from_fn(|k| a[k] + t * (b[k] - a[k])));
        }
    }
    out
}

/// Corners of roof faces closer than this are one point: 1 mm, below what a glb's quantized positions keep apart,
/// and above the scatter of a straight skeleton's simultaneous events (0.2 mm measured over random stars; at 0.1 mm
/// such corners stayed apart and faces crossed).
const WELD_M: f64 = 1e-3;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::topology::{mesh_report, signed_volume_m3};
    use geo_types::{LineString, Polygon};
    use std::sync::atomic::{AtomicUsize, Ordering};

    fn footprint(pts: &[(f64, f64)]) -> MultiPolygon<f64> {
        MultiPolygon(vec![Polygon::new(LineString::from(pts.to_vec()), vec![])])
    }

    fn spec(shape: RoofShape, rise: RoofRise) -> RoofSpec {
        RoofSpec {
            shape,
            rise,
            direction_deg: None,
            across: false,
        }
    }

    /// Closed, consistently wound outwards, no degenerate triangle; the volume it returns.
    fn closed_volume(mesh: &Mesh3d) -> f64 {
        let r = mesh_report(mesh);
        assert!(
            r.watertight && r.orientation_consistent && r.degenerate == 0,
            "{r:?}"
        );
        let v = signed_volume_m3(mesh);
        assert!(v > 0.0, "inside out: {v}");
        v
    }

    fn top_z(mesh: &Mesh3d) -> f64 {
        mesh.positions.iter().map(|p| p[2]).fold(f64::MIN, f64::max)
    }

    /// Roof vertices at the top: where the ridge or apex is.
    fn ridge(mesh: &Mesh3d, z: f64) -> Vec<[f64; 2]> {
        let mut r: Vec<[f64; 2]> = mesh
            .positions
            .iter()
            .filter(|p| (p[2] - z).abs() < 1e-9)
            .map(|p| [p[0], p[1]])
            .collect();
        r.sort_by(|a, b| a.partial_cmp(b).unwrap());
        r
    }

    /// `got` (sorted, as [`ridge`] gives them) are the points `want` to a nanometre.
    fn assert_near_points(got: &[[f64; 2]], want: &[[f64; 2]]) {
        assert_eq!(got.len(), want.len(), "{got:?} against {want:?}");
        for (p, q) in got.iter().zip(want) {
            assert!(
                (p[0] - q[0]).abs() < 1e-9 && (p[1] - q[1]).abs() < 1e-9,
                "{got:?} against {want:?}"
            );
        }
    }

    const HOUSE: [(f64, f64); 4] = [(0.0, 0.0), (12.0, 0.0), (12.0, 8.0), (0.0, 8.0)];

    /// The house standing from 5 m to 15 m with roof `spec`.
    fn house(spec: &RoofSpec) -> (Mesh3d, Vec<SurfaceKind>) {
        roofed_building(&footprint(&HOUSE), 5.0, 10.0, spec).unwrap()
    }

    #[test]
    fn a_gabled_house_has_its_ridge_along_its_long_side_and_the_volume_of_its_shape() {
        let (mesh, kinds) = house(&spec(RoofShape::Gabled, RoofRise::Metres(4.0)));
        // Walls 6 m, a triangular prism of roof 4 m high over 8 m.
        let v = closed_volume(&mesh);
        assert!(
            (v - (12.0 * 8.0 * 6.0 + 0.5 * 8.0 * 4.0 * 12.0)).abs() < 1e-6,
            "{v}"
        );
        assert_eq!(top_z(&mesh), 15.0);
        assert_eq!(ridge(&mesh, 15.0), [[0.0, 4.0], [12.0, 4.0]]);
        // Two roof planes (two triangles each), the ground (a hexagon: the gables' feet split the short sides), 4
        // walls of which 2 gable ends (two quads each).
        let count = |k| kinds.iter().filter(|&&x| x == k).count();
        assert_eq!(count(SurfaceKind::Roof), 4);
        assert_eq!(count(SurfaceKind::Ground), 4);
        assert_eq!(count(SurfaceKind::Wall), 2 * 2 + 2 * 4);
        // Across: the ridge along the short side.
        let mut s = spec(RoofShape::Gabled, RoofRise::Metres(4.0));
        s.across = true;
        let (mesh, _) = house(&s);
        assert_eq!(ridge(&mesh, 15.0), [[6.0, 0.0], [6.0, 8.0]]);
        assert!((closed_volume(&mesh) - (576.0 + 0.5 * 12.0 * 4.0 * 8.0)).abs() < 1e-6);
        // roof:direction 90° (the slopes face east and west): the ridge runs north–south.
        s.across = false;
        s.direction_deg = Some(90.0);
        let (mesh, _) = house(&s);
        assert_eq!(ridge(&mesh, 15.0), [[6.0, 0.0], [6.0, 8.0]]);
    }

    #[test]
    fn a_hipped_roof_rises_from_every_edge_and_a_pyramid_to_one_apex() {
        let (mesh, kinds) = roofed_building(
            &footprint(&HOUSE),
            0.0,
            10.0,
            &spec(RoofShape::Hipped, RoofRise::AngleDeg(45.0)),
        )
        .unwrap();
        // 45° over a half-width of 4 m: 4 m; the ridge from (4, 4) to (8, 4).
        assert!((top_z(&mesh) - 10.0).abs() < 1e-9);
        let r = ridge(&mesh, top_z(&mesh));
        assert_eq!(r.len(), 2);
        assert!((r[0][0] - 4.0).abs() < 1e-9 && (r[1][0] - 8.0).abs() < 1e-9);
        assert!(r.iter().all(|p| (p[1] - 4.0).abs() < 1e-9));
        // Walls 6 m; the roof: a prism of 4 m over the middle 4 m, two half pyramids at the ends.
        let roof = 0.5 * 8.0 * 4.0 * 4.0 + 2.0 * (4.0 * 8.0 * 4.0 / 3.0);
        let v = closed_volume(&mesh);
        assert!((v - (12.0 * 8.0 * 6.0 + roof)).abs() < 1e-6, "{v}");
        assert_eq!(kinds.iter().filter(|&&k| k == SurfaceKind::Roof).count(), 6);

        let square = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)];
        for shape in [RoofShape::Hipped, RoofShape::Pyramidal] {
            let (mesh, _) = roofed_building(
                &footprint(&square),
                0.0,
                8.0,
                &spec(shape, RoofRise::Metres(3.0)),
            )
            .unwrap();
            assert_eq!(ridge(&mesh, 8.0), [[5.0, 5.0]], "{shape:?}");
            let v = closed_volume(&mesh);
            assert!(
                (v - (500.0 + 100.0 * 3.0 / 3.0)).abs() < 1e-6,
                "{shape:?}: {v}"
            );
        }
        // A hexagon: six faces to one apex.
        let hex: Vec<(f64, f64)> = (0..6)
            .map(|i| {
                let a = std::f64::consts::PI / 3.0 * i as f64;
                (10.0 * a.cos(), 10.0 * a.sin())
            })
            .collect();
        let (mesh, kinds) = roofed_building(
            &footprint(&hex),
            0.0,
            8.0,
            &spec(RoofShape::Hipped, RoofRise::Default),
        )
        .unwrap();
        closed_volume(&mesh);
        assert_eq!(ridge(&mesh, top_z(&mesh)).len(), 1);
        assert_eq!(kinds.iter().filter(|&&k| k == SurfaceKind::Roof).count(), 6);
        // 30° over the inradius 8.66 m: 5 m, more than half the height, so 4 m.
        assert!((top_z(&mesh) - 8.0).abs() < 1e-9);
    }

    #[test]
    fn a_dome_rises_as_a_quarter_circle_to_its_apex() {
        // A 48-gon of radius 10 m: inradius 9.98 m, the default dome as high as that.
        let round: Vec<(f64, f64)> = (0..48)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / 48.0;
                (10.0 * a.cos(), 10.0 * a.sin())
            })
            .collect();
        let (mesh, kinds) = roofed_building(
            &footprint(&round),
            0.0,
            30.0,
            &spec(RoofShape::Dome, RoofRise::Default),
        )
        .unwrap();
        let r = 10.0 * (std::f64::consts::PI / 48.0).cos();
        assert!((top_z(&mesh) - 30.0).abs() < 1e-9);
        let apex = ridge(&mesh, 30.0);
        assert!(
            apex.len() == 1 && apex[0][0].hypot(apex[0][1]) < 1e-9,
            "{apex:?}"
        );
        // Walls to 30 − r, then about a hemisphere of the outline's area: (2/3)·A·r, the bands a little less.
        let area = 0.5 * 48.0 * 100.0 * (std::f64::consts::TAU / 48.0).sin();
        let v = closed_volume(&mesh) - area * (30.0 - r);
        let hemisphere = 2.0 / 3.0 * area * r;
        assert!(
            v < hemisphere && v > 0.95 * hemisphere,
            "{v} against {hemisphere}"
        );
        // Every band of every edge is roof: 48 × (5 trapezoids of 2 triangles + 1 apex triangle).
        assert_eq!(
            kinds.iter().filter(|&&k| k == SurfaceKind::Roof).count(),
            48 * 11
        );
        // A corner's copies rise on a quarter circle: at 30° of it, half the rise at cos 30° of the way in.
        let (x, z) = (10.0 * (30f64).to_radians().cos(), 30.0 - r + r * 0.5);
        assert!(mesh
            .positions
            .iter()
            .any(|p| (p[0] - x).abs() < 1e-9 && p[1].abs() < 1e-9 && (p[2] - z).abs() < 1e-9));
    }

    #[test]
    fn a_gabled_roof_over_an_l_has_one_ridge_through_the_middle() {
        let l = [
            (0.0, 0.0),
            (10.0, 0.0),
            (10.0, 4.0),
            (4.0, 4.0),
            (4.0, 10.0),
            (0.0, 10.0),
        ];
        let (mesh, _) = roofed_building(
            &footprint(&l),
            0.0,
            10.0,
            &spec(RoofShape::Gabled, RoofRise::Metres(2.0)),
        )
        .unwrap();
        // The ridge along the longest edge (x) at y = 5, inside the L from x = 0 to 4; the wing east of it slopes
        // from 80 % of the rise at y = 4 to the eaves at y = 0.
        assert_eq!(ridge(&mesh, 10.0), [[0.0, 5.0], [4.0, 5.0]]);
        let v = closed_volume(&mesh);
        let roof = 4.0 * 2.0 * 5.0 + 6.0 * 2.0 * 1.6;
        assert!((v - (64.0 * 8.0 + roof)).abs() < 1e-6, "{v}");
        assert!(mesh
            .positions
            .iter()
            .any(|p| p[0] == 10.0 && p[1] == 4.0 && (p[2] - 9.6).abs() < 1e-9));
    }

    #[test]
    fn a_courtyard_building_gets_a_gabled_or_skillion_roof_around_its_courtyard() {
        let block = MultiPolygon(vec![Polygon::new(
            LineString::from(vec![(0.0, 0.0), (20.0, 0.0), (20.0, 20.0), (0.0, 20.0)]),
            vec![LineString::from(vec![
                (6.0, 6.0),
                (6.0, 14.0),
                (14.0, 14.0),
                (14.0, 6.0),
            ])],
        )]);
        let (mesh, _) = roofed_building(
            &block,
            0.0,
            10.0,
            &spec(RoofShape::Gabled, RoofRise::Metres(2.0)),
        )
        .unwrap();
        // The ridge at y = 10, broken by the courtyard: four ends at the top.
        assert_near_points(
            &ridge(&mesh, 10.0),
            &[[0.0, 10.0], [6.0, 10.0], [14.0, 10.0], [20.0, 10.0]],
        );
        // Walls to 8 m over 336 m², the roof's 400 m³ over the whole square less 102.4 over the courtyard.
        let v = closed_volume(&mesh);
        assert!((v - (336.0 * 8.0 + 400.0 - 102.4)).abs() < 1e-6, "{v}");
        let mut s = spec(RoofShape::Skillion, RoofRise::Metres(2.0));
        s.direction_deg = Some(0.0); // descending to the north
        let (mesh, _) = roofed_building(&block, 0.0, 10.0, &s).unwrap();
        assert!((closed_volume(&mesh) - 336.0 * 9.0).abs() < 1e-6);
    }

    #[test]
    fn a_skillion_roof_descends_towards_its_direction_over_any_outline() {
        // An L: concave, still one plane.
        let l = [
            (0.0, 0.0),
            (10.0, 0.0),
            (10.0, 4.0),
            (4.0, 4.0),
            (4.0, 10.0),
            (0.0, 10.0),
        ];
        let mut s = spec(RoofShape::Skillion, RoofRise::Metres(2.0));
        s.direction_deg = Some(180.0); // descending to the south
        let (mesh, _) = roofed_building(&footprint(&l), 1.0, 9.0, &s).unwrap();
        let v = closed_volume(&mesh);
        // Walls to 8 m at y = 0, to 10 m at y = 10: the mean height over each rectangle.
        let expected = 40.0 * (7.0 + 0.4 * 2.0 / 2.0) + 24.0 * (7.0 + 2.0 * 7.0 / 10.0);
        assert!((v - expected).abs() < 1e-6, "{v} {expected}");
        assert_eq!(ridge(&mesh, 10.0), [[0.0, 10.0], [4.0, 10.0]]);
    }

    #[test]
    fn outlines_without_a_pitched_roof_here_are_refused_with_the_reason() {
        let l = [
            (0.0, 0.0),
            (10.0, 0.0),
            (10.0, 4.0),
            (4.0, 4.0),
            (4.0, 10.0),
            (0.0, 10.0),
        ];
        let gabled = spec(RoofShape::Gabled, RoofRise::Default);
        for shape in [RoofShape::Pyramidal, RoofShape::Dome] {
            let e = roofed_building(&footprint(&l), 0.0, 9.0, &spec(shape, RoofRise::Default))
                .unwrap_err();
            assert!(e.contains("not convex"), "{e}");
        }
        let holed = MultiPolygon(vec![Polygon::new(
            LineString::from(HOUSE.to_vec()),
            vec![LineString::from(vec![
                (1.0, 1.0),
                (1.0, 2.0),
                (2.0, 2.0),
                (2.0, 1.0),
            ])],
        )]);
        for shape in [RoofShape::Pyramidal, RoofShape::Dome] {
            let e = roofed_building(&holed, 0.0, 9.0, &spec(shape, RoofRise::Default)).unwrap_err();
            assert!(e.contains("hole"), "{e}");
        }
        let two = MultiPolygon(vec![footprint(&HOUSE).0[0].clone(); 2]);
        assert!(roofed_building(&two, 0.0, 9.0, &gabled).is_err());
        let flat = spec(RoofShape::Gabled, RoofRise::Metres(0.01));
        assert!(roofed_building(&footprint(&HOUSE), 0.0, 9.0, &flat)
            .unwrap_err()
            .contains("flat"));
        for bad in [f64::NAN, f64::INFINITY, -1.0, 0.0] {
            assert!(roofed_building(&footprint(&HOUSE), 0.0, bad, &gabled).is_err());
            let metres = spec(RoofShape::Gabled, RoofRise::Metres(bad));
            assert!(roofed_building(&footprint(&HOUSE), 0.0, 9.0, &metres).is_err());
            assert!(roofed_building(
                &footprint(&HOUSE),
                0.0,
                9.0,
                &spec(RoofShape::Hipped, RoofRise::AngleDeg(bad))
            )
            .is_err());
        }
        // A corner on a straight edge is no corner: the hipped roof of a rectangle with one has six faces.
        let extra = [(0.0, 0.0), (6.0, 0.0), (12.0, 0.0), (12.0, 8.0), (0.0, 8.0)];
        let (mesh, kinds) = roofed_building(
            &footprint(&extra),
            0.0,
            9.0,
            &spec(RoofShape::Hipped, RoofRise::Metres(3.0)),
        )
        .unwrap();
        closed_volume(&mesh);
        assert_eq!(kinds.iter().filter(|&&k| k == SurfaceKind::Roof).count(), 6);
    }

    /// The slopes (rise over run) of a mesh's roof triangles and their smallest height in plan (m): a hipped roof's
    /// slopes are all one, but for the corners' welding within [`WELD_M`], which tilts a triangle by up to about
    /// 2 · WELD_M over its smallest height.
    fn roof_slopes(mesh: &Mesh3d, kinds: &[SurfaceKind]) -> Vec<(f64, f64)> {
        mesh.triangles
            .iter()
            .zip(kinds)
            .filter(|(_, k)| **k == SurfaceKind::Roof)
            .filter_map(|(t, _)| {
                let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
                let (u, v) = (
                    [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                    [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
                );
                let n = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                let longest = [(a, b), (b, c), (c, a)]
                    .iter()
                    .map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1]))
                    .fold(0.0, f64::max);
                let altitude = n[2].abs() / longest;
                (altitude > 1e-3).then(|| (n[0].hypot(n[1]) / n[2].abs(), altitude))
            })
            .collect()
    }

    /// The volume under a roof plan of faces (shares of the rise times `run`): the roof's own volume above its eaves.
    fn roof_volume(faces: &[Face], run: f64, rings: &[Vec<P2>]) -> f64 {
        let (points, triangles) = plan(faces, rings).unwrap();
        triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| points[i as usize]);
                let area = cross(
                    sub([b[0], b[1]], [a[0], a[1]]),
                    sub([c[0], c[1]], [a[0], a[1]]),
                ) / 2.0;
                area * run * (a[2] + b[2] + c[2]) / 3.0
            })
            .sum()
    }

    #[test]
    fn a_hipped_l_is_its_straight_skeleton() {
        // Arms 10 m wide: every edge rises at 45° (rise 5 m over the run of 5 m) and the wavefront at time t is the
        // L shrunk by t, of area 2(20 − 2t)(10 − 2t) − (10 − 2t)², so the roof holds ∫₀⁵ that dt = 2000/3 m³.
        let l = [
            (0.0, 0.0),
            (20.0, 0.0),
            (20.0, 10.0),
            (10.0, 10.0),
            (10.0, 20.0),
            (0.0, 20.0),
        ];
        let (faces, run) = skeleton(&[l.map(|(x, y)| [x, y]).to_vec()]).unwrap();
        assert!((run - 5.0).abs() < 1e-9, "{run}");
        assert!(
            (roof_volume(&faces, run, &[l.map(|(x, y)| [x, y]).to_vec()]) - 2000.0 / 3.0).abs()
                < 1e-6
        );
        let (mesh, kinds) = roofed_building(
            &footprint(&l),
            0.0,
            10.0,
            &spec(RoofShape::Hipped, RoofRise::Metres(5.0)),
        )
        .unwrap();
        let v = closed_volume(&mesh);
        assert!((v - (300.0 * 5.0 + 2000.0 / 3.0)).abs() < 1e-6, "{v}");
        assert!((top_z(&mesh) - 10.0).abs() < 1e-9);
        // The ridge: from the middle of each arm's end to the corner square's middle, level at 10 m.
        assert_eq!(ridge(&mesh, 10.0), [[5.0, 5.0], [5.0, 15.0], [15.0, 5.0]]);
        assert!(kinds.contains(&SurfaceKind::Roof));
    }

    /// The volume of a roof of `profile` rising `rise` over `run`, where the part of the outline at least t in from the
    /// eaves (in the shape's own sense of distance) has area `area(t)`, quadratic in t: the roof holds, layer by
    /// layer, ∫ area(t) · slope(t) dt, the slope constant between the profile's corners (Simpson's rule, exact).
    fn layered_volume(area: impl Fn(f64) -> f64, run: f64, rise: f64, profile: &[[f64; 2]]) -> f64 {
        let corners: Vec<[f64; 2]> = std::iter::once([0.0, 0.0])
            .chain(profile.iter().copied())
            .chain(std::iter::once([1.0, 1.0]))
            .collect();
        corners
            .windows(2)
            .map(|w| {
                let (t0, t1) = (w[0][0] * run, w[1][0] * run);
                let slope = (w[1][1] - w[0][1]) * rise / (t1 - t0);
                slope * (t1 - t0) / 6.0 * (area(t0) + 4.0 * area(0.5 * (t0 + t1)) + area(t1))
            })
            .sum()
    }

    #[test]
    fn a_gambrel_and_a_round_roof_follow_their_profiles_across_the_ridge() {
        // The house, walls up to 11 m, a roof of 4 m over the half-width of 4 m; the part at least t in from the eaves
        // is 12 × (8 − 2t).
        let walls = 12.0 * 8.0 * 6.0;
        let strip = |t: f64| 12.0 * (8.0 - 2.0 * t);
        let (mesh, kinds) = house(&spec(RoofShape::Gambrel, RoofRise::Metres(4.0)));
        // A cross-section of 8 × 4 × 2/3 m²: more than the gabled roof's half.
        let v = closed_volume(&mesh);
        let roof = layered_volume(strip, 4.0, 4.0, &[BREAK]);
        assert!((roof - 12.0 * 8.0 * 4.0 * 2.0 / 3.0).abs() < 1e-9);
        assert!((v - (walls + roof)).abs() < 1e-6, "{v}");
        assert_eq!(top_z(&mesh), 15.0);
        assert_eq!(ridge(&mesh, 15.0), [[0.0, 4.0], [12.0, 4.0]]);
        // The slope breaks a third of the way in (4/3 m from the eaves) and two thirds of the way up.
        assert_near_points(
            &ridge(&mesh, 11.0 + 8.0 / 3.0),
            &[
                [0.0, 4.0 / 3.0],
                [0.0, 20.0 / 3.0],
                [12.0, 4.0 / 3.0],
                [12.0, 20.0 / 3.0],
            ],
        );
        // Two slopes each side, 2 triangles each: steep (rise 8/3 over 4/3) and shallow (4/3 over 8/3).
        let mut slopes: Vec<f64> = roof_slopes(&mesh, &kinds).iter().map(|s| s.0).collect();
        slopes.sort_by(f64::total_cmp);
        assert_eq!(slopes.len(), 8);
        assert!(
            slopes[..4].iter().all(|s| (s - 0.5).abs() < 1e-9),
            "{slopes:?}"
        );
        assert!(
            slopes[4..].iter().all(|s| (s - 2.0).abs() < 1e-9),
            "{slopes:?}"
        );

        // Round, as high as its run by default: every corner of the roof on the circle of 4 m about the ridge's foot,
        // 6 bands each side, and the volume of that polygon.
        let (mesh, kinds) = house(&spec(RoofShape::Round, RoofRise::Default));
        let v = closed_volume(&mesh);
        assert_eq!(top_z(&mesh), 15.0);
        let on_roof: Vec<[f64; 3]> = mesh
            .positions
            .iter()
            .copied()
            .filter(|p| p[2] > 11.0 + 1e-9)
            .collect();
        assert_eq!(on_roof.len(), 2 * (2 * (DOME_BANDS - 1) + 1), "{on_roof:?}");
        for p in &on_roof {
            assert!(
                ((p[1] - 4.0).hypot(p[2] - 11.0) - 4.0).abs() < 1e-9,
                "{p:?}"
            );
        }
        // 12 triangles of 15° from the ridge's foot, each 8 sin 15° m².
        let section = 12.0 * 0.5 * 16.0 * (std::f64::consts::PI / 12.0).sin();
        let roof = layered_volume(strip, 4.0, 4.0, &profile(RoofShape::Round));
        assert!((roof - 12.0 * section).abs() < 1e-9, "{roof}");
        assert!((v - (walls + roof)).abs() < 1e-6, "{v}");
        assert_eq!(
            kinds.iter().filter(|&&k| k == SurfaceKind::Roof).count(),
            2 * DOME_BANDS * 2
        );
    }

    /// Two events of a Boston footprint 1.3e-8 of the run apart: between them a band of no width runs 3 m out along
    /// a line and back, its sides on its neighbours' edges; in the triangulation they crossed by rounding and the
    /// roof was refused. The band is dropped as a sliver.
    #[test]
    fn near_simultaneous_events_leave_no_sliver_face() {
        let outline = [
            (2690.042548840222, -2157.322214227861),
            (2689.4600328236284, -2142.7709933076885),
            (2687.564478047817, -2142.993879783663),
            (2687.399086378329, -2141.5499067057317),
            (2683.113335022041, -2141.6626281929275),
            (2683.3619950618963, -2145.3281640909613),
            (2682.9498992760255, -2145.3283218303477),
            (2683.2841664018033, -2157.3248045376795),
            (2682.9544892090576, -2157.3249307278056),
            (2682.9548292038376, -2158.2135684152763),
            (2683.7790222890767, -2158.2132529114465),
            (2684.3562976214766, -2159.1016696856163),
            (2686.334361275199, -2159.1009119182027),
            (2687.075794629531, -2158.211989926297),
            (2690.2077283496783, -2158.2107886550384),
            (2690.2073874360667, -2157.3221509675195),
            (2690.042548840222, -2157.322214227861),
        ];
        let fp = footprint(&outline);
        let (_, rings) = roof_rings(&fp.0[0]);
        let (faces, _) = skeleton(&rings).unwrap();
        assert!(faces.iter().all(|f| !is_sliver(f)));
        assert_skeleton_roofs(&outline);
    }

    /// The hipped and the mansard roof of a 12 m building over `outline` (a real footprint): built, closed, under
    /// the top and over the eaves' volume, every face at its slope (a mansard's two).
    fn assert_skeleton_roofs(outline: &[(f64, f64)]) {
        let fp = footprint(outline);
        for shape in [RoofShape::Hipped, RoofShape::Mansard] {
            let (mesh, kinds) =
                roofed_building(&fp, 0.0, 12.0, &spec(shape, RoofRise::Metres(3.0))).unwrap();
            let v = closed_volume(&mesh);
            let corners: Vec<[f64; 2]> = outline.iter().map(|&(x, y)| [x, y]).collect();
            let area = crate::ring::signed_area2(&corners).abs() / 2.0;
            assert!(
                v > area * 9.0 && v < area * 12.0,
                "{shape:?}: {v} over {area} m²"
            );
            assert!((top_z(&mesh) - 12.0).abs() < 1e-9);
            let ratios: &[f64] = if shape == RoofShape::Mansard {
                &[1.0, 4.0, 0.25]
            } else {
                &[1.0]
            };
            assert_eq!(off_slope(&mesh, &kinds, ratios), None, "{shape:?}");
        }
    }

    /// Two courtyards nearer each other than the street: their wavefronts meet first (the diamond's corner on the
    /// square's side, after 2 / (1 + √2) of the run) and go on as one courtyard. The meeting was only looked for
    /// between a courtyard and the outline, so the event came back forever and the roof was refused (two Boston
    /// blocks).
    #[test]
    fn two_courtyards_meeting_become_one() {
        let outer = [
            (0.0, 0.0),
            (40.0, 0.0),
            (40.0, 20.0),
            (0.0, 20.0),
            (0.0, 0.0),
        ];
        let square = [[12.0, 7.0], [12.0, 13.0], [18.0, 13.0], [18.0, 7.0]];
        let diamond = [[20.0, 10.0], [23.0, 13.0], [26.0, 10.0], [23.0, 7.0]];
        let mut fp = footprint(&outer);
        for court in [square, diamond] {
            let mut ring: Vec<(f64, f64)> = court.iter().map(|p| (p[0], p[1])).collect();
            ring.push(ring[0]);
            fp.0[0].interiors_push(ring);
        }
        let rings = [
            outer[..4].iter().map(|&(x, y)| [x, y]).collect(),
            square.to_vec(),
            diamond.to_vec(),
        ];
        let (_, run) = skeleton(&rings).unwrap();
        let (mesh, kinds) = roofed_building(
            &fp,
            0.0,
            10.0,
            &spec(RoofShape::Hipped, RoofRise::Metres(run)),
        )
        .unwrap();
        let v = closed_volume(&mesh);
        let area = 800.0 - 36.0 - 18.0;
        assert!(v > area * (10.0 - run) && v < area * 10.0, "{v}");
        assert_eq!(off_slope(&mesh, &kinds, &[1.0]), None);
        // Where they met, the roof is as high as the time they took.
        let t = 2.0 / (1.0 + 2f64.sqrt());
        let z = 10.0 - run + t;
        assert!(
            mesh.positions
                .iter()
                .any(|p| (p[0] - (18.0 + t)).abs() < 1e-9
                    && (p[1] - 10.0).abs() < 1e-9
                    && (p[2] - z).abs() < 1e-9),
            "no corner at ({}, 10, {z})",
            18.0 + t
        );
    }

    /// A wing whose two long sides meet the main block at walls 17 cm apart (a Boston footprint): when the wing has
    /// shrunk away its sides meet head on, and what is left of them is the 17 cm step between the walls, which goes on
    /// into the block. Dropping both sides made the two walls, nearly parallel, neighbours meeting 16 km away; faces
    /// crossed and the roof was refused.
    #[test]
    fn a_wing_meeting_a_stepped_wall_gets_its_hipped_roof() {
        let outline = [
            (-1655.758531220069, -2838.1168225097344),
            (-1644.5483658208937, -2837.8973020122903),
            (-1644.7109803398805, -2828.344418325911),
            (-1655.5914217099808, -2828.5640164394727),
            (-1655.5916314685232, -2829.452653189082),
            (-1661.1142539951923, -2829.451346788819),
            (-1660.9511620036506, -2836.8937185858304),
            (-1655.758242773694, -2836.8949469939434),
        ];
        assert_skeleton_roofs(&outline);
    }

    #[test]
    fn a_half_hipped_roof_has_hips_over_half_gables() {
        // The house: walls to 11 m, a roof of 4 m over the half-width of 4 m; the gable walls rise to 13 m, and hips at
        // the roof's slope (4 m over 4 m) rise from there to the ridge, 2 m in from each end.
        let (mesh, kinds) = house(&spec(RoofShape::HalfHipped, RoofRise::Metres(4.0)));
        let v = closed_volume(&mesh);
        // The gabled roof's 192 m³ less what each hip cuts off: ∫₀² (2 − x)² / 4 dx of the rise, 8/3 m³.
        let roof = 0.5 * 8.0 * 4.0 * 12.0 - 2.0 * 4.0 * (2.0 / 3.0);
        assert!((v - (12.0 * 8.0 * 6.0 + roof)).abs() < 1e-6, "{v}");
        assert_eq!(top_z(&mesh), 15.0);
        assert_near_points(&ridge(&mesh, 15.0), &[[2.0, 4.0], [10.0, 4.0]]);
        assert_near_points(
            &ridge(&mesh, 13.0),
            &[[0.0, 2.0], [0.0, 6.0], [12.0, 2.0], [12.0, 6.0]],
        );
        // Four roof planes, every one at the roof's slope of 1: the sides hexagons (4 triangles each), the hips
        // triangles.
        let slopes = roof_slopes(&mesh, &kinds);
        assert!(
            slopes.iter().all(|s| (s.0 - 1.0).abs() < 1e-9),
            "{slopes:?}"
        );
        assert_eq!(slopes.len(), 2 * 4 + 2);
    }

    #[test]
    fn a_mansard_roof_breaks_its_slope_on_every_side() {
        // The house, walls up to 6 m, a roof of 3 m over the half-width of 4 m: every face steep for the first 4/3 m
        // in, shallow above; the part at least t in from the outline is (12 − 2t)(8 − 2t).
        let (mesh, kinds) = roofed_building(
            &footprint(&HOUSE),
            0.0,
            9.0,
            &spec(RoofShape::Mansard, RoofRise::Metres(3.0)),
        )
        .unwrap();
        let v = closed_volume(&mesh);
        let roof = layered_volume(|t| (12.0 - 2.0 * t) * (8.0 - 2.0 * t), 4.0, 3.0, &[BREAK]);
        assert!(
            (v - (12.0 * 8.0 * 6.0 + roof)).abs() < 1e-6,
            "{v} against {}",
            576.0 + roof
        );
        assert!((top_z(&mesh) - 9.0).abs() < 1e-9);
        // The break: the outline shrunk by 4/3 m, 2 m up.
        let (a, b) = (4.0 / 3.0, 12.0 - 4.0 / 3.0);
        let (c, d) = (4.0 / 3.0, 8.0 - 4.0 / 3.0);
        assert_near_points(&ridge(&mesh, 8.0), &[[a, c], [a, d], [b, c], [b, d]]);
        for s in roof_slopes(&mesh, &kinds) {
            assert!(
                (s.0 - 1.5).abs() < 1e-9 || (s.0 - 0.375).abs() < 1e-9,
                "{s:?}"
            );
        }

        // Over an L (the straight skeleton): the break is the L shrunk by 5/3 m (its corners, and none off its edges), and
        // the volume the shrinking L gives, 2(20 − 2t)(10 − 2t) − (10 − 2t)² in from t.
        let l = [
            (0.0, 0.0),
            (20.0, 0.0),
            (20.0, 10.0),
            (10.0, 10.0),
            (10.0, 20.0),
            (0.0, 20.0),
        ];
        let (mesh, kinds) = roofed_building(
            &footprint(&l),
            0.0,
            10.0,
            &spec(RoofShape::Mansard, RoofRise::Metres(5.0)),
        )
        .unwrap();
        let v = closed_volume(&mesh);
        let shrunk = |t: f64| 2.0 * (20.0 - 2.0 * t) * (10.0 - 2.0 * t) - (10.0 - 2.0 * t).powi(2);
        let roof = layered_volume(shrunk, 5.0, 5.0, &[BREAK]);
        assert!(
            (v - (300.0 * 5.0 + roof)).abs() < 1e-6,
            "{v} against {}",
            1500.0 + roof
        );
        let (a, b, c) = (5.0 / 3.0, 20.0 - 5.0 / 3.0, 10.0 - 5.0 / 3.0);
        let shrunk_l = [[a, a], [b, a], [b, c], [c, c], [c, b], [a, b]];
        let at_break: Vec<[f64; 2]> = ridge(&mesh, 5.0 + 10.0 / 3.0);
        let off_edges = |p: [f64; 2]| {
            (0..6)
                .map(|i| {
                    let (e0, e1) = (shrunk_l[i], shrunk_l[(i + 1) % 6]);
                    let (ab, ap) = (sub(e1, e0), sub(p, e0));
                    let s = (dot(ab, ap) / dot(ab, ab)).clamp(0.0, 1.0);
                    (ap[0] - s * ab[0]).hypot(ap[1] - s * ab[1])
                })
                .fold(f64::INFINITY, f64::min)
        };
        assert!(
            at_break.iter().all(|&p| off_edges(p) < 1e-6),
            "{at_break:?}"
        );
        for q in shrunk_l {
            assert!(
                at_break
                    .iter()
                    .any(|p| (p[0] - q[0]).hypot(p[1] - q[1]) < 1e-6),
                "{q:?} not in {at_break:?}"
            );
        }
        for s in roof_slopes(&mesh, &kinds) {
            assert!(
                (s.0 - 2.0).abs() < 1e-6 || (s.0 - 0.5).abs() < 1e-6,
                "{s:?}"
            );
        }
    }

    /// A building 30 km from the origin gets the roof it gets at the origin, moved: same triangles, same corners to
    /// the micrometre, for every shape.
    #[test]
    fn a_roof_is_the_same_wherever_the_building_stands() {
        let l: Vec<(f64, f64)> = vec![
            (0.0, 0.0),
            (20.0, 0.0),
            (20.0, 8.0),
            (8.0, 8.0),
            (8.0, 20.0),
            (0.0, 20.0),
            (0.0, 0.0),
        ];
        let square: Vec<(f64, f64)> =
            vec![(0.0, 0.0), (12.0, 0.0), (12.0, 9.0), (0.0, 9.0), (0.0, 0.0)];
        let shift = (30_000.0, -21_000.0);
        // The L takes every shape that spans a concave outline, the square the hipped roof and the rest.
        let spanning: Vec<RoofShape> = RoofShape::ALL
            .into_iter()
            .filter(|s| !s.needs_convex())
            .collect();
        let on_square: Vec<RoofShape> = RoofShape::ALL
            .into_iter()
            .filter(|s| *s == RoofShape::Hipped || s.needs_convex())
            .collect();
        for (outline, shapes) in [(&l, &spanning), (&square, &on_square)] {
            let moved: Vec<(f64, f64)> = outline
                .iter()
                .map(|&(x, y)| (x + shift.0, y + shift.1))
                .collect();
            for &shape in shapes {
                let spec = spec(shape, RoofRise::Metres(3.0));
                let (a, ka) = roofed_building(&footprint(outline), 0.0, 10.0, &spec).unwrap();
                let (b, kb) = roofed_building(&footprint(&moved), 0.0, 10.0, &spec).unwrap();
                assert_eq!((&a.triangles, &ka), (&b.triangles, &kb), "{shape:?}");
                for (p, q) in a.positions.iter().zip(&b.positions) {
                    let d = [q[0] - shift.0 - p[0], q[1] - shift.1 - p[1], q[2] - p[2]];
                    assert!(d.iter().all(|x| x.abs() < 1e-6), "{shape:?}: {p:?} {q:?}");
                }
            }
        }
    }

    /// A star-shaped footprint from corners at (angle, radius) around the origin, and its hipped roof rising 0.1 m on
    /// a building 20 m high, checked closed.
    fn hipped_star(star: &[(f64, f64)]) -> (MultiPolygon<f64>, Mesh3d, Vec<SurfaceKind>) {
        let pts: Vec<(f64, f64)> = star
            .iter()
            .map(|&(t, r)| (r * t.cos(), r * t.sin()))
            .collect();
        let fp = footprint(&pts);
        let spec = spec(RoofShape::Hipped, RoofRise::Metres(0.1));
        let (mesh, kinds) = roofed_building(&fp, 0.0, 20.0, &spec).unwrap();
        let r = mesh_report(&mesh);
        assert!(r.watertight && r.orientation_consistent, "{r:?}");
        (fp, mesh, kinds)
    }

    /// A roof triangle of a hipped roof off its one slope — that of the widest roof triangle, the least tilted by
    /// welding — times one of `ratios` (a mansard's two slopes) by more than welding explains: corners moved by up to
    /// WELD_M in plan and in height tilt a triangle by about (1 + slope) · 2 · WELD_M over its smallest height. (its
    /// slope, the one slope, its height in m)
    fn off_slope(mesh: &Mesh3d, kinds: &[SurfaceKind], ratios: &[f64]) -> Option<(f64, f64, f64)> {
        let slopes = roof_slopes(mesh, kinds);
        let (slope, _) = slopes
            .iter()
            .copied()
            .fold((0.0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
        slopes
            .into_iter()
            .find(|&(s, altitude)| {
                ratios.iter().all(|r| {
                    (s - r * slope).abs() > (1.0 + r * slope) * 2.0 * WELD_M / altitude + 1e-9
                })
            })
            .map(|(s, altitude)| (s, slope, altitude))
    }

    /// Outlines found by the property test below: a star whose outline splits where, by rounding, one piece's
    /// corner lies on the other's edge (the two were joined and split again without end: the test hung).
    #[test]
    fn a_hipped_roof_over_a_split_star_is_built() {
        let stars: [&[(f64, f64)]; 2] = [
            &[
                (0.9225964059237215, 15.924799714588252),
                (0.9998280606598666, 6.950993816577015),
                (1.0184806687518075, 21.24830402825126),
                (3.157773151925716, 2.0),
                (5.251738300501225, 16.152083824127548),
                (5.266529638616059, 7.130940781942794),
                (5.370098781507061, 31.183571067342136),
            ],
            &[
                (0.25018914787664476, 34.57798735313806),
                (0.292589543546951, 8.184975024985635),
                (0.3876329194692887, 37.78262270006809),
                (1.1083089518600826, 6.725909884030436),
                (3.9991931066812145, 28.258659072123383),
                (4.2520422976393775, 2.785575287518493),
                (4.629870832246306, 36.651127570940716),
            ],
        ];
        for star in stars {
            let (fp, mesh, kinds) = hipped_star(star);
            let area = roof_outline_area_m2(&fp.0[0]);
            let v = signed_volume_m3(&mesh);
            assert!(v > area * 19.9 && v < area * 20.0, "{v} over {area} m²");
            assert!(kinds.contains(&SurfaceKind::Roof));
        }
    }

    /// Stars found by the property test below whose simultaneous events, each corner from another pair of lines,
    /// scatter by 0.2 mm: welded within 0.1 mm, one corner stayed two points whose faces' edges crossed, the
    /// triangulation dropped an edge and triangles spanned two faces (a slope of 0 or 2.5 times the roof's). Now the
    /// corners weld within 1 mm, transitively, and a crossing refuses the roof; these are built at the one slope.
    #[test]
    fn a_hipped_roof_over_a_star_with_scattered_events_keeps_its_one_slope() {
        let stars: [&[(f64, f64)]; 2] = [
            &[
                (2.220567520703817, 25.89180440485222),
                (2.5310421814118285, 23.630707965458644),
                (2.597834926829401, 3.5740245178220627),
                (2.904086332504415, 9.852985644398856),
                (3.6752715672799754, 5.265008491559015),
                (3.7289521396152505, 3.7131302477569843),
                (3.9483746411657688, 16.26723847238963),
                (5.468344243620371, 3.3337780238559787),
                (5.652573793634447, 26.893471151323972),
            ],
            &[
                (0.022544070927573896, 31.594638968348548),
                (0.3130960948175091, 3.9907637697347456),
                (0.4916389631112465, 21.07318044829589),
                (1.2879954781283447, 7.854201079021699),
                (2.1811563338275812, 2.1316152808599345),
                (2.4572905093419446, 14.697258183084864),
                (3.4982518145052652, 9.644106928827638),
                (3.6815006756116118, 3.656630020160926),
                (3.877828144111617, 6.452948635275905),
            ],
        ];
        for star in stars {
            let (_, mesh, kinds) = hipped_star(star);
            if let Some((s, slope, altitude)) = off_slope(&mesh, &kinds, &[1.0]) {
                panic!("slope {s} against {slope} (height {altitude} m)");
            }
        }
    }

    #[test]
    fn a_hipped_courtyard_block_rises_from_its_street_and_its_courtyard() {
        // A 30 m square around a 10 m courtyard: a ring 10 m wide whose wavefront at time t has the area
        // (30 − 2t)² − (10 + 2t)², so the roof holds ∫₀⁵ that dt = 2000 m³ at 45°, its ridge a square 20 m wide.
        let outer = [(0.0, 0.0), (30.0, 0.0), (30.0, 30.0), (0.0, 30.0)];
        let court = vec![
            (10.0, 10.0),
            (10.0, 20.0),
            (20.0, 20.0),
            (20.0, 10.0),
            (10.0, 10.0),
        ];
        let mut fp = footprint(&outer);
        fp.0[0].interiors_push(court);
        let rings = [
            outer.map(|(x, y)| [x, y]).to_vec(),
            vec![[10.0, 10.0], [10.0, 20.0], [20.0, 20.0], [20.0, 10.0]],
        ];
        let (faces, run) = skeleton(&rings).unwrap();
        assert!((run - 5.0).abs() < 1e-9, "{run}");
        let (mesh, kinds) = roofed_building(
            &fp,
            0.0,
            10.0,
            &spec(RoofShape::Hipped, RoofRise::Metres(5.0)),
        )
        .unwrap();
        let v = closed_volume(&mesh);
        assert!((v - (800.0 * 5.0 + 2000.0)).abs() < 1e-6, "{v}");
        assert_eq!(
            ridge(&mesh, 10.0),
            [[5.0, 5.0], [5.0, 25.0], [25.0, 5.0], [25.0, 25.0]]
        );
        assert!(kinds.contains(&SurfaceKind::Roof));
        // The faces' own volume, under the plan of the outline with its courtyard.
        let under = roof_volume(&faces, run, &rings);
        assert!((under - 2000.0).abs() < 1e-6, "{under}");
    }

    #[test]
    fn the_skeleton_of_a_convex_outline_is_its_nearest_edge_roof() {
        let outlines: [&[P2]; 4] = [
            &[[0.0, 0.0], [12.0, 0.0], [12.0, 8.0], [0.0, 8.0]],
            &[[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]],
            &[
                [0.0, 0.0],
                [9.0, -2.0],
                [14.0, 5.0],
                [8.0, 12.0],
                [-1.0, 7.0],
            ],
            &[
                [0.0, 0.0],
                [30.0, 0.0],
                [31.0, 3.0],
                [29.0, 9.0],
                [2.0, 11.0],
                [-2.0, 5.0],
            ],
        ];
        for ring in outlines {
            let (a, run_a) = hipped(ring);
            let (b, run_b) = skeleton(&[ring.to_vec()]).unwrap();
            assert!((run_a - run_b).abs() < 1e-9, "{ring:?}: {run_a} {run_b}");
            let (va, vb) = (
                roof_volume(&a, run_a, &[ring.to_vec()]),
                roof_volume(&b, run_b, &[ring.to_vec()]),
            );
            assert!((va - vb).abs() < 1e-6 * va, "{ring:?}: {va} {vb}");
        }
    }

    /// What a hipped roof over an outline whose skeleton rounding spoils is refused with (the building keeps a flat
    /// roof and the report says why).
    const HIPPED_REFUSALS: [&str; 2] = [
        "the outline's straight skeleton could not be built",
        "the roof's faces could not be triangulated",
    ];

    /// Hipped roofs the star-shaped property test built and refused.
    static BUILT: AtomicUsize = AtomicUsize::new(0);
    static REFUSED: AtomicUsize = AtomicUsize::new(0);

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(1000))]
        /// Any convex outline (corners on an ellipse, some nearly in line) gets, for every shape and direction, a
        /// closed mesh whose volume lies between the prism to its eaves and the prism to its top.
        #[test]
        fn every_convex_outline_gets_a_closed_roof(
            angles in proptest::collection::vec(0.0f64..std::f64::consts::TAU, 3..40),
            a in 3.0f64..60.0,
            b in 3.0f64..60.0,
            turn in 0.0f64..180.0,
            rise in 0.1f64..15.0,
            direction in proptest::option::of(0.0f64..360.0),
            across in proptest::bool::ANY,
        ) {
            let mut angles = angles;
            angles.sort_by(f64::total_cmp);
            angles.dedup_by(|x, y| (*x - *y).abs() < 1e-3);
            let (s, c) = turn.to_radians().sin_cos();
            let pts: Vec<(f64, f64)> = angles
                .iter()
                .map(|t| {
                    let (x, y) = (a * t.cos(), b * t.sin());
                    (1000.0 + c * x - s * y, -500.0 + s * x + c * y)
                })
                .collect();
            let fp = footprint(&pts);
            let ring: Vec<[f64; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
            let area = crate::ring::signed_area2(&ring) / 2.0;
            for shape in RoofShape::ALL {
                let spec = RoofSpec { shape, rise: RoofRise::Metres(rise), direction_deg: direction, across };
                let built = roofed_building(&fp, 2.0, 20.0, &spec);
                // A sliver of an outline (all corners on a short arc) may have too few corners left once those
                // nearly in line are merged; anything wider is roofed.
                if area < 1.0 {
                    continue;
                }
                let (mesh, kinds) = built.map_err(|e| proptest::test_runner::TestCaseError::fail(format!("{shape:?}: {e}")))?;
                proptest::prop_assert_eq!(kinds.len(), mesh.triangles.len());
                let r = mesh_report(&mesh);
                proptest::prop_assert!(r.watertight && r.orientation_consistent, "{:?}: {:?}", shape, r);
                let v = signed_volume_m3(&mesh);
                let eaves = area * (20.0 - rise);
                proptest::prop_assert!(v > eaves - 1e-6 * area && v < area * 20.0 + 1e-6 * area,
                    "{:?}: volume {} outside ({}, {})", shape, v, eaves, area * 20.0);
                proptest::prop_assert!((top_z(&mesh) - 22.0).abs() < 1e-6, "{:?}", shape);
            }
        }

        /// Skillion, gabled and hipped roofs over any star-shaped outline (concave, corners at random radii), with or
        /// without a courtyard, are closed too; every face of a hipped roof rises at its one slope.
        #[test]
        fn every_star_shaped_outline_gets_a_closed_skillion_and_gabled_roof(
            corners in proptest::collection::vec((0.0f64..std::f64::consts::TAU, 2.0f64..40.0), 3..30),
            rise in 0.1f64..15.0,
            direction in 0.0f64..360.0,
            courtyard in proptest::bool::ANY,
        ) {
            let mut corners = corners;
            corners.sort_by(|a, b| a.0.total_cmp(&b.0));
            corners.dedup_by(|x, y| (x.0 - y.0).abs() < 1e-2);
            // Star-shaped around the origin (so simple) only when no angular gap reaches half a turn.
            let n = corners.len();
            if n < 3 || (0..n).any(|i| {
                let next = if i + 1 < n { corners[i + 1].0 } else { corners[0].0 + std::f64::consts::TAU };
                next - corners[i].0 >= 0.95 * std::f64::consts::PI
            }) {
                return Ok(());
            }
            let pts: Vec<(f64, f64)> = corners.iter().map(|(t, r)| (r * t.cos(), r * t.sin())).collect();
            let ring: Vec<[f64; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
            // The area of the outline the roof is built on: corners turning by under 0.5° are dropped (a corner
            // of 0.46° between edges of 16 and 34 m holds 2 m²).
            let mut area = crate::ring::signed_area2(&super::corners(ring.clone())) / 2.0;
            if pts.len() < 3 || area < 1.0 {
                return Ok(());
            }
            let mut fp = footprint(&pts);
            // A square courtyard around the origin, within the disc the outline holds (the nearest edge line).
            let nearest = (0..n)
                .map(|i| {
                    let (a, b) = (ring[i], ring[(i + 1) % n]);
                    let d = sub(b, a);
                    cross(d, [-a[0], -a[1]]).abs() / d[0].hypot(d[1])
                })
                .fold(f64::INFINITY, f64::min);
            if courtyard && nearest > 1.0 {
                let h = 0.5 * nearest / std::f64::consts::SQRT_2;
                fp.0[0].interiors_push(vec![(-h, -h), (-h, h), (h, h), (h, -h), (-h, -h)]);
                area -= 4.0 * h * h;
            }
            // Hipped: the straight skeleton of a concave outline and its courtyard.
            for shape in [RoofShape::Skillion, RoofShape::Gabled, RoofShape::Gambrel, RoofShape::Round, RoofShape::HalfHipped, RoofShape::Hipped, RoofShape::Mansard] {
                let skeleton = matches!(shape, RoofShape::Hipped | RoofShape::Mansard);
                let spec = RoofSpec { shape, rise: RoofRise::Metres(rise), direction_deg: Some(direction), across: false };
                let (mesh, kinds) = match roofed_building(&fp, 0.0, 20.0, &spec) {
                    Ok(built) => built,
                    Err(e) if skeleton && HIPPED_REFUSALS.contains(&e.as_str()) => {
                        let refused = REFUSED.fetch_add(1, Ordering::Relaxed) + 1;
                        // Rare (one in 20 000 outlines when measured), never the rule.
                        proptest::prop_assert!(refused <= 1 + BUILT.load(Ordering::Relaxed) / 200,
                            "{} hipped roofs refused against {} built", refused, BUILT.load(Ordering::Relaxed));
                        continue;
                    }
                    Err(e) => return Err(proptest::test_runner::TestCaseError::fail(format!("{shape:?}: {e}"))),
                };
                if skeleton {
                    BUILT.fetch_add(1, Ordering::Relaxed);
                }
                let r = mesh_report(&mesh);
                proptest::prop_assert!(r.watertight && r.orientation_consistent, "{:?}: {:?}", shape, r);
                let v = signed_volume_m3(&mesh);
                proptest::prop_assert!(v > area * (20.0 - rise) * (1.0 - 1e-9) && v < area * 20.0 * (1.0 + 1e-9), "{:?}: {} of {}", shape, v, area);
                proptest::prop_assert!((top_z(&mesh) - 20.0).abs() < 1e-6, "{:?}", shape);
                if skeleton {
                    // Every face rises from its edge at the one slope of a straight skeleton's roof (a mansard's at its
                    // two, the lower four times the upper).
                    let ratios: &[f64] = if shape == RoofShape::Mansard { &[1.0, 4.0, 0.25] } else { &[1.0] };
                    let off = off_slope(&mesh, &kinds, ratios);
                    proptest::prop_assert!(off.is_none(), "{:?}: (slope, against, height m) {:?}", shape, off);
                }
            }
        }
    }
}
