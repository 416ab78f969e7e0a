//! Leaf tiling for full-detail content: a k-d split of features by centroid (x, then y, alternating;
//! split at the median) until each leaf holds ≤ max features and ≤ max triangles. Inner tiles have
//! no content yet. Deterministic: the same features in the same order give the same tree.

use crate::content::bounds;
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
    let mut keyed: Vec<([f64; 2], ContentFeature)> =
        features.into_iter().map(|f| (centroid(&f), f)).collect();
    split(&mut keyed, 0, max_features.max(1), max_triangles)
}

fn centroid(f: &ContentFeature) -> [f64; 2] {
    match bounds(f.mesh.positions.iter().copied()) {
        Some((lo, hi)) => [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0],
        None => [0.0, 0.0],
    }
}

fn split(
    items: &mut Vec<([f64; 2], ContentFeature)>,
    depth: usize,
    max_features: usize,
    max_triangles: usize,
) -> TileSpec {
    let tris: usize = items.iter().map(|(_, f)| f.mesh.triangles.len()).sum();
    if items.len() <= 1 || (items.len() <= max_features && tris <= max_triangles) {
        return TileSpec {
            features: items.drain(..).map(|(_, f)| f).collect(),
            children: Vec::new(),
            geometric_error_m: 0.0,
        };
    }
    let diagonal = bounds(
        items
            .iter()
            .flat_map(|(_, f)| f.mesh.positions.iter().copied()),
    )
    .map_or(0.0, |(lo, hi)| {
        (0..3).map(|i| (hi[i] - lo[i]).powi(2)).sum::<f64>().sqrt()
    });
    let axis = depth % 2;
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.0[axis].total_cmp(&b.0[axis]));
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
