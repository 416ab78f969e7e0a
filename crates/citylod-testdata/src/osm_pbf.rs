//! A writer of OpenStreetMap PBF files for tests, written from the format's description
//! (wiki.openstreetmap.org/wiki/PBF_Format): an OSMHeader blob, then one OSMData blob of nodes (dense or plain), one
//! of ways and one of relations, each raw or zlib-compressed.

use std::io::Write;

/// A node: id, lon°, lat°, tags.
pub struct Node {
    pub id: i64,
    pub lon: f64,
    pub lat: f64,
    pub tags: Vec<(String, String)>,
}

pub struct Way {
    pub id: i64,
    pub refs: Vec<i64>,
    pub tags: Vec<(String, String)>,
}

/// A relation member: `'n'`, `'w'` or `'r'`, its id, its role.
pub struct Relation {
    pub id: i64,
    pub members: Vec<(char, i64, String)>,
    pub tags: Vec<(String, String)>,
}

#[derive(Default)]
pub struct OsmData {
    pub nodes: Vec<Node>,
    pub ways: Vec<Way>,
    pub relations: Vec<Relation>,
}

/// How to write: dense or plain nodes, zlib or raw blobs, node locations on the ways too (and then no node blob),
/// the header's required features (`OsmSchema-V0.6` and `DenseNodes` when empty).
#[derive(Default, Clone)]
pub struct PbfOptions {
    pub plain_nodes: bool,
    pub raw_blobs: bool,
    pub locations_on_ways: bool,
    pub required_features: Vec<String>,
    /// Unpacked repeated fields (one field per number), which readers must accept as well.
    pub unpacked: bool,
}

/// `[(key, value)]` from `&str` pairs.
pub fn tags(t: &[(&str, &str)]) -> Vec<(String, String)> {
    t.iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

fn int_field(out: &mut Vec<u8>, n: u32, v: u64) {
    varint(out, u64::from(n) << 3);
    varint(out, v);
}

fn bytes_field(out: &mut Vec<u8>, n: u32, b: &[u8]) {
    varint(out, (u64::from(n) << 3) | 2);
    varint(out, b.len() as u64);
    out.extend_from_slice(b);
}

fn repeated(out: &mut Vec<u8>, n: u32, vs: &[u64], unpacked: bool) {
    if vs.is_empty() {
        return;
    }
    if unpacked {
        for &v in vs {
            int_field(out, n, v);
        }
    } else {
        let mut packed = Vec::new();
        for &v in vs {
            varint(&mut packed, v);
        }
        bytes_field(out, n, &packed);
    }
}

fn deltas(vs: impl Iterator<Item = i64>) -> Vec<u64> {
    let mut last = 0i64;
    vs.map(|v| {
        let d = zigzag(v - last);
        last = v;
        d
    })
    .collect()
}

fn nano(deg: f64) -> i64 {
    (deg * 1e7).round() as i64
}

/// The strings of a block, index 0 empty as the format wants.
#[derive(Default)]
struct Strings(Vec<String>);

impl Strings {
    fn id(&mut self, s: &str) -> u64 {
        if self.0.is_empty() {
            self.0.push(String::new());
        }
        match self.0.iter().position(|x| x == s) {
            Some(i) if i > 0 => i as u64,
            _ => {
                self.0.push(s.to_string());
                (self.0.len() - 1) as u64
            }
        }
    }

    fn block(&self, group: &[u8]) -> Vec<u8> {
        let mut table = Vec::new();
        for s in &self.0 {
            bytes_field(&mut table, 1, s.as_bytes());
        }
        let mut b = Vec::new();
        bytes_field(&mut b, 1, &table);
        bytes_field(&mut b, 2, group);
        b
    }
}

fn blob(out: &mut Vec<u8>, kind: &str, data: &[u8], raw: bool) {
    let mut blob = Vec::new();
    if raw {
        bytes_field(&mut blob, 1, data);
    } else {
        int_field(&mut blob, 2, data.len() as u64);
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(data).unwrap();
        bytes_field(&mut blob, 3, &z.finish().unwrap());
    }
    let mut header = Vec::new();
    bytes_field(&mut header, 1, kind.as_bytes());
    int_field(&mut header, 3, blob.len() as u64);
    out.extend_from_slice(&(header.len() as u32).to_be_bytes());
    out.extend_from_slice(&header);
    out.extend_from_slice(&blob);
}

/// A way's or relation's message begun: its id (int64) and tags (keys and values in the block's strings).
fn id_and_tags(s: &mut Strings, id: i64, tags: &[(String, String)], unpacked: bool) -> Vec<u8> {
    let mut m = Vec::new();
    int_field(&mut m, 1, id as u64);
    let keys: Vec<u64> = tags.iter().map(|(k, _)| s.id(k)).collect();
    let vals: Vec<u64> = tags.iter().map(|(_, v)| s.id(v)).collect();
    repeated(&mut m, 2, &keys, unpacked);
    repeated(&mut m, 3, &vals, unpacked);
    m
}

/// The PBF bytes of `d`.
pub fn write_pbf(d: &OsmData, o: &PbfOptions) -> Vec<u8> {
    let mut out = Vec::new();
    let mut header = Vec::new();
    let required: Vec<String> = if o.required_features.is_empty() {
        vec!["OsmSchema-V0.6".into(), "DenseNodes".into()]
    } else {
        o.required_features.clone()
    };
    for f in &required {
        bytes_field(&mut header, 4, f.as_bytes());
    }
    if o.locations_on_ways {
        bytes_field(&mut header, 5, b"LocationsOnWays");
    }
    bytes_field(&mut header, 16, b"citylod-testdata");
    blob(&mut out, "OSMHeader", &header, o.raw_blobs);

    let u = o.unpacked;
    if !d.nodes.is_empty() && !o.locations_on_ways {
        let mut s = Strings::default();
        let mut group = Vec::new();
        if o.plain_nodes {
            for n in &d.nodes {
                let mut m = Vec::new();
                int_field(&mut m, 1, zigzag(n.id));
                let keys: Vec<u64> = n.tags.iter().map(|(k, _)| s.id(k)).collect();
                let vals: Vec<u64> = n.tags.iter().map(|(_, v)| s.id(v)).collect();
                repeated(&mut m, 2, &keys, u);
                repeated(&mut m, 3, &vals, u);
                int_field(&mut m, 8, zigzag(nano(n.lat)));
                int_field(&mut m, 9, zigzag(nano(n.lon)));
                bytes_field(&mut group, 1, &m);
            }
        } else {
            let mut m = Vec::new();
            repeated(&mut m, 1, &deltas(d.nodes.iter().map(|n| n.id)), u);
            repeated(&mut m, 8, &deltas(d.nodes.iter().map(|n| nano(n.lat))), u);
            repeated(&mut m, 9, &deltas(d.nodes.iter().map(|n| nano(n.lon))), u);
            if d.nodes.iter().any(|n| !n.tags.is_empty()) {
                let mut kv = Vec::new();
                for n in &d.nodes {
                    for (k, v) in &n.tags {
                        kv.push(s.id(k));
                        kv.push(s.id(v));
                    }
                    kv.push(0);
                }
                repeated(&mut m, 10, &kv, u);
            }
            bytes_field(&mut group, 2, &m);
        }
        blob(&mut out, "OSMData", &s.block(&group), o.raw_blobs);
    }
    if !d.ways.is_empty() {
        let mut s = Strings::default();
        let mut group = Vec::new();
        for w in &d.ways {
            let mut m = id_and_tags(&mut s, w.id, &w.tags, u);
            repeated(&mut m, 8, &deltas(w.refs.iter().copied()), u);
            if o.locations_on_ways {
                // A node not in the data gets osmium's undefined location (i32::MIN in both).
                let undefined = (i64::from(i32::MIN), i64::from(i32::MIN));
                let at = |r: &i64| {
                    d.nodes
                        .iter()
                        .find(|n| n.id == *r)
                        .map_or(undefined, |n| (nano(n.lat), nano(n.lon)))
                };
                let pts: Vec<(i64, i64)> = w.refs.iter().map(at).collect();
                repeated(&mut m, 9, &deltas(pts.iter().map(|p| p.0)), u);
                repeated(&mut m, 10, &deltas(pts.iter().map(|p| p.1)), u);
            }
            bytes_field(&mut group, 3, &m);
        }
        blob(&mut out, "OSMData", &s.block(&group), o.raw_blobs);
    }
    if !d.relations.is_empty() {
        let mut s = Strings::default();
        let mut group = Vec::new();
        for r in &d.relations {
            let mut m = id_and_tags(&mut s, r.id, &r.tags, u);
            let roles: Vec<u64> = r.members.iter().map(|(_, _, role)| s.id(role)).collect();
            repeated(&mut m, 8, &roles, u);
            repeated(&mut m, 9, &deltas(r.members.iter().map(|m| m.1)), u);
            let types: Vec<u64> = r
                .members
                .iter()
                .map(|(t, _, _)| match t {
                    'n' => 0,
                    'w' => 1,
                    _ => 2,
                })
                .collect();
            repeated(&mut m, 10, &types, u);
            bytes_field(&mut group, 4, &m);
        }
        blob(&mut out, "OSMData", &s.block(&group), o.raw_blobs);
    }
    out
}
