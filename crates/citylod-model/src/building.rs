//! A building as citylod works with it: a footprint in local ENU metres (x east, y north), a base
//! height and a height above it, the source id and attributes, and where the height came from.

use crate::attr::Attributes;
use geo_types::MultiPolygon;

/// Index of a building in the ingested input, in input order (0-based). Stable for one input and options.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
pub struct BuildingId(pub u32);

/// A footprint in local ENU metres: exterior rings counter-clockwise, holes clockwise, rings closed,
/// valid (no self-intersection), non-zero area.
pub type Footprint = MultiPolygon<f64>;

/// Which rule gave a building its height; counted in the build report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum HeightSource {
    /// The attribute named by `--height-attr`.
    NamedAttribute,
    /// A well-known height attribute (`height`, `building:height`, `measuredHeight`, …).
    KnownAttribute,
    /// Roof minus ground height attributes (3DBAG `b3_h_dak_70p − b3_h_maaiveld`).
    RoofMinusGround,
    /// Storeys × storey height.
    Storeys,
    /// Taken from the 3D geometry's vertical extent.
    Geometry,
    /// No height information: the stated default height.
    Default,
}

/// A triangle mesh in local ENU metres (x east, y north, z up), counter-clockwise seen from outside.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh3d {
    pub positions: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// What a triangle of a building model is part of, from CityJSON semantic surfaces: `Roof`
/// (RoofSurface, OuterFloorSurface), `Wall` (WallSurface, Window, Door), `Ground` (GroundSurface),
/// `Other` (ClosureSurface, OuterCeilingSurface, interior surfaces, unknown or no semantics).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceKind {
    Roof,
    Wall,
    Ground,
    Other,
}

/// A building's own 3D model (e.g. CityJSON LoD2.2): one mesh for the building and its parts, in the
/// same local ENU metres and vertical frame as its footprint, with the surface kind of every triangle.
/// Invariant: `surfaces.len() == mesh.triangles.len()`, every index < `mesh.positions.len()`.
#[derive(Debug, Clone, PartialEq)]
pub struct BuildingModel {
    pub mesh: Mesh3d,
    /// One per triangle, in triangle order.
    pub surfaces: Vec<SurfaceKind>,
    /// The LoD the mesh was taken from, as the source writes it (`"2.2"`, `"2"`).
    pub lod: String,
}

impl BuildingModel {
    /// Checks the invariant above; tests call it.
    pub fn check_invariants(&self) -> Result<(), String> {
        if self.surfaces.len() != self.mesh.triangles.len() {
            return Err(format!(
                "{} surface kinds for {} triangles",
                self.surfaces.len(),
                self.mesh.triangles.len()
            ));
        }
        let n = self.mesh.positions.len();
        match self
            .mesh
            .triangles
            .iter()
            .flatten()
            .find(|&&i| i as usize >= n)
        {
            Some(i) => Err(format!("vertex index {i} out of range ({n} positions)")),
            None => Ok(()),
        }
    }
}

/// One input building.
#[derive(Debug, Clone)]
pub struct Building {
    pub id: BuildingId,
    /// The feature's id in the source (GeoJSON `id`, CityJSON object key), or a generated `feature-N`.
    pub source_id: String,
    pub footprint: Footprint,
    /// Height of the ground under the building in the local frame (m, up).
    pub base_z_m: f64,
    /// Height of the building above its base (m), > 0.
    pub height_m: f64,
    pub height_source: HeightSource,
    pub attributes: Attributes,
    /// The building's 3D model (CityJSON solids and surfaces) when the input has one and it was
    /// asked for; the footprint and heights above do not depend on it.
    pub mesh: Option<BuildingModel>,
}

impl Building {
    /// Footprint area in m².
    pub fn area_m2(&self) -> f64 {
        footprint_area_m2(&self.footprint)
    }
}

/// Unsigned area of a footprint (m²), holes subtracted.
pub fn footprint_area_m2(fp: &Footprint) -> f64 {
    fn ring(r: &geo_types::LineString<f64>) -> f64 {
        let c = &r.0;
        if c.len() < 3 {
            return 0.0;
        }
        let mut s = 0.0;
        for i in 0..c.len() - 1 {
            s += c[i].x * c[i + 1].y - c[i + 1].x * c[i].y;
        }
        (s / 2.0).abs()
    }
    fp.0.iter()
        .map(|p| ring(p.exterior()) - p.interiors().iter().map(ring).sum::<f64>())
        .sum()
}
