//! "No panic on any input file" for the CityGML reader (1.0, 2.0 and 3.0; `.gml`, `.xml`, gzip-compressed, ZIP
//! archives of tiles), on the footprint path and the 3D model path (`--lod`). Small valid city models — Zürich's
//! LoD 2 buildings with parts (1.0), a Delft 3dfier tile (2.0), SIG3D's generic attributes (2.0), a CityGML 3.0
//! model written here after `citygml_input.rs`'s, a WFS answer — are parsed into a tiny element tree of this file's
//! own (qualified names and escaped text kept as written) and mutated structurally with a seeded SplitMix64: an
//! element deleted, duplicated, moved, swapped or renamed; a prefix or a namespace changed; a posList emptied, made
//! huge, not numbers or of an odd count; srsDimension 0, 2 or huge; srsName changed, garbage or gone; xlink:hrefs to
//! nothing, to themselves, in cycles and in chains that multiply; measuredHeight in odd units; gml:ids given twice;
//! interior rings; one GML geometry type for another; BuildingParts nested deep; implicit geometry; comments,
//! CDATA and character references inside coordinates; deep nesting; the encoding declared (ISO-8859-1 or UTF-8,
//! rightly or not). The text is written plain, gzip-compressed or in a ZIP archive, sometimes cut short or with a
//! byte changed, and ingested with and without an LoD.
//!
//! Each case must give an error naming the file, or buildings and skips whose counts add up (finite frame, positive
//! heights, every footprint valid, every model's invariants), never a panic or a hang; and, where the text is
//! exactly the tree written in a consistent encoding, every Building that is a member's city object must be read as
//! a feature (written or skipped with its id); a Building or thematic surface the reader does not reach, or an
//! element with coordinates inside a geometry where the reader reads none, must be named somewhere in the report (or
//! its building have an issue); and the footprints and heights must be the same with and without an LoD (as
//! `IngestOptions::lod` promises). Counts of the outcomes make sure the mutations reach the reader: some cases give
//! buildings, some skips, some errors, some 3D models.
//!
//! A failing case names its input and seed: rerun one with `CITYGML_MUTATIONS_ONLY=<input>:<seed>` (and
//! `CITYGML_MUTATIONS_KEEP=<file>` to keep its file); `CITYGML_MUTATIONS_CASES=20000` for a longer hunt;
//! `CITYGML_MUTATIONS_VERBOSE=1` prints every case and what it gave; `CITYGML_MUTATIONS_MESSAGES=1` counts the errors
//! by their text, to read what they say. A failing run lists its failures by kind, each with its shortest first case.

mod harness;

use citylod_ingest::{ingest, IngestError, IngestOptions, Ingested, LodChoice};
use citylod_testdata::{fnv1a as fnv, SplitMix64};
use harness::{check, guarded, Outcome};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

// ---------------------------------------------------------------------------------------------------------------
// A tiny XML tree: qualified names, attribute values and character data kept as written (escaped), so that a
// document written back is the same text.

#[derive(Clone, Debug)]
enum Node {
    Elem(Elem),
    /// Character data as written (escaped), a CDATA section, a comment or a processing instruction.
    Raw(String),
}

#[derive(Clone, Debug)]
struct Elem {
    name: String,
    /// Values as written (escaped); written back in double quotes.
    attrs: Vec<(String, String)>,
    children: Vec<Node>,
}

#[derive(Clone, Debug)]
struct Doc {
    /// `<?xml …?>`, when there is one.
    decl: Option<String>,
    /// Comments and processing instructions before the root.
    prolog: String,
    root: Elem,
    epilog: String,
}

fn local(name: &str) -> &str {
    name.rsplit(':').next().unwrap_or(name)
}

fn prefix(name: &str) -> Option<&str> {
    name.split_once(':').map(|(p, _)| p)
}

fn with_prefix(p: Option<&str>, local: &str) -> String {
    match p {
        Some(p) => format!("{p}:{local}"),
        None => local.to_string(),
    }
}

fn parse(text: &str) -> Doc {
    let text = text.trim_start_matches('\u{feff}');
    let (decl, rest) = if text.starts_with("<?xml") {
        let end = text.find("?>").expect("declaration") + 2;
        (Some(text[..end].to_string()), &text[end..])
    } else {
        (None, text)
    };
    let mut p = 0;
    loop {
        let lt = p + rest[p..].find('<').expect("a root element");
        if rest[lt..].starts_with("<!--") {
            p = lt + rest[lt..].find("-->").unwrap() + 3;
        } else if rest[lt..].starts_with("<?") {
            p = lt + rest[lt..].find("?>").unwrap() + 2;
        } else {
            p = lt;
            break;
        }
    }
    let (root, end) = parse_elem(rest, p);
    Doc {
        decl,
        prolog: rest[..p].to_string(),
        root,
        epilog: rest[end..].to_string(),
    }
}

fn parse_elem(s: &str, at: usize) -> (Elem, usize) {
    let mut i = at + 1;
    let end = i + s[i..]
        .find(|c: char| c.is_whitespace() || c == '>' || c == '/')
        .unwrap();
    let name = s[i..end].to_string();
    i = end;
    let mut attrs = Vec::new();
    loop {
        i += s[i..].len() - s[i..].trim_start().len();
        if s[i..].starts_with("/>") {
            let e = Elem {
                name,
                attrs,
                children: Vec::new(),
            };
            return (e, i + 2);
        }
        if s[i..].starts_with('>') {
            i += 1;
            break;
        }
        let eq = i + s[i..].find('=').unwrap();
        let an = s[i..eq].trim().to_string();
        i = eq + 1;
        i += s[i..].len() - s[i..].trim_start().len();
        let q = s[i..].chars().next().unwrap();
        let vend = i + 1 + s[i + 1..].find(q).unwrap();
        let v = s[i + 1..vend].replace('"', "&quot;");
        attrs.push((an, v));
        i = vend + 1;
    }
    let mut children = Vec::new();
    loop {
        let lt = i + s[i..].find('<').unwrap();
        if lt > i {
            children.push(Node::Raw(s[i..lt].to_string()));
        }
        i = lt;
        let r = &s[i..];
        if r.starts_with("</") {
            let gt = i + r.find('>').unwrap();
            return (
                Elem {
                    name,
                    attrs,
                    children,
                },
                gt + 1,
            );
        }
        let raw_end = if r.starts_with("<!--") {
            Some(r.find("-->").unwrap() + 3)
        } else if r.starts_with("<![CDATA[") {
            Some(r.find("]]>").unwrap() + 3)
        } else if r.starts_with("<?") {
            Some(r.find("?>").unwrap() + 2)
        } else {
            None
        };
        match raw_end {
            Some(e) => {
                children.push(Node::Raw(r[..e].to_string()));
                i += e;
            }
            None => {
                let (c, e) = parse_elem(s, i);
                children.push(Node::Elem(c));
                i = e;
            }
        }
    }
}

fn write_elem(e: &Elem, out: &mut String) {
    out.push('<');
    out.push_str(&e.name);
    for (k, v) in &e.attrs {
        let _ = write!(out, " {k}=\"{v}\"");
    }
    if e.children.is_empty() {
        out.push_str("/>");
        return;
    }
    out.push('>');
    for c in &e.children {
        match c {
            Node::Elem(c) => write_elem(c, out),
            Node::Raw(r) => out.push_str(r),
        }
    }
    out.push_str("</");
    out.push_str(&e.name);
    out.push('>');
}

/// The document's text after its declaration (the declaration is written with the encoding chosen).
fn body_text(doc: &Doc) -> String {
    let mut out = doc.prolog.clone();
    write_elem(&doc.root, &mut out);
    out.push_str(&doc.epilog);
    out
}

impl Elem {
    fn new(name: impl Into<String>) -> Elem {
        Elem {
            name: name.into(),
            attrs: Vec::new(),
            children: Vec::new(),
        }
    }
    fn with(mut self, child: Elem) -> Elem {
        self.children.push(Node::Elem(child));
        self
    }
    fn text(mut self, t: impl Into<String>) -> Elem {
        self.children.push(Node::Raw(t.into()));
        self
    }
    fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }
    fn set_attr(&mut self, name: &str, value: &str) {
        match self.attrs.iter_mut().find(|(k, _)| k == name) {
            Some((_, v)) => *v = value.to_string(),
            None => self.attrs.push((name.to_string(), value.to_string())),
        }
    }
    fn remove_attr(&mut self, name: &str) {
        self.attrs.retain(|(k, _)| k != name);
    }
    fn elems(&self) -> impl Iterator<Item = &Elem> {
        self.children.iter().filter_map(|c| match c {
            Node::Elem(e) => Some(e),
            Node::Raw(_) => None,
        })
    }
    /// Character data (comments and processing instructions left out; CDATA as written).
    fn text_content(&self) -> String {
        self.children
            .iter()
            .filter_map(|c| match c {
                Node::Raw(r) if !r.starts_with("<!--") && !r.starts_with("<?") => Some(r.as_str()),
                _ => None,
            })
            .collect()
    }
    fn set_text(&mut self, t: impl Into<String>) {
        self.children = vec![Node::Raw(t.into())];
    }
    fn gml_id(&self) -> Option<&str> {
        self.attr("gml:id")
    }
}

/// Every element's path (child indices) below `e`, `e` itself as the empty path, in document order.
fn element_paths(e: &Elem, at: &mut Vec<usize>, out: &mut Vec<Vec<usize>>) {
    out.push(at.clone());
    for (i, c) in e.children.iter().enumerate() {
        if let Node::Elem(c) = c {
            at.push(i);
            element_paths(c, at, out);
            at.pop();
        }
    }
}

fn all_paths(doc: &Doc) -> Vec<Vec<usize>> {
    let mut out = Vec::new();
    element_paths(&doc.root, &mut Vec::new(), &mut out);
    out
}

fn elem<'a>(root: &'a Elem, path: &[usize]) -> &'a Elem {
    let mut e = root;
    for &i in path {
        e = match &e.children[i] {
            Node::Elem(c) => c,
            Node::Raw(_) => panic!("a path to text"),
        };
    }
    e
}

fn elem_mut<'a>(root: &'a mut Elem, path: &[usize]) -> &'a mut Elem {
    let mut e = root;
    for &i in path {
        e = match &mut e.children[i] {
            Node::Elem(c) => c,
            Node::Raw(_) => panic!("a path to text"),
        };
    }
    e
}

/// Shows a path by its elements' names: `/CityModel/cityObjectMember[2]/bldg:Building/…`.
fn show(root: &Elem, path: &[usize]) -> String {
    let mut s = format!("/{}", root.name);
    let mut e = root;
    for &i in path {
        let Node::Elem(c) = &e.children[i] else {
            break;
        };
        let nth = e.children[..i]
            .iter()
            .filter(|n| matches!(n, Node::Elem(x) if x.name == c.name))
            .count();
        if nth > 0 {
            let _ = write!(s, "/{}[{}]", c.name, nth + 1);
        } else {
            let _ = write!(s, "/{}", c.name);
        }
        e = c;
    }
    s
}

fn remove_at(root: &mut Elem, path: &[usize]) -> Elem {
    let (last, parent) = path.split_last().expect("not the root");
    match elem_mut(root, parent).children.remove(*last) {
        Node::Elem(e) => e,
        Node::Raw(_) => unreachable!(),
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Inputs

struct Input {
    /// The file name the case is written under (`.gz` or `.zip` appended when so written).
    name: &'static str,
    doc: Doc,
    /// Written in ISO-8859-1 (as its declaration says) unless a mutation says otherwise.
    latin1: bool,
    /// A valid file read with it now and then.
    companion: PathBuf,
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/citygml")
        .join(name)
}

fn read_fixture(name: &str) -> String {
    std::fs::read_to_string(fixture(name)).unwrap()
}

fn zurich() -> Input {
    Input {
        name: "zurich-lod2-citygml1.xml",
        doc: parse(&read_fixture("zurich-lod2-citygml1.xml")),
        latin1: false,
        companion: fixture("delft-citygml2.xml"),
    }
}

fn delft() -> Input {
    Input {
        name: "delft-citygml2.xml",
        doc: parse(&read_fixture("delft-citygml2.xml")),
        latin1: false,
        companion: fixture("zurich-lod2-citygml1.xml"),
    }
}

/// SIG3D's example declares CH1903 for coordinates in a German UTM zone: given its true CRS, so that it reads.
fn sig3d() -> Input {
    let text = read_fixture("sig3d-genericattributes-citygml2.xml")
        .replace("srsName=\"CH1903\"", "srsName=\"EPSG:25832\"");
    Input {
        name: "sig3d-genericattributes.gml",
        doc: parse(&text),
        latin1: false,
        companion: fixture("tiles.zip"),
    }
}

/// A gabled house 10 m × 8 m, eaves at 6 m and ridge at 9 m above z0, as (type, ring) polygons.
fn gabled_house(x0: f64, y0: f64, z0: f64) -> Vec<(&'static str, Vec<[f64; 3]>)> {
    let p = |x: f64, y: f64, z: f64| [x0 + x, y0 + y, z0 + z];
    vec![
        (
            "GroundSurface",
            vec![p(0., 0., 0.), p(0., 8., 0.), p(10., 8., 0.), p(10., 0., 0.)],
        ),
        (
            "WallSurface",
            vec![p(0., 0., 0.), p(10., 0., 0.), p(10., 0., 6.), p(0., 0., 6.)],
        ),
        (
            "WallSurface",
            vec![
                p(10., 0., 0.),
                p(10., 8., 0.),
                p(10., 8., 6.),
                p(10., 4., 9.),
                p(10., 0., 6.),
            ],
        ),
        (
            "WallSurface",
            vec![p(10., 8., 0.), p(0., 8., 0.), p(0., 8., 6.), p(10., 8., 6.)],
        ),
        (
            "WallSurface",
            vec![
                p(0., 8., 0.),
                p(0., 0., 0.),
                p(0., 0., 6.),
                p(0., 4., 9.),
                p(0., 8., 6.),
            ],
        ),
        (
            "RoofSurface",
            vec![p(0., 0., 6.), p(10., 0., 6.), p(10., 4., 9.), p(0., 4., 9.)],
        ),
        (
            "RoofSurface",
            vec![p(0., 8., 6.), p(0., 4., 9.), p(10., 4., 9.), p(10., 8., 6.)],
        ),
    ]
}

fn pos_list_text(ring: &[[f64; 3]]) -> String {
    ring.iter()
        .chain(ring.first())
        .map(|p| format!("{} {} {}", p[0], p[1], p[2]))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The six faces of a box `side` m wide and `h` m high at (x, y, z0), each a `gml:surfaceMember` of `gml:pos`s.
fn box_members(x: f64, y: f64, z0: f64, side: f64, h: f64) -> String {
    let p = |a: f64, b: f64, z: f64| [x + a, y + b, z0 + z];
    let s = side;
    let faces = [
        vec![p(0., 0., 0.), p(0., s, 0.), p(s, s, 0.), p(s, 0., 0.)],
        vec![p(0., 0., h), p(s, 0., h), p(s, s, h), p(0., s, h)],
        vec![p(0., 0., 0.), p(s, 0., 0.), p(s, 0., h), p(0., 0., h)],
        vec![p(s, 0., 0.), p(s, s, 0.), p(s, s, h), p(s, 0., h)],
        vec![p(s, s, 0.), p(0., s, 0.), p(0., s, h), p(s, s, h)],
        vec![p(0., s, 0.), p(0., 0., 0.), p(0., 0., h), p(0., s, h)],
    ];
    faces
        .iter()
        .map(|f| {
            format!(
                "<gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>{}</gml:LinearRing>\
                 </gml:exterior></gml:Polygon></gml:surfaceMember>",
                f.iter()
                    .chain(f.first())
                    .map(|q| format!("<gml:pos>{} {} {}</gml:pos>", q[0], q[1], q[2]))
                    .collect::<String>()
            )
        })
        .collect()
}

/// A CityGML 3.0 model in ISO-8859-1 near Cologne, after `citygml_input.rs`'s: B1 a gabled house whose lod2Solid
/// refers to its thematic surfaces' polygons (one through a reversed OrientableSurface), with a 3.0 `con:height`;
/// B2 a box with a BuildingPart (a smaller box beside it) and a broken lod3 geometry; B3 with only a reference to
/// nothing; a road.
fn citygml3() -> Input {
    let (x0, y0, z0) = (356_000.0, 5_645_000.0, 50.0);
    let house = gabled_house(x0, y0, z0);
    let mut boundary = String::new();
    let mut members = String::new();
    for (i, (kind, ring)) in house.iter().enumerate() {
        let reversed: Vec<[f64; 3]> = ring.iter().rev().copied().collect();
        let ring = if i == 1 { &reversed } else { ring };
        boundary.push_str(&format!(
            "<core:boundary><con:{kind} gml:id=\"B1_s{i}\"><core:lod2MultiSurface><gml:MultiSurface>\
             <gml:surfaceMember><gml:Polygon gml:id=\"B1_p{i}\"><gml:exterior><gml:LinearRing>\
             <gml:posList>{}</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember>\
             </gml:MultiSurface></core:lod2MultiSurface></con:{kind}></core:boundary>\n",
            pos_list_text(ring)
        ));
        if i == 1 {
            members.push_str(&format!(
                "<gml:surfaceMember><gml:OrientableSurface orientation=\"-\">\
                 <gml:baseSurface xlink:href=\"#B1_p{i}\"/></gml:OrientableSurface></gml:surfaceMember>"
            ));
        } else {
            members.push_str(&format!("<gml:surfaceMember xlink:href=\"#B1_p{i}\"/>"));
        }
    }
    let text = format!(
        r##"<?xml version="1.0" encoding="ISO-8859-1"?>
<!-- written by citylod's tests -->
<core:CityModel xmlns:core="http://www.opengis.net/citygml/3.0" xmlns:bldg="http://www.opengis.net/citygml/building/3.0"
  xmlns:con="http://www.opengis.net/citygml/construction/3.0" xmlns:gen="http://www.opengis.net/citygml/generics/3.0"
  xmlns:tran="http://www.opengis.net/citygml/transportation/3.0" xmlns:gml="http://www.opengis.net/gml/3.2"
  xmlns:xlink="http://www.w3.org/1999/xlink">
 <gml:name>Prüfmodell</gml:name>
 <gml:boundedBy><gml:Envelope srsName="urn:adv:crs:ETRS89_UTM32*DE_DHHN2016_NH" srsDimension="3">
  <gml:lowerCorner>356000 5645000 50</gml:lowerCorner><gml:upperCorner>356040 5645010 59</gml:upperCorner>
 </gml:Envelope></gml:boundedBy>
 <core:cityObjectMember>
  <bldg:Building gml:id="B1">
   <gml:name>Haus Müller</gml:name>
   <gen:genericAttribute><gen:StringAttribute><gen:name>Bauweise</gen:name><gen:value>Massivbau</gen:value></gen:StringAttribute></gen:genericAttribute>
   <gen:genericAttribute><gen:IntAttribute><gen:name>Eingänge</gen:name><gen:value>2</gen:value></gen:IntAttribute></gen:genericAttribute>
   <con:height><con:Height><con:highReference>highestPoint</con:highReference><con:lowReference>lowestGroundPoint</con:lowReference>
    <con:status>measured</con:status><con:value uom="m">9</con:value></con:Height></con:height>
   <bldg:storeysAboveGround>2</bldg:storeysAboveGround>
   {boundary}
   <core:lod2Solid><gml:Solid><gml:exterior><gml:Shell>{members}</gml:Shell></gml:exterior></gml:Solid></core:lod2Solid>
  </bldg:Building>
 </core:cityObjectMember>
 <core:cityObjectMember><tran:Road gml:id="R1"/></core:cityObjectMember>
 <core:cityObjectMember>
  <bldg:Building gml:id="B2">
   <core:lod1Solid><gml:Solid><gml:exterior><gml:Shell>{box}</gml:Shell></gml:exterior></gml:Solid></core:lod1Solid>
   <core:lod3MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>
    <gml:posList>1 2 3 4</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></core:lod3MultiSurface>
   <bldg:buildingPart><bldg:BuildingPart gml:id="B2_part">
    <core:lod1Solid><gml:Solid><gml:exterior><gml:Shell>{part}</gml:Shell></gml:exterior></gml:Solid></core:lod1Solid>
   </bldg:BuildingPart></bldg:buildingPart>
  </bldg:Building>
 </core:cityObjectMember>
 <core:cityObjectMember>
  <bldg:Building gml:id="B3">
   <core:lod1Solid xlink:href="#nowhere"/>
  </bldg:Building>
 </core:cityObjectMember>
</core:CityModel>
"##,
        box = box_members(x0 + 20.0, y0, z0, 6.0, 7.5),
        part = box_members(x0 + 26.0, y0, z0, 4.0, 4.0),
    );
    Input {
        name: "model-3.0.gml",
        doc: parse(&text),
        latin1: true,
        companion: fixture("zurich-lod2-citygml1.xml"),
    }
}

/// A WFS 2.0 GetFeature answer of CityGML 2.0 buildings (`wfs:member`s): two LoD 0 footprints with measured heights
/// and a box as an lod1Solid.
fn wfs() -> Input {
    let text = format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<wfs:FeatureCollection xmlns:wfs="http://www.opengis.net/wfs/2.0" xmlns:gml="http://www.opengis.net/gml"
 xmlns:bldg="http://www.opengis.net/citygml/building/2.0" xmlns:xlink="http://www.w3.org/1999/xlink" numberMatched="3" numberReturned="3">
 <wfs:member><bldg:Building gml:id="W1"><bldg:measuredHeight uom="m">12</bldg:measuredHeight>
  <bldg:lod0FootPrint><gml:MultiSurface srsName="EPSG:25832"><gml:surfaceMember><gml:Polygon gml:id="W1p"><gml:exterior>
  <gml:LinearRing><gml:posList srsDimension="3">356000 5645000 50 356010 5645000 50 356010 5645010 50 356000 5645010 50 356000 5645000 50</gml:posList>
  </gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod0FootPrint>
 </bldg:Building></wfs:member>
 <wfs:member><bldg:Building gml:id="W2"><bldg:measuredHeight uom="m">6</bldg:measuredHeight>
  <bldg:lod0FootPrint><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior>
  <gml:LinearRing><gml:posList srsDimension="3">356020 5645000 50 356030 5645000 50 356030 5645010 50 356020 5645010 50 356020 5645000 50</gml:posList>
  </gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod0FootPrint>
 </bldg:Building></wfs:member>
 <wfs:member><bldg:Building gml:id="W3"><bldg:lod1Solid><gml:Solid><gml:exterior><gml:CompositeSurface>{}</gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod1Solid>
 </bldg:Building></wfs:member>
</wfs:FeatureCollection>
"#,
        box_members(356_040.0, 5_645_000.0, 50.0, 8.0, 5.0)
    );
    Input {
        name: "wfs-answer.xml",
        doc: parse(&text),
        latin1: false,
        companion: fixture("delft-citygml2.xml"),
    }
}

// ---------------------------------------------------------------------------------------------------------------
// Mutations

/// Local names an element may be renamed to: CityGML's and GML's, and a few they do not have.
#[rustfmt::skip]
const NAMES: &[&str] = &[
    "Building", "BuildingPart", "BuildingInstallation", "Road", "CityModel", "cityObjectMember", "featureMember",
    "member", "boundedBy", "boundary", "consistsOfBuildingPart", "buildingPart", "RoofSurface", "WallSurface",
    "GroundSurface", "ClosureSurface", "OuterCeilingSurface", "Window", "Door", "opening", "lod0FootPrint",
    "lod0RoofEdge", "lod0MultiSurface", "lod1Solid", "lod1MultiSurface", "lod2Solid", "lod2MultiSurface",
    "lod2MultiSolid", "lod3MultiSurface", "lod4Solid", "lod4MultiSurface", "lod5Solid", "lod2Surface",
    "lod2CompositeSurface", "lod2ImplicitRepresentation", "lod", "lodSolid", "Polygon", "Triangle", "Rectangle",
    "PolygonPatch", "MultiSurface", "CompositeSurface", "Surface", "TriangulatedSurface", "Tin", "PolyhedralSurface",
    "Shell", "Solid", "CompositeSolid", "MultiSolid", "solidMember", "solidMembers", "surfaceMember",
    "surfaceMembers", "patches", "trianglePatches", "exterior", "interior", "outerBoundaryIs", "innerBoundaryIs",
    "LinearRing", "Ring", "curveMember", "LineString", "Curve", "segments", "LineStringSegment", "Arc", "posList",
    "pos", "coordinates", "pointProperty", "Point", "OrientableSurface", "TexturedSurface", "baseSurface",
    "Envelope", "lowerCorner", "upperCorner", "measuredHeight", "storeysAboveGround", "height", "Height", "value",
    "name", "description", "class", "function", "stringAttribute", "genericAttribute", "genericAttributeSet",
    "externalReference", "address", "MultiPoint", "x", "",
];

/// Local names of GML geometry, swapped for one another.
#[rustfmt::skip]
const GEOMETRY: &[&str] = &[
    "Polygon", "Triangle", "Rectangle", "PolygonPatch", "MultiSurface", "CompositeSurface", "Surface",
    "TriangulatedSurface", "Tin", "PolyhedralSurface", "Shell", "Solid", "CompositeSolid", "MultiSolid",
    "OrientableSurface", "TexturedSurface", "LinearRing", "Ring", "MultiCurve", "LineString",
];

/// Geometry properties: the element holding a geometry inline or by reference.
#[rustfmt::skip]
const PROPERTIES: &[&str] = &[
    "surfaceMember", "solidMember", "exterior", "interior", "baseSurface", "curveMember", "lod0FootPrint",
    "lod0RoofEdge", "lod1Solid", "lod2Solid", "lod2MultiSurface", "lod1MultiSurface", "lod3MultiSurface",
    "lod0MultiSurface", "lod4Solid", "outerBoundaryIs",
];

/// CRS names a srsName may give: EPSG codes of every kind, the usual URN and URL spellings, compound ones, the
/// AdV's and Switzerland's names, proj strings and garbage.
#[rustfmt::skip]
const CRS_NAMES: &[&str] = &[
    "EPSG:4326", "urn:ogc:def:crs:EPSG::4326", "EPSG:4258", "EPSG:3857", "EPSG:2263", "EPSG:32631", "EPSG:3413",
    "EPSG:27700", "EPSG:21781", "EPSG:2056", "EPSG:4978", "EPSG:7415", "EPSG:28992", "EPSG:25832", "EPSG:0",
    "EPSG:99999", "EPSG:4294967297", "urn:ogc:def:crs:EPSG::28992", "urn:ogc:def:crs:EPSG:6.12:25832",
    "https://www.opengis.net/def/crs/EPSG/0/28992", "http://www.opengis.net/def/crs/EPSG/0/6697",
    "urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::7837", "urn:ogc:def:crs,crs:EPSG::,crs:EPSG::7837",
    "urn:ogc:def:crs,,,", "urn:adv:crs:ETRS89_UTM32*DE_DHHN2016_NH", "urn:adv:crs:DE_DHDN_3GK3*DE_DHHN92_NH",
    "urn:adv:crs:Somewhere", "urn:adv:crs:*", "CH1903", "CH1903+", "LV95", "CRS84", "urn:ogc:def:crs:OGC:1.3:CRS84",
    "", " ", "EPSG", "EPSG:", "EPSG::", "epsg:28992", "EPSG:28992 ", "#", "x", "\u{e9}\u{feff}",
    "+proj=longlat +datum=WGS84", "+proj=tmerc +k=0", "+proj=utm +zone=61", "+proj=nonsense", "+proj",
    "+proj=tmerc +lat_0=90 +k=1e-300", "+proj=geos +h=0", "+proj=tmerc +to_meter=-1",
];

/// Texts a number or a coordinate may become.
#[rustfmt::skip]
const NUMBERS: &[&str] = &[
    "x", "NaN", "nan", "inf", "-inf", "infinity", "1e400", "-1e400", "1e-400", "1,5", "0x10", "+5", ".5", "5.", "-0",
    "1e308", "-1e308", "1_000", "\u{661}\u{662}", "", "1e", "--1", "4294967296", "18446744073709551616",
];

/// Values an attribute may be given.
#[rustfmt::skip]
const ATTRIBUTE_VALUES: &[&str] = &[
    "", " ", "2", "3", "0", "-", "+", "#m", "m", "ft", "#", "#x", "x", "&amp;", "&#x41;", "&lt;gml&gt;",
    "99999999999999999999", "http://www.opengis.net/gml", "urn:x",
];

/// Attributes the reader looks at.
#[rustfmt::skip]
const ATTRIBUTE_NAMES: &[&str] = &[
    "gml:id", "xlink:href", "srsName", "srsDimension", "orientation", "uom", "name", "cs", "ts", "decimal", "count",
    "id", "href", "xlink:type",
];

/// The elements whose text is coordinates.
fn is_coordinates(name: &str) -> bool {
    matches!(
        local(name),
        "posList" | "pos" | "coordinates" | "lowerCorner" | "upperCorner"
    )
}

/// A random element path from the pool (all elements when the pool is empty).
fn pick_path(rng: &mut SplitMix64, paths: &[Vec<usize>], pool: &[usize]) -> Vec<usize> {
    if pool.is_empty() {
        paths[(rng.next_u64() % paths.len() as u64) as usize].clone()
    } else {
        paths[*rng.pick(pool)].clone()
    }
}

/// The indices in `paths` of the elements `keep` takes.
fn pool(doc: &Doc, paths: &[Vec<usize>], keep: impl Fn(&Elem, &[usize]) -> bool) -> Vec<usize> {
    (0..paths.len())
        .filter(|&i| keep(elem(&doc.root, &paths[i]), &paths[i]))
        .collect()
}

/// The prefix that names `uri` on the root, if any (`Some(None)`: the default namespace).
fn prefix_of(doc: &Doc, part: &str) -> Option<Option<String>> {
    doc.root.attrs.iter().find_map(|(k, v)| {
        if !v.contains(part) {
            return None;
        }
        if k == "xmlns" {
            Some(None)
        } else {
            k.strip_prefix("xmlns:").map(|p| Some(p.to_string()))
        }
    })
}

/// A random number of the ring as a (x, y, z) list, from a posList or pos children.
fn ring_points(ring: &Elem) -> Vec<[f64; 3]> {
    let mut nums: Vec<f64> = Vec::new();
    for c in ring.elems() {
        if matches!(local(&c.name), "posList" | "pos") {
            nums.extend(
                c.text_content()
                    .split_ascii_whitespace()
                    .filter_map(|t| t.parse::<f64>().ok()),
            );
        }
    }
    nums.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

fn pos_list_of(points: &[[f64; 3]]) -> String {
    points
        .iter()
        .map(|p| format!("{} {} {}", p[0], p[1], p[2]))
        .collect::<Vec<_>>()
        .join(" ")
}

/// One structural mutation of `doc`, described.
fn mutate(doc: &mut Doc, rng: &mut SplitMix64) -> String {
    let paths = all_paths(doc);
    let any: Vec<usize> = Vec::new();
    // Most mutations aim at what the reader reads: a Building's elements, geometry, coordinates.
    let in_building = pool(doc, &paths, |_, p| {
        p.len() >= 2 && {
            let b = elem(&doc.root, &p[..2]);
            matches!(local(&b.name), "Building")
        }
    });
    let chosen = match rng.next_u64() % 3 {
        0 => &any,
        _ => &in_building,
    };
    let path = pick_path(rng, &paths, chosen);
    let at = show(&doc.root, &path);
    match rng.next_u64() % 12 {
        0 | 1 if !path.is_empty() => {
            remove_at(&mut doc.root, &path);
            format!("{at} deleted")
        }
        2 if !path.is_empty() => {
            let e = elem(&doc.root, &path).clone();
            let (last, parent) = path.split_last().unwrap();
            let p = elem_mut(&mut doc.root, parent);
            let to = if rng.chance(0.5) {
                last + 1
            } else {
                (rng.next_u64() % (p.children.len() as u64 + 1)) as usize
            };
            p.children.insert(to, Node::Elem(e));
            format!("{at} duplicated at child {to}")
        }
        3 if !path.is_empty() => {
            // Moved under another element (not inside itself).
            let e = remove_at(&mut doc.root, &path);
            let paths = all_paths(doc);
            let to = paths[(rng.next_u64() % paths.len() as u64) as usize].clone();
            let shown = show(&doc.root, &to);
            let t = elem_mut(&mut doc.root, &to);
            let k = (rng.next_u64() % (t.children.len() as u64 + 1)) as usize;
            t.children.insert(k, Node::Elem(e));
            format!("{at} moved into {shown} at child {k}")
        }
        4 => {
            let e = elem_mut(&mut doc.root, &path);
            let idx: Vec<usize> = (0..e.children.len())
                .filter(|&i| matches!(e.children[i], Node::Elem(_)))
                .collect();
            if idx.len() >= 2 {
                let (i, j) = (*rng.pick(&idx), *rng.pick(&idx));
                e.children.swap(i, j);
                format!("{at}: children {i} and {j} swapped")
            } else {
                e.children.reverse();
                format!("{at}: children reversed")
            }
        }
        5 => {
            let e = elem_mut(&mut doc.root, &path);
            e.children.reverse();
            format!("{at}: children reversed")
        }
        6 | 7 => {
            let to = *rng.pick(NAMES);
            let e = elem_mut(&mut doc.root, &path);
            let p = prefix(&e.name).map(str::to_string);
            e.name = with_prefix(p.as_deref(), to);
            if to.is_empty() {
                // Not a name: keep the text well-formed XML and just something no reader knows.
                e.name = with_prefix(p.as_deref(), "unknownElement");
            }
            format!("{at} renamed {}", e.name)
        }
        8 => {
            // Its prefix: another the root declares, none, or one nobody declares.
            let declared: Vec<String> = doc
                .root
                .attrs
                .iter()
                .filter_map(|(k, _)| k.strip_prefix("xmlns:").map(str::to_string))
                .collect();
            let e = elem_mut(&mut doc.root, &path);
            let l = local(&e.name).to_string();
            let p = match rng.next_u64() % 4 {
                0 => None,
                1 => Some("zz".to_string()),
                _ => Some(rng.pick(&declared).clone()),
            };
            e.name = with_prefix(p.as_deref(), &l);
            format!("{at} renamed {}", e.name)
        }
        9 => {
            let e = elem_mut(&mut doc.root, &path);
            if rng.chance(0.5) {
                e.children.clear();
                format!("{at} emptied")
            } else {
                let t = *rng.pick(&["", "x", "12", " ", "0 0 0", "&amp;", "&#32;"]);
                e.set_text(t);
                format!("{at}: content := {t:?}")
            }
        }
        10 => {
            let e = elem_mut(&mut doc.root, &path);
            if e.attrs.is_empty() || rng.chance(0.5) {
                let k = *rng.pick(ATTRIBUTE_NAMES);
                let v = *rng.pick(ATTRIBUTE_VALUES);
                e.set_attr(k, v);
                format!("{at}: @{k} := {v:?}")
            } else {
                let i = (rng.next_u64() % e.attrs.len() as u64) as usize;
                let (k, _) = e.attrs.remove(i);
                format!("{at}: @{k} removed")
            }
        }
        _ if !path.is_empty() => {
            // Wrapped in another element.
            let to = *rng.pick(NAMES);
            let to = if to.is_empty() { "x" } else { to };
            let e = remove_at(&mut doc.root, &path);
            let p = prefix(&e.name).map(str::to_string);
            let w = Elem::new(with_prefix(p.as_deref(), to)).with(e);
            let (last, parent) = path.split_last().unwrap();
            elem_mut(&mut doc.root, parent)
                .children
                .insert(*last, Node::Elem(w));
            format!("{at} wrapped in {}", with_prefix(p.as_deref(), to))
        }
        _ => {
            doc.root.children.reverse();
            "the root's children reversed".into()
        }
    }
}

/// A mutation aimed at what the generic ones rarely reach; `None` when the document has nothing it aims at.
fn mutate_targeted(doc: &mut Doc, rng: &mut SplitMix64) -> Option<String> {
    let paths = all_paths(doc);
    let coords = pool(doc, &paths, |e, _| is_coordinates(&e.name));
    let buildings = pool(doc, &paths, |e, _| {
        matches!(local(&e.name), "Building" | "BuildingPart")
    });
    let with_ids = pool(doc, &paths, |e, _| e.gml_id().is_some());
    let ids: Vec<String> = with_ids
        .iter()
        .map(|&i| elem(&doc.root, &paths[i]).gml_id().unwrap().to_string())
        .collect();
    if coords.is_empty() || buildings.is_empty() {
        return None;
    }
    let kind = rng.next_u64() % 28;
    match kind {
        0..=2 => {
            // Coordinates' text.
            let path = paths[*rng.pick(&coords)].clone();
            let at = show(&doc.root, &path);
            let e = elem_mut(&mut doc.root, &path);
            let text = e.text_content();
            let tokens: Vec<&str> = text.split_ascii_whitespace().collect();
            let (new, what) = match rng.next_u64() % 11 {
                0 => (String::new(), "emptied".to_string()),
                1 => {
                    let n = *rng.pick(&[3_000usize, 30_000, 300_000]);
                    let t: Vec<&str> = tokens.iter().cycle().take(n).copied().collect();
                    (t.join(" "), format!("{n} numbers"))
                }
                2 if !tokens.is_empty() => {
                    let i = (rng.next_u64() % tokens.len() as u64) as usize;
                    let v = *rng.pick(NUMBERS);
                    let mut t = tokens.clone();
                    t[i] = v;
                    (t.join(" "), format!("number {i} := {v:?}"))
                }
                3 if !tokens.is_empty() => {
                    let mut t = tokens.clone();
                    t.pop();
                    (t.join(" "), "last number dropped".into())
                }
                4 => {
                    let mut t = tokens.clone();
                    t.push("7");
                    (t.join(" "), "a number added".into())
                }
                5 if tokens.len() >= 3 => {
                    let first = tokens[..3].join(" ");
                    let t: Vec<String> = (0..tokens.len() / 3).map(|_| first.clone()).collect();
                    (t.join(" "), "every point the first".into())
                }
                6 => {
                    let k = *rng.pick(&[1e300, 1e15, -1.0, 0.0, 1e-300, 1.0 + 1e-12]);
                    let t: Vec<String> = tokens
                        .iter()
                        .map(|x| {
                            x.parse::<f64>()
                                .map_or(x.to_string(), |v| format!("{}", v * k))
                        })
                        .collect();
                    (t.join(" "), format!("every number × {k}"))
                }
                7 => {
                    // Made 2D: every third number dropped.
                    let t: Vec<&str> = tokens
                        .iter()
                        .enumerate()
                        .filter(|(i, _)| i % 3 != 2)
                        .map(|(_, t)| *t)
                        .collect();
                    (t.join(" "), "every third number dropped".into())
                }
                8 => {
                    let t: Vec<&str> = tokens
                        .chunks(3)
                        .flat_map(|c| {
                            if c.len() == 3 {
                                vec![c[1], c[0], c[2]]
                            } else {
                                c.to_vec()
                            }
                        })
                        .collect();
                    (t.join(" "), "x and y swapped".into())
                }
                9 => {
                    let sep = *rng.pick(&["\t", "\n  ", ",", "\u{a0}", "  ", "\r\n"]);
                    (tokens.join(sep), format!("separated by {sep:?}"))
                }
                _ => {
                    let mut t = tokens.clone();
                    t.reverse();
                    (t.join(" "), "numbers reversed".into())
                }
            };
            e.set_text(new);
            Some(format!("{at}: {what}"))
        }
        3 => {
            // srsDimension on coordinates or one of their ancestors.
            let path = paths[*rng.pick(&coords)].clone();
            let up = (rng.next_u64() % 4) as usize;
            let path = path[..path.len().saturating_sub(up)].to_vec();
            let at = show(&doc.root, &path);
            let v = *rng.pick(&[
                "2",
                "3",
                "0",
                "1",
                "4",
                "-1",
                "",
                "3.0",
                " 3 ",
                "99999999999999999999",
                "2 3",
            ]);
            elem_mut(&mut doc.root, &path).set_attr("srsDimension", v);
            Some(format!("{at}: @srsDimension := {v:?}"))
        }
        4 => {
            // srsName: every one changed, all removed, or one added on a geometry deep inside.
            let v = *rng.pick(CRS_NAMES);
            match rng.next_u64() % 3 {
                0 => {
                    for p in &paths {
                        let e = elem_mut(&mut doc.root, p);
                        if e.attr("srsName").is_some() {
                            e.set_attr("srsName", v);
                        }
                    }
                    Some(format!("every @srsName := {v:?}"))
                }
                1 => {
                    for p in &paths {
                        elem_mut(&mut doc.root, p).remove_attr("srsName");
                    }
                    Some("every @srsName removed".into())
                }
                _ => {
                    let path = pick_path(rng, &paths, &coords);
                    let path = path[..path.len().saturating_sub(2)].to_vec();
                    let at = show(&doc.root, &path);
                    elem_mut(&mut doc.root, &path).set_attr("srsName", v);
                    Some(format!("{at}: @srsName := {v:?}"))
                }
            }
        }
        5..=7 => {
            // An xlink:href on a geometry property: to nothing, itself, an ancestor, another element, outside.
            let props = pool(doc, &paths, |e, _| PROPERTIES.contains(&local(&e.name)));
            let path = pick_path(rng, &paths, &props);
            let at = show(&doc.root, &path);
            let ancestor_ids: Vec<String> = (0..path.len())
                .filter_map(|k| elem(&doc.root, &path[..k]).gml_id().map(str::to_string))
                .collect();
            let target = match rng.next_u64() % 6 {
                0 => "#nowhere".to_string(),
                1 => rng
                    .pick(&["#", "", "nowhere", "other.gml#p1", "#B1 ", "# p"])
                    .to_string(),
                2 if !ancestor_ids.is_empty() => format!("#{}", rng.pick(&ancestor_ids)),
                3 if !ids.is_empty() => format!("#{}", rng.pick(&ids).to_uppercase()),
                _ if !ids.is_empty() => format!("#{}", rng.pick(&ids)),
                _ => "#nowhere".to_string(),
            };
            let e = elem_mut(&mut doc.root, &path);
            e.set_attr("xlink:href", &target);
            let emptied = rng.chance(0.7);
            if emptied {
                e.children.clear();
            }
            Some(format!(
                "{at}: @xlink:href := {target:?}{}",
                if emptied { ", emptied" } else { "" }
            ))
        }
        8 => {
            // References in a cycle, or an element referring to itself.
            if ids.len() < 2 {
                return None;
            }
            let a = with_ids[(rng.next_u64() % with_ids.len() as u64) as usize];
            let b = with_ids[(rng.next_u64() % with_ids.len() as u64) as usize];
            let (ida, idb) = (
                elem(&doc.root, &paths[a]).gml_id().unwrap().to_string(),
                elem(&doc.root, &paths[b]).gml_id().unwrap().to_string(),
            );
            elem_mut(&mut doc.root, &paths[a]).set_attr("xlink:href", &format!("#{idb}"));
            elem_mut(&mut doc.root, &paths[b]).set_attr("xlink:href", &format!("#{ida}"));
            // A property pointing into the cycle.
            let props = pool(doc, &paths, |e, _| {
                matches!(
                    local(&e.name),
                    "surfaceMember" | "lod2MultiSurface" | "lod1Solid" | "exterior"
                )
            });
            if let Some(&p) = props.first().map(|_| rng.pick(&props)) {
                let e = elem_mut(&mut doc.root, &paths[p]);
                e.set_attr("xlink:href", &format!("#{ida}"));
                e.children.clear();
            }
            Some(format!(
                "#{ida} and #{idb} refer to each other, a property to #{ida}"
            ))
        }
        9 => {
            // A chain of MultiSurfaces each referring `fan` times to the one before: fan^depth polygons from a
            // few elements (as entities expand in a "billion laughs").
            let polys = pool(doc, &paths, |e, p| {
                local(&e.name) == "Polygon" && p.len() >= 2
            });
            if polys.is_empty() || buildings.is_empty() {
                return None;
            }
            let pp = paths[*rng.pick(&polys)].clone();
            let id = match elem(&doc.root, &pp).gml_id() {
                Some(id) => id.to_string(),
                None => {
                    elem_mut(&mut doc.root, &pp).set_attr("gml:id", "bomb0");
                    "bomb0".to_string()
                }
            };
            // The building whose member holds the polygon.
            let bpath = pp[..2].to_vec();
            if !matches!(
                local(&elem(&doc.root, &bpath).name),
                "Building" | "BuildingPart"
            ) {
                return None;
            }
            let fan = *rng.pick(&[2usize, 3]);
            // At most some 10,000 polygons: a case stays fast (see
            // `references_do_not_multiply_a_few_elements_into_millions_of_polygons` for more).
            let depth = match fan {
                2 => 4 + (rng.next_u64() % 10) as usize,
                _ => 3 + (rng.next_u64() % 6) as usize,
            };
            let g = prefix_of(doc, "opengis.net/gml").flatten();
            let gn = |l: &str| with_prefix(g.as_deref(), l);
            let b = elem_mut(&mut doc.root, &bpath);
            let bp = prefix(&b.name).map(str::to_string);
            let mut defs = Elem::new(with_prefix(bp.as_deref(), "definitions"));
            let mut prev = id.clone();
            for k in 1..=depth {
                let mut ms = Elem::new(gn("MultiSurface"));
                ms.set_attr("gml:id", &format!("chain{k}"));
                for _ in 0..fan {
                    let mut m = Elem::new(gn("surfaceMember"));
                    m.set_attr("xlink:href", &format!("#{prev}"));
                    ms = ms.with(m);
                }
                defs = defs.with(ms);
                prev = format!("chain{k}");
            }
            let mut prop = Elem::new(with_prefix(bp.as_deref(), "lod3MultiSurface"));
            prop.set_attr("xlink:href", &format!("#{prev}"));
            b.children.push(Node::Elem(defs));
            b.children.push(Node::Elem(prop));
            Some(format!(
                "{}: an lod3MultiSurface of {fan}^{depth} references to #{id}",
                show(&doc.root, &bpath)
            ))
        }
        10 => {
            // measuredHeight (1.0/2.0) or con:height's value (3.0): an odd unit or value, removed or given twice.
            let b = paths[*rng.pick(&buildings)].clone();
            let at = show(&doc.root, &b);
            let e = elem_mut(&mut doc.root, &b);
            let bp = prefix(&e.name).map(str::to_string);
            let uom = *rng.pick(&[
                "#m",
                "m",
                "ft",
                "[ft_i]",
                "[ft_us]",
                "cm",
                "mm",
                "furlong",
                "",
                "urn:adv:uom:m",
                "#",
                "m2",
                "#km",
            ]);
            let value = *rng.pick(&[
                "0", "-5", "1e400", "NaN", "inf", "12,5", "  7  ", "1e-320", "", "99999999", "3.5",
                "1e6", "-0", "12 m", "0x10",
            ]);
            let name = with_prefix(bp.as_deref(), "measuredHeight");
            let existing = e
                .children
                .iter()
                .position(|c| matches!(c, Node::Elem(x) if local(&x.name) == "measuredHeight"));
            match rng.next_u64() % 4 {
                0 => {
                    e.children.retain(
                        |c| !matches!(c, Node::Elem(x) if local(&x.name) == "measuredHeight"),
                    );
                    Some(format!("{at}: measuredHeight removed"))
                }
                1 => {
                    // A second one after the first.
                    let mut m = Elem::new(name).text(value);
                    m.set_attr("uom", uom);
                    e.children.push(Node::Elem(m));
                    Some(format!(
                        "{at}: another measuredHeight {value:?} uom {uom:?}"
                    ))
                }
                _ => {
                    let mut m = Elem::new(name).text(value);
                    if !rng.chance(0.15) {
                        m.set_attr("uom", uom);
                    }
                    match existing {
                        Some(i) => e.children[i] = Node::Elem(m),
                        None => e.children.insert(0, Node::Elem(m)),
                    }
                    Some(format!("{at}: measuredHeight := {value:?} uom {uom:?}"))
                }
            }
        }
        11 => {
            // gml:ids given twice: one element's id given to another, a Building's to another Building, or gone.
            if ids.is_empty() {
                return None;
            }
            let (from, to) = if rng.chance(0.4) && buildings.len() >= 2 {
                (
                    paths[*rng.pick(&buildings)].clone(),
                    paths[*rng.pick(&buildings)].clone(),
                )
            } else {
                (
                    paths[*rng.pick(&with_ids)].clone(),
                    paths[*rng.pick(&with_ids)].clone(),
                )
            };
            let at = show(&doc.root, &to);
            match elem(&doc.root, &from).gml_id().map(str::to_string) {
                Some(id) if rng.chance(0.8) => {
                    elem_mut(&mut doc.root, &to).set_attr("gml:id", &id);
                    Some(format!("{at}: @gml:id := {id:?} (given twice)"))
                }
                _ => {
                    let v = *rng.pick(&["", " ", "#x", "a b", "1"]);
                    let e = elem_mut(&mut doc.root, &to);
                    if rng.chance(0.5) {
                        e.remove_attr("gml:id");
                        Some(format!("{at}: @gml:id removed"))
                    } else {
                        e.set_attr("gml:id", v);
                        Some(format!("{at}: @gml:id := {v:?}"))
                    }
                }
            }
        }
        12 => {
            // An interior ring: a proper hole, the shell again, reversed, grown past the shell, away from it, or
            // of two points.
            let polys = pool(doc, &paths, |e, _| {
                local(&e.name) == "Polygon" && e.elems().any(|c| local(&c.name) == "exterior")
            });
            if polys.is_empty() {
                return None;
            }
            let path = paths[*rng.pick(&polys)].clone();
            let at = show(&doc.root, &path);
            let g = prefix_of(doc, "opengis.net/gml").flatten();
            let gn = |l: &str| with_prefix(g.as_deref(), l);
            let p = elem_mut(&mut doc.root, &path);
            let ext = p
                .elems()
                .find(|c| local(&c.name) == "exterior")
                .unwrap()
                .clone();
            let ring = ext.elems().next()?;
            let pts = ring_points(ring);
            if pts.len() < 3 {
                return None;
            }
            let n = pts.len() as f64;
            let c = pts.iter().fold([0.0; 3], |a, q| {
                [a[0] + q[0] / n, a[1] + q[1] / n, a[2] + q[2] / n]
            });
            let scale = |k: f64| -> Vec<[f64; 3]> {
                pts.iter()
                    .map(|q| {
                        [
                            c[0] + (q[0] - c[0]) * k,
                            c[1] + (q[1] - c[1]) * k,
                            c[2] + (q[2] - c[2]) * k,
                        ]
                    })
                    .collect()
            };
            let (hole, what) = match rng.next_u64() % 6 {
                0 | 1 => {
                    let mut h = scale(0.5);
                    h.reverse();
                    (h, "half its size")
                }
                2 => (pts.clone(), "the shell again"),
                3 => (scale(2.0), "twice the shell's size"),
                4 => (
                    pts.iter().map(|q| [q[0] + 1000.0, q[1], q[2]]).collect(),
                    "1 km away",
                ),
                _ => (pts[..2].to_vec(), "of two points"),
            };
            let ring =
                Elem::new(gn("LinearRing")).with(Elem::new(gn("posList")).text(pos_list_of(&hole)));
            p.children
                .push(Node::Elem(Elem::new(gn("interior")).with(ring)));
            Some(format!("{at}: an interior ring {what}"))
        }
        13 => {
            // One GML geometry type for another, or wrapped in another.
            let geoms = pool(doc, &paths, |e, _| GEOMETRY.contains(&local(&e.name)));
            let path = pick_path(rng, &paths, &geoms);
            let at = show(&doc.root, &path);
            let to = *rng.pick(GEOMETRY);
            let e = elem_mut(&mut doc.root, &path);
            let p = prefix(&e.name).map(str::to_string);
            if rng.chance(0.7) || path.is_empty() {
                e.name = with_prefix(p.as_deref(), to);
                Some(format!("{at} renamed {to}"))
            } else {
                let (outer, inner) = *rng.pick(&[
                    ("CompositeSolid", "solidMember"),
                    ("MultiSolid", "solidMember"),
                    ("Solid", "exterior"),
                    ("MultiSurface", "surfaceMember"),
                    ("CompositeSurface", "surfaceMember"),
                    ("OrientableSurface", "baseSurface"),
                ]);
                let e = remove_at(&mut doc.root, &path);
                let mut w = Elem::new(with_prefix(p.as_deref(), outer))
                    .with(Elem::new(with_prefix(p.as_deref(), inner)).with(e));
                if outer == "OrientableSurface" {
                    let o: &&str = rng.pick(&["-", "+", "x", ""]);
                    w.set_attr("orientation", o);
                }
                let (last, parent) = path.split_last().unwrap();
                elem_mut(&mut doc.root, parent)
                    .children
                    .insert(*last, Node::Elem(w));
                Some(format!("{at} wrapped in {outer}/{inner}"))
            }
        }
        14 | 15 => {
            // BuildingParts: a part nested in a part nested …, a part made a member of its own, a part with its
            // building's id, a Building where a part should be.
            if buildings.is_empty() {
                return None;
            }
            let b = paths[*rng.pick(&buildings)].clone();
            let at = show(&doc.root, &b);
            match rng.next_u64() % 4 {
                0 | 1 => {
                    let depth = *rng.pick(&[1usize, 2, 5, 40, 120]);
                    let e = elem(&doc.root, &b).clone();
                    let bp = prefix(&e.name).map(str::to_string);
                    let tag = if rng.chance(0.85) {
                        "BuildingPart"
                    } else {
                        "Building"
                    };
                    let prop = *rng.pick(&["consistsOfBuildingPart", "buildingPart"]);
                    // The innermost part: the building's geometry again (its own elements, ids and all).
                    let mut part = Elem::new(with_prefix(bp.as_deref(), tag));
                    part.children = e.children.clone();
                    if rng.chance(0.5) {
                        if let Some(id) = e.gml_id() {
                            part.set_attr("gml:id", &format!("{id}_p"));
                        }
                    }
                    for k in 1..depth {
                        let mut outer = Elem::new(with_prefix(bp.as_deref(), "BuildingPart"));
                        if k % 3 == 0 {
                            outer.set_attr("gml:id", &format!("nest{k}"));
                        }
                        part = outer.with(Elem::new(with_prefix(bp.as_deref(), prop)).with(part));
                    }
                    let holder = Elem::new(with_prefix(bp.as_deref(), prop)).with(part);
                    elem_mut(&mut doc.root, &b)
                        .children
                        .push(Node::Elem(holder));
                    Some(format!("{at}: a {tag} {depth} deep in {prop}s"))
                }
                2 => {
                    // A part (or the building's copy as a part) a member of its own.
                    let parts = pool(doc, &paths, |e, _| local(&e.name) == "BuildingPart");
                    let src = if parts.is_empty() {
                        b.clone()
                    } else {
                        paths[*rng.pick(&parts)].clone()
                    };
                    let mut e = elem(&doc.root, &src).clone();
                    let bp = prefix(&e.name).map(str::to_string);
                    e.name = with_prefix(bp.as_deref(), "BuildingPart");
                    let member_name = elem(&doc.root, &b[..1]).name.clone();
                    doc.root
                        .children
                        .push(Node::Elem(Elem::new(member_name).with(e)));
                    Some(format!(
                        "{} made a member of its own as a BuildingPart",
                        show(&doc.root, &src)
                    ))
                }
                _ => {
                    // Its parts' ids the building's.
                    let e = elem_mut(&mut doc.root, &b);
                    let id = e.gml_id().unwrap_or("").to_string();
                    fn set_parts(e: &mut Elem, id: &str) {
                        for c in e.children.iter_mut() {
                            if let Node::Elem(c) = c {
                                if local(&c.name) == "BuildingPart" {
                                    c.set_attr("gml:id", id);
                                }
                                set_parts(c, id);
                            }
                        }
                    }
                    set_parts(e, &id);
                    Some(format!("{at}: every part's @gml:id := {id:?}"))
                }
            }
        }
        16 => {
            // Implicit geometry (a prototype placed by a matrix): what the reader does with it, beside the
            // building's own geometry or instead of it.
            if buildings.is_empty() {
                return None;
            }
            let b = paths[*rng.pick(&buildings)].clone();
            let at = show(&doc.root, &b);
            let core = prefix(&doc.root.name).map(str::to_string);
            let g = prefix_of(doc, "opengis.net/gml").flatten();
            let gn = |l: &str| with_prefix(g.as_deref(), l);
            let polys = pool(doc, &paths, |e, _| local(&e.name) == "Polygon");
            let proto = if polys.is_empty() {
                Elem::new(gn("MultiSurface"))
            } else {
                let mut p = elem(&doc.root, &paths[*rng.pick(&polys)]).clone();
                p.remove_attr("gml:id");
                Elem::new(gn("MultiSurface")).with(Elem::new(gn("surfaceMember")).with(p))
            };
            let first = ring_points(elem(&doc.root, &paths[*rng.pick(&coords)]));
            let e = elem_mut(&mut doc.root, &b);
            let bp = prefix(&e.name).map(str::to_string);
            let lod = *rng.pick(&["1", "2", "3", "4"]);
            let implicit = Elem::new(with_prefix(core.as_deref(), "ImplicitGeometry"))
                .with(
                    Elem::new(with_prefix(core.as_deref(), "transformationMatrix")).text(
                        *rng.pick(&[
                            "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1",
                            "0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0",
                            "1 0 0",
                            "1e308 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1",
                        ]),
                    ),
                )
                .with(Elem::new(with_prefix(core.as_deref(), "relativeGMLGeometry")).with(proto))
                .with(
                    Elem::new(with_prefix(core.as_deref(), "referencePoint")).with(
                        Elem::new(gn("Point")).with(
                            Elem::new(gn("pos")).text(
                                first
                                    .first()
                                    .map(|p| format!("{} {} {}", p[0], p[1], p[2]))
                                    .unwrap_or_else(|| "0 0 0".into()),
                            ),
                        ),
                    ),
                );
            let prop = Elem::new(with_prefix(
                bp.as_deref(),
                &format!("lod{lod}ImplicitRepresentation"),
            ))
            .with(implicit);
            let alone = rng.chance(0.5);
            if alone {
                e.children.retain(|c| {
                    !matches!(c, Node::Elem(x) if local(&x.name).starts_with("lod")
                        || matches!(local(&x.name), "boundedBy" | "boundary" | "consistsOfBuildingPart" | "buildingPart"))
                });
            }
            e.children.push(Node::Elem(prop));
            Some(format!(
                "{at}: an lod{lod}ImplicitRepresentation{}",
                if alone {
                    " instead of its geometry"
                } else {
                    ""
                }
            ))
        }
        17 | 18 => {
            // Character data other than plain text: CDATA, a comment or processing instruction between numbers,
            // character references, an escaped '<', an entity not defined.
            let texts = pool(doc, &paths, |e, _| {
                is_coordinates(&e.name)
                    || matches!(
                        local(&e.name),
                        "measuredHeight" | "value" | "name" | "storeysAboveGround"
                    )
            });
            let path = pick_path(rng, &paths, &texts);
            let at = show(&doc.root, &path);
            let e = elem_mut(&mut doc.root, &path);
            let text = e.text_content();
            let cut = text
                .char_indices()
                .filter(|(_, c)| *c == ' ')
                .map(|(i, _)| i)
                .collect::<Vec<_>>();
            let at_space = if cut.is_empty() {
                text.len()
            } else {
                *rng.pick(&cut)
            };
            let (a, b) = text.split_at(at_space);
            let what = match rng.next_u64() % 9 {
                0 => {
                    e.set_text(format!("<![CDATA[{text}]]>"));
                    "in CDATA"
                }
                1 => {
                    e.set_text(format!("{a}<![CDATA[{b}]]>"));
                    "partly in CDATA"
                }
                2 | 3 => {
                    e.children = vec![
                        Node::Raw(a.to_string()),
                        Node::Raw("<!-- a comment -->".into()),
                        Node::Raw(b.to_string()),
                    ];
                    "a comment inside"
                }
                4 => {
                    e.children = vec![
                        Node::Raw(a.to_string()),
                        Node::Raw("<?pi x?>".into()),
                        Node::Raw(b.to_string()),
                    ];
                    "a processing instruction inside"
                }
                5 => {
                    let t: String = text
                        .chars()
                        .map(|c| match c {
                            '1' => "&#49;".to_string(),
                            ' ' => "&#x20;".to_string(),
                            c => c.to_string(),
                        })
                        .collect();
                    e.set_text(t);
                    "digits 1 and spaces as character references"
                }
                6 => {
                    e.set_text(format!("{a} &lt;x&gt; {b}"));
                    "an escaped <x> inside"
                }
                7 => {
                    e.set_text(format!("{a} &undefined; {b}"));
                    "an undefined entity inside"
                }
                _ => {
                    e.children = vec![
                        Node::Raw(a.to_string()),
                        Node::Elem(Elem::new("x")),
                        Node::Raw(b.to_string()),
                    ];
                    "an element inside"
                }
            };
            Some(format!("{at}: {what}"))
        }
        19 => {
            // Namespaces: a declaration's URI changed or removed; one redeclared on an inner element.
            let decls: Vec<usize> = (0..doc.root.attrs.len())
                .filter(|&i| doc.root.attrs[i].0.starts_with("xmlns"))
                .collect();
            if decls.is_empty() {
                return None;
            }
            let i = *rng.pick(&decls);
            let k = doc.root.attrs[i].0.clone();
            let v = doc.root.attrs[i].1.clone();
            let uri = *rng.pick(&[
                "http://www.opengis.net/gml/3.2",
                "http://www.opengis.net/gml",
                "http://www.opengis.net/citygml/3.0",
                "http://www.opengis.net/citygml/1.0",
                "http://www.opengis.net/citygml/building/2.0",
                "urn:x",
                "",
                "http://www.w3.org/1999/xlink",
            ]);
            match rng.next_u64() % 3 {
                0 => {
                    doc.root.attrs[i].1 = uri.to_string();
                    Some(format!("root: @{k} := {uri:?} (was {v:?})"))
                }
                1 => {
                    doc.root.attrs.remove(i);
                    Some(format!("root: @{k} removed"))
                }
                _ => {
                    let path = pick_path(rng, &paths, &buildings);
                    let at = show(&doc.root, &path);
                    elem_mut(&mut doc.root, &path).set_attr(&k, uri);
                    Some(format!("{at}: @{k} := {uri:?}"))
                }
            }
        }
        20 => {
            // Nesting: an element inside many levels of GML aggregates, or many levels of one unknown element.
            let path = pick_path(rng, &paths, &any_in_buildings(doc, &paths));
            if path.is_empty() {
                return None;
            }
            let at = show(&doc.root, &path);
            let depth = *rng.pick(&[
                20usize, 33, 40, 120, 126, 127, 128, 250, 254, 255, 256, 257, 1000, 100_000,
            ]);
            let g = prefix_of(doc, "opengis.net/gml").flatten();
            let e = remove_at(&mut doc.root, &path);
            let (last, parent) = path.split_last().unwrap();
            let p = elem_mut(&mut doc.root, parent);
            if depth <= 260 && rng.chance(0.6) {
                // MultiSurface/surfaceMember around and around it (each two levels).
                let mut w = e;
                for _ in 0..depth / 2 {
                    w = Elem::new(with_prefix(g.as_deref(), "MultiSurface"))
                        .with(Elem::new(with_prefix(g.as_deref(), "surfaceMember")).with(w));
                }
                p.children.insert(*last, Node::Elem(w));
                Some(format!("{at} inside {} MultiSurfaces", depth / 2))
            } else {
                let mut s = String::new();
                write_elem(&e, &mut s);
                let open = "<n>".repeat(depth);
                let close = "</n>".repeat(depth);
                p.children
                    .insert(*last, Node::Raw(format!("{open}{s}{close}")));
                Some(format!("{at} inside {depth} elements <n>"))
            }
        }
        21 | 22 => rewrite_ring(doc, &paths, rng),
        23 => rewrite_surface(doc, &paths, rng),
        24 | 25 => solid_variant(doc, &paths, rng),
        26 => move_building(doc, &paths, rng),
        _ => {
            // Members: one given twice, emptied, a reference, a Building straight under the root, two Buildings in
            // one member.
            let members: Vec<usize> = (0..doc.root.children.len())
                .filter(|&i| {
                    matches!(&doc.root.children[i], Node::Elem(e) if local(&e.name) != "boundedBy" && local(&e.name) != "name")
                })
                .collect();
            if members.is_empty() {
                return None;
            }
            let m = *rng.pick(&members);
            let Node::Elem(me) = doc.root.children[m].clone() else {
                unreachable!()
            };
            let at = show(&doc.root, &[m]);
            match rng.next_u64() % 5 {
                0 => {
                    doc.root.children.insert(m + 1, Node::Elem(me));
                    Some(format!("{at} given twice"))
                }
                1 => {
                    let mut e = Elem::new(me.name.clone());
                    if rng.chance(0.5) {
                        if let Some(id) = ids.first() {
                            e.set_attr("xlink:href", &format!("#{id}"));
                        }
                    }
                    doc.root.children.insert(m, Node::Elem(e));
                    Some(format!("an empty {} (or a reference) before {at}", me.name))
                }
                2 => {
                    // Its objects straight under the root, no member around them.
                    let inner: Vec<Node> = me.children.clone();
                    doc.root.children.splice(m..m + 1, inner);
                    Some(format!("{at}: its content straight under the root"))
                }
                3 => {
                    // Its objects in the member before it too.
                    let objs: Vec<Node> = me
                        .children
                        .iter()
                        .filter(|c| matches!(c, Node::Elem(_)))
                        .cloned()
                        .collect();
                    let &other = members.iter().find(|&&o| o != m)?;
                    if let Node::Elem(o) = &mut doc.root.children[other] {
                        o.children.extend(objs);
                    }
                    Some(format!(
                        "{at}'s objects added to {}",
                        show(&doc.root, &[other])
                    ))
                }
                _ => {
                    let to = *rng.pick(&[
                        "featureMember",
                        "member",
                        "featureMembers",
                        "cityObjectMembers",
                        "appearanceMember",
                        "x",
                    ]);
                    if let Node::Elem(e) = &mut doc.root.children[m] {
                        let p = prefix(&e.name).map(str::to_string);
                        e.name = with_prefix(p.as_deref(), to);
                    }
                    Some(format!("{at} renamed {to}"))
                }
            }
        }
    }
}

/// A LinearRing written another way GML allows: `gml:coordinates` (with odd separators now and then), a
/// `pointProperty` or `pointRep` per point, a `gml:Ring` of curve members (LineStrings, a Curve of segments, one by
/// reference, an Arc), or a posList of two dimensions.
fn rewrite_ring(doc: &mut Doc, paths: &[Vec<usize>], rng: &mut SplitMix64) -> Option<String> {
    let rings = pool(doc, paths, |e, _| {
        local(&e.name) == "LinearRing" && ring_points(e).len() >= 3
    });
    if rings.is_empty() {
        return None;
    }
    let path = paths[*rng.pick(&rings)].clone();
    let at = show(&doc.root, &path);
    let g = prefix_of(doc, "opengis.net/gml").flatten();
    let gn = |l: &str| with_prefix(g.as_deref(), l);
    let pts = ring_points(elem(&doc.root, &path));
    let xyz = |p: &[f64; 3]| format!("{} {} {}", p[0], p[1], p[2]);
    let (new, what) = match rng.next_u64() % 7 {
        0 | 1 => {
            let (cs, ts, decimal) = *rng.pick(&[
                (",", " ", "."),
                (",", " ", "."),
                (";", "|", ","),
                ("", " ", "."),
                (",", "", "."),
                (",", " ", ""),
                (" ", ",", "."),
                (",,", " ", "."),
            ]);
            let t: Vec<String> = pts
                .iter()
                .map(|p| {
                    [p[0], p[1], p[2]]
                        .iter()
                        .map(|v| {
                            v.to_string()
                                .replace('.', if decimal.is_empty() { "." } else { decimal })
                        })
                        .collect::<Vec<_>>()
                        .join(if cs.is_empty() { "," } else { cs })
                })
                .collect();
            let mut c =
                Elem::new(gn("coordinates")).text(t.join(if ts.is_empty() { " " } else { ts }));
            if (cs, ts, decimal) != (",", " ", ".") {
                c.set_attr("cs", cs);
                c.set_attr("ts", ts);
                c.set_attr("decimal", decimal);
            }
            (
                Elem::new(gn("LinearRing")).with(c),
                format!("as gml:coordinates (cs {cs:?} ts {ts:?} decimal {decimal:?})"),
            )
        }
        2 => {
            let prop = *rng.pick(&["pointProperty", "pointRep"]);
            let mut r = Elem::new(gn("LinearRing"));
            for p in &pts {
                r = r.with(
                    Elem::new(gn(prop))
                        .with(Elem::new(gn("Point")).with(Elem::new(gn("pos")).text(xyz(p)))),
                );
            }
            (r, format!("as {prop}s"))
        }
        3 => {
            let t: Vec<String> = pts.iter().map(|p| format!("{} {}", p[0], p[1])).collect();
            let mut pl = Elem::new(gn("posList")).text(t.join(" "));
            pl.set_attr("srsDimension", "2");
            (
                Elem::new(gn("LinearRing")).with(pl),
                "in two dimensions".into(),
            )
        }
        _ => {
            // A Ring of curve members: the points cut in pieces sharing their ends.
            let mut closed = pts.clone();
            closed.push(pts[0]);
            let cut = 1 + (rng.next_u64() % (closed.len() as u64 - 2)) as usize;
            let pieces = [&closed[..=cut], &closed[cut..]];
            let list = |ps: &[[f64; 3]]| Elem::new(gn("posList")).text(pos_list_of(ps));
            let mut ring = Elem::new(gn("Ring"));
            let how = rng.next_u64() % 4;
            for (k, piece) in pieces.iter().enumerate() {
                let curve = match (how, k) {
                    (0, _) => Elem::new(gn("LineString")).with(list(piece)),
                    (1, 1) | (2, 0) => Elem::new(gn("Curve")).with(
                        Elem::new(gn("segments"))
                            .with(Elem::new(gn("LineStringSegment")).with(list(piece))),
                    ),
                    (3, 1) => Elem::new(gn("Curve")).with(
                        Elem::new(gn("segments")).with(Elem::new(gn("Arc")).with(list(piece))),
                    ),
                    _ => Elem::new(gn("LineString")).with(list(piece)),
                };
                ring = ring.with(Elem::new(gn("curveMember")).with(curve));
            }
            let what = [
                "LineStrings",
                "a Curve of a LineStringSegment",
                "a LineString by reference",
                "an Arc",
            ][how as usize];
            if how == 2 {
                // The second piece by reference to a LineString elsewhere in the member.
                let Node::Elem(second) = ring.children.pop().unwrap() else {
                    unreachable!()
                };
                let mut line = second.elems().next().unwrap().clone();
                line.set_attr("gml:id", "ring-piece");
                let mut m = Elem::new(gn("curveMember"));
                m.set_attr("xlink:href", "#ring-piece");
                ring = ring.with(m);
                // Kept in the building, where the reader finds ids.
                if path.len() >= 2 {
                    let b = elem_mut(&mut doc.root, &path[..2]);
                    let bp = prefix(&b.name).map(str::to_string);
                    b.children.push(Node::Elem(
                        Elem::new(with_prefix(bp.as_deref(), "curves")).with(line),
                    ));
                }
            }
            (ring, format!("as a Ring of {what}"))
        }
    };
    *elem_mut(&mut doc.root, &path) = Elem {
        attrs: elem(&doc.root, &path).attrs.clone(),
        ..new
    };
    Some(format!("{at}: {what}"))
}

/// A Polygon written as another surface GML allows (a Triangle, a Rectangle, a Surface of PolygonPatches, a
/// TriangulatedSurface of its triangles, an OrientableSurface turning it back, a TexturedSurface), or a MultiSurface
/// as a CompositeSurface, with `surfaceMembers`, or as a Solid's shell.
fn rewrite_surface(doc: &mut Doc, paths: &[Vec<usize>], rng: &mut SplitMix64) -> Option<String> {
    let g = prefix_of(doc, "opengis.net/gml").flatten();
    let gn = |l: &str| with_prefix(g.as_deref(), l);
    if rng.chance(0.3) {
        let multis = pool(doc, paths, |e, _| local(&e.name) == "MultiSurface");
        if multis.is_empty() {
            return None;
        }
        let path = paths[*rng.pick(&multis)].clone();
        let at = show(&doc.root, &path);
        let e = elem_mut(&mut doc.root, &path);
        match rng.next_u64() % 3 {
            0 => {
                e.name = gn("CompositeSurface");
                Some(format!("{at} renamed CompositeSurface"))
            }
            1 => {
                let surfaces: Vec<Node> = e
                    .elems()
                    .flat_map(|m| m.elems().cloned().map(Node::Elem))
                    .collect();
                e.children = vec![Node::Elem(Elem {
                    name: gn("surfaceMembers"),
                    attrs: Vec::new(),
                    children: surfaces,
                })];
                Some(format!("{at}: its members in one surfaceMembers"))
            }
            _ => {
                let mut ms = e.clone();
                ms.name = gn("Shell");
                *e = Elem::new(gn("Solid")).with(Elem::new(gn("exterior")).with(ms));
                Some(format!("{at} made a Solid's shell"))
            }
        }
    } else {
        let polys = pool(doc, paths, |e, _| {
            local(&e.name) == "Polygon"
                && e.elems().any(|c| {
                    local(&c.name) == "exterior"
                        && c.elems().next().is_some_and(|r| ring_points(r).len() >= 3)
                })
        });
        if polys.is_empty() {
            return None;
        }
        let path = paths[*rng.pick(&polys)].clone();
        let at = show(&doc.root, &path);
        let poly = elem(&doc.root, &path).clone();
        let ext = poly.elems().find(|c| local(&c.name) == "exterior").unwrap();
        let pts = ring_points(ext.elems().next().unwrap());
        let ring_of = |ps: &[[f64; 3]]| {
            let mut closed = ps.to_vec();
            closed.push(ps[0]);
            Elem::new(gn("exterior")).with(
                Elem::new(gn("LinearRing"))
                    .with(Elem::new(gn("posList")).text(pos_list_of(&closed))),
            )
        };
        let (new, what) = match rng.next_u64() % 6 {
            0 => {
                let mut t = poly.clone();
                t.name = gn(if pts.len() == 3 {
                    "Triangle"
                } else {
                    "Rectangle"
                });
                (t, "as a Triangle or Rectangle")
            }
            1 => {
                let mut patch = poly.clone();
                patch.name = gn("PolygonPatch");
                patch.attrs.clear();
                let mut s = Elem::new(gn("Surface")).with(Elem::new(gn("patches")).with(patch));
                s.attrs = poly.attrs.clone();
                (s, "as a Surface of a PolygonPatch")
            }
            2 => {
                let mut patches = Elem::new(gn("trianglePatches"));
                for k in 1..pts.len() - 1 {
                    patches = patches.with(Elem::new(gn("Triangle")).with(ring_of(&[
                        pts[0],
                        pts[k],
                        pts[k + 1],
                    ])));
                }
                let mut s = Elem::new(gn("TriangulatedSurface")).with(patches);
                s.attrs = poly.attrs.clone();
                (s, "as a TriangulatedSurface of its fan")
            }
            3 | 4 => {
                // Turned, and turned back by an OrientableSurface (or a TexturedSurface) of orientation "-".
                let mut rev = pts.clone();
                rev.reverse();
                let mut p = Elem::new(gn("Polygon")).with(ring_of(&rev));
                p.attrs = poly.attrs.clone();
                let kind = if rng.chance(0.7) {
                    "OrientableSurface".to_string()
                } else {
                    // 1.0's texturedsurface module, under whatever prefix names it (else GML's, unknown there).
                    with_prefix(
                        prefix_of(doc, "texturedsurface")
                            .flatten()
                            .as_deref()
                            .or(g.as_deref()),
                        "TexturedSurface",
                    )
                };
                let name = if kind.contains(':') || g.is_none() {
                    if kind == "OrientableSurface" {
                        gn(&kind)
                    } else {
                        kind.clone()
                    }
                } else {
                    gn(&kind)
                };
                let mut o = Elem::new(name).with(Elem::new(gn("baseSurface")).with(p));
                o.set_attr("orientation", "-");
                (o, "reversed, in an OrientableSurface of orientation -")
            }
            _ => {
                let mut p = poly.clone();
                p.name = gn("Polygon");
                p.children
                    .retain(|c| !matches!(c, Node::Elem(x) if local(&x.name) == "interior"));
                (p, "its holes removed")
            }
        };
        *elem_mut(&mut doc.root, &path) = new;
        Some(format!("{at} {what}"))
    }
}

/// Every point of the coordinates below `e` (posList, pos, lowerCorner, upperCorner, taken three numbers at a time)
/// moved by `f`.
fn transform_coords(e: &mut Elem, f: &dyn Fn([f64; 3]) -> [f64; 3]) {
    if matches!(
        local(&e.name),
        "posList" | "pos" | "lowerCorner" | "upperCorner"
    ) {
        let nums: Vec<f64> = e
            .text_content()
            .split_ascii_whitespace()
            .filter_map(|t| t.parse().ok())
            .collect();
        if nums.len().is_multiple_of(3) && !nums.is_empty() {
            let moved: Vec<[f64; 3]> = nums.chunks(3).map(|c| f([c[0], c[1], c[2]])).collect();
            e.set_text(pos_list_of(&moved));
        }
        return;
    }
    for c in e.children.iter_mut() {
        if let Node::Elem(c) = c {
            transform_coords(c, f);
        }
    }
}

/// The centre of the points below `e`.
fn centre(e: &Elem) -> [f64; 3] {
    let mut pts = Vec::new();
    fn collect(e: &Elem, pts: &mut Vec<[f64; 3]>) {
        if matches!(local(&e.name), "posList" | "pos") {
            let nums: Vec<f64> = e
                .text_content()
                .split_ascii_whitespace()
                .filter_map(|t| t.parse().ok())
                .collect();
            pts.extend(nums.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        }
        for c in e.elems() {
            collect(c, pts);
        }
    }
    collect(e, &mut pts);
    let n = pts.len().max(1) as f64;
    pts.iter().fold([0.0; 3], |a, p| {
        [a[0] + p[0] / n, a[1] + p[1] / n, a[2] + p[2] / n]
    })
}

/// A Solid given a cavity (its shell again, shrunk, as an interior shell), or made one of a CompositeSolid or
/// MultiSolid with a copy of itself (on it, overlapping it, apart from it), or squashed flat or to a speck.
fn solid_variant(doc: &mut Doc, paths: &[Vec<usize>], rng: &mut SplitMix64) -> Option<String> {
    let solids = pool(doc, paths, |e, _| {
        local(&e.name) == "Solid" && e.elems().any(|c| local(&c.name) == "exterior")
    });
    if solids.is_empty() {
        return None;
    }
    let path = paths[*rng.pick(&solids)].clone();
    let at = show(&doc.root, &path);
    let g = prefix_of(doc, "opengis.net/gml").flatten();
    let gn = |l: &str| with_prefix(g.as_deref(), l);
    let solid = elem(&doc.root, &path).clone();
    let c = centre(&solid);
    let scaled = |e: &Elem, k: f64, kz: f64| {
        let mut e = e.clone();
        transform_coords(&mut e, &|p| {
            [
                c[0] + (p[0] - c[0]) * k,
                c[1] + (p[1] - c[1]) * k,
                c[2] + (p[2] - c[2]) * kz,
            ]
        });
        e
    };
    let strip_ids = |e: &mut Elem| {
        fn strip(e: &mut Elem) {
            e.remove_attr("gml:id");
            for c in e.children.iter_mut() {
                if let Node::Elem(c) = c {
                    strip(c);
                }
            }
        }
        strip(e);
    };
    let (new, what) = match rng.next_u64() % 5 {
        0 | 1 => {
            let ext = solid
                .elems()
                .find(|x| local(&x.name) == "exterior")
                .unwrap()
                .clone();
            let mut cavity = scaled(&ext, 0.5, 0.5);
            cavity.name = gn("interior");
            strip_ids(&mut cavity);
            let mut s = solid.clone();
            s.children.push(Node::Elem(cavity));
            (s, "a cavity (its shell at half size) added".to_string())
        }
        2 | 3 => {
            let dx = *rng.pick(&[0.0, 3.0, 100.0]);
            let mut copy = solid.clone();
            transform_coords(&mut copy, &|p| [p[0] + dx, p[1], p[2]]);
            strip_ids(&mut copy);
            let kind = *rng.pick(&["CompositeSolid", "MultiSolid"]);
            let member = |s: Elem| Elem::new(gn("solidMember")).with(s);
            let mut w = Elem::new(gn(kind));
            if rng.chance(0.2) {
                w = w.with(Elem::new(gn("solidMembers")).with(solid.clone()).with(copy));
            } else {
                w = w.with(member(solid.clone())).with(member(copy));
            }
            (w, format!("in a {kind} with a copy {dx} m east"))
        }
        _ => {
            let (k, kz, what) = *rng.pick(&[
                (1.0, 0.0, "squashed flat"),
                (1e-4, 1e-4, "shrunk to a speck"),
                (1.0, -1.0, "turned upside down"),
                (1e4, 1.0, "grown 10,000 times"),
            ]);
            (scaled(&solid, k, kz), what.to_string())
        }
    };
    *elem_mut(&mut doc.root, &path) = new;
    Some(format!("{at}: {what}"))
}

/// A building moved as a whole: far away, mirrored (every polygon turned inside out), onto z 0, below the datum.
fn move_building(doc: &mut Doc, paths: &[Vec<usize>], rng: &mut SplitMix64) -> Option<String> {
    let buildings = pool(doc, paths, |e, p| {
        local(&e.name) == "Building" && p.len() == 2
    });
    if buildings.is_empty() {
        return None;
    }
    let path = paths[*rng.pick(&buildings)].clone();
    let at = show(&doc.root, &path);
    let c = centre(elem(&doc.root, &path));
    type Move = Box<dyn Fn([f64; 3]) -> [f64; 3]>;
    let (f, what): (Move, &str) = match rng.next_u64() % 6 {
        0 => (
            Box::new(|p| [p[0] + 1e7, p[1], p[2]]),
            "moved 10,000 km east",
        ),
        1 => (Box::new(|p| [p[0] + 2e5, p[1] + 2e5, p[2]]), "moved 280 km"),
        2 => (
            Box::new(move |p| [2.0 * c[0] - p[0], p[1], p[2]]),
            "mirrored",
        ),
        3 => (
            Box::new(|p| [p[0], p[1], p[2] - 10_000.0]),
            "10 km below the datum",
        ),
        4 => (Box::new(|p| [p[0], p[1], 0.0]), "flattened onto z 0"),
        _ => (Box::new(|p| [p[1], p[0], p[2]]), "its x and y swapped"),
    };
    transform_coords(elem_mut(&mut doc.root, &path), &*f);
    Some(format!("{at} {what}"))
}

fn any_in_buildings(doc: &Doc, paths: &[Vec<usize>]) -> Vec<usize> {
    pool(doc, paths, |_, p| {
        p.len() >= 3 && matches!(local(&elem(&doc.root, &p[..2]).name), "Building")
    })
}

/// Text mutations after writing: cut short, one byte changed, one deleted, a line repeated, text inserted.
fn mutate_text(text: &mut Vec<u8>, rng: &mut SplitMix64) -> String {
    if text.is_empty() {
        return "no text to change".into();
    }
    let at = (rng.next_u64() % text.len() as u64) as usize;
    match rng.next_u64() % 6 {
        0 => {
            text.truncate(at);
            format!("text cut at byte {at}")
        }
        1 => {
            let b = *rng.pick(b"<>/\"'=&;#:0-.e\n x\0");
            text[at] = b;
            format!("byte {at} := {:?}", b as char)
        }
        2 => {
            text.remove(at);
            format!("byte {at} deleted")
        }
        3 => {
            text[at] = *rng.pick(&[0xFF, 0xC3, 0x80, 0xE9]);
            format!("byte {at} := 0x{:02X}", text[at])
        }
        4 => {
            let s = *rng.pick(&[
                "<!DOCTYPE x [<!ENTITY a \"aaaa\">]>",
                "&a;",
                "<![CDATA[",
                "]]>",
                "<!--",
                "</x>",
                "<x>",
                "\u{feff}",
                "<?xml version=\"1.0\"?>",
            ]);
            let mut at = at;
            while !text.is_char_boundary_at(at) {
                at -= 1;
            }
            text.splice(at..at, s.bytes());
            format!("{s:?} inserted at byte {at}")
        }
        _ => {
            let lines: Vec<&[u8]> = text.split(|&b| b == b'\n').collect();
            let i = (rng.next_u64() % lines.len() as u64) as usize;
            let mut out = Vec::with_capacity(text.len() * 2);
            for (k, l) in lines.iter().enumerate() {
                out.extend_from_slice(l);
                out.push(b'\n');
                if k == i {
                    out.extend_from_slice(l);
                    out.push(b'\n');
                }
            }
            *text = out;
            format!("line {} repeated", i + 1)
        }
    }
}

trait CharBoundary {
    fn is_char_boundary_at(&self, at: usize) -> bool;
}

impl CharBoundary for Vec<u8> {
    fn is_char_boundary_at(&self, at: usize) -> bool {
        at == 0 || at >= self.len() || (self[at] & 0xC0) != 0x80
    }
}

/// How a case's text is encoded and declared.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Encoding {
    /// UTF-8 with the declaration as it was (or none, as it was).
    Utf8,
    /// UTF-8 with a byte-order mark.
    Utf8Bom,
    /// UTF-8, and no declaration.
    Utf8Bare,
    /// ISO-8859-1, as declared.
    Latin1,
    /// Declared ISO-8859-1, written as UTF-8 (read as mojibake: valid, other characters).
    Latin1DeclaredUtf8Written,
    /// Declared UTF-8, written in ISO-8859-1 (not UTF-8 where the text is not ASCII).
    Utf8DeclaredLatin1Written,
    /// Another label declared: one the reader may not know, or UTF-16.
    Label(&'static str),
}

impl Encoding {
    /// Whether the file says truly what its bytes are.
    fn consistent(self) -> bool {
        matches!(
            self,
            Encoding::Utf8 | Encoding::Utf8Bom | Encoding::Utf8Bare | Encoding::Latin1
        )
    }
}

/// The bytes of a document in an encoding.
fn encode(doc: &Doc, enc: Encoding) -> Vec<u8> {
    let body = body_text(doc);
    let decl = |label: &str| {
        match &doc.decl {
            Some(d) => {
                // The declaration's encoding replaced (or added).
                match d.find("encoding=") {
                    Some(at) => {
                        let q = d.as_bytes()[at + 9] as char;
                        let end = at + 10 + d[at + 10..].find(q).unwrap();
                        format!("{}encoding=\"{label}\"{}", &d[..at], &d[end + 1..])
                    }
                    None => d.replacen("?>", &format!(" encoding=\"{label}\"?>"), 1),
                }
            }
            None => format!("<?xml version=\"1.0\" encoding=\"{label}\"?>"),
        }
    };
    let latin1 = |s: &str| -> Vec<u8> {
        let (b, _, _) = encoding_rs::WINDOWS_1252.encode(s);
        b.into_owned()
    };
    match enc {
        Encoding::Utf8 => format!("{}{body}", doc.decl.clone().unwrap_or_default()).into_bytes(),
        Encoding::Utf8Bom => {
            let mut b = b"\xef\xbb\xbf".to_vec();
            b.extend(format!("{}{body}", doc.decl.clone().unwrap_or_default()).bytes());
            b
        }
        Encoding::Utf8Bare => body.into_bytes(),
        Encoding::Latin1 => latin1(&format!("{}{body}", decl("ISO-8859-1"))),
        Encoding::Latin1DeclaredUtf8Written => format!("{}{body}", decl("ISO-8859-1")).into_bytes(),
        Encoding::Utf8DeclaredLatin1Written => latin1(&format!("{}{body}", decl("UTF-8"))),
        Encoding::Label(l) => format!("{}{body}", decl(l)).into_bytes(),
    }
}

fn encoding_for(input: &Input, rng: &mut SplitMix64) -> Encoding {
    let usual = if input.latin1 {
        Encoding::Latin1
    } else {
        Encoding::Utf8
    };
    if !rng.chance(0.15) {
        return usual;
    }
    *rng.pick(&[
        Encoding::Utf8,
        Encoding::Utf8Bom,
        Encoding::Utf8Bare,
        Encoding::Latin1,
        Encoding::Latin1DeclaredUtf8Written,
        Encoding::Utf8DeclaredLatin1Written,
        Encoding::Label("windows-1252"),
        Encoding::Label("latin1"),
        Encoding::Label("utf8"),
        Encoding::Label("UTF-16"),
        Encoding::Label("x-unknown"),
        Encoding::Label("Shift_JIS"),
        Encoding::Label("US-ASCII"),
        Encoding::Label(""),
    ])
}

/// How a case's file is written.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Container {
    Plain,
    Gzip,
    /// A ZIP archive of tiles (stored or deflated members): the case's file among valid ones.
    Zip {
        deflated: bool,
        others: bool,
    },
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

/// A mutated case: the document's tree (for the checks that need it), the file's bytes, and what was done.
struct Case {
    doc: Doc,
    /// The file's bytes are exactly the tree in a consistent encoding (the checks on what was read apply).
    exact: bool,
    file_name: String,
    bytes: Vec<u8>,
    done: Vec<String>,
}

/// The mutated case `seed` of `input`.
fn mutated(input: &Input, seed: u64, companion_text: &[u8]) -> Case {
    let mut rng = SplitMix64(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ fnv(input.name));
    let mut doc = input.doc.clone();
    let mut done = Vec::new();
    for _ in 0..1 + rng.next_u64() % 3 {
        let what = if rng.chance(0.55) {
            mutate_targeted(&mut doc, &mut rng)
        } else {
            None
        };
        done.push(what.unwrap_or_else(|| mutate(&mut doc, &mut rng)));
    }
    let enc = encoding_for(input, &mut rng);
    if enc
        != if input.latin1 {
            Encoding::Latin1
        } else {
            Encoding::Utf8
        }
    {
        done.push(format!("encoding {enc:?}"));
    }
    let mut bytes = encode(&doc, enc);
    let mut exact = enc.consistent();
    if rng.chance(0.12) {
        done.push(mutate_text(&mut bytes, &mut rng));
        exact = false;
    }
    let container = match rng.next_u64() % 20 {
        0 | 1 => Container::Gzip,
        2 | 3 => Container::Zip {
            deflated: rng.chance(0.5),
            others: rng.chance(0.6),
        },
        _ => Container::Plain,
    };
    let (file_name, bytes) = match container {
        Container::Plain => (input.name.to_string(), bytes),
        Container::Gzip => {
            done.push("gzip-compressed".into());
            (format!("{}.gz", input.name), gzip(&bytes))
        }
        Container::Zip { deflated, others } => {
            let mut members = vec![(format!("tiles/{}", input.name), bytes)];
            if others {
                // A valid tile before it, a README and a resource fork not read.
                members.insert(0, ("tiles/a-valid.gml".into(), companion_text.to_vec()));
                members.push(("README.txt".into(), b"tiles".to_vec()));
                members.push(("__MACOSX/tiles/._x.gml".into(), vec![0, 5, 22, 7]));
            }
            done.push(format!(
                "in a ZIP archive ({}{})",
                if deflated { "deflated" } else { "stored" },
                if others { ", after a valid tile" } else { "" }
            ));
            (
                format!("{}.zip", input.name),
                citylod_testdata::zip::zip(&members, deflated).bytes,
            )
        }
    };
    // The compressed bytes themselves cut short or changed now and then (a download cut short, a bad sector).
    let mut bytes = bytes;
    if container != Container::Plain && rng.chance(0.15) {
        let what = mutate_text(&mut bytes, &mut rng);
        done.push(format!("compressed: {what}"));
        exact = false;
    }
    Case {
        doc,
        exact,
        file_name,
        bytes,
        done,
    }
}

// ---------------------------------------------------------------------------------------------------------------
// What a case must give

/// What the document holds that the reader must account for, read from the tree as a namespace-aware parser reads
/// it (roxmltree, on the text written).
#[derive(Default, Debug)]
struct Expected {
    /// The Buildings that are a member's city objects: their gml:ids (`None`: none), each a feature.
    member_buildings: Vec<Option<String>>,
    /// Buildings, BuildingParts and thematic surfaces with geometry the reader does not reach as such (where a part
    /// should be, straight under the root, in a member it does not know, an unknown surface in boundedBy): each
    /// must be named in the report (its name or id), not lost without a word.
    unreached: Vec<Unreached>,
}

#[derive(Debug)]
struct Unreached {
    /// What kind of place it is in (`Building in <consistsOfBuildingPart>`), to count the failures by.
    pattern: String,
    /// Its line and parent.
    place: String,
    name: String,
    id: Option<String>,
    /// Inside a geometry the reader reads: an issue of the building it belongs to (its gml:id) says enough.
    owner: Option<Option<String>>,
    /// In a member's building, not in a geometry: the building it belongs to (its gml:id) skipped says enough — none
    /// of it is written, and the skip names it (a skip in a later stage, such as `transform_failed`, lists no
    /// repairs of the building, which would have named this).
    skipped_owner: Option<Option<String>>,
}

const MEMBERS: &[&str] = &[
    "cityObjectMember",
    "featureMember",
    "featureMembers",
    "member",
];
#[rustfmt::skip]
const THEMATIC: &[&str] = &[
    "RoofSurface", "WallSurface", "GroundSurface", "ClosureSurface", "OuterCeilingSurface", "OuterFloorSurface",
    "FloorSurface", "CeilingSurface", "InteriorWallSurface", "Window", "Door",
];

fn expected(text: &str) -> Option<Expected> {
    let doc = roxmltree::Document::parse_with_options(
        text,
        roxmltree::ParsingOptions {
            allow_dtd: false,
            ..Default::default()
        },
    )
    .ok()?;
    let gml_id = |n: roxmltree::Node| {
        n.attributes()
            .find(|a| {
                a.name() == "id"
                    && a.namespace()
                        .is_some_and(|ns| ns.contains("opengis.net/gml"))
            })
            .map(|a| a.value().to_string())
            // A blank gml:id names nothing: the reader names such a building as one without an id (FILE#INDEX, as
            // `a_building_with_an_empty_gml_id_is_still_named` asks), and a blank id would be "said" by any report.
            .filter(|v| !v.trim().is_empty())
    };
    let has_geometry = |n: roxmltree::Node| {
        n.descendants()
            .any(|d| matches!(d.tag_name().name(), "posList" | "pos" | "coordinates"))
    };
    let mut out = Expected::default();
    let root = doc.root_element();
    let el = |n: roxmltree::Node| n.is_element();
    let line = |n: roxmltree::Node| doc.text_pos_at(n.range().start).row;
    // The objects the reader reads: a member's Buildings and BuildingParts, and their parts (in a part property).
    let mut objects = Vec::new();
    for m in root.children().filter(|n| el(*n)) {
        let name = m.tag_name().name();
        if MEMBERS.contains(&name) {
            for o in m.children().filter(|n| el(*n)) {
                match o.tag_name().name() {
                    "Building" => {
                        out.member_buildings.push(gml_id(o));
                        objects.push(o);
                    }
                    "BuildingPart" => objects.push(o),
                    _ => {}
                }
            }
        } else {
            // Not a member: a building in it is not read.
            for d in m
                .descendants()
                .filter(|d| matches!(d.tag_name().name(), "Building" | "BuildingPart"))
            {
                if has_geometry(d) {
                    let inside = if d.parent() == Some(root) {
                        "straight under the root".to_string()
                    } else {
                        format!("in <{}> under the root", m.tag_name().name())
                    };
                    out.unreached.push(Unreached {
                        pattern: format!("{} {inside}", d.tag_name().name()),
                        place: format!("line {} in <{}>", line(d), m.tag_name().name()),
                        name: d.tag_name().name().to_string(),
                        id: gml_id(d),
                        owner: None,
                        skipped_owner: None,
                    });
                }
            }
        }
    }
    // (object, the member's Building it belongs to: its gml:id)
    let mut objects: Vec<(roxmltree::Node, Option<String>)> =
        objects.into_iter().map(|o| (o, gml_id(o))).collect();
    let mut k = 0;
    while k < objects.len() {
        let (o, owner) = objects[k].clone();
        k += 1;
        let mut geometries = Vec::new();
        for c in o.children().filter(|n| el(*n)) {
            let name = c.tag_name().name();
            match name {
                "consistsOfBuildingPart" | "buildingPart" => {
                    for p in c.children().filter(|n| el(*n)) {
                        if p.tag_name().name() == "BuildingPart" {
                            objects.push((p, owner.clone()));
                        } else if p.tag_name().name().contains("Building") && has_geometry(p) {
                            out.unreached.push(Unreached {
                                pattern: format!("{} in <{}>", p.tag_name().name(), name),
                                place: format!("line {} in <{}>", line(p), name),
                                name: p.tag_name().name().to_string(),
                                id: gml_id(p),
                                owner: None,
                                skipped_owner: Some(owner.clone()),
                            });
                        }
                    }
                }
                "boundedBy" | "boundary"
                    if !c
                        .tag_name()
                        .namespace()
                        .is_some_and(|ns| ns.contains("opengis.net/gml")) =>
                {
                    for s in c.children().filter(|n| el(*n)) {
                        if !THEMATIC.contains(&s.tag_name().name()) {
                            if has_geometry(s) {
                                out.unreached.push(Unreached {
                                    pattern: format!("a surface of an unknown type in <{name}>"),
                                    place: format!("line {} in <{}>", line(s), name),
                                    name: s.tag_name().name().to_string(),
                                    id: gml_id(s),
                                    owner: None,
                                    skipped_owner: Some(owner.clone()),
                                });
                            }
                            continue;
                        }
                        // The thematic surface's geometries, and its openings'.
                        let mut stack = vec![s];
                        while let Some(t) = stack.pop() {
                            for g in t.children().filter(|n| el(*n)) {
                                let gn = g.tag_name().name();
                                if is_geometry_property(gn) {
                                    geometries.push(g);
                                } else if gn == "opening" || gn == "filling" {
                                    stack.extend(g.children().filter(|n| el(*n)));
                                }
                            }
                        }
                    }
                }
                _ if is_geometry_property(name) => geometries.push(c),
                _ => {}
            }
        }
        // Inside geometries: an element with coordinates where the reader reads none.
        let mut stack = geometries;
        while let Some(g) = stack.pop() {
            for c in g.children().filter(|n| el(*n)) {
                let (pn, cn) = (g.tag_name().name(), c.tag_name().name());
                if let Some(allowed) = read_below(pn) {
                    if !allowed.contains(&cn) && has_geometry(c) {
                        out.unreached.push(Unreached {
                            pattern: format!("an element with coordinates not read in a <{pn}>"),
                            place: format!("line {} in <{pn}>", line(c)),
                            name: cn.to_string(),
                            id: gml_id(c),
                            owner: Some(owner.clone()),
                            skipped_owner: None,
                        });
                    }
                }
                stack.push(c);
            }
        }
    }
    Some(out)
}

/// A building's geometry property as the reader takes it: `lod0FootPrint`, `lod2Solid`, `lod1MultiSurface`, …
fn is_geometry_property(name: &str) -> bool {
    if matches!(name, "lod0FootPrint" | "lod0RoofEdge") {
        return true;
    }
    let Some(rest) = name.strip_prefix("lod") else {
        return false;
    };
    let mut c = rest.chars();
    matches!(c.next(), Some('0'..='4'))
        && matches!(
            c.as_str(),
            "Solid" | "MultiSolid" | "MultiSurface" | "CompositeSurface" | "Surface"
        )
}

/// The children a GML geometry element's content is read from (`None`: an element whose children are not
/// geometry's parts).
fn read_below(name: &str) -> Option<&'static [&'static str]> {
    Some(match name {
        "MultiSurface"
        | "CompositeSurface"
        | "Shell"
        | "Surface"
        | "TriangulatedSurface"
        | "Tin"
        | "PolyhedralSurface" => &[
            "surfaceMember",
            "baseSurface",
            "surfaceMembers",
            "patches",
            "trianglePatches",
            "polygonPatches",
        ],
        "Solid" => &["exterior", "interior"],
        "CompositeSolid" | "MultiSolid" => &["solidMember", "solidMembers"],
        "Polygon" | "Triangle" | "Rectangle" | "PolygonPatch" => {
            &["exterior", "interior", "outerBoundaryIs", "innerBoundaryIs"]
        }
        "LinearRing" | "LineString" | "LineStringSegment" => {
            &["posList", "pos", "pointProperty", "pointRep", "coordinates"]
        }
        "Ring" => &["curveMember"],
        _ => return None,
    })
}

/// A case not answered after this is a hang, and one that took a quarter of it a failure too (each input is a few
/// hundred kB at most: a case takes milliseconds).
const HANG: Duration = Duration::from_secs(40);

#[derive(Default)]
struct Tally {
    cases: usize,
    ingests: usize,
    errors: usize,
    with_buildings: usize,
    with_skips: usize,
    with_repairs: usize,
    with_models: usize,
    with_mesh_issues: usize,
    /// Cases whose checks on what was read applied (the text exactly the tree, in a consistent encoding).
    exact: usize,
    /// The longest a case took, and which.
    slowest: (Duration, String),
    /// Errors by their text with numbers left out, to read what they say.
    messages: BTreeMap<String, usize>,
    /// (kind, what): the kind to count them by.
    failures: Vec<(String, String)>,
}

/// Every Building that is a member's city object read as a feature (written, or skipped with its id), and every
/// building or surface the reader does not reach named in the report.
fn check_accounted(
    out: &Ingested,
    want: &Expected,
    file_name: &str,
    id_attr: bool,
) -> Result<(), (String, String)> {
    let r = &out.report;
    let ours: Vec<&citylod_ingest::FileReport> = r
        .files
        .iter()
        .filter(|f| f.path.ends_with(file_name) || f.path.contains(&format!("{file_name}/")))
        .collect();
    // In an archive, the case's own member (a valid tile may come before it).
    let ours: Vec<&citylod_ingest::FileReport> = if ours.len() > 1 {
        ours.into_iter()
            .filter(|f| !f.path.ends_with("a-valid.gml"))
            .collect()
    } else {
        ours
    };
    let Some(file) = ours.first() else {
        return Err((
            "no file report".into(),
            format!(
                "no file report for {file_name}: {:?}",
                r.files.iter().map(|f| &f.path).collect::<Vec<_>>()
            ),
        ));
    };
    if file.features_read < want.member_buildings.len() {
        return Err((
            "a member's Building lost".into(),
            format!(
                "{} Building(s) are members' city objects, {} feature(s) read from the file: a building lost \
                 without a word",
                want.member_buildings.len(),
                file.features_read
            ),
        ));
    }
    if !id_attr {
        let mut count: BTreeMap<&str, usize> = BTreeMap::new();
        for id in want.member_buildings.iter().flatten() {
            *count.entry(id.as_str()).or_default() += 1;
        }
        let path = &file.path;
        for (id, n) in count {
            let found = out.buildings.iter().filter(|b| b.source_id == id).count()
                + r.skipped
                    .iter()
                    .filter(|i| i.feature_id == id && i.file == *path)
                    .count();
            if found < n {
                return Err((
                    "a member's Building lost".into(),
                    format!(
                        "Building {id:?} ({n} in the file) is {found} times a building written or skipped: lost \
                         without a word"
                    ),
                ));
            }
        }
    }
    let said: String = file
        .notes
        .iter()
        .chain(
            r.skipped
                .iter()
                .chain(&r.repaired)
                .chain(&r.mesh_issues)
                .map(|i| &i.detail),
        )
        .fold(String::new(), |mut s, t| {
            s.push_str(t);
            s.push('\n');
            s
        });
    for u in &want.unreached {
        let named =
            said.contains(u.name.as_str()) || u.id.as_deref().is_some_and(|id| said.contains(id));
        // Inside a geometry read: any issue of its building says the geometry was not read whole.
        let owner_said = u.owner.as_ref().is_some_and(|owner| {
            r.skipped
                .iter()
                .chain(&r.repaired)
                .chain(&r.mesh_issues)
                // With --id-attr a building's feature id is its attribute's value, not its gml:id: the CityGML reader
                // names the object by its gml:id in the detail ("… of B1 not read: …").
                .any(|i| {
                    owner.as_deref().is_none_or(|o| {
                        i.feature_id == o || i.detail.contains(&format!(" of {o} "))
                    })
                })
        });
        let owner_skipped = u.skipped_owner.as_ref().is_some_and(|owner| {
            owner
                .as_deref()
                .is_some_and(|o| r.skipped.iter().any(|i| i.feature_id == o))
        });
        if !named && !owner_said && !owner_skipped {
            return Err((
                format!("silent loss: {}", u.pattern),
                format!(
                    "a {}{} with coordinates ({}) is not read, and nothing in the report says so",
                    u.name,
                    u.id.as_deref()
                        .map(|i| format!(" {i:?}"))
                        .unwrap_or_default(),
                    u.place
                ),
            ));
        }
    }
    Ok(())
}

/// The footprints and heights of what was read, and the skips: the same with and without an LoD.
fn same_without_lod(plain: &Ingested, lod: &Ingested) -> Result<(), String> {
    let key = |o: &Ingested| {
        o.buildings
            .iter()
            .map(|b| {
                (
                    b.source_id.clone(),
                    format!("{:?}", b.footprint),
                    b.base_z_m.to_bits(),
                    b.height_m.to_bits(),
                )
            })
            .collect::<Vec<_>>()
    };
    let (a, b) = (key(plain), key(lod));
    if a.len() != b.len() {
        let ids =
            |k: &[(String, String, u64, u64)]| k.iter().map(|x| x.0.clone()).collect::<Vec<_>>();
        return Err(format!(
            "{} buildings without an LoD, {} with one ({:?} / {:?}); skipped without: {:?}; with: {:?}",
            a.len(),
            b.len(),
            ids(&a),
            ids(&b),
            plain.report.skipped.iter().map(|i| format!("{} {}: {}", i.feature_id, i.reason.as_str(), i.detail)).collect::<Vec<_>>(),
            lod.report.skipped.iter().map(|i| format!("{} {}: {}", i.feature_id, i.reason.as_str(), i.detail)).collect::<Vec<_>>(),
        ));
    }
    for (x, y) in a.iter().zip(&b) {
        if x != y {
            let what = if x.0 != y.0 {
                "id"
            } else if x.1 != y.1 {
                "footprint"
            } else if x.2 != y.2 {
                "base"
            } else {
                "height"
            };
            return Err(format!(
                "building {:?}: its {what} differs with an LoD (base {} / {}, height {} / {})",
                x.0,
                f64::from_bits(x.2),
                f64::from_bits(y.2),
                f64::from_bits(x.3),
                f64::from_bits(y.3)
            ));
        }
    }
    Ok(())
}

/// An error must name the file (one of `paths`) or the option at fault.
fn bad_error(e: &IngestError, paths: &[PathBuf]) -> Option<String> {
    let text = e.to_string();
    let names_a_file = paths
        .iter()
        .any(|p| text.contains(&*p.file_name().unwrap().to_string_lossy()));
    let names_an_option =
        matches!(e, IngestError::InvalidOption { .. }) || text.starts_with("--crs: ");
    (!(names_a_file || names_an_option) || text.contains("panicked"))
        .then(|| format!("an error naming no file nor option: {text:?}"))
}

/// An error's text with its numbers and quoted names left out, to count the kinds.
fn message_kind(e: &IngestError) -> String {
    let t = e.to_string();
    let t = t
        .split_once(": ")
        .map_or(t.as_str(), |(_, r)| r)
        .to_string();
    let mut out = String::new();
    let mut in_quote = false;
    for c in t.chars() {
        if c == '"' {
            in_quote = !in_quote;
            out.push('"');
            continue;
        }
        if in_quote {
            continue;
        }
        if c.is_ascii_digit() {
            if !out.ends_with('#') {
                out.push('#');
            }
        } else {
            out.push(c);
        }
    }
    out.chars().take(150).collect()
}

// ---------------------------------------------------------------------------------------------------------------
// Running the cases

/// One line saying what a case gave: the error, or the counts and the reasons of skips and model issues.
fn outcome_line(got: &Outcome) -> String {
    match got {
        Outcome::Panicked(said) => format!("PANIC {said}"),
        Outcome::Failed(e) => format!("error: {e}"),
        Outcome::Read(out) => {
            let r = &out.report;
            let issues = |list: &[citylod_ingest::FeatureIssue]| {
                list.iter()
                    .map(|i| format!("{} {}: {}", i.feature_id, i.reason.as_str(), i.detail))
                    .collect::<Vec<_>>()
                    .join(" | ")
            };
            format!(
                "{} read, {} written, {} with a model; skipped: [{}]; repaired: [{}]; model issues: [{}]; notes: {:?}",
                r.features_read,
                r.buildings_written,
                r.buildings_with_mesh,
                issues(&r.skipped),
                issues(&r.repaired),
                issues(&r.mesh_issues),
                r.files.iter().flat_map(|f| &f.notes).collect::<Vec<_>>()
            )
        }
    }
}

fn options(rng: &mut SplitMix64) -> (Vec<(String, IngestOptions)>, bool) {
    let lod = *rng.pick(&["2", "1", "highest", "3", "4", "1.2", "2.2"]);
    let mut with_lod = IngestOptions {
        lod: Some(lod.parse::<LodChoice>().unwrap()),
        ..Default::default()
    };
    let mut plain = IngestOptions::default();
    let mut id_attr = false;
    if rng.chance(0.05) {
        let crs = rng.pick(CRS_NAMES).to_string();
        plain.crs = Some(crs.clone());
        with_lod.crs = Some(crs);
    }
    if rng.chance(0.05) {
        plain.id_attr = Some("name".into());
        with_lod.id_attr = Some("name".into());
        id_attr = true;
    }
    (
        vec![("no lod".into(), plain), (format!("lod {lod}"), with_lod)],
        id_attr,
    )
}

/// Runs `cases` mutated cases of `input` (or only the one `CITYGML_MUTATIONS_ONLY=<name>:<seed>` names).
fn run(input: &Input, cases: u64) -> Tally {
    // `Some(None)`: another input is asked for, so none of this one's cases run.
    let only: Option<Option<u64>> = std::env::var("CITYGML_MUTATIONS_ONLY").ok().map(|v| {
        let (name, seed) = v.split_once(':').unwrap_or((&v, ""));
        (name == input.name).then(|| seed.parse().expect("CITYGML_MUTATIONS_ONLY=<input>:<seed>"))
    });
    let dir = tempfile::tempdir().unwrap();
    let mut tally = Tally::default();

    // The valid input itself: buildings, and 3D models with an LoD; the tree written back is the same text.
    let valid = encode(
        &input.doc,
        if input.latin1 {
            Encoding::Latin1
        } else {
            Encoding::Utf8
        },
    );
    let path = dir.path().join(input.name);
    std::fs::write(&path, &valid).unwrap();
    for lod in [None, Some(LodChoice::Highest)] {
        let opts = IngestOptions {
            lod: lod.clone(),
            ..Default::default()
        };
        let out = ingest(std::slice::from_ref(&path), &opts)
            .unwrap_or_else(|e| panic!("{}: {e}", input.name));
        check(&out).unwrap_or_else(|e| panic!("{}: {e}", input.name));
        assert!(out.report.buildings_written > 0, "{}", input.name);
        if lod.is_some() {
            assert!(
                out.report.buildings_with_mesh > 0,
                "{}: {:?}",
                input.name,
                out.report.mesh_issues
            );
        }
        let want = expected(std::str::from_utf8(&encode(&input.doc, Encoding::Utf8)).unwrap())
            .expect("the valid input parses");
        check_accounted(&out, &want, input.name, false)
            .unwrap_or_else(|e| panic!("{}: {e:?}", input.name));
    }
    let companion_text = std::fs::read(fixture("delft-citygml2.xml")).unwrap();

    // Every case and what it gave: CITYGML_MUTATIONS_VERBOSE=1.
    let verbose = std::env::var("CITYGML_MUTATIONS_VERBOSE").is_ok();
    let seeds: Vec<u64> = match only {
        Some(Some(s)) => vec![s],
        Some(None) => Vec::new(),
        None => (0..cases).collect(),
    };
    'cases: for seed in seeds {
        let case = mutated(input, seed, &companion_text);
        let path = dir.path().join(&case.file_name);
        std::fs::write(&path, &case.bytes).unwrap();
        let mut rng = SplitMix64(seed ^ 0x5eed);
        let mut paths = vec![path.clone()];
        let with = if rng.chance(0.04) {
            paths.push(path.clone());
            " + itself"
        } else if rng.chance(0.06) {
            paths.insert(0, input.companion.clone());
            " after a valid file"
        } else {
            ""
        };
        // The checks on what was read, where the file is the tree as written.
        let want = if case.exact {
            expected(std::str::from_utf8(&encode(&case.doc, Encoding::Utf8)).unwrap())
        } else {
            None
        };
        tally.cases += 1;
        tally.exact += usize::from(want.is_some());
        let (opts, id_attr) = options(&mut rng);
        let mut read: Vec<Option<Box<Ingested>>> = Vec::new();
        let mut results: Vec<(String, Result<(), String>)> = Vec::new();
        for (label, opts) in opts {
            let name = format!(
                "{} seed {seed} ({label}{with}): {}",
                input.name,
                case.done.join("; ")
            );
            if only.is_some() {
                eprintln!("{name}");
                // The case's file, to look at: CITYGML_MUTATIONS_KEEP=<file> (with CITYGML_MUTATIONS_ONLY).
                if let Ok(keep) = std::env::var("CITYGML_MUTATIONS_KEEP") {
                    std::fs::write(keep, &case.bytes).unwrap();
                }
            }
            tally.ingests += 1;
            let started = Instant::now();
            let ps = paths.clone();
            let got = match guarded(HANG, only.is_none(), move || ingest(&ps, &opts)) {
                Ok(got) => got,
                Err(waited) => {
                    tally.failures.push((
                        "hang".into(),
                        format!("{name}: no answer after {waited:?} (a hang?)"),
                    ));
                    // Its thread still runs: no more cases of this input.
                    break 'cases;
                }
            };
            let took = started.elapsed();
            if took > tally.slowest.0 {
                tally.slowest = (took, name.clone());
            }
            if took > HANG / 4 {
                tally
                    .failures
                    .push(("slow".into(), format!("{name}: took {took:?}")));
            }
            if verbose || only.is_some() {
                eprintln!("{name}\n    -> {}", outcome_line(&got));
            }
            match got {
                Outcome::Panicked(said) => {
                    let at = said
                        .rsplit_once("(at ")
                        .map_or("?", |(_, a)| a.trim_end_matches(')'))
                        .to_string();
                    tally
                        .failures
                        .push((format!("panic at {at}"), format!("{name}: PANIC: {said}")));
                    read.push(None);
                    results.push((name, Err("panicked".into())));
                }
                Outcome::Failed(e) => {
                    tally.errors += 1;
                    *tally.messages.entry(message_kind(&e)).or_default() += 1;
                    if let Some(f) = bad_error(&e, &paths) {
                        tally
                            .failures
                            .push(("an error naming no file".into(), format!("{name}: {f}")));
                    }
                    read.push(None);
                    results.push((name, Err(e.to_string())));
                }
                Outcome::Read(out) => {
                    if let Err(e) = check(&out) {
                        let kind: String = e
                            .split_once(": ")
                            .filter(|(k, _)| {
                                !k.starts_with("an issue") && !k.starts_with("a building")
                            })
                            .map_or(e.as_str(), |(_, r)| r)
                            .chars()
                            .filter(|c| !c.is_ascii_digit())
                            .take(50)
                            .collect();
                        tally
                            .failures
                            .push((format!("invariant: {kind}"), format!("{name}: {e}")));
                    }
                    if let Some(want) = &want {
                        if let Err((kind, e)) =
                            check_accounted(&out, want, &case.file_name, id_attr)
                        {
                            tally.failures.push((kind, format!("{name}: {e}")));
                        }
                    }
                    let r = &out.report;
                    tally.with_buildings += usize::from(r.buildings_written > 0);
                    tally.with_skips += usize::from(!r.skipped.is_empty());
                    tally.with_repairs += usize::from(!r.repaired.is_empty());
                    tally.with_models += usize::from(r.buildings_with_mesh > 0);
                    tally.with_mesh_issues += usize::from(!r.mesh_issues.is_empty());
                    read.push(Some(out));
                    results.push((name, Ok(())));
                }
            }
        }
        // The same buildings with and without an LoD (an LoD adds models, nothing else), or the same refusal.
        if let [(plain_name, plain_res), (_, lod_res)] = &results[..] {
            match (&read[0], &read[1]) {
                (Some(a), Some(b)) => {
                    if let Err(e) = same_without_lod(a, b) {
                        tally.failures.push((
                            "not the same with an LoD".into(),
                            format!("{plain_name} vs with an LoD: {e}"),
                        ));
                    }
                }
                _ if plain_res.is_ok() != lod_res.is_ok() => tally.failures.push((
                    "read only with or only without an LoD".into(),
                    format!(
                        "{plain_name} vs with an LoD: read one way, not the other: {plain_res:?} / {lod_res:?}"
                    ),
                )),
                _ => {}
            }
        }
    }
    tally
}

/// Runs the inputs for `cases` cases each and asserts no failure and that each outcome was reached: on a thread
/// with a large stack, for this file's own recursion over deeply nested trees (each ingest runs on a thread of
/// the usual size, as the reader's own threads are).
fn run_all(inputs: Vec<Input>, cases: u64) {
    std::thread::Builder::new()
        .stack_size(512 << 20)
        .spawn(move || run_inputs(&inputs, cases))
        .unwrap()
        .join()
        .unwrap_or_else(|e| std::panic::resume_unwind(e));
}

fn run_inputs(inputs: &[Input], cases: u64) {
    let started = Instant::now();
    let mut total = Tally::default();
    // More cases for a longer hunt: CITYGML_MUTATIONS_CASES=20000.
    let cases = std::env::var("CITYGML_MUTATIONS_CASES")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(cases);
    for input in inputs {
        let t = run(input, cases);
        let counts = format!(
            "{} cases ({} checked against the tree), {} ingests: {} errors, {} with buildings, {} with skips, {} with \
             repairs, {} with models, {} with model issues; slowest {:?}: {}",
            t.cases,
            t.exact,
            t.ingests,
            t.errors,
            t.with_buildings,
            t.with_skips,
            t.with_repairs,
            t.with_models,
            t.with_mesh_issues,
            t.slowest.0,
            t.slowest.1.chars().take(300).collect::<String>()
        );
        eprintln!("{}: {counts}", input.name);
        // Each input reaches the reader's structure, not only the XML parser: some cases give buildings, some
        // skip features, some are refused, and (with an LoD) some give 3D models.
        if std::env::var("CITYGML_MUTATIONS_ONLY").is_err() && t.cases >= 30 {
            assert!(
                t.with_buildings > 0 && t.errors > 0 && t.with_skips > 0 && t.with_models > 0,
                "{}: {counts}",
                input.name
            );
        }
        total.cases += t.cases;
        total.ingests += t.ingests;
        total.errors += t.errors;
        total.with_buildings += t.with_buildings;
        total.with_skips += t.with_skips;
        total.with_repairs += t.with_repairs;
        total.with_models += t.with_models;
        total.with_mesh_issues += t.with_mesh_issues;
        total.exact += t.exact;
        for (k, n) in t.messages {
            *total.messages.entry(k).or_default() += n;
        }
        total.failures.extend(t.failures);
    }
    eprintln!(
        "{} cases, {} ingests in {:?}: {} errors, {} with buildings, {} with skips, {} with repairs, {} with models, \
         {} with model issues",
        total.cases,
        total.ingests,
        started.elapsed(),
        total.errors,
        total.with_buildings,
        total.with_skips,
        total.with_repairs,
        total.with_models,
        total.with_mesh_issues
    );
    if std::env::var("CITYGML_MUTATIONS_MESSAGES").is_ok() {
        for (k, n) in &total.messages {
            eprintln!("{n:6} × {k}");
        }
    }
    // Each kind of failure, how often, and its first case (the shortest of its first few, to read).
    let mut kinds: BTreeMap<&str, (usize, &str)> = BTreeMap::new();
    for (kind, what) in &total.failures {
        let e = kinds.entry(kind.as_str()).or_insert((0, what.as_str()));
        e.0 += 1;
        if e.0 <= 20 && what.len() < e.1.len() {
            e.1 = what.as_str();
        }
    }
    let summary: Vec<String> = kinds
        .iter()
        .map(|(k, (n, first))| {
            format!(
                "{n} × {k}\n    e.g. {}",
                first.chars().take(2000).collect::<String>()
            )
        })
        .collect();
    assert!(
        total.failures.is_empty(),
        "{} of {} ingests failed, by kind:\n{}",
        total.failures.len(),
        total.ingests,
        summary.join("\n")
    );
}

/// Cases per input by default: the whole file runs in a few seconds in a debug build.
const CASES: u64 = 120;

#[test]
fn mutated_zurich_citygml1_gives_an_error_or_buildings_never_a_panic() {
    run_all(vec![zurich()], CASES);
}

#[test]
fn mutated_delft_citygml2_gives_an_error_or_buildings_never_a_panic() {
    run_all(vec![delft()], CASES);
}

#[test]
fn mutated_sig3d_citygml2_gives_an_error_or_buildings_never_a_panic() {
    run_all(vec![sig3d()], CASES);
}

#[test]
fn mutated_citygml3_gives_an_error_or_buildings_never_a_panic() {
    run_all(vec![citygml3()], CASES);
}

#[test]
fn mutated_wfs_answer_gives_an_error_or_buildings_never_a_panic() {
    run_all(vec![wfs()], CASES);
}

#[test]
fn the_tree_writes_back_the_text_it_read() {
    for input in [zurich(), delft(), sig3d(), citygml3(), wfs()] {
        let text = String::from_utf8(encode(&input.doc, Encoding::Utf8)).unwrap();
        let again = parse(&text);
        let mut a = String::new();
        write_elem(&again.root, &mut a);
        let mut b = String::new();
        write_elem(&input.doc.root, &mut b);
        assert_eq!(a, b, "{}", input.name);
        // The fixtures' own text, whitespace and all (empty elements are written `<x/>` as they are there).
        if input.name.ends_with("citygml1.xml") || input.name.ends_with("citygml2.xml") {
            let original = read_fixture(input.name);
            let original = original.trim_start_matches('\u{feff}');
            let written: String = text.split_whitespace().collect();
            let read: String = original.split_whitespace().collect();
            assert_eq!(written.len(), read.len(), "{}", input.name);
        }
    }
}

#[test]
fn a_panic_or_a_hang_in_a_case_is_caught_and_said() {
    let got = guarded(HANG, true, || {
        use rayon::prelude::*;
        (0..64u32)
            .into_par_iter()
            .for_each(|i| assert!(i != 37, "boom at {i}"));
        unreachable!()
    });
    match got {
        Ok(Outcome::Panicked(said)) => assert!(
            said.contains("boom at 37") && said.contains("citygml_mutations.rs"),
            "{said}"
        ),
        _ => panic!("the panic was not caught"),
    }
    let got = guarded(HANG, true, || ingest(&[], &IngestOptions::default()));
    assert!(matches!(got, Ok(Outcome::Read(_))));
}

// ---------------------------------------------------------------------------------------------------------------
// What the mutations found, each as a small file of its own

/// A CityGML 2.0 model in RD New (EPSG:28992) of `members`.
fn small_model(members: &str) -> String {
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<CityModel xmlns=\"http://www.opengis.net/citygml/2.0\" \
         xmlns:bldg=\"http://www.opengis.net/citygml/building/2.0\" xmlns:gml=\"http://www.opengis.net/gml\" \
         xmlns:xlink=\"http://www.w3.org/1999/xlink\">\n<gml:boundedBy><gml:Envelope srsName=\"EPSG:28992\">\
         <gml:lowerCorner>85000 446000 0</gml:lowerCorner><gml:upperCorner>85100 446100 10</gml:upperCorner>\
         </gml:Envelope></gml:boundedBy>\n{members}\n</CityModel>\n"
    )
}

/// A box `side` m wide and 6 m high at (85000 + x, 446000) as a Building's (or part's) lod1Solid.
fn lod1_box(x: f64, side: f64) -> String {
    format!(
        "<bldg:lod1Solid><gml:Solid><gml:exterior><gml:CompositeSurface>{}</gml:CompositeSurface></gml:exterior>\
         </gml:Solid></bldg:lod1Solid>",
        box_members(85_000.0 + x, 446_000.0, 0.0, side, 6.0)
    )
}

/// A 10 m × 10 m LoD 0 footprint at (85000, 446000) whose posList is `pos_list`, 9 m high.
fn footprint_member(pos_list: &str) -> String {
    format!(
        "<cityObjectMember><bldg:Building gml:id=\"F\"><bldg:measuredHeight uom=\"m\">9</bldg:measuredHeight>\
         <bldg:lod0FootPrint><gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing>\
         <gml:posList>{pos_list}</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember>\
         </gml:MultiSurface></bldg:lod0FootPrint></bldg:Building></cityObjectMember>"
    )
}

fn ingest_text(name: &str, text: &[u8], opts: &IngestOptions) -> Result<Ingested, IngestError> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, text).unwrap();
    let opts = opts.clone();
    match guarded(HANG, false, move || ingest(&[p], &opts)) {
        Ok(Outcome::Read(out)) => Ok(*out),
        Ok(Outcome::Failed(e)) => Err(e),
        Ok(Outcome::Panicked(said)) => panic!("{name}: PANIC {said}"),
        Err(waited) => panic!("{name}: no answer after {waited:?}"),
    }
}

/// Everything the report says of a read: notes, skips, repairs and model issues.
fn said(out: &Ingested) -> String {
    let r = &out.report;
    let mut t: Vec<String> = r.files.iter().flat_map(|f| f.notes.clone()).collect();
    for i in r.skipped.iter().chain(&r.repaired).chain(&r.mesh_issues) {
        t.push(format!(
            "{} {}: {}",
            i.feature_id,
            i.reason.as_str(),
            i.detail
        ));
    }
    t.join("\n")
}

/// Found by the mutations (`delft-citygml2.xml` seed 88, kind `silent loss: Building in <consistsOfBuildingPart>`): a
/// Building where a
/// BuildingPart belongs (in `consistsOfBuildingPart`) is not read and nothing says so — its geometry is gone from the
/// building's footprint and model. citygml.rs `Converter::object` takes only the `BuildingPart` children of a part
/// property. It must be read (as a part, or a building of its own) or named in the report.
#[test]
fn a_building_where_a_part_belongs_is_read_or_named() {
    let text = small_model(&format!(
        "<cityObjectMember><bldg:Building gml:id=\"A\">{}<bldg:consistsOfBuildingPart><bldg:Building \
         gml:id=\"A-annex\">{}</bldg:Building></bldg:consistsOfBuildingPart></bldg:Building></cityObjectMember>",
        lod1_box(0.0, 8.0),
        lod1_box(20.0, 5.0)
    ));
    let out = ingest_text(
        "part-building.gml",
        text.as_bytes(),
        &IngestOptions::default(),
    )
    .unwrap();
    let area: f64 = out.buildings.iter().map(|b| b.area_m2()).sum();
    let t = said(&out);
    assert!(
        area > 64.0 + 24.0 || t.contains("A-annex"),
        "the annex is lost without a word: {area} m² written; the report says: {t:?}"
    );
}

/// Found by the mutations (`zurich-lod2-citygml1.xml` seed 84 and `model-3.0.gml` seed 21: straight under the root;
/// `sig3d-genericattributes.gml` seeds 51 and 83, `model-3.0.gml` seed 33: in a renamed member): a Building that is not in a `cityObjectMember` (straight under the CityModel, or in an element the
/// reader does not know, such as a misspelt member) is not read and nothing says so. citygml.rs `read_stream` reads
/// only the depth-1 elements named `cityObjectMember`, `featureMember(s)`, `member` and ignores the others whole.
#[test]
fn a_building_outside_a_city_object_member_is_read_or_named() {
    let bare = format!(
        "<bldg:Building gml:id=\"R\">{}</bldg:Building>",
        lod1_box(0.0, 8.0)
    );
    let kept = format!(
        "<cityObjectMember><bldg:Building gml:id=\"S\">{}</bldg:Building></cityObjectMember>",
        lod1_box(20.0, 8.0)
    );
    for (name, members) in [
        ("under-the-root.gml", format!("{kept}{bare}")),
        (
            "unknown-member.gml",
            format!("{kept}<cityObjectMembers>{bare}</cityObjectMembers>"),
        ),
    ] {
        let out = ingest_text(
            name,
            small_model(&members).as_bytes(),
            &IngestOptions::default(),
        )
        .unwrap();
        let t = said(&out);
        assert!(
            out.report.features_read == 2
                || t.contains("\"R\"")
                || t.contains(" R ")
                || t.contains("Building"),
            "{name}: building R lost without a word: {} read; the report says: {t:?}",
            out.report.features_read
        );
    }
}

/// Found by the mutations (`model-3.0.gml` seed 440: a `con:WallSurface` renamed; kind `silent loss: a surface of an
/// unknown type in <boundary>`): a boundary surface whose type the
/// reader does not know (here 3.0's `con:WindowSurface`; an ADE's, a misspelt one) is dropped with its geometry and
/// nothing says so. citygml.rs `Converter::thematic` returns without a word for a name not in `THEMATIC`.
#[test]
fn a_boundary_surface_of_a_type_not_known_is_named() {
    let surface = |kind: &str, z: f64| {
        format!(
            "<bldg:boundedBy><bldg:{kind}><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember><gml:Polygon>\
             <gml:exterior><gml:LinearRing><gml:posList>85000 446000 {z} 85010 446000 {z} 85010 446010 {z} 85000 \
             446010 {z} 85000 446000 {z}</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>\
             </gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:{kind}></bldg:boundedBy>"
        )
    };
    let text = small_model(&format!(
        "<cityObjectMember><bldg:Building gml:id=\"T\">{}{}{}</bldg:Building></cityObjectMember>",
        surface("GroundSurface", 0.0),
        surface("RoofSurface", 6.0),
        surface("WindowSurface", 3.0)
    ));
    let opts = IngestOptions {
        lod: Some(LodChoice::Highest),
        ..Default::default()
    };
    let out = ingest_text("window.gml", text.as_bytes(), &opts).unwrap();
    let t = said(&out);
    assert!(
        t.contains("WindowSurface"),
        "a WindowSurface dropped without a word; the report says: {t:?}"
    );
}

/// Found by the mutations (the kind `an element with coordinates not read in a <…>`, in every input: e.g.
/// `delft-citygml2.xml` seeds 13 and 94, `zurich-lod2-citygml1.xml` seed 50, `wfs-answer.xml` seed 15): an element a
/// GML geometry holds that the reader does not read there is dropped with its coordinates and nothing says so —
/// polygons straight in a CompositeSurface (no surfaceMember), GML 2's `gml:coord` points in a LinearRing, a
/// Polygon given as a Shell. citygml.rs `Converter::surfaces`, `polygon`, `solid` and `points` skip children they
/// do not know (`_ => {}`).
#[test]
fn geometry_the_reader_does_not_know_is_not_dropped_without_a_word() {
    let poly = |x: f64| {
        format!(
            "<gml:Polygon><gml:exterior><gml:LinearRing><gml:posList>{x} 446000 0 {x2} 446000 0 {x2} 446010 0 {x} \
             446010 0 {x} 446000 0</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>",
            x2 = x + 10.0
        )
    };
    let cases = [
        (
            "no-surface-member.gml",
            format!(
                "<bldg:lod0FootPrint><gml:CompositeSurface><gml:surfaceMember>{}</gml:surfaceMember>{}\
                 </gml:CompositeSurface></bldg:lod0FootPrint>",
                poly(85_000.0),
                poly(85_020.0)
            ),
        ),
        (
            "coord.gml",
            format!(
                "<bldg:lod0FootPrint><gml:MultiSurface><gml:surfaceMember>{}</gml:surfaceMember><gml:surfaceMember>\
                 <gml:Polygon><gml:exterior><gml:LinearRing>{}</gml:LinearRing></gml:exterior></gml:Polygon>\
                 </gml:surfaceMember></gml:MultiSurface></bldg:lod0FootPrint>",
                poly(85_000.0),
                [(85020, 446000), (85030, 446000), (85030, 446010), (85020, 446010), (85020, 446000)]
                    .iter()
                    .map(|(x, y)| format!("<gml:coord><gml:X>{x}</gml:X><gml:Y>{y}</gml:Y><gml:Z>0</gml:Z></gml:coord>"))
                    .collect::<String>()
            ),
        ),
        (
            "shell.gml",
            format!(
                "<bldg:lod0FootPrint><gml:MultiSurface><gml:surfaceMember>{}</gml:surfaceMember><gml:surfaceMember>\
                 {}</gml:surfaceMember></gml:MultiSurface></bldg:lod0FootPrint>",
                poly(85_000.0),
                poly(85_020.0).replace("gml:Polygon", "gml:Shell")
            ),
        ),
    ];
    let mut lost = Vec::new();
    for (name, geometry) in cases {
        let text = small_model(&format!(
            "<cityObjectMember><bldg:Building gml:id=\"G\"><bldg:measuredHeight uom=\"m\">9</bldg:measuredHeight>\
             {geometry}</bldg:Building></cityObjectMember>"
        ));
        let out = ingest_text(name, text.as_bytes(), &IngestOptions::default()).unwrap();
        let area: f64 = out.buildings.iter().map(|b| b.area_m2()).sum();
        let r = &out.report;
        if area < 150.0 && r.skipped.is_empty() && r.repaired.is_empty() {
            lost.push(format!(
                "{name}: {area:.1} m² of 200 written, nothing said: {:?}",
                said(&out)
            ));
        }
    }
    assert!(lost.is_empty(), "{}", lost.join("\n"));
}

/// Found by probing what the mutation `a comment inside` does to a posList (the fuzzer's checks cannot see a ring cut
/// short): a comment (or processing instruction) between
/// the numbers of a posList cuts the ring there without a word — roxmltree's `Node::text` is the first text node
/// only (citygml.rs `Converter::points` and `point`, `numbers(c.text()…)`). Cut between points, a 10 m × 10 m
/// footprint became a triangle of half its area; cut inside a point, the error says "a posList of 10 numbers" of one
/// that has 15.
#[test]
fn a_comment_inside_a_pos_list_does_not_cut_the_ring() {
    let whole = "85000 446000 0 85010 446000 0 85010 446010 0 85000 446010 0 85000 446000 0";
    let between = "85000 446000 0 85010 446000 0 85010 446010 0 <!-- checked --> 85000 446010 0 85000 446000 0";
    let inside = "85000 446000 0 85010 446000 0 85010 446010 0 85000 <!-- checked --> 446010 0 85000 446000 0";
    // The area written, and the issues reported (skips and repairs).
    let area = |pl: &str| {
        let out = ingest_text(
            "comment.gml",
            small_model(&footprint_member(pl)).as_bytes(),
            &IngestOptions::default(),
        )
        .unwrap();
        let r = &out.report;
        let issues: Vec<String> = r
            .skipped
            .iter()
            .chain(&r.repaired)
            .map(|i| i.detail.clone())
            .collect();
        (
            out.buildings.iter().map(|b| b.area_m2()).sum::<f64>(),
            issues.join("\n"),
        )
    };
    let (want, _) = area(whole);
    assert!((want - 100.0).abs() < 0.1, "{want}");
    let (got, t) = area(between);
    assert!(
        (got - want).abs() < 0.01 || !t.is_empty(),
        "a comment between points: {got} m², not {want}, and nothing said"
    );
    let (got, t) = area(inside);
    assert!(
        (got - want).abs() < 0.01 || !t.contains("a posList of 10 numbers"),
        "a comment inside a point: {got} m² and {t:?}"
    );
}

/// Found by probing what the measuredHeight mutations (`uom` `#km`, `furlong`, `m2`) give: a measuredHeight in a unit the reader
/// does not know is taken as metres without a word (0.5 km became 0.5 m, 3 furlong 3 m). citygml.rs `attribute` keeps
/// the text when `metres_per` does not know the unit ("a unit not known keeps the text"), and height.rs `length_m`
/// reads a text that is a number as metres. It must be converted, or rejected and reported.
#[test]
fn a_measured_height_in_a_unit_not_known_is_not_taken_as_metres() {
    let mut wrong = Vec::new();
    for (uom, value) in [("#km", "0.02"), ("furlong", "3"), ("m2", "20")] {
        let text = small_model(&format!(
            "<cityObjectMember><bldg:Building gml:id=\"U\"><bldg:measuredHeight uom=\"{uom}\">{value}\
             </bldg:measuredHeight>{}</bldg:Building></cityObjectMember>",
            lod1_box(0.0, 8.0)
        ));
        let out = ingest_text("uom.gml", text.as_bytes(), &IngestOptions::default()).unwrap();
        let b = &out.buildings[0];
        let v: f64 = value.parse().unwrap();
        if (b.height_m - v).abs() < 1e-9 && !said(&out).contains("measuredHeight") {
            wrong.push(format!(
                "{value} {uom} read as {} m, nothing said",
                b.height_m
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// Found by the mutations (`an lod3MultiSurface of 2^N references`; the slowest case of every input is one, the time
/// doubling with N): `xlink:href`s are followed every time they are
/// met, so a chain of N MultiSurfaces each referring twice to the one before gives 2^N polygons — a "billion laughs"
/// of GML (the reader refuses a DOCTYPE for its entities, and does not bound references). 16 MultiSurfaces in a
/// 3 kB file give a model of 131,072 triangles (a quarter of a second in a debug build, doubling with each further
/// element: 30 would be 2^30 polygons, hours and hundreds of GB). citygml.rs `Converter::target` / `surfaces`. A
/// building whose references expand past a bound must be skipped or have that geometry left out, saying why.
#[test]
fn references_do_not_multiply_a_few_elements_into_millions_of_polygons() {
    let depth = 16;
    let mut defs = String::new();
    let mut prev = "P0".to_string();
    for k in 1..=depth {
        defs.push_str(&format!(
            "<gml:MultiSurface gml:id=\"c{k}\"><gml:surfaceMember xlink:href=\"#{prev}\"/><gml:surfaceMember \
             xlink:href=\"#{prev}\"/></gml:MultiSurface>"
        ));
        prev = format!("c{k}");
    }
    let text = small_model(&format!(
        "<cityObjectMember><bldg:Building gml:id=\"X\"><bldg:lod0FootPrint><gml:MultiSurface><gml:surfaceMember>\
         <gml:Polygon gml:id=\"P0\"><gml:exterior><gml:LinearRing><gml:posList>85000 446000 0 85010 446000 0 85010 \
         446010 0 85000 446010 0 85000 446000 0</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>\
         </gml:surfaceMember></gml:MultiSurface></bldg:lod0FootPrint><bldg:definitions>{defs}</bldg:definitions>\
         <bldg:lod2MultiSurface xlink:href=\"#{prev}\"/></bldg:Building></cityObjectMember>"
    ));
    assert!(text.len() < 4000);
    let opts = IngestOptions {
        lod: Some(LodChoice::Highest),
        ..Default::default()
    };
    let out = ingest_text("chain.gml", text.as_bytes(), &opts).unwrap();
    let triangles: usize = out
        .buildings
        .iter()
        .filter_map(|b| b.mesh.as_ref())
        .map(|m| m.mesh.triangles.len())
        .sum();
    let t = said(&out);
    assert!(
        triangles <= 10_000 || t.contains("xlink") || t.contains("reference"),
        "{} bytes of CityGML gave a model of {triangles} triangles, and nothing said",
        text.len()
    );
}

/// Found by the encodings the mutations declare: a file whose declaration names an encoding its bytes are not in
/// is refused with a reason that points elsewhere. "UTF-16" declared in an ASCII text (decoded as UTF-16LE into
/// other characters, citygml.rs `decode`) gives "no XML element in the file"; ISO-8859-1 bytes in a file declared
/// UTF-8 (read as a stream) give "not well-formed XML at line 3: … invalid utf-8 sequence of 1 bytes from index 1",
/// where the in-memory path says "not UTF-8 text: byte N (line L) is 0xFC …" (citygml.rs `read_stream`).
#[test]
fn an_encoding_declared_wrongly_is_said_so() {
    let text = small_model(&format!(
        "<cityObjectMember><bldg:Building gml:id=\"E\"><gml:name>Müller</gml:name>{}</bldg:Building></cityObjectMember>",
        lod1_box(0.0, 8.0)
    ));
    let mut bad = Vec::new();
    let utf16 = text.replacen("UTF-8", "UTF-16", 1);
    match ingest_text("utf16.gml", utf16.as_bytes(), &IngestOptions::default()) {
        Err(e) if e.to_string().contains("UTF-16") => {}
        other => bad.push(format!(
            "UTF-16 declared, ASCII written: {:?}",
            other.map(|o| said(&o))
        )),
    }
    let (latin1, _, _) = encoding_rs::WINDOWS_1252.encode(&text);
    match ingest_text("latin1.gml", &latin1, &IngestOptions::default()) {
        Err(e)
            if e.to_string().contains("UTF-8")
                && !e.to_string().contains("not well-formed XML") => {}
        other => bad.push(format!(
            "UTF-8 declared, ISO-8859-1 written: {:?}",
            other.map(|o| said(&o))
        )),
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Found by the mutations (`model-3.0.gml` seed 41: a prefix no one declares): a member that does not parse on its
/// own is refused as "the member at line 8 is not well-formed XML: an unknown namespace prefix 'zz' at 10:90" — 10:90
/// is the row and column within the member (its first row behind the wrapper citylod puts around it, with the
/// root's namespace declarations), not the file's line 17 (citygml.rs `read_member`). The error must
/// place the problem by the file's line.
#[test]
fn a_member_that_does_not_parse_is_placed_by_the_files_line() {
    // The member begins on line 4; the unknown prefix is on its fourth line, the file's line 7.
    let text = small_model(&format!(
        "<cityObjectMember>\n<bldg:Building gml:id=\"Z\">\n{}\n<zz:note>x</zz:note>\n</bldg:Building>\n</cityObjectMember>",
        lod1_box(0.0, 8.0)
    ));
    let line_of_zz = text.lines().position(|l| l.contains("<zz:note>")).unwrap() + 1;
    assert_eq!(line_of_zz, 7);
    let Err(e) = ingest_text("prefix.gml", text.as_bytes(), &IngestOptions::default()) else {
        panic!("read, not refused");
    };
    let t = e.to_string();
    assert!(t.contains("'zz'"), "{t}");
    assert!(
        t.contains("line 7") && !t.contains(" at 4:"),
        "the error does not place the problem at the file's line 7: {t}"
    );
}

/// Found by the mutations (`wfs-answer.xml` seed 115: a Building's `gml:id=""`): the building's id is the empty
/// text, so its skip reads "lod1Solid (line 13) of  not read: …" with no feature id. citygml.rs `read_member` takes
/// any gml:id, empty or blank, where it falls back to `FILE#INDEX` for none.
#[test]
fn a_building_with_an_empty_gml_id_is_still_named() {
    for id in ["", " "] {
        let text = small_model(&format!(
            "<cityObjectMember><bldg:Building gml:id=\"{id}\"><bldg:lod1Solid><gml:Solid><gml:exterior>\
             <gml:CompositeSurface><gml:surfaceMember><gml:Polygon><gml:exterior/></gml:Polygon></gml:surfaceMember>\
             </gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod1Solid></bldg:Building></cityObjectMember>\
             <cityObjectMember><bldg:Building gml:id=\"{id}\">{}</bldg:Building></cityObjectMember>",
            lod1_box(20.0, 8.0)
        ));
        let out = ingest_text("empty-id.gml", text.as_bytes(), &IngestOptions::default()).unwrap();
        let r = &out.report;
        assert_eq!(r.features_read, 2);
        let ids: Vec<&str> = r
            .skipped
            .iter()
            .map(|i| i.feature_id.as_str())
            .chain(out.buildings.iter().map(|b| b.source_id.as_str()))
            .collect();
        assert!(
            ids.iter().all(|i| !i.trim().is_empty()),
            "gml:id {id:?}: features named {ids:?}; skipped: {:?}",
            r.skipped
        );
    }
}

/// A building whose only geometry is implicit (`lod2ImplicitRepresentation`, which the reader does not read) is
/// skipped as "no_geometry: the building and its parts have no geometry", which it has: the skip should say that
/// its implicit geometry is not read (the file's note lists the element, the building's skip does not).
#[test]
fn a_building_of_implicit_geometry_only_is_skipped_saying_so() {
    let text = small_model(
        "<cityObjectMember><bldg:Building gml:id=\"I\"><bldg:lod2ImplicitRepresentation><ImplicitGeometry>\
         <transformationMatrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</transformationMatrix><relativeGMLGeometry>\
         <gml:MultiSurface><gml:surfaceMember><gml:Polygon><gml:exterior><gml:LinearRing><gml:posList>0 0 0 5 0 0 5 5 \
         0 0 5 0 0 0 0</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember>\
         </gml:MultiSurface></relativeGMLGeometry><referencePoint><gml:Point><gml:pos>85000 446000 0</gml:pos>\
         </gml:Point></referencePoint></ImplicitGeometry></bldg:lod2ImplicitRepresentation></bldg:Building>\
         </cityObjectMember>",
    );
    let out = ingest_text("implicit.gml", text.as_bytes(), &IngestOptions::default()).unwrap();
    let r = &out.report;
    assert_eq!((r.features_read, r.skipped.len()), (1, 1), "{r:?}");
    let d = &r.skipped[0].detail;
    assert!(d.contains("Implicit"), "the skip says: {d:?}");
}

/// A CityGML file truly in UTF-16 (a byte-order mark, as Windows tools write it) is refused as "named as CityGML,
/// but it does not read as XML": it should be read, or refused saying it is UTF-16 (as the JSON readers do).
#[test]
fn a_citygml_file_in_utf16_is_read_or_refused_saying_so() {
    let text = small_model(&format!(
        "<cityObjectMember><bldg:Building gml:id=\"W\">{}</bldg:Building></cityObjectMember>",
        lod1_box(0.0, 8.0)
    ))
    .replacen("UTF-8", "UTF-16", 1);
    let mut bytes = vec![0xFF, 0xFE];
    for u in text.encode_utf16() {
        bytes.extend(u.to_le_bytes());
    }
    match ingest_text("utf16le.gml", &bytes, &IngestOptions::default()) {
        Ok(out) => assert_eq!(out.report.buildings_written, 1),
        Err(e) => assert!(e.to_string().contains("UTF-16"), "{e}"),
    }
}
