//! OpenStreetMap XML (`.osm`, or gzip-compressed `.osm.gz`): what JOSM saves, the Overpass API returns and the OSM
//! API's `map` call gives. The same elements as a PBF file holds (nodes with `lat`/`lon`, ways with their `nd`
//! references, relations with their members, each with its `tag`s), gathered for [`crate::osm`]'s assembly. Objects
//! JOSM marks deleted (`action="delete"`) or the API marks invisible (`visible="false"`) are left out; ways whose
//! every `nd` carries its own `lat` and `lon` (Overpass `out geom`) need no nodes; an Overpass `remark` (a timeout,
//! a memory limit: the answer may be cut) is passed on as a note.

use crate::osm::{
    building_tags, member_ways, needed_nodes, wanted_way, Gathered, Member, MemberKind, Relation,
    Want, Way, MAX_MEMBERS, MAX_WAY_NODES,
};
use std::io::Read;
use std::path::Path;

/// roxmltree addresses text with 32-bit offsets.
const MAX_TEXT: u64 = u32::MAX as u64;

type Tags = Vec<(String, String)>;

pub(crate) fn gather(path: &Path, bytes: &[u8], want: Want) -> Result<Gathered, String> {
    let gz = path
        .file_name()
        .is_some_and(|n| n.to_string_lossy().to_ascii_lowercase().ends_with(".gz"));
    let inflated;
    let bytes = if gz {
        let mut out = Vec::new();
        flate2::read::MultiGzDecoder::new(bytes)
            .take(MAX_TEXT + 1)
            .read_to_end(&mut out)
            .map_err(|e| format!("cannot decompress (gzip): {e}"))?;
        inflated = out;
        &inflated[..]
    } else {
        bytes
    };
    if bytes.len() as u64 > MAX_TEXT {
        return Err(
            "over 4 GiB of XML, more than this reader holds; use the PBF format for such files"
                .into(),
        );
    }
    let text = std::str::from_utf8(bytes).map_err(|e| {
        format!(
            "not UTF-8 text (byte {} is not), as OpenStreetMap XML is",
            e.valid_up_to()
        )
    })?;
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("not well-formed XML: {e}"))?;
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
    let elements: Vec<roxmltree::Node> = root
        .children()
        .filter(|n| n.is_element())
        .filter(|e| {
            e.attribute("action") != Some("delete") && e.attribute("visible") != Some("false")
        })
        .collect();
    let of = |name: &'static str| elements.iter().filter(move |e| e.has_tag_name(name));

    let mut g = Gathered::default();
    for r in of("remark") {
        let said = r.text().unwrap_or("").trim();
        g.notes.push(format!(
            "the file's remark (a message of the Overpass API: what it says may have cut the data short): {said}"
        ));
    }
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
        if nds.len() > MAX_WAY_NODES {
            g.ways.push(Way {
                id: way_id,
                refs: Vec::new(),
                tags,
                locations: None,
                oversized: Some(nds.len()),
            });
            continue;
        }
        let refs = nds
            .iter()
            .map(&reference)
            .collect::<Result<Vec<i64>, _>>()?;
        // Overpass `out geom` puts each node's location on its reference.
        let locations = nds
            .iter()
            .map(|n| {
                Some([
                    nanodegrees(n.attribute("lat")?)?,
                    nanodegrees(n.attribute("lon")?)?,
                ])
            })
            .collect::<Option<Vec<[i64; 2]>>>()
            .filter(|l| !l.is_empty());
        g.ways.push(Way {
            id: way_id,
            refs,
            tags,
            locations,
            oversized: None,
        });
    }
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
