//! "No panic on any input file" for the binary readers — File Geodatabase (folders and ZIP archives), GeoPackage,
//! Shapefile (polygons and MultiPatch), GeoParquet (WKB and GeoArrow) and OpenStreetMap PBF — with mutations that
//! know each format's structure and keep the file mostly well-formed, so that they reach the code behind the
//! container: a File Geodatabase table's field descriptions (types, widths, flags, counts), its row index, its rows'
//! null flags and the varints of their geometry blobs (part and point counts, deltas, curve descriptors), its
//! spatial reference text, the central directory of its ZIP; a GeoPackage's geometry header (flags, envelope,
//! srs_id), its WKB (type codes with Z / M / ZM, curves, nested collections, counts huge or zero, byte order) and its
//! `gpkg_*` tables (rows naming missing tables, columns or CRSs); a shapefile's header, record lengths, part arrays
//! and types, `.shx` offsets, `.dbf` header and field descriptors, code page and `.prj`; a GeoParquet file's `geo`
//! metadata (column, encoding, CRS, covering), its WKB and its GeoArrow nesting; a PBF's blob headers, string table,
//! dense-node deltas, way references and relation members, re-encoded as protobuf.
//!
//! Geometry is also changed while kept well-formed (a vertex moved onto another, a spike, a bow tie, a ring as its own
//! hole; a model's face dropped, turned over, lifted or flattened), for the repair and model code behind the readers.
//!
//! Each case is ingested with and without an LoD on a thread of its own, under `catch_unwind` and a time guard: it
//! must give an error naming its file, or buildings and skips whose counts add up (finite frame, positive heights,
//! valid footprints, valid models), never a panic or a hang; where the mutations only changed what rows hold, not
//! which rows there are, every row must be read (written or skipped with its reason): nothing lost silently. A failing
//! case names its reader, seed and mutations. Counts of the outcomes make sure the mutations reach the readers.
//!
//! Environment: `BINARY_MUTATIONS_CASES=<n>` cases per reader (a longer hunt, best in release), from seed
//! `BINARY_MUTATIONS_FIRST=<seed>` (0); `BINARY_MUTATIONS_ONLY=<reader>:<seed>` one case, printed with what it gave;
//! `BINARY_MUTATIONS_KEEP=<dir>` keeps the cases' files there; `BINARY_MUTATIONS_VERBOSE=1` prints every case's
//! outcome, `BINARY_MUTATIONS_TALLY=1` the errors and skip reasons reached. Readers: `fgdb`, `gpkg`, `shp`,
//! `parquet`, `pbf`. The tests after the campaigns' are what they found, each asserting the behaviour it should have.

mod harness;

use citylod_ingest::{ingest, IngestError, IngestOptions, LodChoice};
use citylod_testdata::fgdb::{varint as put_varint, varuint as put_varuint};
use citylod_testdata::guard::take_caught_panics;
use citylod_testdata::zip::{zip, Zip};
use citylod_testdata::{fnv1a as fnv, SplitMix64};
use harness::{check, guarded, Outcome};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

// =================================================================================================================
// The harness (shared with the other mutation tests in tests/harness)

/// A case not answered after this is a hang; one that took a quarter of it is a failure too (inputs are small).
const HANG: Duration = Duration::from_secs(60);

fn error_chain(e: &IngestError) -> String {
    let mut text = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        text.push_str(&format!(": {s}"));
        source = s.source();
    }
    text
}

fn outcome_line(got: &Outcome) -> String {
    match got {
        Outcome::Panicked(said) => format!("PANIC {said}"),
        Outcome::Failed(e) => format!("error: {}", error_chain(e)),
        Outcome::Read(out) => {
            let r = &out.report;
            let issues = |list: &[citylod_ingest::FeatureIssue]| {
                list.iter()
                    .take(6)
                    .map(|i| format!("{} {}: {}", i.feature_id, i.reason.as_str(), i.detail))
                    .collect::<Vec<_>>()
                    .join(" | ")
            };
            format!(
                "{} read, {} written, {} with a model; skipped ({}): [{}]; model issues: [{}]",
                r.features_read,
                r.buildings_written,
                r.buildings_with_mesh,
                r.skipped.len(),
                issues(&r.skipped),
                issues(&r.mesh_issues)
            )
        }
    }
}

/// An error must name the file (or the folder / archive given) or the option at fault.
fn bad_error(e: &IngestError, path: &Path) -> Option<String> {
    let text = error_chain(e);
    let name = path.file_name().unwrap().to_string_lossy().to_string();
    let names_the_file = text.contains(&name);
    let names_an_option = matches!(e, IngestError::InvalidOption { .. })
        || text.starts_with("--crs: ")
        || text.starts_with("--layer");
    if text.contains("panicked") {
        return Some(format!("an error telling of a panic: {text:?}"));
    }
    (!(names_the_file || names_an_option))
        .then(|| format!("an error naming no file nor option: {text:?}"))
}

/// One mutated input: the path to ingest, what was done, and options it needs (a CRS, a layer).
struct Case {
    path: PathBuf,
    done: Vec<String>,
    crs: Option<String>,
    layer: Option<String>,
    /// When the mutations only changed what rows hold (a geometry, a value), not which rows there are: the
    /// features the file holds, each of which must then be read (written or skipped with its reason), none lost.
    rows: Option<usize>,
}

#[derive(Default)]
struct Tally {
    cases: usize,
    ingests: usize,
    errors: usize,
    with_buildings: usize,
    with_skips: usize,
    with_models: usize,
    slowest: (Duration, String),
    failures: Vec<String>,
    /// First words of the errors, counted: what the mutations reach.
    error_kinds: std::collections::BTreeMap<String, usize>,
    skip_reasons: std::collections::BTreeMap<String, usize>,
}

const CRS_NAMES: &[&str] = &[
    "EPSG:4326",
    "EPSG:2263",
    "EPSG:32618",
    "EPSG:28992",
    "EPSG:3857",
    "EPSG:99999",
    "CRS84",
    "",
    "+proj=tmerc +k=0",
    "+proj=utm +zone=61",
    "+proj=longlat +a=0",
    "+proj=nonsense",
];

fn options(case: &Case, rng: &mut SplitMix64) -> Vec<(String, IngestOptions)> {
    let lod = *rng.pick(&["2.2", "1.2", "2", "highest", "1", "3"]);
    let crs = if rng.chance(0.04) {
        Some(rng.pick(CRS_NAMES).to_string())
    } else {
        case.crs.clone()
    };
    let plain = IngestOptions {
        crs: crs.clone(),
        layer: case.layer.clone(),
        ..Default::default()
    };
    let mut with_lod = IngestOptions {
        crs,
        layer: case.layer.clone(),
        lod: Some(lod.parse::<LodChoice>().unwrap()),
        ..Default::default()
    };
    if rng.chance(0.1) {
        with_lod.height_attr = Some(rng.pick(&["height", "HEIGHT", "h", "name"]).to_string());
        with_lod.height_unit_m = Some(0.3048);
    }
    vec![("no lod".into(), plain), (format!("lod {lod}"), with_lod)]
}

fn env_cases(default: u64) -> u64 {
    std::env::var("BINARY_MUTATIONS_CASES")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(default)
}

/// Runs `cases` cases of `reader` (or the one `BINARY_MUTATIONS_ONLY=<reader>:<seed>` names), each made by `make`
/// in a folder of its own, and asserts none failed and that each outcome was reached.
fn run(reader: &str, cases: u64, make: fn(&Path, u64, &mut SplitMix64) -> Case) {
    let started = Instant::now();
    let only: Option<Option<u64>> = std::env::var("BINARY_MUTATIONS_ONLY").ok().map(|v| {
        let (name, seed) = v.split_once(':').unwrap_or((&v, ""));
        (name == reader).then(|| seed.parse().expect("BINARY_MUTATIONS_ONLY=<reader>:<seed>"))
    });
    let seeds: Vec<u64> = match only {
        Some(Some(s)) => vec![s],
        Some(None) => return,
        None => {
            // Another stretch of seeds for a further hunt: BINARY_MUTATIONS_FIRST=<seed>.
            let first: u64 = std::env::var("BINARY_MUTATIONS_FIRST")
                .ok()
                .and_then(|n| n.parse().ok())
                .unwrap_or(0);
            (first..first + env_cases(cases)).collect()
        }
    };
    let verbose = std::env::var("BINARY_MUTATIONS_VERBOSE").is_ok() || only.is_some();
    let keep = std::env::var("BINARY_MUTATIONS_KEEP")
        .ok()
        .map(PathBuf::from);
    // In memory where there is a tmpfs (SQLite's syncs and thousands of small files cost little there).
    let tmp = tempfile::tempdir_in("/dev/shm")
        .or_else(|_| tempfile::tempdir())
        .unwrap();
    let base = keep.clone().unwrap_or_else(|| tmp.path().to_path_buf());
    let mut t = Tally::default();
    for seed in seeds {
        let dir = base.join(format!("{reader}-{seed}"));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let mut rng = SplitMix64(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ fnv(reader));
        // A bug of this test's generators is said as one, and the campaign goes on.
        let Ok(case) =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| make(&dir, seed, &mut rng)))
        else {
            t.failures.push(format!(
                "{reader}:{seed}: the test's own generator panicked (a bug of this test)"
            ));
            continue;
        };
        t.cases += 1;
        let mut orng = SplitMix64(seed ^ 0x5eed);
        for (label, opts) in options(&case, &mut orng) {
            let name = format!("{reader}:{seed} ({label}): {}", case.done.join("; "));
            t.ingests += 1;
            let at = Instant::now();
            let path = case.path.clone();
            let got = guarded(HANG, only.is_none(), move || ingest(&[path], &opts))
                .unwrap_or_else(|waited| panic!("{name}: no answer after {waited:?} (a hang?)"));
            let took = at.elapsed();
            // A panic inside the reader that it caught itself (the GeoParquet reader guards the parquet crate so)
            // still prints to the console: said for every reader but GeoParquet's, whose guard is by design.
            if !matches!(got, Outcome::Panicked(_)) {
                let caught = take_caught_panics();
                if !caught.is_empty() && reader != "parquet" {
                    t.failures.push(format!(
                        "{name}: a panic caught inside the reader: {}",
                        caught.join(" | ")
                    ));
                }
            }
            if took > t.slowest.0 {
                t.slowest = (took, name.clone());
            }
            if took > HANG / 4 {
                t.failures.push(format!("{name}: took {took:?}"));
            }
            if verbose {
                eprintln!("{name}\n    -> {}", outcome_line(&got));
            }
            match got {
                Outcome::Panicked(said) => t.failures.push(format!("{name}: PANIC: {said}")),
                Outcome::Failed(e) => {
                    t.errors += 1;
                    let text = error_chain(&e);
                    // What went wrong, without the path and the format's name.
                    let key: String = text
                        .split(": ")
                        .filter(|s| {
                            !s.contains('/')
                                && !s.starts_with("File Geodatabase")
                                && !s.starts_with("feature class")
                        })
                        .collect::<Vec<_>>()
                        .join(": ")
                        .split_whitespace()
                        .take(6)
                        .collect::<Vec<_>>()
                        .join(" ");
                    *t.error_kinds.entry(key).or_default() += 1;
                    if let Some(f) = bad_error(&e, &case.path) {
                        t.failures.push(format!("{name}: {f}"));
                    }
                }
                Outcome::Read(out) => {
                    if let Err(e) = check(&out) {
                        t.failures.push(format!("{name}: {e}"));
                    }
                    if let Some(n) = case.rows {
                        if out.report.features_read != n {
                            t.failures.push(format!(
                                "{name}: {} features read of the {n} rows the file holds (lost silently?); {}",
                                out.report.features_read,
                                outcome_line(&Outcome::Read(out.clone()))
                            ));
                        }
                    }
                    let r = &out.report;
                    t.with_buildings += usize::from(r.buildings_written > 0);
                    t.with_skips += usize::from(!r.skipped.is_empty());
                    t.with_models += usize::from(r.buildings_with_mesh > 0);
                    for s in &r.skipped {
                        *t.skip_reasons
                            .entry(s.reason.as_str().to_string())
                            .or_default() += 1;
                    }
                }
            }
        }
        if keep.is_none() {
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
    let counts = format!(
        "{reader}: {} cases, {} ingests in {:?}: {} errors, {} with buildings, {} with skips, {} with models; \
         slowest {:?}: {}",
        t.cases,
        t.ingests,
        started.elapsed(),
        t.errors,
        t.with_buildings,
        t.with_skips,
        t.with_models,
        t.slowest.0,
        t.slowest.1.chars().take(300).collect::<String>()
    );
    eprintln!("{counts}");
    if verbose || std::env::var("BINARY_MUTATIONS_TALLY").is_ok() {
        eprintln!("{reader} errors: {:#?}", t.error_kinds);
        eprintln!("{reader} skip reasons: {:?}", t.skip_reasons);
    }
    if only.is_none() {
        assert!(
            t.with_buildings > 0 && t.errors > 0 && t.with_skips > 0,
            "{counts}"
        );
    }
    assert!(
        t.failures.is_empty(),
        "{} of {} ingests failed:\n{}",
        t.failures.len(),
        t.ingests,
        t.failures
            .iter()
            .take(40)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

// =================================================================================================================
// Shared inputs: building outlines in lon/lat

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

/// A building: its id, its polygons (closed rings of lon/lat), its height and roof shape.
#[derive(Clone)]
struct House {
    id: String,
    polygons: Vec<Vec<Vec<[f64; 2]>>>,
    height: Option<f64>,
    levels: Option<i64>,
    roof: Option<String>,
}

/// The nine houses of `examples/roofs` and the first 15 buildings of the Lower East Side extract.
fn houses() -> &'static [House] {
    static HOUSES: std::sync::OnceLock<Vec<House>> = std::sync::OnceLock::new();
    HOUSES.get_or_init(|| {
        let mut out = Vec::new();
        let roofs = read_json(&repo_root().join("examples/roofs/roofs.geojson"));
        let les = read_json(&repo_root().join("examples/nyc-les/les_buildings.geojson"));
        let les_features: Vec<Value> = les["features"]
            .as_array()
            .unwrap()
            .iter()
            .take(15)
            .cloned()
            .collect();
        for (k, f) in roofs["features"]
            .as_array()
            .unwrap()
            .iter()
            .chain(&les_features)
            .enumerate()
        {
            let g = &f["geometry"];
            let ring = |r: &Value| -> Vec<[f64; 2]> {
                r.as_array()
                    .unwrap()
                    .iter()
                    .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
                    .collect()
            };
            // The made-up houses (near 4° E, 52° N) moved beside the Lower East Side, so that all lie in one city.
            let (dx, dy) = if k < 9 { (-77.985, -11.29) } else { (0.0, 0.0) };
            let ring = |r: &Value| -> Vec<[f64; 2]> {
                ring(r).iter().map(|p| [p[0] + dx, p[1] + dy]).collect()
            };
            let poly = |p: &Value| -> Vec<Vec<[f64; 2]>> {
                p.as_array().unwrap().iter().map(ring).collect()
            };
            let polygons = match g["type"].as_str() {
                Some("Polygon") => vec![poly(&g["coordinates"])],
                Some("MultiPolygon") => g["coordinates"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(poly)
                    .collect(),
                _ => continue,
            };
            let p = &f["properties"];
            let num = |v: &Value| {
                v.as_f64()
                    .or_else(|| v.as_str().and_then(|s| s.parse().ok()))
            };
            out.push(House {
                id: p["name"].as_str().map_or(format!("h{k}"), str::to_string),
                polygons,
                height: num(&p["height"]),
                levels: num(&p["building:levels"]).map(|v| v as i64),
                roof: p["roof:shape"].as_str().map(str::to_string),
            });
        }
        out
    })
}

/// A box in metres (UTM 18N near Manhattan): its ring (clockwise from above, closed) and height.
fn utm_boxes() -> Vec<(Vec<[f64; 3]>, f64)> {
    (0..6)
        .map(|k| {
            let (x, y) = (583_000.0 + 30.0 * k as f64, 4_507_000.0 + 7.0 * k as f64);
            let (w, d) = (10.0 + k as f64, 8.0);
            let ring = vec![
                [x, y, 0.0],
                [x, y + d, 0.0],
                [x + w, y + d, 0.0],
                [x + w, y, 0.0],
                [x, y, 0.0],
            ];
            (ring, 6.0 + 3.0 * k as f64)
        })
        .collect()
}

/// The faces of a box standing on `ring` (closed, clockwise from above): bottom, top, walls, each a closed ring.
fn box_faces(ring: &[[f64; 3]], h: f64) -> Vec<Vec<[f64; 3]>> {
    let n = ring.len() - 1;
    let mut faces = vec![ring.to_vec()];
    let mut top: Vec<[f64; 3]> = ring.iter().rev().map(|p| [p[0], p[1], p[2] + h]).collect();
    top.dedup();
    faces.push(top);
    for i in 0..n {
        let (a, b) = (ring[i], ring[i + 1]);
        faces.push(vec![
            a,
            [a[0], a[1], a[2] + h],
            [b[0], b[1], b[2] + h],
            b,
            a,
        ]);
    }
    faces
}

const PRJ_WGS84: &str = "GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]]";
const PRJ_UTM18: &str = "PROJCS[\"WGS_1984_UTM_Zone_18N\",GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]],PROJECTION[\"Transverse_Mercator\"],PARAMETER[\"False_Easting\",500000.0],PARAMETER[\"False_Northing\",0.0],PARAMETER[\"Central_Meridian\",-75.0],PARAMETER[\"Scale_Factor\",0.9996],PARAMETER[\"Latitude_Of_Origin\",0.0],UNIT[\"Meter\",1.0]]";

/// Spatial reference texts a file may carry (`.prj`, a geodatabase's geometry field, a GeoPackage's srs row).
const WKTS: &[&str] = &[
    "",
    "garbage",
    "GEOGCS[",
    "PROJCS[\"x\",GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",0.0,0.0]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0]],PROJECTION[\"Transverse_Mercator\"],PARAMETER[\"Scale_Factor\",0.0],UNIT[\"Meter\",0.0]]",
    "PROJCS[\"NAD_1983_StatePlane_New_York_Long_Island_FIPS_3104_Feet\",GEOGCS[\"GCS_North_American_1983\",DATUM[\"D_North_American_1983\",SPHEROID[\"GRS_1980\",6378137.0,298.257222101]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]],PROJECTION[\"Lambert_Conformal_Conic\"],PARAMETER[\"False_Easting\",984250.0],PARAMETER[\"False_Northing\",0.0],PARAMETER[\"Central_Meridian\",-74.0],PARAMETER[\"Standard_Parallel_1\",40.66666666666666],PARAMETER[\"Standard_Parallel_2\",41.03333333333333],PARAMETER[\"Latitude_Of_Origin\",40.16666666666666],UNIT[\"Foot_US\",0.3048006096012192]]",
    PRJ_WGS84,
    PRJ_UTM18,
    "PROJCS[\"huge\",GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",1e308,1e308]],PRIMEM[\"Greenwich\",1e308],UNIT[\"Degree\",1e308]],PROJECTION[\"Mercator\"],PARAMETER[\"Standard_Parallel_1\",90.0],UNIT[\"Meter\",1e-308]]",
    "LOCAL_CS[\"local\",UNIT[\"Meter\",1.0]]",
    "GEOGCS[\"x\",DATUM[\"y\",SPHEROID[\"z\",6378137,298.257223563]],PRIMEM[\"Greenwich\",0],UNIT[\"degree\",NaN]]",
    "PROJCS[\"RD_New\",GEOGCS[\"GCS_Amersfoort\",DATUM[\"D_Amersfoort\",SPHEROID[\"Bessel_1841\",6377397.155,299.1528128]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]],PROJECTION[\"Double_Stereographic\"],PARAMETER[\"False_Easting\",155000.0],PARAMETER[\"False_Northing\",463000.0],PARAMETER[\"Central_Meridian\",5.38763888888889],PARAMETER[\"Scale_Factor\",0.9999079],PARAMETER[\"Latitude_Of_Origin\",52.1561605555556],UNIT[\"Meter\",1.0]]",
    "GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]],AUTHORITY[\"EPSG\",\"99999\"]",
    "PROJCS[\"WGS 84 / UTM zone 18N\",GEOGCS[\"WGS 84\",DATUM[\"WGS_1984\",SPHEROID[\"WGS 84\",6378137,298.257223563]],PRIMEM[\"Greenwich\",0],UNIT[\"degree\",0.0174532925199433]],PROJECTION[\"Transverse_Mercator\"],PARAMETER[\"central_meridian\",-75],PARAMETER[\"scale_factor\",0.9996],PARAMETER[\"false_easting\",500000],UNIT[\"metre\",1],AUTHORITY[\"EPSG\",\"32618\"]]",
    "\u{0}\u{feff}PROJCS[]]]]",
    // Vertical systems whose unit scales a model's heights out of reach, or to nothing.
    "PROJCS[\"WGS_1984_UTM_Zone_18N\",GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]],PROJECTION[\"Transverse_Mercator\"],PARAMETER[\"False_Easting\",500000.0],PARAMETER[\"False_Northing\",0.0],PARAMETER[\"Central_Meridian\",-75.0],PARAMETER[\"Scale_Factor\",0.9996],PARAMETER[\"Latitude_Of_Origin\",0.0],UNIT[\"Meter\",1.0]],VERTCS[\"v\",VDATUM[\"d\"],PARAMETER[\"Vertical_Shift\",0.0],PARAMETER[\"Direction\",1.0],UNIT[\"Huge\",1e308]]",
    "PROJCS[\"WGS_1984_UTM_Zone_18N\",GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]],PROJECTION[\"Transverse_Mercator\"],PARAMETER[\"False_Easting\",500000.0],PARAMETER[\"False_Northing\",0.0],PARAMETER[\"Central_Meridian\",-75.0],PARAMETER[\"Scale_Factor\",0.9996],PARAMETER[\"Latitude_Of_Origin\",0.0],UNIT[\"Meter\",1.0]],VERTCS[\"v\",VDATUM[\"d\"],PARAMETER[\"Vertical_Shift\",0.0],PARAMETER[\"Direction\",1.0],UNIT[\"Tiny\",1e-300]]",
    "PROJCS[\"WGS_1984_UTM_Zone_18N\",GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]],PROJECTION[\"Transverse_Mercator\"],PARAMETER[\"False_Easting\",500000.0],PARAMETER[\"False_Northing\",0.0],PARAMETER[\"Central_Meridian\",-75.0],PARAMETER[\"Scale_Factor\",0.9996],PARAMETER[\"Latitude_Of_Origin\",0.0],UNIT[\"Meter\",1.0]],VERTCS[\"v\",VDATUM[\"d\"],PARAMETER[\"Vertical_Shift\",0.0],PARAMETER[\"Direction\",1.0],UNIT[\"Far\",1e7]]",
];

// =================================================================================================================
// WKB (GeoPackage and GeoParquet), written with the places a mutation may change

#[derive(Clone, Copy, PartialEq, Debug)]
enum Site {
    Order,
    Type,
    Count,
    Coord,
}

#[derive(Clone, Copy)]
struct Dims {
    z: bool,
    m: bool,
}

struct WkbOut {
    b: Vec<u8>,
    sites: Vec<(usize, Site)>,
    /// EWKB's way of marking Z / M (flags in the type's high bits) rather than ISO's (+1000, +2000, +3000).
    ewkb: bool,
}

impl WkbOut {
    fn u32(&mut self, le: bool, v: u32, site: Site) {
        self.sites.push((self.b.len(), site));
        self.b
            .extend(if le { v.to_le_bytes() } else { v.to_be_bytes() });
    }
    fn f64(&mut self, le: bool, v: f64) {
        self.sites.push((self.b.len(), Site::Coord));
        self.b
            .extend(if le { v.to_le_bytes() } else { v.to_be_bytes() });
    }
    fn header(&mut self, le: bool, kind: u32, d: Dims) {
        self.sites.push((self.b.len(), Site::Order));
        self.b.push(u8::from(le));
        let code = if self.ewkb {
            kind | if d.z { 0x8000_0000 } else { 0 } | if d.m { 0x4000_0000 } else { 0 }
        } else {
            kind + if d.z { 1000 } else { 0 } + if d.m { 2000 } else { 0 }
        };
        self.u32(le, code, Site::Type);
    }
    fn points(&mut self, le: bool, pts: &[[f64; 3]], d: Dims) {
        self.u32(le, pts.len() as u32, Site::Count);
        for p in pts {
            self.f64(le, p[0]);
            self.f64(le, p[1]);
            if d.z {
                self.f64(le, p[2]);
            }
            if d.m {
                self.f64(le, 7.0);
            }
        }
    }
    fn polygon(&mut self, le: bool, rings: &[Vec<[f64; 3]>], d: Dims) {
        self.header(le, 3, d);
        self.u32(le, rings.len() as u32, Site::Count);
        for r in rings {
            self.points(le, r, d);
        }
    }
    fn curve(&mut self, le: bool, kind: u32, pts: &[[f64; 3]], d: Dims) {
        self.header(le, kind, d);
        self.points(le, pts, d);
    }
}

fn lift(r: &[[f64; 2]], z: f64) -> Vec<[f64; 3]> {
    r.iter().map(|p| [p[0], p[1], z]).collect()
}

/// A geometric change of a footprint (closed rings of lon/lat), keeping it well-formed: a vertex moved onto another
/// or a hair past it, a spike, a bow tie, the ring again as its own hole or shrunk inside it, a ring collapsed onto
/// one point or into a sliver, a polygon repeated.
fn mutate_rings(polygons: &mut Vec<Vec<Vec<[f64; 2]>>>, rng: &mut SplitMix64) -> String {
    let p = (rng.next_u64() % polygons.len() as u64) as usize;
    let r = (rng.next_u64() % polygons[p].len() as u64) as usize;
    let ring = polygons[p][r].clone();
    let n = ring.len();
    if n < 4 {
        return "ring too short to change".into();
    }
    let i = (rng.next_u64() % (n as u64 - 1)) as usize;
    let j = (rng.next_u64() % (n as u64 - 1)) as usize;
    let close = |mut v: Vec<[f64; 2]>| {
        let f = v[0];
        *v.last_mut().unwrap() = f;
        v
    };
    let first = ring[0];
    let about = |f: f64| -> Vec<[f64; 2]> {
        ring.iter()
            .map(|q| {
                [
                    first[0] + (q[0] - first[0]) * f,
                    first[1] + (q[1] - first[1]) * f,
                ]
            })
            .collect()
    };
    let what = match rng.next_u64() % 9 {
        0 => {
            let t = *rng.pick(&[1.0, 0.5, 1.0 + 1e-9, 1e-9, -1.0, 2.0]);
            let mut v = ring.clone();
            v[i] = [
                ring[i][0] + (ring[j][0] - ring[i][0]) * t,
                ring[i][1] + (ring[j][1] - ring[i][1]) * t,
            ];
            polygons[p][r] = close(v);
            format!("vertex {i} moved to {t} of the way to vertex {j}")
        }
        1 => {
            let mut v = ring.clone();
            let far = [
                ring[i][0] + (ring[i][0] - first[0]) * 5.0 + 1e-4,
                ring[i][1] + (ring[i][1] - first[1]) * 5.0,
            ];
            v.insert(i + 1, far);
            polygons[p][r] = v;
            format!("a spike after vertex {i}")
        }
        2 => {
            let mut v = ring.clone();
            v.swap(1 + i % (n - 2), 1 + j % (n - 2));
            polygons[p][r] = close(v);
            format!(
                "vertices {} and {} swapped (a bow tie)",
                1 + i % (n - 2),
                1 + j % (n - 2)
            )
        }
        3 => {
            let f = *rng.pick(&[1.0, 0.5, 2.0, -1.0, 1e-7]);
            polygons[p].push(about(f));
            format!("ring {r} again as a hole, scaled {f}")
        }
        4 => {
            polygons[p][r] = vec![first; n];
            format!("ring {r} all one point")
        }
        5 => {
            // A sliver: every vertex onto the line from the first to the middle one.
            let m = ring[n / 2];
            polygons[p][r] = ring
                .iter()
                .enumerate()
                .map(|(k, _)| {
                    let t = k as f64 / n as f64;
                    [
                        first[0] + (m[0] - first[0]) * t,
                        first[1] + (m[1] - first[1]) * t + if k % 2 == 0 { 1e-12 } else { 0.0 },
                    ]
                })
                .collect();
            let v = polygons[p][r].clone();
            polygons[p][r] = close(v);
            format!("ring {r} made a sliver")
        }
        6 => {
            let q = polygons[p].clone();
            polygons.push(q);
            format!("polygon {p} repeated")
        }
        7 => {
            let mut v = ring.clone();
            v.reverse();
            polygons[p][r] = v;
            format!("ring {r} reversed")
        }
        _ => {
            let mut v = ring.clone();
            let k = 1 + i % (n - 1);
            let x = v[k];
            for _ in 0..*rng.pick(&[1usize, 3, 1000]) {
                v.insert(k, x);
            }
            polygons[p][r] = v;
            format!("vertex {k} repeated")
        }
    };
    format!("polygon {p} ring {r}: {what}")
}

/// A geometric change of a model's faces (closed rings of x, y, z): a face dropped, repeated or turned over, a vertex
/// moved onto another face's, a face lifted far or flattened, a vertex raised 10,000 km, a face made a point or a
/// line, every face turned over.
fn mutate_faces(faces: &mut Vec<Vec<[f64; 3]>>, rng: &mut SplitMix64) -> String {
    let f = (rng.next_u64() % faces.len() as u64) as usize;
    let g = (rng.next_u64() % faces.len() as u64) as usize;
    let n = faces[f].len();
    let i = (rng.next_u64() % n as u64) as usize;
    match rng.next_u64() % 10 {
        0 => {
            faces.remove(f);
            format!("face {f} dropped")
        }
        1 => {
            let x = faces[f].clone();
            faces.push(x);
            format!("face {f} repeated")
        }
        2 => {
            faces[f].reverse();
            format!("face {f} turned over")
        }
        3 => {
            let m = faces[g].len();
            let q = faces[g][(rng.next_u64() % m as u64) as usize];
            faces[f][i] = q;
            format!("face {f} vertex {i} moved onto a vertex of face {g}")
        }
        4 => {
            let dz = *rng.pick(&[1000.0, -50.0, 1e-9]);
            faces[f].iter_mut().for_each(|p| p[2] += dz);
            format!("face {f} lifted {dz}")
        }
        5 => {
            faces.iter_mut().flatten().for_each(|p| p[2] = 0.0);
            "every face flattened onto z 0".into()
        }
        6 => {
            let z = *rng.pick(&[1e7, -1e7, 1e15]);
            faces[f][i][2] = z;
            format!("face {f} vertex {i} z := {z}")
        }
        7 => {
            let p = faces[f][0];
            faces[f].iter_mut().for_each(|q| *q = p);
            format!("face {f} all one point")
        }
        8 => {
            let (a, b) = (faces[f][0], faces[f][1 % n]);
            let m = faces[f].len();
            for (k, q) in faces[f].iter_mut().enumerate() {
                let t = k as f64 / m as f64;
                *q = [
                    a[0] + (b[0] - a[0]) * t,
                    a[1] + (b[1] - a[1]) * t,
                    a[2] + (b[2] - a[2]) * t,
                ];
            }
            format!("face {f} made a line")
        }
        _ => {
            faces.iter_mut().for_each(|x| x.reverse());
            "every face turned over (inside out)".into()
        }
    }
}

/// A geometry of `house` (or of a box in `boxes` metres, for 3D kinds) as WKB of a randomly chosen kind: Polygon,
/// MultiPolygon, CurvePolygon of circular, compound and straight rings, MultiSurface, a GeometryCollection nested
/// some levels, a PolyhedralSurface or TIN of a box, a Triangle, or a point or line — with Z, M or both, either
/// byte order, ISO's or EWKB's dimension flags.
fn random_wkb(
    rng: &mut SplitMix64,
    polygons: &[Vec<Vec<[f64; 2]>>],
    solid: Option<&(Vec<[f64; 3]>, f64)>,
    shape: Option<&mut Vec<String>>,
) -> (WkbOut, String) {
    // The shape itself changed first, when asked (`shape` takes what was done).
    let mut polygons = polygons.to_vec();
    let mut face_change = None;
    if let Some(said) = shape {
        if solid.is_some() {
            face_change = Some(said);
        } else if rng.chance(0.5) {
            said.push(mutate_rings(&mut polygons, rng));
        }
    }
    let polygons = &polygons[..];
    let le = !rng.chance(0.15);
    let d = match rng.next_u64() % 6 {
        0 => Dims { z: true, m: false },
        1 => Dims { z: false, m: true },
        2 => Dims { z: true, m: true },
        _ => Dims { z: false, m: false },
    };
    let mut o = WkbOut {
        b: Vec::new(),
        sites: Vec::new(),
        ewkb: rng.chance(0.2),
    };
    let rings3 =
        |p: &Vec<Vec<[f64; 2]>>| -> Vec<Vec<[f64; 3]>> { p.iter().map(|r| lift(r, 0.0)).collect() };
    let what;
    let choice = if solid.is_some() {
        20 + rng.next_u64() % 4
    } else {
        rng.next_u64() % 12
    };
    match choice {
        0..=3 => {
            o.polygon(le, &rings3(&polygons[0]), d);
            what = "Polygon";
        }
        4 | 5 => {
            o.header(le, 6, d);
            o.u32(le, polygons.len() as u32, Site::Count);
            for p in polygons {
                let le2 = if rng.chance(0.1) { !le } else { le };
                o.polygon(le2, &rings3(p), d);
            }
            what = "MultiPolygon";
        }
        6 | 7 => {
            // A CurvePolygon: its exterior as a CircularString (an odd number of points), a CompoundCurve of two
            // straight halves, or a LineString; its holes as LineStrings.
            let p = rings3(&polygons[0]);
            o.header(le, 10, d);
            o.u32(le, p.len() as u32, Site::Count);
            let ext = &p[0];
            match rng.next_u64() % 3 {
                0 => {
                    let mut e = ext.clone();
                    if e.len() % 2 == 0 {
                        e.insert(
                            1,
                            [(e[0][0] + e[1][0]) / 2.0, (e[0][1] + e[1][1]) / 2.0, 0.0],
                        );
                    }
                    o.curve(le, 8, &e, d);
                }
                1 => {
                    let mid = ext.len() / 2;
                    o.header(le, 9, d);
                    o.u32(le, 2, Site::Count);
                    o.curve(le, 2, &ext[..=mid], d);
                    o.curve(le, 2, &ext[mid..], d);
                }
                _ => o.curve(le, 2, ext, d),
            }
            for h in &p[1..] {
                o.curve(le, 2, h, d);
            }
            what = "CurvePolygon";
        }
        8 => {
            o.header(le, 12, d);
            o.u32(le, polygons.len() as u32, Site::Count);
            for p in polygons {
                o.polygon(le, &rings3(p), d);
            }
            what = "MultiSurface";
        }
        9 => {
            let depth = *rng.pick(&[1usize, 2, 5, 15, 16, 17, 40]);
            for _ in 0..depth {
                o.header(le, 7, d);
                o.u32(le, 1, Site::Count);
            }
            o.polygon(le, &rings3(&polygons[0]), d);
            what = "GeometryCollection";
        }
        10 => {
            let p = rings3(&polygons[0]);
            o.header(le, 1, d);
            o.f64(le, p[0][0][0]);
            o.f64(le, p[0][0][1]);
            if d.z {
                o.f64(le, 0.0);
            }
            if d.m {
                o.f64(le, 0.0);
            }
            what = "Point";
        }
        11 => {
            o.curve(le, 2, &rings3(&polygons[0])[0], d);
            what = "LineString";
        }
        _ => {
            let (ring, h) = solid.unwrap();
            let mut faces = box_faces(ring, *h);
            if let Some(said) = face_change {
                if rng.chance(0.6) {
                    said.push(mutate_faces(&mut faces, rng));
                }
            }
            let d = Dims {
                z: true,
                m: rng.chance(0.1),
            };
            match choice {
                20 | 21 => {
                    o.header(le, 15, d);
                    o.u32(le, faces.len() as u32, Site::Count);
                    for f in &faces {
                        o.polygon(le, std::slice::from_ref(f), d);
                    }
                    what = "PolyhedralSurface";
                }
                22 => {
                    // A TIN of the faces fanned into triangles.
                    let tris: Vec<[[f64; 3]; 3]> = faces
                        .iter()
                        .flat_map(|f| (1..f.len() - 2).map(move |i| [f[0], f[i], f[i + 1]]))
                        .collect();
                    o.header(le, 16, d);
                    o.u32(le, tris.len() as u32, Site::Count);
                    for t in &tris {
                        o.header(le, 17, d);
                        o.u32(le, 1, Site::Count);
                        o.points(le, &[t[0], t[1], t[2], t[0]], d);
                    }
                    what = "TIN";
                }
                _ => {
                    // A MultiPolygon Z of the faces (a model too, where the layer says so).
                    o.header(le, 6, d);
                    o.u32(le, faces.len() as u32, Site::Count);
                    for f in &faces {
                        o.polygon(le, std::slice::from_ref(f), d);
                    }
                    what = "MultiPolygon Z faces";
                }
            }
        }
    }
    let desc = format!(
        "{what}{}{}{}{}",
        if d.z { " Z" } else { "" },
        if d.m { " M" } else { "" },
        if le { "" } else { " big-endian" },
        if o.ewkb { " (EWKB flags)" } else { "" }
    );
    (o, desc)
}

#[rustfmt::skip]
const TYPE_CODES: &[u32] = &[
    0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 1003, 2003, 3003, 1006, 3006, 1015, 1016,
    1017, 1007, 1010, 1012, 3010, 1008, 0x8000_0003, 0x4000_0003, 0xC000_0006, 0x2000_0003, 0xA000_0003, 99, 1000,
    4003, 0xFFFF_FFFF, 0x8000_0000, 3, 6, 10, 12, 15,
];

/// One to three changes of the WKB at the places it was written: a byte order, a type code, a count, a coordinate;
/// or the bytes cut at one.
fn mutate_wkb(o: &mut WkbOut, rng: &mut SplitMix64) -> Vec<String> {
    let mut done = Vec::new();
    for _ in 0..1 + rng.next_u64() % 2 {
        if o.sites.is_empty() {
            break;
        }
        let kind = *rng.pick(&[
            Site::Order,
            Site::Type,
            Site::Type,
            Site::Count,
            Site::Count,
            Site::Coord,
        ]);
        let at: Vec<usize> = o
            .sites
            .iter()
            .filter(|s| s.1 == kind)
            .map(|s| s.0)
            .collect();
        if at.is_empty() {
            continue;
        }
        let p = *rng.pick(&at);
        // The byte order in force there: the last order byte before it.
        let le = o
            .sites
            .iter()
            .rfind(|s| s.1 == Site::Order && s.0 <= p)
            .is_none_or(|s| o.b[s.0] == 1);
        let put32 = |b: &mut Vec<u8>, v: u32| {
            b[p..p + 4].copy_from_slice(&if le { v.to_le_bytes() } else { v.to_be_bytes() })
        };
        match kind {
            Site::Order => {
                let v = *rng.pick(&[0u8, 1, 2, 0xFF]);
                o.b[p] = v;
                done.push(format!("WKB byte order at {p} := {v}"));
            }
            Site::Type => {
                let v = *rng.pick(TYPE_CODES);
                put32(&mut o.b, v);
                done.push(format!("WKB type at {p} := {v:#x}"));
            }
            Site::Count => {
                let old = if le {
                    u32::from_le_bytes(o.b[p..p + 4].try_into().unwrap())
                } else {
                    u32::from_be_bytes(o.b[p..p + 4].try_into().unwrap())
                };
                let v = *rng.pick(&[
                    0,
                    1,
                    2,
                    3,
                    old.wrapping_sub(1),
                    old.wrapping_add(1),
                    0x7FFF_FFFF,
                    u32::MAX,
                    1 << 24,
                    1 << 28,
                ]);
                put32(&mut o.b, v);
                done.push(format!("WKB count at {p} := {v} (was {old})"));
            }
            Site::Coord => {
                let v = *rng.pick(&[
                    f64::NAN,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    1e308,
                    -1e308,
                    -0.0,
                    1e-320,
                    400.0,
                ]);
                o.b[p..p + 8].copy_from_slice(&if le { v.to_le_bytes() } else { v.to_be_bytes() });
                done.push(format!("WKB coordinate at {p} := {v}"));
            }
        }
    }
    if rng.chance(0.1) && !o.b.is_empty() {
        let at = (rng.next_u64() % o.b.len() as u64) as usize;
        o.b.truncate(at);
        done.push(format!("WKB cut at byte {at}"));
    }
    if rng.chance(0.05) {
        o.b.extend_from_slice(&[0xAB; 9]);
        done.push("WKB with 9 bytes after it".into());
    }
    done
}

// =================================================================================================================
// File Geodatabase

fn gdb_fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fgdb")
        .join(name)
}

fn get_varuint(b: &[u8], at: &mut usize) -> Option<u64> {
    let mut v = 0u64;
    let mut shift = 0;
    loop {
        let byte = *b.get(*at)?;
        *at += 1;
        if shift < 64 {
            v |= u64::from(byte & 0x7f) << shift;
        }
        shift += 7;
        if byte & 0x80 == 0 {
            return Some(v);
        }
        if shift > 70 {
            return None;
        }
    }
}

fn get_varint(b: &[u8], at: &mut usize) -> Option<i64> {
    let first = *b.get(*at)?;
    *at += 1;
    let mut v = u64::from(first & 0x3f);
    if first & 0x80 != 0 {
        let rest = get_varuint(b, at)?;
        v |= rest.checked_shl(6)?;
    }
    let v = v as i64;
    Some(if first & 0x40 != 0 { -v } else { v })
}

fn le_u16(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(at..at + 2)?.try_into().ok()?))
}
fn le_u32(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}
fn le_u64(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
}

/// One field's description, where it lies in the descriptions' bytes.
#[derive(Clone, Debug)]
struct GField {
    kind: u8,
    nullable: bool,
    /// Where its type byte is, and its width and flags bytes (when it has them).
    kind_at: usize,
    width_at: Option<usize>,
    flags_at: Option<usize>,
    geom: Option<GGeomDef>,
}

#[derive(Clone, Debug)]
struct GGeomDef {
    wkt_len_at: usize,
    wkt_bytes: usize,
    gflags_at: usize,
    /// x origin, y origin, xy scale.
    origin_at: usize,
    z_at: Option<usize>,
    grids_at: usize,
}

/// A table taken apart: header, field descriptions, rows (with where the row index points to each).
struct GTable {
    head: Vec<u8>,
    desc: Vec<u8>,
    fields: Vec<GField>,
    utf8: bool,
    x: Vec<u8>,
    /// Bytes of an offset in the row index.
    size: usize,
    rows: Vec<GRow>,
    /// Patches of the rebuilt table's bytes (header fields) and of the row index, applied last.
    table_patches: Vec<(usize, Vec<u8>)>,
    x_patches: Vec<(usize, Vec<u8>)>,
    keep_desc_size: bool,
}

struct GRow {
    /// Where the row index holds its offset.
    entry: usize,
    bytes: Vec<u8>,
    /// The length written before it, when not its own.
    len: Option<i32>,
    /// The offset the row index gives, when not its own.
    offset: Option<u64>,
    /// The row index gives this other row's offset for it.
    same_as: Option<usize>,
}

fn parse_fields(desc: &[u8]) -> Option<(Vec<GField>, bool)> {
    let flags = le_u32(desc, 8)?;
    let utf8 = flags & 0x100 != 0;
    let (layer_m, layer_z) = (flags & (1 << 30) != 0, flags & (1 << 31) != 0);
    let count = le_u16(desc, 12)?;
    let mut c = 14usize;
    let mut out = Vec::new();
    for _ in 0..count {
        let n = *desc.get(c)? as usize;
        c += 1 + 2 * n;
        let n = *desc.get(c)? as usize;
        c += 1 + 2 * n;
        let kind_at = c;
        let kind = *desc.get(c)?;
        c += 1;
        let mut f = GField {
            kind,
            nullable: false,
            kind_at,
            width_at: None,
            flags_at: None,
            geom: None,
        };
        match kind {
            0 | 1 | 2 | 3 | 5 | 13 | 14 | 15 | 16 => {
                f.width_at = Some(c);
                f.flags_at = Some(c + 1);
                let flags = *desc.get(c + 1)?;
                let default = *desc.get(c + 2)? as usize;
                f.nullable = flags & 1 != 0;
                c += 3 + if flags & 4 != 0 { default } else { 0 };
            }
            4 => {
                f.width_at = Some(c);
                c += 4;
                f.flags_at = Some(c);
                let flags = *desc.get(c)?;
                c += 1;
                let default = get_varuint(desc, &mut c)? as usize;
                if flags & 4 != 0 {
                    c += default;
                }
                f.nullable = flags & 1 != 0;
            }
            6 => c += 2,
            7 => {
                f.width_at = Some(c);
                f.flags_at = Some(c + 1);
                f.nullable = *desc.get(c + 1)? & 1 != 0;
                c += 2;
                let wkt_len_at = c;
                let wkt_bytes = le_u16(desc, c)? as usize;
                c += 2 + wkt_bytes;
                let gflags_at = c;
                let gflags = *desc.get(c)?;
                c += 1;
                let (has_m, has_z) = (gflags & 2 != 0, gflags & 4 != 0);
                let origin_at = c;
                c += 24;
                if has_m {
                    c += 16;
                }
                let z_at = has_z.then_some(c);
                if has_z {
                    c += 16;
                }
                c += 8 * (1 + usize::from(has_m) + usize::from(has_z)) + 32;
                c += 16 * (usize::from(layer_z) + usize::from(layer_m));
                c += 1;
                let grids_at = c;
                let grids = le_u32(desc, c)? as usize;
                c += 4 + 8 * grids;
                f.geom = Some(GGeomDef {
                    wkt_len_at,
                    wkt_bytes,
                    gflags_at,
                    origin_at,
                    z_at,
                    grids_at,
                });
            }
            8 | 10 | 11 | 12 => {
                f.width_at = Some(c);
                f.flags_at = Some(c + 1);
                f.nullable = *desc.get(c + 1)? & 1 != 0;
                c += 2;
            }
            _ => return None,
        }
        if c > desc.len() {
            return None;
        }
        out.push(f);
    }
    Some((out, utf8))
}

fn parse_table(t: &[u8], x: &[u8]) -> Option<GTable> {
    let start = le_u64(t, 32)? as usize;
    let size_desc = le_u32(t, start)? as usize;
    let desc = t.get(start..start + 4 + size_desc)?.to_vec();
    let (fields, utf8) = parse_fields(&desc)?;
    let version = le_u32(x, 0)?;
    let (blocks, size) = if version == 3 {
        (le_u32(x, 4)? as usize, le_u32(x, 12)? as usize)
    } else {
        (le_u64(x, 4)? as usize, le_u32(x, 12)? as usize)
    };
    if !(4..=6).contains(&size) || 16 + blocks * 1024 * size > x.len() {
        return None;
    }
    let mut rows = Vec::new();
    for k in 0..blocks * 1024 {
        let entry = 16 + k * size;
        let off = x[entry..entry + size]
            .iter()
            .rev()
            .fold(0u64, |v, &b| (v << 8) | u64::from(b)) as usize;
        if off == 0 {
            continue;
        }
        let len = le_u32(t, off)? as usize;
        let bytes = t.get(off + 4..off + 4 + len)?.to_vec();
        rows.push(GRow {
            entry,
            bytes,
            len: None,
            offset: None,
            same_as: None,
        });
    }
    Some(GTable {
        head: t[..40].to_vec(),
        desc,
        fields,
        utf8,
        x: x.to_vec(),
        size,
        rows,
        table_patches: Vec::new(),
        x_patches: Vec::new(),
        keep_desc_size: false,
    })
}

fn table_bytes(t: &GTable) -> (Vec<u8>, Vec<u8>) {
    let mut out = t.head.clone();
    out[32..40].copy_from_slice(&40u64.to_le_bytes());
    let mut desc = t.desc.clone();
    if !t.keep_desc_size {
        let n = (desc.len() - 4) as u32;
        desc[..4].copy_from_slice(&n.to_le_bytes());
    }
    out.extend_from_slice(&desc);
    let mut x = t.x.clone();
    let mut largest = 0usize;
    let mut placed = Vec::with_capacity(t.rows.len());
    for r in &t.rows {
        let at = out.len() as u64;
        placed.push(at);
        let o = r.offset.unwrap_or(at);
        x[r.entry..r.entry + t.size].copy_from_slice(&o.to_le_bytes()[..t.size]);
        out.extend(r.len.unwrap_or(r.bytes.len() as i32).to_le_bytes());
        out.extend_from_slice(&r.bytes);
        largest = largest.max(r.bytes.len());
    }
    for r in &t.rows {
        if let Some(o) = r.same_as {
            x[r.entry..r.entry + t.size].copy_from_slice(&placed[o].to_le_bytes()[..t.size]);
        }
    }
    let total = out.len() as u64;
    out[24..32].copy_from_slice(&total.to_le_bytes());
    out[8..12].copy_from_slice(&(largest.max(desc.len()) as u32).to_le_bytes());
    for (at, b) in &t.table_patches {
        if *at + b.len() <= out.len() {
            out[*at..*at + b.len()].copy_from_slice(b);
        }
    }
    for (at, b) in &t.x_patches {
        if *at + b.len() <= x.len() {
            x[*at..*at + b.len()].copy_from_slice(b);
        }
    }
    (out, x)
}

/// Where each field's value lies in a row: (field index, start of its bytes, end), for the fields present.
fn row_cells(t: &GTable, row: &[u8]) -> Vec<(usize, usize, usize)> {
    let nullable = t.fields.iter().filter(|f| f.nullable).count();
    let flag_bytes = nullable.div_ceil(8);
    let Some(flags) = row.get(..flag_bytes) else {
        return Vec::new();
    };
    let mut c = flag_bytes;
    let mut bit = 0usize;
    let mut out = Vec::new();
    for (i, f) in t.fields.iter().enumerate() {
        if f.kind == 6 {
            continue;
        }
        if f.nullable {
            let b = bit;
            bit += 1;
            if flags[b / 8] & (1 << (b % 8)) != 0 {
                continue;
            }
        }
        let start = c;
        let n = match f.kind {
            0 => 2,
            1 | 2 => 4,
            3 | 5 | 13 | 14 | 15 => 8,
            16 => 10,
            10 | 11 => 16,
            4 | 7 | 8 | 12 => {
                let Some(n) = get_varuint(row, &mut c) else {
                    return out;
                };
                n as usize
            }
            _ => return out,
        };
        c = c.saturating_add(n);
        if c > row.len() {
            return out;
        }
        out.push((i, start, c));
    }
    out
}

/// A geometry blob taken apart into its numbers.
#[derive(Clone, Debug)]
struct GGeom {
    kind: u64,
    points: u64,
    extra: Option<u64>,
    parts: u64,
    curves: Option<u64>,
    bbox: [u64; 4],
    sizes: Vec<u64>,
    types: Vec<u64>,
    xy: Vec<(i64, i64)>,
    z: Vec<i64>,
    rest: Vec<u8>,
}

const HAS_Z: u64 = 0x8000_0000;
const HAS_M: u64 = 0x4000_0000;
const HAS_CURVES: u64 = 0x2000_0000;

fn parse_geom(b: &[u8]) -> Option<GGeom> {
    let mut c = 0;
    let kind = get_varuint(b, &mut c)?;
    let base = kind & 0xff;
    let multipatch = matches!(base, 31 | 32 | 54);
    let curved = matches!(base, 50 | 51) && kind & HAS_CURVES != 0;
    let has_z = matches!(base, 15 | 19 | 31 | 32 | 10 | 13)
        || (matches!(base, 50 | 51 | 54) && kind & HAS_Z != 0);
    let points = get_varuint(b, &mut c)?;
    if points == 0 || points > b.len() as u64 {
        return None;
    }
    let extra = if multipatch {
        Some(get_varuint(b, &mut c)?)
    } else {
        None
    };
    let parts = get_varuint(b, &mut c)?;
    if parts == 0 || parts > points {
        return None;
    }
    let curves = if curved {
        Some(get_varuint(b, &mut c)?)
    } else {
        None
    };
    let mut bbox = [0u64; 4];
    for v in &mut bbox {
        *v = get_varuint(b, &mut c)?;
    }
    let mut sizes = Vec::new();
    for _ in 1..parts {
        sizes.push(get_varuint(b, &mut c)?);
    }
    let mut types = Vec::new();
    if multipatch {
        for _ in 0..parts {
            types.push(get_varuint(b, &mut c)?);
        }
    }
    let mut xy = Vec::new();
    for _ in 0..points {
        xy.push((get_varint(b, &mut c)?, get_varint(b, &mut c)?));
    }
    let mut z = Vec::new();
    if has_z && (multipatch || curved) {
        for _ in 0..points {
            z.push(get_varint(b, &mut c)?);
        }
    }
    Some(GGeom {
        kind,
        points,
        extra,
        parts,
        curves,
        bbox,
        sizes,
        types,
        xy,
        z,
        rest: b[c..].to_vec(),
    })
}

fn geom_bytes(g: &GGeom) -> Vec<u8> {
    let mut o = Vec::new();
    put_varuint(&mut o, g.kind);
    put_varuint(&mut o, g.points);
    if let Some(e) = g.extra {
        put_varuint(&mut o, e);
    }
    put_varuint(&mut o, g.parts);
    if let Some(k) = g.curves {
        put_varuint(&mut o, k);
    }
    for v in g.bbox {
        put_varuint(&mut o, v);
    }
    for &s in &g.sizes {
        put_varuint(&mut o, s);
    }
    for &t in &g.types {
        put_varuint(&mut o, t);
    }
    for &(x, y) in &g.xy {
        put_varint(&mut o, x);
        put_varint(&mut o, y);
    }
    for &z in &g.z {
        put_varint(&mut o, z);
    }
    o.extend_from_slice(&g.rest);
    o
}

/// Curve descriptors (start point, type, numbers, flags) for a general polygon's tail.
fn curve_descriptors(rng: &mut SplitMix64, points: u64, k: u64) -> (Vec<u8>, String) {
    let mut o = Vec::new();
    let mut said = Vec::new();
    let odd = [f64::NAN, f64::INFINITY, 0.0, -1.0, 1e308, 1e-300];
    for _ in 0..k {
        let start = match rng.next_u64() % 6 {
            0 => points,
            1 => u64::MAX >> 1,
            2 => points.saturating_sub(1),
            _ => rng.next_u64() % points.max(1),
        };
        let kind = *rng.pick(&[1u64, 1, 4, 5, 5, 2, 7, 0]);
        put_varuint(&mut o, start);
        put_varuint(&mut o, kind);
        let num = |rng: &mut SplitMix64| {
            if rng.chance(0.3) {
                *rng.pick(&odd)
            } else {
                rng.range(-5.0, 5.0)
            }
        };
        match kind {
            1 => {
                for _ in 0..2 {
                    let v = num(rng);
                    o.extend(v.to_le_bytes());
                }
                let bits = *rng.pick(&[0u32, 0x80, 0x8, 0x88, 0x1, 0x20, 0x40, u32::MAX]);
                o.extend(bits.to_le_bytes());
            }
            4 => {
                for _ in 0..4 {
                    let v = num(rng);
                    o.extend(v.to_le_bytes());
                }
            }
            5 => {
                for _ in 0..5 {
                    let v = num(rng);
                    o.extend(v.to_le_bytes());
                }
                let bits = *rng.pick(&[0u32, 0x800, 0x1, 0x40, 0x80]);
                o.extend(bits.to_le_bytes());
            }
            _ => {}
        }
        said.push(format!("{kind}@{start}"));
    }
    (o, said.join(","))
}

fn mutate_geom(g: &mut GGeom, rng: &mut SplitMix64) -> String {
    let n = g.points;
    match rng.next_u64() % 12 {
        0 => {
            let base = g.kind & 0xff;
            let v = *rng.pick(&[
                5,
                15,
                19,
                25,
                51,
                51 | HAS_CURVES,
                51 | HAS_Z,
                51 | HAS_Z | HAS_CURVES,
                51 | HAS_M | HAS_CURVES,
                31,
                32,
                54 | HAS_Z,
                54,
                3,
                50,
                50 | HAS_CURVES,
                0,
                1,
                8,
                99,
                1 << 40,
                base | HAS_Z | HAS_M,
            ]);
            g.kind = v;
            format!("geometry type := {v:#x}")
        }
        1 => {
            let v = *rng.pick(&[
                0,
                1,
                2,
                n.saturating_sub(1),
                n + 1,
                2 * n,
                1 << 31,
                u64::MAX >> 1,
            ]);
            g.points = v;
            format!("point count := {v} (was {n})")
        }
        2 => {
            let v = *rng.pick(&[0, 1, 2, n, n + 1, g.parts + 1, u64::MAX]);
            let was = g.parts;
            g.parts = v;
            format!("part count := {v} (was {was})")
        }
        3 if !g.sizes.is_empty() => {
            let i = (rng.next_u64() % g.sizes.len() as u64) as usize;
            let v = *rng.pick(&[0, 1, 2, 3, n, n + 1, u64::MAX, 1 << 33]);
            g.sizes[i] = v;
            format!("part {i}'s size := {v}")
        }
        3 | 4 => {
            // One part more or less, its size list kept consistent or not.
            if rng.chance(0.5) && n >= 4 {
                g.parts += 1;
                g.sizes.push(n / 2);
                if !g.types.is_empty() {
                    g.types.push(*rng.pick(&[0, 1, 2, 3, 4, 5, 99]));
                }
                "a part split off".into()
            } else {
                g.parts = g.parts.saturating_sub(1).max(1);
                g.sizes.pop();
                g.types.pop();
                "a part merged".into()
            }
        }
        5 if !g.xy.is_empty() => {
            let i = (rng.next_u64() % g.xy.len() as u64) as usize;
            let v = *rng.pick(&[
                1i64 << 60,
                -(1i64 << 60),
                0,
                1,
                -1,
                i64::MAX / 2,
                -(1i64 << 40),
            ]);
            if rng.chance(0.5) {
                g.xy[i].0 = v;
            } else {
                g.xy[i].1 = v;
            }
            format!("point {i}'s delta := {v}")
        }
        6 if !g.xy.is_empty() => {
            // Every point after the first onto it (deltas 0), or the deltas negated (the ring mirrored).
            if rng.chance(0.5) {
                g.xy.iter_mut().skip(1).for_each(|p| *p = (0, 0));
                "every delta 0 (all points one)".into()
            } else {
                g.xy.iter_mut().skip(1).for_each(|p| *p = (-p.0, -p.1));
                "deltas negated".into()
            }
        }
        7 if !g.types.is_empty() => {
            let i = (rng.next_u64() % g.types.len() as u64) as usize;
            let v = *rng.pick(&[0, 1, 2, 3, 4, 5, 6, 7, 15, 99, u64::MAX]);
            g.types[i] = v;
            format!("part {i}'s type := {v}")
        }
        7 if !g.z.is_empty() => {
            let i = (rng.next_u64() % g.z.len() as u64) as usize;
            let v = *rng.pick(&[1i64 << 60, -(1i64 << 60), 0, i64::MAX / 2]);
            g.z[i] = v;
            format!("z delta {i} := {v}")
        }
        8 | 9 => {
            // Curves: the type made a general polygon with curves and descriptors put after the points.
            let k = *rng.pick(&[1u64, 2, 3, 8]);
            let (desc, said) = curve_descriptors(rng, n, k);
            let zm = g.kind & (HAS_Z | HAS_M);
            g.kind = *rng.pick(&[51, 50]) | HAS_CURVES | if rng.chance(0.3) { zm } else { 0 };
            let claimed = *rng.pick(&[k, k, k + 1, 0, u64::MAX >> 1]);
            g.curves = Some(claimed);
            if g.kind & HAS_Z != 0 && g.z.is_empty() {
                g.z = vec![0; g.xy.len()];
            }
            g.rest = if g.kind & HAS_M != 0 && rng.chance(0.7) {
                vec![0x42]
            } else {
                Vec::new()
            };
            g.rest.extend(desc);
            format!(
                "{k} curve(s) [{said}] said as {claimed}, type {:#x}",
                g.kind
            )
        }
        10 => {
            g.bbox = [u64::MAX, 0, u64::MAX, 1 << 62];
            "bounding box huge".into()
        }
        _ => {
            // The blob cut inside its points.
            let keep = (rng.next_u64() % (g.xy.len() as u64 + 1)) as usize;
            g.xy.truncate(keep);
            g.z.truncate(keep);
            g.rest.clear();
            format!("the blob cut after {keep} points")
        }
    }
}

fn bytes_to_utf16(s: &str) -> Vec<u8> {
    s.encode_utf16().flat_map(u16::to_le_bytes).collect()
}

/// One structural mutation of a table, described.
fn mutate_table(t: &mut GTable, rng: &mut SplitMix64) -> String {
    // The descriptions as they are now (an earlier mutation may have moved or broken them).
    match parse_fields(&t.desc) {
        Some((f, u)) => {
            t.fields = f;
            t.utf8 = u;
        }
        None => t.fields.clear(),
    }
    let geom_field = t.fields.iter().position(|f| f.geom.is_some());
    let choice = if t.fields.is_empty() {
        15 + rng.next_u64() % 5
    } else {
        rng.next_u64() % 20
    };
    match choice {
        0..=6 if geom_field.is_some() && !t.rows.is_empty() => {
            // A row's geometry blob.
            let gi = geom_field.unwrap();
            for _ in 0..8 {
                let r = (rng.next_u64() % t.rows.len() as u64) as usize;
                let row = t.rows[r].bytes.clone();
                let cells = row_cells(t, &row);
                let Some(&(_, start, end)) = cells.iter().find(|c| c.0 == gi) else {
                    continue;
                };
                let mut c = start;
                let n = get_varuint(&row, &mut c).unwrap() as usize;
                let blob = &row[c..c + n];
                let Some(mut g) = parse_geom(blob) else {
                    continue;
                };
                let mut said = vec![mutate_geom(&mut g, rng)];
                if rng.chance(0.3) {
                    said.push(mutate_geom(&mut g, rng));
                }
                let nb = geom_bytes(&g);
                let mut out = row[..start].to_vec();
                put_varuint(&mut out, nb.len() as u64);
                out.extend_from_slice(&nb);
                out.extend_from_slice(&row[end..]);
                t.rows[r].bytes = out;
                return format!("row {r}'s geometry: {}", said.join(", "));
            }
            "no geometry to change".into()
        }
        7 => {
            // A field's type byte.
            let i = (rng.next_u64() % t.fields.len() as u64) as usize;
            let v = *rng.pick(&[
                0u8, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 99, 255,
            ]);
            let at = t.fields[i].kind_at;
            t.desc[at] = v;
            format!("field {i}'s type {} := {v}", t.fields[i].kind)
        }
        8 => {
            // A field's flags: nullable or editable (a default value) toggled.
            let i = (rng.next_u64() % t.fields.len() as u64) as usize;
            match t.fields[i].flags_at {
                Some(at) => {
                    let bit = *rng.pick(&[1u8, 4, 0xff]);
                    t.desc[at] ^= bit;
                    format!("field {i}'s flags ^= {bit:#x}")
                }
                None => "a field without flags".into(),
            }
        }
        9 => {
            let i = (rng.next_u64() % t.fields.len() as u64) as usize;
            match t.fields[i].width_at {
                Some(at) => {
                    let v = *rng.pick(&[0u8, 1, 2, 255, 0x80]);
                    t.desc[at] = v;
                    format!("field {i}'s width := {v}")
                }
                None => "a field without a width".into(),
            }
        }
        10 => {
            let n = le_u16(&t.desc, 12).unwrap();
            let v = *rng.pick(&[0u16, 1, n.saturating_sub(1), n + 1, u16::MAX]);
            t.desc[12..14].copy_from_slice(&v.to_le_bytes());
            format!("field count := {v} (was {n})")
        }
        11 => {
            // The table's flags: its geometry type, UTF-8, Z, M.
            let what = rng.next_u64() % 4;
            match what {
                0 => {
                    let v = *rng.pick(&[0u8, 1, 2, 3, 4, 5, 9, 255]);
                    t.desc[8] = v;
                    format!("table geometry type := {v}")
                }
                1 => {
                    t.desc[9] ^= 1;
                    "table UTF-8 flag toggled".into()
                }
                2 => {
                    t.desc[11] ^= 0x80;
                    "table Z flag toggled".into()
                }
                _ => {
                    t.desc[11] ^= 0x40;
                    "table M flag toggled".into()
                }
            }
        }
        12 => {
            let v = *rng.pick(&[0u32, 3, 4, 5, 6, 7, u32::MAX]);
            t.desc[4..8].copy_from_slice(&v.to_le_bytes());
            format!("descriptions' version := {v}")
        }
        13 if geom_field.is_some() => {
            // The spatial reference text, or its length.
            let g = t.fields[geom_field.unwrap()].geom.clone().unwrap();
            if rng.chance(0.25) {
                let v = *rng.pick(&[1u16, 3, u16::MAX, (g.wkt_bytes as u16).wrapping_add(1), 0]);
                t.desc[g.wkt_len_at..g.wkt_len_at + 2].copy_from_slice(&v.to_le_bytes());
                t.keep_desc_size = rng.chance(0.5);
                return format!("WKT length := {v} (was {})", g.wkt_bytes);
            }
            let wkt = *rng.pick(WKTS);
            let b = bytes_to_utf16(wkt);
            let mut desc = t.desc[..g.wkt_len_at].to_vec();
            desc.extend((b.len() as u16).to_le_bytes());
            desc.extend_from_slice(&b);
            desc.extend_from_slice(&t.desc[g.wkt_len_at + 2 + g.wkt_bytes..]);
            t.desc = desc;
            format!("WKT := {:?}", wkt.chars().take(40).collect::<String>())
        }
        14 if geom_field.is_some() => {
            let g = t.fields[geom_field.unwrap()].geom.clone().unwrap();
            let which = rng.next_u64() % 5;
            let v = *rng.pick(&[
                0.0,
                -1.0,
                f64::NAN,
                f64::INFINITY,
                1e-300,
                1e300,
                -2_147_483_647.0 * 1e10,
            ]);
            match which {
                0 | 1 => {
                    let at = g.origin_at + 8 * which as usize;
                    t.desc[at..at + 8].copy_from_slice(&v.to_le_bytes());
                    format!("{} origin := {v}", if which == 0 { "x" } else { "y" })
                }
                2 => {
                    let at = g.origin_at + 16;
                    t.desc[at..at + 8].copy_from_slice(&v.to_le_bytes());
                    format!("xy scale := {v}")
                }
                3 => match g.z_at {
                    Some(at) => {
                        t.desc[at + 8..at + 16].copy_from_slice(&v.to_le_bytes());
                        format!("z scale := {v}")
                    }
                    None => {
                        t.desc[g.gflags_at] ^= 6;
                        "geometry Z / M flags toggled".into()
                    }
                },
                _ => {
                    let v = *rng.pick(&[0u32, 4, u32::MAX]);
                    t.desc[g.grids_at..g.grids_at + 4].copy_from_slice(&v.to_le_bytes());
                    format!("spatial grid levels := {v}")
                }
            }
        }
        15 if !t.rows.is_empty() => {
            // A row's offset in the row index.
            let r = (rng.next_u64() % t.rows.len() as u64) as usize;
            let other = (rng.next_u64() % t.rows.len() as u64) as usize;
            let v = match rng.next_u64() % 5 {
                0 => (1u64 << (8 * t.size)) - 1,
                1 => 40,
                2 => 41,
                3 => 12,
                _ => u64::MAX, // marker: another row's
            };
            if v == u64::MAX {
                t.rows[r].same_as = Some(other);
                format!("row {r}'s index entry := row {other}'s offset")
            } else {
                t.rows[r].offset = Some(v);
                format!("row {r}'s offset := {v}")
            }
        }
        16 if !t.rows.is_empty() => {
            let r = (rng.next_u64() % t.rows.len() as u64) as usize;
            let n = t.rows[r].bytes.len() as i32;
            match rng.next_u64() % 5 {
                0 => {
                    t.rows[r].len = Some(-n);
                    format!("row {r}'s length negated (deleted)")
                }
                1 => {
                    t.rows[r].len = Some(i32::MAX);
                    format!("row {r}'s length := i32::MAX")
                }
                2 => {
                    let keep = (rng.next_u64() % (n as u64 + 1)) as usize;
                    t.rows[r].bytes.truncate(keep);
                    format!("row {r} cut to {keep} bytes")
                }
                3 => {
                    if let Some(b) = t.rows[r].bytes.first_mut() {
                        *b = *rng.pick(&[0u8, 0xff, !*b]);
                    }
                    format!("row {r}'s first null-flag byte changed")
                }
                _ => {
                    t.rows[r].len = Some(n + 1);
                    format!("row {r}'s length one more")
                }
            }
        }
        17 if !t.rows.is_empty() => {
            // A string or binary cell's length varint made huge.
            let r = (rng.next_u64() % t.rows.len() as u64) as usize;
            let row = t.rows[r].bytes.clone();
            let cells: Vec<_> = row_cells(t, &row)
                .into_iter()
                .filter(|c| matches!(t.fields[c.0].kind, 4 | 8 | 12 | 7))
                .collect();
            if cells.is_empty() {
                return "no text cell".into();
            }
            let &(i, start, end) = rng.pick(&cells);
            let v = *rng.pick(&[u64::MAX, 1 << 40, (end - start) as u64 + 3]);
            let mut c = start;
            get_varuint(&row, &mut c);
            let mut out = row[..start].to_vec();
            put_varuint(&mut out, v);
            out.extend_from_slice(&row[c..]);
            t.rows[r].bytes = out;
            format!("row {r}'s field {i} length := {v}")
        }
        18 => {
            // The row index's header: blocks, rows, offset size.
            match rng.next_u64() % 5 {
                0 => {
                    let v = *rng.pick(&[0u32, 1, 2, u32::MAX]);
                    t.x_patches.push((4, v.to_le_bytes().to_vec()));
                    format!("row index blocks := {v}")
                }
                1 => {
                    let v = *rng.pick(&[0u32, 1, u32::MAX]);
                    t.x_patches.push((8, v.to_le_bytes().to_vec()));
                    format!("row index rows := {v}")
                }
                2 => {
                    let v = *rng.pick(&[3u32, 4, 6, 7, 0]);
                    t.x_patches.push((12, v.to_le_bytes().to_vec()));
                    format!("row index offset size := {v}")
                }
                3 if rng.chance(0.6) => {
                    // Its trailer: the bitmap's length in words, the blocks it covers, the blocks stored, a bitmap byte.
                    let blocks = if le_u32(&t.x, 0) == Some(3) {
                        le_u32(&t.x, 4).unwrap_or(0) as usize
                    } else {
                        le_u64(&t.x, 4).unwrap_or(0) as usize
                    };
                    let body = 16 + blocks * 1024 * t.size;
                    let (off, v) = *rng.pick(&[
                        (0usize, 0u32),
                        (0, 1),
                        (0, u32::MAX),
                        (4, 0),
                        (4, u32::MAX),
                        (8, 0),
                        (8, 1),
                        (16, 0),
                        (16, 0xffff_ffff),
                        (12, 32_842),
                    ]);
                    t.x_patches.push((body + off, v.to_le_bytes().to_vec()));
                    format!("row index trailer field at +{off} := {v}")
                }
                _ => {
                    let keep = (rng.next_u64() % t.x.len() as u64) as usize;
                    t.x.truncate(keep.max(16));
                    t.rows.retain(|r| r.entry + t.size <= keep.max(16));
                    format!("row index cut to {} bytes", keep.max(16))
                }
            }
        }
        _ => {
            // The table header.
            match rng.next_u64() % 3 {
                0 => {
                    let v = *rng.pick(&[0u64, 7, 1 << 40, u64::MAX]);
                    t.table_patches.push((32, v.to_le_bytes().to_vec()));
                    format!("descriptions' offset := {v}")
                }
                1 => {
                    let v = *rng.pick(&[0u32, 5, u32::MAX]);
                    t.table_patches.push((0, v.to_le_bytes().to_vec()));
                    format!("table version := {v}")
                }
                _ => {
                    t.keep_desc_size = true;
                    let v = *rng.pick(&[0u32, 11 << 20, u32::MAX]);
                    t.desc[..4].copy_from_slice(&v.to_le_bytes());
                    format!("descriptions' size := {v}")
                }
            }
        }
    }
}

/// The catalog's table names by OBJECTID (the catalog's rows are never sparse).
fn catalog_names(t: &GTable) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for r in &t.rows {
        let oid = (r.entry - 16) / t.size + 1;
        let cells = row_cells(t, &r.bytes);
        if let Some(&(_, start, end)) = cells.iter().find(|c| t.fields[c.0].kind == 4) {
            let mut c = start;
            let n = get_varuint(&r.bytes, &mut c).unwrap() as usize;
            let b = &r.bytes[c..end.min(c + n)];
            let name = if t.utf8 {
                String::from_utf8_lossy(b).into_owned()
            } else {
                let u: Vec<u16> = b
                    .chunks_exact(2)
                    .map(|p| u16::from_le_bytes([p[0], p[1]]))
                    .collect();
                String::from_utf16_lossy(&u)
            };
            out.push((oid, name));
        }
    }
    out
}

// ---- ZIP

fn mutate_zip(z: &mut Zip, rng: &mut SplitMix64) -> String {
    let put16 =
        |b: &mut Vec<u8>, at: usize, v: u16| b[at..at + 2].copy_from_slice(&v.to_le_bytes());
    let put32 =
        |b: &mut Vec<u8>, at: usize, v: u32| b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    let k = (rng.next_u64() % z.central.len().max(1) as u64) as usize;
    match rng.next_u64() % 11 {
        0 => {
            let v = *rng.pick(&[0u16, 1, 12, 14, 99, 8]);
            put16(&mut z.bytes, z.central[k] + 10, v);
            format!("zip member {k}'s method := {v}")
        }
        1 => {
            let v = *rng.pick(&[0u32, 1, u32::MAX, 0x7fff_ffff]);
            put32(&mut z.bytes, z.central[k] + 20, v);
            format!("zip member {k}'s compressed size := {v}")
        }
        2 => {
            let v = *rng.pick(&[0u32, 1, u32::MAX, 0x7fff_ffff]);
            put32(&mut z.bytes, z.central[k] + 24, v);
            format!("zip member {k}'s size := {v}")
        }
        3 => {
            let other = z.locals[(rng.next_u64() % z.locals.len() as u64) as usize] as u32;
            let v = *rng.pick(&[u32::MAX, other, other + 1, z.eocd as u32]);
            put32(&mut z.bytes, z.central[k] + 42, v);
            format!("zip member {k}'s local header offset := {v}")
        }
        4 => {
            let v = *rng.pick(&[0u16, 1, u16::MAX]);
            put16(&mut z.bytes, z.central[k] + 28, v);
            format!("zip member {k}'s name length := {v}")
        }
        5 => {
            put16(&mut z.bytes, z.central[k] + 8, 1);
            format!("zip member {k} marked encrypted")
        }
        6 => {
            let at = z.central[k] + 16;
            z.bytes[at] ^= 0x5a;
            format!("zip member {k}'s CRC changed")
        }
        7 => {
            let v = *rng.pick(&[0u16, 1, u16::MAX]);
            put16(&mut z.bytes, z.eocd + 10, v);
            put16(&mut z.bytes, z.eocd + 8, v);
            format!("zip entries := {v}")
        }
        8 => {
            let v = *rng.pick(&[0u32, 1, u32::MAX]);
            let at = z.eocd + if rng.chance(0.5) { 12 } else { 16 };
            put32(&mut z.bytes, at, v);
            format!(
                "zip central directory {} := {v}",
                if at == z.eocd + 12 { "size" } else { "offset" }
            )
        }
        9 => {
            let v = *rng.pick(&[0u16, u16::MAX, 200]);
            put16(&mut z.bytes, z.locals[k] + 26, v);
            format!("zip member {k}'s local name length := {v}")
        }
        _ => {
            let at = z.locals[k] + 30 + 5;
            if at < z.bytes.len() {
                z.bytes[at] ^= 0xff;
            }
            format!("zip member {k}'s data changed at byte 5")
        }
    }
}

/// The File Geodatabase inputs: folder, layer, CRS needed.
const GDBS: &[(&str, Option<&str>, Option<&str>)] = &[
    ("nyc-les-2263.gdb", None, None),
    ("kinds.gdb", Some("blocks"), None),
    ("kinds.gdb", Some("round"), None),
    ("kinds.gdb", Some("models"), None),
    ("kinds.gdb", Some("walls"), None),
    ("pro32.gdb", None, None),
    ("sparse.gdb", None, None),
    ("arcgis.gdb", Some("several_polygons"), Some("EPSG:32618")),
    ("arcgis.gdb", Some("multipolygonzm"), Some("EPSG:32618")),
    ("no-crs.gdb", None, Some("EPSG:32618")),
];

/// The features a fixture's layer gives unchanged.
fn gdb_rows(name: &str, layer: Option<&str>, crs: Option<&str>) -> usize {
    static ROWS: std::sync::Mutex<Vec<(String, usize)>> = std::sync::Mutex::new(Vec::new());
    let key = format!("{name}/{layer:?}");
    if let Some(n) = ROWS
        .lock()
        .unwrap()
        .iter()
        .find(|r| r.0 == key)
        .map(|r| r.1)
    {
        return n;
    }
    let opts = IngestOptions {
        layer: layer.map(str::to_string),
        crs: crs.map(str::to_string),
        ..Default::default()
    };
    let n = ingest(&[gdb_fixture(name)], &opts)
        .unwrap()
        .report
        .features_read;
    ROWS.lock().unwrap().push((key, n));
    n
}

fn make_fgdb(dir: &Path, _seed: u64, rng: &mut SplitMix64) -> Case {
    let &(name, layer, crs) = rng.pick(GDBS);
    let src = gdb_fixture(name);
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&src)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    files.sort();
    let mut done = vec![format!(
        "{name}{}",
        layer.map_or(String::new(), |l| format!(" layer {l}"))
    )];
    let get =
        |files: &[(String, Vec<u8>)], f: &str| files.iter().find(|e| e.0 == f).map(|e| e.1.clone());
    let catalog = parse_table(
        &get(&files, "a00000001.gdbtable").unwrap(),
        &get(&files, "a00000001.gdbtablx").unwrap(),
    )
    .expect("the catalog parses");
    let names = catalog_names(&catalog);
    let wanted = names.iter().find(|(oid, n)| {
        layer.map_or(
            !n.starts_with("GDB_") && files.iter().any(|f| f.0 == format!("a{oid:08x}.gdbtable")),
            |l| n == l,
        )
    });
    // (The draw made whether or not a table was found, as before, so that each seed makes the same case.)
    let catalog = rng.chance(0.12);
    let stem = match wanted {
        Some(w) if !catalog => format!("a{:08x}", w.0),
        _ => "a00000001".to_string(),
    };
    let (tb, xb) = (
        get(&files, &format!("{stem}.gdbtable")).unwrap(),
        get(&files, &format!("{stem}.gdbtablx")).unwrap(),
    );
    // Only geometry blobs changed (in the layer's table): every row is still read.
    let mut local = stem != "a00000001";
    match parse_table(&tb, &xb) {
        Some(mut t) => {
            let mut said = Vec::new();
            for _ in 0..1 + rng.next_u64() % 3 {
                said.push(mutate_table(&mut t, rng));
            }
            // Whatever the rows hold, however the fields are described, each row the index points at is read
            // (written, or skipped saying why) once the table is read at all: only the row index's own header
            // may change which rows there are (and even then not silently: see
            // `a_row_index_counting_too_few_rows_does_not_drop_the_rest_silently`).
            local &= !said.iter().any(|d| d.starts_with("row index"));
            let (tb2, xb2) = table_bytes(&t);
            for f in files.iter_mut() {
                if f.0 == format!("{stem}.gdbtable") {
                    f.1 = tb2.clone();
                } else if f.0 == format!("{stem}.gdbtablx") {
                    f.1 = xb2.clone();
                }
            }
            done.push(format!("{stem}: {}", said.join("; ")));
        }
        None => done.push(format!("{stem} not parsed: unchanged")),
    }
    if rng.chance(0.04) {
        local = false;
        let what = *rng.pick(&["gdbtablx", "gdbtable", "cdf"]);
        if what == "cdf" {
            files.push((format!("{stem}.cdf"), Vec::new()));
        } else {
            files.retain(|f| f.0 != format!("{stem}.{what}"));
        }
        done.push(format!(
            "{stem}.{what} {}",
            if what == "cdf" { "added" } else { "removed" }
        ));
    }
    let folder = dir.join(name);
    std::fs::create_dir_all(&folder).unwrap();
    for (n, b) in &files {
        std::fs::write(folder.join(n), b).unwrap();
    }
    let mut path = folder;
    if rng.chance(0.2) {
        let prefix = if rng.chance(0.7) {
            format!("{name}/")
        } else {
            "deep/er/".to_string() + name + "/"
        };
        let entries: Vec<(String, Vec<u8>)> = files
            .iter()
            .map(|(n, b)| (format!("{prefix}{n}"), b.clone()))
            .collect();
        let deflate = rng.chance(0.5);
        let mut z = zip(&entries, deflate);
        let mut said = format!("zipped ({})", if deflate { "deflated" } else { "stored" });
        if rng.chance(0.6) {
            said.push_str(": ");
            said.push_str(&mutate_zip(&mut z, rng));
            local = false;
        }
        done.push(said);
        path = dir.join(format!("{name}.zip"));
        std::fs::write(&path, &z.bytes).unwrap();
    }
    let rows = local.then(|| gdb_rows(name, layer, crs));
    Case {
        path,
        done,
        crs: crs.map(str::to_string),
        layer: layer.map(str::to_string),
        rows,
    }
}

/// The zip fixtures with their central directory or local headers changed.
fn make_fgdb_zip(dir: &Path, _seed: u64, rng: &mut SplitMix64) -> Case {
    let name = *rng.pick(&["nyc-les-2263.gdb.zip", "nested-zip64.zip", "two.zip"]);
    let mut b = std::fs::read(gdb_fixture(name)).unwrap();
    let mut done = vec![name.to_string()];
    let sig = |b: &[u8], s: u32| -> Vec<usize> {
        (0..b.len().saturating_sub(4))
            .filter(|&i| le_u32(b, i) == Some(s))
            .collect()
    };
    for _ in 0..1 + rng.next_u64() % 2 {
        let central = sig(&b, 0x0201_4b50);
        let eocd = sig(&b, 0x0605_4b50);
        let z64 = sig(&b, 0x0606_4b50);
        let which = rng.next_u64() % 4;
        if which == 0 && !z64.is_empty() {
            // The ZIP64 record: entries, size, offset.
            let at = z64[0] + *rng.pick(&[24usize, 32, 40, 48]);
            let v = *rng.pick(&[0u64, 1, u64::MAX, 1 << 40]);
            b[at..at + 8].copy_from_slice(&v.to_le_bytes());
            done.push(format!("ZIP64 record field at {} := {v}", at - z64[0]));
        } else if which == 1 && !eocd.is_empty() {
            let e = *eocd.last().unwrap();
            let at = e + *rng.pick(&[8usize, 10, 12, 16, 20]);
            let v = *rng.pick(&[0u16, 1, u16::MAX]);
            b[at..at + 2].copy_from_slice(&v.to_le_bytes());
            done.push(format!("EOCD field at {} := {v}", at - e));
        } else if !central.is_empty() {
            let c = *rng.pick(&central);
            let (off, w) = *rng.pick(&[
                (8usize, 2usize),
                (10, 2),
                (16, 4),
                (20, 4),
                (24, 4),
                (28, 2),
                (30, 2),
                (42, 4),
            ]);
            let v = *rng.pick(&[0u32, 1, u32::MAX, 0xFFFF, 12]);
            b[c + off..c + off + w].copy_from_slice(&v.to_le_bytes()[..w]);
            done.push(format!("central entry at {c}, field {off} := {v}"));
        }
    }
    let path = dir.join(name);
    std::fs::write(&path, &b).unwrap();
    Case {
        path,
        done,
        crs: None,
        layer: None,
        rows: None,
    }
}

fn make_fgdb_any(dir: &Path, seed: u64, rng: &mut SplitMix64) -> Case {
    if rng.chance(0.1) {
        make_fgdb_zip(dir, seed, rng)
    } else {
        make_fgdb(dir, seed, rng)
    }
}

// =================================================================================================================
// GeoPackage

fn gpkg_header(rng: &mut SplitMix64, srs: i32, empty_ok: bool) -> (Vec<u8>, Option<String>) {
    if rng.chance(0.75) {
        let ind = *rng.pick(&[0u8, 1, 1]);
        let mut b = vec![b'G', b'P', 0, 1 | (ind << 1)];
        b.extend(srs.to_le_bytes());
        b.extend(std::iter::repeat_n(0u8, 32 * usize::from(ind)));
        return (b, None);
    }
    let magic = if rng.chance(0.1) { *b"GX" } else { *b"GP" };
    let version = *rng.pick(&[0u8, 0, 1, 255]);
    let ind = *rng.pick(&[0u8, 1, 2, 3, 4, 5, 6, 7]);
    let le = !rng.chance(0.2);
    let empty = empty_ok && rng.chance(0.2);
    let extended = rng.chance(0.1);
    let flags = u8::from(le) | (ind << 1) | (u8::from(empty) << 4) | (u8::from(extended) << 5);
    let srs_v = *rng.pick(&[srs, srs, 0, -1, 4326, 2263, 32618, 99999]);
    let mut b = vec![magic[0], magic[1], version, flags];
    b.extend(if le {
        srs_v.to_le_bytes()
    } else {
        srs_v.to_be_bytes()
    });
    let doubles = match ind {
        0 => 0,
        1 => 4,
        2 | 3 => 6,
        4 => 8,
        _ => *rng.pick(&[0usize, 4, 8]),
    };
    for _ in 0..doubles {
        let v = *rng.pick(&[0.0, f64::NAN, 1e308, -5.0]);
        b.extend(if le { v.to_le_bytes() } else { v.to_be_bytes() });
    }
    let said = format!(
        "header {}{} version {version} envelope {ind} ({doubles} doubles){}{}{} srs {srs_v}",
        magic[0] as char,
        magic[1] as char,
        if le { "" } else { " big-endian" },
        if empty { " empty" } else { "" },
        if extended { " extended" } else { "" }
    );
    (b, Some(said))
}

fn make_gpkg(dir: &Path, seed: u64, rng: &mut SplitMix64) -> Case {
    use citylod_testdata::geopackage::{write, Layer, Row, Srs};
    use rusqlite::types::Value as Sql;
    let path = dir.join("case.gpkg");
    let mut done = Vec::new();
    let three_d = rng.chance(0.3);
    let boxes = utm_boxes();
    let n = if three_d { boxes.len() } else { houses().len() };
    let (srs_id, table) = if three_d {
        (32618i64, "models")
    } else {
        (4326, "buildings")
    };
    // Which rows get mutated geometry: one to three.
    let mutated: Vec<usize> = (0..1 + rng.next_u64() % 3)
        .map(|_| (rng.next_u64() % n as u64) as usize)
        .collect();
    let mut rows = Vec::new();
    for k in 0..n {
        let mut said = Vec::new();
        let shape = mutated.contains(&k).then_some(&mut said);
        let (mut o, what) = if three_d {
            let h = &houses()[0];
            random_wkb(rng, &h.polygons, Some(&boxes[k]), shape)
        } else {
            random_wkb(rng, &houses()[k].polygons, None, shape)
        };
        // The WKB's bytes changed too, or only its shape.
        if mutated.contains(&k) && (said.is_empty() || rng.chance(0.5)) {
            said.extend(mutate_wkb(&mut o, rng));
        }
        let (mut blob, head) = if mutated.contains(&k) {
            gpkg_header(rng, srs_id as i32, true)
        } else {
            // A plain header: little-endian, no envelope, the layer's srs_id.
            let mut b = vec![b'G', b'P', 0, 1];
            b.extend((srs_id as i32).to_le_bytes());
            (b, None)
        };
        if let Some(h) = head {
            said.push(h);
        }
        blob.extend_from_slice(&o.b);
        if mutated.contains(&k) && rng.chance(0.05) {
            blob.truncate((rng.next_u64() % 12) as usize);
            said.push(format!("blob cut to {} bytes", blob.len()));
        }
        if !said.is_empty() {
            done.push(format!("row {k} ({what}): {}", said.join(", ")));
        }
        let hs = houses();
        let h = &hs[k % hs.len()];
        rows.push(Row {
            fid: k as i64 + 1,
            geometry: Some(blob),
            values: vec![
                Sql::Text(h.id.clone()),
                h.height.map_or(Sql::Null, Sql::Real),
                h.levels.map_or(Sql::Null, Sql::Integer),
                h.roof.clone().map_or(Sql::Null, Sql::Text),
            ],
        });
    }
    let geometry_type = if three_d {
        "POLYHEDRALSURFACE"
    } else {
        *rng.pick(&["MULTIPOLYGON", "POLYGON", "GEOMETRY"])
    };
    let layer = Layer {
        table: table.into(),
        geometry_column: "geom".into(),
        geometry_type: geometry_type.into(),
        srs_id,
        columns: vec![
            ("name".into(), "TEXT".into()),
            ("height".into(), "REAL".into()),
            ("building:levels".into(), "INTEGER".into()),
            ("roof:shape".into(), "TEXT".into()),
        ],
        rows,
    };
    let mut srs = vec![Srs::epsg(2263)];
    if three_d {
        srs.push(Srs {
            srs_id: 32618,
            organization: "EPSG".into(),
            organization_coordsys_id: 32618,
            definition: WKTS[12].into(),
        });
    }
    let mut layers = vec![layer];
    if rng.chance(0.1) {
        // A second feature table, so that --layer matters.
        let mut second = layers[0].clone();
        second.table = "second".into();
        second.rows.truncate(2);
        layers.push(second);
    }
    write(&path, &srs, &layers);
    // The gpkg_* tables changed.
    let mut layer_opt = (layers.len() > 1).then(|| table.to_string());
    let mut rows = Some(n);
    if rng.chance(0.35) {
        rows = None;
        let db = rusqlite::Connection::open(&path).unwrap();
        let wkt = rng.pick(WKTS).replace('\'', "''");
        let sqls: Vec<String> = vec![
            format!("UPDATE gpkg_contents SET table_name = 'gone' WHERE table_name = '{table}'"),
            "UPDATE gpkg_geometry_columns SET column_name = 'nope'".into(),
            "UPDATE gpkg_geometry_columns SET srs_id = 99999".into(),
            "UPDATE gpkg_contents SET srs_id = 99999".into(),
            format!("UPDATE gpkg_spatial_ref_sys SET definition = '{wkt}' WHERE srs_id = {srs_id}"),
            format!("UPDATE gpkg_spatial_ref_sys SET organization = 'NONE', organization_coordsys_id = -5, definition = '{wkt}' WHERE srs_id = {srs_id}"),
            format!("UPDATE gpkg_spatial_ref_sys SET organization = 'epsg', organization_coordsys_id = 2263 WHERE srs_id = {srs_id}"),
            format!("DELETE FROM gpkg_spatial_ref_sys WHERE srs_id = {srs_id}"),
            "DELETE FROM gpkg_geometry_columns".into(),
            "UPDATE gpkg_contents SET data_type = 'tiles'".into(),
            "UPDATE gpkg_contents SET data_type = 'attributes'".into(),
            format!("UPDATE gpkg_geometry_columns SET geometry_type_name = '{}'", rng.pick(&["CURVEPOLYGON", "POINT", "GEOMETRYCOLLECTION", "garbage", "", "TIN", "MULTISURFACE"])),
            "UPDATE gpkg_geometry_columns SET z = 2, m = 2".into(),
            format!("ALTER TABLE \"{table}\" RENAME COLUMN geom TO g2"),
            format!("DROP TABLE \"{table}\""),
            "DROP TABLE gpkg_geometry_columns".into(),
            "DROP TABLE gpkg_spatial_ref_sys".into(),
            "DROP TABLE gpkg_contents".into(),
            format!("UPDATE \"{table}\" SET geom = x'00' WHERE fid = 1"),
            format!("UPDATE \"{table}\" SET geom = 'text' WHERE fid = 2"),
            format!("UPDATE \"{table}\" SET geom = 12.5 WHERE fid = 3"),
            format!("UPDATE \"{table}\" SET name = x'FFFE00', height = 'tall' WHERE fid = 1"),
            format!("UPDATE \"{table}\" SET height = 1e308, \"building:levels\" = -5 WHERE fid = 2"),
            format!("UPDATE \"{table}\" SET height = -3, \"building:levels\" = 9223372036854775807 WHERE fid = 1"),
            "INSERT INTO gpkg_contents (table_name, data_type, identifier, srs_id) VALUES ('ghost', 'features', 'ghost', 4326)".into(),
            "INSERT INTO gpkg_geometry_columns VALUES ('ghost', 'geom', 'POLYGON', 4326, 0, 0)".into(),
            format!("INSERT INTO gpkg_geometry_columns VALUES ('{table}', 'name', 'POLYGON', 4326, 0, 0)"),
            "PRAGMA application_id = 0".into(),
            format!("UPDATE \"{table}\" SET fid = fid + 1000000000000 WHERE fid = 2"),
        ];
        for _ in 0..1 + rng.next_u64() % 2 {
            let sql = rng.pick(&sqls).clone();
            let r = db.execute_batch(&sql);
            done.push(format!(
                "SQL {sql}{}",
                if r.is_err() { " (failed)" } else { "" }
            ));
        }
    }
    if rng.chance(0.05) {
        rows = None;
        layer_opt = Some(
            rng.pick(&["buildings", "models", "ghost", "gpkg_contents", "nope"])
                .to_string(),
        );
        done.push(format!("--layer {}", layer_opt.as_ref().unwrap()));
    }
    let _ = seed;
    Case {
        path,
        done,
        crs: None,
        layer: layer_opt,
        rows,
    }
}

// =================================================================================================================
// Shapefile

fn make_shp(dir: &Path, _seed: u64, rng: &mut SplitMix64) -> Case {
    use citylod_testdata::shapefile::{
        dbf_bytes, num, shp_bytes, shx_bytes, text, Field, Shape, Table,
    };
    let mut done = Vec::new();
    let kind = rng.next_u64() % 6;
    // .shp, .shx, .dbf, .prj, .cpg
    type Files = (
        Vec<u8>,
        Option<Vec<u8>>,
        Option<Vec<u8>>,
        Option<String>,
        Option<String>,
    );
    let (mut shp, mut shx, mut dbf, mut prj, mut cpg): Files;
    if kind == 5 {
        let m = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/multipatch");
        let r = |e: &str| std::fs::read(m.join(format!("delft_multipatch.{e}"))).unwrap();
        shp = r("shp");
        shx = Some(r("shx"));
        dbf = Some(r("dbf"));
        prj = Some(String::from_utf8(r("prj")).unwrap());
        cpg = Some(String::from_utf8(r("cpg")).unwrap());
        done.push("delft MultiPatch".into());
    } else {
        // One record's shape changed (its faces, or its rings), well-formed still.
        let changed = (rng.next_u64() % 24) as usize;
        let change = rng.chance(0.5);
        let shapes: Vec<Shape> = if kind == 4 {
            // MultiPatch boxes: walls as a triangle strip, bottom and top as outer rings (or a fan, or triangles);
            // or every face its own outer ring.
            utm_boxes()
                .iter()
                .enumerate()
                .map(|(k, (ring, h))| {
                    let strip: Vec<[f64; 3]> = ring
                        .iter()
                        .flat_map(|p| [*p, [p[0], p[1], p[2] + h]])
                        .collect();
                    let mut faces = box_faces(ring, *h);
                    if change && k == changed % 6 {
                        let said = mutate_faces(&mut faces, rng);
                        done.push(format!("record {k}: {said}"));
                        return Shape::MultiPatch(
                            faces
                                .into_iter()
                                .map(|f| (*rng.pick(&[2, 2, 4, 5, 3, 1, 6]), f))
                                .collect(),
                        );
                    }
                    let top_kind = *rng.pick(&[2, 4, 5, 1]);
                    Shape::MultiPatch(vec![
                        (0, strip),
                        (2, faces[0].clone()),
                        (top_kind, faces[1].clone()),
                    ])
                })
                .collect()
        } else {
            houses()
                .iter()
                .enumerate()
                .map(|(k, h)| {
                    let mut polygons = h.polygons.clone();
                    if change && k == changed {
                        let said = mutate_rings(&mut polygons, rng);
                        done.push(format!("record {k}: {said}"));
                    }
                    let rings: Vec<Vec<[f64; 2]>> = polygons
                        .iter()
                        .flat_map(|p| {
                            p.iter().enumerate().map(|(i, r)| {
                                // Esri: outer rings clockwise, holes counter-clockwise (GeoJSON's are the other way).
                                let mut r = r.clone();
                                if i == 0 {
                                    r.reverse()
                                }
                                r
                            })
                        })
                        .collect();
                    match kind {
                        1 => Shape::PolygonZ(rings.iter().map(|r| lift(r, 3.0)).collect()),
                        2 => Shape::PolygonM(rings),
                        _ => Shape::Polygon(rings),
                    }
                })
                .collect()
        };
        let mut t = Table::new(vec![
            Field::new("NAME", b'C', 24, 0),
            Field::new("HEIGHT", b'N', 10, 2),
            Field::new("LEVELS", b'N', 4, 0),
            Field::new("OK", b'L', 1, 0),
            Field::new("BUILT", b'D', 8, 0),
        ]);
        let hs = houses();
        for (i, _) in shapes.iter().enumerate() {
            let h = &hs[i % hs.len()];
            let name: String = h.id.chars().take(20).collect();
            t.push([
                text(&name),
                h.height.map_or(Vec::new(), |v| num(format!("{v:.2}"))),
                h.levels.map_or(Vec::new(), num),
                b"T".to_vec(),
                b"19991231".to_vec(),
            ]);
        }
        shp = shp_bytes(&shapes);
        shx = Some(shx_bytes(&shapes));
        dbf = Some(dbf_bytes(&t));
        prj = Some(if kind == 4 { PRJ_UTM18 } else { PRJ_WGS84 }.to_string());
        cpg = rng.chance(0.3).then(|| "UTF-8".to_string());
        done.push(
            ["Polygon", "PolygonZ", "PolygonM", "Polygon", "MultiPatch"][kind as usize].to_string(),
        );
    }
    // The records of the .shp: where each content starts and its length.
    let records = |shp: &[u8]| -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        let mut at = 100;
        while at + 8 <= shp.len() {
            let len =
                i32::from_be_bytes(shp[at + 4..at + 8].try_into().unwrap()).max(0) as usize * 2;
            if at + 8 + len > shp.len() {
                break;
            }
            out.push((at + 8, len));
            at += 8 + len;
        }
        out
    };
    // Records not added, removed or reframed: every one must then be read (written or skipped).
    let mut rows = Some(records(&shp).len());
    for _ in 0..1 + rng.next_u64() % 3 {
        let recs = records(&shp);
        let r = (rng.next_u64() % recs.len().max(1) as u64) as usize;
        let pick_i32 = |rng: &mut SplitMix64, old: i32| {
            *rng.pick(&[
                0,
                1,
                -1,
                old.wrapping_sub(1),
                old.wrapping_add(1),
                i32::MAX,
                i32::MIN,
                1 << 20,
            ])
        };
        match rng.next_u64() % 14 {
            0 => {
                let v = *rng.pick(&[0i32, 1, 3, 5, 8, 15, 25, 31, 99, -1]);
                shp[32..36].copy_from_slice(&v.to_le_bytes());
                done.push(format!("header shape type := {v}"));
            }
            1 => {
                let v = *rng.pick(&[0i32, 50, -1, i32::MAX, (shp.len() / 2) as i32 + 4]);
                shp[24..28].copy_from_slice(&v.to_be_bytes());
                done.push(format!("header file length := {v} words"));
            }
            2 if !recs.is_empty() => {
                let (c, len) = recs[r];
                let v = pick_i32(rng, (len / 2) as i32);
                shp[c - 4..c].copy_from_slice(&v.to_be_bytes());
                rows = None;
                done.push(format!("record {r}'s content length := {v} words"));
            }
            3 if !recs.is_empty() => {
                let (c, _) = recs[r];
                let v = *rng.pick(&[0i32, 1, 3, 5, 8, 11, 13, 15, 18, 21, 23, 25, 28, 31, 99, -1]);
                shp[c..c + 4].copy_from_slice(&v.to_le_bytes());
                done.push(format!("record {r}'s shape type := {v}"));
            }
            4 | 5 if !recs.is_empty() && recs[r].1 >= 44 => {
                let (c, _) = recs[r];
                let at = c + if rng.chance(0.5) { 36 } else { 40 };
                let old = i32::from_le_bytes(shp[at..at + 4].try_into().unwrap());
                let v = pick_i32(rng, old);
                shp[at..at + 4].copy_from_slice(&v.to_le_bytes());
                done.push(format!(
                    "record {r}'s {} := {v} (was {old})",
                    if at == c + 36 {
                        "part count"
                    } else {
                        "point count"
                    }
                ));
            }
            6 | 7 if !recs.is_empty() && recs[r].1 >= 44 => {
                let (c, len) = recs[r];
                let parts =
                    i32::from_le_bytes(shp[c + 36..c + 40].try_into().unwrap()).max(0) as usize;
                let points = i32::from_le_bytes(shp[c + 40..c + 44].try_into().unwrap());
                let multipatch = i32::from_le_bytes(shp[c..c + 4].try_into().unwrap()) == 31;
                if parts == 0 || c + 44 + 8 * parts > c + len {
                    continue;
                }
                let k = (rng.next_u64() % parts as u64) as usize;
                if multipatch && rng.chance(0.5) {
                    let at = c + 44 + 4 * parts + 4 * k;
                    let v = *rng.pick(&[-1i32, 0, 1, 2, 3, 4, 5, 6, 7, 99, i32::MAX]);
                    shp[at..at + 4].copy_from_slice(&v.to_le_bytes());
                    done.push(format!("record {r}'s part {k} type := {v}"));
                } else {
                    let at = c + 44 + 4 * k;
                    let v = *rng.pick(&[
                        -1i32,
                        points,
                        points.wrapping_sub(1),
                        points.wrapping_add(1),
                        i32::MAX,
                        0,
                        2,
                    ]);
                    shp[at..at + 4].copy_from_slice(&v.to_le_bytes());
                    done.push(format!("record {r}'s part {k} start := {v}"));
                }
            }
            8 if !recs.is_empty() && recs[r].1 > 52 => {
                let (c, len) = recs[r];
                let at = c + 44 + 8 * ((rng.next_u64() % ((len - 52) as u64 / 8)) as usize);
                let v = *rng.pick(&[f64::NAN, f64::INFINITY, 1e308, -1e308, 0.0, 1e-320]);
                shp[at..at + 8].copy_from_slice(&v.to_le_bytes());
                done.push(format!("record {r}: 8 bytes at {} := {v}", at - c));
            }
            9 => {
                // The .shx: an offset or length, cut, or gone.
                if let Some(x) = shx.as_mut() {
                    let n = (x.len().saturating_sub(100)) / 8;
                    match rng.next_u64() % 4 {
                        0 if n > 0 => {
                            let k = (rng.next_u64() % n as u64) as usize;
                            let at = 100 + 8 * k + if rng.chance(0.5) { 0 } else { 4 };
                            let v = *rng.pick(&[0i32, 1, 50, -1, i32::MAX, (shp.len() / 2) as i32]);
                            x[at..at + 4].copy_from_slice(&v.to_be_bytes());
                            done.push(format!(
                                ".shx entry {k} {} := {v}",
                                if (at - 100).is_multiple_of(8) {
                                    "offset"
                                } else {
                                    "length"
                                }
                            ));
                        }
                        1 => {
                            let keep = 100 + (rng.next_u64() % (x.len() as u64 - 99)) as usize;
                            x.truncate(keep);
                            done.push(format!(".shx cut to {keep}"));
                        }
                        2 => {
                            shx = None;
                            done.push(".shx removed".into());
                        }
                        _ => {
                            let v = *rng.pick(&[0i32, 50, i32::MAX]);
                            x[24..28].copy_from_slice(&v.to_be_bytes());
                            done.push(format!(".shx file length := {v}"));
                        }
                    }
                }
            }
            10 | 11 => {
                // The .dbf: its header, a field descriptor, the terminator, the language driver.
                if let Some(d) = dbf.as_mut() {
                    // Fields by the header's length (an earlier mutation may have changed it), within the file.
                    let nf = ((u16::from_le_bytes([d[8], d[9]]) as usize).saturating_sub(33) / 32)
                        .min(d.len().saturating_sub(33) / 32);
                    match rng.next_u64() % 9 {
                        0 => {
                            let v = *rng.pick(&[0u32, 1, u32::MAX, 1 << 24]);
                            let old = u32::from_le_bytes(d[4..8].try_into().unwrap());
                            let v = if rng.chance(0.4) {
                                old.wrapping_add(1)
                            } else if rng.chance(0.4) {
                                old.saturating_sub(1)
                            } else {
                                v
                            };
                            d[4..8].copy_from_slice(&v.to_le_bytes());
                            done.push(format!(".dbf record count := {v} (was {old})"));
                        }
                        1 => {
                            let old = u16::from_le_bytes([d[8], d[9]]);
                            let v = *rng.pick(&[
                                0u16,
                                32,
                                33,
                                old.wrapping_sub(1),
                                old.wrapping_add(1),
                                u16::MAX,
                            ]);
                            d[8..10].copy_from_slice(&v.to_le_bytes());
                            done.push(format!(".dbf header length := {v}"));
                        }
                        2 => {
                            let old = u16::from_le_bytes([d[10], d[11]]);
                            let v = *rng.pick(&[
                                0u16,
                                1,
                                old.wrapping_sub(1),
                                old.wrapping_add(1),
                                u16::MAX,
                            ]);
                            d[10..12].copy_from_slice(&v.to_le_bytes());
                            done.push(format!(".dbf record length := {v}"));
                        }
                        3 | 4 if nf > 0 => {
                            let k = (rng.next_u64() % nf as u64) as usize;
                            let v = *rng.pick(b"CNFLDMIBO@+0Y T\0");
                            d[32 + 32 * k + 11] = v;
                            done.push(format!(".dbf field {k} type := {:?}", v as char));
                        }
                        5 if nf > 0 => {
                            let k = (rng.next_u64() % nf as u64) as usize;
                            let (at, v) = if rng.chance(0.6) {
                                (16, *rng.pick(&[0u8, 1, 255, 100]))
                            } else {
                                (17, *rng.pick(&[0u8, 15, 255]))
                            };
                            d[32 + 32 * k + at] = v;
                            done.push(format!(
                                ".dbf field {k} {} := {v}",
                                if at == 16 { "length" } else { "decimals" }
                            ));
                        }
                        6 if nf > 0 => {
                            let k = (rng.next_u64() % nf as u64) as usize;
                            let at = 32 + 32 * k;
                            d[at..at + 11].copy_from_slice(&[0xFF; 11]);
                            done.push(format!(".dbf field {k} name := 11 × 0xFF"));
                        }
                        7 => {
                            let at = 32 + 32 * nf;
                            if at < d.len() {
                                d[at] = b' ';
                            }
                            done.push(".dbf header terminator removed".into());
                        }
                        _ => {
                            let v = *rng.pick(&[
                                0u8, 1, 2, 3, 0x57, 0x64, 0x65, 0xC8, 0x4D, 0x7A, 0xFF, 0x26,
                            ]);
                            d[29] = v;
                            d[0] = *rng.pick(&[3u8, 3, 0x83, 0x30, 0x8B, 0xF5, 0]);
                            done.push(format!(
                                ".dbf language driver := {v:#x}, version {:#x}",
                                d[0]
                            ));
                        }
                    }
                } else {
                    done.push("no .dbf".into());
                }
            }
            12 => {
                let v = *rng.pick(&[
                    "",
                    "UTF-8",
                    "utf8",
                    "1252",
                    "ANSI 1251",
                    "88591",
                    "CP437",
                    "950",
                    "65001",
                    "x\u{0}",
                    "ISO-8859-99",
                    "UTF-16",
                ]);
                cpg = Some(v.to_string());
                done.push(format!(".cpg := {v:?}"));
            }
            13 => {
                if rng.chance(0.15) {
                    prj = None;
                    dbf = if rng.chance(0.3) { None } else { dbf };
                    done.push(format!(
                        ".prj removed{}",
                        if dbf.is_none() { ", .dbf removed" } else { "" }
                    ));
                } else {
                    let v = *rng.pick(WKTS);
                    prj = Some(v.to_string());
                    done.push(format!(
                        ".prj := {:?}",
                        v.chars().take(40).collect::<String>()
                    ));
                }
            }
            _ => {
                rows = None;
                if !recs.is_empty() && rng.chance(0.5) {
                    let (c, len) = recs[r];
                    let keep = c + (rng.next_u64() % len.max(1) as u64) as usize;
                    shp.truncate(keep);
                    done.push(format!(".shp cut at {keep} (inside record {r})"));
                } else {
                    // A record duplicated at the end (the .shx not knowing it), or the records' numbers shuffled.
                    if let Some(&(c, len)) = recs.get(r) {
                        let rec = shp[c - 8..c + len].to_vec();
                        shp.extend_from_slice(&rec);
                        done.push(format!("record {r} repeated at the end"));
                    }
                }
            }
        }
    }
    let stem = "case";
    let put = |ext: &str, b: &[u8]| std::fs::write(dir.join(format!("{stem}.{ext}")), b).unwrap();
    put("shp", &shp);
    if let Some(x) = &shx {
        put("shx", x);
    }
    if let Some(d) = &dbf {
        put("dbf", d);
    }
    if let Some(p) = &prj {
        put("prj", p.as_bytes());
    }
    if let Some(c) = &cpg {
        put("cpg", c.as_bytes());
    }
    Case {
        path: dir.join(format!("{stem}.shp")),
        done,
        crs: None,
        layer: None,
        rows,
    }
}

// =================================================================================================================
// GeoParquet

/// One leaf column's values and levels.
enum Leaf {
    Bytes(Vec<Vec<u8>>),
    Double(Vec<f64>),
}

/// A nested value of a GeoArrow column: null, a list, a coordinate.
#[derive(Clone)]
enum Nest {
    Null,
    List(Vec<Nest>),
    Coord(Option<f64>, Option<f64>),
}

/// The levels of leaf `x` (`which` 0) or `y` (1) of a column of `depth` lists of {x, y} structs, each list and
/// element optional (standard 3-level lists).
fn levels(
    v: &Nest,
    depth: usize,
    which: usize,
    vals: &mut Vec<f64>,
    def: &mut Vec<i16>,
    rep: &mut Vec<i16>,
) {
    // A recursive helper carrying the walk's state: its arguments are that state.
    #[allow(clippy::too_many_arguments)]
    fn list(
        items: &[Nest],
        li: usize,
        depth: usize,
        d: i16,
        r: i16,
        which: usize,
        vals: &mut Vec<f64>,
        def: &mut Vec<i16>,
        rep: &mut Vec<i16>,
    ) {
        if items.is_empty() {
            def.push(d);
            rep.push(r);
            return;
        }
        for (j, child) in items.iter().enumerate() {
            let r2 = if j == 0 { r } else { li as i16 };
            let d2 = d + 1;
            match child {
                Nest::Null => {
                    def.push(d2);
                    rep.push(r2);
                }
                Nest::List(c) if li < depth => {
                    list(c, li + 1, depth, d2 + 1, r2, which, vals, def, rep)
                }
                Nest::Coord(x, y) if li == depth => {
                    // The struct present (+1), its field optional (+1).
                    let v = if which == 0 { *x } else { *y };
                    match v {
                        Some(v) => {
                            vals.push(v);
                            def.push(d2 + 2);
                        }
                        None => def.push(d2 + 1),
                    }
                    rep.push(r2);
                }
                _ => {
                    // The wrong kind at this level: null.
                    def.push(d2);
                    rep.push(r2);
                }
            }
        }
    }
    match v {
        Nest::List(items) => list(items, 1, depth, 1, 0, which, vals, def, rep),
        _ => {
            def.push(0);
            rep.push(0);
        }
    }
}

fn geoarrow_schema(depth: usize) -> String {
    let mut inner = "optional group element { optional double x; optional double y; }".to_string();
    for k in (0..depth).rev() {
        let name = if k == 0 { "geometry" } else { "element" };
        inner = format!("optional group {name} (LIST) {{ repeated group list {{ {inner} }} }}");
    }
    inner
}

fn make_parquet(dir: &Path, seed: u64, rng: &mut SplitMix64) -> Case {
    use parquet::data_type::{ByteArray, ByteArrayType, DoubleType};
    use parquet::file::metadata::KeyValue;
    use parquet::file::properties::WriterProperties;
    use parquet::file::writer::SerializedFileWriter;
    use std::sync::Arc;
    let mut done = Vec::new();
    let path = dir.join("case.parquet");
    if rng.chance(0.08) {
        // A fixture with bytes changed in its footer (the metadata) or pages.
        let name = *rng.pick(&[
            "les_overture.parquet",
            "les_overture_parts.parquet",
            "les_utm_native.parquet",
        ]);
        let mut b = std::fs::read(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/geoparquet")
                .join(name),
        )
        .unwrap();
        let len = b.len();
        for _ in 0..1 + rng.next_u64() % 3 {
            let at = if rng.chance(0.6) {
                len - 8 - (rng.next_u64() % 400.min(len as u64 - 8)) as usize
            } else {
                (rng.next_u64() % len as u64) as usize
            };
            let v = *rng.pick(&[0u8, 0xff, 0x7f, 0x80, 0x15, 0x19]);
            b[at] = v;
            done.push(format!("{name}: byte {at} := {v:#x}"));
        }
        std::fs::write(&path, &b).unwrap();
        return Case {
            path,
            done,
            crs: None,
            layer: None,
            rows: None,
        };
    }
    let hs = houses();
    let native = rng.chance(0.35);
    let depth = if native {
        *rng.pick(&[2usize, 2, 3, 3, 1, 4])
    } else {
        0
    };
    let enc_true = match depth {
        0 => "WKB",
        1 => "linestring",
        2 => "polygon",
        3 => "multipolygon",
        _ => "multipolygon",
    };
    let mut geo = json!({"version": "1.1.0", "primary_column": "geometry",
        "columns": {"geometry": {"encoding": enc_true, "geometry_types": ["Polygon", "MultiPolygon"]}}});
    // The rows' geometries.
    let mut wkbs: Vec<Option<Vec<u8>>> = Vec::new();
    let mut nests: Vec<Nest> = Vec::new();
    let mutated: Vec<usize> = (0..1 + rng.next_u64() % 3)
        .map(|_| (rng.next_u64() % hs.len() as u64) as usize)
        .collect();
    for (k, h) in hs.iter().enumerate() {
        if native {
            let coord = |p: &[f64; 2]| Nest::Coord(Some(p[0]), Some(p[1]));
            let ring = |r: &Vec<[f64; 2]>| Nest::List(r.iter().map(coord).collect());
            let poly = |p: &Vec<Vec<[f64; 2]>>| Nest::List(p.iter().map(ring).collect());
            let mut v = match depth {
                1 => ring(&h.polygons[0][0]),
                2 => poly(&h.polygons[0]),
                3 => Nest::List(h.polygons.iter().map(poly).collect()),
                _ => Nest::List(vec![Nest::List(h.polygons.iter().map(poly).collect())]),
            };
            if mutated.contains(&k) {
                let what = rng.next_u64() % 6;
                fn first_list(v: &mut Nest, levels: usize) -> Option<&mut Vec<Nest>> {
                    match v {
                        Nest::List(items) => {
                            if levels == 0 {
                                Some(items)
                            } else {
                                items.first_mut().and_then(|c| first_list(c, levels - 1))
                            }
                        }
                        _ => None,
                    }
                }
                let lvl = (rng.next_u64() % depth as u64) as usize;
                let said = match (what, first_list(&mut v, lvl)) {
                    (0, _) => {
                        v = Nest::Null;
                        "null".to_string()
                    }
                    (1, Some(items)) => {
                        items.clear();
                        format!("level {lvl} emptied")
                    }
                    (2, Some(items)) if !items.is_empty() => {
                        items[0] = Nest::Null;
                        format!("level {lvl}'s first element null")
                    }
                    (3, Some(items)) => {
                        items.truncate(2);
                        format!("level {lvl} cut to 2")
                    }
                    (4, _) => {
                        if let Some(items) = first_list(&mut v, depth - 1) {
                            let c = rng.pick(&[
                                Nest::Coord(None, Some(1.0)),
                                Nest::Coord(Some(f64::NAN), Some(1.0)),
                                Nest::Coord(Some(1e308), Some(-1e308)),
                                Nest::Coord(Some(f64::INFINITY), None),
                            ]);
                            if let Some(x) = items.first_mut() {
                                *x = c.clone();
                            }
                        }
                        "a coordinate made odd".to_string()
                    }
                    _ => {
                        if let Some(items) = first_list(&mut v, depth - 1) {
                            let n = items.len();
                            items
                                .iter_mut()
                                .skip(1)
                                .take(n.saturating_sub(2))
                                .for_each(|c| *c = Nest::Coord(Some(-73.99), Some(40.72)));
                        }
                        "a ring's points made one".to_string()
                    }
                };
                done.push(format!("row {k}: {said}"));
            }
            nests.push(v);
        } else {
            let mut said = Vec::new();
            let shape = mutated.contains(&k).then_some(&mut said);
            let (mut o, what) = random_wkb(rng, &h.polygons, None, shape);
            if mutated.contains(&k) {
                if said.is_empty() || rng.chance(0.5) {
                    said.extend(mutate_wkb(&mut o, rng));
                }
                done.push(format!("row {k} ({what}): {}", said.join(", ")));
            }
            if mutated.contains(&k) && rng.chance(0.1) {
                wkbs.push(None);
                done.push(format!("row {k}: null geometry"));
            } else {
                wkbs.push(Some(o.b));
            }
        }
    }
    // The "geo" metadata.
    let mut geo_text = None;
    let mut no_geo = false;
    let mut rows = Some(hs.len());
    if rng.chance(0.4) {
        rows = None;
        let c = &mut geo["columns"]["geometry"];
        match rng.next_u64() % 12 {
            0 => {
                let v = *rng.pick(&["id", "height", "nope", "", "names"]);
                geo["primary_column"] = json!(v);
                done.push(format!("geo primary_column := {v:?}"));
            }
            1 => {
                let v = rng
                    .pick(&[
                        json!("wkb"),
                        json!("WKT"),
                        json!("point"),
                        json!("polygon"),
                        json!("multipolygon"),
                        json!("linestring"),
                        json!("multilinestring"),
                        json!("geoarrow.polygon"),
                        json!(null),
                        json!(3),
                        json!(""),
                    ])
                    .clone();
                done.push(format!("geo encoding := {v}"));
                c["encoding"] = v;
            }
            2 | 3 => {
                let v = rng.pick(&[
                    json!(null), json!("EPSG:2263"), json!("OGC:CRS84"), json!("nonsense"), json!(""), json!(42),
                    json!({"type": "ProjectedCRS", "name": "x", "id": {"authority": "EPSG", "code": 32618}}),
                    json!({"type": "ProjectedCRS", "name": "no id"}),
                    json!({"type": "GeographicCRS", "id": {"authority": "EPSG", "code": "4326"}}),
                    json!({"type": "CompoundCRS", "components": [{"id": {"authority": "EPSG", "code": 2263}}, {"id": {"authority": "EPSG", "code": 6360}}]}),
                    json!({"type": "BoundCRS", "source_crs": {"id": {"authority": "EPSG", "code": 99999}}}),
                    json!({"id": {"authority": "", "code": ""}}),
                    json!({"id": {"authority": "EPSG", "code": 1e308}}),
                    json!({"id": {"authority": "EPSG", "code": -1}}),
                    json!([]),
                ]).clone();
                done.push(format!("geo crs := {v}"));
                c["crs"] = v;
            }
            4 => {
                let v = rng
                    .pick(&[
                        json!([1e308, -1e308, 0, 0]),
                        json!([]),
                        json!("x"),
                        json!([f64::MAX, 0, 0, 0]),
                    ])
                    .clone();
                done.push(format!("geo bbox := {v}"));
                c["bbox"] = v;
            }
            5 => {
                let v = *rng.pick(&["geometry", "id", "nope", "names"]);
                c["covering"] = json!({"bbox": {"xmin": [v, "xmin"], "ymin": [v, "ymin"]}});
                done.push(format!("geo covering := {v:?}"));
            }
            6 => {
                geo["columns"] = json!({});
                done.push("geo columns := {}".into());
            }
            7 => {
                let v = *rng.pick(&["{", "null", "[]", "", "\"geo\"", "{\"primary_column\": 5}"]);
                geo_text = Some(v.to_string());
                done.push(format!("geo := {v:?}"));
            }
            8 => {
                no_geo = true;
                done.push("no geo metadata".into());
            }
            9 => {
                c["geometry_types"] = json!(["Point", "Polygon Z", 7]);
                geo["version"] = json!("99.0");
                done.push("geo geometry_types and version odd".into());
            }
            10 => {
                c["edges"] = json!("spherical");
                c["orientation"] = json!("clockwise");
                done.push("geo edges spherical, orientation clockwise".into());
            }
            _ => {
                geo["primary_column"] = json!(null);
                done.push("geo primary_column := null".into());
            }
        }
    }
    let geo_text = geo_text.unwrap_or_else(|| geo.to_string());
    let geometry_schema = if native {
        geoarrow_schema(depth)
    } else if rng.chance(0.05) {
        done.push("geometry column UTF8-typed".into());
        "optional binary geometry (UTF8);".to_string()
    } else {
        "optional binary geometry;".to_string()
    };
    let schema_text = format!(
        "message building {{ required binary id (UTF8); {geometry_schema} optional double height; optional group names {{ optional binary primary (UTF8); }} }}"
    );
    let schema = Arc::new(parquet::schema::parser::parse_message_type(&schema_text).unwrap());
    let mut kv = Vec::new();
    if !no_geo {
        kv.push(KeyValue::new("geo".into(), geo_text));
    }
    let props = WriterProperties::builder()
        .set_key_value_metadata(Some(kv))
        .build();
    let file = std::fs::File::create(&path).unwrap();
    let mut w = SerializedFileWriter::new(file, schema, Arc::new(props)).unwrap();
    let per_group = if rng.chance(0.3) { 5 } else { hs.len() };
    let ids: Vec<String> = hs.iter().map(|h| h.id.clone()).collect();
    for start in (0..hs.len()).step_by(per_group) {
        let end = (start + per_group).min(hs.len());
        let mut rg = w.next_row_group().unwrap();
        let mut leaves: Vec<(Leaf, Vec<i16>, Option<Vec<i16>>)> = Vec::new();
        leaves.push((
            Leaf::Bytes(
                ids[start..end]
                    .iter()
                    .map(|s| s.as_bytes().to_vec())
                    .collect(),
            ),
            vec![],
            None,
        ));
        if native {
            for which in 0..2 {
                let (mut vals, mut def, mut rep) = (Vec::new(), Vec::new(), Vec::new());
                for v in &nests[start..end] {
                    levels(v, depth, which, &mut vals, &mut def, &mut rep);
                }
                leaves.push((Leaf::Double(vals), def, Some(rep)));
            }
        } else {
            let g = &wkbs[start..end];
            leaves.push((
                Leaf::Bytes(g.iter().flatten().cloned().collect()),
                g.iter().map(|b| i16::from(b.is_some())).collect(),
                None,
            ));
        }
        let hts: Vec<Option<f64>> = hs[start..end].iter().map(|h| h.height).collect();
        leaves.push((
            Leaf::Double(hts.iter().flatten().copied().collect()),
            hts.iter().map(|h| i16::from(h.is_some())).collect(),
            None,
        ));
        leaves.push((Leaf::Bytes(Vec::new()), vec![1; end - start], None));
        let mut i = 0;
        while let Some(mut col) = rg.next_column().unwrap() {
            let (leaf, def, rep) = &leaves[i];
            let def = (!def.is_empty()).then_some(def.as_slice());
            match leaf {
                Leaf::Bytes(v) => {
                    let v: Vec<ByteArray> = v.iter().map(|b| ByteArray::from(b.clone())).collect();
                    col.typed::<ByteArrayType>()
                        .write_batch(&v, def, rep.as_deref())
                        .unwrap();
                }
                Leaf::Double(v) => {
                    col.typed::<DoubleType>()
                        .write_batch(v, def, rep.as_deref())
                        .unwrap();
                }
            }
            col.close().unwrap();
            i += 1;
        }
        rg.close().unwrap();
    }
    w.close().unwrap();
    done.insert(
        0,
        format!(
            "{} encoding{}",
            if native {
                format!("GeoArrow depth {depth}")
            } else {
                "WKB".into()
            },
            if per_group < hs.len() {
                ", row groups of 5"
            } else {
                ""
            }
        ),
    );
    let _ = seed;
    Case {
        path,
        done,
        crs: None,
        layer: None,
        rows,
    }
}

// =================================================================================================================
// OpenStreetMap PBF, re-encoded as protobuf after changes

#[derive(Clone, Debug)]
enum PVal {
    Varint(u64),
    Fixed64([u8; 8]),
    Fixed32([u8; 4]),
    Bytes(Vec<u8>),
    Msg(Vec<(u32, PVal)>),
    Packed(Vec<u64>),
}

/// Which fields of which message are messages (their type) or packed numbers.
#[derive(Clone, Copy, PartialEq, Debug)]
enum PType {
    HeaderBlock,
    Bbox,
    Block,
    Strings,
    Group,
    Node,
    Dense,
    Way,
    Relation,
    Info,
}

enum PField {
    Msg(PType),
    Packed,
    Other,
}

fn pfield(t: PType, n: u32) -> PField {
    use PField::*;
    use PType as T;
    match (t, n) {
        (T::HeaderBlock, 1) => Msg(T::Bbox),
        (T::Block, 1) => Msg(T::Strings),
        (T::Block, 2) => Msg(T::Group),
        (T::Group, 1) => Msg(T::Node),
        (T::Group, 2) => Msg(T::Dense),
        (T::Group, 3) => Msg(T::Way),
        (T::Group, 4) => Msg(T::Relation),
        (T::Dense, 5) | (T::Node, 4) | (T::Way, 4) | (T::Relation, 4) => Msg(T::Info),
        (T::Dense, 1 | 8 | 9 | 10) => Packed,
        (T::Node, 2 | 3) => Packed,
        (T::Way, 2 | 3 | 8 | 9 | 10) => Packed,
        (T::Relation, 2 | 3 | 8 | 9 | 10) => Packed,
        _ => Other,
    }
}

fn pb_varint(b: &[u8], at: &mut usize) -> Option<u64> {
    let mut v = 0u64;
    for shift in (0..70).step_by(7) {
        let byte = *b.get(*at)?;
        *at += 1;
        v |= u64::from(byte & 0x7f).checked_shl(shift).unwrap_or(0);
        if byte & 0x80 == 0 {
            return Some(v);
        }
    }
    None
}

fn pb_put(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn pb_parse(b: &[u8], t: PType) -> Option<Vec<(u32, PVal)>> {
    let mut at = 0;
    let mut out = Vec::new();
    while at < b.len() {
        let key = pb_varint(b, &mut at)?;
        let (n, wire) = ((key >> 3) as u32, key & 7);
        let v = match wire {
            0 => PVal::Varint(pb_varint(b, &mut at)?),
            1 => {
                let v = b.get(at..at + 8)?.try_into().ok()?;
                at += 8;
                PVal::Fixed64(v)
            }
            5 => {
                let v = b.get(at..at + 4)?.try_into().ok()?;
                at += 4;
                PVal::Fixed32(v)
            }
            2 => {
                let len = pb_varint(b, &mut at)? as usize;
                let body = b.get(at..at.checked_add(len)?)?;
                at += len;
                match pfield(t, n) {
                    PField::Msg(st) => PVal::Msg(pb_parse(body, st)?),
                    PField::Packed => {
                        let mut p = 0;
                        let mut vs = Vec::new();
                        while p < body.len() {
                            vs.push(pb_varint(body, &mut p)?);
                        }
                        PVal::Packed(vs)
                    }
                    PField::Other => PVal::Bytes(body.to_vec()),
                }
            }
            _ => return None,
        };
        out.push((n, v));
    }
    Some(out)
}

fn pb_bytes(m: &[(u32, PVal)]) -> Vec<u8> {
    let mut out = Vec::new();
    for (n, v) in m {
        let n = u64::from(*n) << 3;
        match v {
            PVal::Varint(x) => {
                pb_put(&mut out, n);
                pb_put(&mut out, *x);
            }
            PVal::Fixed64(x) => {
                pb_put(&mut out, n | 1);
                out.extend_from_slice(x);
            }
            PVal::Fixed32(x) => {
                pb_put(&mut out, n | 5);
                out.extend_from_slice(x);
            }
            PVal::Bytes(b) => {
                pb_put(&mut out, n | 2);
                pb_put(&mut out, b.len() as u64);
                out.extend_from_slice(b);
            }
            PVal::Msg(m) => {
                let b = pb_bytes(m);
                pb_put(&mut out, n | 2);
                pb_put(&mut out, b.len() as u64);
                out.extend_from_slice(&b);
            }
            PVal::Packed(vs) => {
                let mut b = Vec::new();
                for &x in vs {
                    pb_put(&mut b, x);
                }
                pb_put(&mut out, n | 2);
                pb_put(&mut out, b.len() as u64);
                out.extend_from_slice(&b);
            }
        }
    }
    out
}

/// Every place in a message tree: the path of field indices to it, and its message type.
fn pb_sites(
    m: &[(u32, PVal)],
    t: PType,
    at: &mut Vec<usize>,
    out: &mut Vec<(Vec<usize>, PType, u32)>,
) {
    for (i, (n, v)) in m.iter().enumerate() {
        at.push(i);
        out.push((at.clone(), t, *n));
        if let (PVal::Msg(sub), PField::Msg(st)) = (v, pfield(t, *n)) {
            pb_sites(sub, st, at, out);
        }
        at.pop();
    }
}

fn pb_at<'a>(m: &'a mut [(u32, PVal)], path: &[usize]) -> &'a mut (u32, PVal) {
    let (first, rest) = path.split_first().unwrap();
    let e = &mut m[*first];
    if rest.is_empty() {
        return e;
    }
    match &mut e.1 {
        PVal::Msg(sub) => pb_at(sub, rest),
        _ => unreachable!(),
    }
}

fn zz(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

fn mutate_block(m: &mut [(u32, PVal)], t: PType, strings: u64, rng: &mut SplitMix64) -> String {
    let mut sites = Vec::new();
    pb_sites(m, t, &mut Vec::new(), &mut sites);
    if sites.is_empty() {
        return "nothing to change".into();
    }
    // Packed arrays and strings most often.
    let packed: Vec<&(Vec<usize>, PType, u32)> = sites
        .iter()
        .filter(|s| matches!(pfield(s.1, s.2), PField::Packed))
        .collect();
    let pick = if !packed.is_empty() && rng.chance(0.6) {
        (*rng.pick(&packed)).clone()
    } else {
        rng.pick(&sites).clone()
    };
    let (path, pt, n) = pick;
    let e = pb_at(m, &path);
    let where_ = format!("{pt:?}.{n}");
    match &mut e.1 {
        PVal::Packed(vs) => {
            let len = vs.len();
            match rng.next_u64() % 8 {
                0 | 1 if len > 0 => {
                    let i = (rng.next_u64() % len as u64) as usize;
                    let v = *rng.pick(&[
                        0,
                        1,
                        strings,
                        strings + 1,
                        u64::MAX,
                        zz(i64::MIN),
                        zz(i64::MAX),
                        zz(-1),
                        1 << 32,
                        zz(1 << 40),
                    ]);
                    vs[i] = v;
                    format!("{where_}[{i}] := {v}")
                }
                2 if len > 0 => {
                    let keep = (rng.next_u64() % len as u64) as usize;
                    vs.truncate(keep);
                    format!("{where_} cut to {keep} of {len}")
                }
                3 if len > 0 => {
                    let i = (rng.next_u64() % len as u64) as usize;
                    let x = vs[i];
                    vs.insert(i, x);
                    format!("{where_}[{i}] repeated")
                }
                4 => {
                    vs.reverse();
                    format!("{where_} reversed")
                }
                5 if len > 0 => {
                    let i = (rng.next_u64() % len as u64) as usize;
                    vs[i] = 0;
                    format!("{where_}[{i}] := 0 (delta 0)")
                }
                6 => {
                    let vs2 = vs.clone();
                    e.1 = PVal::Bytes(vs2.iter().flat_map(|v| v.to_le_bytes()).take(7).collect());
                    format!("{where_} := 7 stray bytes")
                }
                _ => {
                    vs.clear();
                    format!("{where_} emptied")
                }
            }
        }
        PVal::Bytes(b) => {
            // A string of the table (or another bytes field).
            let v: &[u8] = rng.pick::<&[u8]>(&[
                &b"building"[..],
                b"outer",
                b"inner",
                b"multipolygon",
                b"type",
                b"height",
                b"",
                b"\xff\xfe",
                b"building:part",
                b"yes",
                b"-1e400",
                b"roof:shape",
                b"way",
            ]);
            let old = String::from_utf8_lossy(b).into_owned();
            *b = v.to_vec();
            format!("{where_} {old:?} := {:?}", String::from_utf8_lossy(v))
        }
        PVal::Varint(x) => {
            let old = *x;
            let v = *rng.pick(&[
                0,
                1,
                u64::MAX,
                zz(i64::MIN),
                1 << 31,
                1 << 62,
                old.wrapping_add(1),
            ]);
            *x = v;
            format!("{where_} := {v} (was {old})")
        }
        PVal::Msg(sub) => match rng.next_u64() % 3 {
            0 => {
                sub.clear();
                format!("{where_} emptied")
            }
            1 => {
                let x = sub.clone();
                sub.extend(x);
                format!("{where_}'s fields given twice")
            }
            _ => {
                e.1 = PVal::Varint(7);
                format!("{where_} := varint 7 (wrong wire type)")
            }
        },
        PVal::Fixed32(_) | PVal::Fixed64(_) => {
            e.1 = PVal::Varint(0);
            format!("{where_} := varint 0")
        }
    }
}

fn make_pbf(dir: &Path, _seed: u64, rng: &mut SplitMix64) -> Case {
    use citylod_testdata::osm_pbf::{tags, write_pbf, PbfOptions, Relation};
    use std::io::{Read, Write};
    let mut done = Vec::new();
    let roofs = read_json(&repo_root().join("examples/roofs/roofs.geojson"));
    let mut data = citylod_testdata::osm_xml::from_geojson(&roofs, 1, 0.0);
    // A building:part relation and a multipolygon with a missing member, roles odd.
    // Heights and roof shapes on the houses' ways (one way each, in order), for models with an LoD.
    for (w, f) in data
        .ways
        .iter_mut()
        .zip(roofs["features"].as_array().unwrap())
    {
        let p = &f["properties"];
        for k in [
            "height",
            "roof:shape",
            "roof:height",
            "roof:direction",
            "roof:levels",
        ] {
            if let Some(v) = p.get(k).filter(|v| !v.is_null()) {
                let v = v.as_str().map_or_else(|| v.to_string(), str::to_string);
                w.tags.push((k.to_string(), v));
            }
        }
    }
    let ways: Vec<i64> = data.ways.iter().map(|w| w.id).collect();
    data.relations.push(Relation {
        id: 9001,
        members: vec![
            ('w', ways[0], "outer".into()),
            ('w', ways[1], "inner".into()),
            ('w', 424242, "outer".into()),
        ],
        tags: tags(&[
            ("type", "multipolygon"),
            ("building", "yes"),
            ("height", "12"),
        ]),
    });
    data.relations.push(Relation {
        id: 9002,
        members: vec![
            ('w', ways[2], "outline".into()),
            ('w', ways[3], "part".into()),
            ('n', 1, "".into()),
        ],
        tags: tags(&[("type", "building"), ("name", "parts")]),
    });
    // The map itself changed now and then: a node moved onto another or a hair from it, a way's nodes repeated,
    // reversed or one left out, a node's coordinates out of range.
    if rng.chance(0.3) {
        let n = data.nodes.len() as u64;
        let (a, b) = ((rng.next_u64() % n) as usize, (rng.next_u64() % n) as usize);
        let w = (rng.next_u64() % data.ways.len() as u64) as usize;
        match rng.next_u64() % 6 {
            0 => {
                let (lon, lat) = (data.nodes[b].lon, data.nodes[b].lat);
                data.nodes[a].lon = lon;
                data.nodes[a].lat = lat + *rng.pick(&[0.0, 1e-7, -1e-7]);
                done.push(format!(
                    "node {} moved onto node {}",
                    data.nodes[a].id, data.nodes[b].id
                ));
            }
            1 => {
                let r = data.ways[w].refs.clone();
                data.ways[w].refs.extend(r);
                done.push(format!("way {} goes round twice", data.ways[w].id));
            }
            2 => {
                data.ways[w].refs.reverse();
                done.push(format!("way {} reversed", data.ways[w].id));
            }
            3 => {
                let len = data.ways[w].refs.len();
                data.ways[w].refs.remove(len / 2);
                done.push(format!("way {} without its middle node", data.ways[w].id));
            }
            4 => {
                let v: f64 = *rng.pick(&[91.0, -90.0, 180.0, 200.0, 214.748]);
                data.nodes[a].lat = v;
                done.push(format!("node {} at latitude {v}", data.nodes[a].id));
            }
            _ => {
                let first = data.ways[w].refs[0];
                data.ways[w].refs = vec![first; 4];
                done.push(format!("way {} all one node", data.ways[w].id));
            }
        }
    }
    let o = PbfOptions {
        plain_nodes: rng.chance(0.25),
        raw_blobs: rng.chance(0.3),
        locations_on_ways: rng.chance(0.15),
        unpacked: false,
        required_features: Vec::new(),
    };
    done.push(format!(
        "{}{}{}",
        if o.plain_nodes {
            "plain nodes"
        } else {
            "dense nodes"
        },
        if o.raw_blobs { ", raw blobs" } else { ", zlib" },
        if o.locations_on_ways {
            ", locations on ways"
        } else {
            ""
        }
    ));
    let bytes = write_pbf(&data, &o);
    // The blobs: header length, BlobHeader, Blob.
    // Each blob's BlobHeader and Blob, as protobuf fields.
    type Message = Vec<(u32, PVal)>;
    let mut blobs: Vec<(Message, Message)> = Vec::new();
    let mut at = 0;
    while at + 4 <= bytes.len() {
        let hl = u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        let h = pb_parse(&bytes[at + 4..at + 4 + hl], PType::Info).unwrap();
        let size = h
            .iter()
            .find_map(|(n, v)| match (n, v) {
                (3, PVal::Varint(s)) => Some(*s as usize),
                _ => None,
            })
            .unwrap();
        let b = pb_parse(&bytes[at + 4 + hl..at + 4 + hl + size], PType::Info).unwrap();
        blobs.push((h, b));
        at += 4 + hl + size;
    }
    let data_of = |b: &[(u32, PVal)]| -> Vec<u8> {
        for (n, v) in b {
            if let PVal::Bytes(x) = v {
                if *n == 1 {
                    return x.clone();
                }
                if *n == 3 {
                    let mut out = Vec::new();
                    // Data an earlier mutation cut gives what inflates of it.
                    let _ = flate2::read::ZlibDecoder::new(&x[..]).read_to_end(&mut out);
                    return out;
                }
            }
        }
        Vec::new()
    };
    let mut header_len_patch: Option<(usize, u32)> = None;
    for _ in 0..1 + rng.next_u64() % 3 {
        // The OSMHeader now and then, mostly the data blobs.
        let k = if blobs.len() < 2 || rng.chance(0.1) {
            0
        } else {
            1 + (rng.next_u64() % (blobs.len() as u64 - 1)) as usize
        };
        let is_header = k == 0;
        match rng.next_u64() % 10 {
            0 => {
                // The BlobHeader: its type, its datasize.
                let (h, _) = &mut blobs[k];
                if rng.chance(0.5) {
                    let v = *rng.pick(&["OSMHeader", "OSMData", "X", "", "OSMData\u{0}"]);
                    for (n, x) in h.iter_mut() {
                        if *n == 1 {
                            *x = PVal::Bytes(v.as_bytes().to_vec());
                        }
                    }
                    done.push(format!("blob {k}'s type := {v:?}"));
                } else {
                    let v = *rng.pick(&[0u64, 1, 1 << 31, u64::MAX]);
                    for (n, x) in h.iter_mut() {
                        if *n == 3 {
                            *x = PVal::Varint(v);
                        }
                    }
                    done.push(format!(
                        "blob {k}'s datasize := {v} (data written as it is)"
                    ));
                }
            }
            1 => {
                // The Blob: raw_size wrong, zlib data cut, or both forms.
                let (_, b) = &mut blobs[k];
                match rng.next_u64() % 3 {
                    0 => {
                        let v = *rng.pick(&[0u64, 1, 1 << 30, u64::MAX]);
                        b.retain(|(n, _)| *n != 2);
                        b.push((2, PVal::Varint(v)));
                        done.push(format!("blob {k}'s raw_size := {v}"));
                    }
                    1 => {
                        for (n, x) in b.iter_mut() {
                            if let (1 | 3, PVal::Bytes(d)) = (*n, x) {
                                let keep = d.len() / 2;
                                d.truncate(keep);
                            }
                        }
                        done.push(format!("blob {k}'s data cut in half"));
                    }
                    _ => {
                        b.push((1, PVal::Bytes(b"\x0a\x00".to_vec())));
                        done.push(format!("blob {k} has raw data too"));
                    }
                }
            }
            2 => {
                header_len_patch = Some((k, *rng.pick(&[0u32, 1, 70000, u32::MAX])));
                done.push(format!(
                    "blob {k}'s header length := {}",
                    header_len_patch.unwrap().1
                ));
            }
            _ => {
                // The block inside, as protobuf.
                let t = if is_header {
                    PType::HeaderBlock
                } else {
                    PType::Block
                };
                let raw = data_of(&blobs[k].1);
                let Some(mut m) = pb_parse(&raw, t) else {
                    done.push(format!("blob {k} not parsed"));
                    continue;
                };
                let strings = m
                    .iter()
                    .find_map(|(n, v)| match (n, v) {
                        (1, PVal::Msg(s)) => Some(s.len() as u64),
                        _ => None,
                    })
                    .unwrap_or(0);
                let mut said = mutate_block(&mut m, t, strings, rng);
                if !is_header && rng.chance(0.15) {
                    // Granularity, offsets.
                    let (f, v) = *rng.pick(&[
                        (17u32, 0u64),
                        (17, 1),
                        (17, u64::MAX),
                        (19, zz(i64::MAX)),
                        (20, zz(i64::MIN)),
                        (18, 0),
                    ]);
                    m.push((f, PVal::Varint(v)));
                    said.push_str(&format!(", block field {f} := {v}"));
                }
                if is_header && rng.chance(0.3) {
                    let v = *rng.pick(&[
                        "HistoricalInformation",
                        "Sort.Type_then_ID",
                        "Nonsense",
                        "DenseNodes",
                    ]);
                    m.push((4, PVal::Bytes(v.as_bytes().to_vec())));
                    said.push_str(&format!(", required feature {v:?}"));
                }
                let nb = pb_bytes(&m);
                let (_, b) = &mut blobs[k];
                let raw_blob = b.iter().any(|(n, _)| *n == 1);
                b.clear();
                if raw_blob {
                    b.push((1, PVal::Bytes(nb)));
                } else {
                    let mut z =
                        flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
                    z.write_all(&nb).unwrap();
                    b.push((2, PVal::Varint(nb.len() as u64)));
                    b.push((3, PVal::Bytes(z.finish().unwrap())));
                }
                done.push(format!("blob {k}: {said}"));
            }
        }
    }
    let mut out = Vec::new();
    for (k, (h, b)) in blobs.iter_mut().enumerate() {
        let bb = pb_bytes(b);
        // The datasize follows the blob unless a mutation set it.
        let said_size = done
            .iter()
            .any(|d| d.starts_with(&format!("blob {k}'s datasize")));
        if !said_size {
            for (n, x) in h.iter_mut() {
                if *n == 3 {
                    *x = PVal::Varint(bb.len() as u64);
                }
            }
        }
        let hb = pb_bytes(h);
        let hl = match header_len_patch {
            Some((pk, v)) if pk == k => v,
            _ => hb.len() as u32,
        };
        out.extend(hl.to_be_bytes());
        out.extend(hb);
        out.extend(bb);
    }
    if rng.chance(0.05) {
        let keep = (rng.next_u64() % out.len() as u64) as usize;
        out.truncate(keep);
        done.push(format!("file cut at {keep}"));
    }
    let path = dir.join("case.osm.pbf");
    std::fs::write(&path, &out).unwrap();
    Case {
        path,
        done,
        crs: None,
        layer: None,
        rows: None,
    }
}

// =================================================================================================================
// The tests

#[test]
fn mutated_file_geodatabases_give_an_error_or_buildings_never_a_panic() {
    run("fgdb", 100, make_fgdb_any);
}

#[test]
fn mutated_geopackages_give_an_error_or_buildings_never_a_panic() {
    run("gpkg", 150, make_gpkg);
}

#[test]
fn mutated_shapefiles_give_an_error_or_buildings_never_a_panic() {
    run("shp", 150, make_shp);
}

#[test]
fn mutated_geoparquet_gives_an_error_or_buildings_never_a_panic() {
    run("parquet", 150, make_parquet);
}

#[test]
fn mutated_osm_pbf_gives_an_error_or_buildings_never_a_panic() {
    run("pbf", 200, make_pbf);
}

/// The unmutated inputs each reader's cases start from are read whole: buildings, and models where they have any.
#[test]
fn the_inputs_the_mutations_start_from_are_read() {
    for &(name, layer, crs) in GDBS {
        let opts = IngestOptions {
            layer: layer.map(str::to_string),
            crs: crs.map(str::to_string),
            lod: Some(LodChoice::Highest),
            ..Default::default()
        };
        let out =
            ingest(&[gdb_fixture(name)], &opts).unwrap_or_else(|e| panic!("{name} {layer:?}: {e}"));
        check(&out).unwrap();
        assert!(out.report.buildings_written > 0, "{name} {layer:?}");
        // The table parser of this test reads every fixture's tables.
        let dir = gdb_fixture(name);
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|e| e == "gdbtable") {
                let t = std::fs::read(&p).unwrap();
                let x = std::fs::read(p.with_extension("gdbtablx")).unwrap();
                let parsed = parse_table(&t, &x).unwrap_or_else(|| panic!("{}", p.display()));
                // Rebuilt unchanged, the table reads the same.
                let _ = table_bytes(&parsed);
            }
        }
    }
    // A geometry blob taken apart and put back is the same bytes.
    let dir = gdb_fixture("kinds.gdb");
    let t = std::fs::read(dir.join("a00000009.gdbtable")).unwrap();
    let x = std::fs::read(dir.join("a00000009.gdbtablx")).unwrap();
    let t = parse_table(&t, &x).unwrap();
    let gi = t.fields.iter().position(|f| f.geom.is_some()).unwrap();
    let mut seen = 0;
    for r in &t.rows {
        for (i, start, end) in row_cells(&t, &r.bytes) {
            if i == gi {
                let mut c = start;
                let n = get_varuint(&r.bytes, &mut c).unwrap() as usize;
                assert_eq!(c + n, end);
                let g = parse_geom(&r.bytes[c..end]).unwrap();
                assert_eq!(geom_bytes(&g), &r.bytes[c..end]);
                seen += 1;
            }
        }
    }
    assert!(seen > 0);
}

// =================================================================================================================
// Findings, each as the behaviour it should have

/// A GeoPackage of the houses' footprints (`buildings`, MULTIPOLYGON, EPSG:4326), then `sql` run on it.
fn houses_gpkg(path: &Path, sql: &str) {
    use citylod_testdata::geopackage::{blob, write, Envelope, Layer, Row, Wkb};
    use rusqlite::types::Value as Sql;
    let rows = houses()
        .iter()
        .enumerate()
        .map(|(k, h)| Row {
            fid: k as i64 + 1,
            geometry: Some(blob(
                4326,
                Envelope::None,
                false,
                &Wkb::default().multipolygon(&h.polygons),
            )),
            values: vec![Sql::Text(h.id.clone())],
        })
        .collect();
    let layer = Layer {
        table: "buildings".into(),
        geometry_column: "geom".into(),
        geometry_type: "MULTIPOLYGON".into(),
        srs_id: 4326,
        columns: vec![("name".into(), "TEXT".into())],
        rows,
    };
    write(path, &[], &[layer]);
    rusqlite::Connection::open(path)
        .unwrap()
        .execute_batch(sql)
        .unwrap();
}

/// Found by the mutations (`gpkg` cases with `DELETE FROM gpkg_geometry_columns`, or `gpkg_contents` naming a table
/// `gpkg_geometry_columns` does not): the error said "gpkg_contents lists none with data_type 'features'" of a
/// GeoPackage whose gpkg_contents lists one, sending the reader to the wrong table. It should say that the feature
/// table has no row in gpkg_geometry_columns.
#[test]
fn a_feature_table_missing_from_gpkg_geometry_columns_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    for (name, sql) in [
        (
            "no-geometry-columns.gpkg",
            "DELETE FROM gpkg_geometry_columns",
        ),
        (
            "renamed-contents.gpkg",
            "UPDATE gpkg_contents SET table_name = 'gone' WHERE table_name = 'buildings'",
        ),
    ] {
        let path = dir.path().join(name);
        houses_gpkg(&path, sql);
        let e = ingest(&[path], &IngestOptions::default())
            .err()
            .map(|e| error_chain(&e));
        let text = e.unwrap_or_else(|| panic!("{name}: read"));
        assert!(
            !text.contains("lists none with data_type 'features'")
                && text.contains("gpkg_geometry_columns"),
            "{name}: {text}"
        );
    }
}

/// Found by the mutations (`gpkg` cases inserting a second gpkg_geometry_columns row for the feature table): the
/// error listed the one table twice, "feature tables: buildings (MULTIPOLYGON), buildings (POLYGON)", and asked for
/// --layer, which cannot tell two columns of one table apart. The GeoPackage standard gives a feature table one
/// geometry column: the error should say the table has two, naming the columns.
#[test]
fn a_feature_table_with_two_geometry_columns_is_not_listed_as_two_tables() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two-columns.gpkg");
    houses_gpkg(
        &path,
        "INSERT INTO gpkg_geometry_columns VALUES ('buildings', 'name', 'POLYGON', 4326, 0, 0)",
    );
    let got = ingest(std::slice::from_ref(&path), &IngestOptions::default());
    let text = got.as_ref().err().map(error_chain).unwrap_or_default();
    let with = IngestOptions {
        layer: Some("buildings".into()),
        ..Default::default()
    };
    let mut problems = Vec::new();
    if text.contains("buildings (MULTIPOLYGON), buildings (POLYGON)")
        || text.contains("name the one to read with --layer")
    {
        problems.push(format!("no --layer: {text}"));
    }
    // Asked for by name, the table is read by one of its two columns, chosen by their order: here `fid` (before
    // `geom`), whose integers are no geometry. Every building is then skipped as malformed, where an error should
    // name the two columns.
    let path = dir.path().join("fid-column.gpkg");
    houses_gpkg(
        &path,
        "INSERT INTO gpkg_geometry_columns VALUES ('buildings', 'fid', 'POLYGON', 4326, 0, 0)",
    );
    match ingest(&[path], &with) {
        Ok(out) => problems.push(format!(
            "--layer buildings of a table with geometry columns fid and geom: {}",
            outcome_line(&Outcome::Read(Box::new(out)))
        )),
        Err(e) if !error_chain(&e).contains("fid") => problems.push(error_chain(&e)),
        Err(_) => {}
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// A copy of fixture geodatabase `name` in `dir`, its feature class's row index changed by `patch`.
fn gdb_copy_with_index(
    dir: &Path,
    name: &str,
    stem: &str,
    patch: impl Fn(&mut Vec<u8>),
) -> PathBuf {
    let to = dir.join(name);
    std::fs::create_dir_all(&to).unwrap();
    for e in std::fs::read_dir(gdb_fixture(name)).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, to.join(p.file_name().unwrap())).unwrap();
    }
    let x = to.join(format!("{stem}.gdbtablx"));
    let mut b = std::fs::read(&x).unwrap();
    patch(&mut b);
    std::fs::write(&x, b).unwrap();
    to
}

/// Found by the mutations (`fgdb` seed 27: `nyc-les-2263.gdb`, its row index's row count := 0): a row index whose
/// header counts fewer rows than it holds offsets for (and than the table's header says are live) was read as far
/// as its count, and the rest of the feature class dropped without a word: 0 or 1 of the 1,416 buildings read, the
/// ingest "successful", nothing skipped, no error. Every row the index points at should be read, or the file
/// refused saying its row index and its table disagree.
#[test]
fn a_row_index_counting_too_few_rows_does_not_drop_the_rest_silently() {
    let dir = tempfile::tempdir().unwrap();
    let all = gdb_rows("nyc-les-2263.gdb", None, None);
    let mut problems = Vec::new();
    for count in [0u32, 1, 700] {
        let sub = dir.path().join(format!("count-{count}"));
        let gdb = gdb_copy_with_index(&sub, "nyc-les-2263.gdb", "a00000009", |x| {
            x[8..12].copy_from_slice(&count.to_le_bytes())
        });
        match ingest(&[gdb], &IngestOptions::default()) {
            Ok(out) if out.report.features_read != all => problems.push(format!(
                "the feature class's row index counting {count} rows: {} of {all} rows read, nothing said: {} \
                 (notes: {:?})",
                out.report.features_read,
                outcome_line(&Outcome::Read(Box::new(out.clone()))),
                out.report.files[0].notes
            )),
            Err(e) if !error_chain(&e).contains("nyc-les-2263.gdb") => problems.push(error_chain(&e)),
            _ => {}
        }
    }
    // The catalog's row index counting one row: its tables after the first are not seen, and the error says the
    // geodatabase has no feature classes ("a File Geodatabase without feature classes"; with a layer named, "feature
    // classes: none"), sending the reader to look for missing tables rather than at a damaged catalog.
    let sub = dir.path().join("catalog");
    let gdb = gdb_copy_with_index(&sub, "nyc-les-2263.gdb", "a00000001", |x| {
        x[8..12].copy_from_slice(&1u32.to_le_bytes())
    });
    for layer in [None, Some("buildings")] {
        let opts = IngestOptions {
            layer: layer.map(str::to_string),
            ..Default::default()
        };
        match ingest(std::slice::from_ref(&gdb), &opts) {
            Ok(out) if out.report.features_read != all => problems.push(format!(
                "the catalog's row index counting 1 row: {} of {all} rows read",
                out.report.features_read
            )),
            Err(e) => {
                let text = error_chain(&e);
                if text.contains("without feature classes")
                    || text.contains("feature classes: none")
                {
                    problems.push(format!(
                        "the catalog's row index counting 1 row, layer {layer:?}: {text}"
                    ));
                }
            }
            _ => {}
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Found by the mutations (`pbf` seed 39: the relations' blob's type changed to "X"): a blob of a type the reader does
/// not know is skipped, as the PBF format allows — and with it, here, the multipolygon building it held, without a
/// word in the report. Skipping is right; the file's notes should say a blob was skipped, and of which type.
#[test]
fn a_pbf_blob_of_an_unknown_type_is_skipped_with_a_note() {
    use citylod_testdata::osm_pbf::{tags, write_pbf, PbfOptions, Relation};
    let roofs = read_json(&repo_root().join("examples/roofs/roofs.geojson"));
    let mut data = citylod_testdata::osm_xml::from_geojson(&roofs, 1, 0.0);
    let ways: Vec<i64> = data.ways.iter().map(|w| w.id).collect();
    data.relations.push(Relation {
        id: 9001,
        members: vec![
            ('w', ways[0], "outer".into()),
            ('w', ways[1], "inner".into()),
        ],
        tags: tags(&[("type", "multipolygon"), ("building", "yes")]),
    });
    let mut bytes = write_pbf(&data, &PbfOptions::default());
    // The last blob (the relations'): its header's type "OSMData" made "OSMDatX".
    let at = bytes.windows(7).rposition(|w| w == b"OSMData").unwrap();
    bytes[at + 6] = b'X';
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("unknown-blob.osm.pbf");
    std::fs::write(&path, &bytes).unwrap();
    let out = ingest(&[path], &IngestOptions::default()).unwrap();
    let f = &out.report.files[0];
    assert!(
        f.notes.iter().any(|n| n.contains("OSMDatX")),
        "{} ({} features read; notes: {:?})",
        outcome_line(&Outcome::Read(Box::new(out.clone()))),
        f.features_read,
        f.notes
    );
}

/// Found by the mutations (`shp` seed 36 and others: one record's content length made -1 or huge, the file whole):
/// the error said "the .shp is cut short: record 3 starts 2992 bytes before the end of the file and does not fit in
/// them (its header gives the file 4588 bytes, it has 4588)" — a file of exactly its declared length called cut
/// short. What is wrong is record 3's content length (a negative number of words); the error should say that.
#[test]
fn a_record_length_out_of_its_file_is_not_called_a_cut_file() {
    use citylod_testdata::shapefile::{num, write, Field, Shape, Table};
    let dir = tempfile::tempdir().unwrap();
    let shapes: Vec<Shape> = houses()
        .iter()
        .take(4)
        .map(|h| {
            let mut r = h.polygons[0][0].clone();
            r.reverse();
            Shape::Polygon(vec![r])
        })
        .collect();
    let mut t = Table::new(vec![Field::new("H", b'N', 4, 0)]);
    for _ in &shapes {
        t.push([num(9)]);
    }
    let shp = write(dir.path(), "houses", &shapes, &t, Some(PRJ_WGS84), None);
    let mut b = std::fs::read(&shp).unwrap();
    // The third record's header: its number, then its content length in 16-bit words (big-endian).
    let mut at = 100;
    for _ in 0..2 {
        let words = i32::from_be_bytes(b[at + 4..at + 8].try_into().unwrap());
        at += 8 + 2 * words as usize;
    }
    let mut problems = Vec::new();
    for words in [-1i32, i32::MAX, 1 << 20] {
        b[at + 4..at + 8].copy_from_slice(&words.to_be_bytes());
        std::fs::write(&shp, &b).unwrap();
        let text = match ingest(std::slice::from_ref(&shp), &IngestOptions::default()) {
            Ok(out) => {
                problems.push(format!(
                    "content length {words}: read: {}",
                    outcome_line(&Outcome::Read(Box::new(out)))
                ));
                continue;
            }
            Err(e) => error_chain(&e),
        };
        if text.contains("cut short") || !text.contains("length") {
            problems.push(format!("content length {words}: {text}"));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Found by a mutation added late (a `.prj` whose VERTCS unit is 1e308 m beside MultiPatch boxes): the heights,
/// multiplied by the unit (`surface_model::stand`), become infinite; the walls and roof are then dropped as "without
/// area or self-intersecting" (model_surface_dropped, 5 of 6) and the ground face alone is written as the building's
/// 3D model — a flat model, which the same reader refuses ("a flat 3D model …: its footprint only") when the heights
/// are scaled to nothing instead (unit 1e-300). Heights out of reach should be said as such, and no flat model
/// written.
#[test]
fn a_vertical_unit_out_of_reach_gives_no_flat_model() {
    use citylod_testdata::shapefile::{num, write, Field, Shape, Table};
    let dir = tempfile::tempdir().unwrap();
    let shapes: Vec<Shape> = utm_boxes()
        .iter()
        .map(|(ring, h)| {
            let faces = box_faces(ring, *h);
            Shape::MultiPatch(faces.into_iter().map(|f| (2, f)).collect())
        })
        .collect();
    let mut t = Table::new(vec![Field::new("H", b'N', 4, 0)]);
    for _ in &shapes {
        t.push([num(9)]);
    }
    let n = WKTS.len();
    let mut problems = Vec::new();
    for (k, prj) in WKTS[n - 3..].iter().enumerate() {
        let unit = ["1e308", "1e-300", "1e7"][k];
        let shp = write(dir.path(), &format!("v{k}"), &shapes, &t, Some(prj), None);
        for lod in [None, Some(LodChoice::Highest)] {
            let opts = IngestOptions {
                lod: lod.clone(),
                ..Default::default()
            };
            let Ok(out) = ingest(std::slice::from_ref(&shp), &opts) else {
                continue;
            };
            if let Err(e) = check(&out) {
                problems.push(format!("vertical unit {unit}, {lod:?}: {e}"));
            }
            for b in &out.buildings {
                let Some(m) = &b.mesh else { continue };
                let (lo, hi) = m
                    .mesh
                    .positions
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                        (l.min(p[2]), h.max(p[2]))
                    });
                if hi - lo < 0.1 {
                    problems.push(format!(
                        "vertical unit {unit}: {} written with a flat model ({} vertices, z {lo}..{hi}); issues: {}",
                        b.source_id,
                        m.mesh.positions.len(),
                        outcome_line(&Outcome::Read(Box::new(out.clone())))
                    ));
                    break;
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
