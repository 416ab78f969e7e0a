//! OpenStreetMap XML (`.osm`, or gzip-compressed `.osm.gz`): what JOSM saves, the Overpass API returns and the OSM
//! API's `map` call gives. The same elements as a PBF file holds (nodes with `lat`/`lon`, ways with their `nd`
//! references, relations with their members, each with its `tag`s), gathered for [`crate::osm`]'s assembly. Objects
//! JOSM marks deleted (`action="delete"`) or the API marks invisible (`visible="false"`) are left out, and of an object
//! given in several versions the highest stands; `nd`s that carry their own `lat` and `lon` (Overpass `out geom`, in
//! ways and in a relation's members) need no nodes; an Overpass `remark` (a timeout, a memory limit: the answer may be
//! cut) is passed on as a note. The file is held as a tree, so its size is capped and its nesting checked first.

use crate::osm::{
    building_tags, member_ways, needed_nodes, wanted_way, Gathered, Member, MemberKind, Relation,
    Want, Way, MAX_MEMBERS, MAX_WAY_NODES,
};
use std::collections::{HashMap, HashSet};

/// The XML read at most: its tree takes ~7.5 bytes of memory per byte of text (PBF is the format for more).
const MAX_TEXT: u64 = 512 * 1024 * 1024;
/// OSM XML nests three or four deep (`osm`, `relation`, `member`, `nd`); the tree is built by recursion, so deeper
/// nesting is refused before it is parsed.
const MAX_DEPTH: usize = 64;
/// A coordinate no node has, for a reference without its location (an Overpass `out geom(bbox)` cut).
const NOWHERE: [i64; 2] = [i64::MAX, i64::MAX];

type Tags = Vec<(String, String)>;

pub(crate) fn gather(bytes: &[u8], want: Want) -> Result<Gathered, String> {
    let too_big = || {
        "over 512 MiB of XML, more than this reader holds; convert it to PBF (e.g. `osmium cat FILE -o FILE.osm.pbf`)"
            .to_string()
    };
    if bytes.starts_with(b"BZh") {
        return Err("bzip2-compressed, which this reader does not read: decompress it (bunzip2) or convert it to PBF".into());
    }
    let inflated = crate::zip::gunzipped(bytes, MAX_TEXT)?;
    let bytes = inflated.as_deref().unwrap_or(bytes);
    if bytes.len() as u64 > MAX_TEXT {
        return Err(too_big());
    }
    if let Some(line) = too_deep(bytes) {
        return Err(format!(
            "elements nested more than {MAX_DEPTH} deep (at line {line}); OpenStreetMap XML nests three or four"
        ));
    }
    let text = std::str::from_utf8(bytes).map_err(|e| {
        format!(
            "not UTF-8 text (byte {} is not), as OpenStreetMap XML is",
            e.valid_up_to()
        )
    })?;
    let doc = roxmltree::Document::parse(text).map_err(|e| match e {
        roxmltree::Error::DtdDetected => {
            "a DOCTYPE, which OpenStreetMap XML does not have (refused: its entities could expand without end)"
                .to_string()
        }
        e => format!("not well-formed XML: {e}"),
    })?;
    let root = doc.root_element();
    if root.tag_name().name() != "osm" {
        return Err(format!(
            "not OpenStreetMap XML: the document is <{}>, not <osm>",
            root.tag_name().name()
        ));
    }
    let line = |n: &roxmltree::Node| doc.text_pos_at(n.range().start).row;
    // A whole-number attribute (`id`, `ref`) of an element, or an error naming its line.
    let whole = |e: &roxmltree::Node, name: &str| -> Result<i64, String> {
        e.attribute(name)
            .and_then(|v| v.trim().parse().ok())
            .ok_or_else(|| {
                format!(
                    "line {}: a <{}> without a whole-number {name}",
                    line(e),
                    e.tag_name().name()
                )
            })
    };
    let id = |e: &roxmltree::Node| whole(e, "id");
    let reference = |e: &roxmltree::Node| whole(e, "ref");
    // Of an object given more than once (versions from the API's history calls, files appended), the highest
    // version stands, and an object whose standing version is deleted or invisible is not there at all.
    let all: Vec<roxmltree::Node> = root.children().filter(|n| n.is_element()).collect();
    let version = |e: &roxmltree::Node| -> i64 {
        e.attribute("version")
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or(0)
    };
    let mut latest: HashMap<(&str, &str), (i64, usize)> = HashMap::new();
    for (i, e) in all.iter().enumerate() {
        if let Some(id) = e.attribute("id") {
            let v = version(e);
            let slot = latest.entry((e.tag_name().name(), id)).or_insert((v, i));
            if v >= slot.0 {
                *slot = (v, i);
            }
        }
    }
    let superseded = all
        .iter()
        .enumerate()
        .filter(|(i, e)| {
            e.attribute("id")
                .is_some_and(|id| latest[&(e.tag_name().name(), id)].1 != *i)
        })
        .count();
    let elements: Vec<roxmltree::Node> = all
        .iter()
        .enumerate()
        .filter(|(i, e)| {
            e.attribute("id")
                .is_none_or(|id| latest[&(e.tag_name().name(), id)].1 == *i)
        })
        .map(|(_, e)| *e)
        .filter(|e| {
            e.attribute("action") != Some("delete") && e.attribute("visible") != Some("false")
        })
        .collect();
    let of = |name: &'static str| elements.iter().filter(move |e| e.has_tag_name(name));

    let mut g = Gathered::default();
    if superseded > 0 {
        g.notes.push(format!(
            "{superseded} element(s) given again with a higher version (or later, at the same version) left out"
        ));
    }
    for r in of("remark") {
        let said = r.text().unwrap_or("").trim();
        g.notes.push(format!(
            "the file's remark (a message of the Overpass API: what it says may have cut the data short): {said}"
        ));
    }
    let mut inline: Vec<Way> = Vec::new();
    if want == Want::Buildings {
        for e in of("relation") {
            let tags = tags(e);
            if !building_tags(&tags) {
                continue;
            }
            let listed: Vec<roxmltree::Node> =
                e.children().filter(|c| c.has_tag_name("member")).collect();
            let oversized = (listed.len() > MAX_MEMBERS).then_some(listed.len());
            let members = listed
                .iter()
                .take(if oversized.is_some() { 0 } else { listed.len() })
                .map(|m| {
                    let kind = match m.attribute("type") {
                        Some("way") => MemberKind::Way,
                        Some("relation") => MemberKind::Relation,
                        _ => MemberKind::Node,
                    };
                    Ok(Member {
                        id: reference(m)?,
                        kind,
                    })
                })
                .collect::<Result<_, String>>()?;
            // Overpass `out geom` gives a member way's nodes inline, and the way itself not at all.
            if oversized.is_none() {
                for m in &listed {
                    if m.attribute("type") == Some("way") {
                        let nds: Vec<roxmltree::Node> =
                            m.children().filter(|c| c.has_tag_name("nd")).collect();
                        if !nds.is_empty() {
                            inline.push(way_of(reference(m)?, &nds, Vec::new()));
                        }
                    }
                }
            }
            g.relations.push(Relation {
                id: id(e)?,
                tags,
                members,
                oversized,
            });
        }
    }
    let members = member_ways(&g.relations);
    for e in of("way") {
        let tags = tags(e);
        let way_id = id(e)?;
        if !wanted_way(want, way_id, &tags, &members) {
            continue;
        }
        let nds: Vec<roxmltree::Node> = e.children().filter(|c| c.has_tag_name("nd")).collect();
        let mut w = way_of(way_id, &nds, tags);
        if w.oversized.is_none() {
            w.refs = nds
                .iter()
                .map(&reference)
                .collect::<Result<Vec<i64>, _>>()?;
        }
        g.ways.push(w);
    }
    let present: HashSet<i64> = g.ways.iter().map(|w| w.id).collect();
    g.ways
        .extend(inline.into_iter().filter(|w| !present.contains(&w.id)));
    let needed = needed_nodes(&g.ways);
    for e in of("node") {
        let node_id = id(e)?;
        if needed.contains(&node_id) {
            let at = e
                .attribute("lat")
                .and_then(nanodegrees)
                .zip(e.attribute("lon").and_then(nanodegrees));
            if let Some((lat, lon)) = at {
                g.located.insert(node_id, [lat, lon]);
            }
        }
        if want == Want::Buildings {
            let tags = tags(e);
            if building_tags(&tags) {
                g.point_buildings.push((node_id, tags));
            }
        }
    }
    Ok(g)
}

/// A way of `nds`: too long, or with the locations its references carry (Overpass `out geom`; one without gets
/// [`NOWHERE`], as a node not in the file), or none. Its `refs` are the references' `ref`s where they have them.
fn way_of(id: i64, nds: &[roxmltree::Node], tags: Tags) -> Way {
    if nds.len() > MAX_WAY_NODES {
        return Way {
            id,
            refs: Vec::new(),
            tags,
            locations: None,
            oversized: Some(nds.len()),
        };
    }
    let at = |n: &roxmltree::Node| {
        Some([
            nanodegrees(n.attribute("lat")?)?,
            nanodegrees(n.attribute("lon")?)?,
        ])
    };
    let locations = nds
        .iter()
        .any(|n| at(n).is_some())
        .then(|| nds.iter().map(|n| at(n).unwrap_or(NOWHERE)).collect());
    Way {
        id,
        refs: nds
            .iter()
            .map(|n| {
                n.attribute("ref")
                    .and_then(|r| r.trim().parse().ok())
                    .unwrap_or(0)
            })
            .collect(),
        tags,
        locations,
        oversized: None,
    }
}

/// The line at which elements nest deeper than [`MAX_DEPTH`], if they do: a scan of tags that skips comments,
/// CDATA, declarations and quoted attribute values.
fn too_deep(text: &[u8]) -> Option<usize> {
    let (mut depth, mut line, mut i) = (0usize, 1usize, 0usize);
    let skip_to = |from: usize, end: &[u8]| {
        text[from..]
            .windows(end.len())
            .position(|w| w == end)
            .map_or(text.len(), |k| from + k + end.len())
    };
    while i < text.len() {
        match text[i] {
            b'\n' => {
                line += 1;
                i += 1;
            }
            b'<' if text[i..].starts_with(b"<!--") => i = skip_to(i, b"-->"),
            b'<' if text[i..].starts_with(b"<![CDATA[") => i = skip_to(i, b"]]>"),
            b'<' if text[i..].starts_with(b"<?") => i = skip_to(i, b"?>"),
            b'<' if text[i..].starts_with(b"<!") => i = skip_to(i, b">"),
            b'<' if text[i..].starts_with(b"</") => {
                depth = depth.saturating_sub(1);
                i = skip_to(i, b">");
            }
            b'<' => {
                // An opening tag, to its end outside quotes; `/>` closes it at once.
                let mut j = i + 1;
                let mut quote = None;
                while j < text.len() {
                    match (quote, text[j]) {
                        (None, b'"' | b'\'') => quote = Some(text[j]),
                        (Some(q), c) if c == q => quote = None,
                        (None, b'>') => break,
                        (_, b'\n') => line += 1,
                        _ => {}
                    }
                    j += 1;
                }
                if !(j > i + 1 && text[j - 1] == b'/') {
                    depth += 1;
                    if depth > MAX_DEPTH {
                        return Some(line);
                    }
                }
                i = j + 1;
            }
            _ => i += 1,
        }
    }
    None
}

fn tags(e: &roxmltree::Node) -> Tags {
    e.children()
        .filter(|c| c.has_tag_name("tag"))
        .filter_map(|t| {
            Some((
                t.attribute("k")?.to_string(),
                t.attribute("v").unwrap_or("").to_string(),
            ))
        })
        .collect()
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
