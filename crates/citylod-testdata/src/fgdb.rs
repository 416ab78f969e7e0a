//! Dev-only: writes a File Geodatabase of one polygon feature class, byte by byte, with the minimum citylod's reader
//! needs (the catalog table and the feature class's `.gdbtable` and `.gdbtablx`; no system tables, indexes or
//! `GDB_Items`, so ArcGIS and GDAL would not list it). For benchmarks at sizes GDAL would take long to write, and
//! for tests that choose their bytes. The layout is the format's as citylod's reader documents it: rings are written
//! in the order and winding given (Esri's rule: outer rings clockwise), coordinates on a grid of `1 / xy_scale`.

use std::io::Write;
use std::path::Path;

/// One row: its rings (each closed by the caller, or not), height and name.
#[derive(Clone, Debug, Default)]
pub struct Row {
    pub rings: Vec<Vec<[f64; 2]>>,
    pub height: Option<f64>,
    pub name: Option<String>,
}

/// How the feature class is written.
#[derive(Clone, Debug)]
pub struct GdbOptions {
    /// The geometry field's spatial reference, Esri WKT (empty: none).
    pub wkt: String,
    pub origin: [f64; 2],
    /// Integer steps per unit (GDAL's default for projected CRSs: 10,000).
    pub xy_scale: f64,
    /// OBJECTIDs left without a row (deleted): their row index entries are 0.
    pub deleted: Vec<u64>,
}

impl Default for GdbOptions {
    fn default() -> Self {
        GdbOptions {
            wkt: String::new(),
            origin: [-2_147_483_647.0, -2_147_483_647.0],
            xy_scale: 10_000.0,
            deleted: Vec::new(),
        }
    }
}

/// The format's variable-length unsigned integer (7 bits a byte, low first).
pub fn varuint(out: &mut Vec<u8>, mut v: u64) {
    loop {
        let b = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            out.push(b);
            return;
        }
        out.push(b | 0x80);
    }
}

/// Its signed one: 6 bits and the sign in the first byte, then as [`varuint`].
pub fn varint(out: &mut Vec<u8>, v: i64) {
    let (sign, mut m) = (if v < 0 { 0x40 } else { 0 }, v.unsigned_abs());
    let first = (m & 0x3f) as u8 | sign;
    m >>= 6;
    if m == 0 {
        out.push(first);
        return;
    }
    out.push(first | 0x80);
    varuint(out, m);
}

fn utf16(out: &mut Vec<u8>, s: &str) {
    for u in s.encode_utf16() {
        out.extend_from_slice(&u.to_le_bytes());
    }
}

/// A field description: name, type byte, then what follows it.
fn field(out: &mut Vec<u8>, name: &str, kind: u8, rest: &[u8]) {
    out.push(name.encode_utf16().count() as u8);
    utf16(out, name);
    out.push(0);
    out.push(kind);
    out.extend_from_slice(rest);
}

/// A table file: its header, its field descriptions, then `rows` (each already a blob), with its row index.
fn table(fields: &[u8], count: u16, flags: u32, rows: &[Option<Vec<u8>>]) -> (Vec<u8>, Vec<u8>) {
    let mut desc = Vec::new();
    desc.extend_from_slice(&4u32.to_le_bytes());
    desc.extend_from_slice(&flags.to_le_bytes());
    desc.extend_from_slice(&count.to_le_bytes());
    desc.extend_from_slice(fields);
    desc.extend_from_slice(&[0xde, 0xad, 0xbe, 0xef]);
    let mut body = Vec::new();
    body.extend_from_slice(&(desc.len() as u32).to_le_bytes());
    body.extend_from_slice(&desc);
    let mut offsets = Vec::with_capacity(rows.len());
    let mut largest = 0usize;
    for row in rows {
        match row {
            Some(r) => {
                offsets.push(40 + body.len() as u64);
                body.extend_from_slice(&(r.len() as u32).to_le_bytes());
                body.extend_from_slice(r);
                largest = largest.max(r.len());
            }
            None => offsets.push(0),
        }
    }
    let mut t = Vec::with_capacity(40 + body.len());
    t.extend_from_slice(&3u32.to_le_bytes());
    t.extend_from_slice(&(rows.iter().flatten().count() as u32).to_le_bytes());
    t.extend_from_slice(&(largest.max(desc.len()) as u32).to_le_bytes());
    t.extend_from_slice(&5u32.to_le_bytes());
    t.extend_from_slice(&[0; 8]);
    t.extend_from_slice(&((40 + body.len()) as u64).to_le_bytes());
    t.extend_from_slice(&40u64.to_le_bytes());
    t.extend_from_slice(&body);
    let blocks = rows.len().div_ceil(1024);
    let mut x = Vec::with_capacity(32 + blocks * 1024 * 5);
    for v in [3u32, blocks as u32, rows.len() as u32, 5] {
        x.extend_from_slice(&v.to_le_bytes());
    }
    for k in 0..blocks * 1024 {
        let o = offsets.get(k).copied().unwrap_or(0);
        x.extend_from_slice(&o.to_le_bytes()[..5]);
    }
    for v in [0u32, blocks as u32, blocks as u32, 0] {
        x.extend_from_slice(&v.to_le_bytes());
    }
    (t, x)
}

/// Writes `rows` as feature class `layer` of the geodatabase folder `dir` (created; files in it replaced).
pub fn write_gdb(dir: &Path, layer: &str, rows: &[Row], opts: &GdbOptions) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let write = |name: &str, bytes: &[u8]| -> std::io::Result<()> {
        std::io::BufWriter::new(std::fs::File::create(dir.join(name))?).write_all(bytes)
    };
    // The catalog: the eight system tables ArcGIS numbers first, then the feature class as table 9.
    let mut fields = Vec::new();
    field(&mut fields, "ID", 6, &[4, 2]);
    let mut name_rest = 160u32.to_le_bytes().to_vec();
    name_rest.extend_from_slice(&[4, 0]);
    field(&mut fields, "Name", 4, &name_rest);
    field(&mut fields, "FileFormat", 1, &[4, 4, 0]);
    let system = [
        "GDB_SystemCatalog",
        "GDB_DBTune",
        "GDB_SpatialRefs",
        "GDB_Items",
        "GDB_ItemTypes",
        "GDB_ItemRelationships",
        "GDB_ItemRelationshipTypes",
        "GDB_ReplicaLog",
    ];
    let catalog_rows: Vec<Option<Vec<u8>>> = system
        .iter()
        .copied()
        .chain(std::iter::once(layer))
        .enumerate()
        .map(|(k, n)| {
            let mut r = Vec::new();
            varuint(&mut r, n.len() as u64);
            r.extend_from_slice(n.as_bytes());
            r.extend_from_slice(&(if k == 7 { 2i32 } else { 0 }).to_le_bytes());
            Some(r)
        })
        .collect();
    let (t, x) = table(&fields, 3, 0x100, &catalog_rows);
    write("a00000001.gdbtable", &t)?;
    write("a00000001.gdbtablx", &x)?;

    // The feature class: OBJECTID, SHAPE, height (double), name (text); the last three nullable.
    let mut fields = Vec::new();
    field(&mut fields, "OBJECTID", 6, &[4, 2]);
    let mut shape = vec![0u8, 7];
    let wkt_bytes = opts.wkt.encode_utf16().count() * 2;
    shape.extend_from_slice(&(wkt_bytes as u16).to_le_bytes());
    utf16(&mut shape, &opts.wkt);
    shape.push(1); // no M or Z origins
    for v in [opts.origin[0], opts.origin[1], opts.xy_scale, 0.001] {
        shape.extend_from_slice(&v.to_le_bytes());
    }
    for _ in 0..4 {
        shape.extend_from_slice(&f64::NAN.to_le_bytes());
    }
    shape.push(0);
    shape.extend_from_slice(&1u32.to_le_bytes());
    shape.extend_from_slice(&100.0f64.to_le_bytes());
    field(&mut fields, "SHAPE", 7, &shape);
    field(&mut fields, "height", 3, &[8, 5, 0]);
    let mut text = 255u32.to_le_bytes().to_vec();
    text.extend_from_slice(&[5, 0]);
    field(&mut fields, "name", 4, &text);

    let grid = |v: f64, o: f64| ((v - o) * opts.xy_scale).round() as i64;
    let mut blobs: Vec<Option<Vec<u8>>> = Vec::with_capacity(rows.len());
    for (k, row) in rows.iter().enumerate() {
        let oid = k as u64 + 1;
        if opts.deleted.contains(&oid) {
            blobs.push(None);
            continue;
        }
        let mut r = Vec::new();
        let points: usize = row.rings.iter().map(Vec::len).sum();
        // Null flags: SHAPE, height, name (1 = null), unused bits set.
        let mut nulls = 0xf8u8;
        if points == 0 {
            nulls |= 1;
        }
        if row.height.is_none() {
            nulls |= 2;
        }
        if row.name.is_none() {
            nulls |= 4;
        }
        r.push(nulls);
        if points > 0 {
            let mut g = Vec::new();
            varuint(&mut g, 5);
            varuint(&mut g, points as u64);
            varuint(&mut g, row.rings.len() as u64);
            let all = row.rings.iter().flatten();
            let (mut lo, mut hi) = ([i64::MAX; 2], [i64::MIN; 2]);
            for p in all.clone() {
                let q = [grid(p[0], opts.origin[0]), grid(p[1], opts.origin[1])];
                for a in 0..2 {
                    lo[a] = lo[a].min(q[a]);
                    hi[a] = hi[a].max(q[a]);
                }
            }
            varuint(&mut g, lo[0] as u64);
            varuint(&mut g, lo[1] as u64);
            varuint(&mut g, (hi[0] - lo[0]) as u64);
            varuint(&mut g, (hi[1] - lo[1]) as u64);
            for ring in &row.rings[..row.rings.len() - 1] {
                varuint(&mut g, ring.len() as u64);
            }
            let mut last = [0i64; 2];
            for p in all {
                let q = [grid(p[0], opts.origin[0]), grid(p[1], opts.origin[1])];
                varint(&mut g, q[0] - last[0]);
                varint(&mut g, q[1] - last[1]);
                last = q;
            }
            varuint(&mut r, g.len() as u64);
            r.extend_from_slice(&g);
        }
        if let Some(h) = row.height {
            r.extend_from_slice(&h.to_le_bytes());
        }
        if let Some(n) = &row.name {
            varuint(&mut r, n.len() as u64);
            r.extend_from_slice(n.as_bytes());
        }
        blobs.push(Some(r));
    }
    let (t, x) = table(&fields, 4, 0x304, &blobs);
    write("a00000009.gdbtable", &t)?;
    write("a00000009.gdbtablx", &x)
}
