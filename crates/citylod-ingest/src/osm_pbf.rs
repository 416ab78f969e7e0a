//! The OpenStreetMap PBF format (wiki.openstreetmap.org/wiki/PBF_Format), decoded field by field: a sequence of
//! blobs, each a 4-byte big-endian length, a `BlobHeader` and a `Blob` (raw or zlib-compressed) holding a
//! `HeaderBlock` or a `PrimitiveBlock` of nodes (plain or dense, delta-coded), ways (node references delta-coded,
//! locations too when the file has `LocationsOnWays`) and relations.
//!
//! Read in three passes, each decompressing the blocks again (so no more than one block per thread is held): the
//! relations tagged as buildings and the ways they name; the ways wanted and those members; the nodes those ways use.
//! Tags are looked at in the block's string table and copied only for what is kept.

use crate::osm::{
    building_tags, member_ways, needed_nodes, wanted_way, Gathered, Member, MemberKind, Relation,
    Want, Way, MAX_MEMBERS, MAX_WAY_NODES,
};
use rayon::prelude::*;
use std::borrow::Cow;
use std::collections::HashSet;
use std::io::Read;

/// The format's limits: a BlobHeader is at most 64 KiB, a Blob's data at most 32 MiB.
const MAX_BLOB_HEADER: usize = 64 * 1024;
const MAX_BLOB: usize = 32 * 1024 * 1024;
/// More tags than any real object has; an element with more makes the file refused (a memory guard).
const MAX_TAGS: usize = 10_000;

type Tags<'a> = Vec<(Cow<'a, str>, Cow<'a, str>)>;

/// What `want` needs from a PBF file.
pub(crate) fn gather(bytes: &[u8], want: Want) -> Result<Gathered, String> {
    let file = File::open(bytes)?;
    let relations: Vec<Relation> = match want {
        Want::Buildings => file.per_block(|b, out| b.relations(out))?,
        Want::Streets => Vec::new(),
    };
    let members = member_ways(&relations);
    let ways: Vec<Way> =
        file.per_block(|b, out| b.ways(out, |id, tags| wanted_way(want, id, tags, &members)))?;
    let needed = needed_nodes(&ways);
    let nodes: Vec<NodeRead> = file.per_block(|b, out| b.nodes(out, &needed, want))?;
    let mut g = Gathered {
        ways,
        relations,
        ..Default::default()
    };
    g.located.reserve(needed.len());
    for n in nodes {
        match n {
            NodeRead::Location(id, at) => {
                g.located.insert(id, at);
            }
            NodeRead::Building(id, tags) => g.point_buildings.push((id, tags)),
        }
    }
    if file.locations_on_ways {
        g.notes
            .push("node locations read from the ways (LocationsOnWays)".into());
    }
    if !file.skipped.is_empty() {
        g.notes.push(format!(
            "{} blob(s) of a type this reader does not know skipped (only OSMHeader and OSMData are read; the PBF \
             format lets readers skip others), so any objects in them are not read: {}",
            file.skipped.len(),
            crate::geojson::listing(&file.skipped)
        ));
    }
    Ok(g)
}

struct File<'a> {
    /// The data blobs, in file order.
    blobs: Vec<Blob<'a>>,
    locations_on_ways: bool,
    /// The blobs of a type this reader does not know, skipped (as the format allows), for the file's notes: each
    /// as "blob N (at byte B) of type T".
    skipped: Vec<String>,
}

/// A data blob: where it is (its number among all blobs and its byte offset, for messages) and its data.
struct Blob<'a> {
    index: usize,
    at: usize,
    data: BlobData<'a>,
}

enum BlobData<'a> {
    Raw(&'a [u8]),
    Zlib(&'a [u8], usize),
}

impl<'a> File<'a> {
    fn open(bytes: &'a [u8]) -> Result<Self, String> {
        let mut pos = 0usize;
        let mut blobs = Vec::new();
        let mut header = None;
        let mut skipped = Vec::new();
        let mut index = 0usize;
        let not_pbf = || {
            "not an OpenStreetMap PBF file (it does not start with an OSMHeader blob)".to_string()
        };
        while pos < bytes.len() {
            let at = pos;
            let cut =
                || format!("blob {index} (at byte {at}): the file ends inside it (cut short)");
            let len_bytes: [u8; 4] = bytes
                .get(pos..pos + 4)
                .ok_or_else(cut)?
                .try_into()
                .expect("4 bytes");
            let header_len = u32::from_be_bytes(len_bytes) as usize;
            if header_len > MAX_BLOB_HEADER {
                return Err(if index == 0 {
                    not_pbf()
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
                match f.map_err(|e| {
                    if index == 0 {
                        not_pbf()
                    } else {
                        format!("blob {index} (at byte {at}): its header: {e}")
                    }
                })? {
                    (1, Val::Bytes(b)) => kind = Some(b),
                    (3, Val::Int(n)) => size = Some(n as usize),
                    _ => {}
                }
            }
            let (Some(kind), Some(size)) = (kind, size) else {
                return Err(if index == 0 {
                    not_pbf()
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
            let blob = Blob {
                index,
                at,
                data: BlobData::of(data)
                    .map_err(|e| format!("blob {index} (at byte {at}): {e}"))?,
            };
            match kind {
                b"OSMHeader" if index == 0 => {
                    let data = blob.data()?;
                    header = Some(read_header(&data)?);
                }
                b"OSMHeader" => {
                    return Err(format!("blob {index} (at byte {at}): a second OSMHeader"))
                }
                _ if index == 0 => return Err(not_pbf()),
                b"OSMData" => blobs.push(blob),
                // Other blob types are allowed by the format and skipped by readers; said in the notes.
                _ => {
                    // The type as text, its first 40 characters (a header may be 64 KiB).
                    let text = String::from_utf8_lossy(kind);
                    let mut name: String = text.chars().take(40).collect();
                    if text.chars().nth(40).is_some() {
                        name.push('…');
                    }
                    skipped.push(format!("blob {index} (at byte {at}) of type {name:?}"));
                }
            }
            index += 1;
        }
        let Some(locations_on_ways) = header else {
            return Err("an empty file: no OSMHeader".into());
        };
        Ok(File {
            blobs,
            locations_on_ways,
            skipped,
        })
    }

    /// Runs `f` on every block in parallel, each decompressed for this pass, and concatenates what it gives in
    /// block order.
    fn per_block<T: Send>(
        &self,
        f: impl Fn(&Block, &mut Vec<T>) -> Result<(), String> + Sync,
    ) -> Result<Vec<T>, String> {
        let parts: Vec<Vec<T>> = self
            .blobs
            .par_iter()
            .map(|blob| {
                let data = blob.data()?;
                let place = |e: String| format!("blob {} (at byte {}): {e}", blob.index, blob.at);
                let block = Block::new(&data).map_err(place)?;
                let mut out = Vec::new();
                f(&block, &mut out).map_err(place)?;
                Ok(out)
            })
            .collect::<Result<_, String>>()?;
        Ok(parts.into_iter().flatten().collect())
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

impl<'a> BlobData<'a> {
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
            (Some(r), None, _) => Ok(BlobData::Raw(r)),
            (None, Some(z), Some(n)) if n <= MAX_BLOB => Ok(BlobData::Zlib(z, n)),
            (None, Some(_), Some(n)) => {
                Err(format!("{n} bytes uncompressed, over the format's 32 MiB"))
            }
            (None, Some(_), None) => Err("compressed data without its raw size".into()),
            _ => Err("no data (or both raw and compressed)".into()),
        }
    }
}

impl Blob<'_> {
    fn data(&self) -> Result<Cow<'_, [u8]>, String> {
        let place = |e: String| format!("blob {} (at byte {}): {e}", self.index, self.at);
        match self.data {
            BlobData::Raw(r) => Ok(Cow::Borrowed(r)),
            BlobData::Zlib(z, n) => {
                let mut out = Vec::with_capacity(n);
                flate2::read::ZlibDecoder::new(z)
                    .take(n as u64 + 1)
                    .read_to_end(&mut out)
                    .map_err(|e| place(format!("cannot decompress: {e}")))?;
                match out.len() {
                    m if m > n => Err(place(format!(
                        "decompresses to more than the {n} bytes its header says"
                    ))),
                    m if m < n => Err(place(format!(
                        "decompresses to {m} bytes, not the {n} its header says"
                    ))),
                    _ => Ok(Cow::Owned(out)),
                }
            }
        }
    }
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

fn owned(tags: Tags) -> Vec<(String, String)> {
    tags.into_iter()
        .map(|(k, v)| (k.into_owned(), v.into_owned()))
        .collect()
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

    fn string(&self, i: u64) -> Result<Cow<'a, str>, String> {
        let s = self.strings.get(i as usize).ok_or_else(|| {
            format!(
                "string {i} is not in the block's table of {}",
                self.strings.len()
            )
        })?;
        Ok(String::from_utf8_lossy(s))
    }

    fn tags(&self, keys: &[u64], vals: &[u64]) -> Result<Tags<'a>, String> {
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
                .clamp(i64::MIN as i128 + 1, i64::MAX as i128) as i64
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
                    (2, v) => numbers(v, &mut keys, MAX_TAGS)?,
                    (3, v) => numbers(v, &mut vals, MAX_TAGS)?,
                    (9, v) => ids.push(v),
                    (10, v) => types.push(v),
                    _ => {}
                }
            }
            let tags = self.tags(&keys, &vals)?;
            if !building_tags(&tags) {
                return Ok(());
            }
            let count = counted(&ids);
            if count != counted(&types) {
                return Err(format!(
                    "relation {id}: {count} member ids for {} member types",
                    counted(&types)
                ));
            }
            let mut members = Vec::new();
            if count <= MAX_MEMBERS {
                let mut member = 0i64;
                for (d, t) in Numbers::new(&ids).zip(Numbers::new(&types)) {
                    member = member.wrapping_add(zigzag(d?));
                    let kind = match t? {
                        0 => MemberKind::Node,
                        1 => MemberKind::Way,
                        2 => MemberKind::Relation,
                        other => return Err(format!("relation {id}: member type {other}")),
                    };
                    members.push(Member { id: member, kind });
                }
            }
            out.push(Relation {
                id,
                tags: owned(tags),
                members,
                oversized: (count > MAX_MEMBERS).then_some(count),
            });
            Ok(())
        })
    }

    fn ways(
        &self,
        out: &mut Vec<Way>,
        keep: impl Fn(i64, &[(Cow<str>, Cow<str>)]) -> bool,
    ) -> Result<(), String> {
        self.group_items(3, |data| {
            let (mut id, mut keys, mut vals, mut refs, mut lats, mut lons) =
                (0, vec![], vec![], vec![], vec![], vec![]);
            for f in Fields::new(data) {
                match f? {
                    (1, Val::Int(n)) => id = n as i64,
                    (2, v) => numbers(v, &mut keys, MAX_TAGS)?,
                    (3, v) => numbers(v, &mut vals, MAX_TAGS)?,
                    (8, v) => refs.push(v),
                    (9, v) => lats.push(v),
                    (10, v) => lons.push(v),
                    _ => {}
                }
            }
            let tags = self.tags(&keys, &vals)?;
            if !keep(id, &tags) {
                return Ok(());
            }
            let count = counted(&refs);
            if count > MAX_WAY_NODES {
                out.push(Way {
                    id,
                    refs: Vec::new(),
                    tags: owned(tags),
                    locations: None,
                    oversized: Some(count),
                });
                return Ok(());
            }
            let refs = deltas(&refs)?;
            let locations = if lats.is_empty() && lons.is_empty() {
                None
            } else if counted(&lats) == refs.len() && counted(&lons) == refs.len() {
                let (lats, lons) = (deltas(&lats)?, deltas(&lons)?);
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
                    counted(&lats),
                    counted(&lons)
                ));
            };
            out.push(Way {
                id,
                refs,
                tags: owned(tags),
                locations,
                oversized: None,
            });
            Ok(())
        })
    }

    fn nodes(
        &self,
        out: &mut Vec<NodeRead>,
        needed: &HashSet<i64>,
        want: Want,
    ) -> Result<(), String> {
        let buildings = want == Want::Buildings;
        // Plain nodes.
        self.group_items(1, |data| {
            let (mut id, mut keys, mut vals, mut lat, mut lon) = (0, vec![], vec![], 0, 0);
            for f in Fields::new(data) {
                match f? {
                    (1, Val::Int(n)) => id = zigzag(n),
                    (2, v) => numbers(v, &mut keys, MAX_TAGS)?,
                    (3, v) => numbers(v, &mut vals, MAX_TAGS)?,
                    (8, Val::Int(n)) => lat = zigzag(n),
                    (9, Val::Int(n)) => lon = zigzag(n),
                    _ => {}
                }
            }
            if needed.contains(&id) {
                out.push(NodeRead::Location(id, self.at(lat, lon)));
            }
            if buildings && !keys.is_empty() {
                let tags = self.tags(&keys, &vals)?;
                if building_tags(&tags) {
                    out.push(NodeRead::Building(id, owned(tags)));
                }
            }
            Ok(())
        })?;
        // Dense nodes, read in step without collecting their columns.
        self.group_items(2, |data| {
            let (mut ids, mut lats, mut lons, mut kv) = (vec![], vec![], vec![], vec![]);
            for f in Fields::new(data) {
                match f? {
                    (1, v) => ids.push(v),
                    (8, v) => lats.push(v),
                    (9, v) => lons.push(v),
                    (10, v) => kv.push(v),
                    _ => {}
                }
            }
            let n = counted(&ids);
            if counted(&lats) != n || counted(&lons) != n {
                return Err(format!(
                    "dense nodes: {n} ids, {} latitudes, {} longitudes",
                    counted(&lats),
                    counted(&lons)
                ));
            }
            let (mut id, mut lat, mut lon) = (0i64, 0i64, 0i64);
            let mut kv = Numbers::new(&kv);
            for ((d_id, d_lat), d_lon) in Numbers::new(&ids)
                .zip(Numbers::new(&lats))
                .zip(Numbers::new(&lons))
            {
                id = id.wrapping_add(zigzag(d_id?));
                lat = lat.wrapping_add(zigzag(d_lat?));
                lon = lon.wrapping_add(zigzag(d_lon?));
                if needed.contains(&id) {
                    out.push(NodeRead::Location(id, self.at(lat, lon)));
                }
                // This node's tags: key, value pairs up to a 0 (none at all when the block has no tags).
                let (mut keys, mut vals) = (vec![], vec![]);
                while let Some(k) = kv.next() {
                    let k = k?;
                    if k == 0 {
                        break;
                    }
                    let v = kv
                        .next()
                        .ok_or_else(|| format!("dense node {id}: a tag key without its value"))??;
                    if keys.len() >= MAX_TAGS {
                        return Err(format!("dense node {id}: more than {MAX_TAGS} tags"));
                    }
                    keys.push(k);
                    vals.push(v);
                }
                if buildings && !keys.is_empty() {
                    let tags = self.tags(&keys, &vals)?;
                    if building_tags(&tags) {
                        out.push(NodeRead::Building(id, owned(tags)));
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

/// Delta-coded signed (zigzag) numbers of a repeated field, summed.
fn deltas(parts: &[Val]) -> Result<Vec<i64>, String> {
    let mut at = 0i64;
    Numbers::new(parts)
        .map(|d| {
            at = at.wrapping_add(zigzag(d?));
            Ok(at)
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

/// A small repeated number field (tag keys and values), packed or not, appended to `out`; more than `limit`
/// numbers make the block refused.
fn numbers(v: Val, out: &mut Vec<u64>, limit: usize) -> Result<(), String> {
    if out.len() + counted(&[v]) > limit {
        return Err(format!("more than {limit} tags on one element"));
    }
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

/// How many numbers the parts of a repeated field hold: a packed run has one per byte below 0x80 (a varint's last).
fn counted(parts: &[Val]) -> usize {
    parts
        .iter()
        .map(|p| match p {
            Val::Int(_) => 1,
            Val::Bytes(b) => b.iter().filter(|&&x| x < 0x80).count(),
        })
        .sum()
}

/// The numbers of a repeated field, packed runs and single values alike, in order, read as they are asked for.
struct Numbers<'p, 'a> {
    parts: &'p [Val<'a>],
    part: usize,
    pos: usize,
}

impl<'p, 'a> Numbers<'p, 'a> {
    fn new(parts: &'p [Val<'a>]) -> Self {
        Numbers {
            parts,
            part: 0,
            pos: 0,
        }
    }
}

impl Iterator for Numbers<'_, '_> {
    type Item = Result<u64, String>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            match self.parts.get(self.part)? {
                Val::Int(n) => {
                    self.part += 1;
                    return Some(Ok(*n));
                }
                Val::Bytes(b) if self.pos < b.len() => return Some(varint(b, &mut self.pos)),
                Val::Bytes(_) => {
                    self.part += 1;
                    self.pos = 0;
                }
            }
        }
    }
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
