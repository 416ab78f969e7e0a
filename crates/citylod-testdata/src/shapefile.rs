//! Dev-only: writes Esri Shapefiles (`.shp`, `.shx`, `.dbf`, optional `.prj` / `.cpg`) byte by byte, so a reader's
//! tests see exactly the bytes they chose — broken ones included. Follows the Esri Shapefile Technical Description
//! (1998) and the dBase III table layout; nothing is validated or repaired (rings are neither closed nor reoriented).

use std::fmt::Display;
use std::path::{Path, PathBuf};

/// One record's geometry, written exactly as given (rings are written in the order and winding given, and NOT
/// closed automatically: the caller writes the closing point when it wants one).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Shape type 0: the record content is the shape type alone.
    Null,
    /// Shape type 1: x, y.
    Point([f64; 2]),
    /// Shape type 3: parts of x, y points.
    PolyLine(Vec<Vec<[f64; 2]>>),
    /// Shape type 5: parts = rings of x, y points.
    Polygon(Vec<Vec<[f64; 2]>>),
    /// Shape type 15: x, y, z per point; writes the Z range + Z array, then an M range + M array of zeros.
    PolygonZ(Vec<Vec<[f64; 3]>>),
    /// Shape type 25: x, y per point, then an M range + M array of zeros.
    PolygonM(Vec<Vec<[f64; 2]>>),
    /// Shape type 31: parts of a part type (0 triangle strip, 1 fan, 2 outer ring, 3 inner ring, 4 first ring, 5 ring,
    /// 6 triangles) and x, y, z points; writes the Z range + Z array, then an M range + M array of zeros.
    MultiPatch(Vec<(i32, Vec<[f64; 3]>)>),
    /// Any shape type with raw content bytes after the 4-byte shape type (for malformed records). The content
    /// length in words is `(4 + content.len()) / 2` rounded down, so an odd length misaligns the file on purpose.
    Raw {
        /// Written little-endian as the record's first 4 bytes.
        shape_type: i32,
        /// Everything after the shape type, verbatim.
        content: Vec<u8>,
    },
}

impl Shape {
    /// The shape type code this record starts with.
    pub fn shape_type(&self) -> i32 {
        match self {
            Shape::Null => 0,
            Shape::Point(_) => 1,
            Shape::PolyLine(_) => 3,
            Shape::Polygon(_) => 5,
            Shape::PolygonZ(_) => 15,
            Shape::PolygonM(_) => 25,
            Shape::MultiPatch(_) => 31,
            Shape::Raw { shape_type, .. } => *shape_type,
        }
    }

    /// The x, y of every point, in order (none for `Null` and `Raw`).
    fn xy(&self) -> Vec<[f64; 2]> {
        match self {
            Shape::Point(p) => vec![*p],
            Shape::PolyLine(parts) | Shape::Polygon(parts) | Shape::PolygonM(parts) => {
                parts.concat()
            }
            Shape::PolygonZ(parts) => parts.iter().flatten().map(|p| [p[0], p[1]]).collect(),
            Shape::MultiPatch(parts) => parts
                .iter()
                .flat_map(|(_, ps)| ps)
                .map(|p| [p[0], p[1]])
                .collect(),
            Shape::Null | Shape::Raw { .. } => Vec::new(),
        }
    }

    /// The z of every point (only `PolygonZ` and `MultiPatch` have any).
    fn zs(&self) -> Vec<f64> {
        match self {
            Shape::PolygonZ(parts) => parts.iter().flatten().map(|p| p[2]).collect(),
            Shape::MultiPatch(parts) => parts.iter().flat_map(|(_, ps)| ps).map(|p| p[2]).collect(),
            _ => Vec::new(),
        }
    }

    /// The record content as written after the 8-byte record header: shape type (LE), then the geometry.
    pub fn content(&self) -> Vec<u8> {
        let mut b = self.shape_type().to_le_bytes().to_vec();
        let xy = self.xy();
        let part_lens: Vec<usize> = match self {
            Shape::PolyLine(parts) | Shape::Polygon(parts) | Shape::PolygonM(parts) => {
                parts.iter().map(Vec::len).collect()
            }
            Shape::PolygonZ(parts) => parts.iter().map(Vec::len).collect(),
            Shape::MultiPatch(parts) => parts.iter().map(|(_, ps)| ps.len()).collect(),
            Shape::Point(p) => {
                put_f64s(&mut b, p);
                return b;
            }
            Shape::Null => return b,
            Shape::Raw { content, .. } => {
                b.extend_from_slice(content);
                return b;
            }
        };
        put_f64s(&mut b, &bbox(&xy));
        put_i32(&mut b, part_lens.len());
        put_i32(&mut b, xy.len());
        let mut start = 0;
        for len in part_lens {
            put_i32(&mut b, start);
            start += len;
        }
        if let Shape::MultiPatch(parts) = self {
            for (kind, _) in parts {
                b.extend(kind.to_le_bytes());
            }
        }
        xy.iter().for_each(|p| put_f64s(&mut b, p));
        if let Shape::PolygonZ(_) | Shape::MultiPatch(_) = self {
            put_measure(&mut b, &self.zs());
        }
        if let Shape::PolygonZ(_) | Shape::PolygonM(_) | Shape::MultiPatch(_) = self {
            put_measure(&mut b, &vec![0.0; xy.len()]);
        }
        b
    }
}

fn put_f64s(b: &mut Vec<u8>, vs: &[f64]) {
    vs.iter().for_each(|v| b.extend(v.to_le_bytes()));
}

fn put_i32(b: &mut Vec<u8>, v: usize) {
    b.extend(i32::try_from(v).expect("count over i32").to_le_bytes());
}

/// A byte length as big-endian 16-bit words (rounded down).
fn words_be(bytes: usize) -> [u8; 4] {
    i32::try_from(bytes / 2)
        .expect("over i32 words")
        .to_be_bytes()
}

fn u16_le(v: usize, what: &str) -> [u8; 2] {
    u16::try_from(v)
        .unwrap_or_else(|_| panic!("{what} over u16"))
        .to_le_bytes()
}

/// (min, max) of `vs`, or (0, 0) when empty.
fn range(vs: &[f64]) -> [f64; 2] {
    match vs.first() {
        None => [0.0; 2],
        Some(&v) => vs
            .iter()
            .fold([v, v], |[lo, hi], &v| [lo.min(v), hi.max(v)]),
    }
}

/// [xmin, ymin, xmax, ymax], or zeros when there are no points.
fn bbox(xy: &[[f64; 2]]) -> [f64; 4] {
    let [x0, x1] = range(&xy.iter().map(|p| p[0]).collect::<Vec<_>>());
    let [y0, y1] = range(&xy.iter().map(|p| p[1]).collect::<Vec<_>>());
    [x0, y0, x1, y1]
}

/// Range then values: the Z or M block of a Z / M shape.
fn put_measure(b: &mut Vec<u8>, vs: &[f64]) {
    put_f64s(b, &range(vs));
    put_f64s(b, vs);
}

/// The 100-byte main-file header shared by `.shp` and `.shx`, for a file of `file_bytes` bytes.
fn header(shapes: &[Shape], file_bytes: usize) -> Vec<u8> {
    let mut h = 9994i32.to_be_bytes().to_vec();
    h.extend([0; 20]);
    h.extend(words_be(file_bytes));
    h.extend(1000i32.to_le_bytes());
    let ty = shapes.iter().map(Shape::shape_type).find(|&t| t != 0);
    h.extend(ty.unwrap_or(0).to_le_bytes());
    let xy: Vec<_> = shapes.iter().flat_map(Shape::xy).collect();
    let zs: Vec<_> = shapes.iter().flat_map(Shape::zs).collect();
    put_f64s(&mut h, &bbox(&xy));
    put_f64s(&mut h, &range(&zs));
    put_f64s(&mut h, &[0.0, 0.0]); // M range: every M written is 0
    h
}

/// The `.shp` bytes: the 100-byte header (file code 9994 BE, file length in 16-bit words BE, version 1000 LE,
/// shape type LE = the first shape type that is not 0, else 0; the bounding box of all points, the Z range of all
/// z, the M range 0..0), then per record: record number (1-based) BE, content length in words BE, content.
pub fn shp_bytes(shapes: &[Shape]) -> Vec<u8> {
    let contents: Vec<Vec<u8>> = shapes.iter().map(Shape::content).collect();
    let len = 100 + contents.iter().map(|c| 8 + c.len()).sum::<usize>();
    let mut b = header(shapes, len);
    for (i, c) in contents.iter().enumerate() {
        b.extend((i as i32 + 1).to_be_bytes());
        b.extend(words_be(c.len()));
        b.extend_from_slice(c);
    }
    b
}

/// The `.shx` bytes: the same 100-byte header (with the `.shx` file length), then per record its offset in the
/// `.shp` (in words, pointing at the record header) BE and its content length in words BE.
pub fn shx_bytes(shapes: &[Shape]) -> Vec<u8> {
    let mut b = header(shapes, 100 + 8 * shapes.len());
    let mut offset = 100;
    for s in shapes {
        let len = s.content().len();
        b.extend(words_be(offset));
        b.extend(words_be(len));
        offset += 8 + len;
    }
    b
}

/// One dBase column.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    /// Up to 10 bytes, NUL-padded to 11 (11 bytes are allowed too, leaving no NUL: a malformed name).
    pub name: String,
    /// Type byte: `b'C'`, `b'N'`, `b'F'`, `b'L'`, `b'D'`, `b'M'`, `b'I'`, … (written as given).
    pub kind: u8,
    /// Cell width in bytes.
    pub length: u8,
    /// Decimal count (numbers).
    pub decimals: u8,
}

impl Field {
    /// A field from its four descriptor values.
    pub fn new(name: &str, kind: u8, length: u8, decimals: u8) -> Self {
        Field {
            name: name.to_string(),
            kind,
            length,
            decimals,
        }
    }
}

/// One dBase row.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// Written as the deletion flag `*` (else a space).
    pub deleted: bool,
    /// Raw cell bytes, one per field; [`dbf_bytes`] pads each with spaces to its field length (left-padded, i.e.
    /// right-aligned, for `N` / `F`; right-padded for the others) and panics if a cell is longer than its field.
    pub cells: Vec<Vec<u8>>,
}

/// A dBase III table: the `.dbf` of a shapefile.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// Byte 0 (`0x03` from [`Table::new`]).
    pub version: u8,
    /// Language driver id, byte 29 (0 from [`Table::new`]).
    pub ldid: u8,
    /// The columns, in order.
    pub fields: Vec<Field>,
    /// The rows, in order (the `.shp` records' attributes, one to one).
    pub records: Vec<Record>,
}

impl Table {
    /// An empty table of version `0x03`, LDID 0.
    pub fn new(fields: Vec<Field>) -> Self {
        Table {
            version: 0x03,
            ldid: 0,
            fields,
            records: Vec::new(),
        }
    }

    /// Appends a live row (`Vec<&[u8]>`, `Vec<Vec<u8>>`, `[&[u8]; N]`, … all fit).
    pub fn push<C: AsRef<[u8]>>(&mut self, cells: impl IntoIterator<Item = C>) {
        self.push_row(false, cells);
    }

    /// Appends a row flagged deleted (`*`).
    pub fn push_deleted<C: AsRef<[u8]>>(&mut self, cells: impl IntoIterator<Item = C>) {
        self.push_row(true, cells);
    }

    fn push_row<C: AsRef<[u8]>>(&mut self, deleted: bool, cells: impl IntoIterator<Item = C>) {
        let cells = cells.into_iter().map(|c| c.as_ref().to_vec()).collect();
        self.records.push(Record { deleted, cells });
    }
}

/// `v` as its `Display` text, e.g. `num(3.5)` = `b"3.5"` (a numeric cell).
pub fn num(v: impl Display) -> Vec<u8> {
    v.to_string().into_bytes()
}

/// The UTF-8 bytes of `s` (a text cell).
pub fn text(s: &str) -> Vec<u8> {
    s.as_bytes().to_vec()
}

/// The `.dbf` bytes (dBase III): version, date YY MM DD = 126 1 1 (2026-01-01, fixed so output is deterministic),
/// record count u32 LE, header length u16 LE (32 + 32·fields + 1), record length u16 LE (1 + sum of field
/// lengths), reserved bytes with the LDID at byte 29, 32-byte field descriptors, 0x0D, the records (deletion flag
/// then cells), and a final 0x1A.
///
/// # Panics
/// On a name over 11 bytes, a row whose cell count differs from the field count, or a cell longer than its field.
pub fn dbf_bytes(table: &Table) -> Vec<u8> {
    let header_len = 32 + 32 * table.fields.len() + 1;
    let record_len: usize = 1 + table
        .fields
        .iter()
        .map(|f| f.length as usize)
        .sum::<usize>();
    let mut b = vec![table.version, 126, 1, 1];
    b.extend(u32::try_from(table.records.len()).unwrap().to_le_bytes());
    b.extend(u16_le(header_len, "header length"));
    b.extend(u16_le(record_len, "record length"));
    b.resize(32, 0);
    b[29] = table.ldid;
    for f in &table.fields {
        let name = f.name.as_bytes();
        assert!(name.len() <= 11, "field name {:?} over 11 bytes", f.name);
        let mut d = [0u8; 32];
        d[..name.len()].copy_from_slice(name);
        d[11] = f.kind;
        d[16] = f.length;
        d[17] = f.decimals;
        b.extend_from_slice(&d);
    }
    b.push(0x0D);
    for (i, r) in table.records.iter().enumerate() {
        assert_eq!(r.cells.len(), table.fields.len(), "record {i}: cell count");
        b.push(if r.deleted { b'*' } else { b' ' });
        for (f, c) in table.fields.iter().zip(&r.cells) {
            let pad = (f.length as usize).checked_sub(c.len());
            let pad = pad.unwrap_or_else(|| panic!("record {i}: cell longer than {}", f.name));
            let pad = vec![b' '; pad];
            if matches!(f.kind, b'N' | b'F') {
                b.extend_from_slice(&pad);
                b.extend_from_slice(c);
            } else {
                b.extend_from_slice(c);
                b.extend_from_slice(&pad);
            }
        }
    }
    b.push(0x1A);
    b
}

/// Writes `dir/stem.shp`, `.shx`, `.dbf`, and `.prj` / `.cpg` when given (creating `dir`); returns the `.shp` path.
///
/// # Panics
/// On any I/O error (a test helper), or as [`dbf_bytes`].
pub fn write(
    dir: &Path,
    stem: &str,
    shapes: &[Shape],
    table: &Table,
    prj: Option<&str>,
    cpg: Option<&str>,
) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let put = |ext: &str, bytes: &[u8]| {
        let p = dir.join(format!("{stem}.{ext}"));
        std::fs::write(&p, bytes).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        p
    };
    put("shx", &shx_bytes(shapes));
    put("dbf", &dbf_bytes(table));
    prj.map(|s| put("prj", s.as_bytes()));
    cpg.map(|s| put("cpg", s.as_bytes()));
    put("shp", &shp_bytes(shapes))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn be(b: &[u8], at: usize) -> i32 {
        i32::from_be_bytes(b[at..at + 4].try_into().unwrap())
    }
    fn le(b: &[u8], at: usize) -> i32 {
        i32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }
    fn f64s(b: &[u8], at: usize, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| f64::from_le_bytes(b[at + 8 * i..at + 8 * i + 8].try_into().unwrap()))
            .collect()
    }

    #[test]
    fn one_polygon_with_a_hole() {
        let outer = vec![
            [0.0, 0.0],
            [0.0, 10.0],
            [10.0, 10.0],
            [10.0, 0.0],
            [0.0, 0.0],
        ];
        let hole = vec![[2.0, 2.0], [4.0, 2.0], [4.0, 4.0], [2.0, 4.0]]; // left open: not closed for us
        let b = shp_bytes(&[Shape::Polygon(vec![outer, hole])]);
        // content: type 4 + box 32 + numParts 4 + numPoints 4 + 2 part starts 8 + 9 points 144 = 196 bytes
        assert_eq!(b.len(), 100 + 8 + 196);
        let head = (be(&b, 0), be(&b, 24), le(&b, 28), le(&b, 32));
        assert_eq!(head, (9994, 152, 1000, 5)); // file length 304 bytes = 152 words
        assert!(b[4..24].iter().all(|&x| x == 0));
        assert_eq!(f64s(&b, 36, 8), [0.0, 0.0, 10.0, 10.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!((be(&b, 100), be(&b, 104), le(&b, 108)), (1, 98, 5));
        assert_eq!(f64s(&b, 112, 4), [0.0, 0.0, 10.0, 10.0]);
        let parts = (le(&b, 144), le(&b, 148), le(&b, 152), le(&b, 156));
        assert_eq!(parts, (2, 9, 0, 5)); // numParts, numPoints, part starts
        assert_eq!(f64s(&b, 160, 2), [0.0, 0.0]);
        assert_eq!(f64s(&b, 160 + 16 * 8, 2), [2.0, 4.0]); // the hole's last point, as given
    }

    #[test]
    fn z_m_point_null_and_raw_lengths() {
        let ring = vec![[0., 0., 5.], [0., 1., 7.], [1., 1., 6.], [0., 0., 5.]];
        let z = Shape::PolygonZ(vec![ring]);
        // 4 + 32 + 4 + 4 + 4 + 4 points·16 + Z (16 + 4·8) + M (16 + 4·8) = 208 bytes
        let c = z.content();
        assert_eq!(c.len(), 208);
        assert_eq!(f64s(&c, 112, 6), [5.0, 7.0, 5.0, 7.0, 6.0, 5.0]); // Z range, Zs
        assert_eq!(f64s(&c, 160, 6), [0.0; 6]); // M range, Ms
        let m = Shape::PolygonM(vec![vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 0.0]]]);
        assert_eq!(m.content().len(), 4 + 32 + 12 + 64 + 48);
        let raw = Shape::Raw {
            shape_type: 5,
            content: vec![1, 2, 3, 4],
        };
        let b = shp_bytes(&[Shape::Null, z, Shape::Point([3.0, -2.0]), m, raw]);
        assert_eq!(le(&b, 32), 15); // first non-null type
        assert_eq!(f64s(&b, 36, 8), [0.0, -2.0, 3.0, 1.0, 5.0, 7.0, 0.0, 0.0]);
        assert_eq!((be(&b, 100), be(&b, 104), le(&b, 108)), (1, 2, 0)); // Null: 4 bytes
        assert_eq!((be(&b, 112), be(&b, 116), le(&b, 120)), (2, 104, 15));
        let pt = 120 + 208;
        assert_eq!((be(&b, pt), be(&b, pt + 4), le(&b, pt + 8)), (3, 10, 1));
        assert_eq!(f64s(&b, pt + 12, 2), [3.0, -2.0]);
        assert_eq!(&b[b.len() - 8..], [5, 0, 0, 0, 1, 2, 3, 4]);
        assert_eq!(be(&b, b.len() - 12), 4);
    }

    #[test]
    fn shx_offsets_point_at_shp_record_headers() {
        let shapes = [
            Shape::Point([1.0, 2.0]),
            Shape::Null,
            Shape::PolyLine(vec![
                vec![[0.0, 0.0], [1.0, 1.0]],
                vec![[2.0, 2.0], [3.0, 3.0], [4.0, 3.0]],
            ]),
            Shape::Polygon(vec![vec![[0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 0.0]]]),
        ];
        let (shp, shx) = (shp_bytes(&shapes), shx_bytes(&shapes));
        assert_eq!(shx.len(), 100 + 8 * 4);
        assert_eq!(be(&shx, 24), 50 + 4 * 4);
        assert_eq!(shx[28..100], shp[28..100]);
        assert_eq!(be(&shx, 100), 50);
        for (i, s) in shapes.iter().enumerate() {
            let (off, len) = (be(&shx, 100 + 8 * i) as usize * 2, be(&shx, 104 + 8 * i));
            assert_eq!((be(&shp, off), be(&shp, off + 4)), (i as i32 + 1, len));
            assert_eq!(le(&shp, off + 8), s.shape_type());
        }
        let last = be(&shx, 100 + 8 * 3) as usize * 2;
        assert_eq!(last + 8 + be(&shx, 128) as usize * 2, shp.len());
    }

    #[test]
    fn dbf_layout() {
        let fields = vec![
            Field::new("NAME", b'C', 8, 0),
            Field::new("HEIGHT", b'N', 6, 2),
        ];
        let mut t = Table::new(fields);
        t.ldid = 0x57;
        t.push(vec![&b"ab"[..], b"3.50"]);
        t.push_deleted([text("zz"), num(-1)]);
        let b = dbf_bytes(&t);
        let (header_len, record_len) = (32 + 32 * 2 + 1, 1 + 8 + 6);
        assert_eq!(b.len(), header_len + 2 * record_len + 1);
        assert_eq!(b[..8], [0x03, 126, 1, 1, 2, 0, 0, 0]);
        assert_eq!(u16::from_le_bytes([b[8], b[9]]) as usize, header_len);
        assert_eq!(u16::from_le_bytes([b[10], b[11]]) as usize, record_len);
        assert_eq!(b[29], 0x57);
        assert_eq!(&b[32..44], b"NAME\0\0\0\0\0\0\0C");
        assert_eq!((b[48], b[49]), (8, 0));
        assert_eq!(&b[64..76], b"HEIGHT\0\0\0\0\0N");
        assert_eq!((b[80], b[81]), (6, 2));
        assert_eq!(b[96], 0x0D);
        assert_eq!(&b[97..97 + record_len], b" ab        3.50");
        assert_eq!(&b[97 + record_len..b.len() - 1], b"*zz          -1");
        assert_eq!(b[b.len() - 1], 0x1A);
    }

    #[test]
    #[should_panic(expected = "cell longer than NAME")]
    fn dbf_cell_too_long_panics() {
        let mut t = Table::new(vec![Field::new("NAME", b'C', 2, 0)]);
        t.push([b"abc"]);
        dbf_bytes(&t);
    }

    #[test]
    fn write_puts_the_files() {
        let dir = std::env::temp_dir().join(format!("citylod-testdata-shp-{}", std::process::id()));
        let mut t = Table::new(vec![Field::new("ID", b'N', 3, 0)]);
        t.push([num(7)]);
        let shapes = [Shape::Point([1.0, 1.0])];
        let shp = write(&dir, "a", &shapes, &t, Some("GEOGCS[]"), None);
        assert_eq!(shp, dir.join("a.shp"));
        let read = |ext: &str| std::fs::read(dir.join(format!("a.{ext}"))).unwrap();
        assert_eq!(read("shp"), shp_bytes(&shapes));
        assert_eq!(read("dbf"), dbf_bytes(&t));
        assert_eq!(read("prj"), b"GEOGCS[]");
        assert!(dir.join("a.shx").is_file() && !dir.join("a.cpg").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
