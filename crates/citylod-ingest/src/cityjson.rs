//! CityJSON 0.8–2.0 and CityJSONSeq reader. One raw feature per `Building` (and per BuildingPart that no
//! Building reaches), read with its BuildingParts: its footprint is its LoD0 ground (GroundSurface or unlabelled
//! LoD0, not a roof edge), else the union of its own and its parts' footprints, each the GroundSurface of the
//! lowest-LoD 3D geometry or that geometry's lowest horizontal surfaces; its top is the highest over all. Every
//! Building and BuildingPart is read once, so no building geometry is lost. Vertices are decoded with
//! `transform` (scale, translate); a vertex that is not three numbers is an error, never read as another.
//! Geometry instances are expanded from their templates first ([`crate::template`]). A key the reader uses
//! given twice is refused, never silently chosen ([`keys`]).
//! When a 3D model is asked for, the building and its BuildingParts also go to [`crate::model3d`].

use crate::crs::DeclaredCrs;
use crate::feature::{attributes, RawFeature, RawPolygon};
use crate::lod::Target;
use crate::model3d;
use crate::report::IssueReason;
use crate::template::{self, Templates};
use serde_json::{Map, Value};
use std::collections::{HashMap, HashSet};

/// The buildings of a CityJSON document (or sequence) and what its header declares.
#[derive(Debug, Default)]
pub(crate) struct CityDoc {
    pub features: Vec<RawFeature>,
    pub declared_crs: Option<DeclaredCrs>,
    pub version: Option<String>,
    pub non_building_objects: usize,
}

/// Integer-vertex decoding: real = v · scale + translate. Identity for a file before CityJSON 1.1 without one
/// (0.x and 1.0 allowed real coordinates); from 1.1 on it is mandatory.
#[derive(Debug, Clone, Copy)]
struct Transform {
    scale: [f64; 3],
    translate: [f64; 3],
}

impl Transform {
    fn of(doc: &Value) -> Result<Self, String> {
        let Some(t) = doc.get("transform") else {
            let version = doc.get("version").and_then(Value::as_str).unwrap_or("");
            if !transform_optional(version) {
                return Err(format!(
                    "no \"transform\": CityJSON {} requires one (its vertices are integers scaled by it); only \
                     files before version 1.1 may list real coordinates without it",
                    if version.is_empty() { "without a version" } else { version }
                ));
            }
            return Ok(Transform {
                scale: [1.0; 3],
                translate: [0.0; 3],
            });
        };
        let triple = |k: &str| -> Result<[f64; 3], String> {
            let v = t.get(k).ok_or(format!("transform.{k} missing"))?;
            three_numbers(v).ok_or(format!("transform.{k} is not three numbers: {v}"))
        };
        Ok(Transform {
            scale: triple("scale")?,
            translate: triple("translate")?,
        })
    }

    fn vertices(&self, v: Option<&Value>) -> Result<Vec<[f64; 3]>, String> {
        let list = v.and_then(Value::as_array).ok_or("no \"vertices\" array")?;
        list.iter()
            .enumerate()
            .map(|(i, p)| {
                let c = three_numbers(p)
                    .ok_or_else(|| format!("vertex {i} is not three numbers: {p}"))?;
                // A product beyond f64 stays infinite here: only the buildings using it are skipped.
                Ok(std::array::from_fn(|k| {
                    c[k] * self.scale[k] + self.translate[k]
                }))
            })
            .collect()
    }
}

/// Whether a file of this CityJSON `version` may go without `transform`: before 1.1 ("0.8", "0.9", "1.0",
/// "1.0.3"), where it was optional. A version that does not read as numbers is taken to require it.
fn transform_optional(version: &str) -> bool {
    let mut numbers = version.trim().split('.').map(str::parse::<u32>);
    match (numbers.next(), numbers.next()) {
        (Some(Ok(major)), None) => major <= 1,
        (Some(Ok(major)), Some(Ok(minor))) => (major, minor) < (1, 1),
        _ => false,
    }
}

/// `[x, y, z]`: exactly three JSON numbers (JSON numbers are finite), else `None`.
pub(crate) fn three_numbers(v: &Value) -> Option<[f64; 3]> {
    match v.as_array()?.as_slice() {
        [x, y, z] => Some([x.as_f64()?, y.as_f64()?, z.as_f64()?]),
        _ => None,
    }
}

fn header_crs(doc: &Value) -> Option<DeclaredCrs> {
    doc.pointer("/metadata/referenceSystem")
        .and_then(DeclaredCrs::from_cityjson)
}

/// Reads a whole CityJSON document (`"type": "CityJSON"`); with `model_target`, each building also
/// gets its 3D model at that LoD.
pub(crate) fn read_document(doc: &Value, model_target: Option<Target>) -> Result<CityDoc, String> {
    let transform = Transform::of(doc)?;
    let vertices = transform.vertices(doc.get("vertices"))?;
    let templates = Templates::of(doc)?;
    let objects = doc
        .get("CityObjects")
        .and_then(Value::as_object)
        .ok_or("no \"CityObjects\" object")?;
    let mut out = CityDoc::of_header(doc);
    read_with_vertices(objects, Ok(vertices), &templates, model_target, &mut out);
    Ok(out)
}

/// [`read_document`] from the document's `text` too, to refuse what parsing into a [`Value`] hides: a member
/// the reader uses, or a CityObjects id, given twice (see [`keys`]). A building's repeated attribute keys
/// keep their last value, recorded as a repair.
pub(crate) fn read_document_text(
    text: &str,
    doc: &Value,
    model_target: Option<Target>,
) -> Result<CityDoc, String> {
    let repeats = keys::check(text).map_err(|e| format!("{e}: {}", keys::REFUSED))?;
    let mut out = read_document(doc, model_target)?;
    keys::record(&repeats, &mut out.features);
    Ok(out)
}

/// Reads a CityJSONSeq text: a CityJSON header line, then one `CityJSONFeature` per line. City objects
/// in the header (the spec leaves them empty; a CityJSON document saved as `.jsonl` has them) are read
/// too, over the header's vertices, before the lines'. A line whose vertices are broken, or which gives a key the
/// reader uses twice, has its buildings skipped with the reason (a header giving one twice refuses the file).
/// `Err((line, error))` for a line that is not JSON; `Ok(Err(detail))` for a broken structure.
pub(crate) fn read_sequence(
    text: &str,
    model_target: Option<Target>,
) -> Result<Result<CityDoc, String>, (usize, serde_json::Error)> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((hl, header_text)) = lines.next() else {
        return Ok(Err("empty file".into()));
    };
    let header: Value = serde_json::from_str(header_text).map_err(|e| (hl + 1, e))?;
    if header.get("type").and_then(Value::as_str) != Some("CityJSON") {
        return Ok(Err("first line is not a CityJSON header".into()));
    }
    let repeats_in = |text: &str, line: usize| {
        keys::check(text).map_err(|e| {
            format!(
                "line {line}, column {}: {}: {}",
                e.column(),
                keys::without_position(&e.to_string()),
                keys::REFUSED
            )
        })
    };
    let header_repeats = match repeats_in(header_text, hl + 1) {
        Ok(r) => r,
        Err(e) => return Ok(Err(e)),
    };
    let (transform, templates) =
        match Transform::of(&header).and_then(|t| Ok((t, Templates::of(&header)?))) {
            Ok(t) => t,
            Err(e) => return Ok(Err(e)),
        };
    let mut out = CityDoc::of_header(&header);
    match header.get("CityObjects") {
        None => {}
        Some(Value::Object(objects)) => {
            let vertices = transform.vertices(header.get("vertices")).map_err(|e| {
                (
                    IssueReason::MalformedGeometry,
                    format!("line {}: {e}", hl + 1),
                )
            });
            read_with_vertices(objects, vertices, &templates, model_target, &mut out);
            keys::record(&header_repeats, &mut out.features);
        }
        Some(_) => {
            return Ok(Err(format!(
                "line {}: the header's CityObjects is not an object",
                hl + 1
            )))
        }
    }
    for (i, line) in lines {
        let f: Value = serde_json::from_str(line).map_err(|e| (i + 1, e))?;
        if f.get("type").and_then(Value::as_str) != Some("CityJSONFeature") {
            return Ok(Err(format!("line {} is not a CityJSONFeature", i + 1)));
        }
        let repeats = repeats_in(line, i + 1);
        let first = out.features.len();
        let Some(objects) = f.get("CityObjects").and_then(Value::as_object) else {
            return Ok(Err(format!(
                "line {}: CityJSONFeature without CityObjects",
                i + 1
            )));
        };
        // A line is read on its own: a bad vertex, or a key the reader uses given twice (which of the two values
        // is meant?), skips this line's buildings, with the line named.
        let vertices = match &repeats {
            Err(e) => Err((IssueReason::DuplicateKey, e.clone())),
            Ok(_) => transform.vertices(f.get("vertices")).map_err(|e| {
                (
                    IssueReason::MalformedGeometry,
                    format!("line {}: {e}", i + 1),
                )
            }),
        };
        read_with_vertices(objects, vertices, &templates, model_target, &mut out);
        if let Ok(repeats) = &repeats {
            keys::record(repeats, &mut out.features[first..]);
        }
    }
    Ok(Ok(out))
}

impl CityDoc {
    /// No buildings yet, and what `doc`'s header declares.
    fn of_header(doc: &Value) -> Self {
        CityDoc {
            features: Vec::new(),
            declared_crs: header_crs(doc),
            version: doc
                .get("version")
                .and_then(Value::as_str)
                .map(str::to_string),
            non_building_objects: 0,
        }
    }
}

/// Reads `objects` over their decoded `vertices` into `out`, geometry instances expanded first. When they cannot be
/// read (`Err`: the reason and why — broken vertices, a key given twice), each building is skipped with it.
fn read_with_vertices(
    objects: &Map<String, Value>,
    mut vertices: Result<Vec<[f64; 3]>, (IssueReason, String)>,
    templates: &Templates,
    model_target: Option<Target>,
    out: &mut CityDoc,
) {
    let expanded = vertices
        .as_mut()
        .ok()
        .and_then(|v| template::expand(objects, v, templates));
    read_objects(
        expanded.as_ref().unwrap_or(objects),
        vertices.as_deref().map_err(|(r, e)| (*r, e.as_str())),
        model_target,
        out,
    );
}

/// [`read_with_vertices`] for objects that hold no geometry instances (CityGML's, converted).
pub(crate) fn read_objects_with_vertices(
    objects: &Map<String, Value>,
    vertices: Result<Vec<[f64; 3]>, (IssueReason, String)>,
    model_target: Option<Target>,
    out: &mut CityDoc,
) {
    read_with_vertices(objects, vertices, &Templates::default(), model_target, out);
}

fn parents(o: &Value) -> Vec<&str> {
    match (o.get("parents"), o.get("parent")) {
        (Some(Value::Array(a)), _) => a.iter().filter_map(Value::as_str).collect(),
        (_, Some(Value::String(s))) => vec![s.as_str()],
        _ => Vec::new(),
    }
}

fn read_objects<'a>(
    objects: &'a Map<String, Value>,
    vertices: Result<&[[f64; 3]], (IssueReason, &str)>,
    model_target: Option<Target>,
    out: &mut CityDoc,
) {
    // Children listed by the parent, plus those that only name their parent (both spellings).
    let mut children: HashMap<&str, Vec<&str>> = HashMap::new();
    for (k, o) in objects {
        if let Some(list) = o.get("children").and_then(Value::as_array) {
            children
                .entry(k.as_str())
                .or_default()
                .extend(list.iter().filter_map(Value::as_str));
        }
    }
    for (k, o) in objects {
        for p in parents(o) {
            let list = children.entry(p).or_default();
            if !list.contains(&k.as_str()) {
                list.push(k.as_str());
            }
        }
    }
    // Every Building is a feature, whatever its parents (a group, a missing object, another Building: CityJSON
    // does not allow that, files do) or children; a Building is never another's part. Its BuildingParts, nested
    // at any depth, are read with it. A BuildingPart that no Building reaches (its building missing, parts naming
    // only each other) is a feature of its own unless another such part reaches it (the first of a cycle in file
    // order). A part reached from several features (two Buildings listing it) is read with the first in file
    // order. So every Building and BuildingPart is read exactly once.
    let is = |o: &Value, t: &str| o.get("type").and_then(Value::as_str) == Some(t);
    let part_ids = |p: &[(&'a str, &'a Value)]| p.iter().map(|&(c, _)| c).collect::<Vec<_>>();
    // The features, each with every part it reaches (`parts_of`, once per candidate).
    let mut parts: HashMap<&str, Vec<(&str, &Value)>> = objects
        .iter()
        .filter(|(_, o)| is(o, "Building"))
        .map(|(k, _)| (k.as_str(), parts_of(k, objects, &children)))
        .collect();
    let mut covered: HashSet<&str> = HashSet::new();
    for (k, p) in &parts {
        covered.insert(k);
        covered.extend(part_ids(p));
    }
    let orphans: Vec<(&str, Vec<(&str, &Value)>)> = objects
        .iter()
        .filter(|(k, o)| !covered.contains(k.as_str()) && is(o, "BuildingPart"))
        .map(|(k, _)| (k.as_str(), parts_of(k, objects, &children)))
        .collect();
    let reached: HashSet<&str> = orphans.iter().flat_map(|(_, p)| part_ids(p)).collect();
    // Tops first (no other orphan reaches them), then what cycles leave, each in file order.
    for top_only in [true, false] {
        for (k, p) in &orphans {
            let waits = top_only && reached.contains(k);
            if !covered.contains(k) && !waits {
                covered.insert(k);
                covered.extend(part_ids(p));
                parts.insert(k, p.clone());
            }
        }
    }
    let mut owned: HashSet<&str> = HashSet::new();
    for (key, o) in objects {
        let Some(reach) = parts.get(key.as_str()) else {
            if !is(o, "BuildingPart") {
                out.non_building_objects += 1;
            }
            continue;
        };
        let own: Vec<(&str, &Value)> = reach
            .iter()
            .copied()
            .filter(|(c, _)| !parts.contains_key(c) && owned.insert(c))
            .collect();
        let mut f = RawFeature {
            source_id: key.clone(),
            attributes: attributes(o.get("attributes")),
            assemble: true,
            ..Default::default()
        };
        match vertices {
            Err((reason, e)) => f.skip = Some((reason, e.to_string())),
            Ok(v) => fill_building(&mut f, key, o, own, v, model_target),
        }
        out.features.push(f);
    }
}

/// A footprint piece with z: rings of (x, y, z), open.
type Polygon3 = Vec<Vec<[f64; 3]>>;

/// What one city object's own geometry gives the footprint and the heights.
#[derive(Default)]
struct ObjectGeometry {
    /// Its LoD0 ground (GroundSurface or unlabelled LoD0 surfaces), else the ground of its lowest 3D LoD.
    footprint: Vec<Polygon3>,
    /// `footprint` is the object's LoD0.
    from_lod0: bool,
    /// Semantic types of LoD0 surfaces that are no footprint (a `RoofSurface` is the roof edge), once each.
    lod0_not_ground: Vec<String>,
    top_z: Option<f64>,
    has_geometry: bool,
}

/// The footprint of a building and its BuildingParts, and its top over all of them. The building's own LoD0
/// stands for the whole building (3DBAG draws it so, and its parts' reconstructed ground surfaces differ from
/// it by slivers): parts then add only LoD0 surfaces of their own. Without it, the footprint is the union of
/// the building's own footprint and every part's, whatever geometry each comes from.
fn fill_building<'a>(
    f: &mut RawFeature,
    key: &'a str,
    object: &'a Value,
    parts: Vec<(&'a str, &'a Value)>,
    vertices: &[[f64; 3]],
    model_target: Option<Target>,
) {
    let mut whole = match object_geometry(object, vertices) {
        Ok(g) => g,
        Err(e) => {
            f.skip = Some((IssueReason::MalformedGeometry, e));
            return;
        }
    };
    for (c, o) in &parts {
        let part = match object_geometry(o, vertices) {
            Ok(g) => g,
            Err(e) => {
                f.skip = Some((IssueReason::MalformedGeometry, format!("{c}: {e}")));
                return;
            }
        };
        whole.has_geometry |= part.has_geometry;
        whole.top_z = max_opt(whole.top_z, part.top_z);
        if part.from_lod0 || !whole.from_lod0 {
            whole.footprint.extend(part.footprint);
        }
        for t in part.lod0_not_ground {
            if !whole.lod0_not_ground.contains(&t) {
                whole.lod0_not_ground.push(t);
            }
        }
    }
    let footprint = whole.footprint;
    if footprint.is_empty() {
        f.skip = Some(if !whole.has_geometry {
            (
                IssueReason::NoGeometry,
                "the building and its parts have no geometry".into(),
            )
        } else if whole.lod0_not_ground.is_empty() {
            (
                IssueReason::NoFootprint,
                "no LoD0 surface, GroundSurface or horizontal base in any geometry".into(),
            )
        } else {
            (
                IssueReason::NoFootprint,
                format!(
                    "its LoD0 surfaces are {} (a roof edge is not the footprint), and no 3D geometry has a \
                     GroundSurface or horizontal base",
                    whole.lod0_not_ground.join(", ")
                ),
            )
        });
        return;
    }
    f.top_z = whole.top_z;
    f.footprint_min_z = footprint
        .iter()
        .flatten()
        .flatten()
        .map(|p| p[2])
        .reduce(f64::min);
    f.polygons = footprint
        .into_iter()
        .map(|poly| {
            poly.into_iter()
                .map(|r| r.into_iter().map(|p| [p[0], p[1]]).collect())
                .collect::<RawPolygon>()
        })
        .collect();
    if let Some(target) = model_target {
        let members: Vec<(&str, &Value)> = std::iter::once((key, object)).chain(parts).collect();
        f.model = Some(model3d::collect(&members, vertices, target));
    }
}

/// The BuildingParts of `key`, and theirs, depth-first in file order, each once even when the parent links
/// form a cycle. Other children (installations, rooms, a Building) are not parts: a Building is read on its own.
fn parts_of<'a>(
    key: &'a str,
    objects: &'a Map<String, Value>,
    children: &HashMap<&'a str, Vec<&'a str>>,
) -> Vec<(&'a str, &'a Value)> {
    let mut stack: Vec<&str> = children
        .get(key)
        .map(|c| c.iter().rev().copied().collect())
        .unwrap_or_default();
    let mut seen = vec![key];
    let mut out = Vec::new();
    while let Some(c) = stack.pop() {
        if seen.contains(&c) {
            continue;
        }
        seen.push(c);
        let Some(o) = objects
            .get(c)
            .filter(|o| o.get("type").and_then(Value::as_str) == Some("BuildingPart"))
        else {
            continue;
        };
        out.push((c, o));
        if let Some(cc) = children.get(c) {
            stack.extend(cc.iter().rev().copied());
        }
    }
    out
}

fn max_opt(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, b) => a.or(b),
    }
}

fn lod_of(g: &Value) -> f64 {
    match g.get("lod") {
        Some(Value::Number(n)) => n.as_f64().unwrap_or(f64::INFINITY),
        Some(Value::String(s)) => s.trim().parse().unwrap_or(f64::INFINITY),
        _ => f64::INFINITY,
    }
}

/// One surface of a geometry: rings of vertex indices and its semantic type.
pub(crate) struct Surface<'a> {
    pub rings: &'a [Value],
    pub semantic: Option<&'a str>,
}

/// The surfaces of any CityJSON geometry type, with semantic surface types where given.
pub(crate) fn surfaces(g: &Value) -> Result<Vec<Surface<'_>>, String> {
    let depth = match g.get("type").and_then(Value::as_str) {
        Some("MultiSurface" | "CompositeSurface") => 0,
        Some("Solid") => 1,
        Some("MultiSolid" | "CompositeSolid") => 2,
        Some("GeometryInstance") => {
            return match g.get(template::UNRESOLVED).and_then(Value::as_str) {
                Some(why) => Err(why.to_string()),
                // Not expanded: outside the building family, where no surface is read.
                None => Ok(Vec::new()),
            };
        }
        _ => return Ok(Vec::new()), // points, lines: no surfaces
    };
    let kinds: Vec<Option<&str>> = g
        .pointer("/semantics/surfaces")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .map(|s| s.get("type").and_then(Value::as_str))
                .collect()
        })
        .unwrap_or_default();
    let mut out = Vec::new();
    walk(
        g.get("boundaries"),
        g.pointer("/semantics/values"),
        depth,
        &kinds,
        &mut out,
    )?;
    Ok(out)
}

fn walk<'a>(
    b: Option<&'a Value>,
    sem: Option<&'a Value>,
    depth: usize,
    kinds: &[Option<&'a str>],
    out: &mut Vec<Surface<'a>>,
) -> Result<(), String> {
    let list = b
        .and_then(Value::as_array)
        .ok_or("boundaries are not nested arrays")?;
    for (i, item) in list.iter().enumerate() {
        let s = sem.and_then(|s| s.as_array()).and_then(|a| a.get(i));
        if depth == 0 {
            let rings = item.as_array().ok_or("surface is not an array of rings")?;
            let semantic = s
                .and_then(Value::as_u64)
                .and_then(|k| kinds.get(k as usize).copied().flatten());
            out.push(Surface { rings, semantic });
        } else {
            walk(Some(item), s, depth - 1, kinds, out)?;
        }
    }
    Ok(())
}

/// The vertex a boundary's entry `i` indexes; `Err` says whether it is no index at all (a string, a negative or
/// fractional number, an array) or one past the vertices.
pub(crate) fn vertex<'a>(i: &Value, vertices: &'a [[f64; 3]]) -> Result<&'a [f64; 3], String> {
    let k = i
        .as_u64()
        .ok_or_else(|| format!("vertex index {i} is not an index (a whole number from 0)"))?;
    usize::try_from(k)
        .ok()
        .and_then(|k| vertices.get(k))
        .ok_or_else(|| {
            format!(
                "vertex index {k} out of range: there are {} vertices",
                vertices.len()
            )
        })
}

fn polygon3(s: &Surface, vertices: &[[f64; 3]]) -> Result<Polygon3, String> {
    s.rings
        .iter()
        .map(|r| {
            let idx = r.as_array().ok_or("ring is not an array of indices")?;
            let mut ring: Vec<[f64; 3]> = idx
                .iter()
                .map(|i| vertex(i, vertices).copied())
                .collect::<Result<_, _>>()?;
            if ring.len() >= 2 && ring.first() == ring.last() {
                ring.pop();
            }
            Ok(ring)
        })
        .collect()
}

/// A surface whose [`horizontality`] is over this (within ~10° of horizontal) may be a building's floor.
pub(crate) const HORIZONTAL: f64 = 0.985;

/// Newell normal's vertical share: 1 for a horizontal ring, 0 for a vertical one.
pub(crate) fn horizontality(ring: &[[f64; 3]]) -> f64 {
    let mut n = [0.0; 3];
    for (i, a) in ring.iter().enumerate() {
        let b = ring[(i + 1) % ring.len()];
        n[0] += (a[1] - b[1]) * (a[2] + b[2]);
        n[1] += (a[2] - b[2]) * (a[0] + b[0]);
        n[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len > 0.0 {
        n[2].abs() / len
    } else {
        0.0
    }
}

/// Footprint pieces and top height of one city object's own geometry.
fn object_geometry(o: &Value, vertices: &[[f64; 3]]) -> Result<ObjectGeometry, String> {
    let geoms: &[Value] = o
        .get("geometry")
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    let mut g = ObjectGeometry {
        has_geometry: !geoms.is_empty(),
        ..Default::default()
    };
    // LoD0 holds the footprint and may hold the roof edge (RoofSurface), which overhangs it at roof height.
    for lod0 in geoms.iter().filter(|x| lod_of(x) == 0.0) {
        for s in surfaces(lod0)? {
            match s.semantic {
                None | Some("GroundSurface") => g.footprint.push(polygon3(&s, vertices)?),
                Some(t) if !g.lod0_not_ground.iter().any(|k| k == t) => {
                    g.lod0_not_ground.push(t.to_string())
                }
                Some(_) => {}
            }
        }
    }
    g.from_lod0 = !g.footprint.is_empty();
    // The lowest LoD above 0 with surfaces gives the top height and, without LoD0, the footprint.
    // Malformed geometries of higher LoDs are not the footprint's concern (3D models report them).
    let mut best: Option<(f64, Vec<Surface>)> = None;
    let mut malformed: Option<(f64, String)> = None;
    for x in geoms.iter().filter(|x| lod_of(x) != 0.0) {
        let l = lod_of(x);
        match surfaces(x) {
            Ok(s) if !s.is_empty() && best.as_ref().is_none_or(|(bl, _)| l < *bl) => {
                best = Some((l, s));
            }
            Ok(_) => {}
            Err(e) if malformed.as_ref().is_none_or(|(ml, _)| l < *ml) => malformed = Some((l, e)),
            Err(_) => {}
        }
    }
    if let Some((ml, e)) = malformed {
        if best.as_ref().is_none_or(|(bl, _)| ml <= *bl) {
            return Err(e);
        }
    }
    let Some((_, surfs)) = best else { return Ok(g) };
    let polys: Vec<(Polygon3, Option<&str>)> = surfs
        .iter()
        .map(|s| polygon3(s, vertices).map(|p| (p, s.semantic)))
        .collect::<Result<_, _>>()?;
    g.top_z = polys
        .iter()
        .flat_map(|(p, _)| p.iter().flatten())
        .map(|v| v[2])
        .reduce(f64::max);
    if !g.footprint.is_empty() {
        return Ok(g);
    }
    let ground: Vec<&Polygon3> = polys
        .iter()
        .filter(|(_, s)| *s == Some("GroundSurface"))
        .map(|(p, _)| p)
        .collect();
    if !ground.is_empty() {
        g.footprint = ground.into_iter().cloned().collect();
        return Ok(g);
    }
    // No semantics: the horizontal surfaces (within ~10°) at the lowest mean height (5 cm band).
    let mean_z = |p: &Polygon3| {
        let r = &p[0];
        r.iter().map(|v| v[2]).sum::<f64>() / r.len().max(1) as f64
    };
    let horizontal: Vec<(&Polygon3, f64)> = polys
        .iter()
        .filter(|(p, _)| {
            p.first()
                .is_some_and(|r| r.len() >= 3 && horizontality(r) > HORIZONTAL)
        })
        .map(|(p, _)| (p, mean_z(p)))
        .collect();
    if let Some(low) = horizontal.iter().map(|(_, z)| *z).reduce(f64::min) {
        g.footprint = horizontal
            .into_iter()
            .filter(|(_, z)| *z <= low + 0.05)
            .map(|(p, _)| p.clone())
            .collect();
    }
    Ok(g)
}

/// Repeated keys in what the reader uses of a CityJSON document or CityJSONSeq line. Parsing into a [`Value`]
/// keeps the last value of a repeated key and drops the others unseen, so the text is read once more into
/// outlines of the members used: serde refuses a field given twice ("duplicate field"), as for GeoJSON's
/// `features`, and a CityObjects id given twice is refused naming it — the whole document, or one line of a
/// sequence, whose buildings are then skipped. A building's `attributes` may repeat a
/// key: the last value is kept and reported, as for GeoJSON properties. Members not used may repeat, and a
/// member of the wrong JSON type is left for the reader to judge.
mod keys {
    use crate::feature::RawFeature;
    use crate::report::IssueReason;
    use serde::de::value::MapAccessDeserializer;
    use serde::de::{Error as _, IgnoredAny, MapAccess, SeqAccess, Visitor};
    use serde::{Deserialize, Deserializer};
    use std::collections::{HashMap, HashSet};
    use std::fmt;
    use std::marker::PhantomData;

    /// Why a repeat is refused, for the error detail.
    pub(super) const REFUSED: &str =
        "a key given twice, whose other value a JSON reader would silently drop";

    /// The repeated `attributes` keys of each city object, by id: `name (given N times)`.
    pub(super) type AttributeRepeats = HashMap<String, Vec<String>>;

    /// Reads `text` (valid JSON) for repeats; `Err` names the repeated member or id, at serde_json's position.
    pub(super) fn check(text: &str) -> Result<AttributeRepeats, serde_json::Error> {
        let doc: Object<Document> = serde_json::from_str(text)?;
        Ok(doc
            .0
            .and_then(|d| d.city_objects.0)
            .map(|o| o.0)
            .unwrap_or_default())
    }

    /// Adds a `duplicate_key` repair to each of `features` whose attributes repeat a key.
    pub(super) fn record(repeats: &AttributeRepeats, features: &mut [RawFeature]) {
        for f in features {
            if let Some(keys) = repeats.get(&f.source_id) {
                f.repairs.push((
                    IssueReason::DuplicateKey,
                    format!(
                        "repeated attribute keys, the last value of each kept: {}",
                        crate::geojson::listing(keys)
                    ),
                ));
            }
        }
    }

    /// A serde_json message without its trailing ` at line L column C`.
    pub(super) fn without_position(message: &str) -> &str {
        match message.rfind(" at line ") {
            Some(i) if message[i..].contains(" column ") => &message[..i],
            _ => message,
        }
    }

    // The outlines: their fields are never read; serde's duplicate-field check is what they are for.
    #[derive(Deserialize, Default)]
    #[serde(default)]
    #[allow(dead_code)]
    struct Document {
        r#type: IgnoredAny,
        version: IgnoredAny,
        transform: Object<Transform>,
        metadata: Object<Metadata>,
        #[serde(rename = "CityObjects")]
        city_objects: Object<CityObjects>,
        vertices: IgnoredAny,
        #[serde(rename = "geometry-templates")]
        templates: Object<Templates>,
    }

    #[derive(Deserialize, Default)]
    #[serde(default)]
    #[allow(dead_code)]
    struct Transform {
        scale: IgnoredAny,
        translate: IgnoredAny,
    }

    #[derive(Deserialize, Default)]
    #[serde(default, rename_all = "camelCase")]
    #[allow(dead_code)]
    struct Metadata {
        reference_system: IgnoredAny,
    }

    #[derive(Deserialize, Default)]
    #[serde(default, rename_all = "kebab-case")]
    #[allow(dead_code)]
    struct Templates {
        templates: List<Object<Geometry>>,
        vertices_templates: IgnoredAny,
    }

    #[derive(Deserialize, Default)]
    #[serde(default)]
    #[allow(dead_code)]
    struct CityObject {
        r#type: IgnoredAny,
        geometry: List<Object<Geometry>>,
        children: IgnoredAny,
        parents: IgnoredAny,
        parent: IgnoredAny,
        attributes: Object<Attributes>,
    }

    #[derive(Deserialize, Default)]
    #[serde(default, rename_all = "camelCase")]
    #[allow(dead_code)]
    struct Geometry {
        r#type: IgnoredAny,
        lod: IgnoredAny,
        boundaries: IgnoredAny,
        semantics: Object<Semantics>,
        template: IgnoredAny,
        transformation_matrix: IgnoredAny,
    }

    #[derive(Deserialize, Default)]
    #[serde(default)]
    #[allow(dead_code)]
    struct Semantics {
        surfaces: List<Object<Surface>>,
        values: IgnoredAny,
    }

    #[derive(Deserialize, Default)]
    #[serde(default)]
    #[allow(dead_code)]
    struct Surface {
        r#type: IgnoredAny,
    }

    /// `T` read from a JSON object; another value is skipped.
    struct Object<T>(Option<T>);

    /// Each element read as `T` (for its repeats) from a JSON array; another value is skipped.
    struct List<T>(PhantomData<T>);

    impl<T> Default for Object<T> {
        fn default() -> Self {
            Object(None)
        }
    }

    impl<T> Default for List<T> {
        fn default() -> Self {
            List(PhantomData)
        }
    }

    /// Scalars are skipped, as the default value: only objects and arrays can hide a repeat.
    macro_rules! scalars_skipped {
        () => {
            fn visit_unit<E: serde::de::Error>(self) -> Result<Self::Value, E> {
                Ok(Default::default())
            }
            fn visit_bool<E: serde::de::Error>(self, _: bool) -> Result<Self::Value, E> {
                Ok(Default::default())
            }
            fn visit_i64<E: serde::de::Error>(self, _: i64) -> Result<Self::Value, E> {
                Ok(Default::default())
            }
            fn visit_u64<E: serde::de::Error>(self, _: u64) -> Result<Self::Value, E> {
                Ok(Default::default())
            }
            fn visit_f64<E: serde::de::Error>(self, _: f64) -> Result<Self::Value, E> {
                Ok(Default::default())
            }
            fn visit_str<E: serde::de::Error>(self, _: &str) -> Result<Self::Value, E> {
                Ok(Default::default())
            }
        };
    }

    impl<'de, T: Deserialize<'de>> Deserialize<'de> for Object<T> {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct V<T>(PhantomData<T>);
            impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
                type Value = Object<T>;
                fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                    f.write_str("any JSON value")
                }
                fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Object<T>, A::Error> {
                    T::deserialize(MapAccessDeserializer::new(map)).map(|t| Object(Some(t)))
                }
                fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Object<T>, A::Error> {
                    while seq.next_element::<IgnoredAny>()?.is_some() {}
                    Ok(Object(None))
                }
                scalars_skipped!();
            }
            d.deserialize_any(V(PhantomData))
        }
    }

    impl<'de, T: Deserialize<'de>> Deserialize<'de> for List<T> {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct V<T>(PhantomData<T>);
            impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
                type Value = List<T>;
                fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                    f.write_str("any JSON value")
                }
                fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<List<T>, A::Error> {
                    while seq.next_element::<T>()?.is_some() {}
                    Ok(List(PhantomData))
                }
                fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<List<T>, A::Error> {
                    while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
                    Ok(List(PhantomData))
                }
                scalars_skipped!();
            }
            d.deserialize_any(V(PhantomData))
        }
    }

    /// The attribute keys given more than once, as `name (given N times)`, in order of first appearance.
    struct Attributes(Vec<String>);

    impl<'de> Deserialize<'de> for Attributes {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct V;
            impl<'de> Visitor<'de> for V {
                type Value = Attributes;
                fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                    f.write_str("an attributes object")
                }
                fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Attributes, A::Error> {
                    let mut count: Vec<(String, usize)> = Vec::new();
                    let mut index: HashMap<String, usize> = HashMap::new();
                    while let Some(key) = map.next_key::<String>()? {
                        map.next_value::<IgnoredAny>()?;
                        match index.get(&key) {
                            Some(&i) => count[i].1 += 1,
                            None => {
                                index.insert(key.clone(), count.len());
                                count.push((key, 1));
                            }
                        }
                    }
                    Ok(Attributes(
                        count
                            .into_iter()
                            .filter(|(_, n)| *n > 1)
                            .map(|(key, n)| format!("{key} (given {n} times)"))
                            .collect(),
                    ))
                }
            }
            d.deserialize_map(V)
        }
    }

    /// The city objects' repeated attribute keys, by id; an id given twice is an error naming it.
    struct CityObjects(AttributeRepeats);

    impl<'de> Deserialize<'de> for CityObjects {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            struct V;
            impl<'de> Visitor<'de> for V {
                type Value = CityObjects;
                fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                    f.write_str("a CityObjects object")
                }
                fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<CityObjects, A::Error> {
                    let mut ids: HashSet<String> = HashSet::new();
                    let mut repeats = AttributeRepeats::new();
                    while let Some(id) = map.next_key::<String>()? {
                        if ids.contains(&id) {
                            return Err(A::Error::custom(format!(
                                "CityObjects id {id:?} given more than once"
                            )));
                        }
                        let o: Object<CityObject> = map.next_value().map_err(|e| {
                            A::Error::custom(format!(
                                "CityObjects {id:?}: {}",
                                without_position(&e.to_string())
                            ))
                        })?;
                        if let Some(Attributes(keys)) = o.0.and_then(|o| o.attributes.0) {
                            if !keys.is_empty() {
                                repeats.insert(id.clone(), keys);
                            }
                        }
                        ids.insert(id);
                    }
                    Ok(CityObjects(repeats))
                }
            }
            d.deserialize_map(V)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn cube(ground_semantics: bool) -> Value {
        // Box (4 × 3 m) with ground at z=0 (index 0..3) and roof at z=5 (4..7).
        box_solid(0, ground_semantics)
    }

    /// The annex beside [`cube`]: x from 4 to 6 m, 2 m high (vertices 8..15).
    fn annex() -> Value {
        box_solid(8, true)
    }

    fn box_solid(first: u64, ground_semantics: bool) -> Value {
        let b = |i: [u64; 4]| json!([i.map(|i| i + first)]);
        let mut g = json!({"type": "Solid", "lod": "1.2", "boundaries": [[
            b([0, 3, 2, 1]), b([4, 5, 6, 7]), b([0, 1, 5, 4]), b([1, 2, 6, 5]), b([2, 3, 7, 6]), b([3, 0, 4, 7])
        ]]});
        if ground_semantics {
            g["semantics"] = json!({"surfaces": [{"type": "GroundSurface"}, {"type": "RoofSurface"},
                {"type": "WallSurface"}], "values": [[0, 1, 2, 2, 2, 2]]});
        }
        g
    }

    fn doc(building: Value, extra: Value) -> Value {
        let mut objects = json!({"B1": building});
        if let Value::Object(m) = extra {
            objects.as_object_mut().unwrap().extend(m);
        }
        json!({"type": "CityJSON", "version": "2.0",
            "transform": {"scale": [0.001, 0.001, 0.001], "translate": [1000.0, 2000.0, 0.0]},
            "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/7415"},
            "CityObjects": objects,
            "vertices": [[0,0,0],[4000,0,0],[4000,3000,0],[0,3000,0],[0,0,5000],[4000,0,5000],[4000,3000,5000],[0,3000,5000],
                [4000,0,0],[6000,0,0],[6000,3000,0],[4000,3000,0],[4000,0,2000],[6000,0,2000],[6000,3000,2000],[4000,3000,2000]]})
    }

    #[test]
    fn ground_surface_gives_the_footprint_and_vertices_are_decoded() {
        let d = read_document(
            &doc(
                json!({"type": "Building", "geometry": [cube(true)]}),
                json!({}),
            ),
            None,
        )
        .unwrap();
        let f = &d.features[0];
        assert!(f.skip.is_none(), "{:?}", f.skip);
        assert_eq!(f.polygons.len(), 1);
        let r = &f.polygons[0][0];
        assert_eq!(r.len(), 4);
        assert!(r
            .iter()
            .all(|p| (1000.0..=1004.0).contains(&p[0]) && (2000.0..=2003.0).contains(&p[1])));
        assert_eq!(f.footprint_min_z, Some(0.0));
        assert_eq!(f.top_z, Some(5.0));
        assert_eq!(
            d.declared_crs,
            Some(DeclaredCrs::Name(
                "https://www.opengis.net/def/crs/EPSG/0/7415".into()
            ))
        );
    }

    #[test]
    fn without_semantics_the_lowest_horizontal_surface_is_the_footprint() {
        let d = read_document(
            &doc(
                json!({"type": "Building", "geometry": [cube(false)]}),
                json!({}),
            ),
            None,
        )
        .unwrap();
        let f = &d.features[0];
        assert_eq!(f.polygons.len(), 1);
        assert_eq!(f.footprint_min_z, Some(0.0));
    }

    #[test]
    fn parts_only_buildings_collect_all_part_footprints() {
        let b = json!({"type": "Building", "children": ["P1", "P2"]});
        let parts = json!({
            "P1": {"type": "BuildingPart", "parents": ["B1"], "geometry": [cube(true)]},
            "P2": {"type": "BuildingPart", "parent": "B1", "geometry": [cube(false)]},
            "T": {"type": "TINRelief", "geometry": []}
        });
        let d = read_document(&doc(b, parts), None).unwrap();
        assert_eq!(d.features.len(), 1, "parts are not buildings");
        assert_eq!(d.features[0].polygons.len(), 2);
        assert!(d.features[0].assemble);
        assert_eq!(d.non_building_objects, 1);
    }

    /// The source ids of the features read from `objects` (B1 is the first), sorted.
    fn feature_ids(b1: Value, objects: Value) -> Vec<String> {
        let d = read_document(&doc(b1, objects), None).unwrap();
        let mut ids: Vec<String> = d.features.iter().map(|f| f.source_id.clone()).collect();
        ids.sort();
        ids
    }

    #[test]
    fn buildings_with_odd_parent_links_are_read_once_each() {
        let b = |parents: Value| json!({"type": "Building", "parents": parents, "geometry": [cube(true)]});
        // A member of a group (CityJSON 2.0 lists the group in the member's parents).
        let group = json!({"G": {"type": "CityObjectGroup", "children": ["B1", "B2"]}, "B2": b(json!(["G"]))});
        assert_eq!(feature_ids(b(json!(["G"])), group), ["B1", "B2"]);
        // A parent missing from the file; its own parent.
        assert_eq!(
            feature_ids(b(json!(["nowhere"])), json!({"B2": b(json!(["B2"]))})),
            ["B1", "B2"]
        );
        // A building and its part naming each other as parents: one building.
        let part = json!({"P": {"type": "BuildingPart", "parents": ["B1"], "children": ["B1"], "geometry": [cube(false)]}});
        assert_eq!(feature_ids(b(json!(["P"])), part), ["B1"]);
        // A part whose building is missing is a building of its own.
        let orphan =
            json!({"P": {"type": "BuildingPart", "parents": ["gone"], "geometry": [cube(true)]}});
        assert_eq!(feature_ids(b(json!([])), orphan), ["B1", "P"]);
        // Parts naming only each other: one building, the first in the file.
        let ring = json!({"P1": {"type": "BuildingPart", "parents": ["P2"], "geometry": [cube(true)]},
            "P2": {"type": "BuildingPart", "parents": ["P1"], "geometry": [cube(true)]}});
        assert_eq!(feature_ids(b(json!([])), ring), ["B1", "P1"]);
    }

    #[test]
    fn a_building_under_a_building_is_read_on_its_own_even_in_a_cycle() {
        let b1 = |links: Value| json!({"type": "Building", "children": links, "parents": links, "geometry": [cube(true)]});
        let b2 = |links: Value| {
            json!({"B2": {"type": "Building", "parents": links,
            "children": [ "P2" ], "geometry": [annex()]},
            "P2": {"type": "BuildingPart", "parents": ["B2"], "geometry": [annex()]}})
        };
        // B2 nested in B1, then B1 and B2 each the other's parent: each is one feature with its own footprint
        // and top; B2's part is B2's alone.
        for (links1, links2) in [(json!(["B2"]), json!(["B1"])), (json!(["B2"]), json!([]))] {
            let target = Target::of(&crate::LodChoice::Highest).unwrap();
            let d = read_document(&doc(b1(links1), b2(links2)), Some(target)).unwrap();
            let ids: Vec<&str> = d.features.iter().map(|f| f.source_id.as_str()).collect();
            assert_eq!(ids, ["B1", "B2"]);
            let [f1, f2] = &d.features[..] else {
                unreachable!()
            };
            assert_eq!((f1.polygons.len(), f1.top_z), (1, Some(5.0)));
            assert!(
                f1.polygons[0][0].iter().all(|p| p[0] <= 1004.0),
                "B1 is its own box"
            );
            assert_eq!(
                (f2.polygons.len(), f2.top_z),
                (2, Some(2.0)),
                "B2 and its part"
            );
            assert!(f2.polygons[0][0].iter().all(|p| p[0] >= 1004.0));
            let model = |f: &RawFeature| f.model.clone().unwrap().unwrap().surfaces.len();
            assert_eq!((model(f1), model(f2)), (6, 12));
            assert_eq!(d.non_building_objects, 0);
        }
    }

    #[test]
    fn a_building_with_its_own_geometry_covers_its_parts_too() {
        let b = json!({"type": "Building", "children": ["P1"], "geometry": [cube(true)]});
        let annexed = |geometry: Value| json!({"P1": {"type": "BuildingPart", "parents": ["B1"], "geometry": geometry}});
        let d = read_document(&doc(b.clone(), annexed(json!([annex()]))), None).unwrap();
        let f = &d.features[0];
        assert_eq!(d.features.len(), 1);
        assert!(f.skip.is_none() && f.assemble, "{:?}", f.skip);
        let xs: Vec<f64> = f
            .polygons
            .iter()
            .flat_map(|p| &p[0])
            .map(|p| p[0])
            .collect();
        assert_eq!(f.polygons.len(), 2, "the building's ground and the annex's");
        assert!(xs.contains(&1006.0) && xs.contains(&1000.0), "{xs:?}");
        assert_eq!((f.footprint_min_z, f.top_z), (Some(0.0), Some(5.0)));

        // The building's LoD0 stands for all of it: a part's 3D ground is not added, its own LoD0 is.
        let lod0 = json!({"type": "MultiSurface", "lod": "0", "boundaries": [[[0, 1, 2, 3]]]});
        let annex_lod0 =
            json!({"type": "MultiSurface", "lod": 0, "boundaries": [[[8, 9, 10, 11]]]});
        let with_lod0 = json!({"type": "Building", "children": ["P1"], "geometry": [lod0]});
        let f = &read_document(&doc(with_lod0.clone(), annexed(json!([annex()]))), None)
            .unwrap()
            .features[0];
        assert_eq!(
            (f.polygons.len(), f.top_z),
            (1, Some(2.0)),
            "the annex's top still counts"
        );
        let f = &read_document(&doc(with_lod0, annexed(json!([annex_lod0, annex()]))), None)
            .unwrap()
            .features[0];
        assert_eq!(f.polygons.len(), 2);

        // Installations and other children are not parts: neither footprint nor top; counted as not buildings.
        let d = read_document(
            &doc(b, json!({"I": {"type": "BuildingInstallation", "parents": ["B1"], "geometry": [annex()]}})),
            None,
        )
        .unwrap();
        assert_eq!(
            (d.features[0].polygons.len(), d.non_building_objects),
            (1, 1)
        );
    }

    #[test]
    fn lod0_roof_edges_are_not_the_footprint() {
        let lod0 = |semantic: Option<&str>, first: u64| {
            let mut g = json!({"type": "MultiSurface", "lod": "0",
                "boundaries": [[[first, first + 1, first + 2, first + 3]]]});
            if let Some(t) = semantic {
                g["semantics"] = json!({"surfaces": [{"type": t}], "values": [0]});
            }
            g
        };
        // The roof edge overhangs the walls at roof height (vertices 16..19: 0.5 m out, z = 5 m).
        let read = |geometry: Value| {
            let mut d = doc(json!({"type": "Building", "geometry": geometry}), json!({}));
            for v in [
                [-500, -500, 5000],
                [4500, -500, 5000],
                [4500, 3500, 5000],
                [-500, 3500, 5000],
            ] {
                d["vertices"].as_array_mut().unwrap().push(json!(v));
            }
            read_document(&d, None).unwrap().features.remove(0)
        };
        let in_walls = |f: &RawFeature| {
            assert!(f.skip.is_none(), "{:?}", f.skip);
            assert_eq!(f.polygons.len(), 1);
            assert!(f.polygons[0][0]
                .iter()
                .all(|p| (1000.0..=1004.0).contains(&p[0])));
            assert_eq!(f.footprint_min_z, Some(0.0));
        };
        // Beside a 3D geometry, the roof edge alone: the 3D geometry's ground.
        in_walls(&read(json!([lod0(Some("RoofSurface"), 16), cube(true)])));
        // Beside a LoD0 ground, labelled or not: that ground.
        in_walls(&read(json!([
            lod0(Some("GroundSurface"), 0),
            lod0(Some("RoofSurface"), 16)
        ])));
        in_walls(&read(json!([
            lod0(None, 0),
            lod0(Some("RoofSurface"), 16),
            cube(true)
        ])));
        // Alone: no footprint, and the reason says why.
        let f = read(json!([lod0(Some("RoofSurface"), 16)]));
        let (reason, detail) = f.skip.unwrap();
        assert_eq!(reason, IssueReason::NoFootprint);
        assert!(
            detail.contains("RoofSurface") && detail.contains("roof edge"),
            "{detail}"
        );
    }

    #[test]
    fn a_missing_transform_is_an_error_from_cityjson_1_1_on() {
        let mut d = doc(
            json!({"type": "Building", "geometry": [cube(true)]}),
            json!({}),
        );
        d.as_object_mut().unwrap().remove("transform");
        for version in ["1.1", "1.1.0", "2.0", "2.0.1", "3", "", "v1.0", "one"] {
            d["version"] = json!(version);
            let e = read_document(&d, None).expect_err(version);
            assert!(
                e.contains("transform") && e.contains("before version 1.1"),
                "{version}: {e}"
            );
        }
        d.as_object_mut().unwrap().remove("version");
        let e = read_document(&d, None).expect_err("no version");
        assert!(e.contains("without a version"), "{e}");
        for version in ["0.8", "0.9", "1.0", "1.0.3", " 1.0 ", "1"] {
            d["version"] = json!(version);
            let f = &read_document(&d, None).expect(version).features[0];
            assert!(f.skip.is_none(), "{version}: {:?}", f.skip);
            assert!(
                f.polygons[0][0].iter().any(|p| p[0] == 4000.0),
                "{version}: vertices as given"
            );
        }
    }

    #[test]
    fn bad_vertex_index_skips_the_building_not_the_file() {
        let mut g = cube(true);
        g["boundaries"][0][0][0][0] = json!(99);
        let d = read_document(
            &doc(json!({"type": "Building", "geometry": [g]}), json!({})),
            None,
        )
        .unwrap();
        assert_eq!(
            d.features[0].skip.as_ref().unwrap().0,
            IssueReason::MalformedGeometry
        );
    }

    #[test]
    fn a_vertex_index_that_is_no_index_is_told_from_one_out_of_range() {
        // Found by tests/json_mutations.rs: `"3"`, `null`, `-1` and `[2]` were all "out of range".
        for (bad, says) in [
            (
                json!(99),
                "vertex index 99 out of range: there are 16 vertices",
            ),
            (json!(u64::MAX), "out of range: there are 16 vertices"),
            (
                json!("3"),
                r#"vertex index "3" is not an index (a whole number from 0)"#,
            ),
            (json!(null), "vertex index null is not an index"),
            (json!(-1), "vertex index -1 is not an index"),
            (json!(1.5), "vertex index 1.5 is not an index"),
            (json!([2]), "vertex index [2] is not an index"),
        ] {
            for target in [None, Some(Target::of(&crate::LodChoice::Highest).unwrap())] {
                let mut g = cube(true);
                g["boundaries"][0][0][0][1] = bad.clone();
                let d = read_document(
                    &doc(json!({"type": "Building", "geometry": [g]}), json!({})),
                    target,
                )
                .unwrap();
                let (reason, detail) = d.features[0].skip.clone().unwrap();
                assert_eq!(reason, IssueReason::MalformedGeometry);
                assert!(detail.contains(says), "{bad}: {detail}");
            }
            // The 3D model's reader says the same (a higher LoD than the footprint's, so only the model reads it).
            let mut g = cube(true);
            g["lod"] = json!("2.2");
            g["boundaries"][0][1][0][1] = bad.clone();
            let b = json!({"type": "Building", "geometry": [cube(true), g]});
            let target = Target::of(&crate::LodChoice::Exact("2.2".into())).unwrap();
            let d = read_document(&doc(b, json!({})), Some(target)).unwrap();
            let (reason, detail) = d.features[0].model.clone().unwrap().unwrap_err();
            assert_eq!(reason, IssueReason::ModelInvalid);
            assert!(detail.contains(says), "{bad}: {detail}");
        }
    }

    #[test]
    fn sequence_features_use_the_header_transform_and_their_own_vertices() {
        let text = concat!(
            r#"{"type":"CityJSON","version":"2.0","transform":{"scale":[0.5,0.5,0.5],"translate":[100,200,0]},"#,
            r#""metadata":{"referenceSystem":"https://www.opengis.net/def/crs/EPSG/0/7415"},"CityObjects":{},"vertices":[]}"#,
            "\n\n",
            r#"{"type":"CityJSONFeature","id":"A","CityObjects":{"A":{"type":"Building","attributes":{"b3_h_maaiveld":1.5},"#,
            r#""geometry":[{"type":"MultiSurface","lod":"0","boundaries":[[[0,1,2,3]]]}],"children":["A-0"]},"#,
            r#""A-0":{"type":"BuildingPart","parents":["A"],"geometry":[]}},"vertices":[[0,0,2],[8,0,2],[8,6,2],[0,6,2]]}"#,
            "\n"
        );
        let d = read_sequence(text, None).unwrap().unwrap();
        assert_eq!(d.features.len(), 1);
        let f = &d.features[0];
        assert_eq!(f.source_id, "A");
        assert_eq!(
            f.polygons[0][0],
            vec![
                [100.0, 200.0],
                [104.0, 200.0],
                [104.0, 203.0],
                [100.0, 203.0]
            ]
        );
        assert_eq!(f.footprint_min_z, Some(1.0));
        assert_eq!(d.version.as_deref(), Some("2.0"));
        let e = read_sequence(
            "{\"type\":\"CityJSON\",\"version\":\"2.0\",\"transform\":{\"scale\":[1,1,1],\"translate\":[0,0,0]}}\n{broken",
            None,
        ).unwrap_err();
        assert_eq!(e.0, 2);
    }

    #[test]
    fn sequence_header_objects_are_read_over_the_header_vertices() {
        let header = |objects: &str, vertices: &str| {
            format!(
                r#"{{"type":"CityJSON","version":"2.0","transform":{{"scale":[1,1,1],"translate":[0,0,0]}},"CityObjects":{objects},"vertices":{vertices}}}"#
            )
        };
        let lod0 = r#"{"type":"Building","geometry":[{"type":"MultiSurface","lod":"0","boundaries":[[[0,1,2]]]}]}"#;
        let line = format!(
            r#"{{"type":"CityJSONFeature","id":"A","CityObjects":{{"A":{lod0}}},"vertices":[[0,0,0],[8,0,0],[8,6,0]]}}"#
        );
        // A CityJSON document saved as .jsonl: its one line is the header, and its buildings are read.
        let h = header(
            &format!(r#"{{"H":{lod0},"T":{{"type":"TINRelief"}}}}"#),
            "[[50,0,0],[58,0,0],[58,6,0]]",
        );
        let d = read_sequence(&h, None).unwrap().unwrap();
        assert_eq!(d.features.len(), 1);
        assert!(d.features[0].skip.is_none(), "{:?}", d.features[0].skip);
        assert_eq!(
            d.features[0].polygons[0][0][1],
            [58.0, 0.0],
            "the header's vertices"
        );
        assert_eq!(d.non_building_objects, 1);
        // With feature lines: the header's first, each over its own vertices.
        let d = read_sequence(&format!("{h}\n{line}\n"), None)
            .unwrap()
            .unwrap();
        let ids: Vec<&str> = d.features.iter().map(|f| f.source_id.as_str()).collect();
        assert_eq!(ids, ["H", "A"]);
        assert_eq!(d.features[1].polygons[0][0][1], [8.0, 0.0]);
        // Broken header vertices skip the header's buildings, naming line 1; the lines are still read.
        let h = header(&format!(r#"{{"H":{lod0}}}"#), "[[50,0]]");
        let d = read_sequence(&format!("{h}\n{line}\n"), None)
            .unwrap()
            .unwrap();
        let (reason, detail) = d.features[0].skip.clone().unwrap();
        assert_eq!(reason, IssueReason::MalformedGeometry);
        assert!(
            detail.contains("line 1") && detail.contains("vertex 0"),
            "{detail}"
        );
        assert!(d.features[1].skip.is_none());
        // Header objects that are no object: an error, not a silent nothing.
        let e = read_sequence(&header("[]", "[]"), None)
            .unwrap()
            .unwrap_err();
        assert!(e.contains("line 1") && e.contains("CityObjects"), "{e}");
    }

    /// A document's text with `objects` (JSON text, keys may repeat) and `tail` (more top-level members).
    fn document_text(objects: &str, tail: &str) -> String {
        format!(
            r#"{{"type": "CityJSON", "version": "2.0", "transform": {{"scale": [1, 1, 1], "translate": [0, 0, 0]}},
            "metadata": {{"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/7415"}},
            "CityObjects": {objects}, "vertices": [[0, 0, 0], [8, 0, 0], [8, 6, 0], [0, 6, 0]]{tail}}}"#
        )
    }

    fn read_text(text: &str) -> Result<CityDoc, String> {
        read_document_text(text, &serde_json::from_str(text).unwrap(), None)
    }

    const LOD0: &str = r#"{"type": "MultiSurface", "lod": "0", "boundaries": [[[0, 1, 2, 3]]]}"#;

    #[test]
    fn repeated_keys_the_reader_uses_are_refused_naming_them() {
        let b = format!(r#"{{"type": "Building", "geometry": [{LOD0}]}}"#);
        let refused = |text: &str, names: &[&str]| {
            let e = read_text(text).expect_err(text);
            // The reason every refusal ends with; what was repeated is named before it.
            assert!(e.ends_with(keys::REFUSED), "{e}");
            for n in names {
                assert!(e.contains(n), "{n} not in {e}");
            }
        };
        refused(
            &document_text(&format!(r#"{{"B1": {b}, "B2": {b}, "B1": {b}}}"#), ""),
            &[r#"CityObjects id "B1" given more than once"#],
        );
        refused(
            &document_text(
                &format!(r#"{{"B0": {b}}}, "CityObjects": {{"B1": {b}}}"#),
                "",
            ),
            &["duplicate field `CityObjects`"],
        );
        refused(
            &document_text(&format!(r#"{{"B1": {b}}}"#), r#", "vertices": []"#),
            &["duplicate field `vertices`"],
        );
        refused(
            &document_text(
                &format!(r#"{{"B1": {b}}}"#),
                r#", "transform": {"scale": [2, 2, 2], "translate": [0, 0, 0]}"#,
            ),
            &["duplicate field `transform`"],
        );
        refused(
            &document_text(
                &format!(
                    r#"{{"B1": {{"type": "Building", "geometry": [], "geometry": [{LOD0}]}}}}"#
                ),
                "",
            ),
            &[r#"CityObjects "B1": duplicate field `geometry`"#],
        );
        let roof_or_ground = r#"{"type": "MultiSurface", "lod": "0", "boundaries": [[[0, 1, 2, 3]]],
            "semantics": {"surfaces": [{"type": "RoofSurface", "type": "GroundSurface"}], "values": [0]}}"#;
        refused(
            &document_text(
                &format!(r#"{{"B1": {{"type": "Building", "geometry": [{roof_or_ground}]}}}}"#),
                "",
            ),
            &[r#"CityObjects "B1": duplicate field `type`"#],
        );
    }

    #[test]
    fn repeated_keys_elsewhere_are_read_or_reported() {
        // Members the reader does not use, and used members of another JSON type, are left alone.
        let text = document_text(
            &format!(
                r#"{{"B1": {{"type": "Building", "address": 1, "address": 2, "geometry": [{LOD0}],
                "attributes": {{"h": 3, "roof": 1, "h": 4, "h": 5, "roof": 2, "name": "x"}}}},
                "B2": {{"type": "Building", "geometry": {{"lod": 1, "lod": 2}}}}}}"#
            ),
            r#", "appearance": {}, "appearance": [], "metadata2": {"a": 1, "a": 1}"#,
        );
        let d = read_text(&text).unwrap();
        let [b1, b2] = &d.features[..] else {
            panic!("two buildings")
        };
        assert!(b1.skip.is_none() && b1.polygons.len() == 1, "{:?}", b1.skip);
        assert_eq!(b2.skip.as_ref().unwrap().0, IssueReason::NoGeometry);
        // Repeated attribute keys: the last value kept, and reported on the building.
        assert_eq!(b1.attributes["h"], citylod_model::AttrValue::Int(5));
        assert_eq!(
            b1.repairs,
            [(
                IssueReason::DuplicateKey,
                "repeated attribute keys, the last value of each kept: h (given 3 times), roof (given 2 times)".into()
            )]
        );
        assert!(b2.repairs.is_empty());
        // The same in a sequence line, and a repeat there is refused naming the line and the id.
        let header = r#"{"type":"CityJSON","version":"2.0","transform":{"scale":[1,1,1],"translate":[0,0,0]},"CityObjects":{},"vertices":[]}"#;
        let line = |objects: &str| {
            format!(
                r#"{{"type":"CityJSONFeature","id":"A","CityObjects":{objects},"vertices":[[0,0,0],[8,0,0],[8,6,0],[0,6,0]]}}"#
            )
        };
        let attrs = line(&format!(
            r#"{{"A":{{"type":"Building","attributes":{{"h":1,"h":2}},"geometry":[{LOD0}]}}}}"#
        ));
        let d = read_sequence(&format!("{header}\n{attrs}\n"), None)
            .unwrap()
            .unwrap();
        assert_eq!(d.features[0].repairs[0].0, IssueReason::DuplicateKey);
        let b = format!(r#"{{"type":"Building","geometry":[{LOD0}]}}"#);
        let twice = line(&format!(
            r#"{{"A":{{"type":"Building","geometry":[]}},"A":{b}}}"#
        ));
        // A line giving an id twice has its buildings skipped, the line and the id named; the others are read.
        let d = read_sequence(&format!("{header}\n{attrs}\n{twice}\n"), None)
            .unwrap()
            .unwrap();
        let [read, skipped] = &d.features[..] else {
            panic!("one building a line: {}", d.features.len())
        };
        assert!(read.skip.is_none());
        let (reason, e) = skipped.skip.as_ref().expect("skipped");
        assert_eq!(*reason, IssueReason::DuplicateKey);
        assert!(
            e.starts_with("line 3, column ")
                && e.contains(r#"CityObjects id "A" given more than once"#),
            "{e}"
        );
        assert!(!e.contains(" at line "), "one position: {e}");
        // A member repeated inside a city object of a line: the same.
        let type_twice = line(&format!(
            r#"{{"A":{{"type":"Building","type":"BuildingPart","geometry":[{LOD0}]}}}}"#
        ));
        let d = read_sequence(&format!("{header}\n{type_twice}\n{attrs}\n"), None)
            .unwrap()
            .unwrap();
        let (reason, e) = d.features[0].skip.as_ref().expect("skipped");
        assert_eq!(*reason, IssueReason::DuplicateKey);
        assert!(
            e.starts_with("line 2, ") && e.contains("duplicate field `type`"),
            "{e}"
        );
        assert!(d.features[1].skip.is_none());
        let header_twice = header.replace(r#""vertices":[]"#, r#""vertices":[],"transform":{}"#);
        let e = read_sequence(&format!("{header_twice}\n{attrs}\n"), None)
            .unwrap()
            .unwrap_err();
        assert!(
            e.starts_with("line 1, ") && e.contains("duplicate field `transform`"),
            "{e}"
        );
    }

    #[test]
    fn vertices_that_are_not_three_numbers_are_a_file_error() {
        let b = json!({"type": "Building", "geometry": [cube(true)]});
        for bad in [
            json!([0, null, 0, 0]),
            json!(["x", 0, 0, 0]),
            json!([0, 0]),
            json!([0, 0, "5"]),
        ] {
            let mut d = doc(b.clone(), json!({}));
            d["vertices"][1] = bad.clone();
            let e = read_document(&d, None).expect_err("rejected");
            assert!(
                e.contains("vertex 1 ") && e.contains(&bad.to_string()),
                "{bad}: {e}"
            );
        }
        for k in ["scale", "translate"] {
            let mut d = doc(b.clone(), json!({}));
            d["transform"][k] = json!([1, null, 1, 1]);
            let e = read_document(&d, None).expect_err("rejected");
            assert!(e.contains(&format!("transform.{k}")), "{e}");
        }
        // A sequence line's vertices are its own: its buildings are skipped, naming the line and vertex.
        let text = concat!(
            r#"{"type":"CityJSON","version":"2.0","transform":{"scale":[1,1,1],"translate":[0,0,0]},"CityObjects":{},"vertices":[]}"#,
            "\n",
            r#"{"type":"CityJSONFeature","id":"A","CityObjects":{"A":{"type":"Building","geometry":[{"type":"MultiSurface","lod":"0","boundaries":[[[0,1,2]]]}]}},"vertices":[[0,0,0],[8,null,0,0],[8,6,0]]}"#,
            "\n"
        );
        let d = read_sequence(text, None).unwrap().unwrap();
        let (reason, detail) = d.features[0].skip.as_ref().unwrap();
        assert_eq!(*reason, IssueReason::MalformedGeometry);
        assert!(
            detail.contains("line 2") && detail.contains("vertex 1 "),
            "{detail}"
        );
    }

    fn instance(template: usize, reference: usize) -> Value {
        json!({"type": "GeometryInstance", "template": template, "boundaries": [reference],
            "transformationMatrix": [2, 0, 0, 0,  0, 2, 0, 0,  0, 0, 2, 0,  0, 0, 0, 1]})
    }

    #[test]
    fn geometry_instances_give_their_template_footprint_and_model() {
        let mut d = doc(
            json!({"type": "Building", "geometry": [instance(0, 1)]}),
            json!({}),
        );
        // Template: a unit cube in real coordinates (the transform does not apply to it).
        d["geometry-templates"] = json!({"templates": [cube(true)], "vertices-templates":
            [[0,0,0],[1,0,0],[1,1,0],[0,1,0],[0,0,1],[1,0,1],[1,1,1],[0,1,1]]});
        let target = Target::of(&crate::LodChoice::Highest).unwrap();
        let f = &read_document(&d, Some(target)).unwrap().features[0];
        assert!(f.skip.is_none(), "{:?}", f.skip);
        // Vertex 1 decodes to (1004, 2000, 0); the cube is scaled by 2 from there.
        let mut ring = f.polygons[0][0].clone();
        ring.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert_eq!(
            ring,
            [
                [1004.0, 2000.0],
                [1004.0, 2002.0],
                [1006.0, 2000.0],
                [1006.0, 2002.0]
            ]
        );
        assert_eq!((f.footprint_min_z, f.top_z), (Some(0.0), Some(2.0)));
        let model = f
            .model
            .as_ref()
            .unwrap()
            .as_ref()
            .expect("the template is the model");
        assert_eq!(model.surfaces.len(), 6);
        assert!(model
            .positions_src
            .iter()
            .all(|p| p[0] >= 1004.0 && p[2] <= 2.0));
    }

    #[test]
    fn unresolvable_instances_skip_the_building_with_the_reason() {
        let d = doc(
            json!({"type": "Building", "geometry": [instance(0, 1)]}),
            json!({}),
        );
        let (reason, detail) = read_document(&d, None).unwrap().features[0]
            .skip
            .clone()
            .unwrap();
        assert_eq!(reason, IssueReason::MalformedGeometry);
        assert!(detail.contains("no geometry-templates"), "{detail}");
        let mut d = doc(
            json!({"type": "Building", "geometry": [instance(0, 1)]}),
            json!({}),
        );
        d["geometry-templates"] =
            json!({"templates": [cube(true)], "vertices-templates": [[0, 0, "z"]]});
        let e = read_document(&d, None).expect_err("broken template vertices are a file error");
        assert!(e.contains("vertices-templates"), "{e}");
    }

    #[test]
    fn reference_system_objects_are_read_or_reported() {
        let mut d = doc(
            json!({"type": "Building", "geometry": [cube(true)]}),
            json!({}),
        );
        d["metadata"]["referenceSystem"] = json!({"authority": "EPSG", "code": 7415});
        assert_eq!(
            read_document(&d, None).unwrap().declared_crs,
            Some(DeclaredCrs::Name("EPSG:7415".into()))
        );
        d["metadata"]["referenceSystem"] = json!({"type": "Projected"});
        assert!(matches!(
            read_document(&d, None).unwrap().declared_crs,
            Some(DeclaredCrs::NotUnderstood {
                member: "metadata.referenceSystem",
                ..
            })
        ));
    }

    #[test]
    fn building_without_geometry_is_skipped_with_a_reason() {
        let d = read_document(&doc(json!({"type": "Building"}), json!({})), None).unwrap();
        assert_eq!(
            d.features[0].skip.as_ref().unwrap().0,
            IssueReason::NoGeometry
        );
    }
}
