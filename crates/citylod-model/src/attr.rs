//! Feature attributes as read from the input (GeoJSON properties, CityJSON attributes), kept in a
//! sorted map so every output that lists them is deterministic.

use std::collections::BTreeMap;

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

/// Attribute name → value, sorted by name.
pub type Attributes = BTreeMap<String, AttrValue>;

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
/// Accepts a decimal comma (`"12,5"`). Returns `None` for an empty or non-numeric string.
pub fn parse_leading_number(s: &str) -> Option<f64> {
    let t = s.trim();
    let end = t
        .char_indices()
        .find(|&(i, c)| {
            !(c.is_ascii_digit() || c == '.' || c == ',' || ((c == '-' || c == '+') && i == 0))
        })
        .map(|(i, _)| i)
        .unwrap_or(t.len());
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heights_as_strings_parse() {
        assert_eq!(parse_leading_number("28"), Some(28.0));
        assert_eq!(parse_leading_number(" 28 m"), Some(28.0));
        assert_eq!(parse_leading_number("12,5m"), Some(12.5));
        assert_eq!(parse_leading_number("abc"), None);
        assert_eq!(parse_leading_number(""), None);
        assert_eq!(parse_leading_number("30 ft"), None);
        assert_eq!(AttrValue::String("7.5".into()).as_number(), Some(7.5));
        assert_eq!(AttrValue::Float(f64::NAN).as_number(), None);
    }
}
