//! OpenStreetMap XML (`.osm`, or gzip-compressed `.osm.gz`): what JOSM saves, the Overpass API returns and the OSM
//! API's `map` call gives. The same elements as a PBF file holds (nodes with `lat`/`lon`, ways with their `nd`
//! references, relations with their members, each with its `tag`s), gathered for [`crate::osm`]'s assembly. Objects
//! JOSM marks deleted (`action="delete"`) or the API marks invisible (`visible="false"`) are left out, and of an object
//! given in several versions the highest stands; `nd`s that carry their own `lat` and `lon` (Overpass `out geom`, in
//! ways and in a relation's members) need no nodes; an Overpass `remark` (a timeout, a memory limit: the answer may be
//! cut) is passed on as a note. The text is read as a stream of XML events (quick-xml) in three passes — the relations,
//! the ways they and the buildings need, the nodes those need — so memory is the text and what is kept of it.

use crate::osm::{
    building_tags, member_ways, needed_nodes, wanted_way, Gathered, Member, MemberKind, Relation,
    Want, Way, MAX_MEMBERS, MAX_WAY_NODES,
};
use quick_xml::events::{BytesStart, Event};
use quick_xml::XmlVersion;
use std::collections::HashSet;

/// The XML a gzip-compressed file may inflate to: a guard against a compression bomb (the text is held whole; the
/// elements are read from it as a stream, pass by pass, so memory is the text and what is kept of it).
const MAX_TEXT: u64 = 8 * 1024 * 1024 * 1024;
/// OpenStreetMap XML nests three or four deep (`osm`, `relation`, `member`, `nd`); deeper nesting is no
/// OpenStreetMap data and is refused.
const MAX_DEPTH: usize = 64;
/// A coordinate no node has, for a reference without its location (an Overpass `out geom(bbox)` cut).
const NOWHERE: [i64; 2] = [i64::MAX, i64::MAX];
/// Attribute values are normalized as XML 1.0 says (OpenStreetMap XML is 1.0).
const XML: XmlVersion = XmlVersion::Implicit1_0;

type Tags = Vec<(String, String)>;

pub(crate) fn gather(bytes: &[u8], want: Want) -> Result<Gathered, String> {
    if bytes.starts_with(b"BZh") {
        return Err("bzip2-compressed, which this reader does not read: decompress it (bunzip2) or convert it to PBF".into());
    }
    let inflated = crate::zip::gunzipped(bytes, MAX_TEXT)?;
    let bytes = inflated.as_deref().unwrap_or(bytes);
    if bytes.len() as u64 > MAX_TEXT {
        return Err(
            "inflates to over 8 GiB of XML, more than this reader holds; convert it to PBF (e.g. `osmium cat FILE -o FILE.osm.pbf`)"
                .into(),
        );
    }
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        format!(
            "byte {at} (0x{:02X}) is not UTF-8 text, as OpenStreetMap XML is, and the file is not gzip- or \
             bzip2-compressed either",
            bytes[at]
        )
    })?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);

    // First pass: which objects are given more than once, the building relations, the remarks.
    let mut order = [Order::default(), Order::default(), Order::default()];
    let mut relations: Vec<(usize, Relation, Vec<Way>)> = Vec::new();
    let mut remarks = Vec::new();
    each_object(
        text,
        |kind| kind == Kind::Remark || (kind == Kind::Relation && want == Want::Buildings),
        |o| {
            let Some(slot) = o.kind.slot() else {
                if o.kind == Kind::Remark {
                    remarks.push(o.text.trim().to_string());
                }
                return Ok(());
            };
            let ordinal = order[slot].count;
            order[slot].saw(o.id);
            if o.kind != Kind::Relation || o.gone || !building_tags(&o.tags) {
                return Ok(());
            }
            let id = o.whole_id(text)?;
            let oversized = (o.member_count > MAX_MEMBERS).then_some(o.member_count);
            let mut members = Vec::new();
            // Overpass `out geom` gives a member way's nodes inline, and the way itself not at all.
            let mut inline = Vec::new();
            if oversized.is_none() {
                for m in &o.members {
                    let reference = m
                        .reference
                        .ok_or_else(|| without(text, m.at, "member", "ref"))?;
                    members.push(Member {
                        id: reference,
                        kind: m.kind,
                    });
                    if m.kind == MemberKind::Way && m.nd_count > 0 {
                        inline.push(way_of(reference, &m.nds, m.nd_count, Vec::new()));
                    }
                }
            }
            let r = Relation {
                id,
                tags: o.tags.clone(),
                members,
                oversized,
            };
            relations.push((ordinal, r, inline));
            Ok(())
        },
    )?;
    // Of an object given more than once (versions from the API's history calls, files appended), the highest
    // version stands (the later one at the same version), and an object whose standing version is deleted or
    // invisible is not there at all. Files written by the API, Overpass and osmium list each object once, in
    // ascending id order; only others need the pass that finds the superseded ones.
    let mut superseded: [HashSet<usize>; 3] = Default::default();
    if order.iter().any(|o| !o.ascending) {
        let mut seen: [Vec<(i64, i64)>; 3] = Default::default();
        each_object(
            text,
            |_| false,
            |o| {
                // One entry per object of the kind, so that its index is the object's ordinal; objects without
                // an id, and those of kinds whose ids ascend, need no look.
                if let Some(slot) = o.kind.slot() {
                    match o.id {
                        Some(id) if !order[slot].ascending => seen[slot].push((id, o.version)),
                        _ => seen[slot].push((i64::MIN, 0)),
                    }
                }
                Ok(())
            },
        )?;
        for (slot, seen) in seen.iter().enumerate() {
            superseded[slot] = superseded_among(seen);
        }
    }
    let mut g = Gathered::default();
    let left_out: usize = superseded.iter().map(HashSet::len).sum();
    if left_out > 0 {
        g.notes.push(format!(
            "{left_out} element(s) given again with a higher version (or later, at the same version) left out"
        ));
    }
    for said in remarks {
        g.notes.push(format!(
            "the file's remark (a message of the Overpass API: what it says may have cut the data short): {said}"
        ));
    }
    let mut inline: Vec<Way> = Vec::new();
    for (ordinal, r, ways) in relations {
        if !superseded[2].contains(&ordinal) {
            g.relations.push(r);
            inline.extend(ways);
        }
    }

    // Second pass: the ways.
    let members = member_ways(&g.relations);
    each_standing(text, Kind::Way, true, &superseded[1], |o| {
        let way_id = o.whole_id(text)?;
        if !wanted_way(want, way_id, &o.tags, &members) {
            return Ok(());
        }
        let mut w = way_of(way_id, &o.nds, o.nd_count, o.tags.clone());
        if w.oversized.is_none() {
            w.refs = o
                .nds
                .iter()
                .map(|n| n.reference.ok_or_else(|| without(text, n.at, "nd", "ref")))
                .collect::<Result<Vec<i64>, _>>()?;
        }
        g.ways.push(w);
        Ok(())
    })?;
    let present: HashSet<i64> = g.ways.iter().map(|w| w.id).collect();
    g.ways
        .extend(inline.into_iter().filter(|w| !present.contains(&w.id)));

    // Third pass: the nodes the ways need, and the nodes tagged as buildings.
    let needed = needed_nodes(&g.ways);
    if needed.is_empty() && want != Want::Buildings {
        return Ok(g);
    }
    each_standing(
        text,
        Kind::Node,
        want == Want::Buildings,
        &superseded[0],
        |o| {
            let node_id = o.whole_id(text)?;
            if needed.contains(&node_id) {
                if let Some(at) = o.location {
                    g.located.insert(node_id, at);
                }
            }
            if want == Want::Buildings && building_tags(&o.tags) {
                g.point_buildings.push((node_id, o.tags.clone()));
            }
            Ok(())
        },
    )?;
    Ok(g)
}

/// Calls `on` for each object of `kind` that stands: not superseded (its ordinal among its kind's, in document
/// order, not in `superseded`), not deleted, not invisible; with its children read when `children` says so.
fn each_standing(
    text: &str,
    kind: Kind,
    children: bool,
    superseded: &HashSet<usize>,
    mut on: impl FnMut(&Object) -> Result<(), String>,
) -> Result<(), String> {
    let mut ordinal = 0;
    each_object(
        text,
        |k| k == kind && children,
        |o| {
            if o.kind != kind {
                return Ok(());
            }
            ordinal += 1;
            if o.gone || superseded.contains(&(ordinal - 1)) {
                return Ok(());
            }
            on(o)
        },
    )
}

/// The ordinals (in document order) of objects of one kind given again with a higher version, or later at the same
/// version, among `seen` (id, version; `i64::MIN` where the id need not be looked at).
fn superseded_among(seen: &[(i64, i64)]) -> HashSet<usize> {
    let mut by_id: Vec<usize> = (0..seen.len()).filter(|&i| seen[i].0 != i64::MIN).collect();
    by_id.sort_by_key(|&i| seen[i].0);
    let mut out = HashSet::new();
    for group in by_id.chunk_by(|&a, &b| seen[a].0 == seen[b].0) {
        if let Some(&standing) = group.iter().max_by_key(|&&i| (seen[i].1, i)) {
            out.extend(group.iter().filter(|&&i| i != standing));
        }
    }
    out
}

/// Whether one kind's ids came in ascending order (so none came twice), and how many there were.
#[derive(Clone, Copy)]
struct Order {
    ascending: bool,
    last: Option<i64>,
    count: usize,
}

impl Default for Order {
    fn default() -> Self {
        Order {
            ascending: true,
            last: None,
            count: 0,
        }
    }
}

impl Order {
    /// Counts an object; one without an id is no object given twice, so it leaves the order as it is.
    fn saw(&mut self, id: Option<i64>) {
        self.count += 1;
        if let Some(id) = id {
            if self.last.is_some_and(|last| id <= last) {
                self.ascending = false;
            }
            self.last = Some(id);
        }
    }
}

/// The top-level elements told apart.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Node,
    Way,
    Relation,
    /// An Overpass API message (`<remark>`).
    Remark,
    /// `bounds`, `note`, `meta`, …
    Other,
}

impl Kind {
    fn of(name: &str) -> Kind {
        match name {
            "node" => Kind::Node,
            "way" => Kind::Way,
            "relation" => Kind::Relation,
            "remark" => Kind::Remark,
            _ => Kind::Other,
        }
    }

    /// The index of an OSM object's kind (nodes, ways, relations), for what is kept per kind.
    fn slot(self) -> Option<usize> {
        match self {
            Kind::Node => Some(0),
            Kind::Way => Some(1),
            Kind::Relation => Some(2),
            _ => None,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Kind::Node => "node",
            Kind::Way => "way",
            Kind::Relation => "relation",
            Kind::Remark => "remark",
            Kind::Other => "element",
        }
    }
}

/// A node reference (`nd`): its `ref`, and the location Overpass `out geom` gives with it.
struct Nd {
    at: usize,
    reference: Option<i64>,
    location: Option<[i64; 2]>,
}

/// A relation's `member`, with the nodes Overpass `out geom` lists inside a way member.
struct MemberElement {
    at: usize,
    kind: MemberKind,
    reference: Option<i64>,
    nds: Vec<Nd>,
    nd_count: usize,
}

/// A top-level element as far as a pass reads it: its attributes always, its children (`tag`, `nd`, `member`, a
/// remark's text) where the pass asks for them. At most [`MAX_WAY_NODES`] `nd`s and [`MAX_MEMBERS`] members are
/// kept; their counts go on.
struct Object {
    kind: Kind,
    at: usize,
    /// `id` as a whole number (`None`: missing or not one).
    id: Option<i64>,
    version: i64,
    /// Marked deleted (JOSM's `action="delete"`) or invisible (the API's `visible="false"`).
    gone: bool,
    /// `lat` and `lon` (nanodegrees).
    location: Option<[i64; 2]>,
    tags: Tags,
    nds: Vec<Nd>,
    nd_count: usize,
    members: Vec<MemberElement>,
    member_count: usize,
    text: String,
}

impl Object {
    fn whole_id(&self, text: &str) -> Result<i64, String> {
        self.id
            .ok_or_else(|| without(text, self.at, self.kind.name(), "id"))
    }
}

/// The error for an element without a whole-number attribute, naming its line.
fn without(text: &str, at: usize, element: &str, attribute: &str) -> String {
    format!(
        "line {}: a <{element}> without a whole-number {attribute}",
        line_of(text, at)
    )
}

/// The line (from 1) of a byte offset.
fn line_of(text: &str, at: usize) -> usize {
    text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// An element's attributes by name, normalized; an error names its line.
fn attributes<'a>(
    e: &'a BytesStart<'_>,
    text: &'a str,
    at: usize,
) -> impl Iterator<Item = Result<(&'a str, std::borrow::Cow<'a, str>), String>> + 'a {
    let bad = move |err: quick_xml::Error| {
        format!("not well-formed XML (line {}): {err}", line_of(text, at))
    };
    e.attributes().map(move |a| {
        let a = a.map_err(|err| bad(err.into()))?;
        let v = a.normalized_value(XML).map_err(bad)?;
        Ok((a.key.into_inner(), v))
    })
}

fn whole(v: &str) -> Option<i64> {
    v.trim().parse().ok()
}

/// The location of an element with `lat` and `lon` (nanodegrees), if it has both.
fn location(lat: Option<i64>, lon: Option<i64>) -> Option<[i64; 2]> {
    Some([lat?, lon?])
}

/// Reads `text` as an `<osm>` document and calls `on` for each element directly inside `<osm>`, in document order,
/// with its children read where `children` says so. Errors: not well-formed XML (a cut file, mismatched tags,
/// duplicate attributes, unknown entities), a DOCTYPE, a root other than `<osm>`, nesting deeper than
/// [`MAX_DEPTH`].
fn each_object(
    text: &str,
    children: impl Fn(Kind) -> bool,
    mut on: impl FnMut(&Object) -> Result<(), String>,
) -> Result<(), String> {
    let mut reader = quick_xml::Reader::from_str(text);
    let mut depth = 0usize;
    let mut root = false;
    let mut object: Option<Object> = None;
    let mut member: Option<MemberElement> = None;
    loop {
        let at = reader.buffer_position() as usize;
        let event = reader.read_event().map_err(|e| {
            format!(
                "not well-formed XML (line {}): {e}",
                line_of(text, reader.error_position() as usize)
            )
        })?;
        let (e, empty) = match event {
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(_) => {
                depth = depth.saturating_sub(1);
                match depth {
                    2 => {
                        if let (Some(o), Some(m)) = (object.as_mut(), member.take()) {
                            o.add_member(m);
                        }
                    }
                    1 => {
                        if let Some(o) = object.take() {
                            on(&o)?;
                        }
                    }
                    _ => {}
                }
                continue;
            }
            Event::Text(t) if depth == 2 => {
                if let Some(o) = object.as_mut().filter(|o| o.kind == Kind::Remark) {
                    o.text.push_str(&t.xml10_content());
                }
                continue;
            }
            Event::CData(t) if depth == 2 => {
                if let Some(o) = object.as_mut().filter(|o| o.kind == Kind::Remark) {
                    o.text.push_str(&t);
                }
                continue;
            }
            Event::GeneralRef(r) if depth == 2 => {
                let resolved = match r.resolve_char_ref() {
                    Ok(Some(c)) => Some(c.to_string()),
                    _ => quick_xml::escape::resolve_predefined_entity(&r).map(str::to_string),
                };
                let c = resolved.ok_or_else(|| {
                    format!(
                        "not well-formed XML (line {}): an unknown entity &{};",
                        line_of(text, at),
                        &*r
                    )
                })?;
                if let Some(o) = object.as_mut().filter(|o| o.kind == Kind::Remark) {
                    o.text.push_str(&c);
                }
                continue;
            }
            Event::DocType(_) => {
                return Err(
                    "a DOCTYPE, which OpenStreetMap XML does not have (refused: its entities could expand without end)"
                        .into(),
                )
            }
            Event::Eof => {
                if depth > 0 {
                    return Err(format!(
                        "not well-formed XML: the text ends inside an element (line {}); the file is cut short",
                        line_of(text, text.len())
                    ));
                }
                if !root {
                    return Err("not well-formed XML: no element in it".into());
                }
                return Ok(());
            }
            _ => continue,
        };
        let name = e.name().into_inner();
        match depth {
            0 => {
                if root {
                    return Err(format!(
                        "not well-formed XML (line {}): a second root element <{}>",
                        line_of(text, at),
                        name
                    ));
                }
                root = true;
                if name != "osm" {
                    return Err(format!(
                        "not OpenStreetMap XML: the document is <{}>, not <osm>",
                        name
                    ));
                }
            }
            1 => {
                let mut o = Object {
                    kind: Kind::of(name),
                    at,
                    id: None,
                    version: 0,
                    gone: false,
                    location: None,
                    tags: Vec::new(),
                    nds: Vec::new(),
                    nd_count: 0,
                    members: Vec::new(),
                    member_count: 0,
                    text: String::new(),
                };
                let (mut lat, mut lon) = (None, None);
                for a in attributes(&e, text, at) {
                    let (key, v) = a?;
                    match key {
                        "id" => o.id = whole(&v),
                        "version" => o.version = whole(&v).unwrap_or(0),
                        "action" => o.gone |= v == "delete",
                        "visible" => o.gone |= v == "false",
                        "lat" => lat = nanodegrees(&v),
                        "lon" => lon = nanodegrees(&v),
                        _ => {}
                    }
                }
                o.location = location(lat, lon);
                if empty {
                    on(&o)?;
                } else {
                    object = Some(o);
                }
            }
            2 => {
                if let Some(o) = object.as_mut().filter(|o| children(o.kind)) {
                    match name {
                        "tag" => {
                            let (mut k, mut v) = (None, None);
                            for a in attributes(&e, text, at) {
                                let (key, value) = a?;
                                match key {
                                    "k" => k = Some(value.into_owned()),
                                    "v" => v = Some(value.into_owned()),
                                    _ => {}
                                }
                            }
                            if let Some(k) = k {
                                o.tags.push((k, v.unwrap_or_default()));
                            }
                        }
                        "nd" => {
                            let nd = nd(&e, text, at)?;
                            o.nd_count += 1;
                            if o.nd_count <= MAX_WAY_NODES {
                                o.nds.push(nd);
                            }
                        }
                        "member" => {
                            let mut m = MemberElement {
                                at,
                                kind: MemberKind::Node,
                                reference: None,
                                nds: Vec::new(),
                                nd_count: 0,
                            };
                            for a in attributes(&e, text, at) {
                                let (key, value) = a?;
                                match key {
                                    "type" if value == "way" => m.kind = MemberKind::Way,
                                    "type" if value == "relation" => m.kind = MemberKind::Relation,
                                    "ref" => m.reference = whole(&value),
                                    _ => {}
                                }
                            }
                            if empty {
                                o.add_member(m);
                            } else {
                                member = Some(m);
                            }
                        }
                        _ => {}
                    }
                }
            }
            3 => {
                if let Some(m) = member.as_mut().filter(|_| name == "nd") {
                    let nd = nd(&e, text, at)?;
                    m.nd_count += 1;
                    if m.nd_count <= MAX_WAY_NODES {
                        m.nds.push(nd);
                    }
                }
            }
            _ => {}
        }
        if !empty {
            depth += 1;
            if depth > MAX_DEPTH {
                return Err(format!(
                    "elements nested more than {MAX_DEPTH} deep (at line {}); OpenStreetMap XML nests three or four",
                    line_of(text, at)
                ));
            }
        }
    }
}

impl Object {
    fn add_member(&mut self, m: MemberElement) {
        self.member_count += 1;
        if self.member_count <= MAX_MEMBERS {
            self.members.push(m);
        }
    }
}

fn nd(e: &BytesStart<'_>, text: &str, at: usize) -> Result<Nd, String> {
    let (mut reference, mut lat, mut lon) = (None, None, None);
    for a in attributes(e, text, at) {
        let (key, v) = a?;
        match key {
            "ref" => reference = whole(&v),
            "lat" => lat = nanodegrees(&v),
            "lon" => lon = nanodegrees(&v),
            _ => {}
        }
    }
    Ok(Nd {
        at,
        reference,
        location: location(lat, lon),
    })
}

/// A way of `nds` (`count` of them in the file): too long, or with the locations its references carry (Overpass
/// `out geom`; one without gets [`NOWHERE`], as a node not in the file), or none. Its `refs` are the references'
/// `ref`s where they have them.
fn way_of(id: i64, nds: &[Nd], count: usize, tags: Tags) -> Way {
    if count > MAX_WAY_NODES {
        return Way {
            id,
            refs: Vec::new(),
            tags,
            locations: None,
            oversized: Some(count),
        };
    }
    let locations = nds
        .iter()
        .any(|n| n.location.is_some())
        .then(|| nds.iter().map(|n| n.location.unwrap_or(NOWHERE)).collect());
    Way {
        id,
        refs: nds.iter().map(|n| n.reference.unwrap_or(0)).collect(),
        tags,
        locations,
        oversized: None,
    }
}

/// A decimal number of degrees as whole nanodegrees, exactly for up to 9 decimals (rounded half away from zero
/// beyond), so a node reads as it does from a PBF file; other number forms (an exponent) through a double.
fn nanodegrees(s: &str) -> Option<i64> {
    let t = s.trim();
    let (negative, digits) = match t.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, t.strip_prefix('+').unwrap_or(t)),
    };
    let (whole, fraction) = digits.split_once('.').unwrap_or((digits, ""));
    let plain = !(whole.is_empty() && fraction.is_empty())
        && whole.len() <= 4
        && whole
            .bytes()
            .chain(fraction.bytes())
            .all(|b| b.is_ascii_digit());
    if !plain {
        let x: f64 = t.parse().ok()?;
        return (x.is_finite() && x.abs() < 1e4).then(|| (x * 1e9).round() as i64);
    }
    let mut n: i64 = if whole.is_empty() {
        0
    } else {
        whole.parse().ok()?
    };
    let f = fraction.as_bytes();
    for i in 0..9 {
        n = n * 10 + f.get(i).map_or(0, |b| i64::from(b - b'0'));
    }
    if f.get(9).is_some_and(|&b| b >= b'5') {
        n += 1;
    }
    Some(if negative { -n } else { n })
}

#[cfg(test)]
mod tests {
    use super::nanodegrees;

    #[test]
    fn decimal_degrees_read_exactly() {
        assert_eq!(nanodegrees("40.7182217"), Some(40_718_221_700));
        assert_eq!(nanodegrees("-73.9863937"), Some(-73_986_393_700));
        assert_eq!(nanodegrees("+4.5"), Some(4_500_000_000));
        assert_eq!(nanodegrees(".5"), Some(500_000_000));
        assert_eq!(nanodegrees("1.0000000005"), Some(1_000_000_001));
        assert_eq!(nanodegrees("1.00000000049"), Some(1_000_000_000));
        assert_eq!(nanodegrees("4e1"), Some(40_000_000_000));
        assert_eq!(nanodegrees(" 52 "), Some(52_000_000_000));
        for bad in [
            "", "-", ".", "abc", "1.2.3", "99999999", "NaN", "inf", "1e300",
        ] {
            assert_eq!(nanodegrees(bad), None, "{bad:?}");
        }
    }
}
