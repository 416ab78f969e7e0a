//! Which level of detail of a CityJSON building becomes its 3D mesh. CityJSON writes `lod` as a
//! string ("1.2", "2.2", CityJSON 1.1+) or a number (2, 2.2 in 0.8/1.0 files); LoDs order as
//! (major, minor) with a bare "2" read as 2.0 in a file. Asked for, "2.2" means exactly 2.2 and "2"
//! means the highest 2.x present; a building without it falls back to its highest LoD below.

use serde_json::Value;
use std::str::FromStr;

/// Which LoD of a CityJSON building's 3D geometry becomes its mesh ([`crate::IngestOptions::lod`]).
/// Only geometries of LoD ≥ 1 count (LoD0 is the footprint). A building whose parts lack the LoD
/// use their highest LoD below it; that is counted in `IngestReport::mesh_lod_fallbacks`.
///
/// ```
/// use citylod_ingest::LodChoice;
/// assert_eq!("highest".parse::<LodChoice>(), Ok(LodChoice::Highest));
/// assert_eq!("2.2".parse::<LodChoice>(), Ok(LodChoice::Exact("2.2".into())));
/// assert!("0".parse::<LodChoice>().is_err() && "roof".parse::<LodChoice>().is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LodChoice {
    /// The highest LoD the building (with its parts) has.
    Highest,
    /// A CityJSON LoD as text: `"2.2"` is exactly LoD 2.2, `"2"` the highest 2.x present.
    Exact(String),
}

impl FromStr for LodChoice {
    type Err = String;

    /// `highest` (any case) or an LoD of 1 or more such as `1.2`, `2`, `2.2`.
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        if s.eq_ignore_ascii_case("highest") {
            return Ok(LodChoice::Highest);
        }
        Target::of(&LodChoice::Exact(s.to_string()))?;
        Ok(LodChoice::Exact(s.to_string()))
    }
}

impl std::fmt::Display for LodChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LodChoice::Highest => f.write_str("highest"),
            LodChoice::Exact(s) => f.write_str(s.trim()),
        }
    }
}

/// An LoD in a file, ordered as (major, minor); "2" is (2, 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct LodKey {
    major: u8,
    minor: u8,
}

impl LodKey {
    /// LoD 1.0, the lowest LoD that is a 3D model.
    pub const ONE: LodKey = LodKey { major: 1, minor: 0 };
    /// LoD 2: a roof's shape (OpenStreetMap's `roof:shape` modelled by `roofs`).
    pub const TWO: LodKey = LodKey { major: 2, minor: 0 };
}

/// `"2.2"` → (2, Some(2)), `"2"` → (2, None); `None` for anything else.
fn parse(text: &str) -> Option<(u8, Option<u8>)> {
    let digits = |t: &str| -> Option<u8> {
        (!t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()))
            .then(|| t.parse().ok())
            .flatten()
    };
    match text.trim().split_once('.') {
        Some((a, b)) => Some((digits(a)?, Some(digits(b)?))),
        None => Some((digits(text.trim())?, None)),
    }
}

/// A geometry's LoD as a key and as the source writes it; `None` without a readable `lod`.
pub(crate) fn lod_of_geometry(g: &Value) -> Option<(LodKey, String)> {
    let text = match g.get("lod")? {
        Value::String(s) => s.trim().to_string(),
        Value::Number(n) => n.to_string(),
        _ => return None,
    };
    let (major, minor) = parse(&text)?;
    Some((
        LodKey {
            major,
            minor: minor.unwrap_or(0),
        },
        text,
    ))
}

/// A validated [`LodChoice`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Target {
    Highest,
    /// Any LoD with this major number, the highest present.
    Family(u8),
    Exact(LodKey),
}

impl Target {
    pub fn of(choice: &LodChoice) -> Result<Target, String> {
        let s = match choice {
            LodChoice::Highest => return Ok(Target::Highest),
            LodChoice::Exact(s) => s,
        };
        match parse(s) {
            Some((0, _)) => Err(format!(
                "LoD {s:?}: LoD 0 is a footprint, not a 3D model; ask for 1, 1.2, 2, 2.2, … or highest"
            )),
            Some((major, None)) => Ok(Target::Family(major)),
            Some((major, Some(minor))) => Ok(Target::Exact(LodKey { major, minor })),
            None => Err(format!(
                "{s:?} is not an LoD (expected e.g. 1.2, 2, 2.2 or highest)"
            )),
        }
    }

    /// The LoD to use among `present` (an object's LoDs ≥ 1), and whether it is below the target.
    /// `Highest` must be resolved per building first ([`Target::for_building`]); alone it takes the
    /// highest. `None` when every LoD present is above the target.
    pub fn pick(self, present: &[LodKey]) -> Option<(LodKey, bool)> {
        let best_where = |f: &dyn Fn(&LodKey) -> bool| present.iter().copied().filter(f).max();
        match self {
            Target::Highest => best_where(&|_| true).map(|k| (k, false)),
            Target::Family(m) => best_where(&|k| k.major == m)
                .map(|k| (k, false))
                .or_else(|| best_where(&|k| k.major < m).map(|k| (k, true))),
            Target::Exact(t) => best_where(&|k| *k == t)
                .map(|k| (k, false))
                .or_else(|| best_where(&|k| *k < t).map(|k| (k, true))),
        }
    }

    /// `Highest` becomes the highest LoD among all of a building's objects; others stay.
    pub fn for_building(self, all_present: &[LodKey]) -> Target {
        match self {
            Target::Highest => all_present
                .iter()
                .max()
                .map_or(Target::Highest, |k| Target::Exact(*k)),
            t => t,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn key(s: &str) -> LodKey {
        lod_of_geometry(&json!({ "lod": s })).unwrap().0
    }

    #[test]
    fn string_and_number_lods_order_numerically() {
        let (k2, text) = lod_of_geometry(&json!({"lod": 2})).unwrap();
        assert_eq!(text, "2");
        assert_eq!(k2, key("2.0"));
        assert!(key("1.2") < key("1.3") && key("1.3") < k2 && k2 < key("2.2"));
        assert_eq!(
            lod_of_geometry(&json!({"lod": 2.2})).unwrap(),
            (key("2.2"), "2.2".into())
        );
        for bad in [
            json!({"lod": "x"}),
            json!({"lod": "-1"}),
            json!({}),
            json!({"lod": [2]}),
        ] {
            assert_eq!(lod_of_geometry(&bad), None, "{bad}");
        }
    }

    #[test]
    fn exact_lod_falls_back_to_the_highest_below_never_above() {
        let present = [key("1.2"), key("1.3"), key("2.2")];
        let t = |s: &str| Target::of(&LodChoice::Exact(s.into())).unwrap();
        assert_eq!(t("2.2").pick(&present), Some((key("2.2"), false)));
        assert_eq!(t("2.1").pick(&present), Some((key("1.3"), true)));
        assert_eq!(t("3").pick(&present), Some((key("2.2"), true)));
        assert_eq!(t("2").pick(&present), Some((key("2.2"), false)));
        assert_eq!(t("1").pick(&present), Some((key("1.3"), false)));
        assert_eq!(t("1.1").pick(&present), None);
        assert_eq!(t("2.2").pick(&[key("2")]), Some((key("2"), true)));
    }

    #[test]
    fn highest_is_resolved_per_building_so_lagging_parts_count_as_fallbacks() {
        let all = [key("1.2"), key("2.2")];
        let t = Target::Highest.for_building(&all);
        assert_eq!(t.pick(&[key("2.2")]), Some((key("2.2"), false)));
        assert_eq!(t.pick(&[key("1.2")]), Some((key("1.2"), true)));
        assert_eq!(Target::Highest.for_building(&[]), Target::Highest);
    }

    #[test]
    fn asking_for_lod0_or_garbage_is_an_error() {
        for bad in ["0", "0.1", "", "two", "2.", ".2", "2.2.2", "-2"] {
            assert!(bad.parse::<LodChoice>().is_err(), "{bad:?}");
        }
        assert_eq!(" Highest ".parse::<LodChoice>(), Ok(LodChoice::Highest));
        assert_eq!(LodChoice::Exact("1.3".into()).to_string(), "1.3");
    }
}
