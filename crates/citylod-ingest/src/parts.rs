//! OpenStreetMap's Simple 3D Buildings rule (wiki.openstreetmap.org/wiki/Simple_3D_Buildings): a building outline
//! (`building=*`) with `building:part`s inside it is drawn by its parts, not as a block of its own. The outline
//! carries the building's name and address for 2D maps; its height, when it has one, is often the tallest part's,
//! and without one a default block would hide the lower parts and cut through the taller ones. A part belongs to the
//! smallest outline that holds at least half of it (a skyway between two buildings belongs to neither; a part of a
//! small building inside a large one belongs to the small one). For GeoJSON exports of OSM data and for OSM files
//! alike; a file without `building:part` features is not touched.

use crate::feature::RawFeature;
use citylod_model::{AttrValue, Footprint};
use geo::{Area, BooleanOps, BoundingRect};
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{RTree, AABB};
use std::collections::BTreeMap;

/// A part belongs to the smallest outline holding at least this share of its area.
const PART_INSIDE_SHARE: f64 = 0.5;

/// The outlines among `features` that hold parts, each with the indices of its parts in file order. `footprints[i]`
/// is feature i's placed footprint (m), `None` when skipped.
pub(crate) fn outlines_with_parts(
    features: &[RawFeature],
    footprints: &[Option<&Footprint>],
) -> BTreeMap<usize, Vec<usize>> {
    let mut out: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    if !features.iter().any(|f| f.is_building_part) {
        return out;
    }
    let is_outline = |f: &RawFeature| {
        !f.is_building_part
            && matches!(f.attributes.get("building"), Some(AttrValue::String(v)) if crate::osm::tag_set(v))
    };
    let boxes: Vec<GeomWithData<Rectangle<[f64; 2]>, usize>> = features
        .iter()
        .zip(footprints)
        .enumerate()
        .filter(|(_, (f, _))| is_outline(f))
        .filter_map(|(i, (_, fp))| {
            let r = fp.as_ref()?.bounding_rect()?;
            Some(GeomWithData::new(
                Rectangle::from_corners([r.min().x, r.min().y], [r.max().x, r.max().y]),
                i,
            ))
        })
        .collect();
    if boxes.is_empty() {
        return out;
    }
    let tree = RTree::bulk_load(boxes);
    for (p, (f, fp)) in features.iter().zip(footprints).enumerate() {
        let (true, Some(fp)) = (f.is_building_part, fp) else {
            continue;
        };
        let (Some(r), area) = (fp.bounding_rect(), fp.unsigned_area()) else {
            continue;
        };
        if area <= 0.0 {
            continue;
        }
        let env = AABB::from_corners([r.min().x, r.min().y], [r.max().x, r.max().y]);
        let holder = tree
            .locate_in_envelope_intersecting(&env)
            .map(|g| g.data)
            .filter_map(|o| {
                let outline = footprints[o]?;
                let inside = outline.intersection(*fp).unsigned_area();
                (inside >= PART_INSIDE_SHARE * area).then(|| (outline.unsigned_area(), o))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        if let Some((_, o)) = holder {
            out.entry(o).or_default().push(p);
        }
    }
    out
}

/// The attribute by which Overture Maps' building parts (its `building_part` type) name their building.
const BUILDING_ID_ATTR: &str = "building_id";

/// Overture Maps' building parts: features whose `building_id` is the id of another input feature, in whichever
/// input either comes, each with that feature, as ((input, index) of the part, (input, index) of its building).
/// The parts are marked as building parts. A `building_id` naming no input feature, or the feature itself (a
/// dataset's own id column of that name), links nothing.
pub(crate) fn linked_by_building_id(
    inputs: &mut [&mut Vec<RawFeature>],
) -> Vec<((usize, usize), (usize, usize))> {
    let named = |f: &RawFeature| match f.attributes.get(BUILDING_ID_ATTR) {
        Some(AttrValue::String(s)) if !s.is_empty() && *s != f.source_id => Some(s.clone()),
        _ => None,
    };
    if !inputs
        .iter()
        .any(|fs| fs.iter().any(|f| named(f).is_some()))
    {
        return Vec::new();
    }
    let mut by_id: std::collections::HashMap<String, (usize, usize)> = Default::default();
    for (fi, fs) in inputs.iter().enumerate() {
        for (i, f) in fs.iter().enumerate() {
            by_id.entry(f.source_id.clone()).or_insert((fi, i));
        }
    }
    let mut links = Vec::new();
    for (fi, fs) in inputs.iter_mut().enumerate() {
        for (i, f) in fs.iter_mut().enumerate() {
            if let Some(&building) = named(f).and_then(|b| by_id.get(&b)) {
                f.is_building_part = true;
                links.push(((fi, i), building));
            }
        }
    }
    links
}

#[cfg(test)]
mod tests {
    use super::*;
    use citylod_model::Attributes;
    use geo_types::{polygon, MultiPolygon};

    fn square(x: f64, y: f64, d: f64) -> Footprint {
        MultiPolygon(vec![polygon![
            (x: x, y: y),
            (x: x + d, y: y),
            (x: x + d, y: y + d),
            (x: x, y: y + d),
        ]])
    }

    fn feature(id: &str, building: Option<&str>, part: bool) -> RawFeature {
        let mut attributes = Attributes::new();
        if let Some(b) = building {
            attributes.insert("building".into(), AttrValue::String(b.into()));
        }
        RawFeature {
            source_id: id.into(),
            attributes,
            is_building_part: part,
            ..Default::default()
        }
    }

    #[test]
    fn parts_naming_a_building_by_building_id_are_linked_to_it() {
        let with = |id: &str, building_id: Option<&str>| {
            let mut f = feature(id, None, false);
            if let Some(b) = building_id {
                f.attributes
                    .insert(BUILDING_ID_ATTR.into(), AttrValue::String(b.into()));
            }
            f
        };
        // A dataset's own id column named building_id links nothing; nor does a building that is not given.
        let mut a = vec![with("b1", Some("b1")), with("b2", None)];
        let mut b = vec![
            with("p1", Some("b2")),
            with("p2", Some("elsewhere")),
            with("p3", Some("b2")),
        ];
        let links = linked_by_building_id(&mut [&mut a, &mut b]);
        assert_eq!(links, [((1, 0), (0, 1)), ((1, 2), (0, 1))]);
        assert_eq!(
            b.iter().map(|f| f.is_building_part).collect::<Vec<_>>(),
            [true, false, true]
        );
        assert!(!a[0].is_building_part);
    }

    #[test]
    fn outlines_holding_parts_are_found_with_their_parts() {
        let features = [
            feature("outline", Some("yes"), false),
            feature("part-a", None, true),
            feature("lone", Some("house"), false),
            feature("part-b", Some("yes"), true),
            feature("not-a-building", Some("no"), false),
            feature("part-outside", None, true),
            feature("skipped-part", None, true),
        ];
        let fps = [
            square(0.0, 0.0, 20.0),
            square(1.0, 1.0, 5.0),
            square(30.0, 0.0, 10.0),
            // A part sticking out of its outline, its interior point inside.
            square(10.0, 10.0, 12.0),
            square(-1.0, -1.0, 50.0),
            square(100.0, 0.0, 5.0),
            square(2.0, 2.0, 1.0),
        ];
        let mut refs: Vec<Option<&Footprint>> = fps.iter().map(Some).collect();
        refs[6] = None;
        let found = outlines_with_parts(&features, &refs);
        assert_eq!(found.into_iter().collect::<Vec<_>>(), [(0, vec![1, 3])]);
        // Without parts nothing is looked at.
        let none = outlines_with_parts(&features[..1], &refs[..1]);
        assert!(none.is_empty());
    }

    #[test]
    fn a_part_belongs_to_the_smallest_outline_holding_half_of_it() {
        let features = [
            feature("mall", Some("retail"), false),
            feature("kiosk", Some("yes"), false),
            feature("kiosk-roof", None, true),
            feature("east", Some("yes"), false),
            feature("skyway", None, true),
        ];
        let fps = [
            square(0.0, 0.0, 100.0),
            square(40.0, 40.0, 10.0),
            square(41.0, 41.0, 8.0),
            square(130.0, 0.0, 20.0),
            // From the mall's east wall to the east building: a sixth in each, the rest over the street.
            MultiPolygon(vec![polygon![
                (x: 92.0, y: 10.0),
                (x: 138.0, y: 10.0),
                (x: 138.0, y: 12.0),
                (x: 92.0, y: 12.0),
            ]]),
        ];
        let refs: Vec<Option<&Footprint>> = fps.iter().map(Some).collect();
        let found = outlines_with_parts(&features, &refs);
        // The kiosk's part drops the kiosk, not the mall; the skyway drops neither building.
        assert_eq!(found.into_iter().collect::<Vec<_>>(), [(1, vec![2])]);
    }
}
