//! Dev-only: writes OGC GeoPackages (SQLite databases with the `gpkg_*` tables) holding exactly the tables, rows and
//! geometry bytes a test chooses, broken ones included, and the WKB those geometries are made of. Nothing is
//! validated: a ring is written as given (closed or not), a blob as its bytes.

use rusqlite::types::Value;
use rusqlite::Connection;
use std::path::Path;

/// A row of `gpkg_spatial_ref_sys`.
#[derive(Clone, Debug)]
pub struct Srs {
    pub srs_id: i64,
    pub organization: String,
    pub organization_coordsys_id: i64,
    /// WKT, or `undefined`.
    pub definition: String,
}

impl Srs {
    /// An EPSG CRS whose definition is not given (`undefined`): readers go by the code.
    pub fn epsg(code: i64) -> Srs {
        Srs {
            srs_id: code,
            organization: "EPSG".into(),
            organization_coordsys_id: code,
            definition: "undefined".into(),
        }
    }
}

/// One feature table: its rows' FIDs, geometries (`None`: SQL NULL) and attribute values in `columns`' order.
#[derive(Clone, Debug)]
pub struct Layer {
    pub table: String,
    pub geometry_column: String,
    /// `gpkg_geometry_columns.geometry_type_name`, e.g. `MULTIPOLYGON`.
    pub geometry_type: String,
    pub srs_id: i64,
    /// Attribute columns: name and declared SQL type (`TEXT`, `INTEGER`, `REAL`, `BOOLEAN`, `BLOB`, …).
    pub columns: Vec<(String, String)>,
    pub rows: Vec<Row>,
}

#[derive(Clone, Debug)]
pub struct Row {
    pub fid: i64,
    pub geometry: Option<Vec<u8>>,
    pub values: Vec<Value>,
}

/// Creates `path` (replacing it) with the three rows of `gpkg_spatial_ref_sys` every GeoPackage has (-1, 0, 4326),
/// then `srs`, then `layers`, each listed in `gpkg_contents` and `gpkg_geometry_columns`.
///
/// # Panics
/// On any SQLite error (a test's setup failing).
pub fn write(path: &Path, srs: &[Srs], layers: &[Layer]) {
    let _ = std::fs::remove_file(path);
    let db = Connection::open(path).expect("create the GeoPackage");
    db.execute_batch(
        "PRAGMA application_id = 1196444487; PRAGMA user_version = 10400;
         CREATE TABLE gpkg_spatial_ref_sys (srs_name TEXT NOT NULL, srs_id INTEGER PRIMARY KEY,
           organization TEXT NOT NULL, organization_coordsys_id INTEGER NOT NULL, definition TEXT NOT NULL,
           description TEXT);
         CREATE TABLE gpkg_contents (table_name TEXT NOT NULL PRIMARY KEY, data_type TEXT NOT NULL,
           identifier TEXT UNIQUE, description TEXT DEFAULT '', last_change DATETIME NOT NULL DEFAULT
           (strftime('%Y-%m-%dT%H:%M:%fZ','now')), min_x DOUBLE, min_y DOUBLE, max_x DOUBLE, max_y DOUBLE,
           srs_id INTEGER);
         CREATE TABLE gpkg_geometry_columns (table_name TEXT NOT NULL, column_name TEXT NOT NULL,
           geometry_type_name TEXT NOT NULL, srs_id INTEGER NOT NULL, z TINYINT NOT NULL, m TINYINT NOT NULL,
           CONSTRAINT pk_geom_cols PRIMARY KEY (table_name, column_name));
         INSERT INTO gpkg_spatial_ref_sys VALUES ('Undefined Cartesian SRS', -1, 'NONE', -1, 'undefined', NULL);
         INSERT INTO gpkg_spatial_ref_sys VALUES ('Undefined geographic SRS', 0, 'NONE', 0, 'undefined', NULL);
         INSERT INTO gpkg_spatial_ref_sys VALUES ('WGS 84 geodetic', 4326, 'EPSG', 4326, 'GEOGCS[\"WGS 84\",DATUM[\"WGS_1984\",SPHEROID[\"WGS 84\",6378137,298.257223563]],PRIMEM[\"Greenwich\",0],UNIT[\"degree\",0.0174532925199433],AUTHORITY[\"EPSG\",\"4326\"]]', NULL);",
    )
    .expect("GeoPackage tables");
    for s in srs {
        db.execute(
            "INSERT OR REPLACE INTO gpkg_spatial_ref_sys VALUES (?1, ?2, ?3, ?4, ?5, NULL)",
            rusqlite::params![
                format!("srs {}", s.srs_id),
                s.srs_id,
                s.organization,
                s.organization_coordsys_id,
                s.definition
            ],
        )
        .expect("srs row");
    }
    for l in layers {
        let q = |n: &str| format!("\"{}\"", n.replace('"', "\"\""));
        let mut cols = vec![
            "fid INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL".to_string(),
            format!("{} {}", q(&l.geometry_column), l.geometry_type),
        ];
        cols.extend(l.columns.iter().map(|(n, t)| format!("{} {t}", q(n))));
        db.execute_batch(&format!(
            "CREATE TABLE {} ({});",
            q(&l.table),
            cols.join(", ")
        ))
        .expect("feature table");
        db.execute(
            "INSERT INTO gpkg_contents (table_name, data_type, identifier, srs_id) VALUES (?1, 'features', ?1, ?2)",
            rusqlite::params![l.table, l.srs_id],
        )
        .expect("contents row");
        db.execute(
            "INSERT INTO gpkg_geometry_columns VALUES (?1, ?2, ?3, ?4, 0, 0)",
            rusqlite::params![l.table, l.geometry_column, l.geometry_type, l.srs_id],
        )
        .expect("geometry column row");
        let marks = vec!["?"; l.columns.len() + 2].join(", ");
        let tx = db.unchecked_transaction().expect("transaction");
        {
            let mut st = tx
                .prepare(&format!("INSERT INTO {} VALUES ({marks})", q(&l.table)))
                .expect("insert statement");
            for r in &l.rows {
                let mut vals = vec![
                    Value::Integer(r.fid),
                    r.geometry.clone().map_or(Value::Null, Value::Blob),
                ];
                vals.extend(r.values.iter().cloned());
                st.execute(rusqlite::params_from_iter(vals)).expect("row");
            }
        }
        tx.commit().expect("commit");
    }
}

/// Envelope of a geometry blob's header (its indicator: none 0, xy 1, xyz 2, xym 3, xyzm 4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Envelope {
    None,
    Xy,
    Xyz,
    Xym,
    Xyzm,
}

/// A GeoPackage geometry blob: `GP`, version 0, flags (little-endian header, the envelope's indicator, `empty`), the
/// srs_id, an envelope of zeros of the indicated size, then `wkb`.
pub fn blob(srs_id: i32, envelope: Envelope, empty: bool, wkb: &[u8]) -> Vec<u8> {
    let (indicator, doubles) = match envelope {
        Envelope::None => (0u8, 0),
        Envelope::Xy => (1, 4),
        Envelope::Xyz => (2, 6),
        Envelope::Xym => (3, 6),
        Envelope::Xyzm => (4, 8),
    };
    let mut b = vec![b'G', b'P', 0, 1 | (indicator << 1) | (u8::from(empty) << 4)];
    b.extend(srs_id.to_le_bytes());
    b.extend(std::iter::repeat_n(0u8, 8 * doubles));
    b.extend_from_slice(wkb);
    b
}

/// WKB writer: byte order and how Z is marked.
#[derive(Clone, Copy, Debug)]
pub struct Wkb {
    pub little_endian: bool,
    /// Z marked EWKB's way (type | 0x80000000) instead of ISO's (type + 1000).
    pub ewkb_z: bool,
}

impl Default for Wkb {
    fn default() -> Self {
        Wkb {
            little_endian: true,
            ewkb_z: false,
        }
    }
}

impl Wkb {
    fn u32(&self, out: &mut Vec<u8>, v: u32) {
        out.extend(if self.little_endian {
            v.to_le_bytes()
        } else {
            v.to_be_bytes()
        });
    }

    fn f64(&self, out: &mut Vec<u8>, v: f64) {
        out.extend(if self.little_endian {
            v.to_le_bytes()
        } else {
            v.to_be_bytes()
        });
    }

    /// The header of a geometry of ISO type `kind` (1–17), with Z when `z`.
    pub fn header(&self, out: &mut Vec<u8>, kind: u32, z: bool) {
        out.push(u8::from(self.little_endian));
        let code = match (z, self.ewkb_z) {
            (false, _) => kind,
            (true, false) => kind + 1000,
            (true, true) => kind | 0x8000_0000,
        };
        self.u32(out, code);
    }

    /// A Polygon of x, y rings, written as given.
    pub fn polygon(&self, rings: &[Vec<[f64; 2]>]) -> Vec<u8> {
        let rings: Vec<Vec<[f64; 3]>> = rings
            .iter()
            .map(|r| r.iter().map(|p| [p[0], p[1], f64::NAN]).collect())
            .collect();
        let mut out = Vec::new();
        self.polygon_into(&mut out, &rings, false);
        out
    }

    /// A Polygon Z.
    pub fn polygon_z(&self, rings: &[Vec<[f64; 3]>]) -> Vec<u8> {
        let mut out = Vec::new();
        self.polygon_into(&mut out, rings, true);
        out
    }

    fn polygon_into(&self, out: &mut Vec<u8>, rings: &[Vec<[f64; 3]>], z: bool) {
        self.header(out, 3, z);
        self.u32(out, rings.len() as u32);
        for r in rings {
            self.u32(out, r.len() as u32);
            for p in r {
                self.f64(out, p[0]);
                self.f64(out, p[1]);
                if z {
                    self.f64(out, p[2]);
                }
            }
        }
    }

    /// A MultiPolygon of x, y polygons.
    pub fn multipolygon(&self, polygons: &[Vec<Vec<[f64; 2]>>]) -> Vec<u8> {
        let mut out = Vec::new();
        self.header(&mut out, 6, false);
        self.u32(&mut out, polygons.len() as u32);
        for p in polygons {
            out.extend(self.polygon(p));
        }
        out
    }

    /// A MultiPolygon Z.
    pub fn multipolygon_z(&self, polygons: &[Vec<Vec<[f64; 3]>>]) -> Vec<u8> {
        self.polygons_z(6, polygons)
    }

    /// A PolyhedralSurface Z (ISO type 15) of Polygon Z faces.
    pub fn polyhedral_surface_z(&self, faces: &[Vec<Vec<[f64; 3]>>]) -> Vec<u8> {
        self.polygons_z(15, faces)
    }

    /// A geometry of ISO type `kind` with Z whose members are Polygon Z.
    fn polygons_z(&self, kind: u32, polygons: &[Vec<Vec<[f64; 3]>>]) -> Vec<u8> {
        let mut out = Vec::new();
        self.header(&mut out, kind, true);
        self.u32(&mut out, polygons.len() as u32);
        for p in polygons {
            self.polygon_into(&mut out, p, true);
        }
        out
    }

    /// A TIN Z (ISO type 16) of Triangle Z members (type 17), each one closed ring of four points.
    pub fn tin_z(&self, triangles: &[[[f64; 3]; 3]]) -> Vec<u8> {
        let mut out = Vec::new();
        self.header(&mut out, 16, true);
        self.u32(&mut out, triangles.len() as u32);
        for t in triangles {
            self.header(&mut out, 17, true);
            self.u32(&mut out, 1);
            self.u32(&mut out, 4);
            for p in t.iter().chain(std::iter::once(&t[0])) {
                for c in p {
                    self.f64(&mut out, *c);
                }
            }
        }
        out
    }

    /// A Point.
    pub fn point(&self, p: [f64; 2]) -> Vec<u8> {
        let mut out = Vec::new();
        self.header(&mut out, 1, false);
        self.f64(&mut out, p[0]);
        self.f64(&mut out, p[1]);
        out
    }

    /// A LineString.
    pub fn line(&self, pts: &[[f64; 2]]) -> Vec<u8> {
        let mut out = Vec::new();
        self.header(&mut out, 2, false);
        self.u32(&mut out, pts.len() as u32);
        for p in pts {
            self.f64(&mut out, p[0]);
            self.f64(&mut out, p[1]);
        }
        out
    }

    /// A CircularString (ISO type 8) through x, y points: arcs of three points, each starting where the last ended.
    pub fn circular_string(&self, pts: &[[f64; 2]]) -> Vec<u8> {
        let mut out = Vec::new();
        self.header(&mut out, 8, false);
        self.u32(&mut out, pts.len() as u32);
        for p in pts {
            self.f64(&mut out, p[0]);
            self.f64(&mut out, p[1]);
        }
        out
    }

    /// A geometry of ISO type `kind` whose members are already written WKB: a CompoundCurve (9) of curves, a
    /// CurvePolygon (10) of ring curves, a MultiSurface (12), MultiPoint (4), ….
    pub fn of_members(&self, kind: u32, members: &[Vec<u8>]) -> Vec<u8> {
        let mut out = Vec::new();
        self.header(&mut out, kind, false);
        self.u32(&mut out, members.len() as u32);
        for m in members {
            out.extend_from_slice(m);
        }
        out
    }

    /// A GeometryCollection of already written members.
    pub fn collection(&self, members: &[Vec<u8>]) -> Vec<u8> {
        let mut out = Vec::new();
        self.header(&mut out, 7, false);
        self.u32(&mut out, members.len() as u32);
        for m in members {
            out.extend_from_slice(m);
        }
        out
    }
}
