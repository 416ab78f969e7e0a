//! Esri File Geodatabase input (a `.gdb` folder, as ArcGIS, ArcGIS Pro, QGIS and GDAL write it): one feature class read
//! by this module's own parser of the open format (the `.gdbtable` of rows and the `.gdbtablx` of their offsets; the
//! layout as documented by the GDAL project's reverse-engineered specification). The catalog table
//! (`a00000001.gdbtable`) names the tables; the feature class asked for with `--layer` (or the only one) is read: its
//! polygons or MultiPatch models, every other field an attribute, and the CRS from the geometry field's WKT (Esri WKT,
//! identified as a `.prj`'s is).
//!
//! Polygons are rings in the shapefile's winding (outer clockwise), organized as a shapefile's are; curves (circular
//! arcs, Bézier curves, elliptic arcs) are followed in short segments, reported. A MultiPatch (ArcGIS's 3D buildings)
//! is a 3D surface model, read as a shapefile's MultiPatch is. A row whose geometry cannot become a footprint is a
//! skipped feature with the reason and its OBJECTID; a file that is not a geodatabase table, or is cut short, refuses
//! the input.

use crate::crs::DeclaredCrs;
use crate::feature::{RawFeature, RawPolygon, VectorDoc, Want};
use crate::report::IssueReason;
use crate::surface_model::{Face, Surfaces};
use citylod_mesh::signed_area2;
use citylod_model::{AttrValue, Attributes};
use std::path::{Path, PathBuf};

type Skip = (IssueReason, String);
type Repairs = Vec<(IssueReason, String)>;

/// The catalog of every geodatabase: the table listing the others, each by its row number.
const CATALOG: &str = "a00000001.gdbtable";

/// Whether `path` is a File Geodatabase: a folder named `*.gdb`, or any folder holding the catalog table, or a ZIP
/// archive (`Buildings.gdb.zip`, as geodatabases are downloaded; one without a geodatabase inside is refused).
/// A ZIP archive without the `.zip` extension counts when its content says so: a member in a `*.gdb` folder, or
/// the catalog table.
pub(crate) fn is_filegdb(path: &Path) -> bool {
    let extension = |e: &str| path.extension().is_some_and(|x| x.eq_ignore_ascii_case(e));
    (path.is_dir() && (extension("gdb") || path.join(CATALOG).is_file()))
        || (path.is_file() && (extension("zip") || zip_holds_filegdb(path)))
}

/// A ZIP archive (by its content, whatever its name) holding a File Geodatabase: a member inside a `*.gdb` folder,
/// or the catalog table.
pub(crate) fn zip_holds_filegdb(path: &Path) -> bool {
    if !crate::zip::begins_as_zip(path) {
        return false;
    }
    let Ok(archive) = crate::zip::Archive::open(path) else {
        return false;
    };
    archive
        .members
        .iter()
        .filter(|m| !m.name.starts_with("__MACOSX/"))
        .any(|m| {
            let mut parts: Vec<&str> = m.name.split('/').collect();
            let file = parts.pop().unwrap_or("");
            file.eq_ignore_ascii_case(CATALOG)
                || parts
                    .iter()
                    .any(|d| d.to_ascii_lowercase().ends_with(".gdb"))
        })
}

/// Where the geodatabase's files are: a folder, or a folder inside a ZIP archive.
enum Source {
    Dir(PathBuf),
    Zip {
        archive: crate::zip::Archive,
        /// The members' names by file name, for those in the geodatabase's folder.
        files: std::collections::HashMap<String, usize>,
        folder: String,
    },
}

impl Source {
    fn open(path: &Path) -> Result<Source, String> {
        if path.is_dir() {
            return Ok(Source::Dir(path.to_path_buf()));
        }
        let archive = crate::zip::Archive::open(path)?;
        // The folders holding a catalog table (macOS's resource forks left out).
        let mut folders: Vec<String> = archive
            .members
            .iter()
            .filter(|m| !m.name.starts_with("__MACOSX/"))
            .filter_map(|m| {
                let (folder, file) = m.name.rsplit_once('/').unwrap_or(("", &m.name));
                file.eq_ignore_ascii_case(CATALOG)
                    .then(|| folder.to_string())
            })
            .collect();
        folders.sort();
        folders.dedup();
        let folder = match folders.as_slice() {
            [one] => one.clone(),
            [] => {
                return Err(
                    "a ZIP archive without a File Geodatabase in it (no folder holding a00000001.gdbtable); unzip \
                     other archives and give citylod the files in them"
                        .into(),
                )
            }
            many => {
                return Err(format!(
                    "a ZIP archive holding {} File Geodatabases ({}); unzip it and give citylod the one to read",
                    many.len(),
                    crate::geojson::listing(many)
                ))
            }
        };
        let files = archive
            .members
            .iter()
            .enumerate()
            .filter_map(|(k, m)| {
                let (dir, file) = m.name.rsplit_once('/').unwrap_or(("", &m.name));
                (dir == folder).then(|| (file.to_ascii_lowercase(), k))
            })
            .collect();
        Ok(Source::Zip {
            archive,
            files,
            folder,
        })
    }

    /// The geodatabase's name, for feature ids (`Buildings.gdb`).
    fn name(&self, path: &Path) -> String {
        let last = |p: &str| p.rsplit('/').next().unwrap_or(p).to_string();
        match self {
            Source::Zip { folder, .. } if !folder.is_empty() => last(folder),
            // `.` or `..` has no name of its own: its full path has.
            _ => std::fs::canonicalize(path)
                .ok()
                .as_deref()
                .unwrap_or(path)
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
        }
    }

    fn exists(&self, file: &str) -> bool {
        match self {
            Source::Dir(d) => d.join(file).is_file(),
            Source::Zip { files, .. } => files.contains_key(&file.to_ascii_lowercase()),
        }
    }

    /// The file's bytes (at most `limit` of them, when given).
    fn read(&self, file: &str, limit: Option<u64>) -> Result<Vec<u8>, String> {
        match self {
            Source::Dir(d) => {
                use std::io::Read;
                let mut out = Vec::new();
                std::fs::File::open(d.join(file))
                    .and_then(|f| f.take(limit.unwrap_or(u64::MAX)).read_to_end(&mut out))
                    .map_err(|e| format!("cannot read {file}: {e}"))?;
                Ok(out)
            }
            Source::Zip { archive, files, .. } => {
                let k = files
                    .get(&file.to_ascii_lowercase())
                    .ok_or_else(|| format!("{file} is not in the archive"))?;
                archive.read(&archive.members[*k], limit)
            }
        }
    }
}

/// The files of a geodatabase's tables, each with what it is, for refusing one given as the input.
pub(crate) const MEMBERS: [(&str, &str); 6] = [
    ("gdbtable", "table"),
    ("gdbtablx", "row index"),
    ("gdbindexes", "index list"),
    ("atx", "attribute index"),
    ("spx", "spatial index"),
    ("freelist", "free-space list"),
];

/// Reads the feature class `layer` of the geodatabase `dir` (the only one when `layer` is `None`). Errors name what is
/// wrong with the geodatabase as a whole; one unusable row is a skipped feature.
/// `want` says which classes can be read and chosen: polygons and MultiPatch for buildings, lines for `--streets`.
pub(crate) fn read(path: &Path, layer: Option<&str>, want: Want) -> Result<VectorDoc, String> {
    read_class(path, layer, want, false)
}

/// [`read`], or with `any_geometry` a class of points or lines too (its rows then skipped), for tests of the rows.
fn read_class(
    path: &Path,
    layer: Option<&str>,
    want: Want,
    any_geometry: bool,
) -> Result<VectorDoc, String> {
    let source = Source::open(path)?;
    if !source.exists(CATALOG) {
        return Err(format!(
            "a File Geodatabase folder holds its catalog table {CATALOG}, and this one has none"
        ));
    }
    let catalog =
        Table::open(&source, "a00000001").map_err(|e| format!("its catalog {CATALOG}: {e}"))?;
    let name_field = catalog
        .fields
        .iter()
        .position(|f| f.name.eq_ignore_ascii_case("Name"))
        .ok_or_else(|| format!("its catalog {CATALOG} has no Name field"))?;
    let format_field = catalog
        .fields
        .iter()
        .position(|f| f.name.eq_ignore_ascii_case("FileFormat"));
    // Every table the catalog lists with a file of its own (FileFormat 0), by name and row number.
    let mut tables: Vec<(String, u64)> = Vec::new();
    for (oid, row) in catalog.rows() {
        let values = catalog
            .values(row.map_err(|e| format!("its catalog {CATALOG}, row {oid}: {e}"))?)
            .map_err(|e| format!("its catalog {CATALOG}, row {oid}: {e}"))?;
        let Cell::Value(AttrValue::String(name)) = &values[name_field] else {
            continue;
        };
        if let Some(k) = format_field {
            if !matches!(values[k], Cell::Value(AttrValue::Int(0)) | Cell::Null) {
                continue;
            }
        }
        tables.push((name.clone(), oid));
    }
    // The feature classes: user tables (not GDB_*) with a geometry field whose file is there. Only their field
    // descriptions are read here.
    let system = |n: &str| {
        n.as_bytes()
            .get(..4)
            .is_some_and(|p| p.eq_ignore_ascii_case(b"GDB_"))
    };
    let mut classes: Vec<(String, String, Layout)> = Vec::new();
    let mut unreadable: Vec<(String, String)> = Vec::new();
    for (name, oid) in tables.iter().filter(|(n, _)| !system(n)) {
        let stem = format!("a{oid:08x}");
        // ArcGIS's compressed tables (Compressed Data Format, or 9.x's Smart Data Compression) have a file of their own.
        let compressed = ["cdf", "sdc", "gdbtable.cdf", "gdbtable.sdc"]
            .iter()
            .any(|e| source.exists(&format!("{stem}.{e}")));
        if compressed {
            unreadable.push((
                name.clone(),
                "a compressed table, which this reader cannot read: uncompress the geodatabase in ArcGIS \
                 (Uncompress File Geodatabase Data) first"
                    .to_string(),
            ));
            continue;
        }
        if !source.exists(&format!("{stem}.gdbtable")) {
            unreadable.push((name.clone(), format!("its file {stem}.gdbtable is missing")));
            continue;
        }
        match describe_file(&source, &stem) {
            Ok((fields, layout)) if fields.iter().any(|f| matches!(f.kind, Kind::Geometry(_))) => {
                classes.push((name.clone(), stem, layout))
            }
            Ok(_) => {}
            Err(e) => unreadable.push((name.clone(), e)),
        }
    }
    let items = items(&source, &tables);
    // What the geodatabase holds, for messages: its feature classes (in their feature datasets) with their geometry,
    // and those not readable.
    let in_dataset = |n: &str| match items.dataset.get(&n.to_lowercase()) {
        Some(d) => format!("{d}/{n}"),
        None => n.to_string(),
    };
    let label =
        |(n, _, t): &(String, String, Layout)| format!("{} ({})", in_dataset(n), t.kind_name());
    // The classes but those at `skip` (indices), then those not readable.
    let all_but = |classes: &[(String, String, Layout)], skip: &[usize]| -> Vec<String> {
        (0..classes.len())
            .filter(|k| !skip.contains(k))
            .map(|k| label(&classes[k]))
            .chain(
                unreadable
                    .iter()
                    .map(|(n, _)| format!("{n} (not readable)")),
            )
            .collect()
    };
    let holds = |classes: &[(String, String, Layout)]| {
        let parts = all_but(classes, &[]);
        if parts.is_empty() {
            "none".to_string()
        } else {
            parts.join(", ")
        }
    };
    // Polygons and MultiPatch can be buildings, lines streets; a class of any geometry (0) either.
    let wanted = |t: &Layout| match want {
        Want::Footprints => matches!(t.geometry_type, 4 | 9 | 0),
        Want::Lines => matches!(t.geometry_type, 3 | 0),
    };
    // For messages: the classes wanted, what they are read as, and the option that names one.
    let (kinds, role, option) = match want {
        Want::Footprints => ("polygon or MultiPatch", "buildings", "--layer"),
        Want::Lines => ("line", "street lines", "--streets-layer"),
    };
    let chosen = match layer {
        Some(asked) => {
            // A class inside a feature dataset may be named with it (`Dataset/Class`, `Dataset\Class`): classes
            // are named by their own names, unique in a geodatabase.
            let asked = asked.rsplit(['/', '\\']).next().unwrap_or(asked);
            // ArcGIS's names are case-insensitive: an exact match first, else the one equal but for case.
            let find = |names: &mut dyn Iterator<Item = &str>| -> Option<usize> {
                let names: Vec<&str> = names.collect();
                names.iter().position(|n| *n == asked).or_else(|| {
                    let mut same = names
                        .iter()
                        .enumerate()
                        .filter(|(_, n)| n.eq_ignore_ascii_case(asked));
                    same.next()
                        .filter(|_| same.next().is_none())
                        .map(|(k, _)| k)
                })
            };
            if let Some(k) = find(&mut classes.iter().map(|c| c.0.as_str())) {
                k
            } else if let Some(k) = find(&mut unreadable.iter().map(|c| c.0.as_str())) {
                let (n, why) = &unreadable[k];
                return Err(format!("feature class {n:?} cannot be read: {why}"));
            } else if let Some(k) = find(&mut tables.iter().map(|c| c.0.as_str())) {
                let n = &tables[k].0;
                return Err(if system(n) {
                    format!("{n:?} is one of the geodatabase's system tables, not a feature class (feature classes: {})", holds(&classes))
                } else {
                    format!("{n:?} is a table without geometry, not a feature class (feature classes: {})", holds(&classes))
                });
            } else {
                // A feature dataset: the classes in it.
                let inside: Vec<String> = classes
                    .iter()
                    .filter(|(n, _, _)| {
                        items
                            .dataset
                            .get(&n.to_lowercase())
                            .is_some_and(|d| d.eq_ignore_ascii_case(asked))
                    })
                    .map(|(n, _, t)| format!("{n} ({})", t.kind_name()))
                    .collect();
                return Err(if inside.is_empty() {
                    format!(
                        "no feature class {asked:?} (feature classes: {})",
                        holds(&classes)
                    )
                } else {
                    format!(
                        "{asked:?} is a feature dataset holding {}; name the feature class to read with {option}",
                        inside.join(", ")
                    )
                });
            }
        }
        None => {
            let candidates: Vec<usize> = (0..classes.len())
                .filter(|&k| wanted(&classes[k].2))
                .collect();
            match candidates.as_slice() {
                [k] => *k,
                [] if classes.is_empty() && unreadable.is_empty() => return Err(
                    "a File Geodatabase without feature classes (no table with a geometry field)"
                        .into(),
                ),
                [] if classes.is_empty() => {
                    return Err(format!(
                        "no feature class could be read: {}",
                        crate::geojson::listing(
                            &unreadable
                                .iter()
                                .map(|(n, why)| format!("{n} ({why})"))
                                .collect::<Vec<_>>()
                        )
                    ))
                }
                [] => {
                    return Err(format!(
                        "it holds no {kinds} feature class, which {role} are (feature classes: {})",
                        holds(&classes)
                    ))
                }
                many => {
                    let others = all_but(&classes, many);
                    return Err(format!(
                        "it holds {} {kinds} feature classes, {}; name the one to read with {option}{}",
                        many.len(),
                        many.iter()
                            .map(|&k| label(&classes[k]))
                            .collect::<Vec<_>>()
                            .join(", "),
                        if others.is_empty() {
                            String::new()
                        } else {
                            format!(" (it also holds {}, not read as {role})", others.join(", "))
                        }
                    ));
                }
            }
        }
    };
    if !any_geometry && !wanted(&classes[chosen].2) {
        let (n, _, t) = &classes[chosen];
        return Err(format!(
            "feature class {n:?} holds {}; {role} are {} (feature classes: {})",
            t.kind_name(),
            match want {
                Want::Footprints => "polygons or MultiPatch",
                Want::Lines => "lines",
            },
            holds(&classes)
        ));
    }
    let (name, stem, _) = classes.remove(chosen);
    let table = Table::open(&source, &stem)
        .map_err(|e| format!("feature class {name:?} ({stem}.gdbtable): {e}"))?;
    let mut notes = Vec::new();
    // Row indexes whose counts disagree, and what was read of them.
    notes.extend(
        catalog
            .index_note
            .as_ref()
            .map(|n| format!("its catalog {CATALOG}: {n}")),
    );
    notes.extend(
        items
            .index_note
            .as_ref()
            .map(|n| format!("its table GDB_Items: {n}")),
    );
    notes.extend(
        table
            .index_note
            .as_ref()
            .map(|n| format!("feature class {name:?} ({stem}.gdbtable): {n}")),
    );
    let others = holds(&classes);
    notes.push(if others == "none" {
        format!("read feature class {name:?}")
    } else {
        format!("read feature class {name:?}; the geodatabase also holds {others}")
    });
    if !unreadable.is_empty() {
        notes.push(format!(
            "table(s) of the geodatabase not readable: {}",
            crate::geojson::listing(
                &unreadable
                    .iter()
                    .map(|(n, why)| format!("{n} ({why})"))
                    .collect::<Vec<_>>()
            )
        ));
    }
    let geometry = table.geometry().expect("a feature class").clone();
    let (mut declared_crs, z_unit_m) = declared_crs(&geometry.wkt, &mut notes);
    // ArcGIS records the class's spatial reference by its well-known ID in the class's definition (GDB_Items): an
    // EPSG code there names the CRS with authority, where the WKT alone is matched by its parameters.
    if declared_crs.is_some() {
        if let Some(code) = items.wkid.get(&name.to_lowercase()) {
            let epsg = format!("EPSG:{code}");
            if crate::crs::Crs::parse(&epsg).is_ok() {
                notes.retain(|n| !n.contains("identified from"));
                declared_crs = Some(DeclaredCrs::Name(epsg));
            }
        }
    }
    let dir_name = source.name(path);
    // Coded value domains: each coded field gets its code's description beside it, as ArcGIS shows it.
    let coded: Vec<(String, Vec<(String, String)>)> = items
        .field_domains
        .get(&name.to_lowercase())
        .into_iter()
        .flatten()
        .filter_map(|(field, domain)| Some((field.clone(), items.domains.get(domain)?.clone())))
        .collect();
    if !coded.is_empty() {
        notes.push(format!(
            "field(s) with coded values ({}): each code's description is added as FIELD_description",
            crate::geojson::listing(&coded.iter().map(|(f, _)| f.clone()).collect::<Vec<_>>())
        ));
    }
    let (features, surfaces) = features(&table, &geometry, &dir_name, &coded, &mut notes);
    Ok(VectorDoc {
        features,
        surfaces,
        declared_crs,
        z_unit_m,
        notes,
    })
}

/// What the item table (GDB_Items) says of the feature classes: the EPSG code of each one's spatial reference
/// (`LatestWKID`, else `WKID`; Esri's own codes, over 100,000, left out) and the feature dataset it is in. Keys are
/// class names in lower case. Empty when the geodatabase has no such table or it cannot be read.
#[derive(Default)]
struct Items {
    wkid: std::collections::HashMap<String, u32>,
    dataset: std::collections::HashMap<String, String>,
    /// Per class, its fields' coded value domains: field name → domain name.
    field_domains: std::collections::HashMap<String, Vec<(String, String)>>,
    /// Coded value domains by name: (code as text, description).
    domains: std::collections::HashMap<String, Vec<(String, String)>>,
    /// What was made of GDB_Items's row index, when its counts disagree (see [`offsets`]).
    index_note: Option<String>,
}

/// The text of the first child element of `node` named `name`.
fn child_text<'a>(node: roxmltree::Node<'a, '_>, name: &str) -> Option<&'a str> {
    node.children()
        .find(|c| c.tag_name().name() == name)
        .and_then(|c| c.text())
        .map(str::trim)
}

/// A coded value domain's definition (ArcGIS's GPCodedValueDomain2 XML): its name and (code, description) pairs.
fn coded_domain(xml: &str) -> Option<(String, Vec<(String, String)>)> {
    let doc = roxmltree::Document::parse(xml).ok()?;
    let root = doc.root_element();
    let name = child_text(root, "DomainName")?.to_string();
    let values = root
        .descendants()
        .filter(|n| n.tag_name().name() == "CodedValue")
        .filter_map(|v| {
            Some((
                child_text(v, "Code")?.to_string(),
                child_text(v, "Name")?.to_string(),
            ))
        })
        .collect();
    Some((name, values))
}

/// The fields of a class definition that have a domain: (field, domain).
fn field_domains(xml: &str) -> Vec<(String, String)> {
    let Ok(doc) = roxmltree::Document::parse(xml) else {
        return Vec::new();
    };
    doc.descendants()
        .filter(|n| n.tag_name().name() == "GPFieldInfoEx")
        .filter_map(|f| {
            Some((
                child_text(f, "Name")?.to_string(),
                child_text(f, "DomainName")?.to_string(),
            ))
        })
        .filter(|(_, d)| !d.is_empty())
        .collect()
}

fn items(source: &Source, tables: &[(String, u64)]) -> Items {
    let mut out = Items::default();
    let Some((_, oid)) = tables.iter().find(|(n, _)| n == "GDB_Items") else {
        return out;
    };
    let Ok(table) = Table::open(source, &format!("a{oid:08x}")) else {
        return out;
    };
    out.index_note = table.index_note.clone();
    let field = |name: &str| {
        table
            .fields
            .iter()
            .position(|f| f.name.eq_ignore_ascii_case(name))
    };
    let (Some(name_k), Some(path_k), Some(definition_k)) =
        (field("Name"), field("Path"), field("Definition"))
    else {
        return out;
    };
    for (_, row) in table.rows() {
        let Ok(values) = row.and_then(|r| table.values(r)) else {
            continue;
        };
        let text = |k: usize| match &values[k] {
            Cell::Value(AttrValue::String(t)) => Some(t.as_str()),
            _ => None,
        };
        let (Some(name), Some(d)) = (text(name_k), text(definition_k)) else {
            continue;
        };
        if d.contains("CodedValueDomain") {
            if let Some((domain, values)) = coded_domain(d) {
                out.domains.insert(domain, values);
            }
            continue;
        }
        if !d.contains("DEFeatureClassInfo") {
            continue;
        }
        let key = name.to_lowercase();
        let with_domain = field_domains(d);
        if !with_domain.is_empty() {
            out.field_domains.insert(key.clone(), with_domain);
        }
        let tag = |t: &str| -> Option<u32> {
            let open = format!("<{t}>");
            let at = d.find(&open)? + open.len();
            let end = d[at..].find('<')? + at;
            d[at..end].trim().parse().ok()
        };
        if let Some(code) = tag("LatestWKID")
            .filter(|c| *c < 100_000)
            .or_else(|| tag("WKID").filter(|c| *c < 100_000))
        {
            out.wkid.insert(key.clone(), code);
        }
        // `\Dataset\Class` for a class in a feature dataset, `\Class` for one at the top.
        let parts: Vec<&str> = text(path_k)
            .unwrap_or("")
            .split('\\')
            .filter(|p| !p.is_empty())
            .collect();
        if let [dataset, _] = parts.as_slice() {
            out.dataset.insert(key, dataset.to_string());
        }
    }
    out
}

/// The CRS of the geometry field's WKT (Esri's, as in a `.prj`), and the metres per unit of z its VERTCS gives; `None`
/// for a field without a spatial reference (ArcGIS writes the "Unknown" one's GUID, or nothing).
fn declared_crs(wkt: &str, notes: &mut Vec<String>) -> (Option<DeclaredCrs>, Option<f64>) {
    let wkt = wkt.trim();
    if wkt.is_empty() || wkt.starts_with('{') || wkt.eq_ignore_ascii_case("unknown") {
        return (None, None);
    }
    let source = crate::prj::WktSource {
        member: "feature class's spatial reference (its WKT)",
        whose: "the feature class's",
    };
    let (crs, note) = crate::prj::declared_crs(wkt, &source);
    notes.extend(note);
    let (z_unit_m, note) = crate::prj::vertical_unit_m(wkt);
    notes.extend(note);
    (Some(crs), z_unit_m)
}

/// Every row of the feature class, in OBJECTID order: its attributes, and its polygons or its model's faces.
fn features(
    table: &Table,
    geometry: &GeometryDef,
    dir_name: &str,
    coded: &[(String, Vec<(String, String)>)],
    notes: &mut Vec<String>,
) -> (Vec<RawFeature>, Vec<Surfaces>) {
    let shape_field = table
        .fields
        .iter()
        .position(|f| matches!(f.kind, Kind::Geometry(_)))
        .expect("a feature class");
    let left_out: Vec<String> = table
        .fields
        .iter()
        .filter(|f| matches!(f.kind, Kind::Binary | Kind::Raster(_)))
        .map(|f| f.name.clone())
        .collect();
    if !left_out.is_empty() {
        notes.push(format!(
            "binary and raster field(s) not read as attributes: {}",
            crate::geojson::listing(&left_out)
        ));
    }
    // Each field's coded values (code as text → description), looked up once.
    let coded_at: Vec<Option<std::collections::HashMap<&str, &str>>> = table
        .fields
        .iter()
        .map(|f| {
            coded
                .iter()
                .find(|(name, _)| *name == f.name)
                .map(|(_, values)| {
                    values
                        .iter()
                        .map(|(c, d)| (c.as_str(), d.as_str()))
                        .collect()
                })
        })
        .collect();
    let multipatch_layer = table.layout.geometry_type == 9;
    let mut features = Vec::new();
    let mut surfaces = Vec::new();
    for (oid, row) in table.rows() {
        let name = format!("OBJECTID {oid}");
        // A row that cannot be read (the index points outside the table, the row ends inside a field) is listed as
        // skipped, with what is wrong; the rows around it are read.
        let values = match row.and_then(|r| table.values(r)) {
            Ok(v) => v,
            Err(e) => {
                let mut attributes = Attributes::new();
                attributes.insert("OBJECTID".into(), AttrValue::Int(oid as i64));
                features.push(RawFeature {
                    source_id: crate::feature::source_id(&attributes, dir_name, oid),
                    attributes,
                    skip: Some((
                        IssueReason::UnreadableRow,
                        format!("{name}: the row cannot be read: {e}"),
                    )),
                    ..Default::default()
                });
                continue;
            }
        };
        let mut attributes = Attributes::new();
        let mut blob = None;
        for (k, (field, value)) in table.fields.iter().zip(values).enumerate() {
            match (&field.kind, value) {
                (Kind::ObjectId, _) => {
                    attributes.insert(field.name.clone(), AttrValue::Int(oid as i64));
                }
                (_, Cell::Bytes(b)) if k == shape_field => blob = Some(b),
                (Kind::Binary | Kind::Raster(_) | Kind::Geometry(_), _) => {}
                (_, Cell::Null) => {
                    attributes.insert(field.name.clone(), AttrValue::Null);
                }
                (_, Cell::Value(v)) => {
                    if let Some(values) = &coded_at[k] {
                        let code = match &v {
                            AttrValue::Int(i) => Some(i.to_string()),
                            AttrValue::Float(x) => Some(x.to_string()),
                            AttrValue::String(t) => Some(t.clone()),
                            _ => None,
                        };
                        if let Some(description) = code.and_then(|c| values.get(c.as_str())) {
                            attributes.insert(
                                format!("{}_description", field.name),
                                AttrValue::String(description.to_string()),
                            );
                        }
                    }
                    attributes.insert(field.name.clone(), v);
                }
                (_, Cell::Bytes(_)) => {}
            }
        }
        let mut out = RawFeature {
            source_id: crate::feature::source_id(&attributes, dir_name, oid),
            attributes,
            ..Default::default()
        };
        match blob {
            Some(b) => match shape(b, geometry, multipatch_layer) {
                Ok(Shape::Footprint(polygons, repairs)) => {
                    out.polygons = polygons;
                    out.repairs.extend(repairs);
                }
                Ok(Shape::Surfaces(faces)) => surfaces.push((features.len(), name, faces)),
                Ok(Shape::Lines(lines)) => {
                    out.lines = lines;
                    out.skip = Some((
                        IssueReason::UnsupportedGeometry,
                        format!("{name}: a line, not a polygon"),
                    ));
                }
                Err((reason, detail)) => out.skip = Some((reason, format!("{name}: {detail}"))),
            },
            _ => out.skip = Some((IssueReason::NoGeometry, format!("{name}: geometry is null"))),
        }
        features.push(out);
    }
    (features, surfaces)
}

// ---------------------------------------------------------------------------------------------------------------------
// Tables

/// A field's type, with what its description says about its values.
#[derive(Debug, Clone)]
enum Kind {
    Int16,
    Int32,
    Int64,
    Float32,
    Float64,
    String,
    DateTime,
    DateOnly,
    TimeOnly,
    DateTimeOffset,
    ObjectId,
    Geometry(Box<GeometryDef>),
    Binary,
    /// How its values are stored: 1 a managed raster's number (4 bytes), else a length and bytes.
    Raster(u8),
    Guid,
    Xml,
}

/// A geometry field's description: its CRS, and how its integer coordinates become numbers.
#[derive(Debug, Clone, Default)]
struct GeometryDef {
    wkt: String,
    x_origin: f64,
    y_origin: f64,
    xy_scale: f64,
    z_origin: f64,
    z_scale: f64,
}

#[derive(Debug, Clone)]
struct Field {
    name: String,
    kind: Kind,
    nullable: bool,
}

/// One value of a row.
enum Cell<'a> {
    Null,
    Value(AttrValue),
    /// A geometry, binary or raster field's bytes.
    Bytes(&'a [u8]),
}

/// One `.gdbtable` with its `.gdbtablx`, read whole.
struct Table {
    bytes: Vec<u8>,
    /// Where each row is, by OBJECTID (deleted rows left out).
    offsets: Vec<(u64, u64)>,
    /// What was made of a row index whose count of rows and offsets disagree (see [`offsets`]), for the file's notes.
    index_note: Option<String>,
    fields: Vec<Field>,
    layout: Layout,
    nullable: usize,
}

/// Longest row read: a row claiming more is a damaged file, not a building.
const MAX_ROW_BYTES: u64 = 1 << 31;

impl Table {
    fn open(source: &Source, stem: &str) -> Result<Table, String> {
        let bytes = source.read(&format!("{stem}.gdbtable"), None)?;
        let tablx = source
            .read(&format!("{stem}.gdbtablx"), None)
            .map_err(|e| format!("cannot read its row index: {e}"))?;
        Table::parse(bytes, &tablx)
    }

    /// A table from the bytes of its `.gdbtable` and `.gdbtablx`.
    fn parse(bytes: Vec<u8>, tablx: &[u8]) -> Result<Table, String> {
        let (fields, layout) = describe(&bytes)?;
        // The table header's count of live rows (deleted ones not counted), after its version.
        let live = Cursor::at(&bytes, 4).u32().map_or(0, u64::from);
        let (offsets, index_note) = offsets(tablx, layout.version, live)?;
        let nullable = fields.iter().filter(|f| f.nullable).count();
        Ok(Table {
            bytes,
            offsets,
            index_note,
            fields,
            layout,
            nullable,
        })
    }

    fn geometry(&self) -> Option<&GeometryDef> {
        self.fields.iter().find_map(|f| match &f.kind {
            Kind::Geometry(g) => Some(&**g),
            _ => None,
        })
    }

    /// Each row's OBJECTID and bytes (after its length), in OBJECTID order.
    fn rows(&self) -> impl Iterator<Item = (u64, Result<&[u8], String>)> + '_ {
        self.offsets.iter().map(move |&(oid, at)| {
            let row = (|| {
                let len = Cursor::at(&self.bytes, usize::try_from(at).unwrap_or(usize::MAX))
                    .i32()
                    .ok_or("its offset lies past the end of the table")?;
                // A deleted row's length is negated; the row index should not point to one.
                let len = u32::try_from(len)
                    .map_err(|_| format!("the row at offset {at} is marked deleted"))?;
                let start = at as usize + 4;
                if len as u64 > MAX_ROW_BYTES || start + len as usize > self.bytes.len() {
                    return Err(format!(
                        "a row of {len} bytes at offset {at}, past the end of the table ({} bytes)",
                        self.bytes.len()
                    ));
                }
                Ok(&self.bytes[start..start + len as usize])
            })();
            (oid, row)
        })
    }

    /// A row's values, field by field (OBJECTID as null: it is the row's number).
    fn values<'r>(&self, row: &'r [u8]) -> Result<Vec<Cell<'r>>, String> {
        let flag_bytes = self.nullable.div_ceil(8);
        let flags = row
            .get(..flag_bytes)
            .ok_or("a row shorter than its null flags")?;
        let mut c = Cursor::at(row, flag_bytes);
        let mut nullable_index = 0usize;
        let mut out = Vec::with_capacity(self.fields.len());
        for f in &self.fields {
            if matches!(f.kind, Kind::ObjectId) {
                out.push(Cell::Null);
                continue;
            }
            if f.nullable {
                let bit = nullable_index;
                nullable_index += 1;
                if flags[bit / 8] & (1 << (bit % 8)) != 0 {
                    out.push(Cell::Null);
                    continue;
                }
            }
            let short = || format!("the row ends inside field {:?}", f.name);
            let v = match &f.kind {
                Kind::Int16 => AttrValue::Int(c.i16().ok_or_else(short)? as i64),
                Kind::Int32 => AttrValue::Int(c.i32().ok_or_else(short)? as i64),
                Kind::Int64 => AttrValue::Int(c.i64().ok_or_else(short)?),
                Kind::Float32 => AttrValue::Float(c.f32().ok_or_else(short)? as f64),
                Kind::Float64 => AttrValue::Float(c.f64().ok_or_else(short)?),
                Kind::String if !self.layout.utf8 => {
                    // A table written with UTF-16 text: the length in bytes.
                    let n = c.varuint().ok_or_else(short)?;
                    let b = c.take(n).ok_or_else(short)?;
                    let units: Vec<u16> = b
                        .chunks_exact(2)
                        .map(|p| u16::from_le_bytes([p[0], p[1]]))
                        .collect();
                    AttrValue::String(String::from_utf16_lossy(&units))
                }
                Kind::String | Kind::Xml => {
                    let n = c.varuint().ok_or_else(short)?;
                    let b = c.take(n).ok_or_else(short)?;
                    AttrValue::String(String::from_utf8_lossy(b).into_owned())
                }
                Kind::DateTime => date_time(c.f64().ok_or_else(short)?, true, true),
                Kind::DateOnly => date_time(c.f64().ok_or_else(short)?, true, false),
                Kind::TimeOnly => date_time(c.f64().ok_or_else(short)?, false, true),
                Kind::DateTimeOffset => {
                    let days = c.f64().ok_or_else(short)?;
                    let minutes = c.i16().ok_or_else(short)?;
                    match date_time(days, true, true) {
                        AttrValue::String(s) => {
                            let sign = if minutes < 0 { '-' } else { '+' };
                            let m = minutes.unsigned_abs();
                            AttrValue::String(format!("{s}{sign}{:02}:{:02}", m / 60, m % 60))
                        }
                        other => other,
                    }
                }
                Kind::Guid => {
                    let b = c.take(16).ok_or_else(short)?;
                    AttrValue::String(guid(b))
                }
                Kind::Raster(1) => {
                    out.push(Cell::Bytes(c.take(4).ok_or_else(short)?));
                    continue;
                }
                Kind::Geometry(_) | Kind::Binary | Kind::Raster(_) => {
                    let n = c.varuint().ok_or_else(short)?;
                    out.push(Cell::Bytes(c.take(n).ok_or_else(short)?));
                    continue;
                }
                Kind::ObjectId => unreachable!("handled above"),
            };
            out.push(Cell::Value(v));
        }
        Ok(out)
    }
}

/// A GUID's 16 bytes as ArcGIS shows it: `{XXXXXXXX-XXXX-XXXX-XXXX-XXXXXXXXXXXX}`, the first three groups little-endian.
fn guid(b: &[u8]) -> String {
    format!(
        "{{{:02X}{:02X}{:02X}{:02X}-{:02X}{:02X}-{:02X}{:02X}-{:02X}{:02X}-{:02X}{:02X}{:02X}{:02X}{:02X}{:02X}}}",
        b[3], b[2], b[1], b[0], b[5], b[4], b[7], b[6], b[8], b[9], b[10], b[11], b[12], b[13], b[14], b[15]
    )
}

/// Days since 1899-12-30 (the OLE automation date of Esri's date fields) as ISO 8601 text: the date, the time, or
/// both; to the millisecond when it has any. A value out of any calendar's reach is kept as its number.
fn date_time(days: f64, date: bool, time: bool) -> AttrValue {
    if !days.is_finite() || days.abs() > 3.0e6 {
        return AttrValue::Float(days);
    }
    let ms_total = (days * 86_400_000.0).round() as i64;
    let (day, ms) = (
        ms_total.div_euclid(86_400_000),
        ms_total.rem_euclid(86_400_000),
    );
    // 1899-12-30 is day 693,594 after 0000-03-01 in the proleptic Gregorian calendar's civil-from-days count.
    let (y, m, d) = civil_from_days(day - 25_569);
    let (h, min, s, milli) = (ms / 3_600_000, ms / 60_000 % 60, ms / 1000 % 60, ms % 1000);
    let clock = if milli == 0 {
        format!("{h:02}:{min:02}:{s:02}")
    } else {
        format!("{h:02}:{min:02}:{s:02}.{milli:03}")
    };
    AttrValue::String(match (date, time) {
        (true, true) => format!("{y:04}-{m:02}-{d:02}T{clock}"),
        (true, false) => format!("{y:04}-{m:02}-{d:02}"),
        _ => clock,
    })
}

/// The Gregorian (year, month, day) of a count of days since 1970-01-01.
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// The fields of a `.gdbtable` and its layer's geometry type, from its header and field descriptions.
fn describe(b: &[u8]) -> Result<(Vec<Field>, Layout), String> {
    let mut h = Cursor::at(b, 0);
    let table_version = h.u32();
    if !matches!(table_version, Some(3 | 4)) || b.len() < 40 {
        return Err(
            "not a File Geodatabase table (a .gdbtable starts with the number 3, or 4 for 64-bit OBJECTIDs)"
                .into(),
        );
    }
    let mut c = Cursor::at(b, 32);
    let start = c.u64().ok_or("cut short in its header")?;
    let mut c = Cursor::at(b, usize::try_from(start).unwrap_or(usize::MAX));
    let short = || "cut short in its field descriptions".to_string();
    let _size = c.u32().ok_or_else(short)?;
    let version = c.u32().ok_or_else(short)?;
    if !matches!(version, 3 | 4 | 6) {
        return Err(format!(
            "a table of format version {version}, which this reader does not know (it reads 3, 4 and 6: \
             ArcGIS 9, 10 and ArcGIS Pro 3.2's 64-bit OBJECTIDs)"
        ));
    }
    let flags = c.u32().ok_or_else(short)?;
    let layout = Layout {
        version: table_version.expect("checked"),
        geometry_type: (flags & 0xff) as u8,
        utf8: flags & 0x100 != 0,
        has_m: flags & (1 << 30) != 0,
        has_z: flags & (1 << 31) != 0,
    };
    let count = c.u16().ok_or_else(short)?;
    let mut fields = Vec::with_capacity(count as usize);
    for k in 0..count {
        let field = field(&mut c, &layout).map_err(|e| format!("field {}: {e}", k + 1))?;
        fields.push(field);
    }
    Ok((fields, layout))
}

/// The header and field descriptions of a table (its first bytes only), for listing the feature classes.
fn describe_file(source: &Source, stem: &str) -> Result<(Vec<Field>, Layout), String> {
    let file = format!("{stem}.gdbtable");
    let head = source.read(&file, Some(40))?;
    let at = Cursor::at(&head, 32)
        .u64()
        .ok_or("cut short in its header")?;
    let head = source.read(&file, Some(at.saturating_add(4)))?;
    let size = Cursor::at(&head, at as usize)
        .u32()
        .ok_or("cut short before its field descriptions")?;
    if size > MAX_FIELDS_BYTES {
        return Err(format!("field descriptions of {size} bytes"));
    }
    describe(&source.read(&file, Some(at + 4 + u64::from(size)))?)
}

/// Longest field description section read (GDAL's limit): more is a damaged table.
const MAX_FIELDS_BYTES: u32 = 10 << 20;

/// What a table's header says about all its rows.
#[derive(Debug, Clone, Copy)]
struct Layout {
    /// 3, or 4 for 64-bit OBJECTIDs (ArcGIS Pro 3.2).
    version: u32,
    /// The layer's geometry type (1 point, 2 multipoint, 3 polyline, 4 polygon, 9 MultiPatch; 0 none).
    geometry_type: u8,
    /// Strings are UTF-8 (else UTF-16, as some tables are written).
    utf8: bool,
    /// The layer has M, Z: its geometry field then lists their extents.
    has_m: bool,
    has_z: bool,
}

impl Layout {
    fn kind_name(&self) -> &'static str {
        match self.geometry_type {
            1 => "points",
            2 => "multipoints",
            3 => "lines",
            4 => "polygons",
            9 => "MultiPatch",
            _ => "geometry",
        }
    }
}

/// One field's description (after which `c` stands at the next).
fn field(c: &mut Cursor, layout: &Layout) -> Result<Field, String> {
    let short = || "cut short".to_string();
    let n = c.u8().ok_or_else(short)?;
    let name = c.utf16(n as usize).ok_or_else(short)?;
    let n = c.u8().ok_or_else(short)?;
    let _alias = c.utf16(n as usize).ok_or_else(short)?;
    let kind = c.u8().ok_or_else(short)?;
    // Flags: 0x1 nullable, 0x4 editable; a default value's bytes follow its length only in an editable field.
    let with_default = |c: &mut Cursor| -> Option<bool> {
        let _width = c.u8()?;
        let flags = c.u8()?;
        let default = c.u8()?;
        if flags & 4 != 0 {
            c.take(default as u64)?;
        }
        Some(flags & 1 != 0)
    };
    let (kind, nullable) = match kind {
        0 => (Kind::Int16, with_default(c).ok_or_else(short)?),
        1 => (Kind::Int32, with_default(c).ok_or_else(short)?),
        2 => (Kind::Float32, with_default(c).ok_or_else(short)?),
        3 => (Kind::Float64, with_default(c).ok_or_else(short)?),
        5 => (Kind::DateTime, with_default(c).ok_or_else(short)?),
        13 => (Kind::Int64, with_default(c).ok_or_else(short)?),
        14 => (Kind::DateOnly, with_default(c).ok_or_else(short)?),
        15 => (Kind::TimeOnly, with_default(c).ok_or_else(short)?),
        16 => (Kind::DateTimeOffset, with_default(c).ok_or_else(short)?),
        4 => {
            let _max = c.u32().ok_or_else(short)?;
            let flags = c.u8().ok_or_else(short)?;
            let default = c.varuint().ok_or_else(short)?;
            if flags & 4 != 0 {
                c.take(default).ok_or_else(short)?;
            }
            (Kind::String, flags & 1 != 0)
        }
        6 => {
            c.take(2).ok_or_else(short)?;
            (Kind::ObjectId, false)
        }
        7 => {
            let _ = c.u8().ok_or_else(short)?;
            let flags = c.u8().ok_or_else(short)?;
            (
                Kind::Geometry(Box::new(geometry_def(c, layout)?)),
                flags & 1 != 0,
            )
        }
        8 => {
            let _ = c.u8().ok_or_else(short)?;
            let flags = c.u8().ok_or_else(short)?;
            (Kind::Binary, flags & 1 != 0)
        }
        9 => {
            let (nullable, storage) = raster_def(c)?;
            (Kind::Raster(storage), nullable)
        }
        10 | 11 => {
            let _width = c.u8().ok_or_else(short)?;
            let flags = c.u8().ok_or_else(short)?;
            (Kind::Guid, flags & 1 != 0)
        }
        12 => {
            let _width = c.u8().ok_or_else(short)?;
            let flags = c.u8().ok_or_else(short)?;
            (Kind::Xml, flags & 1 != 0)
        }
        t => {
            return Err(format!(
                "{name:?} is of field type {t}, which this reader does not know"
            ))
        }
    };
    Ok(Field {
        name,
        kind,
        nullable,
    })
}

/// A geometry field's description after its flags: the WKT, then origins, scales and tolerances (M's before Z's,
/// as its own flags say), the extent (Z's before M's, as the layer's flags say) and the spatial grid.
fn geometry_def(c: &mut Cursor, layout: &Layout) -> Result<GeometryDef, String> {
    let short = || "cut short in its geometry description".to_string();
    let wkt_bytes = c.u16().ok_or_else(short)?;
    let wkt = c.utf16(wkt_bytes as usize / 2).ok_or_else(short)?;
    let flags = c.u8().ok_or_else(short)?;
    let (has_m, has_z) = (flags & 2 != 0, flags & 4 != 0);
    let mut g = GeometryDef {
        wkt,
        ..Default::default()
    };
    g.x_origin = c.f64().ok_or_else(short)?;
    g.y_origin = c.f64().ok_or_else(short)?;
    g.xy_scale = c.f64().ok_or_else(short)?;
    if has_m {
        c.take(16).ok_or_else(short)?;
    }
    if has_z {
        g.z_origin = c.f64().ok_or_else(short)?;
        g.z_scale = c.f64().ok_or_else(short)?;
    }
    // The xy tolerance, the M and Z tolerances, the x and y extent.
    c.take(8 * (1 + u64::from(has_m) + u64::from(has_z)) + 32)
        .ok_or_else(short)?;
    c.take(16 * (u64::from(layout.has_z) + u64::from(layout.has_m)))
        .ok_or_else(short)?;
    c.take(1).ok_or_else(short)?;
    let grids = c.u32().ok_or_else(short)?;
    if !(1..=3).contains(&grids) {
        return Err(format!(
            "a spatial index of {grids} grid levels (1 to 3 are known)"
        ));
    }
    c.take(8 * u64::from(grids)).ok_or_else(short)?;
    if !(g.xy_scale.is_finite() && g.xy_scale > 0.0) {
        return Err(format!("an xy scale of {}", g.xy_scale));
    }
    if has_z && !(g.z_scale.is_finite() && g.z_scale > 0.0) {
        // As GDAL reads a zero z scale: the smallest positive number, so that z stays finite or is refused.
        g.z_scale = f64::MIN_POSITIVE;
    }
    Ok(g)
}

/// A raster field's description, skipped: its raster column's name, its CRS, its origins and scales.
/// A raster field's description: whether it may be null, and how its values are stored (0 a path to an external
/// raster, 1 a managed raster's number, 2 the raster inline).
fn raster_def(c: &mut Cursor) -> Result<(bool, u8), String> {
    let short = || "cut short in its raster description".to_string();
    c.take(1).ok_or_else(short)?;
    let nullable = c.u8().ok_or_else(short)? & 1 != 0;
    let n = c.u8().ok_or_else(short)?;
    c.utf16(n as usize).ok_or_else(short)?;
    let wkt_bytes = c.u16().ok_or_else(short)?;
    c.take(u64::from(wkt_bytes)).ok_or_else(short)?;
    let flags = c.u8().ok_or_else(short)?;
    if flags > 0 {
        let (has_m, has_z) = (flags & 2 != 0, flags & 4 != 0);
        let doubles =
            3 + 2 * (u64::from(has_m) + u64::from(has_z)) + 1 + u64::from(has_m) + u64::from(has_z);
        c.take(8 * doubles).ok_or_else(short)?;
    }
    let storage = c.u8().ok_or_else(short)?;
    Ok((nullable, storage))
}

/// A row index read: each row's (OBJECTID, offset), and a note when its counts disagree.
type RowIndex = (Vec<(u64, u64)>, Option<String>);

/// The rows' offsets from a `.gdbtablx`, by OBJECTID: blocks of 1,024 offsets, some left out when a whole block
/// of OBJECTIDs has no row (then a bitmap after them says which blocks are there). `version` is the table's: 4 has
/// 64-bit counts. `live` is the table header's count of live rows: when the index holds offsets past the rows its own
/// header counts, it tells whether those are rows (all read, said in the note returned) or not (left, said so); when
/// it agrees with neither, the index is refused.
fn offsets(x: &[u8], version: u32, live: u64) -> Result<RowIndex, String> {
    let mut h = Cursor::at(x, 0);
    let short = || "its row index (.gdbtablx) is cut short".to_string();
    if h.u32() != Some(version) {
        return Err(format!(
            "its row index (.gdbtablx) does not start with the table's version, {version}"
        ));
    }
    let (blocks, rows, size) = if version == 3 {
        let blocks = u64::from(h.u32().ok_or_else(short)?);
        let rows = u64::from(h.u32().ok_or_else(short)?);
        (blocks, Some(rows), u64::from(h.u32().ok_or_else(short)?))
    } else {
        let blocks = h.u64().ok_or_else(short)?;
        (blocks, None, u64::from(h.u32().ok_or_else(short)?))
    };
    if !(4..=6).contains(&size) {
        return Err(format!(
            "its row index (.gdbtablx) gives offsets of {size} bytes (4, 5 or 6 are known)"
        ));
    }
    let body = blocks
        .checked_mul(1024 * size)
        .and_then(|n| n.checked_add(16))
        .filter(|&n| n <= x.len() as u64)
        .ok_or_else(short)?;
    // Which blocks of 1,024 OBJECTIDs the offsets hold: all, in order, unless the trailer has a bitmap.
    let mut t = Cursor::at(x, body as usize);
    let (present, rows): (Vec<u64>, u64) = match rows {
        Some(rows) => {
            // The trailer: the bitmap's length in 32-bit words (0: every block is there), the blocks it covers, the
            // blocks stored (again), then the bitmap.
            let words = u64::from(t.u32().ok_or_else(short)?);
            let bits = u64::from(t.u32().ok_or_else(short)?);
            let stored = u64::from(t.u32().ok_or_else(short)?);
            t.take(4).ok_or_else(short)?;
            if stored != blocks {
                return Err(format!(
                    "its row index (.gdbtablx) says {blocks} blocks of rows at its start and {stored} at its end"
                ));
            }
            if words == 0 {
                ((0..blocks).collect(), rows)
            } else {
                let bitmap = t.take(4 * words).ok_or_else(short)?;
                (present_blocks(bitmap, bits.min(32 * words), blocks)?, rows)
            }
        }
        None => {
            let rows = t.u64().ok_or_else(short)?;
            let section = t.u32().ok_or_else(short)?;
            // ArcGIS Pro's one known form of the bitmap: a 22-byte head, 32,768 bytes of bits, a 52-byte tail.
            match section {
                0 => ((0..blocks).collect(), rows),
                32_842 => {
                    t.take(22).ok_or_else(short)?;
                    let bitmap = t.take(32_768).ok_or_else(short)?;
                    (present_blocks(bitmap, 32_768 * 8, blocks)?, rows)
                }
                n => {
                    return Err(format!(
                        "its row index (.gdbtablx) has a block map of {n} bytes, a layout this reader does not \
                         know (64-bit OBJECTIDs with whole blocks of rows deleted)"
                    ))
                }
            }
        }
    };
    // Every offset the index holds, in OBJECTID order: those past the rows its header counts too, for telling a
    // count that is wrong from padding.
    let mut out = Vec::new();
    let mut within = 0usize;
    for (k, block) in present.into_iter().enumerate() {
        for j in 0..1024u64 {
            let oid = block * 1024 + j + 1;
            let at = (16 + (k as u64 * 1024 + j) * size) as usize;
            let offset = x[at..at + size as usize]
                .iter()
                .rev()
                .fold(0u64, |v, &byte| (v << 8) | u64::from(byte));
            if offset != 0 {
                out.push((oid, offset));
                within += usize::from(oid <= rows);
            }
        }
    }
    let last = out.last().map_or(0, |&(oid, _)| oid);
    let held = out.len();
    let live_rows = counted(live, "live row");
    if within == held {
        // An index within its own count: its offsets are the rows, unless the table's header counts more live rows
        // than it locates (those cannot be found) or fewer (all are read).
        let note = match (held as u64).cmp(&live) {
            std::cmp::Ordering::Equal => None,
            std::cmp::Ordering::Less => Some(format!(
                "its header counts {live_rows} but its row index (.gdbtablx) locates {held}: {} not found, not \
                 read. The geodatabase is damaged: repair it in ArcGIS (Recover File Geodatabase) or export the \
                 feature class again",
                counted(live - held as u64, "row")
            )),
            std::cmp::Ordering::Greater => Some(format!(
                "its header counts {live_rows} but its row index (.gdbtablx) locates {held} (OBJECTIDs up to \
                 {last}): all {held} read"
            )),
        };
        return Ok((out, note));
    }
    // The table's header (its count of live rows) tells which of the index's two counts is right.
    if within as u64 == live {
        out.truncate(within);
        return Ok((
            out,
            Some(format!(
                "its row index (.gdbtablx) holds {} past the {} its header counts (OBJECTIDs up to {last}); not \
                 read, as the table's header counts {live_rows}, the {within} read",
                counted((held - within) as u64, "row offset"),
                counted(rows, "row")
            )),
        ));
    }
    if held as u64 == live {
        return Ok((
            out,
            Some(format!(
                "its row index (.gdbtablx) counts {} but holds offsets of {held} (OBJECTIDs up to {last}), as many \
                 as the table's header counts live rows: all {held} read",
                counted(rows, "row")
            )),
        ));
    }
    Err(format!(
        "its row index (.gdbtablx) counts {} and holds offsets of {held} (OBJECTIDs up to {last}), {within} of them \
         within its count, while the table's header counts {live_rows}: the index and its table disagree, so which \
         rows the table holds cannot be told. The geodatabase is damaged: repair it in ArcGIS (Recover File \
         Geodatabase) or export the feature class again",
        counted(rows, "row")
    ))
}

/// `n` and its noun, plural unless `n` is 1 ("1 row", "3 rows").
fn counted(n: u64, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// The blocks a row index's bitmap marks present (bit i of the little-endian bytes: block i), of `bits`; there
/// must be `blocks` of them.
fn present_blocks(bitmap: &[u8], bits: u64, blocks: u64) -> Result<Vec<u64>, String> {
    let ids: Vec<u64> = (0..bits.min(8 * bitmap.len() as u64))
        .filter(|&b| bitmap[(b / 8) as usize] & (1 << (b % 8)) != 0)
        .collect();
    if ids.len() as u64 != blocks {
        return Err(format!(
            "its row index (.gdbtablx) holds {blocks} blocks of rows and its bitmap marks {}",
            ids.len()
        ));
    }
    Ok(ids)
}

// ---------------------------------------------------------------------------------------------------------------------
// Geometry

enum Shape {
    /// Polygons, and the repairs made reading them (curves followed in segments among them).
    Footprint(Vec<RawPolygon>, Repairs),
    /// A MultiPatch's faces.
    Surfaces(Vec<Face>),
    /// A polyline's parts in plan (curves followed in segments): not a building, but what `--streets` reads.
    Lines(Vec<Vec<[f64; 2]>>),
}

/// Flags of the "general" geometry types (50–54) in the type's high bits.
const HAS_Z: u64 = 0x8000_0000;
const HAS_M: u64 = 0x4000_0000;
const HAS_CURVES: u64 = 0x2000_0000;

/// A geometry blob (after its length) → polygons or a MultiPatch's faces.
/// `multipatch_layer`: the layer is a MultiPatch one, whose rows GDAL writes as polygons with z (their faces, walls
/// among them) when asked to (`CREATE_MULTIPATCH=YES`): those are models too.
fn shape(b: &[u8], g: &GeometryDef, multipatch_layer: bool) -> Result<Shape, Skip> {
    let malformed = |d: String| (IssueReason::MalformedGeometry, d);
    let mut c = Cursor::at(b, 0);
    let kind = c
        .varuint()
        .ok_or_else(|| malformed("an empty geometry blob".into()))?;
    let base = kind & 0xff;
    let (has_z, has_m, curves) = match base {
        5 => (false, false, false),
        15 => (true, true, false),
        19 => (true, false, false),
        25 => (false, true, false),
        51 => (kind & HAS_Z != 0, kind & HAS_M != 0, kind & HAS_CURVES != 0),
        31 => (true, true, false),
        32 => (true, false, false),
        54 => (kind & HAS_Z != 0, kind & HAS_M != 0, false),
        3 => (false, false, false),
        10 => (true, false, false),
        13 => (true, true, false),
        23 => (false, true, false),
        50 => (kind & HAS_Z != 0, kind & HAS_M != 0, kind & HAS_CURVES != 0),
        0 => return Err((IssueReason::NoGeometry, "geometry is null".into())),
        1 | 9 | 11 | 21 | 52 => {
            return Err((
                IssueReason::UnsupportedGeometry,
                "a point, not a polygon".into(),
            ))
        }
        8 | 18 | 20 | 28 | 53 => {
            return Err((
                IssueReason::UnsupportedGeometry,
                "a multipoint, not a polygon".into(),
            ))
        }
        t => return Err(malformed(format!("unknown geometry type {t}"))),
    };
    let multipatch = matches!(base, 31 | 32 | 54);
    // A polyline is read as a polygon is, its parts kept as lines.
    let line = matches!(base, 3 | 10 | 13 | 23 | 50);
    let faces_with_z = multipatch_layer && !multipatch && has_z && !curves;
    let short = || malformed("the geometry blob is cut short".into());
    let points = c.varuint().ok_or_else(short)?;
    if points == 0 {
        return Err((
            IssueReason::EmptyGeometry,
            format!("a {} without points", if line { "line" } else { "polygon" }),
        ));
    }
    if multipatch {
        // A MultiPatch has one more count here, which is not needed to read it.
        c.varuint().ok_or_else(short)?;
    }
    let parts = c.varuint().ok_or_else(short)?;
    let curve_count = if curves {
        c.varuint().ok_or_else(short)?
    } else {
        0
    };
    // Every point takes at least two bytes, every part count one: counts beyond the blob are a damaged row.
    let room = b.len() as u64;
    if points > room / 2 || parts == 0 || parts > points || curve_count > room {
        return Err(malformed(format!(
            "{points} points in {parts} parts do not fit a blob of {} bytes",
            b.len()
        )));
    }
    // The bounding box (x min, y min, then the spans), not needed.
    for _ in 0..4 {
        c.varuint().ok_or_else(short)?;
    }
    let mut sizes = Vec::with_capacity(parts as usize);
    let mut counted = 0u64;
    for _ in 1..parts {
        let n = c.varuint().ok_or_else(short)?;
        counted = counted.checked_add(n).ok_or_else(short)?;
        sizes.push(n);
    }
    if counted > points || (counted == points && !multipatch) {
        return Err(malformed(format!(
            "damaged geometry: its part sizes ({counted} points before the last part) exceed its {points} points"
        )));
    }
    sizes.push(points - counted);
    let part_types = if multipatch {
        let mut t = Vec::with_capacity(parts as usize);
        for _ in 0..parts {
            t.push(c.varuint().ok_or_else(short)?);
        }
        t
    } else {
        Vec::new()
    };
    let n = points as usize;
    let mut xy = Vec::with_capacity(n);
    let (mut dx, mut dy) = (0i64, 0i64);
    for _ in 0..n {
        dx = dx.wrapping_add(c.varint().ok_or_else(short)?);
        dy = dy.wrapping_add(c.varint().ok_or_else(short)?);
        xy.push([
            dx as f64 / g.xy_scale + g.x_origin,
            dy as f64 / g.xy_scale + g.y_origin,
        ]);
    }
    // Z (a footprint needs none, a MultiPatch does) and M come after every point's x and y; the curves after them.
    let mut z = Vec::new();
    if has_z && (multipatch || curves || faces_with_z) {
        let mut dz = 0i64;
        z.reserve(n);
        for _ in 0..n {
            dz = dz.wrapping_add(c.varint().ok_or_else(short)?);
            z.push(dz as f64 / g.z_scale + g.z_origin);
        }
    }
    if has_m && curves {
        // One byte 0x42 when no point has an M; else one varint a point.
        if c.peek() == Some(0x42) {
            c.take(1);
        } else {
            for _ in 0..n {
                c.varint().ok_or_else(short)?;
            }
        }
    }
    if xy.iter().flatten().chain(&z).any(|v| !v.is_finite()) {
        return Err((
            IssueReason::NonFiniteCoordinate,
            "a vertex that is not a finite number".into(),
        ));
    }
    if multipatch {
        if z.is_empty() {
            return Err(malformed("a MultiPatch without z".into()));
        }
        let mut start = 0usize;
        let parts: Vec<(i64, Vec<[f64; 3]>)> = sizes
            .iter()
            .zip(&part_types)
            .map(|(&size, &t)| {
                let p: Vec<[f64; 3]> = (start..start + size as usize)
                    .map(|i| [xy[i][0], xy[i][1], z[i]])
                    .collect();
                start += size as usize;
                ((t & 0xf) as i64, p)
            })
            .collect();
        return crate::shp::multipatch_faces(parts).map(Shape::Surfaces);
    }
    if faces_with_z {
        return polygon_faces(&sizes, &xy, &z).map(Shape::Surfaces);
    }
    let segments = if curves {
        curve_segments(&mut c, curve_count, n).map_err(malformed)?
    } else {
        Vec::new()
    };
    let mut rings = Vec::with_capacity(parts as usize);
    let mut repairs = Vec::new();
    let mut start = 0usize;
    let mut seg = segments.iter().peekable();
    let mut followed = 0usize;
    // Rings that are one full circle: a circle's points say nothing of its direction, so it is set by nesting below.
    let mut circles = Vec::new();
    for (k, &size) in sizes.iter().enumerate() {
        let end = start + size as usize;
        if (1..=2).contains(&size)
            && segments.iter().any(|s| s.0 == start)
            && xy[start] == xy[end - 1]
        {
            circles.push(k);
        }
        let mut r: Vec<[f64; 2]> = Vec::with_capacity(size as usize);
        for i in start..end {
            r.push(xy[i]);
            while let Some(s) = seg.next_if(|s| s.0 == i) {
                if i + 1 < end {
                    // A curve whose numbers give no finite points (a damaged row) is its straight segment.
                    let points = follow(&s.1, xy[i], xy[i + 1]);
                    if points.iter().flatten().all(|v| v.is_finite()) {
                        followed += points.len();
                        r.extend(points);
                    }
                }
            }
            if followed > MAX_CURVE_POINTS {
                return Err(malformed(format!(
                    "its curves would take more than {MAX_CURVE_POINTS} points to follow"
                )));
            }
        }
        // Segments starting at a ring's last point have no end in it.
        while seg.next_if(|s| s.0 < end).is_some() {}
        if !line {
            crate::shp::open_ring(&mut r, k, &mut repairs);
        }
        rings.push(r);
        start = end;
    }
    if line {
        return Ok(Shape::Lines(rings));
    }
    // A circle inside an even number of the row's other rings is an outer ring (clockwise, Esri's rule), inside an
    // odd number a hole.
    for &k in &circles {
        let Some(&p) = rings[k].first() else { continue };
        let depth = (0..rings.len())
            .filter(|&o| {
                o != k && rings[o].len() >= 3 && crate::shp::locate(p, &rings[o]) == Some(true)
            })
            .count();
        let clockwise = signed_area2(&rings[k]) < 0.0;
        if clockwise != depth.is_multiple_of(2) {
            rings[k].reverse();
        }
    }
    if !segments.is_empty() {
        repairs.push((
            IssueReason::CurvesApproximated,
            format!(
                "{} curve segment(s) (circular or elliptic arcs, Bézier curves) approximated by straight segments \
                 of at most {}° of arc (a Bézier curve: 16)",
                segments.len(),
                crate::gpkg::ARC_STEP_DEG
            ),
        ));
    }
    Ok(Shape::Footprint(crate::shp::organize(rings), repairs))
}

/// A polygon with z in a MultiPatch layer as a model's faces: each ring a face, but for a ring wound the other way
/// (counter-clockwise in plan, Esri's holes) that lies in the plan and height range of the face before it, which is
/// that face's hole. Walls (no area in plan) are faces of their own.
fn polygon_faces(sizes: &[u64], xy: &[[f64; 2]], z: &[f64]) -> Result<Vec<Face>, Skip> {
    let mut faces: Vec<Face> = Vec::new();
    // The plan box and height range of the last face's outer ring, when it is wound as an outer ring.
    let mut last: Option<([f64; 4], [f64; 2])> = None;
    let mut start = 0usize;
    for &size in sizes {
        let mut ring: Vec<[f64; 3]> = (start..start + size as usize)
            .map(|i| [xy[i][0], xy[i][1], z[i]])
            .collect();
        start += size as usize;
        if ring.len() > 1 && ring.first() == ring.last() {
            ring.pop();
        }
        if ring.len() < 3 {
            continue;
        }
        let plan: Vec<[f64; 2]> = ring.iter().map(|p| [p[0], p[1]]).collect();
        let area = signed_area2(&plan);
        let b = crate::feature::ring_box(&plan);
        let span = (b[2] - b[0]).hypot(b[3] - b[1]);
        let flat = area.abs() > 1e-9 * span * span;
        let heights = ring
            .iter()
            .fold([f64::INFINITY, f64::NEG_INFINITY], |h, p| {
                [h[0].min(p[2]), h[1].max(p[2])]
            });
        let hole_of_last = flat
            && area > 0.0
            && last.is_some_and(|(o, h)| {
                b[0] >= o[0]
                    && b[1] >= o[1]
                    && b[2] <= o[2]
                    && b[3] <= o[3]
                    && heights[0] >= h[0] - 1e-6
                    && heights[1] <= h[1] + 1e-6
            });
        match faces.last_mut() {
            Some(face) if hole_of_last => face.push(ring),
            _ => {
                last = (flat && area < 0.0).then_some((b, heights));
                faces.push(vec![ring]);
            }
        }
    }
    if faces.is_empty() {
        return Err((
            IssueReason::EmptyGeometry,
            "a model whose faces have no area".into(),
        ));
    }
    Ok(faces)
}

/// Most points a feature's curves are followed by: more is a damaged or hostile row, not a building.
const MAX_CURVE_POINTS: usize = 1_000_000;

/// A curve segment of a ring: from its start point to the next point of the ring.
#[derive(Debug, Clone)]
enum Curve {
    /// A circular arc through the point `p` on it, or about the centre `p` (`centre: true`, `ccw` saying which way).
    Arc {
        p: [f64; 2],
        centre: bool,
        ccw: bool,
    },
    /// A cubic Bézier curve with its two control points.
    Bezier([f64; 2], [f64; 2]),
    /// An elliptic arc: centre, rotation, semi-major axis, ratio of minor to major, and its direction.
    Ellipse {
        centre: [f64; 2],
        rotation: f64,
        semi_major: f64,
        ratio: f64,
        ccw: bool,
    },
}

/// The curve segments after a general polygon's coordinates, each with the index of its start point.
fn curve_segments(
    c: &mut Cursor,
    count: u64,
    points: usize,
) -> Result<Vec<(usize, Curve)>, String> {
    let short = || "its curve segments are cut short".to_string();
    let mut out = Vec::with_capacity(count.min(points as u64) as usize);
    for _ in 0..count {
        let start = c.varuint().ok_or_else(short)?;
        let kind = c.varuint().ok_or_else(short)?;
        if start as usize >= points {
            return Err(format!("a curve segment from point {start} of {points}"));
        }
        let curve = match kind {
            1 => {
                let p = [c.f64().ok_or_else(short)?, c.f64().ok_or_else(short)?];
                let bits = c.u32().ok_or_else(short)?;
                // Esri's arc flags: 0x1 empty, 0x8 counter-clockwise, 0x20 a line, 0x40 a point (angles stored),
                // 0x80 the two numbers are a point on the arc (else its centre).
                if bits & (0x1 | 0x20 | 0x40) != 0 {
                    continue;
                }
                Curve::Arc {
                    p,
                    centre: bits & 0x80 == 0,
                    ccw: bits & 0x8 != 0,
                }
            }
            4 => {
                let a = [c.f64().ok_or_else(short)?, c.f64().ok_or_else(short)?];
                let b = [c.f64().ok_or_else(short)?, c.f64().ok_or_else(short)?];
                Curve::Bezier(a, b)
            }
            5 => {
                let d: Vec<f64> = (0..5)
                    .map(|_| c.f64().ok_or_else(short))
                    .collect::<Result<_, _>>()?;
                let bits = c.u32().ok_or_else(short)?;
                // Esri's elliptic arc flags: 0x1 empty, 0x40 a line, 0x80 a point (other numbers stored then),
                // 0x800 counter-clockwise.
                if bits & (0x1 | 0x40 | 0x80) != 0 {
                    continue;
                }
                Curve::Ellipse {
                    centre: [d[0], d[1]],
                    rotation: d[2],
                    semi_major: d[3],
                    ratio: d[4],
                    ccw: bits & 0x800 != 0,
                }
            }
            t => {
                return Err(format!(
                    "a curve segment of type {t} (1, 4 and 5 are known)"
                ))
            }
        };
        out.push((start as usize, curve));
    }
    out.sort_by_key(|s| s.0);
    Ok(out)
}

/// The points a curve segment from `a` to `b` passes through after `a`, before `b`.
fn follow(curve: &Curve, a: [f64; 2], b: [f64; 2]) -> Vec<[f64; 2]> {
    let lift = |p: [f64; 2]| [p[0], p[1], 0.0];
    let flat = |v: Vec<[f64; 3]>| -> Vec<[f64; 2]> {
        let mut v: Vec<[f64; 2]> = v.into_iter().map(|p| [p[0], p[1]]).collect();
        v.pop();
        v
    };
    match *curve {
        Curve::Arc {
            p, centre: false, ..
        } => flat(crate::gpkg::arc_points(lift(a), lift(p), lift(b))),
        Curve::Arc {
            p: m,
            centre: true,
            ccw,
        } => {
            // About a centre: a point half-way round the chosen way is the arc's middle point.
            let r = ((a[0] - m[0]).hypot(a[1] - m[1]) + (b[0] - m[0]).hypot(b[1] - m[1])) / 2.0;
            let (ta, tb) = (
                (a[1] - m[1]).atan2(a[0] - m[0]),
                (b[1] - m[1]).atan2(b[0] - m[0]),
            );
            let sweep = if ccw {
                (tb - ta).rem_euclid(std::f64::consts::TAU)
            } else {
                -(ta - tb).rem_euclid(std::f64::consts::TAU)
            };
            let sweep = if sweep == 0.0 {
                std::f64::consts::TAU * if ccw { 1.0 } else { -1.0 }
            } else {
                sweep
            };
            let t = ta + sweep / 2.0;
            let mid = [m[0] + r * t.cos(), m[1] + r * t.sin(), 0.0];
            flat(crate::gpkg::arc_points(lift(a), mid, lift(b)))
        }
        Curve::Bezier(p1, p2) => {
            const STEPS: usize = 16;
            (1..STEPS)
                .map(|k| {
                    let t = k as f64 / STEPS as f64;
                    let u = 1.0 - t;
                    let w = [u * u * u, 3.0 * u * u * t, 3.0 * u * t * t, t * t * t];
                    [
                        w[0] * a[0] + w[1] * p1[0] + w[2] * p2[0] + w[3] * b[0],
                        w[0] * a[1] + w[1] * p1[1] + w[2] * p2[1] + w[3] * b[1],
                    ]
                })
                .collect()
        }
        Curve::Ellipse {
            centre,
            rotation,
            semi_major,
            ratio,
            ccw,
        } => {
            // The angles of a and b on the unrotated ellipse, then steps between them the chosen way round.
            let (cr, sr) = (rotation.cos(), rotation.sin());
            let minor = semi_major * ratio;
            if !(semi_major > 0.0 && minor > 0.0) {
                return Vec::new();
            }
            let param = |p: [f64; 2]| {
                let (dx, dy) = (p[0] - centre[0], p[1] - centre[1]);
                let (u, v) = (dx * cr + dy * sr, -dx * sr + dy * cr);
                (v / minor).atan2(u / semi_major)
            };
            let (ta, tb) = (param(a), param(b));
            let mut sweep = if ccw {
                (tb - ta).rem_euclid(std::f64::consts::TAU)
            } else {
                -(ta - tb).rem_euclid(std::f64::consts::TAU)
            };
            if sweep == 0.0 {
                sweep = std::f64::consts::TAU * if ccw { 1.0 } else { -1.0 };
            }
            let steps = ((sweep.abs() / crate::gpkg::ARC_STEP_DEG.to_radians()).ceil() as usize)
                .clamp(1, 100_000);
            (1..steps)
                .map(|k| {
                    let t = ta + sweep * k as f64 / steps as f64;
                    let (u, v) = (semi_major * t.cos(), minor * t.sin());
                    [centre[0] + u * cr - v * sr, centre[1] + u * sr + v * cr]
                })
                .collect()
        }
    }
}

// ---------------------------------------------------------------------------------------------------------------------
// Bytes

/// A position in a byte slice, reading little-endian numbers and the format's variable-length integers.
struct Cursor<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn at(b: &'a [u8], at: usize) -> Self {
        Cursor { b, at }
    }
    fn take(&mut self, n: u64) -> Option<&'a [u8]> {
        let end = self.at.checked_add(usize::try_from(n).ok()?)?;
        let s = self.b.get(self.at..end)?;
        self.at = end;
        Some(s)
    }
    fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        self.take(N as u64).map(|s| s.try_into().expect("N bytes"))
    }
    fn peek(&self) -> Option<u8> {
        self.b.get(self.at).copied()
    }
    fn u8(&mut self) -> Option<u8> {
        self.array::<1>().map(|a| a[0])
    }
    fn u16(&mut self) -> Option<u16> {
        self.array().map(u16::from_le_bytes)
    }
    fn i16(&mut self) -> Option<i16> {
        self.array().map(i16::from_le_bytes)
    }
    fn u32(&mut self) -> Option<u32> {
        self.array().map(u32::from_le_bytes)
    }
    fn i32(&mut self) -> Option<i32> {
        self.array().map(i32::from_le_bytes)
    }
    fn u64(&mut self) -> Option<u64> {
        self.array().map(u64::from_le_bytes)
    }
    fn i64(&mut self) -> Option<i64> {
        self.array().map(i64::from_le_bytes)
    }
    fn f32(&mut self) -> Option<f32> {
        self.array().map(f32::from_le_bytes)
    }
    fn f64(&mut self) -> Option<f64> {
        self.array().map(f64::from_le_bytes)
    }
    /// `n` UTF-16 code units, little-endian (unpaired surrogates replaced).
    fn utf16(&mut self, n: usize) -> Option<String> {
        let b = self.take(2 * n as u64)?;
        let units: Vec<u16> = b
            .chunks_exact(2)
            .map(|p| u16::from_le_bytes([p[0], p[1]]))
            .collect();
        Some(String::from_utf16_lossy(&units))
    }
    /// An unsigned integer in 7-bit groups, least significant first, the high bit of each byte saying more follow.
    fn varuint(&mut self) -> Option<u64> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let byte = self.u8()?;
            v |= u64::from(byte & 0x7f) << shift;
            if byte & 0x80 == 0 {
                return Some(v);
            }
        }
        None
    }
    /// A signed integer: the first byte holds the sign (0x40) and 6 bits, the rest 7 bits each.
    fn varint(&mut self) -> Option<i64> {
        let first = self.u8()?;
        let negative = first & 0x40 != 0;
        let mut v = u64::from(first & 0x3f);
        if first & 0x80 != 0 {
            let mut shift = 6;
            loop {
                let byte = self.u8()?;
                if shift >= 64 {
                    return None;
                }
                v |= u64::from(byte & 0x7f) << shift;
                shift += 7;
                if byte & 0x80 == 0 {
                    break;
                }
            }
        }
        let v = i64::try_from(v).ok()?;
        Some(if negative { -v } else { v })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fgdb")
            .join(name)
    }

    #[derive(serde::Deserialize)]
    struct Reference {
        objectid: i64,
        attributes: std::collections::BTreeMap<String, serde_json::Value>,
        polygons: Vec<Vec<Vec<[f64; 2]>>>,
    }

    #[test]
    fn varints_are_read_as_the_format_writes_them() {
        let read = |b: &[u8]| Cursor::at(b, 0).varint();
        assert_eq!(read(&[0x05]), Some(5));
        assert_eq!(read(&[0x45]), Some(-5));
        assert_eq!(read(&[0x80 | 0x3f, 0x01]), Some(0x3f | (1 << 6)));
        assert_eq!(read(&[0xc0 | 0x01, 0x02]), Some(-(1 | (2 << 6))));
        assert_eq!(read(&[0x80]), None, "cut short");
        assert_eq!(Cursor::at(&[0xbc, 0x06], 0).varuint(), Some(828));
        assert_eq!(Cursor::at(&[0xff; 11], 0).varuint(), None, "too long");
        assert_eq!(Cursor::at(&[0xff; 12], 0).varint(), None, "too long");
    }

    #[test]
    fn dates_are_days_since_the_end_of_1899() {
        assert_eq!(
            date_time(0.0, true, true),
            AttrValue::String("1899-12-30T00:00:00".into())
        );
        assert_eq!(
            date_time(41_634.524_259_259_3, true, true),
            AttrValue::String("2013-12-26T12:34:56".into())
        );
        assert_eq!(
            date_time(-1.5, true, true),
            AttrValue::String("1899-12-28T12:00:00".into())
        );
        assert_eq!(
            date_time(0.75, false, true),
            AttrValue::String("18:00:00".into())
        );
        assert!(matches!(date_time(f64::NAN, true, true), AttrValue::Float(x) if x.is_nan()));
    }

    /// Every polygon feature class ArcGIS wrote in GDAL's test geodatabase (2D, Z, M, ZM, multi-part, null and
    /// empty shapes; fields of every type, nulls among them), against GDAL's reading.
    #[test]
    fn arcgis_feature_classes_read_as_gdal_reads_them() {
        let dir = fixture("arcgis.gdb");
        for name in [
            "polygon",
            "multipolygon",
            "polygon25D",
            "multipolygon25D",
            "polygonm",
            "polygonzm",
            "multipolygonm",
            "multipolygonzm",
            "several_polygons",
            "null_polygon",
            "empty_polygon",
            "empty_polygonm",
            "hole",
            "testnotnullable",
        ] {
            let doc = read_class(&dir, Some(name), Want::Footprints, true)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let gdal: Vec<Reference> = serde_json::from_str(
                &std::fs::read_to_string(fixture(&format!("arcgis.{name}.reference.json")))
                    .unwrap(),
            )
            .unwrap();
            assert_eq!(doc.features.len(), gdal.len(), "{name}");
            for (f, g) in doc.features.iter().zip(&gdal) {
                let what = format!("{name} OBJECTID {}", g.objectid);
                assert_eq!(
                    f.attributes.get("OBJECTID"),
                    Some(&AttrValue::Int(g.objectid)),
                    "{what}"
                );
                for (k, v) in &g.attributes {
                    if k.starts_with("binary") {
                        assert!(f.attributes.get(k).is_none(), "{what}: {k} left out");
                        continue;
                    }
                    let ours = f.attributes.get(k).unwrap_or_else(|| panic!("{what}: {k}"));
                    let same = match (ours, v) {
                        (AttrValue::Null, serde_json::Value::Null) => true,
                        (AttrValue::Int(i), serde_json::Value::Number(n)) => {
                            n.as_f64() == Some(*i as f64)
                        }
                        (AttrValue::Float(x), serde_json::Value::Number(n)) => {
                            n.as_f64() == Some(*x)
                        }
                        (AttrValue::String(s), serde_json::Value::String(t)) => s == t,
                        _ => false,
                    };
                    assert!(same, "{what}: {k} {ours:?} against {v:?}");
                }
                if g.polygons.is_empty() {
                    assert!(f.skip.is_some(), "{what}");
                    continue;
                }
                assert!(f.skip.is_none(), "{what}: {:?}", f.skip);
                assert_eq!(f.polygons.len(), g.polygons.len(), "{what}");
                let flat = |p: &Vec<Vec<Vec<[f64; 2]>>>| {
                    let mut v: Vec<[f64; 2]> = p.iter().flatten().flatten().copied().collect();
                    v.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
                    v
                };
                let (a, b) = (flat(&f.polygons), flat(&g.polygons));
                assert_eq!(a.len(), b.len(), "{what}");
                for (p, q) in a.iter().zip(&b) {
                    assert!(
                        (p[0] - q[0]).abs() < 1e-9 && (p[1] - q[1]).abs() < 1e-9,
                        "{what}: {p:?} {q:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn null_and_empty_shapes_are_skipped_with_their_reason() {
        let dir = fixture("arcgis.gdb");
        let null = read(&dir, Some("null_polygon"), Want::Footprints).unwrap();
        assert!(null
            .features
            .iter()
            .all(|f| matches!(&f.skip, Some((IssueReason::NoGeometry, d)) if d.ends_with("geometry is null"))));
        let empty = read(&dir, Some("empty_polygonm"), Want::Footprints).unwrap();
        assert!(matches!(
            empty.features[0].skip,
            Some((IssueReason::EmptyGeometry | IssueReason::NoGeometry, _))
        ));
    }

    /// A damaged table (cut anywhere, bytes changed anywhere) gives an error or skipped rows, never a panic or a
    /// runaway allocation.
    #[test]
    fn damaged_tables_never_panic() {
        let dir = fixture("kinds.gdb");
        let catalog = std::fs::read(dir.join(CATALOG)).unwrap();
        let mut cases: Vec<(Vec<u8>, Vec<u8>)> = Vec::new();
        for oid in [3u64, 4, 5] {
            let t =
                std::fs::read(dir.join(format!("a{:08x}.gdbtable", oid + 6))).unwrap_or_default();
            let x =
                std::fs::read(dir.join(format!("a{:08x}.gdbtablx", oid + 6))).unwrap_or_default();
            if !t.is_empty() {
                cases.push((t, x));
            }
        }
        cases.push((
            catalog,
            std::fs::read(dir.join("a00000001.gdbtablx")).unwrap(),
        ));
        assert!(cases.len() >= 3);
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let exercise = |t: Vec<u8>, x: &[u8]| {
            if let Ok(table) = Table::parse(t, x) {
                let g = table.geometry().cloned();
                for (_, row) in table.rows() {
                    if let Ok(values) = row.and_then(|r| table.values(r)) {
                        for v in values {
                            if let (Cell::Bytes(b), Some(g)) = (v, &g) {
                                let _ = shape(b, g, table.layout.geometry_type == 9);
                            }
                        }
                    }
                }
            }
        };
        for (t, x) in &cases {
            for cut in (0..t.len()).step_by(t.len() / 200 + 1) {
                exercise(t[..cut].to_vec(), x);
            }
            for cut in (0..x.len()).step_by(x.len() / 50 + 1) {
                exercise(t.clone(), &x[..cut]);
            }
            for _ in 0..400 {
                let mut m = t.clone();
                for _ in 0..(next() % 4 + 1) {
                    let at = (next() % m.len() as u64) as usize;
                    m[at] = next() as u8;
                }
                exercise(m, x);
                let mut m = x.clone();
                let at = (next() % m.len() as u64) as usize;
                m[at] = next() as u8;
                exercise(t.clone(), &m);
            }
        }
    }
}
