//! A writer of OpenStreetMap XML (`<osm version="0.6">`, as the OSM API and osmium write it: nodes, then ways, then
//! relations, each in the order given) for tests and benchmarks, and building footprints of a GeoJSON
//! FeatureCollection (lon/lat) as OSM data.

use crate::osm_pbf::{tags, Node, OsmData, Relation, Way};
use std::io::{self, Write};

/// `text` escaped for an attribute value in single or double quotes.
fn escaped(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' => out.push_str("&#10;"),
            '\t' => out.push_str("&#9;"),
            '\r' => out.push_str("&#13;"),
            c => out.push(c),
        }
    }
    out
}

fn write_tags(w: &mut impl Write, t: &[(String, String)]) -> io::Result<()> {
    for (k, v) in t {
        writeln!(w, "    <tag k=\"{}\" v=\"{}\"/>", escaped(k), escaped(v))?;
    }
    Ok(())
}

/// Writes `d` as OpenStreetMap XML, every object at version 1; coordinates with 7 decimals, as the API gives them.
pub fn write_xml(d: &OsmData, w: &mut impl Write) -> io::Result<()> {
    writeln!(w, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>")?;
    writeln!(w, "<osm version=\"0.6\" generator=\"citylod-testdata\">")?;
    for n in &d.nodes {
        let head = format!(
            "  <node id=\"{}\" version=\"1\" lat=\"{:.7}\" lon=\"{:.7}\"",
            n.id, n.lat, n.lon
        );
        if n.tags.is_empty() {
            writeln!(w, "{head}/>")?;
        } else {
            writeln!(w, "{head}>")?;
            write_tags(w, &n.tags)?;
            writeln!(w, "  </node>")?;
        }
    }
    for way in &d.ways {
        writeln!(w, "  <way id=\"{}\" version=\"1\">", way.id)?;
        for r in &way.refs {
            writeln!(w, "    <nd ref=\"{r}\"/>")?;
        }
        write_tags(w, &way.tags)?;
        writeln!(w, "  </way>")?;
    }
    for r in &d.relations {
        writeln!(w, "  <relation id=\"{}\" version=\"1\">", r.id)?;
        for (kind, id, role) in &r.members {
            let kind = match kind {
                'n' => "node",
                'w' => "way",
                _ => "relation",
            };
            writeln!(
                w,
                "    <member type=\"{kind}\" ref=\"{id}\" role=\"{}\"/>",
                escaped(role)
            )?;
        }
        write_tags(w, &r.tags)?;
        writeln!(w, "  </relation>")?;
    }
    writeln!(w, "</osm>")
}

/// The Polygon and MultiPolygon features of a GeoJSON FeatureCollection in lon/lat as OSM buildings, `copies` times,
/// each copy `step_deg` degrees of longitude east of the last: a polygon without holes as a way, any other as a
/// multipolygon relation of outer and inner ways; tagged `building=yes`, with `building:levels` from a `stories`
/// property and `name` from a non-empty `name` property. Node and way ids count up from 1.
pub fn from_geojson(doc: &serde_json::Value, copies: usize, step_deg: f64) -> OsmData {
    let mut d = OsmData::default();
    let (mut next_node, mut next_way, mut next_relation) = (1i64, 1i64, 1i64);
    let features = doc["features"].as_array().cloned().unwrap_or_default();
    for copy in 0..copies {
        let dx = copy as f64 * step_deg;
        for f in &features {
            let g = &f["geometry"];
            let polygons: Vec<&serde_json::Value> = match g["type"].as_str() {
                Some("Polygon") => vec![&g["coordinates"]],
                Some("MultiPolygon") => g["coordinates"]
                    .as_array()
                    .map(|a| a.iter().collect())
                    .unwrap_or_default(),
                _ => continue,
            };
            let p = &f["properties"];
            let mut t = tags(&[("building", "yes")]);
            if let Some(levels) = p["stories"].as_f64() {
                t.push(("building:levels".into(), format!("{levels}")));
            }
            if let Some(name) = p["name"].as_str().filter(|s| !s.is_empty()) {
                t.push(("name".into(), name.into()));
            }
            let mut rings: Vec<(i64, &str)> = Vec::new();
            for polygon in &polygons {
                for (i, ring) in polygon.as_array().into_iter().flatten().enumerate() {
                    let points: Vec<[f64; 2]> = ring
                        .as_array()
                        .into_iter()
                        .flatten()
                        .filter_map(|c| Some([c[0].as_f64()? + dx, c[1].as_f64()?]))
                        .collect();
                    if points.len() < 4 {
                        continue;
                    }
                    let first = next_node;
                    let mut refs = Vec::new();
                    for p in &points[..points.len() - 1] {
                        d.nodes.push(Node {
                            id: next_node,
                            lon: p[0],
                            lat: p[1],
                            tags: Vec::new(),
                        });
                        refs.push(next_node);
                        next_node += 1;
                    }
                    refs.push(first);
                    d.ways.push(Way {
                        id: next_way,
                        refs,
                        tags: Vec::new(),
                    });
                    rings.push((next_way, if i == 0 { "outer" } else { "inner" }));
                    next_way += 1;
                }
            }
            match rings.as_slice() {
                [] => {}
                [(way, _)] => d.ways.last_mut().filter(|w| w.id == *way).unwrap().tags = t,
                _ => {
                    t.push(("type".into(), "multipolygon".into()));
                    d.relations.push(Relation {
                        id: next_relation,
                        members: rings
                            .iter()
                            .map(|(id, role)| ('w', *id, role.to_string()))
                            .collect(),
                        tags: t,
                    });
                    next_relation += 1;
                }
            }
        }
    }
    d
}
