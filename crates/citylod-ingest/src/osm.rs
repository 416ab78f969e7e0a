//! OpenStreetMap PBF input (`.osm.pbf`: what Geofabrik, BBBike, osmium and osmosis write). Every way and every
//! multipolygon relation tagged `building` or `building:part` (any value but `no`) is a building; its tags are its
//! attributes (all text, as OSM has them), with `osm_type` and `osm_id` as the GeoJSON exports of OSM data name them,
//! so a building's id is `way/ID` or `relation/ID` either way.
//!
//! The file format (wiki.openstreetmap.org/wiki/PBF_Format): a sequence of blobs, each a 4-byte big-endian length,
//! a `BlobHeader` and a `Blob` (raw or zlib-compressed) holding a `HeaderBlock` or a `PrimitiveBlock` of nodes
//! (plain or dense, delta-coded), ways (node references delta-coded, locations too when the file has
//! `LocationsOnWays`) and relations. The protocol-buffer messages are decoded here field by field.
//!
//! Read in three passes over the decompressed blocks, so that only what buildings need is kept: the relations
//! tagged as buildings and the ways they name; the ways tagged as buildings and those members; the nodes those ways
//! use. A building whose nodes or member ways the extract cut away is skipped (`incomplete_in_extract`), one whose
//! way does not close, or whose relation's ways do not join into closed rings, is `malformed_geometry`; a building
//! mapped as a point (a node) is skipped as `unsupported_geometry`. A relation's rings are outers or holes by how
//! they nest (every second level inside another ring is a hole), not by their members' roles, which are often wrong.

use crate::feature::{RawFeature, RawPolygon};
use crate::report::IssueReason;
use citylod_model::{AttrValue, Attributes};
use rayon::prelude::*;
use std::collections::{HashMap, HashSet};
use std::io::Read;
use std::path::Path;

/// The format's limits: a BlobHeader is at most 64 KiB, a Blob's data at most 32 MiB.
const MAX_BLOB_HEADER: usize = 64 * 1024;
const MAX_BLOB: usize = 32 * 1024 * 1024;

/// The features of a PBF file and what the user should know about the file as a whole.
pub(crate) struct OsmDoc {
    pub features: Vec<RawFeature>,
    pub notes: Vec<String>,
}

/// The street centre lines of a PBF file: each `highway` way's id, name and points (lon°, lat°), or why it has none.
pub(crate) struct OsmLine {
    pub id: String,
    pub points: Result<Vec<[f64; 2]>, (IssueReason, String)>,
}

/// How a file holds OpenStreetMap data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Encoding {
    /// `.osm.pbf`, `.pbf`
    Pbf,
    /// `.osm` (JOSM, the Overpass API, the OSM API), also gzip-compressed as `.osm.gz`
    Xml,
}

impl Encoding {
    /// The encoding a file's name says, if it says OpenStreetMap.
    pub(crate) fn of(path: &Path) -> Option<Self> {
        let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        if name.ends_with(".pbf") {
            Some(Encoding::Pbf)
        } else if name.ends_with(".osm") || name.ends_with(".osm.gz") {
            Some(Encoding::Xml)
        } else {
            None
        }
    }

    pub(crate) fn label(self) -> &'static str {
        match self {
            Encoding::Pbf => "PBF",
            Encoding::Xml => "XML",
        }
    }
}

/// What to read from a file.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Want {
    Buildings,
    Streets,
}

/// What buildings or streets need from a file, whatever its encoding: the ways and relations kept, the locations of
/// the nodes those ways use, the nodes tagged as buildings, and notes on the file.
#[derive(Default)]
pub(crate) struct Gathered {
    pub ways: Vec<Way>,
    pub relations: Vec<Relation>,
    pub located: HashMap<i64, [i64; 2]>,
    pub point_buildings: Vec<(i64, Vec<(String, String)>)>,
    pub notes: Vec<String>,
}

impl Gathered {
    /// A way's locations (nanodegrees lat, lon), or the nodes the file lacks.
    fn points(&self, w: &Way) -> Result<Vec<[i64; 2]>, Vec<i64>> {
        if let Some(l) = &w.locations {
            return located_on_way(w, l);
        }
        let missing: Vec<i64> = w
            .refs
            .iter()
            .filter(|r| !self.located.contains_key(r))
            .copied()
            .collect();
        if missing.is_empty() {
            Ok(w.refs.iter().map(|r| self.located[r]).collect())
        } else {
            Err(missing)
        }
    }
}

fn gather(path: &Path, want: Want) -> Result<Gathered, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read the file: {e}"))?;
    match Encoding::of(path) {
        Some(Encoding::Xml) => crate::osm_xml::gather(path, &bytes, want),
        _ => gather_pbf(&bytes, want),
    }
}

/// Reads the buildings of an OSM file; `Err` (a detail) when the file is not one or is broken.
pub(crate) fn read(path: &Path) -> Result<OsmDoc, String> {
    let g = gather(path, Want::Buildings)?;
    let mut features = Vec::new();
    for (id, tags) in &g.point_buildings {
        let mut f = feature("node", *id, tags.clone());
        f.skip = Some((
            IssueReason::UnsupportedGeometry,
            "a building mapped as a point (a node): it has no outline".into(),
        ));
        features.push(f);
    }
    let by_id: HashMap<i64, &Way> = g.ways.iter().map(|w| (w.id, w)).collect();
    for w in g.ways.iter().filter(|w| building_tags(&w.tags)) {
        let mut f = feature("way", w.id, w.tags.clone());
        match g.points(w) {
            Err(missing) => f.skip = Some(incomplete_nodes(&missing, w.refs.len())),
            Ok(points) => match closed_ring(&w.refs, &points) {
                Ok(ring) => f.polygons = vec![vec![ring]],
                Err(skip) => f.skip = Some(skip),
            },
        }
        features.push(f);
    }
    let mut grouping = 0usize;
    for r in &g.relations {
        let mut f = feature("relation", r.id, r.tags.clone());
        if !r.is_multipolygon() {
            grouping += 1;
            let kind = r.tag("type").unwrap_or("(none)");
            f.skip = Some((
                IssueReason::UnsupportedGeometry,
                format!(
                    "a relation of type {kind:?}, not a multipolygon: it has no outline of its own (a type=building \
                     relation's outline and parts are read as the ways they are)"
                ),
            ));
            features.push(f);
            continue;
        }
        match relation_polygons(r, &by_id, &|w| g.points(w)) {
            Ok((polygons, dropped)) => {
                f.polygons = polygons;
                if dropped > 0 {
                    f.repairs.push((
                        IssueReason::NonPolygonMemberDropped,
                        format!(
                            "{dropped} member(s) that are not ways (nodes, relations) left out"
                        ),
                    ));
                }
            }
            Err(skip) => f.skip = Some(skip),
        }
        features.push(f);
    }
    let mut notes = g.notes;
    if grouping > 0 {
        notes.push(format!(
            "{grouping} relation(s) tagged as buildings are not multipolygons (type=building groups its outline and \
             parts, which are read as their ways): skipped"
        ));
    }
    Ok(OsmDoc { features, notes })
}

/// The `highway` ways of an OSM file that are streets on the ground: every value but those that are not yet or
/// no longer roads, or lie indoors (`proposed`, `construction`, `abandoned`, `corridor`, …), and not in a tunnel or
/// indoors. Errors as [`read`].
pub(crate) fn read_streets(path: &Path) -> Result<Vec<OsmLine>, String> {
    let g = gather(path, Want::Streets)?;
    Ok(g.ways
        .iter()
        .map(|w| {
            let id = match w.tags.iter().find(|(k, _)| k == "name") {
                Some((_, name)) => format!("way/{} ({name})", w.id),
                None => format!("way/{}", w.id),
            };
            let points = g
                .points(w)
                .map(|l| l.into_iter().map(degrees).collect())
                .map_err(|missing| incomplete_nodes(&missing, w.refs.len()));
            OsmLine { id, points }
        })
        .collect())
}

/// The PBF passes: the relations tagged as buildings and the ways they name; the ways wanted; the nodes they use.
fn gather_pbf(bytes: &[u8], want: Want) -> Result<Gathered, String> {
    let file = File::open(bytes)?;
    let blocks = file.blocks()?;
    let relations: Vec<Relation> = match want {
        Want::Buildings => per_block(&blocks, |b, out| b.relations(out))?,
        Want::Streets => Vec::new(),
    };
    let members = member_ways(&relations);
    let ways: Vec<Way> = per_block(&blocks, |b, out| {
        b.ways(out, |id, tags| wanted_way(want, id, tags, &members))
    })?;
    let needed = needed_nodes(&ways);
    let nodes: Vec<NodeRead> = per_block(&blocks, |b, out| b.nodes(out, &needed))?;
    let mut g = Gathered {
        ways,
        relations,
        located: HashMap::with_capacity(needed.len()),
        ..Default::default()
    };
    for n in nodes {
        match n {
            NodeRead::Location(id, at) => {
                g.located.insert(id, at);
            }
            NodeRead::Building(id, tags) if want == Want::Buildings => {
                g.point_buildings.push((id, tags))
            }
            NodeRead::Building(..) => {}
        }
    }
    if file.locations_on_ways {
        g.notes
            .push("node locations read from the ways (LocationsOnWays)".into());
    }
    Ok(g)
}

/// The ways the multipolygon relations name.
pub(crate) fn member_ways(relations: &[Relation]) -> HashSet<i64> {
    relations
        .iter()
        .filter(|r| r.is_multipolygon())
        .flat_map(|r| r.members.iter())
        .filter(|m| m.kind == MemberKind::Way)
        .map(|m| m.id)
        .collect()
}

pub(crate) fn wanted_way(
    want: Want,
    id: i64,
    tags: &[(String, String)],
    members: &HashSet<i64>,
) -> bool {
    match want {
        Want::Buildings => building_tags(tags) || members.contains(&id),
        Want::Streets => street_tags(tags),
    }
}

/// The nodes whose locations the ways need (none for ways that carry their own).
pub(crate) fn needed_nodes(ways: &[Way]) -> HashSet<i64> {
    ways.iter()
        .filter(|w| w.locations.is_none())
        .flat_map(|w| w.refs.iter().copied())
        .collect()
}

/// A way's locations as the file has them on it, or the nodes without one: a writer that adds locations to ways
/// (osmium) marks a node the extract lacks with an undefined location, outside ±90°, ±180°.
fn located_on_way(w: &Way, l: &[[i64; 2]]) -> Result<Vec<[i64; 2]>, Vec<i64>> {
    let missing: Vec<i64> = w
        .refs
        .iter()
        .zip(l)
        .filter(|(_, p)| !(p[0].abs() <= 90_000_000_000 && p[1].abs() <= 180_000_000_000))
        .map(|(&r, _)| r)
        .collect();
    if missing.is_empty() {
        Ok(l.to_vec())
    } else {
        Err(missing)
    }
}

const NOT_STREETS: [&str; 11] = [
    "proposed",
    "construction",
    "abandoned",
    "disused",
    "razed",
    "planned",
    "corridor",
    "elevator",
    "platform",
    "bus_stop",
    "services",
];

fn street_tags(tags: &[(String, String)]) -> bool {
    let get = |k: &str| tags.iter().find(|(t, _)| t == k).map(|(_, v)| v.as_str());
    match get("highway") {
        Some(h) if !NOT_STREETS.contains(&h) => {
            get("tunnel").is_none_or(|t| t == "no")
                && get("indoor").is_none_or(|t| t == "no")
                && get("area") != Some("yes")
        }
        _ => false,
    }
}

/// Tagged `building` or `building:part` with a value other than `no`.
pub(crate) fn building_tags(tags: &[(String, String)]) -> bool {
    tags.iter()
        .any(|(k, v)| (k == "building" || k == "building:part") && v != "no")
}

/// A raw feature with `tags` as attributes and `osm_type`, `osm_id` beside them (a tag of either name is kept
/// under `tag:NAME`, reported).
fn feature(kind: &str, id: i64, tags: Vec<(String, String)>) -> RawFeature {
    let mut f = RawFeature::default();
    let mut attributes = Attributes::new();
    for (k, v) in tags {
        let k = if k == "osm_type" || k == "osm_id" {
            f.repairs.push((
                IssueReason::DuplicateKey,
                format!("the tag {k:?} is kept as \"tag:{k}\" beside the object's own {k}"),
            ));
            format!("tag:{k}")
        } else {
            k
        };
        attributes.insert(k, AttrValue::String(v));
    }
    attributes.insert("osm_type".into(), AttrValue::String(kind.into()));
    attributes.insert("osm_id".into(), AttrValue::Int(id));
    f.source_id = format!("{kind}/{id}");
    f.attributes = attributes;
    f
}

fn incomplete_nodes(missing: &[i64], of: usize) -> (IssueReason, String) {
    (
        IssueReason::IncompleteInExtract,
        format!(
            "{} of its {of} node(s) are not in the file (the extract cut it), e.g. node {}",
            missing.len(),
            missing[0]
        ),
    )
}

/// Nanodegrees (lat, lon) as (lon°, lat°). An exact integer divided by 10⁹ is the double nearest to the decimal
/// number it stands for, as a GeoJSON export of the same node reads.
fn degrees(p: [i64; 2]) -> [f64; 2] {
    [p[1] as f64 / 1e9, p[0] as f64 / 1e9]
}

/// A closed way's points as an open ring (lon°, lat°), or why it is none.
fn closed_ring(refs: &[i64], points: &[[i64; 2]]) -> Result<Vec<[f64; 2]>, (IssueReason, String)> {
    let (Some(first), Some(last)) = (refs.first(), refs.last()) else {
        return Err((IssueReason::EmptyGeometry, "a way without nodes".into()));
    };
    if first != last {
        return Err((
            IssueReason::MalformedGeometry,
            format!(
                "the way is not closed (it starts at node {first} and ends at node {last}): no outline"
            ),
        ));
    }
    if refs.len() < 4 {
        return Err((
            IssueReason::TooFewPoints,
            format!("a closed way of {} node(s): no area", refs.len()),
        ));
    }
    Ok(points[..points.len() - 1]
        .iter()
        .map(|&p| degrees(p))
        .collect())
}

type WayPoints<'a> = dyn Fn(&Way) -> Result<Vec<[i64; 2]>, Vec<i64>> + 'a;

/// A multipolygon relation's polygons (outer rings with their holes) and the number of members that are not ways.
fn relation_polygons(
    r: &Relation,
    by_id: &HashMap<i64, &Way>,
    way_points: &WayPoints,
) -> Result<(Vec<RawPolygon>, usize), (IssueReason, String)> {
    let mut pieces: Vec<Piece> = Vec::new();
    let mut missing_ways = Vec::new();
    let mut dropped = 0;
    for m in &r.members {
        if m.kind != MemberKind::Way {
            dropped += 1;
            continue;
        }
        let Some(w) = by_id.get(&m.id) else {
            missing_ways.push(m.id);
            continue;
        };
        match way_points(w) {
            Ok(points) if w.refs.len() >= 2 => pieces.push((w.refs.clone(), points)),
            Ok(_) => {
                return Err((
                    IssueReason::MalformedGeometry,
                    format!("member way {} has fewer than 2 nodes", w.id),
                ))
            }
            Err(missing) => {
                let (reason, detail) = incomplete_nodes(&missing, w.refs.len());
                return Err((reason, format!("member way {}: {detail}", w.id)));
            }
        }
    }
    if !missing_ways.is_empty() {
        return Err((
            IssueReason::IncompleteInExtract,
            format!(
                "{} of its member ways are not in the file (the extract cut it), e.g. way {}",
                missing_ways.len(),
                missing_ways[0]
            ),
        ));
    }
    if pieces.is_empty() {
        return Err((
            IssueReason::EmptyGeometry,
            "a multipolygon without member ways".into(),
        ));
    }
    let rings = join_rings(pieces)?;
    Ok((nest(rings), dropped))
}

/// A way's node ids and their locations (nanodegrees lat, lon).
type Piece = (Vec<i64>, Vec<[i64; 2]>);

/// Joins ways end to end into closed rings (their locations, closing node repeated).
fn join_rings(pieces: Vec<Piece>) -> Result<Vec<Vec<[i64; 2]>>, (IssueReason, String)> {
    let mut rings = Vec::new();
    let mut open: Vec<Option<Piece>> = Vec::new();
    for (ids, pts) in pieces {
        if ids.first() == ids.last() {
            if ids.len() < 4 {
                return Err((
                    IssueReason::TooFewPoints,
                    format!("a closed member way of {} node(s): no area", ids.len()),
                ));
            }
            rings.push(pts);
        } else {
            open.push(Some((ids, pts)));
        }
    }
    // Open pieces by the nodes they end at.
    let mut ends: HashMap<i64, Vec<usize>> = HashMap::new();
    for (i, p) in open.iter().enumerate() {
        let (ids, _) = p.as_ref().expect("all present");
        ends.entry(ids[0]).or_default().push(i);
        ends.entry(*ids.last().expect("≥ 2 nodes"))
            .or_default()
            .push(i);
    }
    for start in 0..open.len() {
        let Some((mut ids, mut pts)) = open[start].take() else {
            continue;
        };
        while ids.first() != ids.last() {
            let end = *ids.last().expect("≥ 2 nodes");
            let next = ends
                .get(&end)
                .and_then(|c| c.iter().copied().find(|&i| open[i].is_some()));
            let Some(i) = next else {
                return Err((
                    IssueReason::MalformedGeometry,
                    format!(
                        "the member ways do not join into closed rings: the ring through node {} ends at node {end}, \
                         where no other member way continues it",
                        ids[0]
                    ),
                ));
            };
            let (mut more_ids, mut more_pts) = open[i].take().expect("checked");
            if more_ids[0] != end {
                more_ids.reverse();
                more_pts.reverse();
            }
            ids.extend_from_slice(&more_ids[1..]);
            pts.extend_from_slice(&more_pts[1..]);
        }
        if ids.len() < 4 {
            return Err((
                IssueReason::TooFewPoints,
                format!(
                    "a ring of {} node(s) through node {}: no area",
                    ids.len(),
                    ids[0]
                ),
            ));
        }
        rings.push(pts);
    }
    Ok(rings)
}

/// Closed rings (nanodegrees, closing point repeated) as polygons: a ring inside an odd number of others is a hole
/// of the smallest ring around it, every other ring an outer one. Rings are open in the result (lon°, lat°).
fn nest(rings: Vec<Vec<[i64; 2]>>) -> Vec<RawPolygon> {
    let rings: Vec<Vec<[f64; 2]>> = rings
        .into_iter()
        .map(|r| r[..r.len() - 1].iter().map(|&p| degrees(p)).collect())
        .collect();
    let boxes: Vec<[f64; 4]> = rings.iter().map(|r| crate::feature::ring_box(r)).collect();
    let areas: Vec<f64> = rings.iter().map(|r| area(r).abs()).collect();
    // Around each ring: the rings that contain it (a vertex of it that is not a vertex of theirs lies inside).
    let around: Vec<Vec<usize>> = (0..rings.len())
        .map(|i| {
            (0..rings.len())
                .filter(|&j| {
                    j != i
                        && areas[j] > areas[i]
                        && boxes[j][0] <= boxes[i][0]
                        && boxes[j][1] <= boxes[i][1]
                        && boxes[j][2] >= boxes[i][2]
                        && boxes[j][3] >= boxes[i][3]
                        && rings[i]
                            .iter()
                            .find(|p| !rings[j].contains(p))
                            .is_some_and(|p| inside(*p, &rings[j]))
                })
                .collect()
        })
        .collect();
    let mut polygons: Vec<RawPolygon> = Vec::new();
    let mut polygon_of: HashMap<usize, usize> = HashMap::new();
    let mut order: Vec<usize> = (0..rings.len()).collect();
    order.sort_by_key(|&i| around[i].len());
    for i in order {
        if around[i].len().is_multiple_of(2) {
            polygon_of.insert(i, polygons.len());
            polygons.push(vec![rings[i].clone()]);
        } else {
            // The smallest outer ring around it (one level up).
            let parent = around[i]
                .iter()
                .copied()
                .filter(|&j| around[j].len() + 1 == around[i].len())
                .min_by(|&a, &b| areas[a].total_cmp(&areas[b]));
            match parent.and_then(|p| polygon_of.get(&p)) {
                Some(&p) => polygons[p].push(rings[i].clone()),
                None => {
                    polygon_of.insert(i, polygons.len());
                    polygons.push(vec![rings[i].clone()]);
                }
            }
        }
    }
    polygons
}

fn area(r: &[[f64; 2]]) -> f64 {
    let n = r.len();
    (0..n)
        .map(|i| {
            let (a, b) = (r[i], r[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        / 2.0
}

/// Even-odd point in ring.
fn inside(p: [f64; 2], r: &[[f64; 2]]) -> bool {
    let mut c = false;
    let n = r.len();
    for i in 0..n {
        let (a, b) = (r[i], r[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0])
        {
            c = !c;
        }
    }
    c
}

// ---------------------------------------------------------------------------------------------------------------
// The file: blobs and their blocks.

struct File<'a> {
    /// The data blobs, in file order: raw or zlib-compressed.
    blobs: Vec<Blob<'a>>,
    locations_on_ways: bool,
}

enum Blob<'a> {
    Raw(&'a [u8]),
    Zlib(&'a [u8], usize),
}

impl<'a> File<'a> {
    fn open(bytes: &'a [u8]) -> Result<Self, String> {
        let mut pos = 0usize;
        let mut blobs = Vec::new();
        let mut header = None;
        let mut index = 0usize;
        while pos < bytes.len() {
            let at = pos;
            let cut = || format!("the file ends inside blob {index} (at byte {at}): cut short");
            let len_bytes: [u8; 4] = bytes
                .get(pos..pos + 4)
                .ok_or_else(cut)?
                .try_into()
                .expect("4 bytes");
            let header_len = u32::from_be_bytes(len_bytes) as usize;
            if header_len > MAX_BLOB_HEADER {
                return Err(if index == 0 {
                    "not an OpenStreetMap PBF file (it does not start with a blob header)".into()
                } else {
                    format!("blob {index} (at byte {at}): a header of {header_len} bytes, over the format's 64 KiB")
                });
            }
            pos += 4;
            let h = bytes.get(pos..pos + header_len).ok_or_else(cut)?;
            pos += header_len;
            let mut kind = None;
            let mut size = None;
            for f in Fields::new(h) {
                match f.map_err(|e| format!("blob {index}'s header: {e}"))? {
                    (1, Val::Bytes(b)) => kind = Some(b),
                    (3, Val::Int(n)) => size = Some(n as usize),
                    _ => {}
                }
            }
            let (Some(kind), Some(size)) = (kind, size) else {
                return Err(if index == 0 {
                    "not an OpenStreetMap PBF file (no OSMHeader blob first)".into()
                } else {
                    format!("blob {index} (at byte {at}): a header without its type or size")
                });
            };
            if size > MAX_BLOB {
                return Err(format!(
                    "blob {index} (at byte {at}): {size} bytes, over the format's 32 MiB"
                ));
            }
            let data = bytes.get(pos..pos + size).ok_or_else(cut)?;
            pos += size;
            let blob = Blob::of(data).map_err(|e| format!("blob {index} (at byte {at}): {e}"))?;
            match kind {
                b"OSMHeader" => {
                    if header.is_some() {
                        return Err(format!("blob {index}: a second OSMHeader"));
                    }
                    let data = blob.data().map_err(|e| format!("blob {index}: {e}"))?;
                    header = Some(read_header(&data)?);
                }
                b"OSMData" if header.is_none() => {
                    return Err(if index == 0 {
                        "not an OpenStreetMap PBF file (no OSMHeader blob first)".into()
                    } else {
                        format!("blob {index}: data before the OSMHeader")
                    })
                }
                b"OSMData" => blobs.push(blob),
                // Other blob types are allowed by the format and skipped by readers.
                _ if index == 0 => {
                    return Err("not an OpenStreetMap PBF file (no OSMHeader blob first)".into())
                }
                _ => {}
            }
            index += 1;
        }
        let Some(locations_on_ways) = header else {
            return Err("an empty file: no OSMHeader".into());
        };
        Ok(File {
            blobs,
            locations_on_ways,
        })
    }

    /// Every data blob decompressed, in file order.
    fn blocks(&self) -> Result<Vec<Vec<u8>>, String> {
        self.blobs
            .par_iter()
            .enumerate()
            .map(|(i, b)| b.data().map_err(|e| format!("data blob {i}: {e}")))
            .collect()
    }
}

/// The HeaderBlock's required features, checked; whether node locations are on the ways.
fn read_header(data: &[u8]) -> Result<bool, String> {
    let mut on_ways = false;
    for f in Fields::new(data) {
        match f.map_err(|e| format!("the OSMHeader: {e}"))? {
            (4, Val::Bytes(b)) => {
                let feature = String::from_utf8_lossy(b);
                match &*feature {
                    "OsmSchema-V0.6" | "DenseNodes" => {}
                    "HistoricalInformation" => {
                        return Err("a history file (HistoricalInformation: every version of each object); give a \
                             file of current data"
                            .into())
                    }
                    other => {
                        return Err(format!(
                            "the file requires the feature {other:?}, which this reader does not have"
                        ))
                    }
                }
            }
            (5, Val::Bytes(b)) if b == b"LocationsOnWays" => on_ways = true,
            _ => {}
        }
    }
    Ok(on_ways)
}

impl<'a> Blob<'a> {
    fn of(data: &'a [u8]) -> Result<Self, String> {
        let mut raw = None;
        let mut zlib = None;
        let mut raw_size = None;
        for f in Fields::new(data) {
            match f? {
                (1, Val::Bytes(b)) => raw = Some(b),
                (2, Val::Int(n)) => raw_size = Some(n as usize),
                (3, Val::Bytes(b)) => zlib = Some(b),
                (4, _) => return Err("LZMA-compressed, which this reader does not read".into()),
                (5, _) => return Err("bzip2-compressed, which this reader does not read".into()),
                (6, _) => return Err("LZ4-compressed, which this reader does not read".into()),
                (7, _) => {
                    return Err("Zstandard-compressed, which this reader does not read".into())
                }
                _ => {}
            }
        }
        match (raw, zlib, raw_size) {
            (Some(r), None, _) => Ok(Blob::Raw(r)),
            (None, Some(z), Some(n)) if n <= MAX_BLOB => Ok(Blob::Zlib(z, n)),
            (None, Some(_), Some(n)) => {
                Err(format!("{n} bytes uncompressed, over the format's 32 MiB"))
            }
            (None, Some(_), None) => Err("compressed data without its raw size".into()),
            _ => Err("no data (or both raw and compressed)".into()),
        }
    }

    fn data(&self) -> Result<Vec<u8>, String> {
        match *self {
            Blob::Raw(r) => Ok(r.to_vec()),
            Blob::Zlib(z, n) => {
                let mut out = Vec::with_capacity(n);
                flate2::read::ZlibDecoder::new(z)
                    .take(n as u64 + 1)
                    .read_to_end(&mut out)
                    .map_err(|e| format!("cannot decompress: {e}"))?;
                if out.len() != n {
                    return Err(format!(
                        "decompressed to {} bytes, not the {n} its header says",
                        out.len()
                    ));
                }
                Ok(out)
            }
        }
    }
}

/// Runs `f` on every block in parallel and concatenates what it gives, in block order.
fn per_block<T: Send>(
    blocks: &[Vec<u8>],
    f: impl Fn(&Block, &mut Vec<T>) -> Result<(), String> + Sync,
) -> Result<Vec<T>, String> {
    let parts: Vec<Vec<T>> = blocks
        .par_iter()
        .enumerate()
        .map(|(i, data)| {
            let block = Block::new(data).map_err(|e| format!("data block {i}: {e}"))?;
            let mut out = Vec::new();
            f(&block, &mut out).map_err(|e| format!("data block {i}: {e}"))?;
            Ok(out)
        })
        .collect::<Result<_, String>>()?;
    Ok(parts.into_iter().flatten().collect())
}

/// A relation tagged as a building.
pub(crate) struct Relation {
    pub id: i64,
    pub tags: Vec<(String, String)>,
    pub members: Vec<Member>,
}

impl Relation {
    fn tag(&self, k: &str) -> Option<&str> {
        self.tags
            .iter()
            .find(|(t, _)| t == k)
            .map(|(_, v)| v.as_str())
    }

    fn is_multipolygon(&self) -> bool {
        self.tag("type") == Some("multipolygon")
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum MemberKind {
    Node,
    Way,
    Relation,
}

pub(crate) struct Member {
    pub id: i64,
    pub kind: MemberKind,
}

/// A way kept: its node ids, its tags, its locations when the file has them on its ways (nanodegrees lat, lon).
pub(crate) struct Way {
    pub id: i64,
    pub refs: Vec<i64>,
    pub tags: Vec<(String, String)>,
    pub locations: Option<Vec<[i64; 2]>>,
}

enum NodeRead {
    Location(i64, [i64; 2]),
    Building(i64, Vec<(String, String)>),
}

/// A PrimitiveBlock: its string table, coordinate scale and groups.
struct Block<'a> {
    strings: Vec<&'a [u8]>,
    granularity: i64,
    lat_offset: i64,
    lon_offset: i64,
    groups: Vec<&'a [u8]>,
}

impl<'a> Block<'a> {
    fn new(data: &'a [u8]) -> Result<Self, String> {
        let mut b = Block {
            strings: Vec::new(),
            granularity: 100,
            lat_offset: 0,
            lon_offset: 0,
            groups: Vec::new(),
        };
        for f in Fields::new(data) {
            match f? {
                (1, Val::Bytes(table)) => {
                    for s in Fields::new(table) {
                        if let (1, Val::Bytes(s)) = s? {
                            b.strings.push(s);
                        }
                    }
                }
                (2, Val::Bytes(g)) => b.groups.push(g),
                (17, Val::Int(n)) => b.granularity = n as i32 as i64,
                (19, Val::Int(n)) => b.lat_offset = n as i64,
                (20, Val::Int(n)) => b.lon_offset = n as i64,
                _ => {}
            }
        }
        if b.granularity <= 0 {
            return Err(format!("granularity {} is not positive", b.granularity));
        }
        Ok(b)
    }

    fn string(&self, i: u64) -> Result<String, String> {
        let s = self.strings.get(i as usize).ok_or_else(|| {
            format!(
                "string {i} is not in the block's table of {}",
                self.strings.len()
            )
        })?;
        Ok(String::from_utf8_lossy(s).into_owned())
    }

    fn tags(&self, keys: &[u64], vals: &[u64]) -> Result<Vec<(String, String)>, String> {
        if keys.len() != vals.len() {
            return Err(format!("{} tag keys for {} values", keys.len(), vals.len()));
        }
        keys.iter()
            .zip(vals)
            .map(|(&k, &v)| Ok((self.string(k)?, self.string(v)?)))
            .collect()
    }

    /// Nanodegrees of a raw coordinate pair (lat, lon).
    fn at(&self, lat: i64, lon: i64) -> [i64; 2] {
        let scale = |offset: i64, v: i64| {
            (offset as i128 + self.granularity as i128 * v as i128)
                .clamp(i64::MIN as i128, i64::MAX as i128) as i64
        };
        [scale(self.lat_offset, lat), scale(self.lon_offset, lon)]
    }

    fn group_items(
        &self,
        field: u32,
        mut each: impl FnMut(&'a [u8]) -> Result<(), String>,
    ) -> Result<(), String> {
        for &g in &self.groups {
            for f in Fields::new(g) {
                if let (n, Val::Bytes(b)) = f? {
                    if n == field {
                        each(b)?;
                    }
                }
            }
        }
        Ok(())
    }

    fn relations(&self, out: &mut Vec<Relation>) -> Result<(), String> {
        self.group_items(4, |data| {
            let (mut id, mut keys, mut vals, mut ids, mut types) =
                (0, vec![], vec![], vec![], vec![]);
            for f in Fields::new(data) {
                match f? {
                    (1, Val::Int(n)) => id = n as i64,
                    (2, v) => numbers(v, &mut keys)?,
                    (3, v) => numbers(v, &mut vals)?,
                    (9, v) => numbers(v, &mut ids)?,
                    (10, v) => numbers(v, &mut types)?,
                    _ => {}
                }
            }
            let tags = self.tags(&keys, &vals)?;
            if !building_tags(&tags) {
                return Ok(());
            }
            if ids.len() != types.len() {
                return Err(format!(
                    "relation {id}: {} member ids for {} member types",
                    ids.len(),
                    types.len()
                ));
            }
            let mut member = 0i64;
            let members = ids
                .iter()
                .zip(&types)
                .map(|(&d, &t)| {
                    member = member.wrapping_add(zigzag(d));
                    let kind = match t {
                        0 => MemberKind::Node,
                        1 => MemberKind::Way,
                        2 => MemberKind::Relation,
                        other => return Err(format!("relation {id}: member type {other}")),
                    };
                    Ok(Member { id: member, kind })
                })
                .collect::<Result<_, String>>()?;
            out.push(Relation { id, tags, members });
            Ok(())
        })
    }

    fn ways(
        &self,
        out: &mut Vec<Way>,
        keep: impl Fn(i64, &[(String, String)]) -> bool,
    ) -> Result<(), String> {
        self.group_items(3, |data| {
            let (mut id, mut keys, mut vals, mut refs, mut lats, mut lons) =
                (0, vec![], vec![], vec![], vec![], vec![]);
            for f in Fields::new(data) {
                match f? {
                    (1, Val::Int(n)) => id = n as i64,
                    (2, v) => numbers(v, &mut keys)?,
                    (3, v) => numbers(v, &mut vals)?,
                    (8, v) => numbers(v, &mut refs)?,
                    (9, v) => numbers(v, &mut lats)?,
                    (10, v) => numbers(v, &mut lons)?,
                    _ => {}
                }
            }
            let tags = self.tags(&keys, &vals)?;
            if !keep(id, &tags) {
                return Ok(());
            }
            let refs = deltas(&refs);
            let locations = if lats.is_empty() && lons.is_empty() {
                None
            } else if lats.len() == refs.len() && lons.len() == refs.len() {
                let (lats, lons) = (deltas(&lats), deltas(&lons));
                Some(
                    lats.iter()
                        .zip(&lons)
                        .map(|(&a, &o)| self.at(a, o))
                        .collect(),
                )
            } else {
                return Err(format!(
                    "way {id}: {} nodes but {} latitudes and {} longitudes",
                    refs.len(),
                    lats.len(),
                    lons.len()
                ));
            };
            out.push(Way {
                id,
                refs,
                tags,
                locations,
            });
            Ok(())
        })
    }

    fn nodes(&self, out: &mut Vec<NodeRead>, needed: &HashSet<i64>) -> Result<(), String> {
        // Plain nodes.
        self.group_items(1, |data| {
            let (mut id, mut keys, mut vals, mut lat, mut lon) = (0, vec![], vec![], 0, 0);
            for f in Fields::new(data) {
                match f? {
                    (1, Val::Int(n)) => id = zigzag(n),
                    (2, v) => numbers(v, &mut keys)?,
                    (3, v) => numbers(v, &mut vals)?,
                    (8, Val::Int(n)) => lat = zigzag(n),
                    (9, Val::Int(n)) => lon = zigzag(n),
                    _ => {}
                }
            }
            if needed.contains(&id) {
                out.push(NodeRead::Location(id, self.at(lat, lon)));
            }
            if !keys.is_empty() {
                let tags = self.tags(&keys, &vals)?;
                if building_tags(&tags) {
                    out.push(NodeRead::Building(id, tags));
                }
            }
            Ok(())
        })?;
        // Dense nodes.
        self.group_items(2, |data| {
            let (mut ids, mut lats, mut lons, mut kv) = (vec![], vec![], vec![], vec![]);
            for f in Fields::new(data) {
                match f? {
                    (1, v) => numbers(v, &mut ids)?,
                    (8, v) => numbers(v, &mut lats)?,
                    (9, v) => numbers(v, &mut lons)?,
                    (10, v) => numbers(v, &mut kv)?,
                    _ => {}
                }
            }
            if ids.len() != lats.len() || ids.len() != lons.len() {
                return Err(format!(
                    "dense nodes: {} ids, {} latitudes, {} longitudes",
                    ids.len(),
                    lats.len(),
                    lons.len()
                ));
            }
            let (mut id, mut lat, mut lon) = (0i64, 0i64, 0i64);
            let mut kv = kv.iter().copied();
            for i in 0..ids.len() {
                id = id.wrapping_add(zigzag(ids[i]));
                lat = lat.wrapping_add(zigzag(lats[i]));
                lon = lon.wrapping_add(zigzag(lons[i]));
                if needed.contains(&id) {
                    out.push(NodeRead::Location(id, self.at(lat, lon)));
                }
                // This node's tags: key, value pairs up to a 0 (none at all when the block has no tags).
                let (mut keys, mut vals) = (vec![], vec![]);
                while let Some(k) = kv.next() {
                    if k == 0 {
                        break;
                    }
                    let v = kv
                        .next()
                        .ok_or_else(|| format!("dense node {id}: a tag key without its value"))?;
                    keys.push(k);
                    vals.push(v);
                }
                if !keys.is_empty() {
                    let tags = self.tags(&keys, &vals)?;
                    if building_tags(&tags) {
                        out.push(NodeRead::Building(id, tags));
                    }
                }
            }
            Ok(())
        })
    }
}

fn zigzag(n: u64) -> i64 {
    ((n >> 1) as i64) ^ -((n & 1) as i64)
}

/// Delta-coded signed (zigzag) numbers, summed.
fn deltas(v: &[u64]) -> Vec<i64> {
    let mut at = 0i64;
    v.iter()
        .map(|&d| {
            at = at.wrapping_add(zigzag(d));
            at
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------------------------
// Protocol-buffer fields.

#[derive(Clone, Copy)]
enum Val<'a> {
    Int(u64),
    Bytes(&'a [u8]),
}

/// A repeated number field, packed (one length-delimited run of varints) or not (one varint per field).
fn numbers(v: Val, out: &mut Vec<u64>) -> Result<(), String> {
    match v {
        Val::Int(n) => out.push(n),
        Val::Bytes(b) => {
            let mut pos = 0;
            while pos < b.len() {
                out.push(varint(b, &mut pos)?);
            }
        }
    }
    Ok(())
}

fn varint(buf: &[u8], pos: &mut usize) -> Result<u64, String> {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let b = *buf.get(*pos).ok_or("a number cut short")?;
        *pos += 1;
        v |= u64::from(b & 0x7f) << shift;
        if b & 0x80 == 0 {
            return Ok(v);
        }
    }
    Err("a number of more than 10 bytes".into())
}

/// The fields of one message, in order: (field number, value). Fixed-width values are read as numbers.
struct Fields<'a> {
    buf: &'a [u8],
    pos: usize,
    failed: bool,
}

impl<'a> Fields<'a> {
    fn new(buf: &'a [u8]) -> Self {
        Fields {
            buf,
            pos: 0,
            failed: false,
        }
    }

    fn field(&mut self) -> Result<(u32, Val<'a>), String> {
        let key = varint(self.buf, &mut self.pos)?;
        let number = u32::try_from(key >> 3).map_err(|_| "a field number out of range")?;
        let fixed = |s: &mut Self, n: usize| -> Result<u64, String> {
            let b = s
                .buf
                .get(s.pos..s.pos + n)
                .ok_or("a fixed-width value cut short")?;
            s.pos += n;
            Ok(b.iter().rev().fold(0u64, |v, &x| (v << 8) | u64::from(x)))
        };
        let val = match key & 7 {
            0 => Val::Int(varint(self.buf, &mut self.pos)?),
            1 => Val::Int(fixed(self, 8)?),
            5 => Val::Int(fixed(self, 4)?),
            2 => {
                let n = varint(self.buf, &mut self.pos)?;
                let end = usize::try_from(n)
                    .ok()
                    .and_then(|n| self.pos.checked_add(n))
                    .filter(|&e| e <= self.buf.len())
                    .ok_or("a length-delimited field runs past its message")?;
                let b = &self.buf[self.pos..end];
                self.pos = end;
                Val::Bytes(b)
            }
            w => {
                return Err(format!(
                    "field {number} has wire type {w}, which the format does not use"
                ))
            }
        };
        Ok((number, val))
    }
}

impl<'a> Iterator for Fields<'a> {
    type Item = Result<(u32, Val<'a>), String>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed || self.pos >= self.buf.len() {
            return None;
        }
        let f = self.field();
        self.failed = f.is_err();
        Some(f)
    }
}
