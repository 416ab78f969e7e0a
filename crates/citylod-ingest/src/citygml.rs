//! CityGML 1.0, 2.0 and 3.0 reader (`.gml`, `.citygml`, `.xml`, also gzip-compressed): the city model's
//! Buildings with their BuildingParts, their attributes and their geometry, handed to the CityJSON reader's
//! building rules ([`crate::cityjson`]) so that both formats give a building the same footprint, heights and 3D
//! model.
//!
//! The file is scanned once as a stream of XML events ([`quick_xml`]) to find the top-level members
//! (`cityObjectMember`; a WFS FeatureCollection's `member` and `featureMember`); each member's text is then fetched by its position and read as a small tree
//! of its own (`roxmltree`), a batch of members at a time in parallel, so a file of any size costs one batch of text
//! besides its buildings (a gzip-compressed file, a ZIP member or a file in another encoding than UTF-8 is held
//! whole, inflated or decoded). A member's geometry becomes a CityJSON city object:
//! - `lod0FootPrint` (a `GroundSurface` at LoD 0), `lod0RoofEdge` (a `RoofSurface`, never the footprint), 3.0's
//!   `lod0MultiSurface`;
//! - `lodNSolid`, `lodNMultiSurface`, `lodNCompositeSurface` (N = 1–4) and the thematic surfaces of `boundedBy`
//!   (1.0, 2.0) or `boundary` (3.0) — RoofSurface, WallSurface, GroundSurface, …, with their openings — whose
//!   `lodNMultiSurface` give each polygon its semantic type. A solid's polygons are often `xlink:href`s to those
//!   of the thematic surfaces: they take their types. One geometry per LoD: the solid when there is one, else the
//!   multi-surface and the thematic surfaces together;
//! - GML's Polygon, Triangle, Rectangle, OrientableSurface (a `-` orientation turns its rings), CompositeSurface,
//!   MultiSurface, Surface patches, TriangulatedSurface and Tin, Solid, CompositeSolid and MultiSolid, with
//!   coordinates as `posList`, `pos` or GML 2's `coordinates`, in the `srsDimension` they declare (3 by default).
//!
//! Attributes: `gml:name` and `gml:description`, every simple element of the building (`class`, `function`,
//! `measuredHeight` converted to metres from its `uom` (a number in a unit not known is kept with its unit,
//! `3 furlong`, which the height rules name and do not take as metres), `storeysAboveGround`, `yearOfConstruction`,
//! ADE elements with a text value …), generic attributes (1.0/2.0 `gen:stringAttribute` … and sets as `SET.NAME`;
//! 3.0 `gen:genericAttribute`), external references as `externalReference:SYSTEM`, the first address's fields as
//! `address.FIELD`. The CRS is the `srsName` of the model's envelope, else of the first member that names one; the
//! usual spellings (EPSG codes and URNs, compound URNs, the German AdV's `urn:adv:crs:…`, Switzerland's CH1903 and
//! CH1903+) are read.
//! A geometry that cannot be read (an `xlink:href` to nothing in its member, an odd coordinate count, a GML type not
//! above) is left out and listed as `geometry_not_read` with its element's line; so is an element inside a geometry
//! where GML has none (a Polygon straight in a CompositeSurface, an exterior in a Tin), a boundary surface of a type
//! not known (3.0's WindowSurface, an ADE's), and geometry past the building's budget of points and references
//! followed (4 for each byte of its member: references to elements holding references multiply). A building with
//! nothing left is skipped as `malformed_geometry`, one with only implicit geometry as `unsupported_geometry`.
//! Coordinates are an element's whole text (a comment may split it); GML 2's `coord` is read too. A Building straight
//! under the CityModel is read as a member, one where a BuildingPart belongs as a part, and buildings in another
//! element under the model (a misspelt member) are named in the file's notes. UTF-16 files (a byte-order mark, or
//! `<?` in two bytes) are read.

use crate::cityjson::{self, CityDoc};
use crate::crs::{Crs, DeclaredCrs};
use crate::lod::Target;
use crate::report::IssueReason;
use quick_xml::events::Event;
use rayon::prelude::*;
use roxmltree::Node;
use serde_json::{json, Map, Value};
use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

/// Text read at most (after decompression): 8 GiB.
const MAX_TEXT: u64 = 8 << 30;
/// CityGML nests some twenty elements deep; a member is read as a tree, so deeper nesting is refused first.
const MAX_DEPTH: usize = 256;
/// `xlink:href`s followed in a row at most (a reference to a reference …; a cycle ends here).
const MAX_HOPS: usize = 16;

/// A CityGML file's buildings, as a CityJSON document's, and what concerns the file as a whole.
pub(crate) struct GmlDoc {
    pub doc: CityDoc,
    pub notes: Vec<String>,
}

/// The members of a ZIP archive that may be CityGML files (`.gml`, `.xml`, `.citygml`, gzip-compressed too), in
/// name order, when the archive holds no File Geodatabase; macOS's resource forks left out.
fn zip_members(archive: &crate::zip::Archive) -> Vec<&crate::zip::Member> {
    let lower = |m: &crate::zip::Member| m.name.to_ascii_lowercase();
    if archive
        .members
        .iter()
        .any(|m| lower(m).ends_with(".gdbtable"))
    {
        return Vec::new();
    }
    let mut out: Vec<&crate::zip::Member> = archive
        .members
        .iter()
        .filter(|m| {
            let n = lower(m);
            let n = n.strip_suffix(".gz").unwrap_or(&n);
            !n.starts_with("__macosx/")
                && !n.rsplit('/').next().unwrap_or("").starts_with("._")
                && [".gml", ".xml", ".citygml"].iter().any(|e| n.ends_with(e))
        })
        .collect();
    out.sort_by(|a, b| a.name.cmp(&b.name));
    out
}

/// A ZIP archive: named `.zip`, or starting with a ZIP member's signature whatever its name.
pub(crate) fn is_zip(path: &Path) -> bool {
    path.is_file()
        && (path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("zip"))
            || crate::zip::begins_as_zip(path))
}

/// A file whose first element (within its first 64 KiB, inflated when gzip-compressed) is a `CityModel`; or a ZIP
/// archive whose first `.gml`/`.xml` member is such a file (as city models are downloaded, tiles in one archive).
pub(crate) fn is_citygml(path: &Path) -> bool {
    if is_zip(path) {
        let Ok(archive) = crate::zip::Archive::open(path) else {
            return false;
        };
        return zip_members(&archive)
            .first()
            .is_some_and(|m| archive.read(m, Some(64 * 1024)).is_ok_and(starts_citygml));
    }
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    let mut raw = Vec::new();
    if file.take(64 * 1024).read_to_end(&mut raw).is_err() {
        return false;
    }
    starts_citygml(raw)
}

/// The head of a file (gzip-compressed or not) opens a `CityModel`.
fn starts_citygml(raw: Vec<u8>) -> bool {
    let head = inflated_head(raw);
    root_tag(&head).is_some_and(|(name, tag)| is_root(name, tag))
}

/// The first 64 KiB of a file's text, inflated when it is gzip-compressed, as UTF-8 when it is UTF-16.
fn inflated_head(raw: Vec<u8>) -> Vec<u8> {
    let head = if raw.starts_with(&[0x1f, 0x8b]) {
        let mut head = Vec::new();
        let _ = flate2::read::MultiGzDecoder::new(&raw[..])
            .take(64 * 1024)
            .read_to_end(&mut head);
        head
    } else {
        raw
    };
    match utf16_of(&head) {
        // A head cut inside a character ends in a replacement character, after the root's start tag.
        Some(enc) => enc
            .decode_with_bom_removal(&head)
            .0
            .into_owned()
            .into_bytes(),
        None => head,
    }
}

/// UTF-16 text, by its byte-order mark or, without one, by its `<?` written in two bytes each (XML's rule).
fn utf16_of(bytes: &[u8]) -> Option<&'static encoding_rs::Encoding> {
    match bytes {
        [0xFF, 0xFE, ..] | [b'<', 0, b'?', 0, ..] => Some(encoding_rs::UTF_16LE),
        [0xFE, 0xFF, ..] | [0, b'<', 0, b'?', ..] => Some(encoding_rs::UTF_16BE),
        _ => None,
    }
}

/// The name of the first element of a file's head (gzip-compressed or not), `None` if it does not read as XML.
pub(crate) fn root_element(raw: Vec<u8>) -> Option<String> {
    root_tag(&inflated_head(raw)).map(|(name, _)| name.to_string())
}

/// A CityGML document's root: a `CityModel`, or a WFS answer's `FeatureCollection` declaring a CityGML namespace
/// (its `wfs:member`s holding the buildings).
fn is_root(name: &str, tag: &str) -> bool {
    match name.rsplit(':').next() {
        Some("CityModel") => true,
        Some("FeatureCollection") => tag.contains("http://www.opengis.net/citygml/"),
        _ => false,
    }
}

/// The name and the start tag of the first element of an XML text's head: after a byte-order mark, the
/// declaration, comments, processing instructions and a DOCTYPE.
fn root_tag(head: &[u8]) -> Option<(&str, &str)> {
    let mut rest = head.strip_prefix(b"\xef\xbb\xbf").unwrap_or(head);
    loop {
        let at = rest.iter().position(|b| !b.is_ascii_whitespace())?;
        rest = &rest[at..];
        let skip_to = |end: &[u8], from: usize| -> Option<usize> {
            rest.get(from..)?
                .windows(end.len())
                .position(|w| w == end)
                .map(|p| from + p + end.len())
        };
        if rest.starts_with(b"<?") {
            rest = &rest[skip_to(b"?>", 2)?..];
        } else if rest.starts_with(b"<!--") {
            rest = &rest[skip_to(b"-->", 4)?..];
        } else if rest.starts_with(b"<!") {
            // A DOCTYPE, its internal subset in brackets holding `>`s of its own.
            let close = rest.iter().position(|b| *b == b'>')?;
            let from = match rest[..close].iter().position(|b| *b == b'[') {
                Some(open) => skip_to(b"]", open)?,
                None => 0,
            };
            rest = &rest[from + rest[from..].iter().position(|b| *b == b'>')? + 1..];
        } else if rest.starts_with(b"<") {
            let name = &rest[1..];
            let end = name
                .iter()
                .position(|b| b.is_ascii_whitespace() || *b == b'>' || *b == b'/')?;
            let tag_end = rest.iter().position(|b| *b == b'>').unwrap_or(rest.len());
            return Some((
                std::str::from_utf8(&name[..end]).ok()?,
                std::str::from_utf8(&rest[..tag_end]).ok()?,
            ));
        } else {
            return None;
        }
    }
}

/// Reads the buildings of a CityGML file; `Err` (a detail) when the file is not CityGML or not well-formed XML.
/// `given_crs` is the user's `--crs`, which decides the axis order as a declared CRS would.
pub(crate) fn read(
    path: &Path,
    model_target: Option<Target>,
    given_crs: Option<&str>,
) -> Result<GmlDoc, String> {
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let open = || std::fs::File::open(path).map_err(|e| format!("cannot read the file: {e}"));
    let mut head = Vec::new();
    open()?
        .take(512)
        .read_to_end(&mut head)
        .map_err(|e| format!("cannot read the file: {e}"))?;
    let utf8 = declared_encoding(head.strip_prefix(b"\xef\xbb\xbf").unwrap_or(&head))
        .is_none_or(|l| is_utf8(&l));
    if head.starts_with(&[0x1f, 0x8b]) || !utf8 || utf16_of(&head).is_some() {
        // Inflated, or decoded to UTF-8, in memory.
        let bytes = std::fs::read(path).map_err(|e| format!("cannot read the file: {e}"))?;
        let text = decode(bytes)?;
        return read_text(&text, &file_name, model_target, given_crs);
    }
    // Streamed: the events from one handle, each member's text fetched by position from another.
    let base: u64 = if head.starts_with(b"\xef\xbb\xbf") {
        3
    } else {
        0
    };
    let mut events = std::io::BufReader::with_capacity(1 << 20, open()?);
    let mut texts = open()?;
    std::io::Seek::seek(&mut events, std::io::SeekFrom::Start(base))
        .map_err(|e| format!("cannot read the file: {e}"))?;
    read_stream(
        events,
        |from, to| {
            let mut out = vec![0u8; to - from];
            std::io::Seek::seek(&mut texts, std::io::SeekFrom::Start(base + from as u64))
                .and_then(|_| texts.read_exact(&mut out))
                .map_err(|e| format!("cannot read the file: {e}"))?;
            Ok(out)
        },
        &file_name,
        model_target,
        given_crs,
    )
}

/// Every CityGML member of a ZIP archive, one after the other (one member's text in memory at a time), each as a
/// file of its own: its name in the archive and what it holds.
pub(crate) fn read_zip(
    path: &Path,
    model_target: Option<Target>,
    given_crs: Option<&str>,
) -> Result<Vec<(String, GmlDoc)>, String> {
    let archive = crate::zip::Archive::open(path)?;
    let members = zip_members(&archive);
    if members.is_empty() {
        return Err("the archive holds no .gml or .xml file".into());
    }
    members
        .iter()
        .map(|m| {
            let text =
                decode(archive.read(m, None)?).map_err(|e| format!("member {}: {e}", m.name))?;
            let name = m.name.rsplit('/').next().unwrap_or(&m.name);
            let doc = read_text(&text, name, model_target, given_crs)
                .map_err(|e| format!("member {}: {e}", m.name))?;
            Ok((m.name.clone(), doc))
        })
        .collect()
}

/// The file's text: gzip inflated, a byte-order mark dropped, and an encoding the XML declaration names other than
/// UTF-8 (ISO-8859-1, Windows-1252, …) decoded.
fn decode(bytes: Vec<u8>) -> Result<String, String> {
    let bytes = crate::zip::gunzipped(&bytes, MAX_TEXT)?.unwrap_or(bytes);
    if bytes.len() as u64 > MAX_TEXT {
        return Err("over 8 GiB of XML, more than this reader holds: split the file".into());
    }
    if let Some(enc) = utf16_of(&bytes) {
        let (text, bad) = enc.decode_with_bom_removal(&bytes);
        if bad {
            return Err(format!(
                "bytes that are not {} text, as the file's start says it is",
                enc.name()
            ));
        }
        return Ok(text.into_owned());
    }
    let bytes = match bytes.strip_prefix(b"\xef\xbb\xbf") {
        Some(rest) => rest.to_vec(),
        None => bytes,
    };
    match declared_encoding(&bytes).as_deref() {
        None => {}
        Some(l) if is_utf8(l) => {}
        Some(l) => {
            let enc = encoding_rs::Encoding::for_label(l.as_bytes()).ok_or_else(|| {
                format!(
                    "the XML declaration names the encoding {l:?}, which this reader does not know"
                )
            })?;
            // The declaration was read as single bytes: the file is not in UTF-16, whatever it says.
            if enc == encoding_rs::UTF_16LE || enc == encoding_rs::UTF_16BE {
                return Err(format!(
                    "the XML declaration names the encoding {l:?}, but the file is not UTF-16 (its declaration \
                     is written in single bytes, and it has no byte-order mark): correct the declaration"
                ));
            }
            let (text, _, bad) = enc.decode(&bytes);
            if bad {
                return Err(format!(
                    "bytes that are not {l} text, as the XML declaration says it is"
                ));
            }
            return Ok(text.into_owned());
        }
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        format!(
            "not UTF-8 text: byte {at} (line {line}) is 0x{:02X}, and the XML declaration names no other encoding",
            e.as_bytes()[at]
        )
    })
}

/// An encoding label naming UTF-8.
fn is_utf8(label: &str) -> bool {
    label.eq_ignore_ascii_case("utf-8") || label.eq_ignore_ascii_case("utf8")
}

/// The `encoding` of an XML declaration at the start of `bytes`.
fn declared_encoding(bytes: &[u8]) -> Option<String> {
    let head = &bytes[..bytes.len().min(512)];
    let end = head.windows(2).position(|w| w == b"?>")?;
    let decl = std::str::from_utf8(&head[..end]).ok()?;
    let decl = decl.trim_start().strip_prefix("<?xml")?;
    let at = decl.find("encoding")?;
    let rest = decl[at + "encoding".len()..]
        .trim_start()
        .strip_prefix('=')?
        .trim_start();
    let quote = rest.chars().next().filter(|c| *c == '"' || *c == '\'')?;
    let value = &rest[1..];
    Some(value[..value.find(quote)?].to_string())
}

/// What one top-level member gave.
#[derive(Default)]
struct MemberOut {
    /// Its buildings, and its other city objects counted.
    doc: CityDoc,
    srs: Option<String>,
    /// Simple-typed children the attribute rules could not read (complex ADE elements, …), by name.
    not_attributes: Vec<String>,
    /// What the file's notes should say of this member (a Building read where a BuildingPart belongs, …).
    notes: Vec<String>,
}

/// Member text gathered before it is read in parallel: members are read a batch at a time, so a file of any size
/// holds one batch's text besides what its buildings become.
const BATCH_BYTES: usize = 64 << 20;

/// What the scan has found so far of the model as a whole.
#[derive(Default)]
struct Model {
    root_attrs: String,
    srs: Option<String>,
    first_x: Option<f64>,
    /// The axis order, decided with the first batch of members: (latitude first, the note saying so).
    axes: Option<(bool, Option<String>)>,
}

/// Reads a CityGML file's text: the whole of it in memory (gzip-compressed files, ZIP members, files in an encoding
/// other than UTF-8).
pub(crate) fn read_text(
    text: &str,
    file_name: &str,
    model_target: Option<Target>,
    given_crs: Option<&str>,
) -> Result<GmlDoc, String> {
    let bytes = text.as_bytes();
    read_stream(
        bytes,
        |from, to| Ok(bytes[from..to].to_vec()),
        file_name,
        model_target,
        given_crs,
    )
}

/// Scans the XML of `reader` as a stream of events for the model's top-level elements; each one's text is fetched
/// with `bytes_of(from, to)` (the same bytes, by position) and read as a tree of its own, a batch at a time.
fn read_stream<R: std::io::BufRead>(
    reader: R,
    mut bytes_of: impl FnMut(usize, usize) -> Result<Vec<u8>, String>,
    file_name: &str,
    model_target: Option<Target>,
    given_crs: Option<&str>,
) -> Result<GmlDoc, String> {
    let mut reader = quick_xml::Reader::from_reader(reader);
    let mut buf = Vec::new();
    let mut depth = 0usize;
    let mut open: Option<(usize, String)> = None;
    let mut model = Model::default();
    let mut seen_root = false;
    // Lines: counted in the bytes fetched, up to `counted`.
    let mut line = 1usize;
    let mut counted = 0usize;
    let newlines = |b: &[u8]| b.iter().filter(|&&c| c == b'\n').count();
    let mut batch: Vec<(usize, String, usize)> = Vec::new();
    let mut batch_bytes = 0usize;
    let mut members = 0usize;
    let mut outs: Vec<Result<MemberOut, String>> = Vec::new();
    // Elements under the model that are not members, said in the notes when they hold buildings.
    let mut outside: Vec<String> = Vec::new();
    let mut flush = |batch: &mut Vec<(usize, String, usize)>, model: &mut Model| {
        let (swap, _) = model
            .axes
            .get_or_insert_with(|| {
                if let Some((_, first, _)) = batch.first() {
                    if model.srs.is_none() || model.first_x.is_none() {
                        if let Ok(doc) = roxmltree::Document::parse(first) {
                            model.srs = model.srs.take().or_else(|| srs_name(&doc));
                            model.first_x = model.first_x.or_else(|| first_coordinate(&doc));
                        }
                    }
                }
                match given_crs.or(model.srs.as_deref()) {
                    Some(name) => latitude_first(name, model.first_x),
                    None => (false, None),
                }
            })
            .clone();
        let read: Vec<Result<MemberOut, String>> = batch
            .par_iter()
            .map(|(i, text, line)| read_member(text, *line, *i, file_name, model_target, swap))
            .collect();
        outs.extend(read);
        batch.clear();
    };
    loop {
        buf.clear();
        let before = reader.buffer_position() as usize;
        let event = match reader.read_event_into(&mut buf) {
            Ok(e) => e,
            Err(e) => {
                let at = reader.error_position() as usize;
                let line = bytes_of(counted, at.max(counted)).map_or(line, |b| line + newlines(&b));
                if matches!(e, quick_xml::Error::Encoding(_)) {
                    return Err(not_utf8(line));
                }
                return Err(format!("not well-formed XML at line {line}: {e}"));
            }
        };
        match event {
            Event::Start(e) => {
                if depth == 0 {
                    if seen_root {
                        return Err("not well-formed XML: a second element after the CityModel".into());
                    }
                    if !is_root(e.name().as_ref(), e.attributes_raw()) {
                        return Err(format!(
                            "not CityGML: the document is <{}>, not <CityModel> (or a WFS FeatureCollection of \
                             CityGML)",
                            e.name().as_ref()
                        ));
                    }
                    seen_root = true;
                    model.root_attrs = e.attributes_raw().to_string();
                } else if depth == 1 {
                    open = Some((before, e.local_name().as_ref().to_string()));
                }
                depth += 1;
                if depth > MAX_DEPTH {
                    let line = bytes_of(counted, before).map_or(line, |b| line + newlines(&b));
                    return Err(format!(
                        "elements nested more than {MAX_DEPTH} deep (at line {line}); CityGML nests about twenty"
                    ));
                }
            }
            Event::End(_) => {
                depth -= 1;
                if depth != 1 {
                    continue;
                }
                let Some((start, name)) = open.take() else {
                    continue;
                };
                let end = reader.buffer_position() as usize;
                let chunk = bytes_of(counted, end)?;
                let gap = start - counted;
                line += newlines(&chunk[..gap]);
                let member_line = line;
                line += newlines(&chunk[gap..]);
                counted = end;
                let text = std::str::from_utf8(&chunk[gap..]).map_err(|e| {
                    not_utf8(member_line + newlines(&chunk[gap..gap + e.valid_up_to()]))
                })?;
                let wrapped = format!(
                    "<citylod-member {}>{text}</citylod-member>",
                    model.root_attrs
                );
                // The model's own envelope names the CRS for every member.
                if name == "boundedBy" && members == 0 {
                    if let Ok(doc) = roxmltree::Document::parse(&wrapped) {
                        model.srs = srs_name(&doc);
                        model.first_x = first_coordinate(&doc);
                    }
                }
                let member = match name.as_str() {
                    // `member` and `featureMember(s)`: a WFS answer's.
                    "cityObjectMember" | "featureMember" | "featureMembers" | "member" => Some(wrapped),
                    // A city object straight under the model, where a member belongs: read as a member of its own.
                    "Building" | "BuildingPart" => {
                        let wrapped = format!(
                            "<citylod-member {}><citylod-bare>{text}</citylod-bare></citylod-member>",
                            model.root_attrs
                        );
                        outside.push(format!(
                            "{} (line {member_line}) stand(s) straight under the CityModel, not in a \
                             cityObjectMember: read as a member",
                            buildings_in(&wrapped).join(", ")
                        ));
                        Some(wrapped)
                    }
                    // Anything else (the envelope, an appearance, an ADE's element, a misspelt member): said when
                    // it holds buildings, which are not read in it.
                    _ if text.contains("Building") => {
                        let held = buildings_in(&wrapped);
                        if !held.is_empty() {
                            outside.push(format!(
                                "<{name}> (line {member_line}) is no member this reader reads (cityObjectMember, \
                                 featureMember(s), member): the {} in it not read",
                                held.join(", ")
                            ));
                        }
                        None
                    }
                    _ => None,
                };
                if let Some(wrapped) = member {
                    batch_bytes += wrapped.len();
                    batch.push((members, wrapped, member_line));
                    members += 1;
                    if batch_bytes > BATCH_BYTES {
                        flush(&mut batch, &mut model);
                        batch_bytes = 0;
                    }
                }
            }
            Event::Empty(e) if depth == 0 => {
                if !is_root(e.name().as_ref(), e.attributes_raw()) {
                    return Err(format!(
                        "not CityGML: the document is <{}>, not <CityModel>",
                        e.name().as_ref()
                    ));
                }
                seen_root = true;
            }
            Event::DocType(_) => {
                return Err(
                    "a DOCTYPE, which CityGML does not have (refused: its entities could expand without end)"
                        .into(),
                )
            }
            Event::Eof => {
                if depth > 0 {
                    return Err("not well-formed XML: the document ends inside an element (the file is cut short)".into());
                }
                if !seen_root {
                    return Err("no XML element in the file".into());
                }
                break;
            }
            _ => {}
        }
    }
    flush(&mut batch, &mut model);
    let version = version_of(&model.root_attrs);
    let mut doc = CityDoc {
        version: version.clone(),
        ..Default::default()
    };
    let mut notes = Vec::new();
    if let Some(v) = &version {
        notes.push(format!("CityGML {v}"));
    }
    notes.extend(model.axes.and_then(|(_, note)| note));
    let mut member_srs: Vec<(String, usize)> = Vec::new();
    let mut not_attributes: Vec<(String, usize)> = Vec::new();
    let mut member_notes = outside;
    for out in outs {
        let out = out?;
        member_notes.extend(out.notes);
        if let Some(s) = out.srs {
            match member_srs.iter_mut().find(|(n, _)| *n == s) {
                Some((_, c)) => *c += 1,
                None => member_srs.push((s, 1)),
            }
        }
        for n in out.not_attributes {
            match not_attributes.iter_mut().find(|(k, _)| *k == n) {
                Some((_, c)) => *c += 1,
                None => not_attributes.push((n, 1)),
            }
        }
        doc.features.extend(out.doc.features);
        doc.non_building_objects += out.doc.non_building_objects;
    }
    let srs = model
        .srs
        .or_else(|| member_srs.first().map(|(s, _)| s.clone()));
    if let Some(s) = &srs {
        let (declared, note) = declared_crs(s);
        doc.declared_crs = Some(declared);
        notes.extend(note);
        let others: Vec<String> = member_srs
            .iter()
            .filter(|(n, _)| n != s)
            .map(|(n, c)| format!("{n} ({c} member(s))"))
            .collect();
        if !others.is_empty() {
            notes.push(format!(
                "members name other CRSs than {s}, which was used for all: {}",
                others.join(", ")
            ));
        }
    }
    // Each said once; a file of many says the first few and how many more.
    const SAID: usize = 20;
    if member_notes.len() > SAID {
        let more = member_notes.len() - SAID;
        member_notes.truncate(SAID);
        member_notes.push(format!("… and {more} more such notes"));
    }
    notes.extend(member_notes);
    if !not_attributes.is_empty() {
        not_attributes.sort();
        notes.push(format!(
            "elements not read (neither attributes nor the building's geometry): {}",
            not_attributes
                .iter()
                .map(|(n, c)| format!("{n} ({c} building(s))"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    Ok(GmlDoc { doc, notes })
}

/// A file read as UTF-8 (the XML declaration names no other encoding) that is not, at the line `line`.
fn not_utf8(line: usize) -> String {
    format!(
        "not UTF-8 text at line {line}, and the XML declaration names no other encoding: declare the encoding the \
         file is written in (e.g. <?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>) or convert it to UTF-8"
    )
}

/// The Buildings and BuildingParts in an element that is not a member (its text wrapped as a member's): each by its
/// kind and gml:id.
fn buildings_in(wrapped: &str) -> Vec<String> {
    let Ok(doc) = roxmltree::Document::parse(wrapped) else {
        return vec!["Building(s)".to_string()];
    };
    doc.descendants()
        .filter(|d| matches!(d.tag_name().name(), "Building" | "BuildingPart"))
        .map(|d| match gml_id(d) {
            Some(id) => format!("{} {id:?}", d.tag_name().name()),
            None => d.tag_name().name().to_string(),
        })
        .enumerate()
        .filter_map(|(i, b)| match i {
            0..=9 => Some(b),
            10 => Some("…".to_string()),
            _ => None,
        })
        .collect()
}

/// The CityGML version of the model's namespaces (`http://www.opengis.net/citygml/2.0` → `2.0`).
fn version_of(root_attrs: &str) -> Option<String> {
    let at = root_attrs.find("http://www.opengis.net/citygml/")?
        + "http://www.opengis.net/citygml/".len();
    let rest = &root_attrs[at..];
    let v: String = rest
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.')
        .collect();
    (!v.is_empty()).then_some(v)
}

/// A `srsName` as a CRS declaration, with a note when it was read by its name rather than an EPSG code.
fn declared_crs(srs: &str) -> (DeclaredCrs, Option<String>) {
    let s = srs.trim();
    let upper = s.to_ascii_uppercase();
    // A compound URN (`urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::7837`): its first, horizontal, part.
    if upper.contains("EPSG") {
        let first = s
            .split(',')
            .find(|p| p.to_ascii_uppercase().contains("EPSG"))
            .unwrap_or(s);
        return (DeclaredCrs::Name(first.trim().to_string()), None);
    }
    // The German surveying authorities' names (AdV), `urn:adv:crs:HORIZONTAL*VERTICAL`, and Switzerland's.
    const NAMED: &[(&str, u32)] = &[
        ("ETRS89_UTM32", 25832),
        ("ETRS89_UTM33", 25833),
        ("ETRS89_UTM31", 25831),
        ("DE_DHDN_3GK2", 31466),
        ("DE_DHDN_3GK3", 31467),
        ("DE_DHDN_3GK4", 31468),
        ("DE_DHDN_3GK5", 31469),
        ("DE_42/83_3GK4", 2398),
        ("DE_42/83_3GK5", 2399),
        ("ETRS89_3GK3", 5677),
        ("ETRS89_3GK4", 5678),
        ("ETRS89_3GK5", 5679),
        ("CH1903+", 2056),
        ("CH1903+_LV95", 2056),
        ("LV95", 2056),
        ("CH1903", 21781),
        ("CH1903_LV03", 21781),
        ("LV03", 21781),
    ];
    let name = upper.strip_prefix("URN:ADV:CRS:").unwrap_or(&upper);
    let horizontal = name.split('*').next().unwrap_or(name).trim();
    if let Some((n, code)) = NAMED.iter().find(|(n, _)| *n == horizontal) {
        return (
            DeclaredCrs::Name(format!("EPSG:{code}")),
            Some(format!("the srsName {s:?} was read as EPSG:{code} ({n})")),
        );
    }
    match Crs::parse(s) {
        Ok(_) => (DeclaredCrs::Name(s.to_string()), None),
        Err(e) => (
            DeclaredCrs::NotUnderstood {
                member: "srsName",
                detail: format!("{s:?}: {}", e.0),
            },
            None,
        ),
    }
}

/// The first `srsName` in a tree.
fn srs_name(doc: &roxmltree::Document) -> Option<String> {
    doc.descendants()
        .find_map(|n| n.attribute("srsName").map(str::to_string))
}

/// The first number of the first coordinates in a tree (an envelope's corner, a `pos`, a `posList`).
fn first_coordinate(doc: &roxmltree::Document) -> Option<f64> {
    doc.descendants()
        .filter(|n| {
            matches!(
                n.tag_name().name(),
                "lowerCorner" | "upperCorner" | "pos" | "posList"
            )
        })
        .find_map(|n| text_of(n)?.split_ascii_whitespace().next()?.parse().ok())
}

/// Whether coordinates in the CRS `name` come latitude first: EPSG defines its geographic CRSs (4326, 4258,
/// JGD2011's 6668 and 6697, …) with latitude first, and GML follows the CRS's own axis order. A first coordinate
/// beyond ±90 cannot be a latitude: such a file is read longitude first, and the note says so.
fn latitude_first(name: &str, first_x: Option<f64>) -> (bool, Option<String>) {
    let DeclaredCrs::Name(n) = declared_crs(name).0 else {
        return (false, None);
    };
    let geographic = Crs::parse(&n).is_ok_and(|c| c.is_lon_lat());
    if !geographic || !n.to_ascii_uppercase().contains("EPSG") {
        return (false, None);
    }
    match first_x {
        Some(x) if x.abs() > 90.0 => (
            false,
            Some(format!(
                "coordinates read as longitude, latitude: {n} puts latitude first, but the first coordinate ({x}) \
                 cannot be a latitude"
            )),
        ),
        _ => (
            true,
            Some(format!(
                "coordinates read as latitude, longitude, the axis order EPSG gives {n}"
            )),
        ),
    }
}

/// Reads one top-level member (wrapped in an element carrying the model's namespace declarations); `swap`: its
/// coordinates come latitude first.
fn read_member(
    wrapped: &str,
    line: usize,
    index: usize,
    file_name: &str,
    model_target: Option<Target>,
    swap: bool,
) -> Result<MemberOut, String> {
    let mut out = MemberOut::default();
    let doc = roxmltree::Document::parse(wrapped).map_err(|e| member_error(&e, line))?;
    let Some(member) = doc.root_element().first_element_child() else {
        return Ok(out);
    };
    out.srs = member
        .descendants()
        .find_map(|n| n.attribute("srsName").map(str::to_string));
    let ids: HashMap<&str, Node> = member
        .descendants()
        .filter_map(|n| gml_id(n).map(|id| (id, n)))
        .collect();
    // The points read and references followed at most for each building: 4 for each byte of the member's text (a
    // point takes a few bytes, and a valid file reads each a few times: inline, and by reference in a solid and a
    // multi-surface), so that references to elements holding references cannot multiply a few elements into millions.
    let budget = wrapped.len().saturating_mul(4).saturating_add(4096);
    let city = &mut out.doc;
    for (k, object) in member.children().filter(Node::is_element).enumerate() {
        let kind = object.tag_name().name();
        if kind != "Building" && kind != "BuildingPart" {
            city.non_building_objects += 1;
            continue;
        }
        let key = named_id(object).map(str::to_string).unwrap_or_else(|| {
            if k == 0 {
                format!("{file_name}#{index}")
            } else {
                format!("{file_name}#{index}.{k}")
            }
        });
        let mut conv = Converter {
            ids: &ids,
            base_line: line,
            swap,
            vertices: Vec::new(),
            index: HashMap::new(),
            objects: Map::new(),
            problems: Vec::new(),
            not_attributes: Vec::new(),
            unread: std::cell::RefCell::new(Vec::new()),
            hops: std::cell::Cell::new(0),
            budget,
            implicit: Vec::new(),
            notes: Vec::new(),
        };
        conv.object(object, key, None);
        let Converter {
            vertices,
            objects,
            problems,
            not_attributes,
            implicit,
            notes,
            ..
        } = conv;
        out.not_attributes.extend(not_attributes);
        out.notes.extend(notes);
        let no_geometry = objects.values().all(|o| {
            o.get("geometry")
                .and_then(Value::as_array)
                .is_none_or(|g| g.is_empty())
        });
        let vertices = match problems.first() {
            Some(p) if no_geometry => Err((IssueReason::MalformedGeometry, p.clone())),
            None if no_geometry && !implicit.is_empty() => Err((
                IssueReason::UnsupportedGeometry,
                format!(
                    "only implicit geometry ({}: a shared geometry placed by a matrix), which this reader does \
                     not read",
                    implicit.join(", ")
                ),
            )),
            _ => Ok(vertices),
        };
        let first = city.features.len();
        cityjson::read_objects_with_vertices(&objects, vertices, model_target, city);
        for f in &mut city.features[first..] {
            match &mut f.skip {
                None => f.repairs.extend(
                    problems
                        .iter()
                        .map(|p| (IssueReason::GeometryNotRead, p.clone())),
                ),
                // Skipped (for no footprint, …, or the first geometry not read): what else was not read, which may
                // explain it, the first few of it.
                Some((_, detail)) => {
                    let rest = &problems[usize::from(no_geometry).min(problems.len())..];
                    for (i, p) in rest.iter().enumerate() {
                        if i == 8 {
                            detail.push_str(&format!("; and {} more", rest.len() - i));
                            break;
                        }
                        detail.push_str(if i == 0 { "; besides, " } else { "; " });
                        detail.push_str(p);
                    }
                }
            }
        }
    }
    Ok(out)
}

/// Where a member's tree does not parse: the problem and the file's line (roxmltree counts the rows of the member,
/// its first row behind the element put around it).
fn member_error(e: &roxmltree::Error, line: usize) -> String {
    let pos = e.pos();
    let text = e.to_string();
    let what = text
        .strip_suffix(&format!(" at {}:{}", pos.row, pos.col))
        .unwrap_or(&text);
    let at = line + pos.row.max(1) as usize - 1;
    let column = if pos.row > 1 {
        format!(", column {}", pos.col)
    } else {
        String::new()
    };
    format!("the member at line {line} is not well-formed XML: {what} (line {at}{column})")
}

/// The `gml:id` of a city object, when it is not blank (a blank one names nothing: the object is named as one without
/// an id).
fn named_id<'a>(n: Node<'a, '_>) -> Option<&'a str> {
    gml_id(n).filter(|id| !id.trim().is_empty())
}

/// The `gml:id` of an element.
fn gml_id<'a>(n: Node<'a, '_>) -> Option<&'a str> {
    n.attributes()
        .find(|a| {
            a.name() == "id"
                && a.namespace()
                    .is_some_and(|ns| ns.contains("opengis.net/gml"))
        })
        .map(|a| a.value())
}

/// The target of an `xlink:href` on an element, `None` without one.
fn href<'a>(n: Node<'a, '_>) -> Option<&'a str> {
    n.attributes()
        .find(|a| a.name() == "href" && a.namespace() == Some("http://www.w3.org/1999/xlink"))
        .map(|a| a.value())
}

type Ring = Vec<[f64; 3]>;

/// A polygon read from GML: its rings (open) and the `gml:id` of its element, which semantics are looked up by.
struct Poly {
    rings: Vec<Ring>,
    id: Option<String>,
}

/// A geometry property's content.
enum Geom {
    /// Solids (one, or a CompositeSolid's or MultiSolid's), each its shells of polygons, exterior first.
    Solids(Vec<Vec<Vec<Poly>>>),
    Surfaces(Vec<Poly>),
}

impl Geom {
    /// Every polygon, for a property that takes surfaces.
    fn polygons(self) -> Vec<Poly> {
        match self {
            Geom::Solids(solids) => solids.into_iter().flatten().flatten().collect(),
            Geom::Surfaces(p) => p,
        }
    }
}

/// The thematic surface types of buildings (CityGML's names are CityJSON's), openings included.
const THEMATIC: &[&str] = &[
    "RoofSurface",
    "WallSurface",
    "GroundSurface",
    "ClosureSurface",
    "OuterCeilingSurface",
    "OuterFloorSurface",
    "FloorSurface",
    "CeilingSurface",
    "InteriorWallSurface",
    "Window",
    "Door",
];

/// One building's (or part's) geometry by LoD, before it becomes CityJSON.
#[derive(Default)]
struct ByLod {
    solids: Vec<Vec<Vec<Poly>>>,
    surfaces: Vec<(Poly, Option<&'static str>)>,
    thematic: Vec<(Poly, &'static str)>,
}

struct Converter<'m, 'a, 'input> {
    ids: &'m HashMap<&'a str, Node<'a, 'input>>,
    /// The file's line of the member's first line.
    base_line: usize,
    /// Coordinates come latitude first: x and y are swapped as they are read.
    swap: bool,
    vertices: Vec<[f64; 3]>,
    index: HashMap<[u64; 3], usize>,
    objects: Map<String, Value>,
    /// Geometries not read: what (of which object) and why.
    problems: Vec<String>,
    not_attributes: Vec<String>,
    /// Elements inside a geometry being read that are not read (an element where the reader reads none), and why:
    /// the geometry's other elements are read, and these become problems of its object.
    unread: std::cell::RefCell<Vec<(Node<'a, 'input>, String)>>,
    /// The points read and `xlink:href`s followed for this building, and how many at most.
    hops: std::cell::Cell<usize>,
    budget: usize,
    /// Implicit geometries (`lod2ImplicitRepresentation`, line), which are not read.
    implicit: Vec<String>,
    /// Notes for the file (see [`MemberOut::notes`]).
    notes: Vec<String>,
}

impl<'a, 'input> Converter<'_, 'a, 'input> {
    /// Adds the city object `e` (a Building or BuildingPart) under `key`, and its parts after it.
    fn object(&mut self, e: Node<'a, 'input>, key: String, parent: Option<&str>) {
        let mut attributes = Map::new();
        let mut lods: [ByLod; 5] = Default::default();
        let mut parts: Vec<Node> = Vec::new();
        for c in e.children().filter(Node::is_element) {
            let name = c.tag_name().name();
            if let Some((lod, kind)) = geometry_property(name) {
                match self.read_geometry(&key, c) {
                    Some(Geom::Solids(solids)) if kind == Kind::Solid => {
                        lods[lod].solids.extend(solids)
                    }
                    Some(g) => {
                        let semantic = match kind {
                            Kind::Footprint => Some("GroundSurface"),
                            Kind::RoofEdge => Some("RoofSurface"),
                            _ => None,
                        };
                        lods[lod]
                            .surfaces
                            .extend(g.polygons().into_iter().map(|p| (p, semantic)));
                    }
                    None => {}
                }
                continue;
            }
            if is_implicit(name) {
                self.implicit
                    .push(format!("{name} (line {})", self.line_of(c)));
            }
            match name {
                "boundedBy" | "boundary" if !is_gml(c) => {
                    for s in c.children().filter(Node::is_element) {
                        self.thematic(s, &key, &mut lods, 0);
                    }
                }
                "consistsOfBuildingPart" | "buildingPart" => {
                    if let Some(h) = href(c) {
                        self.problem(
                            &key,
                            c,
                            format!("a part by reference (xlink:href {h:?}), which this reader does not follow"),
                        );
                    }
                    for p in c.children().filter(Node::is_element) {
                        match p.tag_name().name() {
                            "BuildingPart" => parts.push(p),
                            // A Building where a part belongs: read as the part it stands for.
                            "Building" => {
                                self.notes.push(format!(
                                    "a Building{} (line {}) in {name} of {key}, where a BuildingPart belongs, was \
                                     read as a part",
                                    gml_id(p).map(|i| format!(" {i:?}")).unwrap_or_default(),
                                    self.line_of(p)
                                ));
                                parts.push(p);
                            }
                            other => self.problem(
                                &key,
                                p,
                                format!("a {other} in {name}, where a BuildingPart belongs"),
                            ),
                        }
                    }
                }
                // The envelope: where the building is, which its geometry says.
                "boundedBy" => {}
                _ => attribute(c, &mut attributes, &mut self.not_attributes),
            }
        }
        let geometry: Vec<Value> = lods
            .into_iter()
            .enumerate()
            .filter_map(|(lod, g)| self.emit(lod, g))
            .collect();
        let mut object = Map::new();
        object.insert(
            "type".into(),
            Value::from(
                if parent.is_some() || e.tag_name().name() == "BuildingPart" {
                    "BuildingPart"
                } else {
                    "Building"
                },
            ),
        );
        object.insert("attributes".into(), Value::Object(attributes));
        object.insert("geometry".into(), Value::Array(geometry));
        if let Some(p) = parent {
            object.insert("parents".into(), json!([p]));
        }
        let mut children = Vec::new();
        let mut part_keys = Vec::new();
        for (i, p) in parts.iter().enumerate() {
            let mut k = named_id(*p)
                .map(str::to_string)
                .unwrap_or_else(|| format!("{key}/part{}", i + 1));
            while self.objects.contains_key(&k) || k == key || part_keys.contains(&k) {
                k.push('\'');
            }
            children.push(Value::from(k.clone()));
            part_keys.push(k);
        }
        if !children.is_empty() {
            object.insert("children".into(), Value::Array(children));
        }
        self.objects.insert(key.clone(), Value::Object(object));
        for (p, k) in parts.into_iter().zip(part_keys) {
            self.object(p, k, Some(&key));
        }
    }

    /// The file's line of an element of the member.
    fn line_of(&self, at: Node) -> usize {
        at.document().text_pos_at(at.range().start).row as usize + self.base_line - 1
    }

    fn problem(&mut self, key: &str, at: Node, why: String) {
        let line = self.line_of(at);
        self.problems.push(format!(
            "{} (line {line}) of {key} not read: {why}",
            at.tag_name().name()
        ));
    }

    /// A thematic surface (`RoofSurface`, …) and the openings in it: their `lodNMultiSurface`s.
    fn thematic(&mut self, s: Node<'a, 'input>, key: &str, lods: &mut [ByLod; 5], depth: usize) {
        let Some(&kind) = THEMATIC.iter().find(|t| **t == s.tag_name().name()) else {
            if holds_geometry(s) {
                self.problem(
                    key,
                    s,
                    format!(
                        "a boundary surface of a type this reader does not know (it reads {})",
                        THEMATIC.join(", ")
                    ),
                );
            }
            return;
        };
        for c in s.children().filter(Node::is_element) {
            let name = c.tag_name().name();
            if let Some((lod, _)) = geometry_property(name) {
                if let Some(g) = self.read_geometry(key, c) {
                    lods[lod]
                        .thematic
                        .extend(g.polygons().into_iter().map(|p| (p, kind)));
                }
            } else if (name == "opening" || name == "filling") && depth < 4 {
                for o in c.children().filter(Node::is_element) {
                    self.thematic(o, key, lods, depth + 1);
                }
            }
        }
    }

    /// The content of a geometry property element of the object `key`; what of it is not read is listed as its
    /// problems.
    fn read_geometry(&mut self, key: &str, property: Node<'a, 'input>) -> Option<Geom> {
        let g = self.geometry(property);
        for (at, why) in std::mem::take(self.unread.get_mut()) {
            self.problem(key, at, why);
        }
        g.map_err(|why| self.problem(key, property, why)).ok()
    }

    /// Notes an element inside a geometry that is not read there (unless it is GML's description of an object,
    /// holding no coordinates).
    fn not_read(&self, child: Node<'a, 'input>, within: Node) {
        let name = child.tag_name().name();
        let described = matches!(
            name,
            "name" | "description" | "descriptionReference" | "identifier" | "metaDataProperty"
        );
        if !described || holds_coordinates(child) {
            self.unread.borrow_mut().push((
                child,
                format!(
                    "a {name} in a {}, where this reader does not read one",
                    within.tag_name().name()
                ),
            ));
        }
    }

    /// Counts `work` points read or references followed against the building's budget.
    fn spend(&self, work: usize) -> Result<(), String> {
        let spent = self.hops.get().saturating_add(work);
        self.hops.set(spent);
        if spent > self.budget {
            return Err(format!(
                "the building's geometry, its xlink:hrefs followed, comes to more than {} points and references \
                 (4 for each byte of its member's text): references to elements holding references multiply",
                self.budget
            ));
        }
        Ok(())
    }

    /// The content of a geometry property element (inline or by `xlink:href`).
    fn geometry(&self, property: Node<'a, 'input>) -> Result<Geom, String> {
        let g = self.target(property)?.ok_or("empty: no geometry inside")?;
        match g.tag_name().name() {
            "Solid" => Ok(Geom::Solids(vec![self.solid(g)?])),
            // Each member a solid of its own: one solid of all their shells would make the others its cavities.
            "CompositeSolid" | "MultiSolid" => {
                let mut solids = Vec::new();
                for m in g.children().filter(Node::is_element) {
                    match m.tag_name().name() {
                        "solidMember" => {
                            if let Some(s) = self.target(m)? {
                                solids.push(self.solid_of(s)?);
                            }
                        }
                        "solidMembers" => {
                            for s in m.children().filter(Node::is_element) {
                                solids.push(self.solid_of(s)?);
                            }
                        }
                        _ => self.not_read(m, g),
                    }
                }
                Ok(Geom::Solids(solids))
            }
            _ => {
                let mut polys = Vec::new();
                self.surfaces(g, 0, &mut polys)?;
                Ok(Geom::Surfaces(polys))
            }
        }
    }

    fn solid_of(&self, s: Node<'a, 'input>) -> Result<Vec<Vec<Poly>>, String> {
        if s.tag_name().name() != "Solid" {
            return Err(format!(
                "a solid member is a {}, not a Solid",
                s.tag_name().name()
            ));
        }
        self.solid(s)
    }

    /// A Solid's shells: its exterior, then its interiors (cavities).
    fn solid(&self, s: Node<'a, 'input>) -> Result<Vec<Vec<Poly>>, String> {
        let mut shells = Vec::new();
        for c in s.children().filter(Node::is_element) {
            if !matches!(c.tag_name().name(), "exterior" | "interior") {
                self.not_read(c, s);
            }
        }
        for side in ["exterior", "interior"] {
            for b in s
                .children()
                .filter(|c| c.is_element() && c.tag_name().name() == side)
            {
                if let Some(shell) = self.target(b)? {
                    let mut polys = Vec::new();
                    self.surfaces(shell, 0, &mut polys)?;
                    shells.push(polys);
                }
            }
        }
        if shells.is_empty() {
            return Err("a Solid without an exterior shell".into());
        }
        Ok(shells)
    }

    /// The element a property holds: its `xlink:href` target in this member, else its first child element.
    fn target(&self, property: Node<'a, 'input>) -> Result<Option<Node<'a, 'input>>, String> {
        let mut n = property;
        for _ in 0..MAX_HOPS {
            let Some(h) = href(n) else {
                let first = n.first_element_child();
                if let Some(second) = first.and_then(|f| f.next_sibling_element()) {
                    self.not_read(second, n);
                }
                return Ok(first);
            };
            self.spend(1)
                .map_err(|why| format!("xlink:href {h:?} not followed: {why}"))?;
            let id = h.strip_prefix('#').ok_or_else(|| {
                format!("xlink:href {h:?} points outside this file's member (only #id references are read)")
            })?;
            let t = *self.ids.get(id).ok_or_else(|| {
                format!("xlink:href {h:?}: no element with that gml:id in this member")
            })?;
            if href(t).is_none() {
                return Ok(Some(t));
            }
            n = t;
        }
        Err(format!(
            "xlink:hrefs chained more than {MAX_HOPS} deep (a cycle?)"
        ))
    }

    /// The polygons of a surface element, in order.
    fn surfaces(
        &self,
        g: Node<'a, 'input>,
        depth: usize,
        out: &mut Vec<Poly>,
    ) -> Result<(), String> {
        if depth > 32 {
            return Err("surfaces nested more than 32 deep".into());
        }
        let name = g.tag_name().name();
        match name {
            "Polygon" | "Triangle" | "Rectangle" | "PolygonPatch" => {
                out.push(self.polygon(g)?);
                Ok(())
            }
            // CityGML 1.0's TexturedSurface is an OrientableSurface with its appearance.
            "OrientableSurface" | "TexturedSurface" => {
                let base = g
                    .children()
                    .find(|c| c.is_element() && c.tag_name().name() == "baseSurface")
                    .ok_or("an OrientableSurface without a baseSurface")?;
                let target = self.target(base)?.ok_or("an empty baseSurface")?;
                let first = out.len();
                self.surfaces(target, depth + 1, out)?;
                if g.attribute("orientation") == Some("-") {
                    for p in &mut out[first..] {
                        for r in &mut p.rings {
                            r.reverse();
                        }
                    }
                }
                Ok(())
            }
            "MultiSurface"
            | "CompositeSurface"
            | "Shell"
            | "Surface"
            | "TriangulatedSurface"
            | "Tin"
            | "PolyhedralSurface" => {
                for m in g.children().filter(Node::is_element) {
                    match m.tag_name().name() {
                        "surfaceMember" | "baseSurface" => {
                            if let Some(t) = self.target(m)? {
                                self.surfaces(t, depth + 1, out)?;
                            }
                        }
                        "surfaceMembers" | "patches" | "trianglePatches" | "polygonPatches" => {
                            for t in m.children().filter(Node::is_element) {
                                self.surfaces(t, depth + 1, out)?;
                            }
                        }
                        // A Tin's constraints on its triangulation, which its triangles are.
                        "stopLines" | "breakLines" | "maxLength" if name == "Tin" => {}
                        _ => self.not_read(m, g),
                    }
                }
                Ok(())
            }
            other => Err(format!("a {other}, not a surface this reader reads")),
        }
    }

    fn polygon(&self, p: Node<'a, 'input>) -> Result<Poly, String> {
        for c in p.children().filter(Node::is_element) {
            if !matches!(
                c.tag_name().name(),
                "exterior" | "interior" | "outerBoundaryIs" | "innerBoundaryIs"
            ) {
                self.not_read(c, p);
            }
        }
        let mut rings = Vec::new();
        for side in [
            ["exterior", "outerBoundaryIs"],
            ["interior", "innerBoundaryIs"],
        ] {
            for b in p
                .children()
                .filter(|c| c.is_element() && side.contains(&c.tag_name().name()))
            {
                let ring = self.target(b)?.ok_or("an empty polygon boundary")?;
                rings.push(match ring.tag_name().name() {
                    "LinearRing" => self.ring(ring)?,
                    "Ring" => self.curve_ring(ring)?,
                    other => {
                        return Err(format!(
                            "a polygon boundary is a {other}, not a LinearRing or Ring"
                        ))
                    }
                });
            }
            if rings.is_empty() {
                return Err(format!(
                    "a {} without an exterior ring",
                    p.tag_name().name()
                ));
            }
        }
        Ok(Poly {
            rings,
            id: gml_id(p).map(str::to_string),
        })
    }

    /// A gml:Ring's points, open: its curve members (LineStrings, or Curves of LineStringSegments, inline or by
    /// reference) joined end to start. Arcs are refused with their name.
    fn curve_ring(&self, r: Node<'a, 'input>) -> Result<Ring, String> {
        for c in r.children().filter(Node::is_element) {
            if c.tag_name().name() != "curveMember" {
                self.not_read(c, r);
            }
        }
        let mut pts: Ring = Vec::new();
        let mut add = |piece: Ring| {
            let skip = usize::from(pts.last().is_some() && pts.last() == piece.first());
            pts.extend(piece.into_iter().skip(skip));
        };
        for m in r
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "curveMember")
        {
            let curve = self.target(m)?.ok_or("an empty curveMember")?;
            match curve.tag_name().name() {
                "LineString" => add(self.points(curve)?),
                "Curve" => {
                    let segments = curve
                        .children()
                        .find(|c| c.is_element() && c.tag_name().name() == "segments")
                        .ok_or("a Curve without segments")?;
                    for seg in segments.children().filter(Node::is_element) {
                        match seg.tag_name().name() {
                            "LineStringSegment" => add(self.points(seg)?),
                            other => {
                                return Err(format!(
                                    "a Ring's curve segment is a {other} (only LineStringSegments are read)"
                                ))
                            }
                        }
                    }
                }
                other => {
                    return Err(format!(
                        "a Ring's curve member is a {other}, not a LineString or Curve"
                    ))
                }
            }
        }
        if pts.len() >= 2 && pts.first() == pts.last() {
            pts.pop();
        }
        Ok(pts)
    }

    /// A LinearRing's points (`posList`, `pos`, `coordinates` or `pointProperty`), open.
    fn ring(&self, r: Node<'a, 'input>) -> Result<Ring, String> {
        let mut pts = self.points(r)?;
        if pts.len() >= 2 && pts.first() == pts.last() {
            pts.pop();
        }
        Ok(pts)
    }

    /// The points of a LinearRing, LineString or LineStringSegment (`posList`, `pos`, `coordinates` or
    /// `pointProperty`), as written (axes in x, y order).
    fn points(&self, r: Node<'a, 'input>) -> Result<Ring, String> {
        let mut pts: Ring = Vec::new();
        for c in r.children().filter(Node::is_element) {
            // Coordinates are text: an element inside them is not read.
            if matches!(c.tag_name().name(), "posList" | "pos" | "coordinates") {
                for x in c.children().filter(Node::is_element) {
                    self.not_read(x, c);
                }
            }
            match c.tag_name().name() {
                "posList" => {
                    let dim = dimension(c)?;
                    let nums = numbers(&text_of(c).unwrap_or_default(), "posList")?;
                    if nums.len() % dim != 0 {
                        return Err(format!(
                            "a posList of {} numbers, not a multiple of its dimension {dim}",
                            nums.len()
                        ));
                    }
                    pts.extend(
                        nums.chunks(dim)
                            .map(|p| [p[0], p[1], if dim == 3 { p[2] } else { 0.0 }]),
                    );
                }
                "pos" => pts.push(point(c)?),
                "pointProperty" | "pointRep" => {
                    let pt = c
                        .descendants()
                        .find(|d| d.is_element() && d.tag_name().name() == "pos")
                        .ok_or(
                            "a pointProperty without a pos (references to points are not read)",
                        )?;
                    pts.push(point(pt)?);
                }
                "coordinates" => {
                    let cs = c.attribute("cs").unwrap_or(",");
                    let ts = c.attribute("ts").unwrap_or(" ");
                    let decimal = c.attribute("decimal").unwrap_or(".");
                    let text = text_of(c).unwrap_or_default();
                    for tuple in text
                        .split(|ch: char| ts.contains(ch) || (ts == " " && ch.is_whitespace()))
                        .filter(|t| !t.is_empty())
                    {
                        let v: Vec<f64> = tuple
                            .split(cs)
                            .map(|x| x.trim().replace(decimal, ".").parse::<f64>())
                            .collect::<Result<_, _>>()
                            .map_err(|_| format!("coordinates {tuple:?} are not numbers"))?;
                        match v[..] {
                            [x, y] => pts.push([x, y, 0.0]),
                            [x, y, z] => pts.push([x, y, z]),
                            _ => {
                                return Err(format!("coordinates {tuple:?} are not 2 or 3 numbers"))
                            }
                        }
                    }
                }
                // GML 2's point: X, Y and Z each an element.
                "coord" => {
                    let axis = |a: &str| {
                        c.children()
                            .find(|x| x.is_element() && x.tag_name().name() == a)
                            .map(|x| text_of(x).unwrap_or_default().trim().parse::<f64>())
                    };
                    match (axis("X"), axis("Y"), axis("Z")) {
                        (Some(Ok(x)), Some(Ok(y)), None) => pts.push([x, y, 0.0]),
                        (Some(Ok(x)), Some(Ok(y)), Some(Ok(z))) => pts.push([x, y, z]),
                        _ => return Err("a coord whose X, Y (and Z) are not numbers".into()),
                    }
                }
                _ => self.not_read(c, r),
            }
        }
        self.spend(pts.len())?;
        if pts.iter().flatten().any(|v| !v.is_finite()) {
            return Err("a coordinate that is not a finite number".into());
        }
        if self.swap {
            for p in &mut pts {
                p.swap(0, 1);
            }
        }
        Ok(pts)
    }

    fn vertex(&mut self, p: [f64; 3]) -> usize {
        let key = p.map(|v| (v + 0.0).to_bits());
        let next = self.vertices.len();
        *self.index.entry(key).or_insert_with(|| {
            self.vertices.push(p);
            next
        })
    }

    fn boundary(&mut self, p: &Poly) -> Value {
        Value::Array(
            p.rings
                .iter()
                .map(|r| Value::Array(r.iter().map(|v| Value::from(self.vertex(*v))).collect()))
                .collect(),
        )
    }

    /// One LoD's geometry as a CityJSON geometry: its solids (their polygons typed by the thematic surfaces they
    /// share a `gml:id` with; several as a MultiSolid), else its surfaces and thematic surfaces together.
    fn emit(&mut self, lod: usize, g: ByLod) -> Option<Value> {
        let kinds: HashMap<&str, &str> = g
            .thematic
            .iter()
            .filter_map(|(p, k)| p.id.as_deref().map(|id| (id, *k)))
            .collect();
        let kind_of = |p: &Poly| p.id.as_deref().and_then(|id| kinds.get(id).copied());
        let mut types: Vec<String> = Vec::new();
        let mut type_index = |t: Option<&str>| -> Value {
            let Some(t) = t else { return Value::Null };
            Value::from(match types.iter().position(|k| *k == t) {
                Some(i) => i,
                None => {
                    types.push(t.to_string());
                    types.len() - 1
                }
            })
        };
        let (kind, boundaries, values) = if !g.solids.is_empty() {
            let mut boundaries = Vec::new();
            let mut values = Vec::new();
            for solid in &g.solids {
                let shells = |f: &mut dyn FnMut(&Poly) -> Value| -> Value {
                    Value::Array(
                        solid
                            .iter()
                            .map(|shell| Value::Array(shell.iter().map(&mut *f).collect()))
                            .collect(),
                    )
                };
                boundaries.push(shells(&mut |p| self.boundary(p)));
                values.push(shells(&mut |p| type_index(kind_of(p))));
            }
            if g.solids.len() == 1 {
                ("Solid", boundaries.remove(0), values.remove(0))
            } else {
                ("MultiSolid", Value::Array(boundaries), Value::Array(values))
            }
        } else {
            let listed: std::collections::HashSet<&str> = g
                .surfaces
                .iter()
                .filter_map(|(p, _)| p.id.as_deref())
                .collect();
            let polys: Vec<(&Poly, Option<&str>)> = g
                .surfaces
                .iter()
                .map(|(p, t)| (p, t.or_else(|| kind_of(p))))
                .chain(
                    g.thematic
                        .iter()
                        .filter(|(p, _)| p.id.as_deref().is_none_or(|id| !listed.contains(id)))
                        .map(|(p, k)| (p, Some(*k))),
                )
                .collect();
            if polys.is_empty() {
                return None;
            }
            (
                "MultiSurface",
                polys.iter().map(|(p, _)| self.boundary(p)).collect(),
                polys.iter().map(|(_, t)| type_index(*t)).collect(),
            )
        };
        let mut out = json!({"type": kind, "lod": lod.to_string(), "boundaries": boundaries});
        if !types.is_empty() {
            out["semantics"] = json!({
                "surfaces": types.iter().map(|t| json!({"type": t})).collect::<Vec<_>>(),
                "values": values,
            });
        }
        Some(out)
    }
}

#[derive(PartialEq, Eq, Clone, Copy)]
enum Kind {
    Solid,
    Surfaces,
    Footprint,
    RoofEdge,
}

/// A geometry property's LoD and kind by its local name: `lod2Solid`, `lod1MultiSurface`, `lod0FootPrint`, …
fn geometry_property(name: &str) -> Option<(usize, Kind)> {
    match name {
        "lod0FootPrint" => return Some((0, Kind::Footprint)),
        "lod0RoofEdge" => return Some((0, Kind::RoofEdge)),
        _ => {}
    }
    let rest = name.strip_prefix("lod")?;
    let lod = rest.chars().next()?.to_digit(10)? as usize;
    if lod > 4 {
        return None;
    }
    match &rest[1..] {
        "Solid" | "MultiSolid" if lod >= 1 => Some((lod, Kind::Solid)),
        "MultiSurface" | "CompositeSurface" | "Surface" => Some((lod, Kind::Surfaces)),
        _ => None,
    }
}

/// A building's implicit geometry property (`lod2ImplicitRepresentation`), which is not read.
fn is_implicit(name: &str) -> bool {
    name.strip_prefix("lod")
        .and_then(|r| r.get(1..))
        .is_some_and(|r| r == "ImplicitRepresentation")
}

/// An element holding coordinates or references (a thematic surface with geometry).
fn holds_geometry(n: Node) -> bool {
    holds_coordinates(n) || n.descendants().any(|d| d.is_element() && href(d).is_some())
}

/// An element holding coordinates.
fn holds_coordinates(n: Node) -> bool {
    n.descendants().any(|d| {
        d.is_element()
            && matches!(
                d.tag_name().name(),
                "posList" | "pos" | "coordinates" | "coord"
            )
    })
}

/// GML's own `boundedBy` (an envelope), not a building's thematic surfaces.
fn is_gml(n: Node) -> bool {
    n.tag_name()
        .namespace()
        .is_some_and(|ns| ns.contains("opengis.net/gml"))
}

/// A `srsDimension` from the element or its ancestors (2 or 3), 3 when none is given.
fn dimension(n: Node) -> Result<usize, String> {
    match n.ancestors().find_map(|a| a.attribute("srsDimension")) {
        None => Ok(3),
        Some(d) => match d.trim() {
            "2" => Ok(2),
            "3" => Ok(3),
            other => Err(format!("srsDimension {other:?}: only 2 and 3 are read")),
        },
    }
}

fn numbers(text: &str, what: &str) -> Result<Vec<f64>, String> {
    text.split_ascii_whitespace()
        .map(|t| {
            t.parse::<f64>()
                .map_err(|_| format!("{what} holds {t:?}, which is not a number"))
        })
        .collect()
}

fn point(pos: Node) -> Result<[f64; 3], String> {
    match numbers(&text_of(pos).unwrap_or_default(), "pos")?[..] {
        [x, y] => Ok([x, y, 0.0]),
        [x, y, z] => Ok([x, y, z]),
        ref v => Err(format!("a pos of {} numbers", v.len())),
    }
}

/// Metres per unit of a `uom` (`#m`, `m`, `urn:adv:uom:m`, UCUM's `[ft_i]`, …); `None` for one not known.
fn metres_per(uom: Option<&str>) -> Option<f64> {
    let u = uom.unwrap_or("m").trim();
    let u = u.rsplit([':', '#']).next().unwrap_or(u);
    match u {
        "" | "m" | "metre" | "meter" | "metres" | "meters" => Some(1.0),
        "ft" | "[ft_i]" | "foot" | "feet" => Some(0.3048),
        "[ft_us]" | "us-ft" | "ftUS" => Some(1200.0 / 3937.0),
        "km" => Some(1000.0),
        "dm" => Some(0.1),
        "cm" => Some(0.01),
        "mm" => Some(0.001),
        _ => None,
    }
}

/// A length's text in metres, converted from its `uom`. A number in a unit not known keeps its text with the unit
/// after it (`3 furlong`), which the height rules do not take as metres: they name it, and the next rule gives the
/// height. Text that is not a number stays as it is.
fn length(t: String, uom: Option<&str>) -> Value {
    match (t.parse::<f64>(), metres_per(uom)) {
        (Ok(x), Some(f)) => Value::from(x * f),
        (Ok(_), None) => Value::from(format!("{t} {}", uom.unwrap_or("").trim())),
        _ => Value::from(t),
    }
}

/// An element's character data: its text pieces joined (a comment or processing instruction between them splits
/// it, and roxmltree's `Node::text` is the first piece only); `None` without any.
fn text_of<'a>(n: Node<'a, '_>) -> Option<std::borrow::Cow<'a, str>> {
    let mut pieces = n.children().filter(Node::is_text).filter_map(|c| c.text());
    let first = pieces.next()?;
    Some(match pieces.next() {
        None => std::borrow::Cow::Borrowed(first),
        Some(second) => {
            let mut all = String::from(first);
            all.push_str(second);
            all.extend(pieces);
            std::borrow::Cow::Owned(all)
        }
    })
}

/// Elements holding a count or a year, read as whole numbers.
const WHOLE: &[&str] = &[
    "storeysAboveGround",
    "storeysBelowGround",
    "yearOfConstruction",
    "yearOfDemolition",
];

/// Reads one child element of a building as attributes: `gml:name`, simple elements, generic attributes, external
/// references, the address. Elements with structure this reader does not know are named in `skipped`.
fn attribute(c: Node, out: &mut Map<String, Value>, skipped: &mut Vec<String>) {
    let name = c.tag_name().name();
    let text = || {
        text_of(c)
            .as_deref()
            .map(str::trim)
            .unwrap_or("")
            .to_string()
    };
    match name {
        "stringAttribute"
        | "intAttribute"
        | "doubleAttribute"
        | "dateAttribute"
        | "uriAttribute"
        | "measureAttribute"
        | "genericAttributeSet"
        | "genericAttribute" => {
            generic(c, "", out);
            return;
        }
        "externalReference" => {
            let system = child_text(c, "informationSystem").unwrap_or_default();
            let object = c
                .children()
                .find(|x| x.is_element() && x.tag_name().name() == "externalObject");
            let value = object
                .and_then(|o| child_text(o, "name").or_else(|| child_text(o, "uri")))
                .or_else(|| child_text(c, "externalObject"))
                .unwrap_or_default();
            // A register's name (`EGID`, `GID`) names the attribute; a longer one (a file path, a URL) stays with
            // the value.
            let short =
                !system.is_empty() && system.len() <= 32 && !system.contains(['/', '\\', ' ', ':']);
            if short {
                put(
                    out,
                    format!("externalReference:{system}"),
                    Value::from(value),
                );
            } else if system.is_empty() {
                put(out, "externalReference".into(), Value::from(value));
            } else {
                put(
                    out,
                    "externalReference".into(),
                    Value::from(format!("{system}: {value}")),
                );
            }
            return;
        }
        "address" => {
            if out.keys().any(|k| k.starts_with("address.")) {
                return;
            }
            for leaf in c
                .descendants()
                .filter(|d| d.is_element() && !d.children().any(|x| x.is_element()))
            {
                let t = text_of(leaf);
                let t = t.as_deref().map(str::trim).unwrap_or("");
                if !t.is_empty() {
                    put(
                        out,
                        format!("address.{}", leaf.tag_name().name()),
                        Value::from(t),
                    );
                }
            }
            return;
        }
        "height" if c.children().any(|x| x.is_element()) => {
            // 3.0: <con:height><con:Height> highReference, lowReference, status, value </con:Height></con:height>
            let h = c.first_element_child().unwrap_or(c);
            let high = child_text(h, "highReference").unwrap_or_default();
            let low = child_text(h, "lowReference").unwrap_or_default();
            let value = h
                .children()
                .find(|x| x.is_element() && x.tag_name().name() == "value");
            if let Some(v) = value {
                let t = text_of(v)
                    .as_deref()
                    .map(str::trim)
                    .unwrap_or("")
                    .to_string();
                let key = if high == "highestPoint" && low == "lowestGroundPoint" {
                    "measuredHeight".to_string()
                } else {
                    format!("height.{high}.{low}")
                };
                put(out, key, length(t, v.attribute("uom")));
            }
            return;
        }
        _ => {}
    }
    if c.children().any(|x| x.is_element()) {
        if !skipped.iter().any(|s| s == name) {
            skipped.push(name.to_string());
        }
        return;
    }
    let t = text();
    let value = if name == "measuredHeight" {
        length(t, c.attribute("uom"))
    } else if WHOLE.contains(&name) {
        t.parse::<i64>()
            .map(Value::from)
            .unwrap_or_else(|_| Value::from(t))
    } else {
        Value::from(t)
    };
    put(out, name.to_string(), value);
}

/// Generic attributes of CityGML 1.0/2.0 (`gen:stringAttribute name="N"` with `gen:value`, sets) and 3.0
/// (`gen:genericAttribute` holding a `gen:StringAttribute` … with `gen:name` and `gen:value`); a set's members are
/// named `SET.NAME`.
fn generic(c: Node, prefix: &str, out: &mut Map<String, Value>) {
    let (element, name) = match c.tag_name().name() {
        "genericAttribute" => match c.first_element_child() {
            Some(inner) => (inner, child_text(inner, "name")),
            None => return,
        },
        _ => (c, c.attribute("name").map(str::to_string)),
    };
    let Some(name) = name else { return };
    let key = format!("{prefix}{name}");
    let kind = element.tag_name().name();
    if kind.eq_ignore_ascii_case("genericAttributeSet") {
        let inner_prefix = format!("{key}.");
        let holder = element
            .children()
            .find(|x| x.is_element() && x.tag_name().name() == "value")
            .unwrap_or(element);
        for m in holder.children().filter(Node::is_element) {
            if m.tag_name().name() != "name" {
                generic(m, &inner_prefix, out);
            }
        }
        return;
    }
    let Some(v) = element
        .children()
        .find(|x| x.is_element() && x.tag_name().name() == "value")
    else {
        return;
    };
    let t = text_of(v)
        .as_deref()
        .map(str::trim)
        .unwrap_or("")
        .to_string();
    let value = match kind.to_ascii_lowercase().as_str() {
        "intattribute" => t
            .parse::<i64>()
            .map(Value::from)
            .unwrap_or_else(|_| Value::from(t)),
        "doubleattribute" | "measureattribute" => t
            .parse::<f64>()
            .ok()
            .and_then(|x| serde_json::Number::from_f64(x).map(Value::Number))
            .unwrap_or_else(|| Value::from(t)),
        _ => Value::from(t),
    };
    put(out, key, value);
}

fn child_text(n: Node, name: &str) -> Option<String> {
    n.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
        .and_then(text_of)
        .map(|t| t.trim().to_string())
}

/// Sets an attribute; a name given again (several `gml:name`s) keeps every value, joined with "; ".
fn put(out: &mut Map<String, Value>, key: String, value: Value) {
    let text = |v: &Value| match v {
        Value::String(t) => t.clone(),
        v => v.to_string(),
    };
    match out.get_mut(&key) {
        Some(old) => *old = Value::from(format!("{}; {}", text(old), text(&value))),
        None => {
            out.insert(key, value);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(body: &str) -> String {
        format!(
            "<CityModel xmlns=\"http://www.opengis.net/citygml/1.0\" xmlns:bldg=\"http://www.opengis.net/citygml/building/1.0\" \
             xmlns:tex=\"http://www.opengis.net/citygml/texturedsurface/1.0\" xmlns:gml=\"http://www.opengis.net/gml\" \
             xmlns:xlink=\"http://www.w3.org/1999/xlink\"><cityObjectMember><bldg:Building gml:id=\"B\">{body}\
             </bldg:Building></cityObjectMember></CityModel>"
        )
    }

    #[test]
    fn a_textured_surface_is_its_base_surface_turned_as_its_orientation_says() {
        // A ground surface whose ring is listed counter-clockwise seen from above (facing up), turned by the
        // TexturedSurface's "-" to face down, out of the building, as a ground surface does.
        let text = model(
            "<bldg:boundedBy><bldg:GroundSurface><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>\
             <tex:TexturedSurface orientation=\"-\"><gml:baseSurface><gml:Polygon><gml:exterior><gml:LinearRing>\
             <gml:posList>0 0 0 10 0 0 10 10 0 0 10 0 0 0 0</gml:posList></gml:LinearRing></gml:exterior>\
             </gml:Polygon></gml:baseSurface></tex:TexturedSurface></gml:surfaceMember></gml:MultiSurface>\
             </bldg:lod2MultiSurface></bldg:GroundSurface></bldg:boundedBy>\
             <bldg:boundedBy><bldg:RoofSurface><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>\
             <gml:Polygon><gml:exterior><gml:LinearRing><gml:posList>0 0 5 10 0 5 10 10 5 0 10 5 0 0 5</gml:posList>\
             </gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface>\
             </bldg:RoofSurface></bldg:boundedBy>",
        );
        let gml = read_text(&text, "t.gml", None, None).unwrap();
        let f = &gml.doc.features[0];
        assert!(f.skip.is_none(), "{:?}", f.skip);
        assert!(f.repairs.is_empty(), "{:?}", f.repairs);
        assert_eq!(
            f.polygons[0][0],
            vec![[0.0, 10.0], [10.0, 10.0], [10.0, 0.0], [0.0, 0.0]]
        );
        assert_eq!((f.footprint_min_z, f.top_z), (Some(0.0), Some(5.0)));
    }

    /// A gml:Ring of curve members (as FME and ArcGIS write some polygons) is the same ring as its LinearRing: a
    /// LineString and a Curve of two LineStringSegments, one by reference, joined end to start; an arc is refused with
    /// its name.
    #[test]
    fn a_ring_of_curve_members_is_read_as_its_linear_ring() {
        let ground = |exterior: &str| {
            model(&format!(
                "<bldg:boundedBy><bldg:GroundSurface><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>\
                 <gml:Polygon><gml:exterior>{exterior}</gml:exterior></gml:Polygon></gml:surfaceMember>\
                 </gml:MultiSurface></bldg:lod2MultiSurface></bldg:GroundSurface></bldg:boundedBy>\
                 <bldg:boundedBy><bldg:RoofSurface><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>\
                 <gml:Polygon><gml:exterior><gml:LinearRing><gml:posList>0 0 5 10 0 5 10 10 5 0 10 5 0 0 5</gml:posList>\
                 </gml:LinearRing></gml:exterior></gml:Polygon></gml:surfaceMember></gml:MultiSurface>\
                 </bldg:lod2MultiSurface></bldg:RoofSurface></bldg:boundedBy>\
                 <gml:LineString gml:id=\"l3\"><gml:posList>10 10 0 10 0 0 0 0 0</gml:posList></gml:LineString>"
            ))
        };
        let linear = read_text(
            &ground("<gml:LinearRing><gml:posList>0 0 0 0 10 0 10 10 0 10 0 0 0 0 0</gml:posList></gml:LinearRing>"),
            "t.gml",
            None,
            None,
        )
        .unwrap();
        let curves = read_text(
            &ground(
                "<gml:Ring><gml:curveMember><gml:LineString><gml:posList>0 0 0 0 10 0</gml:posList></gml:LineString>\
                 </gml:curveMember><gml:curveMember><gml:Curve><gml:segments><gml:LineStringSegment>\
                 <gml:posList>0 10 0 10 10 0</gml:posList></gml:LineStringSegment></gml:segments></gml:Curve>\
                 </gml:curveMember><gml:curveMember xlink:href=\"#l3\"/></gml:Ring>",
            ),
            "t.gml",
            None,
            None,
        )
        .unwrap();
        let (a, b) = (&linear.doc.features[0], &curves.doc.features[0]);
        assert!(
            a.skip.is_none() && b.skip.is_none(),
            "{:?} {:?}",
            a.skip,
            b.skip
        );
        assert_eq!(a.polygons, b.polygons);
        assert_eq!(a.polygons[0][0].len(), 4, "{:?}", a.polygons);
        assert_eq!((b.footprint_min_z, b.top_z), (Some(0.0), Some(5.0)));
        let arc = read_text(
            &ground(
                "<gml:Ring><gml:curveMember><gml:Curve><gml:segments><gml:Arc><gml:posList>0 0 0 5 5 0 10 0 0\
                 </gml:posList></gml:Arc></gml:segments></gml:Curve></gml:curveMember></gml:Ring>",
            ),
            "t.gml",
            None,
            None,
        )
        .unwrap();
        let f = &arc.doc.features[0];
        let why = format!("{:?} {:?}", f.skip, f.repairs);
        assert!(why.contains("Arc"), "{why}");
    }

    #[test]
    fn srs_names_as_cities_write_them() {
        let name = |s: &str| match declared_crs(s).0 {
            DeclaredCrs::Name(n) => Crs::parse(&n).map(|c| c.label).unwrap_or(n),
            DeclaredCrs::NotUnderstood { detail, .. } => format!("?{detail}"),
        };
        assert_eq!(
            name("urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::7837"),
            "EPSG:25832"
        );
        assert_eq!(
            name("urn:adv:crs:ETRS89_UTM32*DE_DHHN2016_NH"),
            "EPSG:25832"
        );
        assert_eq!(name("urn:adv:crs:DE_DHDN_3GK3*DE_DHHN92_NH"), "EPSG:31467");
        assert_eq!(name("CH1903+"), "EPSG:2056");
        assert_eq!(name("CH1903"), "EPSG:21781");
        assert_eq!(
            name("http://www.opengis.net/def/crs/EPSG/0/6697"),
            "EPSG:6697"
        );
        assert_eq!(name("EPSG:7415"), "EPSG:7415 (horizontal EPSG:28992)");
        assert!(name("urn:adv:crs:Somewhere").starts_with('?'));
        // Latitude first for EPSG's geographic CRSs only, unless the data says otherwise.
        assert!(latitude_first("urn:ogc:def:crs:EPSG::4326", Some(52.0)).0);
        assert!(!latitude_first("urn:ogc:def:crs:EPSG::4326", Some(139.0)).0);
        assert!(!latitude_first("urn:ogc:def:crs:OGC:1.3:CRS84", Some(52.0)).0);
        assert!(!latitude_first("EPSG:28992", Some(52.0)).0);
    }

    #[test]
    fn units_of_measure() {
        for (uom, m) in [
            (None, 1.0),
            (Some("#m"), 1.0),
            (Some("urn:adv:uom:m"), 1.0),
            (Some("urn:ogc:def:uom:UCUM::[ft_i]"), 0.3048),
            (Some("ft"), 0.3048),
            (Some("[ft_us]"), 1200.0 / 3937.0),
            (Some("cm"), 0.01),
        ] {
            assert_eq!(metres_per(uom), Some(m), "{uom:?}");
        }
        assert_eq!(metres_per(Some("furlong")), None);
    }
}
