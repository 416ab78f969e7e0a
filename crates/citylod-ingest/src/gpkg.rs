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
use crate::feature::{RawFeature, RawPolygon, VectorDoc, Want};
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
pub(crate) const SQLITE_MAGIC: &[u8; 16] = b"SQLite format 3\0";

/// Deepest nesting of GeometryCollections read; deeper is a malformed geometry (a hostile file, not a building).
const MAX_NESTING: usize = 16;

/// One feature table `gpkg_contents` lists (data_type 'features'), with the rows `gpkg_geometry_columns` has for it:
/// one in a well-formed GeoPackage (the standard gives a feature table one geometry column); none or several make
/// the table unreadable, said by `choose` when it is the one to read.
struct Table {
    name: String,
    columns: Vec<Layer>,
}

/// One feature table with a geometry column, as `gpkg_contents` and `gpkg_geometry_columns` list it.
struct Layer {
    table: String,
    column: String,
    geometry_type: String,
    srs_id: i64,
}

/// Reads the feature table `layer` of `path` (when `layer` is `None`, the only one; for `Want::Lines`, the only one
/// of lines). Errors name what is wrong with the file as a whole; one unusable row is a skipped feature.
/// A damaged file's (or one that is no GeoPackage) error begins "invalid GeoPackage:"; a sound file that only needs
/// `--layer` (or names no such layer) is not called invalid.
pub(crate) fn read(path: &Path, layer: Option<&str>, want: Want) -> Result<VectorDoc, String> {
    read_layer(path, layer, want).map_err(|r| match r {
        Refusal::Invalid(detail) => format!("invalid GeoPackage: {detail}"),
        Refusal::Layer(detail) => detail,
    })
}

/// Why a GeoPackage is not read: the file is damaged or no GeoPackage, or it is sound and the layer to read is to be
/// named (or the one named is not there).
enum Refusal {
    Invalid(String),
    Layer(String),
}

impl From<String> for Refusal {
    fn from(detail: String) -> Self {
        Refusal::Invalid(detail)
    }
}

fn read_layer(path: &Path, layer: Option<&str>, want: Want) -> Result<VectorDoc, Refusal> {
    let mut head = Vec::with_capacity(16);
    std::fs::File::open(path)
        .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, 16), &mut head))
        .map_err(|e| format!("cannot read it: {e}"))?;
    if head.as_slice() != SQLITE_MAGIC {
        return Err(Refusal::Invalid(
            "not an SQLite database (a GeoPackage is one; its first bytes say \"SQLite format 3\")"
                .into(),
        ));
    }
    let mut notes = Vec::new();
    let db = open(path, &mut notes)?;
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
            return Err(Refusal::Invalid(format!(
                "an SQLite database but not a GeoPackage: it has no {table} table"
            )));
        }
    }
    let (tables, orphans) = layers(&db).map_err(sql)?;
    let chosen = choose(&tables, &orphans, layer, want)?;
    if tables.len() > 1 {
        notes.push(format!(
            "layer {:?} read, of {} feature tables ({})",
            chosen.table,
            tables.len(),
            crate::geojson::listing(&tables.iter().map(|t| t.name.clone()).collect::<Vec<_>>())
        ));
    }
    // Feature tables gpkg_contents lists that cannot be read for want of their geometry column: said, not dropped
    // without a word (the table read was chosen among those that can).
    let unregistered: Vec<String> = tables
        .iter()
        .filter(|t| t.columns.is_empty())
        .map(|t| format!("{:?}", t.name))
        .collect();
    if !unregistered.is_empty() {
        notes.push(format!(
            "feature table(s) {} not read: gpkg_contents lists them with data_type 'features', but \
             gpkg_geometry_columns has no row naming their geometry column",
            crate::geojson::listing(&unregistered)
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
        z_unit_m: None,
        notes,
    })
}

/// Opens `path` read-only. A database in WAL mode needs its `-shm` index, which SQLite creates, or opens for writing,
/// beside it: in a read-only folder that fails, and the file is then read as immutable (its write-ahead log not read,
/// as GDAL does), said in `notes`.
fn open(path: &Path, notes: &mut Vec<String>) -> Result<Connection, String> {
    let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
    let probe = |db: &Connection| {
        db.query_row("SELECT count(*) FROM sqlite_master", [], |r| {
            r.get::<_, i64>(0)
        })
    };
    let first = match Connection::open_with_flags(path, flags) {
        Ok(db) => match probe(&db) {
            Ok(_) => return Ok(db),
            Err(e) => e,
        },
        Err(e) => e,
    };
    let uri = format!("file:{}?immutable=1", uri_path(path));
    let db = Connection::open_with_flags(uri, flags | OpenFlags::SQLITE_OPEN_URI)
        .ok()
        .filter(|db| probe(db).is_ok())
        .ok_or_else(|| format!("SQLite cannot open it: {first}"))?;
    notes.push(format!(
        "read as an immutable file: SQLite could not open it as usual ({first}; a database in WAL mode in a read-only \
         folder?), so changes in a write-ahead log beside it, if any, are not seen"
    ));
    Ok(db)
}

/// A path as the path of an SQLite `file:` URI: bytes outside the unreserved set and `/` percent-encoded.
fn uri_path(path: &Path) -> String {
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    absolute
        .to_string_lossy()
        .bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' | b'/' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// `"name"` with its quotes doubled, for an identifier in SQL.
fn quoted(name: &str) -> String {
    format!("\"{}\"", name.replace('"', "\"\""))
}

/// The feature tables `gpkg_contents` lists, in name order, each with its rows of `gpkg_geometry_columns` (names
/// matched whatever their case, as SQLite resolves table names), and the names `gpkg_geometry_columns` has that
/// `gpkg_contents` does not list as feature tables (for saying why a table is missing).
fn layers(db: &Connection) -> rusqlite::Result<(Vec<Table>, Vec<String>)> {
    let mut st = db.prepare(
        "SELECT DISTINCT c.table_name, g.column_name, g.geometry_type_name, g.srs_id \
         FROM gpkg_contents c LEFT JOIN gpkg_geometry_columns g ON c.table_name = g.table_name COLLATE NOCASE \
         WHERE lower(c.data_type) = 'features' AND c.table_name IS NOT NULL \
         ORDER BY c.table_name, g.column_name",
    )?;
    let rows = st.query_map([], |r| {
        Ok((
            r.get::<_, String>(0)?,
            r.get::<_, Option<String>>(1)?,
            r.get::<_, Option<String>>(2)?,
            r.get::<_, Option<i64>>(3)?,
        ))
    })?;
    let mut tables: Vec<Table> = Vec::new();
    for row in rows {
        let (table, column, geometry_type, srs_id) = row?;
        if tables.last().is_none_or(|t| t.name != table) {
            tables.push(Table {
                name: table.clone(),
                columns: Vec::new(),
            });
        }
        let Some(column) = column else { continue };
        // (A row repeated by gpkg_contents listing the table twice is one row here: SELECT DISTINCT.)
        tables
            .last_mut()
            .expect("pushed above")
            .columns
            .push(Layer {
                table,
                column,
                geometry_type: geometry_type.unwrap_or_default(),
                srs_id: srs_id.unwrap_or(-1),
            });
    }
    let mut st = db.prepare(
        "SELECT DISTINCT table_name FROM gpkg_geometry_columns WHERE table_name COLLATE NOCASE NOT IN \
         (SELECT table_name FROM gpkg_contents WHERE lower(data_type) = 'features' AND table_name IS NOT NULL) \
         ORDER BY table_name",
    )?;
    let orphans = st
        .query_map([], |r| r.get::<_, Option<String>>(0))?
        .filter_map(|r| r.transpose())
        .collect::<rusqlite::Result<Vec<String>>>()?;
    Ok((tables, orphans))
}

/// The geometry type names of `gpkg_geometry_columns` that hold lines.
const LINE_TYPES: [&str; 5] = [
    "LINESTRING",
    "MULTILINESTRING",
    "CIRCULARSTRING",
    "COMPOUNDCURVE",
    "MULTICURVE",
];

/// The layer asked for; else for buildings the only one, for streets the only one of lines (or the only one, when its
/// type is any geometry); else an error listing what there is. A feature table without a row in
/// `gpkg_geometry_columns` is refused when asked for, and no candidate for streets (`read` notes it); one with several
/// rows there is refused when it is the one to read: which column is its geometry cannot be told.
fn choose<'a>(
    tables: &'a [Table],
    orphans: &[String],
    asked: Option<&str>,
    want: Want,
) -> Result<&'a Layer, Refusal> {
    let describe = |t: &Table| match t.columns.as_slice() {
        [] => format!("{} (no row in gpkg_geometry_columns)", t.name),
        [one] => format!("{} ({})", t.name, one.geometry_type),
        many => format!("{} ({} geometry columns)", t.name, many.len()),
    };
    let list = |of: &[&Table]| {
        of.iter()
            .map(|t| describe(t))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let all: Vec<&Table> = tables.iter().collect();
    // gpkg_geometry_columns naming tables gpkg_contents does not list as features, said where it explains a miss.
    let orphaned = || {
        (!orphans.is_empty()).then(|| {
            format!(
                "; gpkg_geometry_columns names {}, which gpkg_contents does not list with data_type 'features'",
                crate::geojson::listing(&orphans.iter().map(|o| format!("{o:?}")).collect::<Vec<_>>())
            )
        })
    };
    let fix = "gpkg_contents and gpkg_geometry_columns must name the same feature tables, each with one geometry \
               column: correct their rows, or write the file again (e.g. with GDAL's ogr2ogr or QGIS)";
    // The one geometry column of table `t`, or why it has none to read.
    let one = |t: &'a Table| -> Result<&'a Layer, String> {
        match t.columns.as_slice() {
            [one] => Ok(one),
            [] => Err(format!(
                "feature table {:?} has no row in gpkg_geometry_columns, which names a feature table's geometry \
                 column, so it cannot be read{}; {fix}",
                t.name,
                orphaned().unwrap_or_default()
            )),
            many => Err(format!(
                "feature table {:?} has {} rows in gpkg_geometry_columns ({}), where a GeoPackage feature table has \
                 one geometry column: which one holds its geometry cannot be told; {fix}",
                t.name,
                many.len(),
                many.iter()
                    .map(|l| format!("column {:?} {}", l.column, l.geometry_type))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        }
    };
    if tables.is_empty() {
        return Err(Refusal::Invalid(format!(
            "a GeoPackage without feature tables (gpkg_contents lists none with data_type 'features'){}",
            orphaned().unwrap_or_default()
        )));
    }
    let candidates: Vec<&Table> = tables.iter().filter(|t| !t.columns.is_empty()).collect();
    match (asked, candidates.as_slice()) {
        // SQLite's names are case-insensitive: an exact match first, else the one equal but for case.
        (Some(name), _) => tables
            .iter()
            .find(|t| t.name == name)
            .or_else(|| {
                let mut same = tables.iter().filter(|t| t.name.eq_ignore_ascii_case(name));
                same.next().filter(|_| same.next().is_none())
            })
            .ok_or_else(|| {
                let orphan = orphans.iter().any(|o| o.eq_ignore_ascii_case(name));
                if orphan {
                    Refusal::Invalid(format!(
                        "no feature table {name:?} in gpkg_contents (gpkg_geometry_columns names it, but \
                         gpkg_contents does not list it with data_type 'features'; its feature tables: {}); {fix}",
                        list(&all)
                    ))
                } else {
                    Refusal::Layer(format!(
                        "no feature table {name:?} (its feature tables: {})",
                        list(&all)
                    ))
                }
            })
            .and_then(|t| one(t).map_err(Refusal::Invalid)),
        // None to choose from: why the tables listed cannot be read.
        (None, []) => match tables {
            [t] => Ok(one(t)?),
            _ => Err(Refusal::Invalid(format!(
                "none of its {} feature tables has a row in gpkg_geometry_columns, which names a feature table's \
                 geometry column, so none can be read (feature tables: {}){}; {fix}",
                tables.len(),
                list(&all),
                orphaned().unwrap_or_default()
            ))),
        },
        // Buildings: the only feature table. One that cannot be read still counts, so that another is not read in
        // its place (a table of roads as footprints) but named with --layer.
        (None, _) if want == Want::Footprints => match tables {
            [t] => Ok(one(t)?),
            _ => Err(Refusal::Layer(format!(
                "it holds {} feature tables; name the one to read with --layer (feature tables: {})",
                tables.len(),
                list(&all)
            ))),
        },
        (None, _) => {
            // Streets: the only table of lines; else the only table of any geometry type (which may hold lines).
            let is = |t: &Table, types: &[&str]| {
                t.columns
                    .iter()
                    .any(|l| types.iter().any(|ty| l.geometry_type.eq_ignore_ascii_case(ty)))
            };
            let lines: Vec<&Table> = candidates.iter().copied().filter(|t| is(t, &LINE_TYPES)).collect();
            match (lines.as_slice(), candidates.as_slice()) {
                ([t], _) => Ok(one(t)?),
                ([], [t]) if is(t, &["GEOMETRY", "GEOMETRYCOLLECTION"]) => Ok(one(t)?),
                ([], _) => Err(Refusal::Layer(format!(
                    "it holds no table of lines, which street lines are (feature tables: {})",
                    list(&candidates)
                ))),
                (many, _) => Err(Refusal::Layer(format!(
                    "it holds {} tables of lines; name the one to read with --streets-layer (feature tables: {})",
                    many.len(),
                    list(&candidates)
                ))),
            }
        }
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
    // The CRS WKT extension's column, when the table has it: its WKT 2 is preferred to the WKT 1 `definition`.
    let wkt2 = db
        .prepare("SELECT definition_12_063 FROM gpkg_spatial_ref_sys LIMIT 0")
        .is_ok();
    // organization, organization_coordsys_id, definition, definition_12_063
    type SrsRow = (Option<String>, Option<i64>, Option<String>, Option<String>);
    let row: Option<SrsRow> = db
        .query_row(
            &format!(
                "SELECT organization, organization_coordsys_id, definition, {} FROM gpkg_spatial_ref_sys \
                 WHERE srs_id = ?1",
                if wkt2 { "definition_12_063" } else { "NULL" }
            ),
            [layer.srs_id],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
        )
        .map(Some)
        .or_else(|e| match e {
            rusqlite::Error::QueryReturnedNoRows => Ok(None),
            e => Err(e),
        })?;
    let Some((organization, code, definition, definition2)) = row else {
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
    let usable = |d: Option<String>| {
        d.map(|d| d.trim().to_string())
            .filter(|d| !d.is_empty() && !d.eq_ignore_ascii_case("undefined"))
    };
    let definition = usable(definition2).or_else(|| usable(definition));
    // An EPSG code the offline table knows; one it does not know is read from the definition, when there is one.
    let epsg = code
        .filter(|c| *c > 0 && organization.trim().eq_ignore_ascii_case("EPSG"))
        .map(|c| format!("EPSG:{c}"));
    if let Some(name) = &epsg {
        if definition.is_none() || crate::crs::Crs::parse(name).is_ok() {
            return Ok(Some(DeclaredCrs::Name(name.clone())));
        }
    }
    let Some(definition) = definition else {
        if layer.srs_id <= 0 {
            return Ok(None);
        }
        return Ok(Some(DeclaredCrs::NotUnderstood {
            member: MEMBER,
            detail: format!(
                "srs_id {} ({organization} {}) has no definition",
                layer.srs_id,
                code.map(|c| c.to_string()).unwrap_or_default()
            ),
        }));
    };
    let source = crate::prj::WktSource {
        member: MEMBER,
        whose: "the spatial reference system's",
    };
    let (crs, note) = crate::prj::declared_crs(&definition, &source);
    notes.extend(note);
    Ok(Some(match crs {
        // Neither the code nor the definition: the code's own error says more.
        DeclaredCrs::NotUnderstood { .. } if epsg.is_some() => {
            DeclaredCrs::Name(epsg.expect("checked"))
        }
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
    // table_xinfo lists generated columns too (table_info leaves them out); hidden 1 is a virtual table's.
    let mut info = db
        .prepare(&format!("PRAGMA table_xinfo({})", quoted(&layer.table)))
        .map_err(sql)?;
    // (name, declared type, primary-key position)
    let declared: Vec<(String, String, i64)> = info
        .query_map([], |r| {
            Ok((
                r.get(1)?,
                r.get::<_, Option<String>>(2)?.unwrap_or_default(),
                r.get(5)?,
                r.get::<_, i64>(6)?,
            ))
        })
        .map_err(sql)?
        .filter(|c| !matches!(c, Ok((_, _, _, 1))))
        .map(|c| c.map(|(n, t, pk, _)| (n, t, pk)))
        .collect::<rusqlite::Result<_>>()
        .map_err(sql)?;
    if declared.is_empty() {
        return Err(format!(
            "gpkg_contents lists feature table {:?}, but the database has no such table",
            layer.table
        ));
    }
    // Column names are case-insensitive in SQLite, and writers differ in the case they register.
    let Some(geometry_column) = declared
        .iter()
        .find(|(n, _, _)| n == &layer.column)
        .or_else(|| {
            declared
                .iter()
                .find(|(n, _, _)| n.eq_ignore_ascii_case(&layer.column))
        })
        .map(|(n, _, _)| n.clone())
    else {
        return Err(format!(
            "table {:?} has no column {:?}, which gpkg_geometry_columns names as its geometry",
            layer.table, layer.column
        ));
    };
    // The FID: the table's single integer primary key (a GeoPackage's `fid INTEGER PRIMARY KEY`), else, as GDAL
    // takes it in a view, an integer column named fid; else the rowid. The FID is an attribute too, as QGIS shows it.
    let integer = |t: &str| t.to_ascii_uppercase().contains("INT");
    let keys: Vec<&(String, String, i64)> = declared.iter().filter(|c| c.2 > 0).collect();
    let fid = match keys.as_slice() {
        [k] if integer(&k.1) => Some(k.0.clone()),
        [] => declared
            .iter()
            .find(|(n, t, _)| n.eq_ignore_ascii_case("fid") && integer(t))
            .map(|(n, _, _)| n.clone()),
        _ => None,
    };
    let mut skipped_blobs = Vec::new();
    let columns: Vec<Column> = declared
        .iter()
        .filter(|(n, _, _)| n != &geometry_column)
        .filter(|(n, t, _)| {
            // BLOB, or BLOB(max_size) as the spec allows.
            let blob = t.to_ascii_uppercase().starts_with("BLOB");
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
    // The rowid by a name no column has; a view has none, and its rows are numbered as they come.
    let view: bool = db
        .query_row(
            "SELECT count(*) > 0 FROM sqlite_master WHERE type = 'view' AND name = ?1",
            [&layer.table],
            |r| r.get(0),
        )
        .map_err(sql)?;
    let rowid = ["rowid", "_rowid_", "oid"]
        .into_iter()
        .find(|r| !declared.iter().any(|(n, _, _)| n.eq_ignore_ascii_case(r)));
    // What gives the FID, and the rows' order by it; `None` for a view without a fid column.
    let fid_expr = match (&fid, rowid) {
        (Some(f), _) => Some(quoted(f)),
        (None, _) if view => None,
        (None, Some(r)) => Some(r.to_string()),
        (None, None) => {
            return Err(format!(
                "table {:?} has no integer primary key and columns named rowid, _rowid_ and oid: its rows have no \
                 feature id",
                layer.table
            ))
        }
    };
    let select: Vec<String> = std::iter::once(fid_expr.clone().unwrap_or_else(|| "NULL".into()))
        .chain(std::iter::once(quoted(&geometry_column)))
        .chain(columns.iter().map(|c| quoted(&c.name)))
        .collect();
    let mut st = db
        .prepare(&format!(
            "SELECT {} FROM {}{}",
            select.join(", "),
            quoted(&layer.table),
            fid_expr
                .map(|f| format!(" ORDER BY {f}"))
                .unwrap_or_default()
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
            source_id: crate::feature::source_id(&attributes, file_name, fid),
            attributes,
            repairs,
            ..Default::default()
        };
        let read = match row.get_ref(1).map_err(sql)? {
            ValueRef::Null => Err((IssueReason::NoGeometry, "geometry is null".to_string())),
            ValueRef::Blob(b) => geometry(b),
            other => Err((
                IssueReason::MalformedGeometry,
                format!(
                    "the geometry column holds {} instead of a GeoPackage geometry blob",
                    sql_type_name(other)
                ),
            )),
        };
        let label = format!("FID {fid}");
        if let Some(faces) = put_geometry(&mut out, read, &label) {
            surfaces.push((features.len(), label, faces));
        }
        features.push(out);
    }
    Ok((features, surfaces))
}

fn sql_type_name(v: ValueRef) -> &'static str {
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
    /// Lines in plan (a LineString, MultiLineString or curve, arcs approximated), with the geometry's type name:
    /// not a building, but what `--streets` reads.
    Lines(Vec<Vec<[f64; 2]>>, &'static str),
}

/// Puts what reading a feature's geometry gave into `f`: the footprint's polygons, lines (then skipped: not a
/// footprint), or why it has none, each detail after `label` (the row: `FID 3`, `row 12`); a 3D surface model's faces
/// are handed back for `surface_model::stand`. Repairs made reading go with the feature either way.
pub(crate) fn put_geometry(
    f: &mut RawFeature,
    read: Result<Geometry, Skip>,
    label: &str,
) -> Option<Vec<Face>> {
    match read {
        Ok(Geometry::Footprint(polygons, repairs)) => {
            f.polygons = polygons;
            f.repairs.extend(repairs);
        }
        Ok(Geometry::Surfaces(faces, repairs)) => {
            f.repairs.extend(repairs);
            return Some(faces);
        }
        Ok(Geometry::Lines(lines, name)) => {
            f.lines = lines;
            f.skip = Some((
                IssueReason::UnsupportedGeometry,
                format!("{label}: {name} geometry is not a footprint"),
            ));
        }
        Err((reason, detail)) => f.skip = Some((reason, format!("{label}: {detail}"))),
    }
    None
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
    wkb_geometry(wkb)
}

/// A WKB geometry (ISO, or EWKB with its Z, M and SRID flags) → the footprint's polygons, a 3D model's faces or lines,
/// and the repairs made reading them.
pub(crate) fn wkb_geometry(wkb: &[u8]) -> Result<Geometry, Skip> {
    let mut r = Wkb { b: wkb, at: 0 };
    let mut out = Out::default();
    r.geometry(0, "", &mut out)?;
    if let Some(name) = out.line_type {
        return Ok(Geometry::Lines(out.lines, name));
    }
    if out.polygons.is_empty() && out.dropped.is_empty() {
        return Err((
            IssueReason::EmptyGeometry,
            "a collection without members".into(),
        ));
    }
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
    if out.arcs > 0 {
        out.repairs.push((
            IssueReason::CurvesApproximated,
            format!(
                "{} circular arc(s) approximated by straight segments of at most {ARC_STEP_DEG}° of arc",
                out.arcs
            ),
        ));
    }
    // Members dropped from a collection (only a collection drops any and still has polygons), said for a model too.
    if !out.dropped.is_empty() {
        out.repairs
            .push(crate::feature::dropped_members(&out.dropped));
    }
    // A footprint may have one degenerate part (dropped later as any); walls come several to a building.
    let surfaces = out.surface_type || out.on_edge >= 2;
    if surfaces && out.faces.len() == out.polygons.len() {
        return Ok(Geometry::Surfaces(out.faces, out.repairs));
    }
    Ok(Geometry::Footprint(out.polygons, out.repairs))
}

#[derive(Default)]
struct Out {
    polygons: Vec<RawPolygon>,
    repairs: Repairs,
    /// Members that are not polygons, as "member PATH (Type)", or the whole geometry's type.
    dropped: Vec<String>,
    /// Polygons with heights whose exterior ring stands on edge (a wall of a 3D surface model).
    on_edge: usize,
    /// The polygons with their heights, when they have them.
    faces: Vec<Face>,
    /// A PolyhedralSurface or TIN was read.
    surface_type: bool,
    /// Circular arcs approximated by straight segments, and the points they became.
    arcs: usize,
    arc_points: usize,
    /// The type of a geometry of lines, whose lines (x, y) are `lines`.
    line_type: Option<&'static str>,
    lines: Vec<Vec<[f64; 2]>>,
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

/// The name of a WKB geometry type (1–17).
fn type_name(kind: u32) -> &'static str {
    TYPE_NAMES
        .get(kind as usize)
        .copied()
        .unwrap_or("unknown type")
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
        let name = type_name(kind);
        match kind {
            3 | 17 => self.polygon(le, dims, out),
            10 => self.curve_polygon(le, dims, out),
            6 | 12 | 15 | 16 => {
                // A MultiPolygon's members are Polygons, a MultiSurface's Polygons or CurvePolygons, a
                // PolyhedralSurface's Polygons, a TIN's Triangles.
                let allowed: &[u32] = match kind {
                    12 => &[3, 10],
                    16 => &[17],
                    _ => &[3],
                };
                out.surface_type |= kind == 15 || kind == 16;
                let n = self.u32(le)?;
                for i in 0..n {
                    let (le, k, dims) = self.header()?;
                    if !allowed.contains(&k) {
                        return Err(self.bad_member(name, i, k));
                    }
                    if k == 10 {
                        self.curve_polygon(le, dims, out)?;
                    } else {
                        self.polygon(le, dims, out)?;
                    }
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
            2 | 5 | 8 | 9 | 11 if depth == 0 => {
                out.line_type = Some(name);
                self.lines(le, kind, dims, out)
            }
            _ if depth == 0 => {
                out.dropped.push(format!("{name} geometry"));
                Ok(())
            }
            _ => {
                // A member that is not polygonal is stepped over, and said.
                self.skip(le, kind, dims, name)?;
                out.dropped.push(format!("member {path} ({name})"));
                Ok(())
            }
        }
    }

    fn bad_member(&self, of: &str, i: u32, kind: u32) -> Skip {
        (
            IssueReason::MalformedGeometry,
            format!(
                "{of} member {i} is a {}, which a {of} cannot hold",
                type_name(kind)
            ),
        )
    }

    /// Steps over a point, curve or collection of them in a GeometryCollection: a Point; a LineString or
    /// CircularString; a CompoundCurve of those; a MultiPoint of Points, a MultiLineString of LineStrings, a MultiCurve
    /// of curves. Members are checked against what their collection may hold, so nesting ends within two levels.
    fn skip(&mut self, le: bool, kind: u32, dims: Dims, name: &str) -> Result<(), Skip> {
        let allowed: &[u32] = match kind {
            1 => {
                self.take(8 * dims.n)?;
                return Ok(());
            }
            2 | 8 => {
                let n = self.u32(le)? as usize;
                self.take(n.saturating_mul(8 * dims.n))?;
                return Ok(());
            }
            4 => &[1],
            5 => &[2],
            9 => &[2, 8],
            11 => &[2, 8, 9],
            _ => {
                return Err((
                    IssueReason::UnsupportedGeometry,
                    format!(
                        "a GeometryCollection holding a {name}, which this reader cannot step over"
                    ),
                ))
            }
        };
        let n = self.u32(le)?;
        for i in 0..n {
            let (le, k, dims) = self.header()?;
            if !allowed.contains(&k) {
                return Err(self.bad_member(name, i, k));
            }
            self.skip(le, k, dims, type_name(k))?;
        }
        Ok(())
    }

    /// `n` points of `dims` as x, y, z (z NaN without heights); a count beyond the bytes left is a broken blob, not
    /// an allocation.
    fn points(&mut self, le: bool, dims: Dims) -> Result<Vec<[f64; 3]>, Skip> {
        let n = self.u32(le)? as usize;
        if n.saturating_mul(8 * dims.n) > self.b.len() - self.at {
            return Err((
                IssueReason::MalformedGeometry,
                format!(
                    "a ring said to hold {n} points, more than the rest of its {}-byte WKB",
                    self.b.len()
                ),
            ));
        }
        let mut pts = Vec::with_capacity(n);
        for _ in 0..n {
            let x = self.f64(le)?;
            let y = self.f64(le)?;
            let z = if dims.z { self.f64(le)? } else { f64::NAN };
            self.take(8 * (dims.n - 2 - usize::from(dims.z)))?;
            if !(x.is_finite() && y.is_finite()) {
                return Err((
                    IssueReason::NonFiniteCoordinate,
                    format!("a vertex ({x}, {y}) that is not a finite number"),
                ));
            }
            if dims.z && !z.is_finite() {
                return Err((
                    IssueReason::NonFiniteCoordinate,
                    "a vertex whose height is not a finite number".into(),
                ));
            }
            pts.push([x, y, z]);
        }
        Ok(pts)
    }

    fn polygon(&mut self, le: bool, dims: Dims, out: &mut Out) -> Result<(), Skip> {
        let rings = self.u32(le)?;
        let mut polygon = Vec::new();
        for _ in 0..rings {
            polygon.push(self.points(le, dims)?);
        }
        out.add(polygon, dims.z);
        Ok(())
    }

    /// A CurvePolygon: rings that are LineStrings, CircularStrings (arcs approximated) or CompoundCurves of those.
    fn curve_polygon(&mut self, le: bool, dims: Dims, out: &mut Out) -> Result<(), Skip> {
        let rings = self.u32(le)?;
        let mut polygon = Vec::new();
        for i in 0..rings {
            let (le, k, dims) = self.header()?;
            let ring = match k {
                2 | 8 => self.curve(le, k, dims, out)?,
                9 => self.compound_curve(le, out)?,
                _ => return Err(self.bad_member("CurvePolygon", i, k)),
            };
            polygon.push(ring);
        }
        out.add(polygon, dims.z);
        Ok(())
    }

    /// A CompoundCurve's points (after its header): LineStrings and CircularStrings, each starting where the one
    /// before ends.
    fn compound_curve(&mut self, le: bool, out: &mut Out) -> Result<Vec<[f64; 3]>, Skip> {
        let n = self.u32(le)?;
        let mut line: Vec<[f64; 3]> = Vec::new();
        for j in 0..n {
            let (le, k, dims) = self.header()?;
            if k != 2 && k != 8 {
                return Err(self.bad_member("CompoundCurve", j, k));
            }
            let part = self.curve(le, k, dims, out)?;
            // Each part starts where the one before ends (GDAL refuses curves that do not).
            let xy = |p: Option<&[f64; 3]>| p.map(|p| [p[0], p[1]]);
            if line.last().is_some() && xy(line.last()) != xy(part.first()) {
                return Err((
                    IssueReason::MalformedGeometry,
                    format!(
                        "CompoundCurve part {j} does not start where part {} ends",
                        j - 1
                    ),
                ));
            }
            line.extend(&part[usize::from(!line.is_empty())..]);
        }
        Ok(line)
    }

    /// The lines of a LineString, CircularString or CompoundCurve (after its header), or of a MultiLineString's or
    /// MultiCurve's members, added to `out.lines` in plan.
    fn lines(&mut self, le: bool, kind: u32, dims: Dims, out: &mut Out) -> Result<(), Skip> {
        let line = match kind {
            2 | 8 => self.curve(le, kind, dims, out)?,
            9 => self.compound_curve(le, out)?,
            _ => {
                let allowed: &[u32] = if kind == 5 { &[2] } else { &[2, 8, 9] };
                let n = self.u32(le)?;
                for i in 0..n {
                    let (le, k, dims) = self.header()?;
                    if !allowed.contains(&k) {
                        return Err(self.bad_member(type_name(kind), i, k));
                    }
                    self.lines(le, k, dims, out)?;
                }
                return Ok(());
            }
        };
        out.lines.push(line.iter().map(|p| [p[0], p[1]]).collect());
        Ok(())
    }

    /// A LineString's points, or a CircularString's arcs as straight segments (counted in `out.arcs`).
    fn curve(
        &mut self,
        le: bool,
        kind: u32,
        dims: Dims,
        out: &mut Out,
    ) -> Result<Vec<[f64; 3]>, Skip> {
        let pts = self.points(le, dims)?;
        if kind == 2 || pts.is_empty() {
            return Ok(pts);
        }
        if pts.len().is_multiple_of(2) {
            return Err((
                IssueReason::MalformedGeometry,
                format!("a CircularString of {} points (arcs of three, each from the last's end, make an odd count)", pts.len()),
            ));
        }
        let mut line = vec![pts[0]];
        for arc in pts.windows(3).step_by(2) {
            let added = arc_points(arc[0], arc[1], arc[2]);
            out.arcs += 1;
            out.arc_points += added.len();
            line.extend(added);
            if out.arc_points > MAX_ARC_POINTS {
                return Err((
                    IssueReason::MalformedGeometry,
                    format!(
                        "circular arcs approximated by over {MAX_ARC_POINTS} points in one geometry"
                    ),
                ));
            }
        }
        Ok(line)
    }
}

impl Out {
    /// One polygon of x, y, z rings (z NaN without heights): its closing points dropped (an unclosed ring closed and
    /// said), a wall counted when its outline stands on edge, the plan kept and, with heights, the face.
    fn add(&mut self, rings: Vec<Vec<[f64; 3]>>, z: bool) {
        let mut polygon = Vec::with_capacity(rings.len());
        let mut face = Vec::with_capacity(rings.len());
        for (i, mut ring3) in rings.into_iter().enumerate() {
            if ring3.len() >= 2
                && ring3.first().map(|p| [p[0], p[1]]) == ring3.last().map(|p| [p[0], p[1]])
            {
                ring3.pop();
            } else if ring3.len() >= 3 {
                let what = if i == 0 {
                    "exterior ring".to_string()
                } else {
                    format!("hole {i}")
                };
                self.repairs.push((
                    IssueReason::RingClosed,
                    format!("{what} was not closed; closed it"),
                ));
            }
            let ring: Vec<[f64; 2]> = ring3.iter().map(|p| [p[0], p[1]]).collect();
            if z && i == 0 && ring.len() >= 3 {
                let (lo, hi) = ring3
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                        (lo.min(p[2]), hi.max(p[2]))
                    });
                let b = crate::feature::ring_box(&ring);
                let (w, h) = (b[2] - b[0], b[3] - b[1]);
                // On edge: a plan area nothing against the square of the outline's extent (a wall leaning a millimetre per
                // metre still), while its height varies.
                if hi > lo && signed_area2(&ring).abs() <= 1e-3 * w.max(h).powi(2) {
                    self.on_edge += 1;
                }
            }
            polygon.push(ring);
            face.push(ring3);
        }
        self.polygons.push(polygon);
        if z {
            self.faces.push(face);
        }
    }
}

/// Most points a geometry's arcs may become (a hostile row of tiny arcs would otherwise take gigabytes).
const MAX_ARC_POINTS: usize = 1_000_000;

/// Most of a circle an arc's straight segment spans, as GDAL's default (`OGR_ARC_STEPSIZE`, 4°).
pub(crate) const ARC_STEP_DEG: f64 = 4.0;

/// The arc from `a` through `b` to `c` as points after `a`, the last exactly `c`, each segment spanning at most
/// [`ARC_STEP_DEG`] of the circle (heights interpolated along it); collinear points are a straight line, `a == c` a
/// full circle through the point `b` opposite it.
pub(crate) fn arc_points(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> Vec<[f64; 3]> {
    let full = a[0] == c[0] && a[1] == c[1];
    let (centre, sweep) = if full {
        let m = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
        (m, std::f64::consts::TAU)
    } else {
        let (bx, by, cx, cy) = (b[0] - a[0], b[1] - a[1], c[0] - a[0], c[1] - a[1]);
        let d = 2.0 * (bx * cy - by * cx);
        let scale = (bx.abs() + by.abs() + cx.abs() + cy.abs()).powi(2);
        if d.abs() <= 1e-12 * scale {
            return vec![b, c];
        }
        let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
        let m = [
            a[0] + (cy * b2 - by * c2) / d,
            a[1] + (bx * c2 - cx * b2) / d,
        ];
        let angle = |p: [f64; 3]| (p[1] - m[1]).atan2(p[0] - m[0]);
        let turn = |from: f64, to: f64| (to - from).rem_euclid(std::f64::consts::TAU);
        // Counter-clockwise when b lies on the way from a to c going counter-clockwise.
        let ccw = d > 0.0;
        let sweep = if ccw {
            turn(angle(a), angle(c))
        } else {
            -turn(angle(c), angle(a))
        };
        (m, sweep)
    };
    let r = ((a[0] - centre[0]).powi(2) + (a[1] - centre[1]).powi(2)).sqrt();
    let start = (a[1] - centre[1]).atan2(a[0] - centre[0]);
    let steps = ((sweep.abs() / ARC_STEP_DEG.to_radians()).ceil() as usize).clamp(1, 100_000);
    (1..=steps)
        .map(|k| {
            let t = k as f64 / steps as f64;
            if k == steps {
                return if full { a } else { c };
            }
            let th = start + sweep * t;
            let z = if full { a[2] } else { a[2] + (c[2] - a[2]) * t };
            [centre[0] + r * th.cos(), centre[1] + r * th.sin(), z]
        })
        .collect()
}

/// A path GeoPackage input is read from: the extension `.gpkg`, in any case.
pub(crate) fn is_geopackage_name(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gpkg"))
}

/// A GeoPackage by its content, whatever its name (`None` when it is no SQLite database): an SQLite database whose
/// header's application_id is a GeoPackage's (`GPKG`, or `GP10`/`GP11` of versions 1.0 and 1.1), or, as older
/// writers leave it 0, one holding the `gpkg_contents` table the reader needs.
pub(crate) fn is_geopackage_content(path: &Path) -> Option<bool> {
    let mut head = Vec::with_capacity(72);
    std::fs::File::open(path)
        .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, 72), &mut head))
        .ok()?;
    if !head.starts_with(SQLITE_MAGIC) {
        return None;
    }
    if let Some(id) = head.get(68..72) {
        if [b"GPKG", b"GP10", b"GP11"].iter().any(|k| &k[..] == id) {
            return Some(true);
        }
    }
    let Ok(db) = open(path, &mut Vec::new()) else {
        return Some(false);
    };
    let listed: bool = db
        .query_row(
            "SELECT count(*) > 0 FROM sqlite_master WHERE type IN ('table', 'view') AND name = 'gpkg_contents'",
            [],
            |r| r.get(0),
        )
        .unwrap_or(false);
    Some(listed)
}

/// A GeoPackage input, by its name or by its content.
pub(crate) fn is_geopackage(path: &Path) -> bool {
    is_geopackage_name(path) || path.is_file() && is_geopackage_content(path) == Some(true)
}
