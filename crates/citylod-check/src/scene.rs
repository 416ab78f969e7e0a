//! What the renderer draws: triangles in the tileset root frame (f64 metres), each with a colour and
//! the id of the feature (building or cluster) it belongs to.
//! Invariant: every triangle index is < the number of positions; ids are < `u32::MAX`.

use citylod_model::Mesh3d;

use crate::vec3::Vec3;
use crate::CheckError;

/// Triangles to render, in the root frame. Winding does not matter (no back-face culling).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scene {
    pub(crate) positions_m: Vec<Vec3>,
    pub(crate) triangles: Vec<[u32; 3]>,
    /// Per triangle, parallel to `triangles`.
    pub(crate) colours: Vec<[u8; 4]>,
    /// Per triangle, parallel to `triangles`.
    pub(crate) feature_ids: Vec<u32>,
}

impl Scene {
    pub fn new() -> Scene {
        Scene::default()
    }

    /// Adds a mesh (root frame, m) drawn in `colour` (RGBA8, alpha ignored) and tagged `feature_id`.
    /// Errors, adding nothing, when an index is out of range, a position is not finite, the id is
    /// `u32::MAX` (reserved for "no feature") or the scene would exceed `u32::MAX` positions.
    pub fn add_mesh(
        &mut self,
        mesh: &Mesh3d,
        colour: [u8; 4],
        feature_id: u32,
    ) -> Result<(), CheckError> {
        let bad = |detail: String| CheckError::Mesh { feature_id, detail };
        if feature_id == u32::MAX {
            return Err(bad("feature id u32::MAX is reserved".into()));
        }
        let n = mesh.positions.len();
        if let Some(t) = mesh
            .triangles
            .iter()
            .find(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(bad(format!("triangle {t:?} indexes past {n} positions")));
        }
        if mesh
            .positions
            .iter()
            .any(|p| !p.iter().all(|v| v.is_finite()))
        {
            return Err(bad("a position is not finite".into()));
        }
        let base = u32::try_from(self.positions_m.len())
            .ok()
            .filter(|b| b.checked_add(n as u32).is_some() && n <= u32::MAX as usize)
            .ok_or_else(|| bad("scene exceeds u32::MAX positions".into()))?;
        self.positions_m.extend_from_slice(&mesh.positions);
        self.triangles
            .extend(mesh.triangles.iter().map(|t| t.map(|i| base + i)));
        self.colours
            .extend(std::iter::repeat_n(colour, mesh.triangles.len()));
        self.feature_ids
            .extend(std::iter::repeat_n(feature_id, mesh.triangles.len()));
        Ok(())
    }

    /// Adds a mesh as [`Scene::add_mesh`] does, with one feature id per triangle (`feature_ids`
    /// parallel to `mesh.triangles`). Errors as `add_mesh`, and when the lengths differ.
    pub fn add_mesh_with_ids(
        &mut self,
        mesh: &Mesh3d,
        colour: [u8; 4],
        feature_ids: &[u32],
    ) -> Result<(), CheckError> {
        if feature_ids.len() != mesh.triangles.len() || feature_ids.contains(&u32::MAX) {
            return Err(CheckError::Mesh {
                feature_id: feature_ids.first().copied().unwrap_or(0),
                detail: format!(
                    "{} feature ids for {} triangles, or the reserved id u32::MAX",
                    feature_ids.len(),
                    mesh.triangles.len()
                ),
            });
        }
        self.add_mesh(mesh, colour, 0)?;
        let start = self.feature_ids.len() - feature_ids.len();
        self.feature_ids[start..].copy_from_slice(feature_ids);
        Ok(())
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Axis-aligned bounds (min, max) of all positions (m); `None` for an empty scene.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions_m.first()?;
        Some(self.positions_m.iter().fold((first, first), |(lo, hi), p| {
            (
                std::array::from_fn(|i| lo[i].min(p[i])),
                std::array::from_fn(|i| hi[i].max(p[i])),
            )
        }))
    }
}

/// A closed axis-aligned box mesh from `min_m` to `max_m` (12 triangles, outward-wound), handy for
/// tests and placeholders.
pub fn box_mesh(min_m: Vec3, max_m: Vec3) -> Mesh3d {
    let c = |i: usize| {
        [
            if i & 1 == 0 { min_m[0] } else { max_m[0] },
            if i & 2 == 0 { min_m[1] } else { max_m[1] },
            if i & 4 == 0 { min_m[2] } else { max_m[2] },
        ]
    };
    let quads: [[u32; 4]; 6] = [
        [0, 2, 3, 1], // bottom (z min), seen from below
        [4, 5, 7, 6], // top
        [0, 1, 5, 4], // south (y min)
        [2, 6, 7, 3], // north
        [0, 4, 6, 2], // west (x min)
        [1, 3, 7, 5], // east
    ];
    Mesh3d {
        positions: (0..8).map(c).collect(),
        triangles: quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_mesh_is_outward_wound() {
        let m = box_mesh([0.0; 3], [1.0, 2.0, 3.0]);
        let centre = [0.5, 1.0, 1.5];
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let n = crate::vec3::cross(crate::vec3::sub(b, a), crate::vec3::sub(c, a));
            assert!(
                crate::vec3::dot(n, crate::vec3::sub(a, centre)) > 0.0,
                "{t:?}"
            );
        }
    }

    #[test]
    fn add_mesh_offsets_indices_and_rejects_bad_meshes() {
        let mut s = Scene::new();
        let m = box_mesh([0.0; 3], [1.0; 3]);
        s.add_mesh(&m, [200, 0, 0, 255], 7).unwrap();
        s.add_mesh(&m, [0, 200, 0, 255], 8).unwrap();
        assert_eq!(s.triangle_count(), 24);
        assert!(s.triangles[12..].iter().all(|t| t.iter().all(|&i| i >= 8)));
        let mut bad = m.clone();
        bad.triangles.push([0, 1, 8]);
        assert!(s.add_mesh(&bad, [0; 4], 9).is_err());
        assert!(s.add_mesh(&m, [0; 4], u32::MAX).is_err());
        assert_eq!(s.triangle_count(), 24);
        assert_eq!(s.bounds(), Some(([0.0; 3], [1.0; 3])));
    }
}
