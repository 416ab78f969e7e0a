//! Errors of the tileset writer and reader; every variant names the file or tile it is about.

use std::path::PathBuf;

/// What went wrong writing or reading a tileset.
#[derive(Debug, thiserror::Error)]
pub enum TilesError {
    #[error("{path}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: invalid JSON")]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("{path}: invalid content: {msg}")]
    Glb { path: PathBuf, msg: String },
    #[error("schema: {0}")]
    Schema(String),
    #[error("tile {tile}, feature {feature}: {msg}")]
    Feature {
        tile: String,
        feature: usize,
        msg: String,
    },
    #[error("tile {tile}: {msg}")]
    Tile { tile: String, msg: String },
    /// A file that is unusable as a whole (not a regular file, too large, a top-level value out of range).
    #[error("{path}: {msg}")]
    File { path: PathBuf, msg: String },
}

impl TilesError {
    pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> TilesError {
        let path = path.into();
        move |source| TilesError::Io { path, source }
    }
}
