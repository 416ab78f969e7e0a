//! LoD1 prism from a footprint: one wall quad per ring edge (exteriors and holes) and a flat roof cap: a
//! fan for a convex ring, ear clipping for a small simple one, else triangulated with its holes (constrained
//! Delaunay, spade; faces kept by crossing parity) — for rings of many points nearly in line, on the points
//! Douglas–Peucker keeps, the others fanned back in.
//! Units: local ENU metres, z up. Invariants: triangles counter-clockwise seen from outside, none with
//! zero area, walls and roof share no vertex (flat shading), roof area == footprint area.

use crate::ring::{clean_ring, signed_area2};
use citylod_model::{Footprint, Mesh3d};
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

/// Why a footprint could not be extruded.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    #[error("top height {top_z_m} m is not above base height {base_z_m} m")]
    NonPositiveHeight { base_z_m: f64, top_z_m: f64 },
    #[error("footprint has a non-finite coordinate (polygon {polygon})")]
    NonFinite { polygon: usize },
    #[error("footprint has no polygon with area left after removing near-duplicate points")]
    Empty,
    #[error(
        "polygon {polygon}: coordinates out of the triangulation's range; cannot build the roof"
    )]
    Triangulation { polygon: usize },
}

/// Extrudes `footprint` (local ENU m) from `base_z_m` to `top_z_m` into a closed-top prism.
///
/// Walls: two triangles per ring edge, facing away from the polygon's material (outward on exterior
/// rings, into the courtyard on holes). Roof: the polygon with its holes, normal +z.
///
/// There is no floor: buildings stand on the ground, so a floor is never seen from above or from
/// street level (and with back-face culling not even from below), and leaving it out saves as many
/// triangles as the roof has.
///
/// Rings are cleaned first: consecutive points closer than 1 µm are merged, rings without area
/// are dropped, and orientation is fixed (exterior counter-clockwise, holes clockwise) whatever the
/// input order. Collinear points are kept (they produce extra wall quads and roof vertices, never
/// degenerate triangles).
///
/// Invalid footprints (rings crossing themselves or each other; ingest should have repaired them)
/// still give a prism: the crossings are added as roof vertices and the roof is the even-odd
/// interior of the rings; walls follow the rings as given. The invariants above then hold only
/// where the rings do not cross.
///
/// Errors: `top_z_m <= base_z_m` or non-finite heights, non-finite coordinates, nothing with area
/// left, coordinates too large to triangulate. Never panics.
pub fn extrude(footprint: &Footprint, base_z_m: f64, top_z_m: f64) -> Result<Mesh3d, MeshError> {
    if !(base_z_m.is_finite() && top_z_m.is_finite() && top_z_m > base_z_m) {
        return Err(MeshError::NonPositiveHeight { base_z_m, top_z_m });
    }
    let mut mesh = Mesh3d::default();
    let mut any = false;
    for (pi, poly) in footprint.0.iter().enumerate() {
        let bad = |_| MeshError::NonFinite { polygon: pi };
        let Some(exterior) = clean_ring(poly.exterior(), true).map_err(bad)? else {
            continue;
        };
        let mut rings = vec![exterior];
        for hole in poly.interiors() {
            if let Some(h) = clean_ring(hole, false).map_err(bad)? {
                rings.push(h);
            }
        }
        // Triangulate first so a failing polygon leaves no walls behind.
        let roof = roof_triangles(&rings).ok_or(MeshError::Triangulation { polygon: pi })?;
        // Exactly what this polygon adds, so a city's meshes carry no spare capacity (a growing Vec keeps up to
        // half its allocation unused; ~0.4 GB for a million buildings).
        let corners: usize = rings.iter().map(Vec::len).sum();
        mesh.positions.reserve_exact(4 * corners + roof.0.len());
        mesh.triangles.reserve_exact(2 * corners + roof.1.len());
        for ring in &rings {
            push_walls(&mut mesh, ring, base_z_m, top_z_m);
        }
        push_roof(&mut mesh, &roof, top_z_m);
        any = true;
    }
    if !any {
        return Err(MeshError::Empty);
    }
    Ok(mesh)
}

/// Two triangles per edge: (a_bot, b_bot, b_top) and (a_bot, b_top, a_top). For an edge a→b with the
/// material on its left (exterior CCW, hole CW) the normal (dy, −dx, 0)·h points to its right: outward.
fn push_walls(mesh: &mut Mesh3d, ring: &[[f64; 2]], base_z_m: f64, top_z_m: f64) {
    let n = ring.len();
    for i in 0..n {
        let (a, b) = (ring[i], ring[(i + 1) % n]);
        let v0 = mesh.positions.len() as u32;
        mesh.positions.extend_from_slice(&[
            [a[0], a[1], base_z_m],
            [b[0], b[1], base_z_m],
            [b[0], b[1], top_z_m],
            [a[0], a[1], top_z_m],
        ]);
        mesh.triangles.push([v0, v0 + 1, v0 + 2]);
        mesh.triangles.push([v0, v0 + 2, v0 + 3]);
    }
}

/// Roof triangles as 2D corner points, counter-clockwise.
type Roof = (Vec<[f64; 2]>, Vec<[u32; 3]>);

fn push_roof(mesh: &mut Mesh3d, roof: &Roof, top_z_m: f64) {
    let v0 = mesh.positions.len() as u32;
    mesh.positions
        .extend(roof.0.iter().map(|p| [p[0], p[1], top_z_m]));
    mesh.triangles
        .extend(roof.1.iter().map(|t| [t[0] + v0, t[1] + v0, t[2] + v0]));
}

/// Above this many points a roof is bulk-loaded: inserted one by one in ring order, the points of a
/// round outline cost O(n²) flips (a 100,000-point circle took over 10 min). Below, one-by-one
/// insertion is faster.
const BULK_LOAD_MIN_POINTS: usize = 256;

/// Whether a counter-clockwise ring is strictly convex: every corner turns left by a clear margin (a
/// corner within ~1e-9 rad of straight, or turning right, is not) and the turns add up to one full turn,
/// not two or more (a pentagram turns left at every corner too).
fn is_strictly_convex(ring: &[[f64; 2]]) -> bool {
    let n = ring.len();
    if n < 3 {
        return false;
    }
    let mut turning = 0.0;
    for i in 0..n {
        let (a, b, c) = (ring[i], ring[(i + 1) % n], ring[(i + 2) % n]);
        if !turns_left_clearly(a, b, c) {
            return false;
        }
        let u = [b[0] - a[0], b[1] - a[1]];
        let v = [c[0] - b[0], c[1] - b[1]];
        turning += (u[0] * v[1] - u[1] * v[0]).atan2(u[0] * v[0] + u[1] * v[1]);
    }
    turning < 3.0 * std::f64::consts::PI
}

/// Whether the corner a → b → c turns left by more than ~1e-9 rad: |u × v| = |u||v| sin θ, and the margin
/// is far above the rounding error of the cross product, so the triangle (a, b, c) has a clearly positive
/// area in floating point too.
fn turns_left_clearly(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    let u = [b[0] - a[0], b[1] - a[1]];
    let v = [c[0] - b[0], c[1] - b[1]];
    u[0] * v[1] - u[1] * v[0]
        > 1e-9 * ((u[0] * u[0] + u[1] * u[1]) * (v[0] * v[0] + v[1] * v[1])).sqrt()
}

/// The fan of a strictly convex ring from its first point: n − 2 counter-clockwise triangles, each of
/// positive area, covering the ring exactly — what the constrained triangulation gives in count, at a
/// fraction of its cost (most footprints are convex, most of them quadrilaterals).
fn fan(ring: &[[f64; 2]]) -> Roof {
    let tris = (1..ring.len() as u32 - 1).map(|i| [0, i, i + 1]).collect();
    (ring.to_vec(), tris)
}

/// Most points of a ring without holes that [`ear_clip`] takes: its simplicity test and ear search compare
/// every pair (n² / 2). With 24 or 64, Boston's mesh and tile phases took the same time (150–180 ms and
/// ~600 ms, against 220 and ~680 ms with the triangulation for every roof).
const EAR_MAX_POINTS: usize = 64;

/// Exact orientation of `c` against the line `a` → `b`: > 0 left (counter-clockwise), 0 on it.
fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    let p = |q: [f64; 2]| robust::Coord { x: q[0], y: q[1] };
    robust::orient2d(p(a), p(b), p(c))
}

/// Whether the closed segments `a`–`b` and `c`–`d` meet (touching counts), exactly.
fn segments_meet(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    // Segments whose boxes are apart cannot meet: most pairs of a ring end here, before any orientation.
    if a[0].max(b[0]) < c[0].min(d[0])
        || c[0].max(d[0]) < a[0].min(b[0])
        || a[1].max(b[1]) < c[1].min(d[1])
        || c[1].max(d[1]) < a[1].min(b[1])
    {
        return false;
    }
    let (d1, d2) = (orient(a, b, c), orient(a, b, d));
    let (d3, d4) = (orient(c, d, a), orient(c, d, b));
    let within = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        r[0] >= p[0].min(q[0])
            && r[0] <= p[0].max(q[0])
            && r[1] >= p[1].min(q[1])
            && r[1] <= p[1].max(q[1])
    };
    ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
        || (d1 == 0.0 && within(a, b, c))
        || (d2 == 0.0 && within(a, b, d))
        || (d3 == 0.0 && within(c, d, a))
        || (d4 == 0.0 && within(c, d, b))
}

/// Whether a ring is simple: no two edges meet except neighbours at their shared corner, and no corner
/// folds back onto its incoming edge.
fn is_simple(ring: &[[f64; 2]]) -> bool {
    let n = ring.len();
    for i in 0..n {
        let (a, b) = (ring[i], ring[(i + 1) % n]);
        let c = ring[(i + 2) % n];
        // Neighbours: only a fold back (c on the line a–b, heading back) makes them overlap.
        if orient(a, b, c) == 0.0
            && (c[0] - b[0]) * (b[0] - a[0]) + (c[1] - b[1]) * (b[1] - a[1]) <= 0.0
        {
            return false;
        }
        // Non-neighbours: j from i + 2, and the last edge is the first one's neighbour.
        let last = if i == 0 { n - 1 } else { n };
        for j in i + 2..last {
            if segments_meet(a, b, ring[j], ring[(j + 1) % n]) {
                return false;
            }
        }
    }
    true
}

/// Triangles of a simple counter-clockwise ring of at most [`EAR_MAX_POINTS`] points by clipping ears: a
/// corner turning clearly left whose triangle holds no other corner of what is left, not even on its border
/// (exact predicates). n − 2 triangles, each counter-clockwise with positive area, covering the ring exactly. `None`
/// for a larger or non-simple ring, or when no ear is left (collinear corners can leave none); the
/// constrained triangulation takes those.
fn ear_clip(ring: &[[f64; 2]]) -> Option<Roof> {
    let n = ring.len();
    if !(3..=EAR_MAX_POINTS).contains(&n) || !is_simple(ring) {
        return None;
    }
    let mut left: Vec<u32> = (0..n as u32).collect();
    let mut tris = Vec::with_capacity(n - 2);
    let mut i = 0;
    let mut tried = 0;
    while left.len() > 3 {
        let m = left.len();
        let (a, b, c) = (left[(i + m - 1) % m], left[i], left[(i + 1) % m]);
        let [pa, pb, pc] = [a, b, c].map(|k| ring[k as usize]);
        // A corner outside the triangle's box is outside the triangle: no orientation needed.
        let (lo, hi) = (
            [pa[0].min(pb[0]).min(pc[0]), pa[1].min(pb[1]).min(pc[1])],
            [pa[0].max(pb[0]).max(pc[0]), pa[1].max(pb[1]).max(pc[1])],
        );
        let ear = turns_left_clearly(pa, pb, pc)
            && left.iter().all(|&k| {
                let p = ring[k as usize];
                k == a
                    || k == b
                    || k == c
                    || p[0] < lo[0]
                    || p[0] > hi[0]
                    || p[1] < lo[1]
                    || p[1] > hi[1]
                    || orient(pa, pb, p) < 0.0
                    || orient(pb, pc, p) < 0.0
                    || orient(pc, pa, p) < 0.0
            });
        if ear {
            tris.push([a, b, c]);
            left.remove(i);
            if i == left.len() {
                i = 0;
            }
            tried = 0;
        } else {
            i = (i + 1) % m;
            tried += 1;
            if tried > m {
                return None;
            }
        }
    }
    let [pa, pb, pc] = [left[0], left[1], left[2]].map(|k| ring[k as usize]);
    if !turns_left_clearly(pa, pb, pc) {
        return None;
    }
    tris.push([left[0], left[1], left[2]]);
    Some((ring.to_vec(), tris))
}

/// The roof of the rings ([`exact_roof`]); for many points, most of them nearly in line with their neighbours,
/// [`roof_without_points_in_line`] first. `None` when a point cannot be inserted.
fn roof_triangles(rings: &[Vec<[f64; 2]>]) -> Option<Roof> {
    let n_points: usize = rings.iter().map(Vec::len).sum();
    // (Tested only for many points: every prism's roof comes here, and `exact_roof` tests convexity itself.)
    if n_points >= BULK_LOAD_MIN_POINTS
        && !matches!(rings, [ring] if is_strictly_convex(ring))
        && mostly_in_line(rings)
    {
        if let Some(roof) = roof_without_points_in_line(rings) {
            return Some(roof);
        }
    }
    exact_roof(rings)
}

/// Whether more than half the points lie within [`IN_LINE_M`] of the segment between their neighbours: one pass,
/// so rings of many points that are not a densified outline (a star, a traced curve) skip the Douglas–Peucker
/// pass, which keeps most of their points at a quadratic cost.
fn mostly_in_line(rings: &[Vec<[f64; 2]>]) -> bool {
    let (mut in_line, mut all) = (0usize, 0usize);
    for r in rings {
        let n = r.len();
        for i in 0..n {
            let d = crate::simplify::profile::seg_dist(r[i], r[(i + n - 1) % n], r[(i + 1) % n]);
            in_line += usize::from(d <= IN_LINE_M);
        }
        all += n;
    }
    2 * in_line > all
}

/// Within this distance (m) of the chord between the points kept on either side of it, a roof point is left out of
/// the triangulation and fanned back in afterwards ([`roof_without_points_in_line`]); a twentieth of the leaves' 2 cm
/// grid.
const IN_LINE_M: f64 = 1e-3;

/// The roof of rings of many points, most of them nearly in line (a footprint densified along its sides): such
/// points make the Delaunay triangulation degenerate, and spade took 16 s on a ring of 10,000 points interpolated
/// along the sides of a real footprint and over a minute on 20,000 (found by fuzzing). The points within
/// [`IN_LINE_M`] of the chord between the points kept around them (Douglas–Peucker) are left out, the kept ones
/// triangulated, and each run of left-out points fanned into the triangle on its chord from that triangle's third
/// corner (a triangle on two chords fans the second from a point of the first run, so noise across corners makes it
/// give up). Every point stays a roof point, so the roof covers the rings exactly and meets the walls edge to edge,
/// with as many triangles as the full triangulation. `None` when nothing is left out, a ring keeps fewer than 3 points, or a chord is not a
/// triangle's edge or a fan triangle would not turn counter-clockwise (rings that cross or come that close): the
/// caller triangulates every point then.
fn roof_without_points_in_line(rings: &[Vec<[f64; 2]>]) -> Option<Roof> {
    let keep: Vec<Vec<bool>> = rings
        .iter()
        .map(|r| points_off_line(r, IN_LINE_M))
        .collect();
    if keep.iter().flatten().all(|&k| k) {
        return None;
    }
    let reduced: Vec<Vec<[f64; 2]>> = rings
        .iter()
        .zip(&keep)
        .map(|(r, k)| {
            r.iter()
                .zip(k)
                .filter(|(_, &k)| k)
                .map(|(p, _)| *p)
                .collect()
        })
        .collect();
    if reduced.iter().any(|r| r.len() < 3) {
        return None;
    }
    let (mut points, mut tris) = exact_roof(&reduced)?;
    let bits = |p: [f64; 2]| ((p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits());
    let index: std::collections::HashMap<(u64, u64), u32> = points
        .iter()
        .enumerate()
        .map(|(i, p)| (bits(*p), i as u32))
        .collect();
    // Directed edge → the triangle holding it (counter-clockwise).
    let mut by_edge: std::collections::HashMap<(u32, u32), usize> =
        std::collections::HashMap::new();
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            by_edge.insert((tri[k], tri[(k + 1) % 3]), t);
        }
    }
    for (ring, k) in rings.iter().zip(&keep) {
        let n = ring.len();
        let first = k.iter().position(|&k| k)?;
        // From each kept point, the run of left-out points up to the next kept one (the material is on the
        // left of every ring, so the chord's triangle holds it in that direction).
        let mut i = first;
        loop {
            let mut j = (i + 1) % n;
            let mut run = Vec::new();
            while !k[j] {
                run.push(ring[j]);
                j = (j + 1) % n;
            }
            if !run.is_empty() {
                let (a, c) = (*index.get(&bits(ring[i]))?, *index.get(&bits(ring[j]))?);
                let t = by_edge.remove(&(a, c))?;
                let tri = tris[t];
                let at = tri.iter().position(|&v| v == a)?;
                let x = tri[(at + 2) % 3];
                by_edge.remove(&(c, x));
                by_edge.remove(&(x, a));
                let mut chain = vec![a];
                for p in run {
                    chain.push(points.len() as u32);
                    points.push(p);
                }
                chain.push(c);
                for (w, pair) in chain.windows(2).enumerate() {
                    let fan_tri = [pair[0], pair[1], x];
                    let [p, q, r] = fan_tri.map(|v| points[v as usize]);
                    if orient(p, q, r) <= 0.0 {
                        return None;
                    }
                    let slot = if w == 0 {
                        tris[t] = fan_tri;
                        t
                    } else {
                        tris.push(fan_tri);
                        tris.len() - 1
                    };
                    for e in 0..3 {
                        by_edge.insert((fan_tri[e], fan_tri[(e + 1) % 3]), slot);
                    }
                }
            }
            if j == first {
                break;
            }
            i = j;
        }
    }
    Some((points, tris))
}

/// Which points of a closed ring Douglas–Peucker keeps at tolerance `tol_m`: every point left out lies within
/// `tol_m` of the segment between the kept points around it. The first point and the one farthest from it are kept.
fn points_off_line(ring: &[[f64; 2]], tol_m: f64) -> Vec<bool> {
    let n = ring.len();
    let mut keep = vec![n < 4; n];
    if n < 4 {
        return keep;
    }
    let dist = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]);
    let far = (1..n)
        .max_by(|&a, &b| dist(ring[a], ring[0]).total_cmp(&dist(ring[b], ring[0])))
        .unwrap_or(0);
    keep[0] = true;
    keep[far] = true;
    // Spans (start, end) in ring order, end possibly wrapping past n.
    let mut spans = vec![(0, far), (far, n)];
    while let Some((s, e)) = spans.pop() {
        if e - s < 2 {
            continue;
        }
        let (a, b) = (ring[s % n], ring[e % n]);
        let mut worst = (0.0, s);
        for i in s + 1..e {
            let d = crate::simplify::profile::seg_dist(ring[i % n], a, b);
            if d > worst.0 {
                worst = (d, i);
            }
        }
        if worst.0 > tol_m {
            keep[worst.1 % n] = true;
            spans.push((s, worst.1));
            spans.push((worst.1, e));
        }
    }
    keep
}

/// The roof of every point of the rings: a fan or ear clipping for one simple ring, else the constrained Delaunay
/// triangulation.
fn exact_roof(rings: &[Vec<[f64; 2]>]) -> Option<Roof> {
    if let [ring] = rings {
        if is_strictly_convex(ring) {
            return Some(fan(ring));
        }
        if let Some(roof) = ear_clip(ring) {
            return Some(roof);
        }
    }
    type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;
    let point = |p: &[f64; 2]| Point2::new(p[0], p[1]);
    let constrain = |cdt: &mut Cdt, handles: &[spade::handles::FixedVertexHandle]| {
        for i in 0..handles.len() {
            let (a, b) = (handles[i], handles[(i + 1) % handles.len()]);
            if a == b {
                continue;
            }
            if cdt.can_add_constraint(a, b) {
                cdt.add_constraint(a, b);
            } else {
                cdt.add_constraint_and_split(a, b, |p| p);
            }
        }
    };
    let n_points: usize = rings.iter().map(Vec::len).sum();
    let mut cdt: Cdt;
    if n_points < BULK_LOAD_MIN_POINTS {
        // Each ring's points, then its edges.
        cdt = Cdt::new();
        for ring in rings {
            let handles: Vec<_> = ring
                .iter()
                .map(|p| cdt.insert(point(p)).ok())
                .collect::<Option<_>>()?;
            constrain(&mut cdt, &handles);
        }
    } else {
        cdt = Cdt::bulk_load_cdt(rings.iter().flatten().map(point).collect(), Vec::new()).ok()?;
        // Equal points share one vertex; -0.0 and 0.0 are equal.
        let bits = |p: &[f64; 2]| ((p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits());
        let by_point: std::collections::HashMap<_, _> = cdt
            .vertices()
            .map(|v| (bits(&[v.position().x, v.position().y]), v.fix()))
            .collect();
        for ring in rings {
            let handles: Vec<_> = ring
                .iter()
                .map(|p| by_point.get(&bits(p)).copied())
                .collect::<Option<_>>()?;
            constrain(&mut cdt, &handles);
        }
    }
    let n_faces = cdt.all_faces().len();
    // Parity per face index (outer face is index 0 with parity false); None = not reached yet.
    let mut inside: Vec<Option<bool>> = vec![None; n_faces];
    let outer = cdt.outer_face();
    inside[outer.fix().index()] = Some(false);
    let mut stack = vec![outer.fix()];
    while let Some(f) = stack.pop() {
        let parity = inside[f.index()].unwrap_or(false);
        let face = cdt.face(f);
        let edges: Vec<_> = match face.as_inner() {
            Some(inner) => inner.adjacent_edges().to_vec(),
            // Hull edges oriented with the outer face on their left, so `rev()` leads inside.
            None => cdt
                .convex_hull()
                .map(|e| if e.face().is_outer() { e } else { e.rev() })
                .collect(),
        };
        for e in edges {
            let other = e.rev().face();
            let idx = other.fix().index();
            if inside[idx].is_none() {
                inside[idx] = Some(parity ^ e.is_constraint_edge());
                stack.push(other.fix());
            }
        }
    }
    let mut points = Vec::new();
    let mut remap = vec![u32::MAX; cdt.num_vertices()];
    let mut tris = Vec::new();
    for face in cdt.inner_faces() {
        if inside[face.fix().index()] != Some(true) {
            continue;
        }
        let vs = face.vertices();
        let p = vs.map(|v| [v.position().x, v.position().y]);
        if signed_area2(&p) <= 0.0 {
            continue; // cannot happen with exact predicates; guards flat output
        }
        let t = vs.map(|v| {
            let slot = &mut remap[v.fix().index()];
            if *slot == u32::MAX {
                *slot = points.len() as u32;
                points.push([v.position().x, v.position().y]);
            }
            *slot
        });
        tris.push(t);
    }
    Some((points, tris))
}

#[cfg(test)]
mod tests {
    use super::*;
    use geo_types::{Coord, LineString, MultiPolygon, Polygon};
    use proptest::prelude::*;
    use std::collections::BTreeMap;

    /// Footprint area (m²), holes subtracted, by the shoelace formula on the raw rings.
    fn footprint_area_m2(fp: &Footprint) -> f64 {
        let ring = |r: &LineString<f64>| {
            let pts: Vec<[f64; 2]> = r.0.iter().map(|c| [c.x, c.y]).collect();
            (signed_area2(&pts) / 2.0).abs()
        };
        fp.0.iter()
            .map(|p| ring(p.exterior()) - p.interiors().iter().map(ring).sum::<f64>())
            .sum()
    }

    fn tri_normal(m: &Mesh3d, t: [u32; 3]) -> [f64; 3] {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    }

    fn point_in_footprint(fp: &Footprint, p: [f64; 2]) -> bool {
        let mut inside = false;
        for poly in &fp.0 {
            for ring in std::iter::once(poly.exterior()).chain(poly.interiors()) {
                for w in ring.0.windows(2) {
                    let (a, b) = (w[0], w[1]);
                    if (a.y > p[1]) != (b.y > p[1])
                        && p[0] < a.x + (p[1] - a.y) / (b.y - a.y) * (b.x - a.x)
                    {
                        inside = !inside;
                    }
                }
            }
        }
        inside
    }

    /// Checks every invariant the module promises; returns the first violation.
    fn check_prism(fp: &Footprint, m: &Mesh3d, base: f64, top: f64) -> Result<(), String> {
        check_prism_tol(fp, m, base, top, 1e-9)
    }

    /// `area_tol` is relative: cleaning merges points closer than 1 µm, which moves real areas a little.
    fn check_prism_tol(
        fp: &Footprint,
        m: &Mesh3d,
        base: f64,
        top: f64,
        area_tol: f64,
    ) -> Result<(), String> {
        let mut roof_area = 0.0;
        let mut edges: BTreeMap<([u64; 3], [u64; 3]), i32> = BTreeMap::new();
        let key = |p: [f64; 3]| p.map(f64::to_bits);
        let mut roof_vertices = std::collections::BTreeSet::new();
        let mut wall_vertices = std::collections::BTreeSet::new();
        for &t in &m.triangles {
            let n = tri_normal(m, t);
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if len <= 0.0 {
                return Err(format!("degenerate triangle {t:?}"));
            }
            let ps = t.map(|i| m.positions[i as usize]);
            if ps.iter().all(|p| p[2] == top) {
                if n[2] <= 0.0 {
                    return Err(format!("roof triangle {t:?} faces down"));
                }
                roof_area += n[2] / 2.0;
                roof_vertices.extend(t);
            } else {
                if n[2].abs() > 1e-9 * len {
                    return Err(format!("wall triangle {t:?} not vertical"));
                }
                wall_vertices.extend(t);
                // Step off the wall's centre along the normal: outside the material, and inside behind.
                let c = [
                    (ps[0][0] + ps[1][0] + ps[2][0]) / 3.0,
                    (ps[0][1] + ps[1][1] + ps[2][1]) / 3.0,
                ];
                let eps = 1e-6 / len;
                let out = [c[0] + n[0] * eps, c[1] + n[1] * eps];
                let back = [c[0] - n[0] * eps, c[1] - n[1] * eps];
                if point_in_footprint(fp, out) || !point_in_footprint(fp, back) {
                    return Err(format!("wall triangle {t:?} faces inward"));
                }
            }
            for k in 0..3 {
                let (a, b) = (ps[k], ps[(k + 1) % 3]);
                *edges.entry((key(a), key(b))).or_default() += 1;
            }
        }
        if roof_vertices.intersection(&wall_vertices).next().is_some() {
            return Err("walls and roof share a vertex".into());
        }
        for (&(a, b), &n) in &edges {
            let back = edges.get(&(b, a)).copied().unwrap_or(0);
            let on_floor = f64::from_bits(a[2]) == base && f64::from_bits(b[2]) == base;
            let ok = if on_floor {
                n == 1 && back == 0
            } else {
                n == back
            };
            if !ok {
                return Err(format!("edge {a:?}→{b:?} used {n}× but reversed {back}×"));
            }
        }
        let want = footprint_area_m2(fp);
        if (roof_area - want).abs() > area_tol * want.max(1.0) {
            return Err(format!("roof area {roof_area} != footprint area {want}"));
        }
        Ok(())
    }

    fn ring(pts: &[(f64, f64)]) -> LineString<f64> {
        let mut v: Vec<Coord<f64>> = pts.iter().map(|&(x, y)| Coord { x, y }).collect();
        v.push(v[0]);
        LineString(v)
    }

    /// A star-shaped ring around `c`: strictly increasing angles make it simple.
    fn star(c: (f64, f64), radii: &[f64], ccw: bool) -> LineString<f64> {
        let n = radii.len();
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let a = i as f64 / n as f64 * std::f64::consts::TAU;
                (c.0 + radii[i] * a.cos(), c.1 + radii[i] * a.sin())
            })
            .collect();
        if !ccw {
            pts.reverse();
        }
        ring(&pts)
    }

    #[test]
    fn square_with_courtyard_meets_every_invariant() {
        let outer = ring(&[(0.0, 0.0), (20.0, 0.0), (20.0, 20.0), (0.0, 20.0)]);
        let hole = ring(&[(5.0, 5.0), (5.0, 15.0), (15.0, 15.0), (15.0, 5.0)]);
        let fp = MultiPolygon(vec![Polygon::new(outer, vec![hole])]);
        let m = extrude(&fp, 1.0, 9.0).unwrap();
        check_prism(&fp, &m, 1.0, 9.0).unwrap();
        assert_eq!(m.triangles.len(), 8 * 2 + 8);
    }

    #[test]
    fn round_outlines_over_the_bulk_threshold_meet_every_invariant() {
        // A gasometer-like ring (every point on one circle, the worst case for one-by-one insertion)
        // with a round courtyard, above BULK_LOAD_MIN_POINTS, and a small one below it.
        for (n_outer, n_hole) in [(3_000, 700), (40, 12)] {
            let outer = star((100.0, 50.0), &vec![40.0; n_outer], true);
            let hole = star((100.0, 50.0), &vec![15.0; n_hole], false);
            let fp = MultiPolygon(vec![Polygon::new(outer, vec![hole])]);
            let m = extrude(&fp, 0.0, 30.0).unwrap();
            check_prism(&fp, &m, 0.0, 30.0).unwrap();
            // A polygon with one hole: n − 2 + 2 roof triangles, two per wall.
            let n = n_outer + n_hole;
            assert_eq!(m.triangles.len(), n + 2 * n, "{n_outer}+{n_hole}");
        }
    }

    /// A 20 m square densified to 5,000 points a side by interpolation (as the fuzzing case was, on a real
    /// footprint): spade's triangulation of all 20,000 took over a minute. The roof is triangulated on the four
    /// corners and the points fanned back in; it still has every point, covers the square exactly, meets the walls
    /// edge to edge and has n − 2 triangles. Nudged up to 0.1 mm off the sides and with a courtyard, whatever path
    /// it takes, the roof is as sound.
    #[test]
    fn a_densified_outline_is_roofed_from_its_corners() {
        let side = 5_000;
        let corners = [(0.0, 0.0), (20.0, 0.0), (20.0, 20.0), (0.0, 20.0)];
        let densified = |nudge_m: f64| {
            let mut pts = Vec::new();
            for k in 0..4 {
                let (a, b) = (corners[k], corners[(k + 1) % 4]);
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                for i in 0..side {
                    let t = i as f64 / side as f64;
                    // Off the side, inwards or outwards by turns.
                    let off = if i == 0 {
                        0.0
                    } else {
                        nudge_m * ((i * 7919) % 13) as f64 / 13.0
                            * if i % 2 == 0 { 1.0 } else { -1.0 }
                    } / 20.0;
                    pts.push((a.0 + t * dx - off * dy, a.1 + t * dy + off * dx));
                }
            }
            pts
        };
        let n = 4 * side;
        let pts = densified(0.0);
        let rings: Vec<Vec<[f64; 2]>> = vec![pts.iter().map(|p| [p.0, p.1]).collect()];
        assert!(mostly_in_line(&rings));
        let keep = points_off_line(&rings[0], IN_LINE_M);
        assert_eq!(keep.iter().filter(|&&k| k).count(), 4);
        assert!(roof_without_points_in_line(&rings).is_some());
        let fp = MultiPolygon(vec![Polygon::new(ring(&pts), vec![])]);
        let m = extrude(&fp, 0.0, 10.0).unwrap();
        check_prism(&fp, &m, 0.0, 10.0).unwrap();
        assert_eq!(m.triangles.len(), n - 2 + 2 * n);

        let hole = ring(&[(5.0, 5.0), (5.0, 15.0), (15.0, 15.0), (15.0, 5.0)]);
        let fp = MultiPolygon(vec![Polygon::new(ring(&densified(1e-4)), vec![hole])]);
        let m = extrude(&fp, 0.0, 10.0).unwrap();
        check_prism(&fp, &m, 0.0, 10.0).unwrap();
        let n = n + 4;
        assert_eq!(m.triangles.len(), n + 2 * n);
    }

    /// Points more than [`IN_LINE_M`] off the chord are kept; those within it are not.
    #[test]
    fn points_off_line_keeps_what_lies_off_the_chord() {
        let ring = [
            [0.0, 0.0],
            [5.0, 0.0011],
            [10.0, 0.0],
            [10.0, 10.0],
            [5.0, 10.0009],
            [0.0, 10.0],
        ];
        assert_eq!(
            points_off_line(&ring, IN_LINE_M),
            [true, true, true, true, false, true]
        );
    }

    #[test]
    fn clockwise_input_and_collinear_points_are_handled() {
        // Clockwise exterior with collinear points on every side and a near-duplicate corner.
        let outer = ring(&[
            (0.0, 0.0),
            (0.0, 5.0),
            (0.0, 10.0),
            (10.0, 10.0),
            (10.0, 10.0 + 1e-9),
            (10.0, 5.0),
            (10.0, 0.0),
            (5.0, 0.0),
        ]);
        let fp = MultiPolygon(vec![Polygon::new(outer, vec![])]);
        let m = extrude(&fp, 0.0, 3.0).unwrap();
        check_prism(&fp, &m, 0.0, 3.0).unwrap();
        assert_eq!(m.triangles.len() - 7 * 2, 5); // 7 walls; 7-gon with collinear points → 5 roof triangles
    }

    #[test]
    fn bad_input_gives_errors_not_panics() {
        let sq = MultiPolygon(vec![Polygon::new(
            ring(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)]),
            vec![],
        )]);
        assert!(matches!(
            extrude(&sq, 5.0, 5.0),
            Err(MeshError::NonPositiveHeight { .. })
        ));
        assert!(matches!(
            extrude(&sq, 0.0, f64::NAN),
            Err(MeshError::NonPositiveHeight { .. })
        ));
        let flat = MultiPolygon(vec![Polygon::new(
            ring(&[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)]),
            vec![],
        )]);
        assert_eq!(extrude(&flat, 0.0, 1.0), Err(MeshError::Empty));
        assert_eq!(
            extrude(&MultiPolygon(vec![]), 0.0, 1.0),
            Err(MeshError::Empty)
        );
        let crossing_hole = MultiPolygon(vec![Polygon::new(
            ring(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]),
            vec![ring(&[(8.0, 8.0), (8.0, 12.0), (12.0, 12.0), (12.0, 8.0)])],
        )]);
        // Even-odd roof: 100 m² square, minus the 4 m² overlap, plus the 12 m² of hole outside.
        let m = extrude(&crossing_hole, 0.0, 1.0).unwrap();
        let roof_m2: f64 = m
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&i| m.positions[i as usize][2] == 1.0))
            .map(|&t| tri_normal(&m, t)[2] / 2.0)
            .sum();
        assert!((roof_m2 - 108.0).abs() < 1e-9, "{roof_m2}");
        let bowtie = MultiPolygon(vec![Polygon::new(
            ring(&[(0.0, 0.0), (2.0, 2.0), (2.0, 0.0), (0.0, 2.0), (-1.0, 1.0)]),
            vec![],
        )]);
        assert!(extrude(&bowtie, 0.0, 1.0).is_ok());
        let nan = MultiPolygon(vec![Polygon::new(
            ring(&[(0.0, 0.0), (f64::NAN, 0.0), (1.0, 1.0)]),
            vec![],
        )]);
        assert_eq!(
            extrude(&nan, 0.0, 1.0),
            Err(MeshError::NonFinite { polygon: 0 })
        );
    }

    #[test]
    fn hole_touching_exterior_at_a_vertex_does_not_panic() {
        let outer = ring(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]);
        let hole = ring(&[(0.0, 0.0), (3.0, 6.0), (6.0, 3.0)]);
        let fp = MultiPolygon(vec![Polygon::new(outer, vec![hole])]);
        let m = extrude(&fp, 0.0, 1.0).unwrap();
        check_prism(&fp, &m, 0.0, 1.0).unwrap();
    }

    fn radii(n: std::ops::Range<usize>, lo: f64, hi: f64) -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec(lo..hi, n)
    }

    proptest! {
        #[test]
        fn random_polygons_with_holes_give_sound_prisms(
            outer in radii(12..40, 25.0, 60.0),
            hole in prop::option::of(radii(3..12, 2.0, 9.0)),
            second in prop::option::of(radii(3..20, 5.0, 30.0)),
            offset in (-1e4..1e4f64, -1e4..1e4f64),
            base in -50.0..50.0f64,
            height in 0.5..200.0f64,
            subdivide in any::<bool>(),
        ) {
            let mut holes = Vec::new();
            if let Some(h) = &hole {
                // Two holes side by side; both lie inside the outer ring's smallest radius (20 m).
                holes.push(star((offset.0 - 10.0, offset.1), h, false));
                holes.push(star((offset.0 + 10.0, offset.1), h, true)); // wrong orientation on purpose
            }
            let mut ext = star(offset, &outer, true);
            if subdivide {
                // Collinear midpoints on every edge.
                let mut v = Vec::new();
                for w in ext.0.windows(2) {
                    v.push(w[0]);
                    v.push(Coord { x: (w[0].x + w[1].x) / 2.0, y: (w[0].y + w[1].y) / 2.0 });
                }
                v.push(v[0]);
                ext = LineString(v);
            }
            let mut polys = vec![Polygon::new(ext, holes)];
            if let Some(s) = &second {
                polys.push(Polygon::new(star((offset.0 + 200.0, offset.1), s, false), vec![]));
            }
            let fp = MultiPolygon(polys);
            let m = extrude(&fp, base, base + height).unwrap();
            if let Err(e) = check_prism(&fp, &m, base, base + height) {
                return Err(TestCaseError::fail(e));
            }
        }
    }

    /// Sum of the triangles' areas, and whether each is counter-clockwise with positive area.
    fn roof_area(roof: &Roof) -> (f64, bool) {
        let tri = |t: &[u32; 3]| signed_area2(&t.map(|k| roof.0[k as usize])) / 2.0;
        (
            roof.1.iter().map(tri).sum(),
            roof.1.iter().all(|t| tri(t) > 0.0),
        )
    }

    #[test]
    fn convex_rings_are_fanned_and_others_are_not() {
        let square = vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]];
        assert!(is_strictly_convex(&square));
        let (area, positive) = roof_area(&fan(&square));
        assert!(positive && area == 16.0);
        // A collinear corner, a reflex corner, a pentagram (left turns only, but twice around).
        let collinear = vec![[0.0, 0.0], [2.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]];
        let reflex = vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [2.0, 1.0], [0.0, 4.0]];
        let pentagram: Vec<[f64; 2]> = (0..5)
            .map(|k| {
                let a = std::f64::consts::TAU * (2 * k) as f64 / 5.0;
                [a.cos(), a.sin()]
            })
            .collect();
        for ring in [&collinear, &reflex, &pentagram] {
            assert!(!is_strictly_convex(ring), "{ring:?}");
        }
    }

    #[test]
    fn ear_clipping_covers_simple_rings_and_declines_the_rest() {
        // A comb: five teeth, reflex corners between them, collinear points along its back.
        let mut comb = vec![[0.0, 0.0], [5.0, 0.0], [10.0, 0.0]];
        for k in (0..5).rev() {
            let x = 2.0 * k as f64;
            comb.extend([[x + 2.0, 6.0], [x + 1.0, 6.0], [x + 1.0, 2.0], [x, 2.0]]);
        }
        comb.pop();
        comb.push([0.0, 6.0]);
        let n = comb.len();
        let expected = signed_area2(&comb) / 2.0;
        let roof = ear_clip(&comb).expect("a simple ring");
        assert_eq!(roof.1.len(), n - 2);
        let (area, positive) = roof_area(&roof);
        assert!(positive);
        assert!((area - expected).abs() < 1e-9, "{area} vs {expected}");

        let bow_tie = vec![[0.0, 0.0], [4.0, 4.0], [4.0, 0.0], [0.0, 4.0]];
        let fold_back = vec![[0.0, 0.0], [4.0, 0.0], [2.0, 0.0], [2.0, 3.0]];
        let touching = vec![
            [0.0, 0.0],
            [4.0, 0.0],
            [2.0, 2.0],
            [4.0, 4.0],
            [0.0, 4.0],
            [2.0, 2.0],
        ];
        for ring in [&bow_tie, &fold_back, &touching] {
            assert!(!is_simple(ring), "{ring:?}");
            assert!(ear_clip(ring).is_none());
        }
        let too_many: Vec<[f64; 2]> = (0..EAR_MAX_POINTS + 1)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / (EAR_MAX_POINTS + 1) as f64;
                let r = if k % 2 == 0 { 10.0 } else { 6.0 };
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        assert!(ear_clip(&too_many).is_none());
    }

    proptest! {
        /// Star-shaped rings (simple by construction), with collinear midpoints or not: the ears cover
        /// them exactly with n − 2 positive triangles.
        #[test]
        fn ear_clipping_covers_random_star_rings(
            radii in radii(3..60, 1.0, 40.0),
            offset in (-1e4..1e4f64, -1e4..1e4f64),
            subdivide in any::<bool>(),
        ) {
            let n = radii.len();
            let mut ring: Vec<[f64; 2]> = radii
                .iter()
                .enumerate()
                .map(|(k, r)| {
                    let a = std::f64::consts::TAU * k as f64 / n as f64;
                    [offset.0 + r * a.cos(), offset.1 + r * a.sin()]
                })
                .collect();
            if subdivide {
                ring = (0..n)
                    .flat_map(|k| {
                        let (p, q) = (ring[k], ring[(k + 1) % n]);
                        [p, [(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0]]
                    })
                    .collect();
            }
            prop_assume!(ring.len() <= EAR_MAX_POINTS && is_simple(&ring));
            let roof = ear_clip(&ring).ok_or_else(|| TestCaseError::fail("no ear found"))?;
            prop_assert_eq!(roof.1.len(), ring.len() - 2);
            let (area, positive) = roof_area(&roof);
            prop_assert!(positive);
            let expected = signed_area2(&ring) / 2.0;
            prop_assert!((area - expected).abs() <= 1e-9 * expected.abs().max(1.0), "{} vs {}", area, expected);
        }
    }

    /// Every Boston footprint (holes, self-touching rings, duplicate points) extrudes; all but the
    /// known self-overlapping ones meet every invariant. Skips when ../shared/data is absent.
    #[test]
    fn boston_footprints_extrude_soundly() {
        let Some(path) = citylod_testdata::shared_data("boston/boston_buildings.geojson") else {
            return;
        };
        let text = std::fs::read_to_string(path).unwrap();
        let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
        let (lon0, lat0) = (-71.07f64, 42.35f64);
        let (kx, ky) = (111_319.49 * lat0.to_radians().cos(), 111_132.95);
        let ring_of = |r: &serde_json::Value| {
            LineString(
                r.as_array()
                    .unwrap()
                    .iter()
                    .map(|c| Coord {
                        x: (c[0].as_f64().unwrap() - lon0) * kx,
                        y: (c[1].as_f64().unwrap() - lat0) * ky,
                    })
                    .collect(),
            )
        };
        let poly_of = |p: &serde_json::Value| {
            let rings = p.as_array().unwrap();
            Polygon::new(ring_of(&rings[0]), rings[1..].iter().map(ring_of).collect())
        };
        let (mut ok, mut errors, mut triangles) = (0, Vec::new(), 0);
        for (i, f) in doc["features"].as_array().unwrap().iter().enumerate() {
            let g = &f["geometry"];
            let fp = match g["type"].as_str() {
                Some("Polygon") => MultiPolygon(vec![poly_of(&g["coordinates"])]),
                Some("MultiPolygon") => MultiPolygon(
                    g["coordinates"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(poly_of)
                        .collect(),
                ),
                _ => continue,
            };
            let m = extrude(&fp, 0.0, 10.0).unwrap_or_else(|e| panic!("feature {i}: {e}"));
            triangles += m.triangles.len();
            match check_prism_tol(&fp, &m, 0.0, 10.0, 1e-6) {
                Ok(()) => ok += 1,
                Err(e) => errors.push((i, e)),
            }
        }
        eprintln!("boston: {ok} sound prisms, {triangles} triangles, unsound: {errors:?}");
        // Rings of these features run back over themselves (found with a strict crossing check).
        let self_overlapping = [510, 4560, 7798, 7833, 11172, 11200, 18402];
        assert!(
            errors.iter().all(|(i, _)| self_overlapping.contains(i)),
            "{errors:?}"
        );
        assert!(ok >= 22_186 - self_overlapping.len(), "{ok}");
    }
}
