//! OGC GeoPackage input (OGC 12-128r18): one feature table of a `.gpkg` (an SQLite database), its geometry column read
//! by this module's own parser of GeoPackage binary geometry (a small header, then the feature's geometry as ISO WKB;
//! the EWKB flags some writers use for Z and M are read too), every other column an attribute, and the CRS from the
//! layer's row of `gpkg_spatial_ref_sys` (its EPSG code, else its WKT matched as a `.prj`'s would be).
//!
//! SQLite itself is the system library, through `rusqlite`, opened read-only. A database that is not a GeoPackage, or
//! a layer that is not there, refuses the file with what there is; a row whose geometry cannot become a footprint is
//! a skipped feature with the reason and its feature id (FID: the table's integer primary key, as GDAL and QGIS show
//! it).

use crate::crs::DeclaredCrs;
use crate::feature::{RawFeature, RawPolygon, VectorDoc};
use crate::report::IssueReason;
use crate::surface_model::{Face, Surfaces};
use citylod_mesh::signed_area2;
use citylod_model::{AttrValue, Attributes};
use rusqlite::types::ValueRef;
use rusqlite::{Connection, OpenFlags};
use std::path::Path;

/// The files SQLite keeps beside a database in WAL mode, each with what it is, for refusing one given as the input.
pub(crate) const SIDECARS: [(&str, &str); 3] = [
    ("gpkg-wal", "write-ahead log"),
    ("gpkg-shm", "shared-memory index"),
    ("gpkg-journal", "rollback journal"),
];

/// The first 16 bytes of every SQLite 3 database.
const SQLITE_MAGIC: &[u8; 16] = b"SQLite format 3\0";

/// Deepest nesting of GeometryCollections read; deeper is a malformed geometry (a hostile file, not a building).
const MAX_NESTING: usize = 16;

/// One feature table with a geometry column, as `gpkg_contents` and `gpkg_geometry_columns` list it.
struct Layer {
    table: String,
    column: String,
    geometry_type: String,
    srs_id: i64,
}

/// Reads the feature table `layer` of `path` (the only one when `layer` is `None`). Errors name what is wrong with the
/// file as a whole; one unusable row is a skipped feature.
pub(crate) fn read(path: &Path, layer: Option<&str>) -> Result<VectorDoc, String> {
    let mut head = Vec::with_capacity(16);
    std::fs::File::open(path)
        .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, 16), &mut head))
        .map_err(|e| format!("cannot read it: {e}"))?;
    if head.as_slice() != SQLITE_MAGIC {
        return Err(
            "not an SQLite database (a GeoPackage is one; its first bytes say \"SQLite format 3\")"
                .into(),
        );
    }
    let db = Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(|e| format!("SQLite cannot open it: {e}"))?;
    let sql = |e: rusqlite::Error| format!("SQLite cannot read it: {e}");
    for table in [
        "gpkg_contents",
        "gpkg_geometry_columns",
        "gpkg_spatial_ref_sys",
    ] {
        let present: bool = db
            .query_row(
                "SELECT count(*) > 0 FROM sqlite_master WHERE type IN ('table', 'view') AND name = ?1",
                [table],
                |r| r.get(0),
            )
            .map_err(sql)?;
        if !present {
            return Err(format!(
                "an SQLite database but not a GeoPackage: it has no {table} table"
            ));
        }
    }
    let layers = layers(&db).map_err(sql)?;
    let chosen = choose(&layers, layer)?;
    let mut notes = Vec::new();
    if layers.len() > 1 {
        notes.push(format!(
            "layer {:?} read, of {} feature tables ({})",
            chosen.table,
            layers.len(),
            crate::geojson::listing(&layers.iter().map(|l| l.table.clone()).collect::<Vec<_>>())
        ));
    }
    let declared_crs = declared_crs(&db, chosen, &mut notes).map_err(sql)?;
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (features, surfaces) = rows(&db, chosen, &file_name, &mut notes)?;
    Ok(VectorDoc {
        features,
        surfaces,
        declared_crs,
        notes,
    })
}

/// `"name"` with its quotes doubled, for an identifier in SQL.
fn quoted(name: &str) -> String {
    format!("\"{}\"", name.replace('"', "\"\""))
}

fn layers(db: &Connection) -> rusqlite::Result<Vec<Layer>> {
    let mut st = db.prepare(
        "SELECT c.table_name, g.column_name, g.geometry_type_name, g.srs_id \
         FROM gpkg_contents c JOIN gpkg_geometry_columns g ON c.table_name = g.table_name \
         WHERE lower(c.data_type) = 'features' ORDER BY c.table_name",
    )?;
    let rows = st.query_map([], |r| {
        Ok(Layer {
            table: r.get(0)?,
            column: r.get(1)?,
            geometry_type: r.get::<_, Option<String>>(2)?.unwrap_or_default(),
            srs_id: r.get::<_, Option<i64>>(3)?.unwrap_or(-1),
        })
    })?;
    rows.collect()
}

/// The layer asked for, or the only one; else an error listing what there is.
fn choose<'a>(layers: &'a [Layer], asked: Option<&str>) -> Result<&'a Layer, String> {
    let list = || {
        layers
            .iter()
            .map(|l| format!("{} ({})", l.table, l.geometry_type))
            .collect::<Vec<_>>()
            .join(", ")
    };
    match (asked, layers) {
        (_, []) => Err("a GeoPackage without feature tables (gpkg_contents lists none with data_type 'features')".into()),
        (Some(name), _) => layers.iter().find(|l| l.table == name).ok_or_else(|| {
            format!("no feature table {name:?} (its feature tables: {})", list())
        }),
        (None, [one]) => Ok(one),
        (None, _) => Err(format!(
            "it holds {} feature tables; name the one to read with --layer (feature tables: {})",
            layers.len(),
            list()
        )),
    }
}

/// The CRS of the layer's geometry column: `EPSG:N` when `gpkg_spatial_ref_sys` names an EPSG code, else its WKT
/// definition read as a `.prj` is (EPSG authority, or an Esri WKT matched against the EPSG table); `None` for the
/// undefined systems (-1 Cartesian, 0 geographic), which leave the CRS to `--crs`.
fn declared_crs(
    db: &Connection,
    layer: &Layer,
    notes: &mut Vec<String>,
) -> rusqlite::Result<Option<DeclaredCrs>> {
    const MEMBER: &str = "gpkg_spatial_ref_sys";
    let row: Option<(Option<String>, Option<i64>, Option<String>)> = db
        .query_row(
            "SELECT organization, organization_coordsys_id, definition FROM gpkg_spatial_ref_sys WHERE srs_id = ?1",
            [layer.srs_id],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
        )
        .map(Some)
        .or_else(|e| match e {
            rusqlite::Error::QueryReturnedNoRows => Ok(None),
            e => Err(e),
        })?;
    let Some((organization, code, definition)) = row else {
        if layer.srs_id == -1 || layer.srs_id == 0 {
            return Ok(None);
        }
        return Ok(Some(DeclaredCrs::NotUnderstood {
            member: MEMBER,
            detail: format!(
                "layer {:?} gives srs_id {}, which the table does not list",
                layer.table, layer.srs_id
            ),
        }));
    };
    let organization = organization.unwrap_or_default();
    match code {
        Some(code) if code > 0 && organization.trim().eq_ignore_ascii_case("EPSG") => {
            return Ok(Some(DeclaredCrs::Name(format!("EPSG:{code}"))));
        }
        _ => {}
    }
    let definition = definition.unwrap_or_default();
    if layer.srs_id <= 0
        || definition.trim().eq_ignore_ascii_case("undefined")
        || definition.trim().is_empty()
    {
        return Ok(None);
    }
    let (crs, note) = crate::prj::declared_crs(&definition);
    notes.extend(note);
    Ok(Some(match crs {
        DeclaredCrs::NotUnderstood { detail, .. } => DeclaredCrs::NotUnderstood {
            member: MEMBER,
            detail: format!(
                "srs_id {} ({organization} {}): {detail}",
                layer.srs_id,
                code.map(|c| c.to_string()).unwrap_or_default()
            ),
        },
        named => named,
    }))
}

/// A column of the feature table other than the geometry.
struct Column {
    name: String,
    /// Declared `BOOLEAN`: 0 and 1 are read as false and true.
    boolean: bool,
}

/// Every row of the layer, in FID order.
fn rows(
    db: &Connection,
    layer: &Layer,
    file_name: &str,
    notes: &mut Vec<String>,
) -> Result<(Vec<RawFeature>, Vec<Surfaces>), String> {
    let sql = |e: rusqlite::Error| format!("SQLite cannot read table {:?}: {e}", layer.table);
    let mut info = db
        .prepare(&format!("PRAGMA table_info({})", quoted(&layer.table)))
        .map_err(sql)?;
    // (name, declared type, primary-key position)
    let declared: Vec<(String, String, i64)> = info
        .query_map([], |r| {
            Ok((
                r.get(1)?,
                r.get::<_, Option<String>>(2)?.unwrap_or_default(),
                r.get(5)?,
            ))
        })
        .map_err(sql)?
        .collect::<rusqlite::Result<_>>()
        .map_err(sql)?;
    if declared.is_empty() {
        return Err(format!(
            "gpkg_contents lists feature table {:?}, but the database has no such table",
            layer.table
        ));
    }
    if !declared.iter().any(|(n, _, _)| n == &layer.column) {
        return Err(format!(
            "table {:?} has no column {:?}, which gpkg_geometry_columns names as its geometry",
            layer.table, layer.column
        ));
    }
    // The FID: the single INTEGER primary key a GeoPackage feature table must have; the rowid without one.
    let keys: Vec<&(String, String, i64)> = declared.iter().filter(|c| c.2 > 0).collect();
    let fid = match keys.as_slice() {
        [k] if k.1.eq_ignore_ascii_case("INTEGER") => Some(k.0.clone()),
        _ => None,
    };
    let mut skipped_blobs = Vec::new();
    let columns: Vec<Column> = declared
        .iter()
        .filter(|(n, _, _)| n != &layer.column && Some(n) != fid.as_ref())
        .filter(|(n, t, _)| {
            let blob = t.eq_ignore_ascii_case("BLOB");
            if blob {
                skipped_blobs.push(n.clone());
            }
            !blob
        })
        .map(|(n, t, _)| Column {
            name: n.clone(),
            boolean: t.eq_ignore_ascii_case("BOOLEAN"),
        })
        .collect();
    if !skipped_blobs.is_empty() {
        notes.push(format!(
            "BLOB column(s) not read as attributes: {}",
            crate::geojson::listing(&skipped_blobs)
        ));
    }
    let fid_expr = fid.as_deref().map(quoted).unwrap_or_else(|| "rowid".into());
    let select: Vec<String> = std::iter::once(fid_expr.clone())
        .chain(std::iter::once(quoted(&layer.column)))
        .chain(columns.iter().map(|c| quoted(&c.name)))
        .collect();
    let mut st = db
        .prepare(&format!(
            "SELECT {} FROM {} ORDER BY {fid_expr}",
            select.join(", "),
            quoted(&layer.table)
        ))
        .map_err(sql)?;
    let mut q = st.query([]).map_err(sql)?;
    let mut features = Vec::new();
    let mut surfaces = Vec::new();
    while let Some(row) = q.next().map_err(sql)? {
        let fid = match row.get_ref(0).map_err(sql)? {
            ValueRef::Integer(i) => i,
            _ => features.len() as i64,
        };
        let mut attributes = Attributes::new();
        let mut repairs = Vec::new();
        for (i, c) in columns.iter().enumerate() {
            let v = row.get_ref(i + 2).map_err(sql)?;
            attributes.insert(c.name.clone(), value(v, c, &mut repairs));
        }
        let mut out = RawFeature {
            source_id: crate::shp::source_id(&attributes, file_name, fid),
            attributes,
            repairs,
            ..Default::default()
        };
        match row.get_ref(1).map_err(sql)? {
            ValueRef::Null => {
                out.skip = Some((
                    IssueReason::NoGeometry,
                    format!("FID {fid}: geometry is null"),
                ));
            }
            ValueRef::Blob(b) => match geometry(b) {
                Ok(Geometry::Footprint(polygons, repairs)) => {
                    out.polygons = polygons;
                    out.repairs.extend(repairs);
                }
                Ok(Geometry::Surfaces(faces, repairs)) => {
                    out.repairs.extend(repairs);
                    surfaces.push((features.len(), format!("FID {fid}"), faces));
                }
                Err((reason, detail)) => out.skip = Some((reason, format!("FID {fid}: {detail}"))),
            },
            other => {
                out.skip = Some((
                    IssueReason::MalformedGeometry,
                    format!(
                        "FID {fid}: the geometry column holds {} instead of a GeoPackage geometry blob",
                        type_name(other)
                    ),
                ));
            }
        }
        features.push(out);
    }
    Ok((features, surfaces))
}

fn type_name(v: ValueRef) -> &'static str {
    match v {
        ValueRef::Null => "NULL",
        ValueRef::Integer(_) => "an integer",
        ValueRef::Real(_) => "a real",
        ValueRef::Text(_) => "text",
        ValueRef::Blob(_) => "a blob",
    }
}

/// One cell as an attribute value. Text that is not UTF-8 (SQLite does not check what it stores) is kept with its bad
/// bytes replaced, and a blob in a column not declared BLOB as hex text; both are reported.
fn value(v: ValueRef, c: &Column, repairs: &mut Vec<(IssueReason, String)>) -> AttrValue {
    match v {
        ValueRef::Null => AttrValue::Null,
        ValueRef::Integer(i) if c.boolean && (i == 0 || i == 1) => AttrValue::Bool(i == 1),
        ValueRef::Integer(i) => AttrValue::Int(i),
        ValueRef::Real(x) => AttrValue::Float(x),
        ValueRef::Text(t) => match std::str::from_utf8(t) {
            Ok(s) => AttrValue::String(s.to_string()),
            Err(_) => {
                repairs.push((
                    IssueReason::UndecodableValueKeptAsText,
                    format!(
                        "column {:?}: text that is not UTF-8, kept with its undecodable bytes replaced",
                        c.name
                    ),
                ));
                AttrValue::String(String::from_utf8_lossy(t).into_owned())
            }
        },
        ValueRef::Blob(b) => {
            repairs.push((
                IssueReason::UndecodableValueKeptAsText,
                format!(
                    "column {:?}: a blob of {} bytes, kept as hexadecimal text",
                    c.name,
                    b.len()
                ),
            ));
            AttrValue::String(b.iter().map(|x| format!("{x:02x}")).collect())
        }
    }
}

type Skip = (IssueReason, String);
type Repairs = Vec<(IssueReason, String)>;

/// What a geometry blob holds.
pub(crate) enum Geometry {
    /// Plan outlines (heights, if any, not used), and the repairs made reading them.
    Footprint(Vec<RawPolygon>, Repairs),
    /// The faces of a 3D surface model: a PolyhedralSurface or TIN with heights, or polygons with heights of which
    /// several stand on edge (walls).
    Surfaces(Vec<Face>, Repairs),
}

/// A GeoPackage geometry blob → the footprint's polygons or a 3D model's faces, and the repairs made reading them.
pub(crate) fn geometry(b: &[u8]) -> Result<Geometry, Skip> {
    let malformed = |what: String| (IssueReason::MalformedGeometry, what);
    if b.len() < 8 || &b[..2] != b"GP" {
        return Err(malformed(
            "the geometry blob does not start with a GeoPackage header ('GP')".into(),
        ));
    }
    let flags = b[3];
    if flags & 0b0010_0000 != 0 {
        return Err((
            IssueReason::UnsupportedGeometry,
            "a GeoPackage extended geometry type (not a standard WKB geometry)".into(),
        ));
    }
    let envelope_doubles = match (flags >> 1) & 0b111 {
        0 => 0,
        1 => 4,
        2 | 3 => 6,
        4 => 8,
        e => {
            return Err(malformed(format!(
                "envelope indicator {e} is not one GeoPackage defines"
            )))
        }
    };
    let wkb_at = 8 + 8 * envelope_doubles;
    if flags & 0b0001_0000 != 0 {
        return Err((IssueReason::EmptyGeometry, "an empty geometry".into()));
    }
    let wkb = b.get(wkb_at..).filter(|w| !w.is_empty()).ok_or_else(|| {
        malformed(format!(
            "the geometry blob ends ({} bytes) before its WKB (at byte {wkb_at})",
            b.len()
        ))
    })?;
    let mut r = Wkb { b: wkb, at: 0 };
    let mut out = Out::default();
    r.geometry(0, "", &mut out)?;
    if out.polygons.is_empty() {
        let what = out
            .dropped
            .first()
            .cloned()
            .unwrap_or_else(|| "geometry".into());
        return Err((
            IssueReason::UnsupportedGeometry,
            format!("{what} is not a footprint"),
        ));
    }
    if out.polygons.iter().flatten().all(|r| r.is_empty()) {
        return Err((
            IssueReason::EmptyGeometry,
            "polygonal geometry without coordinates".into(),
        ));
    }
    // A footprint may have one degenerate part (dropped later as any); walls come several to a building.
    let surfaces = out.surface_type || out.on_edge >= 2;
    if surfaces && out.faces.len() == out.polygons.len() {
        return Ok(Geometry::Surfaces(out.faces, out.repairs));
    }
    if out.collection && !out.dropped.is_empty() {
        out.repairs.push((
            IssueReason::NonPolygonMemberDropped,
            format!(
                "{} GeometryCollection member(s) not polygonal, dropped: {}",
                out.dropped.len(),
                crate::geojson::listing(&out.dropped)
            ),
        ));
    }
    Ok(Geometry::Footprint(out.polygons, out.repairs))
}

#[derive(Default)]
struct Out {
    polygons: Vec<RawPolygon>,
    repairs: Repairs,
    /// Members that are not polygons, as "member PATH (Type)", or the whole geometry's type.
    dropped: Vec<String>,
    collection: bool,
    /// Polygons with heights whose exterior ring stands on edge (a wall of a 3D surface model).
    on_edge: usize,
    /// The polygons with their heights, when they have them.
    faces: Vec<Face>,
    /// A PolyhedralSurface or TIN was read.
    surface_type: bool,
}

/// Coordinates per point, and whether the third is a height (else a measure).
#[derive(Clone, Copy)]
struct Dims {
    n: usize,
    z: bool,
}

/// A reader of one WKB geometry (ISO 13249 / OGC 06-103r4 type codes, with EWKB's Z, M and SRID flags).
struct Wkb<'a> {
    b: &'a [u8],
    at: usize,
}

const TYPE_NAMES: [&str; 18] = [
    "Geometry",
    "Point",
    "LineString",
    "Polygon",
    "MultiPoint",
    "MultiLineString",
    "MultiPolygon",
    "GeometryCollection",
    "CircularString",
    "CompoundCurve",
    "CurvePolygon",
    "MultiCurve",
    "MultiSurface",
    "Curve",
    "Surface",
    "PolyhedralSurface",
    "TIN",
    "Triangle",
];

impl Wkb<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], Skip> {
        let s = self
            .at
            .checked_add(n)
            .and_then(|end| self.b.get(self.at..end))
            .ok_or_else(|| {
                (
                    IssueReason::MalformedGeometry,
                    format!(
                        "the WKB ends ({} bytes) before the geometry does",
                        self.b.len()
                    ),
                )
            })?;
        self.at += n;
        Ok(s)
    }

    fn u32(&mut self, le: bool) -> Result<u32, Skip> {
        let s: [u8; 4] = self.take(4)?.try_into().expect("4 bytes");
        Ok(if le {
            u32::from_le_bytes(s)
        } else {
            u32::from_be_bytes(s)
        })
    }

    fn f64(&mut self, le: bool) -> Result<f64, Skip> {
        let s: [u8; 8] = self.take(8)?.try_into().expect("8 bytes");
        Ok(if le {
            f64::from_le_bytes(s)
        } else {
            f64::from_be_bytes(s)
        })
    }

    /// Byte order, type code and coordinates per point (with whether the third is z) of the geometry starting here.
    fn header(&mut self) -> Result<(bool, u32, Dims), Skip> {
        let le = match self.take(1)?[0] {
            0 => false,
            1 => true,
            o => {
                return Err((
                    IssueReason::MalformedGeometry,
                    format!("WKB byte order {o} (0 or 1 expected)"),
                ))
            }
        };
        let code = self.u32(le)?;
        let (z_flag, m_flag, srid_flag) = (
            code & 0x8000_0000 != 0,
            code & 0x4000_0000 != 0,
            code & 0x2000_0000 != 0,
        );
        if srid_flag {
            self.take(4)?;
        }
        let iso = code & 0x0FFF_FFFF;
        let (kind, thousands) = (iso % 1000, iso / 1000);
        if thousands > 3 {
            return Err((
                IssueReason::MalformedGeometry,
                format!("WKB type code {code} is not one ISO WKB defines"),
            ));
        }
        let z = z_flag || thousands == 1 || thousands == 3;
        let m = m_flag || thousands == 2 || thousands == 3;
        Ok((
            le,
            kind,
            Dims {
                n: 2 + usize::from(z) + usize::from(m),
                z,
            },
        ))
    }

    fn geometry(&mut self, depth: usize, path: &str, out: &mut Out) -> Result<(), Skip> {
        let (le, kind, dims) = self.header()?;
        let name = TYPE_NAMES
            .get(kind as usize)
            .copied()
            .unwrap_or("unknown type");
        match kind {
            3 | 17 => self.polygon(le, dims, out),
            6 | 15 | 16 => {
                // A MultiPolygon's members are Polygons, a PolyhedralSurface's too, a TIN's Triangles.
                let member = if kind == 16 { 17 } else { 3 };
                out.surface_type |= kind != 6;
                let n = self.u32(le)?;
                for i in 0..n {
                    let (le, k, dims) = self.header()?;
                    if k != member {
                        return Err((
                            IssueReason::MalformedGeometry,
                            format!(
                                "{name} member {i} is a {} (only {}s may be members)",
                                TYPE_NAMES
                                    .get(k as usize)
                                    .copied()
                                    .unwrap_or("unknown type"),
                                TYPE_NAMES[member as usize]
                            ),
                        ));
                    }
                    self.polygon(le, dims, out)?;
                }
                Ok(())
            }
            7 => {
                if depth >= MAX_NESTING {
                    return Err((
                        IssueReason::MalformedGeometry,
                        format!("GeometryCollections nested over {MAX_NESTING} deep"),
                    ));
                }
                out.collection = true;
                let n = self.u32(le)?;
                for i in 0..n {
                    let member = if path.is_empty() {
                        i.to_string()
                    } else {
                        format!("{path}/{i}")
                    };
                    self.geometry(depth + 1, &member, out)?;
                }
                Ok(())
            }
            _ => {
                if depth == 0 {
                    out.dropped.push(format!("{name} geometry"));
                    Ok(())
                } else {
                    // A member that is not polygonal is skipped over: its length is known only for simple types.
                    self.skip_member(le, kind, dims, name)?;
                    out.dropped.push(format!("member {path} ({name})"));
                    Ok(())
                }
            }
        }
    }

    /// Steps over a Point, LineString, MultiPoint or MultiLineString member of a collection.
    fn skip_member(&mut self, le: bool, kind: u32, dims: Dims, name: &str) -> Result<(), Skip> {
        match kind {
            1 => {
                self.take(8 * dims.n)?;
            }
            2 => {
                let n = self.u32(le)? as usize;
                self.take(n.saturating_mul(8 * dims.n))?;
            }
            4 | 5 => {
                let n = self.u32(le)?;
                for _ in 0..n {
                    let (le, kind, dims) = self.header()?;
                    self.skip_member(le, kind, dims, name)?;
                }
            }
            _ => {
                return Err((
                    IssueReason::UnsupportedGeometry,
                    format!(
                        "a GeometryCollection holding a {name}, which this reader cannot step over"
                    ),
                ))
            }
        }
        Ok(())
    }

    fn polygon(&mut self, le: bool, dims: Dims, out: &mut Out) -> Result<(), Skip> {
        let rings = self.u32(le)?;
        let mut polygon = Vec::new();
        let mut face = Vec::new();
        for i in 0..rings {
            let n = self.u32(le)? as usize;
            // Every point takes 8 bytes a coordinate: a count beyond the bytes left is a broken blob, not an allocation.
            if n.saturating_mul(8 * dims.n) > self.b.len() - self.at {
                return Err((
                    IssueReason::MalformedGeometry,
                    format!(
                        "a ring said to hold {n} points, more than the rest of its {}-byte WKB",
                        self.b.len()
                    ),
                ));
            }
            let mut ring = Vec::with_capacity(n);
            let mut ring3 = Vec::with_capacity(if dims.z { n } else { 0 });
            let (mut z_min, mut z_max) = (f64::INFINITY, f64::NEG_INFINITY);
            for _ in 0..n {
                let x = self.f64(le)?;
                let y = self.f64(le)?;
                if dims.z {
                    let z = self.f64(le)?;
                    z_min = z_min.min(z);
                    z_max = z_max.max(z);
                    ring3.push([x, y, z]);
                }
                self.take(8 * (dims.n - 2 - usize::from(dims.z)))?;
                if !(x.is_finite() && y.is_finite()) {
                    return Err((
                        IssueReason::NonFiniteCoordinate,
                        format!("a vertex ({x}, {y}) that is not a finite number"),
                    ));
                }
                ring.push([x, y]);
            }
            let closed = ring.len() >= 2 && ring.first() == ring.last();
            if closed {
                ring.pop();
                ring3.pop();
            } else if ring.len() >= 3 {
                let what = if i == 0 {
                    "exterior ring".to_string()
                } else {
                    format!("hole {i}")
                };
                out.repairs.push((
                    IssueReason::RingClosed,
                    format!("{what} was not closed; closed it"),
                ));
            }
            if i == 0 && ring.len() >= 3 && z_max > z_min {
                let (w, h) = extent(&ring);
                // On edge: a plan area nothing against the square of the outline's extent, while its height varies.
                if signed_area2(&ring).abs() <= 1e-6 * w.max(h).powi(2) {
                    out.on_edge += 1;
                }
            }
            if dims.z && !z_min.is_finite() && n > 0 {
                return Err((
                    IssueReason::NonFiniteCoordinate,
                    "a vertex whose height is not a finite number".into(),
                ));
            }
            polygon.push(ring);
            face.push(ring3);
        }
        out.polygons.push(polygon);
        if dims.z {
            out.faces.push(face);
        }
        Ok(())
    }
}

fn extent(r: &[[f64; 2]]) -> (f64, f64) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in r {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (hi[0] - lo[0], hi[1] - lo[1])
}

/// A path GeoPackage input is read from: the extension `.gpkg`, in any case.
pub(crate) fn is_geopackage_name(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gpkg"))
}
