//! OpenStreetMap input, PBF (`osm_pbf`) or XML (`osm_xml`): every way and every multipolygon relation tagged
//! `building` or `building:part` (any value but `no`) is a building; its tags are its attributes (all text, as OSM
//! has them), with `osm_type` and `osm_id` as the GeoJSON exports of OSM data name them, so a building's id is
//! `way/ID` or `relation/ID` either way.
//!
//! A building whose nodes or member ways the extract cut away is skipped (`incomplete_in_extract`), one whose way
//! does not close, or whose relation's ways do not join into closed rings, is `malformed_geometry`; a building mapped
//! as a point (a node) is skipped as `unsupported_geometry`. A relation's member ways are joined where they meet (by
//! location, as osmium does), rings passing a location twice are split there, and rings are outers or holes by how
//! they nest (every second level inside another ring is a hole), not by their members' roles, which are often wrong.

use crate::feature::{RawFeature, RawPolygon};
use crate::report::IssueReason;
use citylod_model::{AttrValue, Attributes};
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// Nodes a way may have here: 50 times what OpenStreetMap's API allows (2,000); a longer one is no building (a
/// memory guard against hostile files).
pub(crate) const MAX_WAY_NODES: usize = 100_000;
/// Members a relation may have: OpenStreetMap's API limit.
pub(crate) const MAX_MEMBERS: usize = 32_000;
/// Rings a multipolygon building may have here, and their nodes in all (their nesting is found pair by pair).
const MAX_RINGS: usize = 2_000;
const MAX_RING_NODES: usize = 500_000;

/// A reason and its detail: why a feature is skipped, or what was repaired.
type Skip = (IssueReason, String);

/// The features of an OSM file and what the user should know about the file as a whole.
pub(crate) struct OsmDoc {
    pub features: Vec<RawFeature>,
    pub notes: Vec<String>,
}

/// The street centre lines of an OSM file: each `highway` way's id, name and points (lon°, lat°), or why it has none.
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
    /// The encoding a file's head says, whatever its name: PBF by its first blob's type `OSMHeader`, XML by a
    /// root element `osm` inside gzip, or text starting with `<` (an Overpass API answer saved as `interpreter`, a
    /// `.xml`: none of the other formats does). Only when the head says neither, the name (`.pbf`; `.osm`,
    /// `.osm.gz`, `.osm.bz2`), so that a broken file named as OpenStreetMap is refused by its reader.
    pub(crate) fn of(path: &Path) -> Option<Self> {
        let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        let mut raw = Vec::new();
        let _ = std::fs::File::open(path).and_then(|f| {
            std::io::Read::read_to_end(&mut std::io::Read::take(f, 64 * 1024), &mut raw)
        });
        if is_pbf_head(&raw) {
            return Some(Encoding::Pbf);
        }
        if raw.starts_with(&[0x1f, 0x8b]) {
            if crate::citygml::root_element(raw).as_deref() == Some("osm") {
                return Some(Encoding::Xml);
            }
        } else {
            let text = raw.strip_prefix(b"\xef\xbb\xbf").unwrap_or(&raw);
            if text.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'<') {
                return Some(Encoding::Xml);
            }
        }
        if name.ends_with(".pbf") {
            return Some(Encoding::Pbf);
        }
        [".osm", ".osm.gz", ".osm.bz2"]
            .iter()
            .any(|e| name.ends_with(e))
            .then_some(Encoding::Xml)
    }

    pub(crate) fn label(self) -> &'static str {
        match self {
            Encoding::Pbf => "PBF",
            Encoding::Xml => "XML",
        }
    }
}

/// The head of an OSM PBF file: its first blob's header, a 4-byte length and then field 1 (`type`) holding
/// `OSMHeader`, as the PBF format requires of every file.
pub(crate) fn is_pbf_head(head: &[u8]) -> bool {
    head.len() >= 15 && head[4] == 0x0a && head[5] == 9 && &head[6..15] == b"OSMHeader"
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
    /// A way's locations (nanodegrees lat, lon), or why it has none: nodes the file lacks, too many nodes.
    fn points(&self, w: &Way) -> Result<Vec<[i64; 2]>, Skip> {
        if let Some(n) = w.oversized {
            return Err((
                IssueReason::MalformedGeometry,
                format!(
                    "a way of {n} nodes, more than the {MAX_WAY_NODES} read here (OpenStreetMap allows 2,000)"
                ),
            ));
        }
        let missing: Vec<i64> = match &w.locations {
            Some(l) => w
                .refs
                .iter()
                .zip(l)
                .filter(|(_, p)| !on_earth(**p))
                .map(|(&r, _)| r)
                .collect(),
            None => w
                .refs
                .iter()
                .filter(|r| !self.located.contains_key(r))
                .copied()
                .collect(),
        };
        if !missing.is_empty() {
            return Err((
                IssueReason::IncompleteInExtract,
                format!(
                    "{} of its {} node(s) are not in the file (the extract cut it), e.g. node {}",
                    missing.len(),
                    w.refs.len(),
                    missing[0]
                ),
            ));
        }
        Ok(match &w.locations {
            Some(l) => l.clone(),
            None => w.refs.iter().map(|r| self.located[r]).collect(),
        })
    }
}

fn gather(path: &Path, want: Want) -> Result<Gathered, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read the file: {e}"))?;
    match Encoding::of(path) {
        Some(Encoding::Xml) => crate::osm_xml::gather(&bytes, want),
        _ => crate::osm_pbf::gather(&bytes, want),
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
        match g.points(w).and_then(|p| closed_ring(&w.refs, &p)) {
            Ok(ring) => f.polygons = vec![vec![ring]],
            Err(skip) => f.skip = Some(skip),
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
        match relation_polygons(r, &by_id, &g) {
            Ok((polygons, repairs)) => {
                f.polygons = polygons;
                f.repairs.extend(repairs);
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
            let points = g.points(w).map(|l| l.into_iter().map(degrees).collect());
            OsmLine { id, points }
        })
        .collect())
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

pub(crate) fn wanted_way<K: AsRef<str>, V: AsRef<str>>(
    want: Want,
    id: i64,
    tags: &[(K, V)],
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

/// A location within ±90°, ±180° (nanodegrees lat, lon). A writer that adds locations to ways (osmium) marks a node
/// the extract lacks with an undefined location outside them.
fn on_earth(p: [i64; 2]) -> bool {
    p[0].unsigned_abs() <= 90_000_000_000 && p[1].unsigned_abs() <= 180_000_000_000
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

fn street_tags<K: AsRef<str>, V: AsRef<str>>(tags: &[(K, V)]) -> bool {
    tags.iter().any(|(k, _)| k.as_ref() == "highway") && off_ground(tags).is_none()
}

/// Why a line with these tags (OpenStreetMap's, or a street file's attributes named alike, names in any case) is no
/// street on the ground between buildings, for the report: in a tunnel (`tunnel` set: `yes`, `building_passage`,
/// `culvert`, or `T` / `true` / `1` as exports of OSM data write it), indoors (`indoor` set), an area (`area=yes`),
/// or a `highway` not yet or no longer a road (`proposed`, `construction`, `abandoned`, …). `None` for a street.
pub(crate) fn off_ground<K: AsRef<str>, V: AsRef<str>>(tags: &[(K, V)]) -> Option<String> {
    let get = |key: &str| {
        tags.iter()
            .find(|(k, _)| k.as_ref().eq_ignore_ascii_case(key))
            .map(|(k, v)| (k.as_ref(), v.as_ref().trim()))
    };
    let flag = |v: &str| {
        tag_set(v)
            && !["f", "false", "0", "n"]
                .iter()
                .any(|no| v.eq_ignore_ascii_case(no))
    };
    if let Some((k, v)) = get("tunnel").filter(|(_, v)| flag(v)) {
        return Some(format!(
            "in a tunnel ({k}={v}): no barrier between the buildings above it"
        ));
    }
    if let Some((k, v)) = get("indoor").filter(|(_, v)| flag(v)) {
        return Some(format!("indoors ({k}={v}), not a street between buildings"));
    }
    if let Some((k, v)) = get("area").filter(|(_, v)| v.eq_ignore_ascii_case("yes")) {
        return Some(format!("an area ({k}={v}), not a street line"));
    }
    if let Some((k, v)) =
        get("highway").filter(|(_, v)| NOT_STREETS.iter().any(|n| v.eq_ignore_ascii_case(n)))
    {
        return Some(format!("{k}={v}: not a road on the ground"));
    }
    None
}

/// The value of OSM tag `key` in a feature's attributes, as GeoJSON and OSM files keep it (`building:part`), as GDAL
/// writes it where a name may not hold a colon (`building_part`: File Geodatabase, PostgreSQL), or as shapefile
/// writers cut either to 10 characters (`building:p`, `building_p`).
pub(crate) fn exported_tag<'a>(attrs: &'a Attributes, key: &str) -> Option<&'a AttrValue> {
    let laundered = key.replace(':', "_");
    let cut = |k: &str| k.chars().take(10).collect::<String>();
    [
        key.to_string(),
        laundered.clone(),
        cut(key),
        cut(&laundered),
    ]
    .iter()
    .find_map(|k| attrs.get(k))
}

/// Why a feature's attributes say it lies wholly below the ground, if they do: OpenStreetMap's `location=underground`
/// (an underground car park, a bunker), Overture Maps' `is_underground` (true, or as text `true`, `yes`, `1`).
pub(crate) fn underground(attrs: &Attributes) -> Option<String> {
    let text = |v: &AttrValue| match v {
        AttrValue::String(s) => Some(s.trim().to_ascii_lowercase()),
        AttrValue::Bool(b) => Some(b.to_string()),
        AttrValue::Int(i) => Some(i.to_string()),
        _ => None,
    };
    if let Some(v) = exported_tag(attrs, "location").and_then(text) {
        if v == "underground" {
            return Some("location=underground: below the ground, not drawn".into());
        }
    }
    let v = attrs.get("is_underground").and_then(text)?;
    matches!(v.as_str(), "true" | "yes" | "1")
        .then(|| format!("is_underground={v} (Overture Maps): below the ground, not drawn"))
}

/// Tagged `building` or `building:part` with a value other than `no`.
pub(crate) fn building_tags<K: AsRef<str>, V: AsRef<str>>(tags: &[(K, V)]) -> bool {
    tags.iter()
        .any(|(k, v)| matches!(k.as_ref(), "building" | "building:part") && tag_set(v.as_ref()))
}

/// A tag value that says yes in OSM's sense: anything but empty or `no` (in any case).
pub(crate) fn tag_set(v: &str) -> bool {
    let v = v.trim();
    !(v.is_empty() || v.eq_ignore_ascii_case("no"))
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

/// Nanodegrees (lat, lon) as (lon°, lat°). An exact integer divided by 10⁹ is the double nearest to the decimal
/// number it stands for, as a GeoJSON export of the same node reads.
fn degrees(p: [i64; 2]) -> [f64; 2] {
    [p[1] as f64 / 1e9, p[0] as f64 / 1e9]
}

/// A closed way's points as an open ring (lon°, lat°), or why it is none. Closed when it ends where it starts (at
/// its first node, or at another node at the same location, as osmium takes it).
fn closed_ring(refs: &[i64], points: &[[i64; 2]]) -> Result<Vec<[f64; 2]>, Skip> {
    let (Some(first), Some(last)) = (points.first(), points.last()) else {
        return Err((IssueReason::EmptyGeometry, "a way without nodes".into()));
    };
    if first != last {
        return Err((
            IssueReason::MalformedGeometry,
            format!(
                "the way is not closed (it starts at node {} and ends at node {}, elsewhere): no outline",
                refs[0],
                refs[refs.len() - 1]
            ),
        ));
    }
    if points.len() < 4 {
        return Err((
            IssueReason::TooFewPoints,
            format!("a closed way of {} node(s): no area", points.len()),
        ));
    }
    Ok(points[..points.len() - 1]
        .iter()
        .map(|&p| degrees(p))
        .collect())
}

/// A multipolygon relation's polygons (outer rings with their holes) and the repairs made on the way: members that
/// are not ways, member ways listed more than once (each taken once).
fn relation_polygons(
    r: &Relation,
    by_id: &HashMap<i64, &Way>,
    g: &Gathered,
) -> Result<(Vec<RawPolygon>, Vec<Skip>), Skip> {
    if let Some(n) = r.oversized {
        return Err((
            IssueReason::MalformedGeometry,
            format!("a relation of {n} members, more than the {MAX_MEMBERS} OpenStreetMap allows"),
        ));
    }
    let mut pieces: Vec<Vec<[i64; 2]>> = Vec::new();
    let mut missing_ways = Vec::new();
    let mut not_ways = 0;
    let mut seen = HashSet::new();
    let mut repeated = Vec::new();
    for m in &r.members {
        if m.kind != MemberKind::Way {
            not_ways += 1;
            continue;
        }
        if !seen.insert(m.id) {
            repeated.push(m.id);
            continue;
        }
        let Some(w) = by_id.get(&m.id) else {
            missing_ways.push(m.id);
            continue;
        };
        let points = g
            .points(w)
            .map_err(|(reason, detail)| (reason, format!("member way {}: {detail}", w.id)))?;
        if points.len() < 2 {
            return Err((
                IssueReason::MalformedGeometry,
                format!("member way {} has fewer than 2 nodes", w.id),
            ));
        }
        pieces.push(points);
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
    let rings: Vec<Vec<[i64; 2]>> = join_rings(pieces)?
        .into_iter()
        .flat_map(split_at_repeats)
        .collect();
    if rings.is_empty() {
        return Err((
            IssueReason::TooFewPoints,
            "its rings enclose no area".into(),
        ));
    }
    let nodes: usize = rings.iter().map(Vec::len).sum();
    if rings.len() > MAX_RINGS || nodes > MAX_RING_NODES {
        return Err((
            IssueReason::MalformedGeometry,
            format!(
                "{} rings of {nodes} nodes, more than the {MAX_RINGS} rings or {MAX_RING_NODES} nodes a building is \
                 read with here",
                rings.len()
            ),
        ));
    }
    let mut repairs = Vec::new();
    if not_ways > 0 {
        repairs.push((
            IssueReason::NonPolygonMemberDropped,
            format!("{not_ways} member(s) that are not ways (nodes, relations) left out"),
        ));
    }
    if !repeated.is_empty() {
        repeated.sort_unstable();
        repeated.dedup();
        let ids: Vec<String> = repeated.iter().map(|w| format!("way {w}")).collect();
        repairs.push((
            IssueReason::NonPolygonMemberDropped,
            format!(
                "member way(s) listed more than once, each taken once: {}",
                crate::geojson::listing(&ids)
            ),
        ));
    }
    Ok((nest(rings), repairs))
}

/// Joins ways end to end, where one ends at the location another starts or ends, into closed rings (closing point
/// repeated). A ring that cannot be closed refuses the relation.
fn join_rings(pieces: Vec<Vec<[i64; 2]>>) -> Result<Vec<Vec<[i64; 2]>>, Skip> {
    let mut rings = Vec::new();
    let mut open: Vec<Option<Vec<[i64; 2]>>> = Vec::new();
    for p in pieces {
        if p.first() == p.last() {
            rings.push(p);
        } else {
            open.push(Some(p));
        }
    }
    // Open pieces by the locations they end at.
    let mut ends: HashMap<[i64; 2], Vec<usize>> = HashMap::new();
    for (i, p) in open.iter().enumerate() {
        let p = p.as_ref().expect("all present");
        ends.entry(p[0]).or_default().push(i);
        ends.entry(p[p.len() - 1]).or_default().push(i);
    }
    for start in 0..open.len() {
        let Some(mut ring) = open[start].take() else {
            continue;
        };
        while ring.first() != ring.last() {
            let end = ring[ring.len() - 1];
            let next = ends
                .get(&end)
                .and_then(|c| c.iter().copied().find(|&i| open[i].is_some()));
            let Some(i) = next else {
                let [lon, lat] = degrees(end);
                return Err((
                    IssueReason::MalformedGeometry,
                    format!(
                        "the member ways do not join into closed rings: one ends at ({lon}, {lat}), where no other \
                         member way continues it"
                    ),
                ));
            };
            let mut more = open[i].take().expect("checked");
            if more[0] != end {
                more.reverse();
            }
            ring.extend_from_slice(&more[1..]);
        }
        rings.push(ring);
    }
    Ok(rings)
}

/// A closed ring split where it passes a location twice into simple closed rings (two outers touching at a corner
/// that the joining walked through as one figure eight, an inner ring touching its outer); what encloses no area (a
/// spike out and back) is dropped.
fn split_at_repeats(ring: Vec<[i64; 2]>) -> Vec<Vec<[i64; 2]>> {
    let mut out = Vec::new();
    let mut path: Vec<[i64; 2]> = Vec::with_capacity(ring.len());
    let mut at: HashMap<[i64; 2], usize> = HashMap::new();
    for &p in &ring[..ring.len() - 1] {
        if let Some(&k) = at.get(&p) {
            let mut loop_ = path.split_off(k);
            for q in &loop_ {
                at.remove(q);
            }
            loop_.push(p);
            if loop_.len() >= 4 {
                out.push(loop_);
            }
        }
        at.insert(p, path.len());
        path.push(p);
    }
    if path.len() >= 3 {
        path.push(path[0]);
        out.push(path);
    }
    out
}

/// Closed simple rings (nanodegrees, closing point repeated) as polygons: a ring inside an odd number of others is a
/// hole of the smallest ring around it, every other ring an outer one (outers in ring order, then their holes).
/// Rings are open in the result (lon°, lat°). Containment is decided exactly, on the integer locations.
fn nest(rings: Vec<Vec<[i64; 2]>>) -> Vec<RawPolygon> {
    let areas: Vec<i128> = rings.iter().map(|r| twice_area(r).abs()).collect();
    let boxes: Vec<[i64; 4]> = rings.iter().map(|r| bounds(r)).collect();
    // Around each ring: how many rings contain it, and the smallest of them.
    let around: Vec<(usize, Option<usize>)> = (0..rings.len())
        .map(|i| {
            let mut count = 0;
            let mut smallest: Option<usize> = None;
            for j in 0..rings.len() {
                let (a, b) = (boxes[i], boxes[j]);
                if j != i
                    && areas[j] > areas[i]
                    && b[0] <= a[0]
                    && b[1] <= a[1]
                    && b[2] >= a[2]
                    && b[3] >= a[3]
                    && ring_inside(&rings[i], &rings[j])
                {
                    count += 1;
                    if smallest.is_none_or(|s| areas[j] < areas[s]) {
                        smallest = Some(j);
                    }
                }
            }
            (count, smallest)
        })
        .collect();
    let open = |r: &[[i64; 2]]| -> Vec<[f64; 2]> {
        r[..r.len() - 1].iter().map(|&p| degrees(p)).collect()
    };
    let mut polygons: Vec<RawPolygon> = Vec::new();
    let mut polygon_of: HashMap<usize, usize> = HashMap::new();
    for (i, r) in rings.iter().enumerate() {
        if around[i].0.is_multiple_of(2) {
            polygon_of.insert(i, polygons.len());
            polygons.push(vec![open(r)]);
        }
    }
    for (i, r) in rings.iter().enumerate() {
        if !around[i].0.is_multiple_of(2) {
            match around[i].1.and_then(|p| polygon_of.get(&p)) {
                Some(&p) => polygons[p].push(open(r)),
                // Its smallest container is itself a hole (rings that cross): an outer of its own.
                None => polygons.push(vec![open(r)]),
            }
        }
    }
    polygons
}

/// [min lat, min lon, max lat, max lon].
fn bounds(r: &[[i64; 2]]) -> [i64; 4] {
    r.iter()
        .fold([i64::MAX, i64::MAX, i64::MIN, i64::MIN], |b, p| {
            [
                b[0].min(p[0]),
                b[1].min(p[1]),
                b[2].max(p[0]),
                b[3].max(p[1]),
            ]
        })
}

fn twice_area(r: &[[i64; 2]]) -> i128 {
    r.windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            a[1] as i128 * b[0] as i128 - b[1] as i128 * a[0] as i128
        })
        .sum()
}

#[derive(PartialEq, Eq)]
enum Where {
    Inside,
    Outside,
    Boundary,
}

/// Whether ring `a` lies inside ring `b`: the first of its points (vertices, then edge midpoints) not on `b`'s
/// boundary decides; a ring lying all on `b`'s boundary is not inside it.
fn ring_inside(a: &[[i64; 2]], b: &[[i64; 2]]) -> bool {
    let vertices = a.iter().map(|p| [2 * p[0] as i128, 2 * p[1] as i128]);
    let midpoints = a.windows(2).map(|w| {
        [
            w[0][0] as i128 + w[1][0] as i128,
            w[0][1] as i128 + w[1][1] as i128,
        ]
    });
    for p in vertices.chain(midpoints) {
        match locate(p, b) {
            Where::Inside => return true,
            Where::Outside => return false,
            Where::Boundary => {}
        }
    }
    false
}

/// Where point `p` (doubled nanodegrees lat, lon) lies against the closed ring `r`: exact, by crossings of a ray
/// towards +lon.
fn locate(p: [i128; 2], r: &[[i64; 2]]) -> Where {
    let (py, px) = (p[0], p[1]);
    let mut inside = false;
    for w in r.windows(2) {
        let (ay, ax) = (2 * w[0][0] as i128, 2 * w[0][1] as i128);
        let (by, bx) = (2 * w[1][0] as i128, 2 * w[1][1] as i128);
        let cross = (bx - ax) * (py - ay) - (by - ay) * (px - ax);
        if cross == 0
            && px >= ax.min(bx)
            && px <= ax.max(bx)
            && py >= ay.min(by)
            && py <= ay.max(by)
        {
            return Where::Boundary;
        }
        if (ay > py) != (by > py) && (by > ay) == (cross > 0) {
            inside = !inside;
        }
    }
    if inside {
        Where::Inside
    } else {
        Where::Outside
    }
}

/// A relation tagged as a building.
pub(crate) struct Relation {
    pub id: i64,
    pub tags: Vec<(String, String)>,
    pub members: Vec<Member>,
    /// More members than [`MAX_MEMBERS`]: their number (and none kept).
    pub oversized: Option<usize>,
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
    /// More nodes than [`MAX_WAY_NODES`]: their number (and no refs kept).
    pub oversized: Option<usize>,
}
