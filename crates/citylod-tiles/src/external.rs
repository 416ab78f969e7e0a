//! External tilesets (3D Tiles 1.1 §"External tilesets"): when `tileset.json` would exceed a byte
//! limit, subtrees move into their own files. The subtree of tile `p` goes to `tiles/<p>.json`
//! (beside `tiles/<p>.glb`, so every uri inside stays relative and free of `..`); in the parent
//! file `p` becomes a content-less copy (same box and geometric error) whose `content.uri` is that
//! file. External roots carry no `transform`: they inherit the referencing tile's frame (the root
//! ENU frame). Invariant: every file written is at most the limit, or the split fails.

use crate::tileset_json as tj;
use crate::TilesError;

/// Splits `root` (uris relative to the output folder, tile paths as in the writer) so that its
/// file and every external file, wrapped by `wrap` (which adds `asset`, `geometricError` and, for
/// the main file only — its second argument — `extras`), is at most `limit_bytes`. Returns the external
/// files as (path relative to the output folder, bytes), in a deterministic order. Errors when a
/// single tile with stubs for all its children is still too large.
pub(crate) fn split_external(
    root: &mut tj::Tile,
    limit_bytes: usize,
    wrap: &dyn Fn(tj::Tile, bool) -> tj::Tileset,
) -> Result<Vec<(String, Vec<u8>)>, TilesError> {
    let mut files = Vec::new();
    // What a tile's file adds to the tile's own JSON (wrapper, `refine` of an external root).
    let limit_for = |t: &tj::Tile, is_root: bool| {
        let leaf = leaf_copy(t);
        let mut as_root = leaf.clone();
        as_root.refine = Some("REPLACE".into());
        limit_bytes.saturating_sub(json_len(&wrap(as_root, is_root)) - json_len(&leaf))
    };
    compact(root, "0", &limit_for, wrap, &mut files).map_err(|e| match e {
        TilesError::Tile { tile, msg } => TilesError::Tile {
            tile,
            msg: format!(
                "{msg} (limit {limit_bytes} bytes per tileset JSON file: raise --max-tileset-json-bytes)"
            ),
        },
        e => e,
    })?;
    let main = json_len(&wrap(root.clone(), true));
    for (name, len) in std::iter::once(("tileset.json", main))
        .chain(files.iter().map(|(f, b)| (f.as_str(), b.len())))
    {
        if len > limit_bytes {
            return Err(TilesError::Tile {
                tile: name.into(),
                msg: format!("{len} bytes of JSON, over the limit of {limit_bytes}"),
            });
        }
    }
    Ok(files)
}

/// Post-order: compacts the children, then moves the largest children out until this tile's JSON
/// fits its file's budget.
fn compact(
    t: &mut tj::Tile,
    path: &str,
    limit_for: &dyn Fn(&tj::Tile, bool) -> usize,
    wrap: &dyn Fn(tj::Tile, bool) -> tj::Tileset,
    files: &mut Vec<(String, Vec<u8>)>,
) -> Result<(), TilesError> {
    for (k, c) in t.children.iter_mut().enumerate() {
        compact(c, &format!("{path}/{k}"), limit_for, wrap, files)?;
    }
    let budget = limit_for(t, path == "0");
    let mut size = json_len(t);
    let mut sizes: Vec<Option<usize>> = t
        .children
        .iter()
        .map(|c| (!is_stub(c)).then(|| json_len(c)))
        .collect();
    while size > budget {
        // The largest child not yet moved out; ties go to the first, so the split is deterministic.
        let Some((k, child_len)) = sizes
            .iter()
            .enumerate()
            .filter_map(|(k, s)| s.map(|s| (k, s)))
            .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
        else {
            return Err(TilesError::Tile {
                tile: path.into(),
                msg: format!(
                    "its JSON needs {size} bytes even with every child in an external tileset, \
                     over the {budget} bytes a file has for it after its own wrapper"
                ),
            });
        };
        let child_path = format!("{path}/{k}");
        let folder = format!("tiles/{path}/");
        let file = format!("tiles/{child_path}.json");
        let stub = tj::Tile {
            content: Some(tj::Content { uri: file.clone() }),
            ..leaf_copy(&t.children[k])
        };
        let mut sub = std::mem::replace(&mut t.children[k], stub);
        rebase(&mut sub, &folder);
        sub.refine = Some("REPLACE".into());
        let bytes =
            serde_json::to_vec(&wrap(sub, false)).expect("tileset structs always serialize");
        files.push((file, bytes));
        size = size - child_len + json_len(&t.children[k]);
        sizes[k] = None;
    }
    Ok(())
}

/// The tile without content and children: box, geometric error and refinement kept.
fn leaf_copy(t: &tj::Tile) -> tj::Tile {
    tj::Tile {
        transform: t.transform,
        bounding_volume: t.bounding_volume.clone(),
        geometric_error: t.geometric_error,
        refine: t.refine.clone(),
        content: None,
        contents: Vec::new(),
        children: Vec::new(),
        implicit_tiling: None,
        extensions: None,
    }
}

fn is_stub(t: &tj::Tile) -> bool {
    t.content.as_ref().is_some_and(|c| c.uri.ends_with(".json"))
}

/// Makes the uris of a subtree relative to `folder` (every uri in it starts with it).
fn rebase(t: &mut tj::Tile, folder: &str) {
    if let Some(c) = &mut t.content {
        debug_assert!(c.uri.starts_with(folder), "{} not under {folder}", c.uri);
        c.uri = c.uri.strip_prefix(folder).unwrap_or(&c.uri).to_string();
    }
    t.children.iter_mut().for_each(|c| rebase(c, folder));
}

fn json_len<T: serde::Serialize>(v: &T) -> usize {
    serde_json::to_vec(v)
        .expect("tileset structs always serialize")
        .len()
}
