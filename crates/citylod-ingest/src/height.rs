//! Height resolution (DESIGN.md §2): the ground height under a building and its height above that
//! base, each from the first rule that gives a plausible value, with the rule recorded.
//! Metres; ground heights are in the data's vertical datum (NAP, …) and used as they are.
//! Invariant: the resolved height is finite, ≥ `MIN_HEIGHT_M` and ≤ `MAX_HEIGHT_M`.

use crate::IngestOptions;
use citylod_model::{AttrValue, Attributes, HeightSource};

/// Heights above this are treated as data errors and fall through to the next rule (m).
pub const MAX_HEIGHT_M: f64 = 1000.0;

/// Heights below this are treated as data errors and fall through to the next rule (m): a lower prism vanishes on
/// the leaves' 2 cm grid, its walls dropped as degenerate.
pub const MIN_HEIGHT_M: f64 = 0.1;

/// Well-known building height attributes (total height above ground), tried in this order.
pub const KNOWN_HEIGHT_ATTRS: &[&str] = &[
    "height",
    "building:height",
    "measuredHeight",
    "measured_height",
    "Height",
    "HEIGHT",
    "bldg_height",
    // `building:height` as GDAL writes it where a name may not hold a colon (File Geodatabase, PostgreSQL).
    "building_height",
    // The same names as shapefile writers cut them to 10 characters (a GeoJSON converted with ogr2ogr).
    "building_h",
    "measuredHe",
    "measured_h",
    "bldg_heigh",
];

/// Storey-count attributes tried when no storey attribute is named.
pub const DEFAULT_STOREY_ATTRS: &[&str] = &[
    "stories",
    "storeys",
    "building:levels",
    "b3_bouwlagen",
    "num_floors",
    "STORIES",
    "NUM_FLOORS",
    // As GDAL writes OSM's name where a name may not hold a colon (File Geodatabase, PostgreSQL).
    "building_levels",
    // Cut to 10 characters by shapefile writers.
    "building_l",
    "b3_bouwlag",
];

/// OpenStreetMap's storey count (and its names where a name may hold no colon, or only 10 characters), which counts
/// no level in the roof: a height from it adds [`ROOF_LEVELS_ATTR`].
const OSM_LEVELS_ATTRS: [&str; 3] = ["building:levels", "building_levels", "building_l"];
/// OpenStreetMap's levels in the roof, on top of `building:levels`.
const ROOF_LEVELS_ATTR: &str = "roof:levels";
/// More levels in a roof than this is no roof (a typo); the height is then the levels under it.
const MAX_ROOF_LEVELS: f64 = 20.0;

/// 3DBAG ground height and roof height (70th percentile) attributes.
pub(crate) const GROUND_ATTR: &str = "b3_h_maaiveld";
const ROOF_ATTR: &str = "b3_h_dak_70p";
/// A ground height further from the datum than this (m) is a data error: the Dead Sea shore is at −430 m, the
/// highest towns near 5,100 m.
pub(crate) const MAX_GROUND_M: f64 = 10_000.0;
/// OSM base of a building part above the ground (m).
const MIN_HEIGHT_ATTR: &str = "min_height";
/// OSM: the levels a building part skips from the ground (its base, in storeys), read when `min_height` is not there;
/// then as GDAL writes the name where a name may not hold a colon (File Geodatabase, PostgreSQL), and Overture Maps'
/// name for the same (`min_floor`).
const MIN_LEVEL_ATTRS: [&str; 3] = ["building:min_level", "building_min_level", "min_floor"];

/// Where a building's ground height came from (report key).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum GroundSource {
    Attribute,
    Geometry,
    Zero,
}

impl GroundSource {
    pub fn as_str(self) -> &'static str {
        match self {
            GroundSource::Attribute => GROUND_ATTR,
            GroundSource::Geometry => "geometry",
            GroundSource::Zero => "zero",
        }
    }
}

/// The resolved heights of one building.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Heights {
    /// Ground height in the data's vertical datum (m).
    pub ground_m: f64,
    pub ground_source: GroundSource,
    /// OSM `min_height`: the building's base above its ground (m), else 0.
    pub base_offset_m: f64,
    /// Height of the building above its base (m).
    pub height_m: f64,
    pub source: HeightSource,
    /// Attributes that were present but gave no plausible value (or, for a base, one at or above the height).
    pub rejected: Vec<Rejected>,
}

/// An attribute value as the report quotes a rejected one: text in quotes, `null` for none.
pub(crate) fn shown(v: Option<&AttrValue>) -> String {
    match v {
        Some(AttrValue::String(t)) => format!("{t:?}"),
        Some(AttrValue::Int(i)) => i.to_string(),
        Some(AttrValue::Float(f)) => f.to_string(),
        Some(AttrValue::Bool(b)) => b.to_string(),
        Some(AttrValue::Null) | None => "null".into(),
    }
}

/// An attribute a rule reached that was present and not used, with what it held and why (for the report).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Rejected {
    pub name: String,
    pub detail: String,
}

impl Rejected {
    fn new(name: &str, v: Option<&AttrValue>, why: &str) -> Self {
        Rejected {
            name: name.to_string(),
            detail: format!("{name} = {}: {why}", shown(v)),
        }
    }

    /// Why a value gave no length: not a number, or an ambiguous comma, or `range` (when it gave `metres`).
    fn unusable(name: &str, v: &AttrValue, metres: Option<f64>, range: &str) -> Self {
        let why = match (metres, v) {
            (Some(m), _) => format!("{} m, {range}", trim_float(m)),
            (None, AttrValue::String(t)) if citylod_model::ambiguous_comma(t) => {
                "a comma before three digits may separate thousands (1,776) or decimals (1,776 = 1.776): \
                 write the number without it"
                    .to_string()
            }
            (None, AttrValue::String(t)) if unit_not_known(t).is_some() => format!(
                "a length in {:?}, a unit not known: not taken as metres",
                unit_not_known(t).unwrap_or_default()
            ),
            _ => "not a number".to_string(),
        };
        Rejected::new(name, Some(v), &why)
    }
}

/// The unit of a text that is a number followed by a unit's name (`3 furlong`, `20 m2`, as the CityGML reader keeps a
/// `measuredHeight` whose `uom` it does not know): that name.
fn unit_not_known(t: &str) -> Option<&str> {
    let t = t.trim();
    let (number, unit) = t.split_once(char::is_whitespace)?;
    let unit = unit.trim();
    (number.parse::<f64>().is_ok()
        && unit.starts_with(|c: char| c.is_alphabetic() || c == '#' || c == '[')
        && !unit.contains(char::is_whitespace))
    .then_some(unit)
}

pub(crate) fn trim_float(m: f64) -> String {
    let t = format!("{m:.3}");
    t.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The range a height must lie in, as the report says it.
const HEIGHT_RANGE: &str = "not a height between 0.1 and 1000 m";

fn plausible(h: f64) -> bool {
    h.is_finite() && (MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&h)
}

fn number(attrs: &Attributes, name: &str) -> Option<f64> {
    attrs.get(name).and_then(AttrValue::as_number)
}

/// How an attribute gives metres: as a length, or as a count of storeys of the given height.
#[derive(Clone, Copy)]
enum Measure {
    /// A length: metres per unit of a number without a unit (`--height-unit`).
    Length(f64),
    Storeys(f64),
}

impl Measure {
    fn metres(self, v: &AttrValue) -> Option<f64> {
        match self {
            Measure::Length(unit) => length_m(v, unit),
            Measure::Storeys(h) => v.as_number().map(|n| n * h),
        }
    }
}

/// A length in metres: a number without a unit (times `unit`, metres per unit), a number in metres (`28 m`), or
/// feet and inches as OpenStreetMap allows them (`100'`, `16'4"`, `35 ft`).
pub(crate) fn length_m(v: &AttrValue, unit: f64) -> Option<f64> {
    if let Some(m) = v.as_number() {
        let explicit_metres = matches!(v, AttrValue::String(s) if s.trim_end().ends_with(|c: char| c.is_ascii_alphabetic()));
        return Some(if explicit_metres { m } else { m * unit });
    }
    let AttrValue::String(s) = v else {
        return None;
    };
    let t = s.trim();
    let number = |x: &str| -> Option<f64> {
        let x = x.trim();
        (!x.is_empty() && x.bytes().all(|b| b.is_ascii_digit() || b == b'.'))
            .then(|| x.parse::<f64>().ok())
            .flatten()
    };
    let lower = t.to_ascii_lowercase();
    for unit in ["feet", "foot", "ft"] {
        if let Some(x) = lower.strip_suffix(unit) {
            return number(x).map(|f| f * 0.3048);
        }
    }
    let (feet, inches) = t.split_once('\'')?;
    let inches = match inches.trim() {
        "" => 0.0,
        i => number(i.strip_suffix('"')?)?,
    };
    Some(number(feet)? * 0.3048 + inches * 0.0254)
}

/// The 3DBAG ground attribute, when it is a number within [`MAX_GROUND_M`] of the datum.
pub(crate) fn ground_attribute(attrs: &Attributes) -> Option<f64> {
    number(attrs, GROUND_ATTR).filter(|g| g.abs() < MAX_GROUND_M)
}

/// Resolves ground and height. Ground: `b3_h_maaiveld`, else the lowest footprint vertex z
/// (CityJSON), else 0; an OSM `min_height` (or `building:min_level` storeys) raises the base above that ground. Height: the named
/// attribute, known names, 3DBAG roof − ground, the 3D geometry's top − ground, storeys × storey
/// height, else the default. Attribute heights count from the ground, so `min_height` is
/// subtracted from them (a part reaching less than 0.1 m above its base is 0.1 m thick). A value under 0.1 m or
/// over 1000 m falls through to the next rule; every attribute of a
/// rule that was reached, present and not usable is named in `rejected` (a ground attribute too).
pub(crate) fn resolve(
    attrs: &Attributes,
    footprint_min_z: Option<f64>,
    top_z: Option<f64>,
    opts: &IngestOptions,
) -> Heights {
    let mut rejected = Vec::new();
    let present = |name: &str| !matches!(attrs.get(name), None | Some(AttrValue::Null));
    let ground_attr = ground_attribute(attrs);
    if ground_attr.is_none() && present(GROUND_ATTR) {
        let v = attrs.get(GROUND_ATTR).expect("present");
        rejected.push(Rejected::unusable(
            GROUND_ATTR,
            v,
            v.as_number(),
            "further than 10 km from the datum",
        ));
    }
    let (ground_m, ground_source) = match (ground_attr, footprint_min_z) {
        (Some(g), _) => (g, GroundSource::Attribute),
        (_, Some(z)) if z.is_finite() => (z, GroundSource::Geometry),
        _ => (0.0, GroundSource::Zero),
    };
    // A `min_height` that is not a number in [0, 1000) m is rejected (reported) and the base stays on the ground.
    // Without one, OSM's `building:min_level` (levels skipped below a part) × the storey height.
    let mut base_from = |name: &'static str, measure: Measure| match attrs.get(name) {
        None | Some(AttrValue::Null) => None,
        Some(v) => {
            let m = measure.metres(v);
            match m.filter(|m| (0.0..MAX_HEIGHT_M).contains(m)) {
                Some(m) => Some((m, name)),
                None => {
                    rejected.push(Rejected::unusable(
                        name,
                        v,
                        m,
                        "not a base between 0 and 1000 m",
                    ));
                    None
                }
            }
        }
    };
    let length = Measure::Length(opts.height_unit_m.unwrap_or(1.0));
    let base = base_from(MIN_HEIGHT_ATTR, length).or_else(|| {
        MIN_LEVEL_ATTRS
            .iter()
            .find_map(|n| base_from(n, Measure::Storeys(opts.storey_height_m)))
    });
    let mut base_offset_m = base.map_or(0.0, |(m, _)| m);

    // The height above the base, and whether the base must go: a height (from the ground) at or under the base
    // contradicts it, and the height is what the data says of the building, so it stands on the ground instead.
    let try_attr = |name: &str,
                    measure: Measure,
                    offset: f64,
                    rejected: &mut Vec<Rejected>|
     -> Option<(f64, bool)> {
        let v = attrs.get(name)?;
        if matches!(v, AttrValue::Null) {
            return None;
        }
        let total = measure.metres(v);
        match total.map(|x| x - offset) {
            Some(h) if plausible(h) => Some((h, false)),
            // A part reaching only just above its `min_height` is a thin slab there (a canopy): MIN_HEIGHT_M
            // thick, not the default height standing on its base.
            Some(h) if offset > 0.0 && h > 0.0 && h < MIN_HEIGHT_M => Some((MIN_HEIGHT_M, false)),
            Some(h) if offset > 0.0 && h <= 0.0 && total.is_some_and(plausible) => {
                Some((total.expect("checked"), true))
            }
            _ => {
                rejected.push(Rejected::unusable(name, v, total, HEIGHT_RANGE));
                None
            }
        }
    };
    let mut found: Option<(f64, HeightSource)> = None;
    let mut base_dropped = false;
    let mut take = |r: Option<(f64, bool)>, source: HeightSource| {
        r.map(|(h, dropped)| {
            base_dropped |= dropped;
            (h, source)
        })
    };
    if let Some(name) = &opts.height_attr {
        found = take(
            try_attr(name, length, base_offset_m, &mut rejected),
            HeightSource::NamedAttribute,
        );
    }
    if found.is_none() {
        found = take(
            KNOWN_HEIGHT_ATTRS
                .iter()
                .find_map(|n| try_attr(n, length, base_offset_m, &mut rejected)),
            HeightSource::KnownAttribute,
        );
    }
    if found.is_none() && present(ROOF_ATTR) {
        found = number(attrs, ROOF_ATTR)
            .zip(ground_attr)
            .map(|(roof, g)| roof - g)
            .filter(|h| plausible(*h))
            .map(|h| (h, HeightSource::RoofMinusGround));
        if found.is_none() {
            let v = attrs.get(ROOF_ATTR).expect("present");
            let h = v.as_number().zip(ground_attr).map(|(r, g)| r - g);
            rejected.push(Rejected::unusable(ROOF_ATTR, v, h, HEIGHT_RANGE));
        }
    }
    if found.is_none() {
        found = top_z
            .map(|t| t - ground_m - base_offset_m)
            .filter(|h| plausible(*h))
            .map(|h| (h, HeightSource::Geometry));
    }
    if found.is_none() {
        let s = opts.storey_height_m;
        // Storeys count from the ground too (OSM's building:levels of a part includes the levels below it).
        let storeys = match &opts.storey_attr {
            Some(name) => try_attr(name, Measure::Storeys(s), base_offset_m, &mut rejected)
                .map(|r| (r, name.as_str())),
            None => DEFAULT_STOREY_ATTRS.iter().find_map(|n| {
                try_attr(n, Measure::Storeys(s), base_offset_m, &mut rejected).map(|r| (r, *n))
            }),
        };
        // OpenStreetMap's building:levels counts the levels under the roof only; roof:levels are those in it, on top.
        let in_roof = |name: &str| {
            OSM_LEVELS_ATTRS
                .contains(&name)
                .then(|| number(attrs, ROOF_LEVELS_ATTR))
                .flatten()
                .filter(|n| n.is_finite() && (0.0..=MAX_ROOF_LEVELS).contains(n))
                .unwrap_or(0.0)
        };
        found = take(
            storeys.map(|((h, dropped), name)| (h + in_roof(name) * s, dropped)),
            HeightSource::Storeys,
        );
    }
    if base_dropped {
        if let Some((m, name)) = base {
            let why = format!(
                "a base of {} m, not below the height {} m: the part stands on the ground",
                trim_float(m),
                trim_float(found.map_or(0.0, |f| f.0))
            );
            rejected.push(Rejected::new(name, attrs.get(name), &why));
        }
        base_offset_m = 0.0;
    }
    let (height_m, source) = found.unwrap_or((opts.default_height_m, HeightSource::Default));
    Heights {
        ground_m,
        ground_source,
        base_offset_m,
        height_m,
        source,
        rejected,
    }
}

/// The report key of a height source (its snake_case serde name).
pub(crate) fn height_source_key(s: HeightSource) -> &'static str {
    match s {
        HeightSource::NamedAttribute => "named_attribute",
        HeightSource::KnownAttribute => "known_attribute",
        HeightSource::RoofMinusGround => "roof_minus_ground",
        HeightSource::Storeys => "storeys",
        HeightSource::Geometry => "geometry",
        HeightSource::Default => "default",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Rejections compare with attribute names in these tests; their details have tests of their own.
    impl PartialEq<&str> for Rejected {
        fn eq(&self, other: &&str) -> bool {
            self.name == *other
        }
    }
    impl PartialEq<String> for Rejected {
        fn eq(&self, other: &String) -> bool {
            self.name == *other
        }
    }

    fn attrs(pairs: &[(&str, AttrValue)]) -> Attributes {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect()
    }

    #[test]
    fn bare_numbers_are_in_the_height_unit_and_text_in_its_own() {
        let ft = Measure::Length(0.3048);
        let near = |v: Option<f64>, m: f64| (v.unwrap() - m).abs() < 1e-9;
        assert!(near(ft.metres(&AttrValue::Float(100.0)), 30.48));
        assert!(near(ft.metres(&AttrValue::Int(100)), 30.48));
        assert!(near(ft.metres(&AttrValue::String("100".into())), 30.48));
        assert!(near(ft.metres(&AttrValue::String("100 m".into())), 100.0));
        assert!(near(ft.metres(&AttrValue::String("100 ft".into())), 30.48));
        assert!(near(ft.metres(&AttrValue::String("16'4\"".into())), 4.9784));
        assert!(near(
            Measure::Length(1.0).metres(&AttrValue::Float(100.0)),
            100.0
        ));
        let o = IngestOptions {
            height_unit_m: Some(0.3048),
            ..Default::default()
        };
        let a = attrs(&[
            ("height", AttrValue::Float(328.0)),
            ("min_height", AttrValue::Int(100)),
        ]);
        let h = resolve(&a, None, None, &o);
        assert!(
            (h.height_m - (328.0 - 100.0) * 0.3048).abs() < 1e-9,
            "{h:?}"
        );
        assert!((h.base_offset_m - 30.48).abs() < 1e-9);
        // Storey counts are counts, whatever the unit.
        let a = attrs(&[("stories", AttrValue::Int(4))]);
        assert_eq!(resolve(&a, None, None, &o).height_m, 12.0);
    }

    #[test]
    fn rules_apply_in_documented_order() {
        let o = IngestOptions {
            height_attr: Some("h".into()),
            ..Default::default()
        };
        let a = attrs(&[
            ("h", AttrValue::Int(20)),
            ("height", AttrValue::Int(30)),
            ("stories", AttrValue::Int(4)),
        ]);
        assert_eq!(
            resolve(&a, None, None, &o).source,
            HeightSource::NamedAttribute
        );
        let d = IngestOptions::default();
        let h = resolve(&a, None, None, &d);
        assert_eq!((h.height_m, h.source), (30.0, HeightSource::KnownAttribute));
        let a = attrs(&[("stories", AttrValue::Float(2.5))]);
        let h = resolve(&a, None, None, &d);
        assert_eq!((h.height_m, h.source), (7.5, HeightSource::Storeys));
        let h = resolve(&Attributes::new(), None, None, &d);
        assert_eq!((h.height_m, h.source), (10.0, HeightSource::Default));
    }

    /// OpenStreetMap's building:levels leaves the roof's levels out (Simple 3D Buildings): a height from it adds
    /// roof:levels; another storey attribute does not, nor does a height given in metres.
    #[test]
    fn roof_levels_stand_on_osm_building_levels() {
        let d = IngestOptions {
            storey_height_m: 3.0,
            ..Default::default()
        };
        let osm = |levels: &str, roof: &str| {
            attrs(&[
                (levels, AttrValue::String("3".into())),
                ("roof:levels", AttrValue::String(roof.into())),
            ])
        };
        for (a, want) in [
            (osm("building:levels", "1"), 12.0),
            (osm("building_levels", "2"), 15.0),
            (osm("building:levels", "0"), 9.0),
            // Not a count of roof levels: the building's levels alone.
            (osm("building:levels", "roof"), 9.0),
            (osm("building:levels", "500"), 9.0),
            (osm("stories", "1"), 9.0),
        ] {
            let h = resolve(&a, None, None, &d);
            assert_eq!(
                (h.height_m, h.source),
                (want, HeightSource::Storeys),
                "{a:?}"
            );
        }
        let mut a = osm("building:levels", "1");
        a.insert("height".into(), AttrValue::String("10".into()));
        assert_eq!(resolve(&a, None, None, &d).height_m, 10.0);
    }

    #[test]
    fn string_heights_with_units_parse() {
        let a = attrs(&[("height", AttrValue::String("28 m".into()))]);
        let h = resolve(&a, None, None, &IngestOptions::default());
        assert_eq!((h.height_m, h.source), (28.0, HeightSource::KnownAttribute));
    }

    #[test]
    fn absurd_and_non_positive_heights_fall_through_and_are_counted() {
        let a = attrs(&[
            ("height", AttrValue::Int(5000)),
            ("building:height", AttrValue::Int(0)),
            ("bldg_height", AttrValue::Float(1e-9)),
            ("Height", AttrValue::String("tall".into())),
            ("building:levels", AttrValue::String("3".into())),
        ]);
        let h = resolve(&a, None, None, &IngestOptions::default());
        assert_eq!((h.height_m, h.source), (9.0, HeightSource::Storeys));
        assert_eq!(
            h.rejected,
            vec!["height", "building:height", "Height", "bldg_height"]
        );
    }

    #[test]
    fn unusable_three_dbag_ground_and_roof_are_named() {
        let d = IngestOptions::default();
        // A ground far off any datum, or not a number: the footprint's ground instead, the attribute named; the
        // roof then has no ground to count from.
        for bad in [AttrValue::Float(1e5), AttrValue::String("abc".into())] {
            let a = attrs(&[
                ("b3_h_maaiveld", bad.clone()),
                ("b3_h_dak_70p", AttrValue::Float(12.0)),
            ]);
            let h = resolve(&a, Some(0.5), None, &d);
            assert_eq!(
                (h.ground_m, h.ground_source),
                (0.5, GroundSource::Geometry),
                "{bad:?}"
            );
            assert_eq!(h.source, HeightSource::Default, "{bad:?}");
            assert_eq!(h.rejected, ["b3_h_maaiveld", "b3_h_dak_70p"], "{bad:?}");
        }
        // A roof below its ground: the next rule, the roof named.
        let a = attrs(&[
            ("b3_h_maaiveld", AttrValue::Float(3.0)),
            ("b3_h_dak_70p", AttrValue::Float(1.0)),
            ("stories", AttrValue::Int(2)),
        ]);
        let h = resolve(&a, None, None, &d);
        assert_eq!((h.height_m, h.source), (6.0, HeightSource::Storeys));
        assert_eq!(h.rejected, ["b3_h_dak_70p"]);
        // A null ground is no value, not a bad one.
        let a = attrs(&[
            ("b3_h_maaiveld", AttrValue::Null),
            ("height", AttrValue::Int(9)),
        ]);
        assert!(resolve(&a, None, None, &d).rejected.is_empty());
    }

    #[test]
    fn three_dbag_roof_minus_ground_and_ground_attribute() {
        let a = attrs(&[
            ("b3_h_maaiveld", AttrValue::Float(-1.5)),
            ("b3_h_dak_70p", AttrValue::Float(10.5)),
        ]);
        let h = resolve(&a, Some(0.2), Some(12.0), &IngestOptions::default());
        assert_eq!(
            (h.height_m, h.source),
            (12.0, HeightSource::RoofMinusGround)
        );
        assert_eq!(
            (h.ground_m, h.ground_source),
            (-1.5, GroundSource::Attribute)
        );
    }

    #[test]
    fn geometry_top_gives_height_above_footprint_ground() {
        let h = resolve(
            &Attributes::new(),
            Some(2.0),
            Some(14.5),
            &IngestOptions::default(),
        );
        assert_eq!(
            (h.height_m, h.source, h.ground_m),
            (12.5, HeightSource::Geometry, 2.0)
        );
    }

    #[test]
    fn implausible_min_heights_are_rejected_and_reported() {
        let d = IngestOptions::default();
        for bad in [
            AttrValue::Float(-3.0),
            AttrValue::Float(5000.0),
            AttrValue::String("tall".into()),
        ] {
            let a = attrs(&[("height", AttrValue::Int(20)), ("min_height", bad.clone())]);
            let h = resolve(&a, None, None, &d);
            assert_eq!(h.base_offset_m, 0.0, "{bad:?}");
            assert_eq!(h.height_m, 20.0, "{bad:?}");
            assert_eq!(h.rejected, vec!["min_height".to_string()], "{bad:?}");
        }
        for ok in [AttrValue::Int(0), AttrValue::Null] {
            let a = attrs(&[("height", AttrValue::Int(20)), ("min_height", ok.clone())]);
            let h = resolve(&a, None, None, &d);
            assert_eq!((h.base_offset_m, h.rejected.len()), (0.0, 0), "{ok:?}");
        }
    }

    #[test]
    fn a_part_just_above_its_min_height_is_a_thin_slab_not_the_default() {
        let a = attrs(&[
            ("height", AttrValue::Int(10)),
            ("min_height", AttrValue::Float(9.95)),
        ]);
        let h = resolve(&a, None, None, &IngestOptions::default());
        assert_eq!(h.source, HeightSource::KnownAttribute);
        assert!((h.base_offset_m - 9.95).abs() < 1e-12);
        assert_eq!(h.height_m, MIN_HEIGHT_M);
        assert!(h.rejected.is_empty(), "{:?}", h.rejected);
    }

    #[test]
    fn a_base_at_or_above_the_height_is_dropped_and_the_part_stands_on_the_ground() {
        // The height is what the data says of the building; a base that contradicts it goes (reported), where it
        // used to stay and carry a default-height box floating above it.
        let o = IngestOptions::default();
        for (min, detail) in [
            (
                AttrValue::Int(10),
                "min_height = 10: a base of 10 m, not below the height 10 m",
            ),
            (
                AttrValue::String("30".into()),
                "min_height = \"30\": a base of 30 m, not below the height 10 m",
            ),
        ] {
            let a = attrs(&[("height", AttrValue::Int(10)), ("min_height", min)]);
            let h = resolve(&a, None, None, &o);
            assert_eq!(h.source, HeightSource::KnownAttribute);
            assert_eq!((h.base_offset_m, h.height_m), (0.0, 10.0));
            assert_eq!(h.rejected, ["min_height"]);
            assert!(
                h.rejected[0].detail.starts_with(detail),
                "{}",
                h.rejected[0].detail
            );
        }
        // Storeys alike: 2 levels with 5 skipped below.
        let a = attrs(&[
            ("building:levels", AttrValue::String("2".into())),
            ("building:min_level", AttrValue::String("5".into())),
        ]);
        let h = resolve(&a, None, None, &o);
        assert_eq!(
            (h.base_offset_m, h.height_m, h.source),
            (0.0, 6.0, HeightSource::Storeys)
        );
        assert_eq!(h.rejected, ["building:min_level"]);
    }

    #[test]
    fn rejected_values_say_what_they_held_and_why() {
        let o = IngestOptions::default();
        for (v, detail) in [
            (
                AttrValue::String("1,776".into()),
                "height = \"1,776\": a comma before three digits",
            ),
            (
                AttrValue::String("tall".into()),
                "height = \"tall\": not a number",
            ),
            (
                AttrValue::Float(0.09),
                "height = 0.09: 0.09 m, not a height between 0.1 and 1000 m",
            ),
            (
                AttrValue::Int(5000),
                "height = 5000: 5000 m, not a height between 0.1 and 1000 m",
            ),
            (AttrValue::Bool(true), "height = true: not a number"),
            // As the CityGML reader keeps a measuredHeight whose uom it does not know.
            (
                AttrValue::String("3 furlong".into()),
                "height = \"3 furlong\": a length in \"furlong\", a unit not known",
            ),
        ] {
            let h = resolve(&attrs(&[("height", v.clone())]), None, None, &o);
            assert_eq!(h.source, HeightSource::Default, "{v:?}");
            assert_eq!(h.rejected, ["height"], "{v:?}");
            assert!(
                h.rejected[0].detail.starts_with(detail),
                "{}",
                h.rejected[0].detail
            );
        }
        // A US height column in feet with thousands separators: the ambiguous value is not read as 1.776 ft.
        let feet = IngestOptions {
            height_unit_m: Some(0.3048),
            ..IngestOptions::default()
        };
        let h = resolve(
            &attrs(&[("height", AttrValue::String("1,776".into()))]),
            None,
            None,
            &feet,
        );
        assert_eq!(h.source, HeightSource::Default);
        let h = resolve(
            &attrs(&[("height", AttrValue::String("1776".into()))]),
            None,
            None,
            &feet,
        );
        assert!((h.height_m - 541.3248).abs() < 1e-9);
    }

    #[test]
    fn osm_min_height_raises_the_base_and_shortens_the_part() {
        let a = attrs(&[
            ("height", AttrValue::String("30".into())),
            ("min_height", AttrValue::String("12".into())),
        ]);
        let h = resolve(&a, None, None, &IngestOptions::default());
        assert_eq!((h.base_offset_m, h.height_m), (12.0, 18.0));
    }

    #[test]
    fn osm_heights_in_feet_and_inches_are_read() {
        let o = IngestOptions::default();
        for (v, m) in [
            ("100'", 30.48),
            ("16'4\"", 4.9784),
            ("35 ft", 10.668),
            ("12 feet", 3.6576),
            ("28 m", 28.0),
        ] {
            let h = resolve(
                &attrs(&[("height", AttrValue::String(v.into()))]),
                None,
                None,
                &o,
            );
            assert!((h.height_m - m).abs() < 1e-9, "{v}: {}", h.height_m);
            assert_eq!(h.source, HeightSource::KnownAttribute, "{v}");
        }
        let h = resolve(
            &attrs(&[
                ("height", AttrValue::String("60'".into())),
                ("min_height", AttrValue::String("20'".into())),
            ]),
            None,
            None,
            &o,
        );
        assert!((h.base_offset_m - 6.096).abs() < 1e-9 && (h.height_m - 12.192).abs() < 1e-9);
        for bad in ["ft", "'", "5'x\"", "1.2.3 ft", "-3'"] {
            let h = resolve(
                &attrs(&[("height", AttrValue::String(bad.into()))]),
                None,
                None,
                &o,
            );
            assert_eq!(h.source, HeightSource::Default, "{bad}");
        }
    }

    #[test]
    fn osm_min_level_raises_a_part_without_min_height_and_levels_count_from_the_ground() {
        let o = IngestOptions::default();
        // The top levels of a tower, 9 levels of 3 m above the ground, 8 of them below this part.
        let a = attrs(&[
            ("building:levels", AttrValue::String("9".into())),
            ("building:min_level", AttrValue::String("8".into())),
        ]);
        let h = resolve(&a, None, None, &o);
        assert_eq!((h.base_offset_m, h.height_m), (24.0, 3.0));
        // A height counts from the ground as well; min_height comes first when both are there.
        let a = attrs(&[
            ("height", AttrValue::String("29.3".into())),
            ("building:min_level", AttrValue::String("8".into())),
        ]);
        let h = resolve(&a, None, None, &o);
        assert_eq!(h.base_offset_m, 24.0);
        assert!((h.height_m - 5.3).abs() < 1e-9, "{}", h.height_m);
        let a = attrs(&[
            ("height", AttrValue::String("22".into())),
            ("min_height", AttrValue::String("19.9".into())),
            ("building:min_level", AttrValue::String("7".into())),
        ]);
        assert_eq!(resolve(&a, None, None, &o).base_offset_m, 19.9);
        // Not a number of levels: rejected, on the ground.
        let a = attrs(&[
            ("height", AttrValue::Int(10)),
            ("building:min_level", AttrValue::String("roof".into())),
        ]);
        let h = resolve(&a, None, None, &o);
        assert_eq!(h.base_offset_m, 0.0);
        assert_eq!(h.rejected, vec!["building:min_level".to_string()]);
    }
}
