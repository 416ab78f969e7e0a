//! File-level ingest errors: a file that cannot be read or understood at all. Problems with single
//! features are never errors; they are repaired or skipped and listed in the `IngestReport`.

use std::path::PathBuf;

/// Why a whole input could not be ingested. Every variant names the file (or the option) at fault.
#[derive(Debug, thiserror::Error)]
pub enum IngestError {
    /// The file could not be read (missing, unreadable, not UTF-8).
    #[error("{path}: cannot read file")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file (or one line of a CityJSONSeq file, 1-based `line`) is not valid JSON, e.g. truncated.
    #[error("{path}: line {line}: invalid JSON")]
    Json {
        path: PathBuf,
        line: usize,
        #[source]
        source: serde_json::Error,
    },
    /// Valid JSON, but neither GeoJSON nor CityJSON / CityJSONSeq.
    #[error("{path}: unknown input format: {detail}")]
    UnknownFormat { path: PathBuf, detail: String },
    /// A CityJSON document whose structure is broken beyond single objects (e.g. no `vertices`).
    #[error("{path}: invalid CityJSON: {detail}")]
    InvalidCityJson { path: PathBuf, detail: String },
    /// A CRS name that is not understood or not in the offline EPSG table. `origin` is the file
    /// that declared it, or `--crs`.
    #[error("{origin}: unknown CRS {crs:?}: {detail}")]
    UnknownCrs {
        origin: String,
        crs: String,
        detail: String,
    },
    /// A CRS declaration in the file that names no usable CRS (a legacy GeoJSON `crs` link, an unknown
    /// form of `crs` or `metadata.referenceSystem`), and no CRS was given by the user with `option` (`--crs`, or
    /// `--streets-crs` for a street file).
    #[error("{path}: the {member} member is not understood: {detail}; pass the CRS with {option}, e.g. {option} EPSG:2263")]
    CrsNotUnderstood {
        path: PathBuf,
        member: &'static str,
        detail: String,
        option: &'static str,
    },
    /// An ingest option out of its range (e.g. a non-positive default height).
    #[error("option {name}: {detail}")]
    InvalidOption { name: &'static str, detail: String },
    /// A shapefile that cannot be read as one (no `.dbf`, not a shapefile, cut short, `.shp` and `.dbf` of
    /// different lengths).
    #[error("{path}: invalid shapefile: {detail}")]
    InvalidShapefile { path: PathBuf, detail: String },
    /// A shapefile without a `.prj`, and no CRS was given by the user.
    #[error("{path}: no .prj beside it names its CRS; pass one with --crs, e.g. --crs EPSG:26986")]
    MissingPrj { path: PathBuf },
    /// A GeoPackage that cannot be read as one (not SQLite, no GeoPackage tables, several feature tables and no
    /// `--layer`, a layer that is not there). `detail` begins "invalid GeoPackage:" when the file is damaged or no
    /// GeoPackage, not when it only needs `--layer` or names no such layer.
    #[error("{path}: {detail}")]
    InvalidGeoPackage { path: PathBuf, detail: String },
    /// A file named `.pbf`, `.osm` or `.osm.gz` that cannot be read as OpenStreetMap PBF or XML (not one, cut short,
    /// a compression this reader lacks, a history file, XML that is not well-formed).
    #[error("{path}: invalid OpenStreetMap {encoding}: {detail}")]
    InvalidOsm {
        path: PathBuf,
        encoding: &'static str,
        detail: String,
    },
    /// A CityGML file that cannot be read as one (not well-formed XML, a root other than `CityModel`, a DOCTYPE, an
    /// encoding this reader does not know).
    #[error("{path}: invalid CityGML: {detail}")]
    InvalidCityGml { path: PathBuf, detail: String },
    /// A GeoParquet file that cannot be read as one (not Parquet, no geometry column this reader can read, a page
    /// that cannot be decoded).
    #[error("{path}: invalid GeoParquet: {detail}")]
    InvalidGeoParquet { path: PathBuf, detail: String },
    /// A GeoParquet file whose geometry column's CRS is `null` (unknown), or a Parquet file without GeoParquet
    /// metadata, and no CRS was given by the user.
    #[error("{path}: the file does not say its CRS (the GeoParquet metadata gives crs null, or there is none); pass it with --crs, e.g. --crs EPSG:32618")]
    GeoParquetWithoutCrs { path: PathBuf },
    /// A File Geodatabase that cannot be read as one (no catalog, a table cut short or of an unknown layout, several
    /// feature classes and no `--layer`, a layer that is not there).
    #[error("{path}: File Geodatabase: {detail}")]
    InvalidFileGdb { path: PathBuf, detail: String },
    /// A File Geodatabase feature class whose geometry field has no spatial reference, and no CRS was given by the
    /// user.
    #[error("{path}: the feature class has no spatial reference (Unknown); pass its CRS with --crs, e.g. --crs EPSG:2263")]
    FileGdbWithoutCrs { path: PathBuf },
    /// A GeoPackage layer whose spatial reference system is the undefined one (srs_id -1 or 0), and no CRS was given
    /// by the user.
    #[error("{path}: the layer's spatial reference system is undefined (srs_id -1 or 0); pass its CRS with --crs, e.g. --crs EPSG:28992")]
    GeoPackageWithoutCrs { path: PathBuf },
    /// A `--streets` Shapefile without a `.prj` or GeoPackage layer of the undefined CRS, and neither `--streets-crs`
    /// nor `--crs` given.
    #[error("{path}: the street file declares no CRS (no .prj, or an undefined spatial reference system); pass it with --streets-crs, e.g. --streets-crs EPSG:26986")]
    StreetsWithoutCrs { path: PathBuf },
    /// A CityJSON file that declares no `referenceSystem` (a CityGML file no `srsName`), and no CRS was given by the
    /// user.
    #[error("{path}: the file declares no CRS (no {member}); pass one with --crs, e.g. --crs EPSG:28992")]
    MissingCrs { path: PathBuf, member: &'static str },
    /// The written buildings lie too far apart for one local frame (see `place::MAX_DISTANCE_FROM_ORIGIN_M`).
    #[error("{detail}")]
    TooWide { detail: String },
}
