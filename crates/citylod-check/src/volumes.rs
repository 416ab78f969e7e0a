//! Content inside bounding volumes: a client culls a tile, and never visits its descendants, when the tile's
//! bounding volume is outside the view, so everything a tile or any of its descendants draws must lie inside
//! its box (3D Tiles' spatial coherence). A vertex outside is drawn late or not at all: it is missing from the
//! picture whenever the box that should hold it is off screen while the vertex is on it. Root frame, metres.
//! A `sphere` or `region` is checked as written: a sphere by the distance to its centre, a region by each vertex's
//! longitude, latitude and height (its distance outside measured along the surface with the ellipsoid's
//! smallest curvature radius, so never over-stated). A sphere under a transform that is not a similarity is
//! checked as the box enclosing it. Tiles without any volume (hand-made
//! data) got the bounds of their content and children (see [`LoadedTileset`]), so only written volumes can fail.

use crate::camera::apply_point;
use crate::finding::{Finding, FindingKind};
use crate::tileset::{mesh_bounds, LoadedTileset, NodeRef, TileInfo};
use crate::vec3::Vec3;
use citylod_model::ecef_to_geodetic;
use citylod_tiles::read::{ExactVolume, VolumeKind};

/// How far (m) a vertex may lie outside a box before it counts: rounding, not geometry — a millimetre, plus the
/// single-precision step of glTF positions at the vertex's distance from the root frame's origin.
fn slack_m(p: Vec3) -> f64 {
    // The distance from the origin, scaled by the largest coordinate so that it cannot overflow.
    let far = p.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    let norm = if far > 0.0 && far.is_finite() {
        far * p.iter().map(|c| (c / far) * (c / far)).sum::<f64>().sqrt()
    } else {
        far
    };
    1e-3 + 2.0 * f64::from(f32::EPSILON) * norm
}

/// One finding per (tile, box) pair where some vertex the tile draws lies outside the tile's own box or an
/// ancestor's (or sphere, or region): how many of its vertices, the farthest distance, and the feature that vertex
/// belongs to.
pub fn check_volumes(ts: &LoadedTileset) -> Vec<Finding> {
    let n = ts.tiles.len();
    // Parent links, first one seen (a tile linked twice is a bad link reported elsewhere).
    let mut parent = vec![usize::MAX; n];
    for (i, t) in ts.tree.tiles.iter().enumerate() {
        for &c in &t.children {
            if c < n && c != i && parent[c] == usize::MAX {
                parent[c] = i;
            }
        }
    }
    let mut out = Vec::new();
    for (i, info) in ts.tiles.iter().enumerate() {
        let Some(mesh) = &info.mesh else { continue };
        let mut feature_of = None;
        // The bounds of all its vertices: a box (convex) holding their 8 corners holds every vertex, which settles
        // most boxes without looking at each vertex; the others are checked vertex by vertex.
        let Some((lo, hi)) = mesh_bounds(mesh) else {
            continue;
        };
        let corners: Vec<Vec3> = (0..8)
            .map(|c| std::array::from_fn(|k| if c >> k & 1 == 1 { hi[k] } else { lo[k] }))
            .collect();
        // The tile itself, then its ancestors up to the root (a cycle of links ends the walk).
        let mut chain = vec![i];
        while let Some(&p) = parent.get(*chain.last().unwrap()) {
            if p >= n || chain.contains(&p) {
                break;
            }
            chain.push(p);
        }
        // Each vertex as (lon°, lat°, h), once per tile, when some volume on the chain is a region.
        let mut geodetic: Option<Vec<[f64; 3]>> = None;
        for owner in chain {
            let b = &ts.tree.tiles[owner].bounds;
            let exact = ts.tiles[owner].exact_volume.as_ref();
            // The box holds the volume: corners inside the box settle a box; a sphere (convex) is settled by
            // the corners inside it; a region is checked vertex by vertex.
            let settled = match exact {
                None => corners.iter().all(|c| b.distance_to(*c) <= slack_m(*c)),
                Some(e @ ExactVolume::Sphere { .. }) => corners
                    .iter()
                    .all(|c| e.distance_outside(*c, || [0.0; 3]) <= slack_m(*c)),
                Some(ExactVolume::Region { .. }) => false,
            };
            if settled {
                continue;
            }
            if let Some(ExactVolume::Region { root_to_ecef, .. }) = exact {
                geodetic.get_or_insert_with(|| {
                    mesh.positions
                        .iter()
                        .map(|&p| ecef_to_geodetic(apply_point(root_to_ecef, p)))
                        .collect()
                });
            }
            let feature_of = feature_of.get_or_insert_with(|| drawn_vertices(info));
            let mut outside = 0usize;
            let mut worst: Option<(f64, u32)> = None;
            for (k, (p, f)) in mesh.positions.iter().zip(feature_of.iter()).enumerate() {
                let Some(f) = f else { continue };
                let d = match exact {
                    None => b.distance_to(*p),
                    Some(e) => {
                        e.distance_outside(*p, || geodetic.as_ref().map_or([0.0; 3], |g| g[k]))
                    }
                };
                if d > slack_m(*p) {
                    outside += 1;
                    if worst.is_none_or(|(w, _)| d > w) {
                        worst = Some((d, *f));
                    }
                }
            }
            if let Some((d, f)) = worst {
                let drawn = feature_of.iter().filter(|f| f.is_some()).count();
                let volume = match (ts.tiles[owner].volume_kind, exact) {
                    (VolumeKind::Box, _) => "bounding box".to_string(),
                    (k, Some(_)) => format!("bounding {}", k.name()),
                    (k, None) => format!("bounding {} (the box enclosing it)", k.name()),
                };
                let whose = if owner == i {
                    format!("this tile's {volume}")
                } else {
                    format!(
                        "the {volume} of its ancestor {} (a client culling that tile never draws them)",
                        ts.tiles[owner].path_in_tree
                    )
                };
                let mut finding = Finding::at(
                    FindingKind::ContentOutsideVolume,
                    ts,
                    i,
                    format!("{outside} of the {drawn} vertices drawn lie outside {whose}, up to {d:.3} m"),
                )
                .values(d, slack_m([0.0; 3]));
                if let Some(fi) = info.features.get(f as usize) {
                    finding = finding.node(fi.node);
                    if let NodeRef::Building { building_index } = fi.node {
                        finding = finding.buildings(&[building_index]);
                    }
                }
                out.push(finding);
            }
        }
    }
    out
}

/// Per vertex of the tile's mesh: the feature of a triangle using it (`u32::MAX` for none), `None` when no
/// triangle does (such a vertex draws nothing).
fn drawn_vertices(info: &TileInfo) -> Vec<Option<u32>> {
    let Some(mesh) = &info.mesh else {
        return Vec::new();
    };
    let mut feature_of = vec![None; mesh.positions.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for &v in tri {
            if let Some(slot) = feature_of.get_mut(v as usize) {
                slot.get_or_insert(info.triangle_features.get(t).copied().unwrap_or(u32::MAX));
            }
        }
    }
    feature_of
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::select::{OrientedBox, TileNode, TileTree};
    use crate::tileset::FeatureInfo;
    use citylod_model::Mesh3d;

    /// The slack grows with the distance from the origin but stays finite however far a vertex is: a norm that
    /// overflowed to infinity let content thrown to 10³⁰⁸ m pass as inside every box (found by fuzzing).
    #[test]
    fn slack_is_finite_and_far_below_the_distance_of_a_far_vertex() {
        assert!((slack_m([0.0; 3]) - 1e-3).abs() < 1e-15);
        let far = [1e308, 1e308, 0.0];
        assert!(
            slack_m(far).is_finite() && slack_m(far) < 1e303,
            "{}",
            slack_m(far)
        );
        let near = [6.4e6, 0.0, 0.0];
        assert!(
            slack_m(near) > 1.5 && slack_m(near) < 3.0,
            "{}",
            slack_m(near)
        );
    }

    fn tile(path: &str, positions: Vec<Vec3>) -> TileInfo {
        let triangles = (0..positions.len() as u32 / 3)
            .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
            .collect::<Vec<_>>();
        TileInfo {
            path_in_tree: path.into(),
            content_uri: Some(format!("{path}.glb")),
            content_bytes: 0,
            content_uris: vec![],
            volume_kind: Default::default(),
            exact_volume: None,
            triangle_features: vec![0; triangles.len()],
            mesh: Some(Mesh3d {
                positions,
                triangles,
            }),
            features: vec![FeatureInfo::building(7)],
            under: vec![],
        }
    }

    fn node(lo: Vec3, hi: Vec3, children: Vec<usize>) -> TileNode {
        TileNode {
            bounds: OrientedBox::from_min_max(lo, hi),
            geometric_error_m: 0.0,
            children,
            has_content: true,
            external_tileset: false,
        }
    }

    fn tileset(child_box_hi: f64, child_vertex_x: f64) -> LoadedTileset {
        let tri = |x: f64| vec![[x, 0.0, 0.0], [x, 1.0, 0.0], [x, 0.0, 1.0]];
        LoadedTileset {
            tree: TileTree {
                tiles: vec![
                    node([0.0; 3], [10.0; 3], vec![1]),
                    node([0.0; 3], [child_box_hi; 3], vec![]),
                ],
                root: 0,
                tileset_geometric_error_m: 1.0,
            },
            tiles: vec![tile("0", tri(5.0)), tile("0/0", tri(child_vertex_x))],
            buildings: Default::default(),
            written_by_citylod: false,
        }
    }

    #[test]
    fn content_inside_every_box_passes() {
        assert!(check_volumes(&tileset(10.0, 4.0)).is_empty());
        // Within the slack.
        assert!(check_volumes(&tileset(10.0, 10.0005)).is_empty());
    }

    #[test]
    fn content_outside_its_own_box_and_an_ancestors_is_found() {
        let f = check_volumes(&tileset(5.0, 12.0));
        assert_eq!(f.len(), 2, "{f:?}");
        assert!(f
            .iter()
            .all(|f| f.kind == FindingKind::ContentOutsideVolume && f.tile == "0/0"));
        assert!(f[0].message.contains("this tile's"), "{}", f[0].message);
        assert!((f[0].measured.unwrap() - 7.0).abs() < 1e-9);
        assert!(f[1].message.contains("ancestor 0 "), "{}", f[1].message);
        assert!((f[1].measured.unwrap() - 2.0).abs() < 1e-9);
        assert_eq!(f[0].buildings, vec![7]);
        // Outside the ancestor only: a child box poking out of its parent is allowed, content is not.
        let f = check_volumes(&tileset(20.0, 12.0));
        assert_eq!(f.len(), 1, "{f:?}");
        assert!(f[0].message.contains("ancestor"));
    }

    #[test]
    fn spheres_and_regions_are_checked_as_written_not_as_their_boxes() {
        // The child's volume is a sphere of radius 5 about (5, 5, 5); its box is the cube [0, 10]³. A vertex at
        // (9.5, 9.5, 9.5) is in the cube but 2.794 m outside the sphere.
        let mut ts = tileset(10.0, 4.0);
        ts.tiles[1].volume_kind = VolumeKind::Sphere;
        ts.tiles[1].exact_volume = Some(ExactVolume::Sphere {
            centre: [5.0; 3],
            radius_m: 5.0,
        });
        let corner = vec![[9.5, 9.5, 9.5], [9.0, 9.5, 9.5], [9.5, 9.0, 9.5]];
        ts.tiles[1].mesh.as_mut().unwrap().positions = corner.clone();
        let f = check_volumes(&ts);
        assert_eq!(f.len(), 1, "{f:?}");
        assert!(
            f[0].message.contains(
                "3 of the 3 vertices drawn lie outside this tile's bounding sphere, up to 2.794 m"
            ),
            "{}",
            f[0].message
        );
        // Inside the sphere: nothing.
        ts.tiles[1].mesh.as_mut().unwrap().positions =
            vec![[5.0, 5.0, 5.0], [6.0, 5.0, 5.0], [5.0, 6.0, 5.0]];
        assert!(check_volumes(&ts).is_empty());

        // A region: the root frame is ENU at 10° E, 50° N, height 0; the region spans 9.999–10.001° E,
        // 49.999–50.001° N, heights 0–20 m. Its box (in the root frame) reaches past its corners; a vertex
        // 30 m up at the centre is 10 m above it, one 60 m east of the centre (about 4.6 m outside the
        // eastern edge, 71.6 m from the centre at this latitude) only that much outside.
        let frame = citylod_model::LocalFrame::new(10.0, 50.0, 0.0);
        let d = 0.001f64.to_radians();
        let (lon, lat) = (10f64.to_radians(), 50f64.to_radians());
        ts.tiles[1].volume_kind = VolumeKind::Region;
        ts.tiles[1].exact_volume = Some(ExactVolume::Region {
            region: [lon - d, lat - d, lon + d, lat + d, 0.0, 20.0],
            root_to_ecef: frame.enu_to_ecef_column_major(),
        });
        ts.tiles[0].mesh = None;
        ts.tree.tiles[1].bounds =
            OrientedBox::from_min_max([-200.0, -200.0, -10.0], [200.0, 200.0, 40.0]);
        ts.tree.tiles[0].bounds = ts.tree.tiles[1].bounds;
        ts.tiles[1].mesh.as_mut().unwrap().positions =
            vec![[0.0, 0.0, 30.0], [0.0, 1.0, 10.0], [1.0, 0.0, 10.0]];
        let f = check_volumes(&ts);
        assert_eq!(f.len(), 1, "{f:?}");
        let m = f[0].measured.unwrap();
        assert!((m - 10.0).abs() < 0.01, "{}", f[0].message);
        assert!(f[0]
            .message
            .contains("1 of the 3 vertices drawn lie outside this tile's bounding region"));
        let half_width_m = 71.6;
        ts.tiles[1].mesh.as_mut().unwrap().positions = vec![
            [half_width_m + 5.0, 0.0, 10.0],
            [0.0, 1.0, 10.0],
            [1.0, 0.0, 10.0],
        ];
        let f = check_volumes(&ts);
        assert_eq!(f.len(), 1, "{f:?}");
        let m = f[0].measured.unwrap();
        assert!(m > 4.5 && m < 5.1, "{}", f[0].message);
        ts.tiles[1].mesh.as_mut().unwrap().positions = vec![
            [half_width_m - 1.0, 0.0, 10.0],
            [0.0, 1.0, 10.0],
            [1.0, 0.0, 10.0],
        ];
        assert!(check_volumes(&ts).is_empty());
    }
}
