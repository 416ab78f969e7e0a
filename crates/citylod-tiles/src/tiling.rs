//! Leaf tiling for full-detail content: a k-d split of features by centroid (x, then y, alternating;
//! split at the median, equal centroids in input order) until each leaf holds ≤ max features and ≤ max
//! triangles; a leaf keeps its features in input order. Inner tiles have no content yet. Deterministic: the same
//! features in the same order give the same tree.

use crate::content::{bounds, Bounds};
use crate::spec::{ContentFeature, TileSpec};

/// Placeholder geometric error factor for inner tiles without content: error = factor × box
/// diagonal, so a client refines as soon as the tile spans about a pixel (refinement starts when
/// error·k/d > 16 px, i.e. diagonal·k/d > 1 px). The LOD work replaces this with measured errors and
/// content in every level.
const EMPTY_INNER_ERROR_FACTOR: f64 = 16.0;

/// Splits `features` into a tree whose leaves hold at most `max_features` features (≥ 1) and at
/// most `max_triangles` triangles (a single feature larger than that still gets its own leaf).
/// Leaves have geometric error 0; inner tiles have no content and a placeholder error (see
/// [`EMPTY_INNER_ERROR_FACTOR`]) that makes clients refine them. No features → an empty root.
pub fn tile_spatially(
    features: Vec<ContentFeature>,
    max_features: usize,
    max_triangles: usize,
) -> TileSpec {
    tile_spatially_by(
        features,
        |f| {
            (
                bounds(f.mesh.positions.iter().copied()),
                f.mesh.triangles.len(),
            )
        },
        max_features,
        max_triangles,
    )
}

/// [`tile_spatially`] for items that stand for features (e.g. building ids whose meshes are made when the tile is
/// written): `measure(item)` gives the bounds of the item's mesh (`None` without vertices) and its triangle count.
/// Same tree as [`tile_spatially`] on the features themselves.
pub fn tile_spatially_by<T>(
    items: Vec<T>,
    measure: impl Fn(&T) -> (Option<Bounds>, usize),
    max_features: usize,
    max_triangles: usize,
) -> TileSpec<Vec<T>> {
    let mut keyed: Vec<Keyed<T>> = items
        .into_iter()
        .enumerate()
        .map(|(index, item)| {
            let (b, triangles) = measure(&item);
            let centroid = match b {
                Some((lo, hi)) => [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0],
                None => [0.0, 0.0],
            };
            Keyed {
                index,
                centroid,
                bounds: b,
                triangles,
                item,
            }
        })
        .collect();
    split(&mut keyed, 0, max_features.max(1), max_triangles)
}

struct Keyed<T> {
    /// Position in the input: breaks ties between equal centroids and orders a leaf's features.
    index: usize,
    centroid: [f64; 2],
    bounds: Option<Bounds>,
    triangles: usize,
    item: T,
}

fn split<T>(
    items: &mut Vec<Keyed<T>>,
    depth: usize,
    max_features: usize,
    max_triangles: usize,
) -> TileSpec<Vec<T>> {
    let tris: usize = items.iter().map(|k| k.triangles).sum();
    if items.len() <= 1 || (items.len() <= max_features && tris <= max_triangles) {
        items.sort_unstable_by_key(|k| k.index);
        return TileSpec {
            features: items.drain(..).map(|k| k.item).collect(),
            children: Vec::new(),
            geometric_error_m: 0.0,
        };
    }
    let diagonal = bounds(
        items
            .iter()
            .filter_map(|k| k.bounds)
            .flat_map(|(lo, hi)| [lo, hi]),
    )
    .map_or(0.0, |(lo, hi)| {
        (0..3).map(|i| (hi[i] - lo[i]).powi(2)).sum::<f64>().sqrt()
    });
    let axis = depth % 2;
    let mid = items.len() / 2;
    // A total order (ties by input position), so the halves do not depend on how the selection moves items.
    items.select_nth_unstable_by(mid, |a, b| {
        a.centroid[axis]
            .total_cmp(&b.centroid[axis])
            .then(a.index.cmp(&b.index))
    });
    let mut right = items.split_off(mid);
    let left = split(items, depth + 1, max_features, max_triangles);
    let right = split(&mut right, depth + 1, max_features, max_triangles);
    TileSpec {
        features: Vec::new(),
        children: vec![left, right],
        geometric_error_m: diagonal * EMPTY_INNER_ERROR_FACTOR,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use citylod_model::Mesh3d;

    fn cube_at(x: f64, y: f64) -> ContentFeature {
        let mesh = Mesh3d {
            positions: vec![[x, y, 0.0], [x + 1.0, y, 0.0], [x, y + 1.0, 5.0]],
            triangles: vec![[0, 1, 2]],
        };
        ContentFeature {
            mesh,
            class: 0,
            values: vec![],
            max_rounding_m: 0.0,
        }
    }

    fn leaves(t: &TileSpec, out: &mut Vec<usize>) {
        if t.children.is_empty() {
            out.push(t.features.len());
        } else {
            assert!(t.features.is_empty() && t.geometric_error_m > 0.0);
            t.children.iter().for_each(|c| {
                assert!(c.geometric_error_m <= t.geometric_error_m);
                leaves(c, out)
            });
        }
    }

    #[test]
    fn leaves_respect_budgets_and_keep_every_feature() {
        let feats: Vec<_> = (0..1000)
            .map(|i| cube_at((i * 37 % 101) as f64 * 10.0, (i / 10) as f64 * 7.0))
            .collect();
        let tree = tile_spatially(feats.clone(), 30, 1000);
        let mut sizes = Vec::new();
        leaves(&tree, &mut sizes);
        assert!(sizes.iter().all(|&n| (1..=30).contains(&n)), "{sizes:?}");
        assert_eq!(sizes.iter().sum::<usize>(), 1000);
        assert_eq!(
            tree,
            tile_spatially(feats.clone(), 30, 1000),
            "deterministic"
        );
        let by_tris = tile_spatially(feats, 1000, 7);
        let mut sizes = Vec::new();
        leaves(&by_tris, &mut sizes);
        assert!(sizes.iter().all(|&n| n <= 7));
    }

    #[test]
    fn tiling_items_that_stand_for_features_gives_the_same_tree() {
        let feats: Vec<_> = (0..300)
            .map(|i| cube_at((i * 37 % 101) as f64 * 10.0, (i / 10) as f64 * 7.0))
            .collect();
        let by_index = tile_spatially_by(
            (0..feats.len()).collect(),
            |&i| {
                (
                    bounds(feats[i].mesh.positions.iter().copied()),
                    feats[i].mesh.triangles.len(),
                )
            },
            13,
            40,
        );
        let direct = tile_spatially(feats.clone(), 13, 40);
        assert!(direct.count_tiles() > 10);
        let resolved =
            by_index.map(&|ids: Vec<usize>| ids.iter().map(|&i| feats[i].clone()).collect());
        assert_eq!(resolved, direct);
    }

    #[test]
    fn empty_and_oversized_inputs_give_leaves() {
        let t = tile_spatially(Vec::new(), 10, 10);
        assert!(t.features.is_empty() && t.children.is_empty());
        let t = tile_spatially(vec![cube_at(0.0, 0.0)], 0, 0);
        assert_eq!(t.features.len(), 1);
        // Identical centroids still split (median split never leaves a side empty).
        let t = tile_spatially(vec![cube_at(0.0, 0.0); 5], 2, 100);
        let mut sizes = Vec::new();
        leaves(&t, &mut sizes);
        assert!(sizes.iter().all(|&n| n <= 2) && sizes.iter().sum::<usize>() == 5);
    }
}
