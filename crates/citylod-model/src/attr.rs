//! Feature attributes as read from the input (GeoJSON properties, CityJSON attributes), kept sorted by
//! name so every output that lists them is deterministic.

/// One attribute value. Nested JSON objects and arrays are kept as their compact JSON text.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum AttrValue {
    Null,
    Bool(bool),
    Int(i64),
    Float(f64),
    String(String),
}

/// Attribute name → value, sorted by name, each name once (a later value for a name replaces the earlier one, as in
/// a map). A sorted list rather than a `BTreeMap`: a building has a handful of attributes, and a map node costs
/// ~630 bytes even for two — half a gigabyte for a million buildings.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Attributes(Vec<(String, AttrValue)>);

impl Attributes {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn len(&self) -> usize {
        self.0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    fn find(&self, name: &str) -> Result<usize, usize> {
        self.0.binary_search_by(|(k, _)| k.as_str().cmp(name))
    }

    /// The value of attribute `name`, if the feature has it.
    pub fn get(&self, name: &str) -> Option<&AttrValue> {
        self.find(name).ok().map(|i| &self.0[i].1)
    }

    /// Sets attribute `name`; returns the value it replaces.
    pub fn insert(&mut self, name: String, value: AttrValue) -> Option<AttrValue> {
        match self.find(&name) {
            Ok(i) => Some(std::mem::replace(&mut self.0[i].1, value)),
            Err(i) => {
                self.0.insert(i, (name, value));
                None
            }
        }
    }

    /// (name, value) pairs sorted by name.
    pub fn iter(&self) -> AttributesIter<'_> {
        self.0.iter().map(|(k, v)| (k, v))
    }

    pub fn keys(&self) -> impl Iterator<Item = &String> {
        self.0.iter().map(|(k, _)| k)
    }

    pub fn values(&self) -> impl Iterator<Item = &AttrValue> {
        self.0.iter().map(|(_, v)| v)
    }
}

/// The iterator of [`Attributes::iter`].
pub type AttributesIter<'a> = std::iter::Map<
    std::slice::Iter<'a, (String, AttrValue)>,
    fn(&'a (String, AttrValue)) -> (&'a String, &'a AttrValue),
>;

impl FromIterator<(String, AttrValue)> for Attributes {
    fn from_iter<I: IntoIterator<Item = (String, AttrValue)>>(iter: I) -> Self {
        let mut v: Vec<(String, AttrValue)> = iter.into_iter().collect();
        // Stable, so among equal names the last given comes last; keep that one.
        v.sort_by(|a, b| a.0.cmp(&b.0));
        let mut out: Vec<(String, AttrValue)> = Vec::with_capacity(v.len());
        for pair in v {
            match out.last_mut() {
                Some(last) if last.0 == pair.0 => *last = pair,
                _ => out.push(pair),
            }
        }
        Attributes(out)
    }
}

impl<'a> IntoIterator for &'a Attributes {
    type Item = (&'a String, &'a AttrValue);
    type IntoIter = AttributesIter<'a>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl std::ops::Index<&str> for Attributes {
    type Output = AttrValue;
    /// Panics when the attribute is missing, like a map's index; use [`Attributes::get`] otherwise.
    fn index(&self, name: &str) -> &AttrValue {
        self.get(name).expect("no attribute of that name")
    }
}

impl AttrValue {
    /// The value as a number if it is one, or a string that starts with one (`"28"`, `"28 m"`, `"12.5m"`).
    pub fn as_number(&self) -> Option<f64> {
        match self {
            AttrValue::Int(i) => Some(*i as f64),
            AttrValue::Float(f) if f.is_finite() => Some(*f),
            AttrValue::String(s) => parse_leading_number(s),
            _ => None,
        }
    }
}

/// Parses the number a string starts with, ignoring surrounding blanks and a trailing unit such as `m`.
/// Accepts a decimal comma (`"12,5"`). Returns `None` for an empty or non-numeric string, and for one whose only
/// comma stands before exactly three digits (`"1,776"`, [`ambiguous_comma`]).
pub fn parse_leading_number(s: &str) -> Option<f64> {
    let t = s.trim();
    let end = number_end(t);
    if comma_before_three_digits(&t[..end]) {
        return None;
    }
    let num = t[..end].replace(',', ".");
    let rest = t[end..].trim().to_ascii_lowercase();
    if !(rest.is_empty()
        || rest == "m"
        || rest == "meter"
        || rest == "meters"
        || rest == "metre"
        || rest == "metres")
    {
        return None;
    }
    num.parse::<f64>().ok().filter(|v| v.is_finite())
}

fn number_end(t: &str) -> usize {
    t.char_indices()
        .find(|&(i, c)| {
            !(c.is_ascii_digit() || c == '.' || c == ',' || ((c == '-' || c == '+') && i == 0))
        })
        .map(|(i, _)| i)
        .unwrap_or(t.len())
}

/// True when the number a string starts with has one comma, no point, and exactly three digits after the comma
/// (`"1,776"`, `"12,500 m"`): a thousands separator in US data, a decimal comma in European data. Neither reading
/// is safe (One World Trade Center's 1,776 ft would become a 54 cm slab), so such text is not read as a number.
pub fn ambiguous_comma(s: &str) -> bool {
    let t = s.trim();
    comma_before_three_digits(&t[..number_end(t)])
}

/// [`ambiguous_comma`] of the number's own characters.
fn comma_before_three_digits(n: &str) -> bool {
    let Some((_, after)) = n.split_once(',') else {
        return false;
    };
    !n.contains('.') && after.len() == 3 && after.bytes().all(|b| b.is_ascii_digit())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attributes_are_sorted_unique_and_the_last_value_wins() {
        let a: Attributes = [
            ("roof".to_string(), AttrValue::Int(1)),
            ("height".to_string(), AttrValue::Float(12.5)),
            ("roof".to_string(), AttrValue::Int(2)),
            ("addr".to_string(), AttrValue::Null),
        ]
        .into_iter()
        .collect();
        assert_eq!(
            a.keys().map(String::as_str).collect::<Vec<_>>(),
            ["addr", "height", "roof"]
        );
        assert_eq!(a.get("roof"), Some(&AttrValue::Int(2)));
        assert_eq!(a["height"], AttrValue::Float(12.5));
        assert_eq!(a.get("nope"), None);
        let mut b = a.clone();
        assert_eq!(
            b.insert("roof".into(), AttrValue::Int(3)),
            Some(AttrValue::Int(2))
        );
        assert_eq!(b.insert("base".into(), AttrValue::Bool(true)), None);
        let pairs: Vec<(&str, &AttrValue)> = b.iter().map(|(k, v)| (k.as_str(), v)).collect();
        assert_eq!(
            pairs,
            [
                ("addr", &AttrValue::Null),
                ("base", &AttrValue::Bool(true)),
                ("height", &AttrValue::Float(12.5)),
                ("roof", &AttrValue::Int(3)),
            ]
        );
        assert_eq!((b.len(), Attributes::new().is_empty()), (4, true));
    }

    #[test]
    fn heights_as_strings_parse() {
        assert_eq!(parse_leading_number("28"), Some(28.0));
        assert_eq!(parse_leading_number(" 28 m"), Some(28.0));
        assert_eq!(parse_leading_number("12,5m"), Some(12.5));
        assert_eq!(parse_leading_number("abc"), None);
        assert_eq!(parse_leading_number(""), None);
        assert_eq!(parse_leading_number("30 ft"), None);
        // A comma before exactly three digits may separate thousands or decimals: not read either way.
        for t in ["1,776", "1,250", " 12,500 m", "-1,000"] {
            assert!(ambiguous_comma(t), "{t}");
            assert_eq!(parse_leading_number(t), None, "{t}");
        }
        for (t, v) in [
            ("1,7", 1.7),
            ("12,50", 12.5),
            ("1,7765", 1.7765),
            ("1.776", 1.776),
        ] {
            assert!(!ambiguous_comma(t), "{t}");
            assert_eq!(parse_leading_number(t), Some(v), "{t}");
        }
        assert_eq!(AttrValue::String("7.5".into()).as_number(), Some(7.5));
        assert_eq!(AttrValue::Float(f64::NAN).as_number(), None);
    }
}
