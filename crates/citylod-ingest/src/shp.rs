//! Esri Shapefile input: the `.shp` geometry and the `.dbf` attribute table beside it, read by this module's own
//! parser (the Esri Shapefile Technical Description of 1998 and the dBase III table layout), with the code page from
//! a `.cpg` or the table's language driver byte and the CRS from a `.prj` (see `prj`).
//!
//! Nothing is dropped without a word: a shape that cannot become a footprint (a null shape, a line, a record whose
//! counts do not fit its length) is a skipped feature with the reason; a record the `.dbf` marks deleted is skipped
//! as `deleted_record`; a cell that does not read as its field's type is kept as its text and reported; a `.shp` and
//! a `.dbf` of different lengths, or either cut short, refuse the file.
//!
//! Rings: a shapefile's outer rings run clockwise and its holes counter-clockwise, in any order. As GDAL does, every
//! clockwise ring is an outer ring, and a counter-clockwise one a hole of the smallest outer ring holding it (so an
//! island in a courtyard is a polygon of its own); a counter-clockwise ring no outer ring holds is an outer ring
//! wound the wrong way (repaired and counted later as any misoriented ring).

use crate::feature::{ring_box, RawFeature, RawPolygon, VectorDoc};
use crate::report::IssueReason;
use crate::surface_model::Face;
use citylod_mesh::signed_area2;
use citylod_model::{AttrValue, Attributes};
use std::path::{Path, PathBuf};

/// The extensions of a shapefile's other files, each with what it is, for refusing one given as the input.
pub(crate) const SIDECARS: [(&str, &str); 7] = [
    ("dbf", "attribute table"),
    ("shx", "shape index"),
    ("prj", "CRS definition"),
    ("cpg", "code page"),
    ("sbn", "spatial index"),
    ("sbx", "spatial index"),
    ("qix", "spatial index"),
];

/// Reads `path` (a `.shp`) with its `.dbf`, `.prj` and `.cpg`. Errors name what is wrong with the file as a whole;
/// one unusable record is a skipped feature.
pub(crate) fn read(path: &Path) -> Result<VectorDoc, String> {
    let read = |p: &Path| std::fs::read(p).map_err(|e| format!("{}: {e}", p.display()));
    let shp = read(path)?;
    let (shapes, layout_note) = shapes(&shp).map_err(|e| format!("the .shp {e}"))?;
    let dbf_path = sidecar(path, "dbf").ok_or_else(|| {
        "its attribute table (a .dbf of the same name beside it) is missing; a shapefile is read with its .dbf"
            .to_string()
    })?;
    let cpg = match sidecar(path, "cpg") {
        Some(p) => Some(String::from_utf8_lossy(&read(&p)?).into_owned()),
        None => None,
    };
    let dbf_bytes = read(&dbf_path)?;
    let table = Table::parse(&dbf_bytes, cpg.as_deref()).map_err(|e| format!("the .dbf {e}"))?;
    if table.count != shapes.len() {
        return Err(format!(
            "the .shp holds {} shape(s) and its .dbf {} record(s): they pair one to one, so one of the two is cut \
             short or belongs to another file",
            shapes.len(),
            table.count
        ));
    }
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut notes: Vec<String> = layout_note
        .into_iter()
        .chain(table.notes.iter().cloned())
        .collect();
    let mut features = Vec::with_capacity(shapes.len());
    let mut surfaces = Vec::new();
    for (index, shape) in shapes.into_iter().enumerate() {
        let (attributes, repairs, deleted) = table.record(index);
        let mut out = RawFeature {
            source_id: crate::feature::source_id(&attributes, &file_name, index),
            attributes,
            repairs,
            ..Default::default()
        };
        // Records are counted from 1 (the .shp numbers them so); GDAL's feature ids (FID) from 0.
        let record = format!("record {} (FID {index})", index + 1);
        if deleted {
            out.skip = Some((
                IssueReason::DeletedRecord,
                format!("{record} is marked deleted in the .dbf"),
            ));
        } else {
            match shape {
                Ok(Read::Surfaces(faces)) => surfaces.push((index, record, faces)),
                Ok(Read::Footprint(polygons, repairs)) => {
                    out.polygons = polygons;
                    out.repairs.extend(repairs);
                }
                Ok(Read::Lines(lines, name)) => {
                    out.lines = lines;
                    out.skip = Some((
                        IssueReason::UnsupportedGeometry,
                        format!("{record}: {name} shape, not a polygon"),
                    ));
                }
                Err((reason, detail)) => out.skip = Some((reason, format!("{record}: {detail}"))),
            }
        }
        features.push(out);
    }
    let mut z_unit_m = None;
    let declared_crs = match sidecar(path, "prj") {
        Some(p) => {
            let bytes = read(&p)?;
            // A .prj written as UTF-16 (some Windows tools) is read as such; any other as UTF-8.
            let text = match bytes.get(..2) {
                Some([0xFF, 0xFE]) => encoding_rs::UTF_16LE.decode_with_bom_removal(&bytes).0,
                Some([0xFE, 0xFF]) => encoding_rs::UTF_16BE.decode_with_bom_removal(&bytes).0,
                _ => String::from_utf8_lossy(&bytes),
            };
            let (crs, note) = crate::prj::declared_crs(&text, &crate::prj::PRJ);
            notes.extend(note);
            let (unit, note) = crate::prj::vertical_unit_m(&text);
            z_unit_m = unit;
            notes.extend(note);
            Some(crs)
        }
        None => None,
    };
    Ok(VectorDoc {
        features,
        surfaces,
        declared_crs,
        z_unit_m,
        notes,
    })
}

/// The file beside `shp` with the same name and extension `ext`, the extension in any case (`.DBF` beside `.SHP`);
/// the name in another case only when there is no exact match.
fn sidecar(shp: &Path, ext: &str) -> Option<PathBuf> {
    let stem = shp.file_stem()?.to_string_lossy().into_owned();
    let dir = match shp.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut candidates: Vec<(bool, PathBuf)> = std::fs::read_dir(&dir)
        .ok()?
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.is_file())
        .filter_map(|p| {
            let e = p.extension()?.to_string_lossy().into_owned();
            let s = p.file_stem()?.to_string_lossy().into_owned();
            (e.eq_ignore_ascii_case(ext) && s.eq_ignore_ascii_case(&stem)).then_some((s != stem, p))
        })
        .collect();
    candidates.sort();
    candidates.into_iter().next().map(|(_, p)| p)
}

// --- the .shp ---

/// A record's footprint polygons (open rings in the OGC's winding) with the repairs made, or why it has none.
type ShapeResult = Result<Read, (IssueReason, String)>;

/// What a record holds.
enum Read {
    /// Polygon footprints and the repairs made reading them.
    Footprint(Vec<RawPolygon>, Vec<(IssueReason, String)>),
    /// A MultiPatch's faces.
    Surfaces(Vec<Face>),
    /// A PolyLine's parts (x, y), and the shape's name for the skip a building gets: what `--streets` reads.
    Lines(Vec<Vec<[f64; 2]>>, &'static str),
}

fn be_i32(b: &[u8], at: usize) -> Option<i32> {
    Some(i32::from_be_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

fn le_i32(b: &[u8], at: usize) -> Option<i32> {
    Some(i32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

fn le_f64(b: &[u8], at: usize) -> Option<f64> {
    Some(f64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
}

/// Every record of a `.shp`, in order, and a note when the header's length disagrees with the records. Errors are
/// for the file as a whole (not a shapefile, cut short); a record's own trouble is its skip reason.
///
/// The header's file length is not trusted alone (writers leave it stale): records are read to the end of the file.
/// Past the length the header gives, only whole records numbered in sequence count (a stale header after an
/// append); anything else there ends the records (padding), and non-zero bytes left are said in the note. A record
/// cut short before that length is an error.
fn shapes(b: &[u8]) -> Result<(Vec<ShapeResult>, Option<String>), String> {
    const HEADER: usize = 100;
    if b.len() < HEADER || be_i32(b, 0) != Some(9994) {
        return Err(format!(
            "is not a shapefile: it does not start with the 100-byte header whose first four bytes hold 9994 \
             ({} bytes in all)",
            b.len()
        ));
    }
    let declared = (be_i32(b, 24).unwrap_or(0).max(0) as usize)
        .saturating_mul(2)
        .max(HEADER);
    let mut out = Vec::new();
    let mut at = HEADER;
    while at < b.len() {
        let n = out.len() + 1;
        let len = be_i32(b, at + 4)
            .filter(|_| at + 8 <= b.len())
            .and_then(|w| usize::try_from(w).ok())
            .and_then(|w| w.checked_mul(2))
            .filter(|l| at + 8 + l <= b.len());
        let in_sequence = be_i32(b, at) == i32::try_from(n).ok();
        match len {
            Some(len) if at < declared || (in_sequence && len >= 4) => {
                out.push(shape(&b[at + 8..at + 8 + len]));
                at += 8 + len;
            }
            _ if at < declared => {
                // A record header whose content length no record can have (negative, or ending past both the file
                // and the length its header gives it) is a damaged record, not a file cut short.
                let words = be_i32(b, at + 4).filter(|_| at + 8 <= b.len());
                let room = b.len().saturating_sub(at + 8);
                return Err(match words {
                    Some(w) if w < 0 => format!(
                        "is damaged: its record {n} (at byte {at}) gives its content length as {w} 16-bit words, \
                         a negative length no record can have, so its records from {n} on cannot be found; write \
                         the shapefile again from its source"
                    ),
                    Some(w) if at as u64 + 8 + 2 * w as u64 > declared.max(b.len()) as u64 => format!(
                        "is damaged: its record {n} (at byte {at}) gives its content length as {w} 16-bit words \
                         ({} bytes), more than the {room} bytes after it (its header gives the file {declared} \
                         bytes, it has {}): an impossible length, so its records from {n} on cannot be found; write \
                         the shapefile again from its source",
                        2 * w as u64,
                        b.len()
                    ),
                    _ => format!(
                        "is cut short: record {n} starts {} bytes before the end of the file and does not fit in \
                         them (its header gives the file {declared} bytes, it has {})",
                        b.len() - at,
                        b.len()
                    ),
                });
            }
            _ => break,
        }
    }
    let note = if at < b.len() && b[at..].iter().any(|&c| c != 0) {
        Some(format!(
            "the .shp's last {} bytes, after its records, are not records and were not read",
            b.len() - at
        ))
    } else if at != declared {
        Some(format!(
            "the .shp's header gives it {declared} bytes; its {} records take {at}, all read",
            out.len()
        ))
    } else {
        None
    };
    Ok((out, note))
}

/// The name of a shape type, for skip reasons.
fn type_name(t: i32) -> Option<&'static str> {
    Some(match t {
        0 => "null",
        1 => "Point",
        3 => "PolyLine",
        5 => "Polygon",
        8 => "MultiPoint",
        11 => "PointZ",
        13 => "PolyLineZ",
        15 => "PolygonZ",
        18 => "MultiPointZ",
        21 => "PointM",
        23 => "PolyLineM",
        25 => "PolygonM",
        28 => "MultiPointM",
        31 => "MultiPatch",
        _ => return None,
    })
}

/// One record's content (from its shape type on).
fn shape(c: &[u8]) -> ShapeResult {
    let malformed = |d: String| Err((IssueReason::MalformedGeometry, d));
    let Some(t) = le_i32(c, 0) else {
        return malformed(format!(
            "a record of {} bytes, too short for a shape type",
            c.len()
        ));
    };
    match (t, type_name(t)) {
        (0, _) => Err((IssueReason::NoGeometry, "null shape".into())),
        (5 | 15 | 25, _) => polygon(c),
        (31, _) => multipatch(c),
        (3 | 13 | 23, Some(name)) => polyline(c, name),
        (_, Some(name)) => Err((
            IssueReason::UnsupportedGeometry,
            format!("{name} shape, not a polygon"),
        )),
        (_, None) => malformed(format!("unknown shape type {t}")),
    }
}

/// The part and point counts of a polygon or MultiPatch record (`what`) and where its parts start, checked against the
/// record's length: `per_part` and `per_point` bytes each after the 44-byte head, then `tail` bytes. Parts of no points
/// are allowed where `empty_parts` (a MultiPatch's), else every part starts after the one before.
fn parts(
    c: &[u8],
    what: &str,
    (per_part, per_point, tail): (u64, u64, u64),
    empty_parts: bool,
) -> Result<(usize, Vec<usize>), (IssueReason, String)> {
    let malformed = |d: String| Err((IssueReason::MalformedGeometry, d));
    let (Some(parts), Some(points)) = (le_i32(c, 36), le_i32(c, 40)) else {
        return malformed(format!(
            "a {what} record of {} bytes, too short for its counts",
            c.len()
        ));
    };
    if parts < 0 || points < 0 {
        return malformed(format!("a {what} of {parts} parts and {points} points"));
    }
    let need = 44 + per_part * parts as u64 + per_point * points as u64 + tail;
    if need > c.len() as u64 {
        return malformed(format!(
            "a {what} of {parts} parts and {points} points needs {need} bytes, its record holds {}",
            c.len()
        ));
    }
    if parts == 0 || points == 0 {
        return Err((IssueReason::EmptyGeometry, format!("{what} without parts")));
    }
    let (parts, points) = (parts as usize, points as usize);
    let starts: Vec<usize> = (0..parts)
        .map(|k| le_i32(c, 44 + 4 * k).unwrap_or(-1) as i64 as usize)
        .collect();
    let valid = starts[0] == 0
        && starts
            .windows(2)
            .all(|w| w[0] < w[1] || (empty_parts && w[0] == w[1]))
        && starts.last().is_some_and(|&s| s < points);
    if !valid {
        let shown: Vec<String> = starts
            .iter()
            .take(8)
            .map(|s| (*s as i64).to_string())
            .collect();
        return malformed(format!(
            "part starts {} are not increasing from 0 below its {points} points",
            shown.join(", ")
        ));
    }
    Ok((points, starts))
}

/// The x, y points of each part of a polygon or PolyLine record (`what`), Z and M values not read.
fn plan_parts(c: &[u8], what: &str) -> Result<Vec<Vec<[f64; 2]>>, (IssueReason, String)> {
    let (points, starts) = parts(c, what, (4, 16, 0), false)?;
    let xy = 44 + 4 * starts.len();
    let point = |i: usize| -> [f64; 2] {
        let at = xy + 16 * i;
        [
            le_f64(c, at).unwrap_or(f64::NAN),
            le_f64(c, at + 8).unwrap_or(f64::NAN),
        ]
    };
    Ok((0..starts.len())
        .map(|k| {
            let end = starts.get(k + 1).copied().unwrap_or(points);
            (starts[k]..end).map(point).collect()
        })
        .collect())
}

/// A Polygon, PolygonZ or PolygonM record (Z and M values are not read: a footprint is flat).
fn polygon(c: &[u8]) -> ShapeResult {
    let mut repairs = Vec::new();
    let mut rings = plan_parts(c, "polygon")?;
    for (k, r) in rings.iter_mut().enumerate() {
        open_ring(r, k, &mut repairs);
    }
    Ok(Read::Footprint(organize(rings), repairs))
}

/// A PolyLine, PolyLineZ or PolyLineM record (`name`): its parts in plan.
fn polyline(c: &[u8], name: &'static str) -> ShapeResult {
    Ok(Read::Lines(plan_parts(c, name)?, name))
}

/// Ring `k` of a record as an open ring: its closing point dropped, or a repair said when it had none.
pub(crate) fn open_ring(r: &mut Vec<[f64; 2]>, k: usize, repairs: &mut Vec<(IssueReason, String)>) {
    if r.len() > 1 && r.first() == r.last() {
        r.pop();
    } else if r.len() >= 3 {
        repairs.push((
            IssueReason::RingClosed,
            format!("ring {} was not closed; closed it", k + 1),
        ));
    }
}

/// A MultiPatch record's faces: triangle strips, fans and lists as triangles, an outer ring with the inner rings
/// after it (or a first ring with the rings after it) as one face with holes, a ring alone as a face. Triangles
/// without area (a strip's restarts) are left out; M values are not read.
fn multipatch(c: &[u8]) -> ShapeResult {
    // Part starts and types, x, y, the z range and z: the M range and values may follow.
    let (points, starts) = parts(c, "MultiPatch", (8, 24, 16), true)?;
    let parts = starts.len();
    let int = |at: usize| le_i32(c, at).unwrap_or(-1);
    let xy = 44 + 8 * parts;
    let z = xy + 16 * points + 16;
    let point = |i: usize| -> [f64; 3] {
        let f = |at: usize| le_f64(c, at).unwrap_or(f64::NAN);
        [f(xy + 16 * i), f(xy + 16 * i + 8), f(z + 8 * i)]
    };
    let mut read_parts = Vec::with_capacity(parts);
    for k in 0..parts {
        let end = starts.get(k + 1).copied().unwrap_or(points);
        let pts: Vec<[f64; 3]> = (starts[k]..end).map(point).collect();
        if pts.iter().flatten().any(|v| !v.is_finite()) {
            return Err((
                IssueReason::NonFiniteCoordinate,
                format!("part {} has a vertex that is not a finite number", k + 1),
            ));
        }
        // Esri's extended MultiPatch keeps flags in the high bits; the part type is the low four (as GDAL reads it).
        read_parts.push(((int(44 + 4 * parts + 4 * k) & 0xf) as i64, pts));
    }
    multipatch_faces(read_parts).map(Read::Surfaces)
}

/// A MultiPatch's parts (type, points) as faces: triangle strips, fans and lists as triangles, an outer ring with the
/// inner rings after it (or a first ring with the rings after it) as one face with holes, a ring alone as a face.
/// Triangles without area (a strip's restarts) are left out. Shared by shapefiles and File Geodatabases.
pub(crate) fn multipatch_faces(
    parts: Vec<(i64, Vec<[f64; 3]>)>,
) -> Result<Vec<Face>, (IssueReason, String)> {
    let malformed = |d: String| Err((IssueReason::MalformedGeometry, d));
    let mut faces: Vec<Face> = Vec::new();
    // The face a ring part joins: an outer or first ring opens one, an inner ring or ring after it adds a hole.
    let mut open_face: Option<i64> = None;
    for (k, (kind, pts)) in parts.into_iter().enumerate() {
        let triangle = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| -> Option<Face> {
            let (u, v) = (
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            (n.iter().any(|x| *x != 0.0)).then(|| vec![vec![a, b, c]])
        };
        match kind {
            // Triangle strip: every three consecutive points, every other one turned to keep the winding.
            0 => {
                open_face = None;
                for i in 2..pts.len() {
                    let (a, b) = if i % 2 == 0 {
                        (pts[i - 2], pts[i - 1])
                    } else {
                        (pts[i - 1], pts[i - 2])
                    };
                    faces.extend(triangle(a, b, pts[i]));
                }
            }
            // Triangle fan about the first point.
            1 => {
                open_face = None;
                for i in 2..pts.len() {
                    faces.extend(triangle(pts[0], pts[i - 1], pts[i]));
                }
            }
            // Triangles, three points each (a later addition to the format).
            6 => {
                open_face = None;
                if !pts.len().is_multiple_of(3) {
                    return malformed(format!(
                        "part {} lists triangles in {} points, not a multiple of 3",
                        k + 1,
                        pts.len()
                    ));
                }
                for t in pts.chunks_exact(3) {
                    faces.extend(triangle(t[0], t[1], t[2]));
                }
            }
            2..=5 => {
                let mut ring = pts;
                if ring.len() > 1 && ring.first() == ring.last() {
                    ring.pop();
                }
                // An inner ring or a ring after an outer or first ring is a hole of its face (as GDAL reads them);
                // one with no face open is a face of its own.
                match (kind, open_face, faces.last_mut()) {
                    (3 | 5, Some(_), Some(face)) => face.push(ring),
                    _ => {
                        faces.push(vec![ring]);
                        open_face = matches!(kind, 2 | 4).then_some(kind);
                    }
                }
            }
            t => {
                return malformed(format!(
                    "part {} is of type {t}, which MultiPatch does not define",
                    k + 1
                ))
            }
        }
    }
    if faces.is_empty() {
        return Err((
            IssueReason::EmptyGeometry,
            "MultiPatch whose parts have no area".into(),
        ));
    }
    Ok(faces)
}

/// Where `p` lies against the open ring `r`: `Some(true)` inside, `Some(false)` outside, `None` on its boundary.
pub(crate) fn locate(p: [f64; 2], r: &[[f64; 2]]) -> Option<bool> {
    let n = r.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (r[i], r[(i + 1) % n]);
        let cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        if cross == 0.0
            && p[0] >= a[0].min(b[0])
            && p[0] <= a[0].max(b[0])
            && p[1] >= a[1].min(b[1])
            && p[1] <= a[1].max(b[1])
        {
            return None;
        }
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    Some(inside)
}

/// Whether ring `inner` lies inside ring `outer`: its first point not on `outer`'s boundary decides (rings of one
/// valid polygon do not cross); a ring all on the boundary counts as inside. At most `TRIED` points, spread over the
/// ring, are tried (a hole tracing its outer ring would otherwise cost the square of their points).
fn holds(outer: &[[f64; 2]], outer_box: [f64; 4], inner: &[[f64; 2]], inner_box: [f64; 4]) -> bool {
    let boxed = inner_box[0] >= outer_box[0]
        && inner_box[1] >= outer_box[1]
        && inner_box[2] <= outer_box[2]
        && inner_box[3] <= outer_box[3];
    const TRIED: usize = 16;
    let step = inner.len().div_ceil(TRIED).max(1);
    boxed
        && inner
            .iter()
            .step_by(step)
            .find_map(|&p| locate(p, outer))
            .unwrap_or(true)
}

/// Polygons from a record's rings in a shapefile's winding: clockwise rings are outer rings, each counter-clockwise
/// ring joins the smallest outer ring holding it, or is an outer ring (wound the wrong way) when none does. Rings
/// come out reversed, in the OGC's winding (outer counter-clockwise), so only a ring wound against the shapefile's
/// rule is later reoriented and counted.
///
/// A record whose every ring is wound against the rule (outer rings counter-clockwise, holes clockwise, as GeoJSON
/// has them — some writers copy rings as they come) is read with the winding the other way round, so that its
/// courtyards stay courtyards; its rings are then all counted as reoriented. Told by nesting depth (an outer ring
/// is held by an even number of the record's rings), for records of up to `NESTING_CHECKED` rings.
pub(crate) fn organize(rings: Vec<Vec<[f64; 2]>>) -> Vec<RawPolygon> {
    const NESTING_CHECKED: usize = 512;
    let mut area: Vec<f64> = rings.iter().map(|r| signed_area2(r)).collect();
    let boxes: Vec<[f64; 4]> = rings.iter().map(|r| ring_box(r)).collect();
    let n = rings.len();
    if (2..=NESTING_CHECKED).contains(&n) {
        let depth: Vec<usize> = (0..n)
            .map(|k| {
                (0..n)
                    .filter(|&o| {
                        o != k
                            && area[o].abs() > area[k].abs()
                            && holds(&rings[o], boxes[o], &rings[k], boxes[k])
                    })
                    .count()
            })
            .collect();
        let wound_against = (0..n).all(|k| depth[k].is_multiple_of(2) == (area[k] > 0.0));
        if wound_against && area.iter().any(|a| *a < 0.0) {
            area.iter_mut().for_each(|a| *a = -*a);
        }
    }
    let area = area;
    // A ring without area (or with non-finite points) is an outer ring: ingest's checks then say what is wrong.
    let is_hole = |k: usize| area[k] > 0.0;
    let mut owner: Vec<Option<usize>> = vec![None; rings.len()];
    for h in (0..rings.len()).filter(|&k| is_hole(k)) {
        owner[h] = (0..rings.len())
            .filter(|&o| !is_hole(o) && holds(&rings[o], boxes[o], &rings[h], boxes[h]))
            .min_by(|&a, &b| area[a].abs().total_cmp(&area[b].abs()).then(a.cmp(&b)));
    }
    let mut index_of = vec![usize::MAX; rings.len()];
    let mut polygons: Vec<RawPolygon> = Vec::new();
    for k in 0..rings.len() {
        if owner[k].is_none() {
            index_of[k] = polygons.len();
            polygons.push(Vec::new());
        }
    }
    for (k, mut r) in rings.into_iter().enumerate() {
        r.reverse();
        let p = match owner[k] {
            Some(o) => index_of[o],
            None => index_of[k],
        };
        if owner[k].is_none() {
            polygons[p].insert(0, r);
        } else {
            polygons[p].push(r);
        }
    }
    polygons
}

// --- the .dbf ---

/// How a table's text is decoded.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Codec {
    Utf8,
    /// ISO-8859-1: each byte is the code point of the same number.
    Latin1,
    Other(&'static encoding_rs::Encoding),
    /// A DOS code page citylod has no table for: ASCII read, other bytes replaced and reported.
    AsciiOnly(u16),
}

impl Codec {
    /// A `.cpg`'s text (`UTF-8`, `1252`, `ISO-8859-1`, `LATIN1`, `windows-1251`, `936`, …).
    fn from_cpg(text: &str) -> Option<Codec> {
        let t = text.trim().trim_start_matches('\u{feff}').trim();
        let key: String = t
            .chars()
            .filter(|c| c.is_ascii_alphanumeric())
            .collect::<String>()
            .to_ascii_uppercase();
        match key.as_str() {
            "UTF8" | "65001" => return Some(Codec::Utf8),
            "LATIN1" | "88591" | "ISO88591" | "28591" => return Some(Codec::Latin1),
            "437" | "CP437" | "IBM437" => return Some(Codec::AsciiOnly(437)),
            "850" | "CP850" | "IBM850" => return Some(Codec::AsciiOnly(850)),
            "852" | "CP852" | "IBM852" => return Some(Codec::AsciiOnly(852)),
            "865" | "CP865" | "IBM865" => return Some(Codec::AsciiOnly(865)),
            _ => {}
        }
        // A bare Windows or ISO number: 1250–1258, 874, 932, 936, 949, 950, 866, 8859-n (885915, 28592).
        let digits = key.trim_start_matches("CP").trim_start_matches("ANSI");
        if digits.bytes().all(|b| b.is_ascii_digit()) && !digits.is_empty() {
            if let Some(n) = digits
                .strip_prefix("8859")
                .or_else(|| digits.strip_prefix("2859"))
            {
                return encoding_rs::Encoding::for_label(format!("iso-8859-{n}").as_bytes())
                    .map(Codec::Other);
            }
            return Codec::from_code_page(digits.parse().ok()?);
        }
        // Labels encoding_rs maps to its replacement decoder (ISO-2022-KR, HZ) or to UTF-16 name no code page a
        // dBase table can be in.
        encoding_rs::Encoding::for_label(t.as_bytes())
            .filter(|e| {
                ![
                    encoding_rs::REPLACEMENT,
                    encoding_rs::UTF_16LE,
                    encoding_rs::UTF_16BE,
                ]
                .contains(e)
            })
            .map(|e| {
                if e == encoding_rs::UTF_8 {
                    Codec::Utf8
                } else {
                    Codec::Other(e)
                }
            })
    }

    fn from_code_page(n: u32) -> Option<Codec> {
        let label = match n {
            65001 => return Some(Codec::Utf8),
            437 | 737 | 850 | 852 | 857 | 861 | 865 => return Some(Codec::AsciiOnly(n as u16)),
            866 => "ibm866",
            874 => "windows-874",
            932 => "shift_jis",
            936 => "gbk",
            949 => "euc-kr",
            950 => "big5",
            1250..=1258 => {
                return encoding_rs::Encoding::for_label(format!("windows-{n}").as_bytes())
                    .map(Codec::Other)
            }
            _ => return None,
        };
        encoding_rs::Encoding::for_label(label.as_bytes()).map(Codec::Other)
    }

    /// The code page a dBase language driver id (byte 29 of the header) names; `None` for 0 (none) or one unknown.
    fn from_ldid(id: u8) -> Option<Codec> {
        let page = match id {
            0x01 => 437,
            0x02 => 850,
            0x26 | 0x65 => 866,
            0x64 | 0x87 => 852,
            0x67 => 861,
            0x6A | 0x86 => 737,
            0x6B | 0x88 => 857,
            0x03 | 0x57 | 0x58 | 0x59 => 1252,
            0x66 => 865,
            0x78 | 0x4F => 950,
            0x79 | 0x4E => 949,
            0x7A | 0x4D => 936,
            0x7B | 0x13 => 932,
            0x7C | 0x50 => 874,
            0x7D => 1255,
            0x7E => 1256,
            0xC8 => 1250,
            0xC9 => 1251,
            0xCA => 1254,
            0xCB => 1253,
            0xCC => 1257,
            _ => return None,
        };
        Codec::from_code_page(page)
    }

    fn name(self) -> String {
        match self {
            Codec::Utf8 => "UTF-8".into(),
            Codec::Latin1 => "ISO-8859-1".into(),
            Codec::Other(e) => e.name().into(),
            Codec::AsciiOnly(n) => format!("code page {n} (ASCII only)"),
        }
    }

    /// The text of `b`, and whether some bytes could not be decoded (replaced by U+FFFD).
    fn decode(self, b: &[u8]) -> (String, bool) {
        match self {
            Codec::Utf8 => match std::str::from_utf8(b) {
                Ok(s) => (s.to_string(), false),
                Err(_) => (String::from_utf8_lossy(b).into_owned(), true),
            },
            Codec::Latin1 => (b.iter().map(|&c| c as char).collect(), false),
            Codec::Other(e) => {
                let (s, had_errors) = e.decode_without_bom_handling(b);
                (s.into_owned(), had_errors)
            }
            Codec::AsciiOnly(_) => {
                let s: String = b
                    .iter()
                    .map(|&c| if c.is_ascii() { c as char } else { '\u{fffd}' })
                    .collect();
                (s, !b.is_ascii())
            }
        }
    }
}

/// A field of a dBase table.
struct Field {
    name: String,
    kind: u8,
    offset: usize,
    len: usize,
    decimals: u8,
}

/// A dBase table as shapefiles carry it (dBase III / IV and Visual FoxPro headers: 32-byte field descriptors).
struct Table<'a> {
    bytes: &'a [u8],
    fields: Vec<Field>,
    first: usize,
    record_len: usize,
    count: usize,
    codec: Codec,
    notes: Vec<String>,
}

impl<'a> Table<'a> {
    fn parse(b: &'a [u8], cpg: Option<&str>) -> Result<Table<'a>, String> {
        if b.len() < 32 {
            return Err(format!(
                "is cut short: {} bytes, less than a dBase header",
                b.len()
            ));
        }
        if b[0] & 0x07 == 0x04 {
            return Err(format!(
                "is a dBase 7 table (version byte {:#04x}); shapefiles carry dBase III or IV tables",
                b[0]
            ));
        }
        let count = u32::from_le_bytes(b[4..8].try_into().expect("4 bytes")) as usize;
        let header_len = u16::from_le_bytes([b[8], b[9]]) as usize;
        let record_len = u16::from_le_bytes([b[10], b[11]]) as usize;
        if header_len < 33 || header_len > b.len() {
            return Err(format!(
                "is broken: its header length {header_len} is not within its {} bytes",
                b.len()
            ));
        }
        let mut notes = Vec::new();
        // The field descriptors, names still as bytes (their code page is settled below).
        let mut raw: Vec<(Vec<u8>, u8, usize, u8)> = Vec::new();
        let mut offset = 1;
        let mut at = 32;
        while at + 32 <= header_len && b[at] != 0x0D {
            let d = &b[at..at + 32];
            let name = &d[..11];
            let name = name[..name.iter().position(|&c| c == 0).unwrap_or(11)].to_vec();
            // A text field wider than 255 bytes keeps its high byte where numbers keep their decimals (FoxPro,
            // shapelib).
            let (len, decimals) = match d[11] {
                b'C' => (d[16] as usize + 256 * d[17] as usize, 0),
                _ => (d[16] as usize, d[17]),
            };
            raw.push((name, d[11], offset, decimals));
            offset += len;
            at += 32;
        }
        let widths: Vec<usize> = raw
            .iter()
            .map(|r| r.2)
            .chain([offset])
            .collect::<Vec<_>>()
            .windows(2)
            .map(|w| w[1] - w[0])
            .collect();
        if offset > record_len {
            return Err(format!(
                "is broken: its fields take {offset} bytes a record, its header gives {record_len}"
            ));
        }
        if offset < record_len {
            notes.push(format!(
                "the .dbf's records are {record_len} bytes and its fields take {offset}: the last {} bytes of each \
                 record belong to no field and were not read",
                record_len - offset
            ));
        }
        let whole = (b.len() - header_len).checked_div(record_len).unwrap_or(0);
        if count > 0 && whole < count {
            return Err(format!(
                "is cut short: its header gives {count} records of {record_len} bytes, the file holds {whole}"
            ));
        }
        // The table's text, for telling UTF-8 from a single-byte code page: field names and text cells.
        let text_bytes = || {
            let mut t: Vec<u8> = raw.iter().flat_map(|r| r.0.iter().copied()).collect();
            for i in 0..count {
                let rec = &b[header_len + i * record_len..header_len + (i + 1) * record_len];
                for (r, w) in raw.iter().zip(&widths) {
                    if r.1 == b'C' {
                        t.extend_from_slice(&rec[r.2..r.2 + w]);
                    }
                }
            }
            t
        };
        let sniffed = || {
            let t = text_bytes();
            match std::str::from_utf8(&t) {
                Ok(_) => (Codec::Utf8, None),
                Err(_) => (
                    Codec::Other(encoding_rs::WINDOWS_1252),
                    Some("its text is not UTF-8, read as Windows-1252".to_string()),
                ),
            }
        };
        let cpg = cpg
            .map(|t| t.trim().trim_start_matches('\u{feff}').trim())
            .filter(|t| !t.is_empty());
        let codec = match cpg.map(|t| (t, t.to_ascii_uppercase())) {
            // The writer's own system code pages, which the file does not name.
            Some((_, u)) if u == "OEM" => Codec::AsciiOnly(437),
            Some((t, u)) if u == "SYSTEM" || u == "ANSI" => {
                let (c, why) = sniffed();
                notes.push(format!(
                    "the .cpg says {t:?} (the writer's system code page, not named): {}",
                    why.unwrap_or_else(|| "its text reads as UTF-8".into())
                ));
                c
            }
            Some((t, _)) => Codec::from_cpg(t).ok_or_else(|| {
                let shown: String = t.chars().take(40).collect();
                format!(
                    "is in the code page its .cpg names, {shown:?}, which citylod cannot decode (it reads UTF-8, Windows \
                     874 and 1250–1258, ISO-8859-x, IBM 866, Shift_JIS, GBK, Big5, EUC-KR and KOI8; write one of \
                     these in the .cpg, or convert the .dbf)"
                )
            })?,
            None => match Codec::from_ldid(b[29]) {
                Some(c) => {
                    // A code-page byte kept from an older file while the text was written as UTF-8 (the .cpg
                    // lost): said, not guessed over.
                    let t = text_bytes();
                    if c != Codec::Utf8 && !t.is_ascii() && std::str::from_utf8(&t).is_ok() {
                        notes.push(format!(
                            "the .dbf's header names {} but its text reads as UTF-8; read as {} (a .cpg saying \
                             UTF-8 would read it as UTF-8)",
                            c.name(),
                            c.name()
                        ));
                    }
                    c
                }
                // No code page named: UTF-8 when the table's text reads as UTF-8, else Windows-1252 (what Esri's
                // tools write); the report says which.
                None => {
                    let (c, why) = sniffed();
                    let named = match b[29] {
                        0 => "no .cpg and no code page in the .dbf".to_string(),
                        id => format!("no .cpg, and a code-page byte {id:#04x} citylod does not know"),
                    };
                    if let Some(why) = why {
                        notes.push(format!("{named}: {why}"));
                    } else if b[29] != 0 {
                        notes.push(format!("{named}: its text reads as UTF-8"));
                    }
                    c
                }
            },
        };
        if let Codec::AsciiOnly(n) = codec {
            notes.push(format!(
                "text in code page {n}: citylod reads its ASCII characters and reports the others as \
                 replaced (convert the .dbf to UTF-8 and write a .cpg saying UTF-8 to keep them)"
            ));
        }
        let mut fields: Vec<Field> = Vec::new();
        let mut taken = std::collections::HashSet::new();
        let mut copies: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
        let mut renamed_fields = Vec::new();
        for ((raw_name, kind, offset, decimals), len) in raw.into_iter().zip(widths) {
            let (name, replaced) = codec.decode(&raw_name);
            let mut name = name.trim().to_string();
            if replaced {
                notes.push(format!(
                    "field name {name:?} has bytes not in {}, replaced by U+FFFD",
                    codec.name()
                ));
            }
            if name.is_empty() {
                name = format!("field_{}", fields.len() + 1);
            }
            if taken.contains(&name) {
                let copy = copies.entry(name.clone()).or_insert(1);
                let renamed = loop {
                    *copy += 1;
                    let n = format!("{name}_{copy}");
                    if !taken.contains(&n) {
                        break n;
                    }
                };
                renamed_fields.push(format!("{name} → {renamed}"));
                name = renamed;
            }
            taken.insert(name.clone());
            fields.push(Field {
                name,
                kind,
                offset,
                len,
                decimals,
            });
        }
        if !renamed_fields.is_empty() {
            notes.push(format!(
                "field names given more than once, the later ones renamed: {}",
                crate::geojson::listing(&renamed_fields)
            ));
        }
        fields.retain(|f| {
            let kind = f.kind as char;
            let read = matches!(kind, 'C' | 'N' | 'F' | 'L' | 'D' | 'I' | 'O');
            if !read {
                let what = match kind {
                    'M' | 'G' | 'P' | 'B' => {
                        " (its values are kept in a memo file, not in the .dbf)"
                    }
                    _ => "",
                };
                notes.push(format!(
                    "field {} of type {:?} is not read{what}; its values are left out",
                    f.name, kind
                ));
            }
            read
        });
        Ok(Table {
            bytes: b,
            fields,
            first: header_len,
            record_len,
            count,
            codec,
            notes,
        })
    }

    /// Record `i` (0-based): its attributes, the repairs reading them took, and whether it is marked deleted.
    fn record(&self, i: usize) -> (Attributes, Vec<(IssueReason, String)>, bool) {
        let start = self.first + i * self.record_len;
        let rec = &self.bytes[start..start + self.record_len];
        let mut repairs = Vec::new();
        let attributes = self
            .fields
            .iter()
            .map(|f| {
                let cell = &rec[f.offset..f.offset + f.len];
                let (value, trouble) = self.value(f, cell);
                if let Some(t) = trouble {
                    repairs.push((
                        IssueReason::UndecodableValueKeptAsText,
                        format!("field {}: {t}", f.name),
                    ));
                }
                (f.name.clone(), value)
            })
            .collect();
        (attributes, repairs, rec.first() == Some(&b'*'))
    }

    /// A cell's value, and what went wrong reading it (then the value is its text, or null for no text).
    fn value(&self, f: &Field, cell: &[u8]) -> (AttrValue, Option<String>) {
        let text = || {
            // Text ends at a NUL, as dBase readers take it (writers leave bytes of older values after one).
            let cell = &cell[..cell.iter().position(|&c| c == 0).unwrap_or(cell.len())];
            let (s, replaced) = self.codec.decode(cell);
            (s.trim_end_matches([' ', '\0']).to_string(), replaced)
        };
        let as_text = |t: String, why: String| {
            let v = if t.is_empty() {
                AttrValue::Null
            } else {
                AttrValue::String(t)
            };
            (v, Some(why))
        };
        match f.kind {
            b'C' => {
                let (t, replaced) = text();
                let v = if t.is_empty() {
                    AttrValue::Null
                } else {
                    AttrValue::String(t)
                };
                let trouble = replaced.then(|| {
                    format!(
                        "bytes not in {} replaced by U+FFFD (a .cpg naming the file's code page would read them)",
                        self.codec.name()
                    )
                });
                (v, trouble)
            }
            b'N' | b'F' => {
                let t = text().0.trim().to_string();
                // Blank, or '*' in every place (the writer's mark for a number too wide for the field): no value.
                if t.is_empty() || t.bytes().all(|c| c == b'*') {
                    return (AttrValue::Null, None);
                }
                if f.kind == b'N' && f.decimals == 0 {
                    if let Ok(i) = t.parse::<i64>() {
                        return (AttrValue::Int(i), None);
                    }
                    // A whole number beyond 64 bits (an identifier, most likely): its digits kept exactly.
                    let digits = t.strip_prefix(['+', '-']).unwrap_or(&t);
                    if !digits.is_empty() && digits.bytes().all(|c| c.is_ascii_digit()) {
                        return as_text(
                            t.clone(),
                            format!("{t} is beyond a 64-bit integer; kept as text"),
                        );
                    }
                }
                match t.parse::<f64>() {
                    Ok(x)
                        if x.is_finite() && t.bytes().all(|c| b"+-.0123456789eE".contains(&c)) =>
                    {
                        (AttrValue::Float(x), None)
                    }
                    _ => as_text(t.clone(), format!("{t:?} is not a number; kept as text")),
                }
            }
            b'L' => {
                let t = text().0.trim().to_string();
                match t.as_str() {
                    "T" | "t" | "Y" | "y" => (AttrValue::Bool(true), None),
                    "F" | "f" | "N" | "n" => (AttrValue::Bool(false), None),
                    "" | "?" => (AttrValue::Null, None),
                    _ => as_text(
                        t.clone(),
                        format!("{t:?} is not a logical value; kept as text"),
                    ),
                }
            }
            b'D' => {
                let t = text().0.trim().to_string();
                if t.is_empty() || t == "00000000" {
                    return (AttrValue::Null, None);
                }
                let n = |r: std::ops::Range<usize>| t.get(r).and_then(|s| s.parse::<u32>().ok());
                let days = |y: u32, m: u32| match m {
                    2 if y.is_multiple_of(4)
                        && (!y.is_multiple_of(100) || y.is_multiple_of(400)) =>
                    {
                        29
                    }
                    2 => 28,
                    4 | 6 | 9 | 11 => 30,
                    _ => 31,
                };
                match (
                    t.len() == 8 && t.bytes().all(|c| c.is_ascii_digit()),
                    n(0..4),
                    n(4..6),
                    n(6..8),
                ) {
                    (true, Some(y), Some(m @ 1..=12), Some(d)) if d >= 1 && d <= days(y, m) => {
                        (AttrValue::String(format!("{y:04}-{m:02}-{d:02}")), None)
                    }
                    _ => as_text(
                        t.clone(),
                        format!("{t:?} is not a date YYYYMMDD; kept as text"),
                    ),
                }
            }
            b'I' => match cell.try_into().map(i32::from_le_bytes) {
                Ok(i) => (AttrValue::Int(i as i64), None),
                Err(_) => (
                    AttrValue::Null,
                    Some(format!("an integer field {} bytes wide", cell.len())),
                ),
            },
            b'O' => match cell.try_into().map(f64::from_le_bytes) {
                Ok(x) if x.is_finite() => (AttrValue::Float(x), None),
                Ok(x) => (AttrValue::Null, Some(format!("{x} is not a finite number"))),
                Err(_) => (
                    AttrValue::Null,
                    Some(format!("a double field {} bytes wide", cell.len())),
                ),
            },
            _ => (AttrValue::Null, None),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x0: f64, y0: f64, s: f64) -> Vec<[f64; 2]> {
        // Clockwise, as a shapefile's outer ring.
        vec![[x0, y0], [x0, y0 + s], [x0 + s, y0 + s], [x0 + s, y0]]
    }

    fn rev(mut r: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
        r.reverse();
        r
    }

    #[test]
    fn holes_join_the_smallest_outer_ring_holding_them_and_lone_holes_are_outlines() {
        // A courtyard block with an island building in its courtyard, the island's own hole, and a separate
        // square; rings in a scrambled order.
        let block = square(0.0, 0.0, 100.0);
        let court = rev(square(20.0, 20.0, 60.0));
        let island = square(40.0, 40.0, 20.0);
        let island_hole = rev(square(45.0, 45.0, 5.0));
        let other = square(200.0, 0.0, 10.0);
        let p = organize(vec![
            island_hole.clone(),
            court.clone(),
            other.clone(),
            block.clone(),
            island.clone(),
        ]);
        assert_eq!(
            p,
            vec![
                vec![rev(other.clone())],
                vec![rev(block.clone()), rev(court.clone())],
                vec![rev(island.clone()), rev(island_hole.clone())],
            ]
        );
        // Every outer ring comes out counter-clockwise, every hole clockwise (the OGC's winding).
        for poly in &p {
            assert!(signed_area2(&poly[0]) > 0.0);
            assert!(poly[1..].iter().all(|h| signed_area2(h) < 0.0));
        }
        // A counter-clockwise ring no outer ring holds is an outline of its own, not dropped; it stays wound the
        // wrong way for the repair to count.
        let p = organize(vec![square(0.0, 0.0, 10.0), rev(square(50.0, 0.0, 10.0))]);
        assert_eq!(p.len(), 2);
        assert!(signed_area2(&p[1][0]) < 0.0);
        // A hole touching its outer ring's boundary (sharing a corner) still joins it.
        let p = organize(vec![square(0.0, 0.0, 10.0), rev(square(0.0, 0.0, 5.0))]);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].len(), 2);
    }

    #[test]
    fn a_record_wound_all_the_other_way_keeps_its_courtyard() {
        // GeoJSON's winding in a shapefile: the outer ring counter-clockwise, its courtyard clockwise.
        let block = rev(square(0.0, 0.0, 100.0));
        let court = square(20.0, 20.0, 60.0);
        let p = organize(vec![block.clone(), court.clone()]);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0], vec![rev(block), rev(court)]);
        // Both rings come out wound against the OGC's rule, for the repair to turn and count them.
        assert!(signed_area2(&p[0][0]) < 0.0 && signed_area2(&p[0][1]) > 0.0);
        // A lone counter-clockwise ring beside a clockwise one is not a reversed record.
        let p = organize(vec![square(0.0, 0.0, 10.0), rev(square(50.0, 0.0, 10.0))]);
        assert_eq!(p.len(), 2);
    }

    #[test]
    fn code_pages_from_cpg_files_and_language_driver_bytes() {
        assert_eq!(Codec::from_cpg("UTF-8\n"), Some(Codec::Utf8));
        assert_eq!(Codec::from_cpg("65001"), Some(Codec::Utf8));
        assert_eq!(Codec::from_cpg("LATIN1"), Some(Codec::Latin1));
        assert_eq!(Codec::from_cpg("ISO-8859-1"), Some(Codec::Latin1));
        assert_eq!(Codec::from_cpg("ISO 88591"), Some(Codec::Latin1));
        assert_eq!(
            Codec::from_cpg("1252"),
            Some(Codec::Other(encoding_rs::WINDOWS_1252))
        );
        assert_eq!(
            Codec::from_cpg("ANSI 1251"),
            Some(Codec::Other(encoding_rs::WINDOWS_1251))
        );
        assert_eq!(
            Codec::from_cpg("88592"),
            Some(Codec::Other(encoding_rs::ISO_8859_2))
        );
        assert_eq!(
            Codec::from_cpg("885915"),
            Some(Codec::Other(encoding_rs::ISO_8859_15))
        );
        assert_eq!(Codec::from_cpg("936"), Some(Codec::Other(encoding_rs::GBK)));
        assert_eq!(
            Codec::from_cpg("shift_jis"),
            Some(Codec::Other(encoding_rs::SHIFT_JIS))
        );
        assert_eq!(Codec::from_cpg("850"), Some(Codec::AsciiOnly(850)));
        assert_eq!(Codec::from_cpg("EBCDIC"), None);
        assert_eq!(Codec::from_cpg("iso-2022-kr"), None);
        assert_eq!(Codec::from_cpg("utf-16"), None);
        assert_eq!(
            Codec::from_ldid(0x57),
            Some(Codec::Other(encoding_rs::WINDOWS_1252))
        );
        assert_eq!(
            Codec::from_ldid(0xC9),
            Some(Codec::Other(encoding_rs::WINDOWS_1251))
        );
        assert_eq!(Codec::from_ldid(0), None);
        // Latin-1 differs from Windows-1252 in 0x80–0x9F; both read é.
        assert_eq!(Codec::Latin1.decode(b"caf\xe9 \x80").0, "café \u{80}");
        assert_eq!(
            Codec::Other(encoding_rs::WINDOWS_1252)
                .decode(b"caf\xe9 \x80")
                .0,
            "café €"
        );
        assert_eq!(
            Codec::AsciiOnly(850).decode(b"caf\x82"),
            ("caf\u{fffd}".to_string(), true)
        );
        assert_eq!(
            Codec::Utf8.decode(b"caf\xc3\xa9"),
            ("café".to_string(), false)
        );
        assert!(Codec::Utf8.decode(b"caf\xe9").1);
    }
}
