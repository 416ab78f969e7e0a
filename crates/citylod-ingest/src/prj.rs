//! The CRS of a shapefile's `.prj`: OGC WKT 1 / WKT 2 naming its EPSG code, or — what ArcGIS writes — Esri WKT with
//! no code at all, identified by comparing its projection, parameters, linear unit and ellipsoid with every CRS of
//! the offline EPSG table (as `gdalsrsinfo -e` or PROJ's `identify` do). An identified code is said in the file's
//! report notes; a `.prj` that matches no CRS, or CRSs on different datums, is refused with a request for `--crs`.

use crate::crs::DeclaredCrs;

/// A WKT node: `KEY[arg, …]`.
#[derive(Debug, Clone, PartialEq)]
struct Node {
    key: String,
    args: Vec<Arg>,
}

#[derive(Debug, Clone, PartialEq)]
enum Arg {
    Text(String),
    Number(f64),
    /// A bare word (`EAST`, `Cartesian`).
    Word(String),
    Node(Node),
}

impl Node {
    fn child(&self, key: &str) -> Option<&Node> {
        self.children().find(|n| n.key == key)
    }

    fn children(&self) -> impl Iterator<Item = &Node> {
        self.args.iter().filter_map(|a| match a {
            Arg::Node(n) => Some(n),
            _ => None,
        })
    }

    fn name(&self) -> &str {
        match self.args.first() {
            Some(Arg::Text(t)) => t,
            _ => "",
        }
    }

    fn number(&self, i: usize) -> Option<f64> {
        match self.args.get(i)? {
            Arg::Number(x) => Some(*x),
            _ => None,
        }
    }
}

/// Parses WKT (either bracket style): one node, which an Esri vertical CRS may follow; `None` when it is not WKT.
/// Nesting is limited (a `.prj` is a few levels deep).
fn parse(s: &str) -> Option<Node> {
    parse_node(s, true)
}

/// The node `s` starts with: with `whole`, only when nothing but Esri's trailing `VERTCS` follows it.
fn parse_node(s: &str, whole: bool) -> Option<Node> {
    struct P<'a> {
        b: &'a [u8],
        at: usize,
    }
    impl P<'_> {
        fn skip(&mut self) {
            while self.at < self.b.len() && self.b[self.at].is_ascii_whitespace() {
                self.at += 1;
            }
        }
        fn node(&mut self, depth: usize) -> Option<Node> {
            if depth > 16 {
                return None;
            }
            self.skip();
            let start = self.at;
            while self.at < self.b.len()
                && (self.b[self.at].is_ascii_alphanumeric() || self.b[self.at] == b'_')
            {
                self.at += 1;
            }
            let key = std::str::from_utf8(&self.b[start..self.at])
                .ok()?
                .to_ascii_uppercase();
            self.skip();
            let close = match self.b.get(self.at)? {
                b'[' => b']',
                b'(' => b')',
                _ => return None,
            };
            self.at += 1;
            let mut args = Vec::new();
            loop {
                self.skip();
                match *self.b.get(self.at)? {
                    c if c == close && args.is_empty() => {
                        self.at += 1;
                        break;
                    }
                    b'"' => {
                        let from = self.at + 1;
                        let len = self.b[from..].iter().position(|&c| c == b'"')?;
                        args.push(Arg::Text(
                            String::from_utf8_lossy(&self.b[from..from + len]).into_owned(),
                        ));
                        self.at = from + len + 1;
                    }
                    c if c == b'-' || c == b'+' || c == b'.' || c.is_ascii_digit() => {
                        let from = self.at;
                        while self.at < self.b.len()
                            && (self.b[self.at].is_ascii_digit()
                                || b"+-.eE".contains(&self.b[self.at]))
                        {
                            self.at += 1;
                        }
                        let t = std::str::from_utf8(&self.b[from..self.at]).ok()?;
                        args.push(Arg::Number(t.parse().ok()?));
                    }
                    _ => {
                        let save = self.at;
                        match self.node(depth + 1) {
                            Some(n) => args.push(Arg::Node(n)),
                            None => {
                                self.at = save;
                                let from = self.at;
                                while self.at < self.b.len()
                                    && (self.b[self.at].is_ascii_alphanumeric()
                                        || self.b[self.at] == b'_')
                                {
                                    self.at += 1;
                                }
                                if self.at == from {
                                    return None;
                                }
                                args.push(Arg::Word(
                                    String::from_utf8_lossy(&self.b[from..self.at]).into_owned(),
                                ));
                            }
                        }
                    }
                }
                self.skip();
                match *self.b.get(self.at)? {
                    b',' => self.at += 1,
                    c if c == close => {
                        self.at += 1;
                        break;
                    }
                    _ => return None,
                }
            }
            Some(Node { key, args })
        }
    }
    let mut p = P {
        b: s.as_bytes(),
        at: 0,
    };
    let n = p.node(0)?;
    if !whole {
        return Some(n);
    }
    p.skip();
    // Esri writes a vertical CRS after the horizontal one: `PROJCS[…],VERTCS[…]` (see `vertical_unit_m`).
    while p.b.get(p.at) == Some(&b',') {
        p.at += 1;
        if p.node(0)?.key != "VERTCS" {
            return None;
        }
        p.skip();
    }
    (p.at == p.b.len()).then_some(n)
}

/// Metres per unit a length unit may have: from the millimetre to past the league and the nautical mile. A vertical
/// unit outside (a damaged `.prj`'s 1e7 m) would make every model thousands of kilometres tall.
const LENGTH_UNIT_M: std::ops::RangeInclusive<f64> = 1e-3..=1e4;

/// Metres per unit of z when the WKT declares a vertical CRS: Esri's `VERTCS[…]` after the horizontal CRS, or a
/// `VERT_CS`/`VERTCRS` inside a compound one, by its `UNIT` (`LENGTHUNIT`); with a note when it declares one whose
/// unit is not a length (z is then taken as without a vertical CRS).
pub(crate) fn vertical_unit_m(wkt: &str) -> (Option<f64>, Option<String>) {
    let upper = wkt.to_ascii_uppercase();
    let Some(at) = ["VERTCS[", "VERT_CS[", "VERTCRS["]
        .iter()
        .filter_map(|k| upper.find(k))
        .min()
    else {
        return (None, None);
    };
    let unit = parse_node(&wkt[at..], false).and_then(|n| {
        n.children()
            .filter(|c| c.key == "UNIT" || c.key == "LENGTHUNIT")
            .last()
            .map(|u| u.args.get(1).cloned())
    });
    match unit {
        Some(Some(Arg::Number(x))) if LENGTH_UNIT_M.contains(&x) => (Some(x), None),
        Some(Some(Arg::Number(x))) => (
            None,
            Some(format!(
                "its vertical CRS gives {x} m per unit of z, which is no length unit (from {} to {} m): z is read \
                 as without a vertical CRS, in the horizontal unit",
                LENGTH_UNIT_M.start(),
                LENGTH_UNIT_M.end()
            )),
        ),
        Some(_) => (
            None,
            Some(
                "its vertical CRS's unit gives no number of metres: z is read as without a vertical CRS, in the \
                 horizontal unit"
                    .to_string(),
            ),
        ),
        None => (None, None),
    }
}

/// Letters and digits of a name, upper case: `North_American_Datum_1983` → `NORTHAMERICANDATUM1983`.
fn key(name: &str) -> String {
    name.chars()
        .filter(|c| c.is_ascii_alphanumeric())
        .collect::<String>()
        .to_ascii_uppercase()
}

/// A datum's name as both dialects can agree on it: Esri's `D_` prefix and the word `DATUM` dropped, and Esri's
/// short names of common datums spelled out as the EPSG table has them.
fn datum_key(name: &str) -> String {
    let n = name.strip_prefix("D_").unwrap_or(name);
    let k = key(n).replace("DATUM", "");
    let spelled = match k.as_str() {
        "ETRS1989" => "EUROPEANTERRESTRIALREFERENCESYSTEM1989",
        "GDA1994" => "GEOCENTRICOFAUSTRALIA1994",
        "GDA2020" => "GEOCENTRICOFAUSTRALIA2020",
        "NORTHAMERICAN1983HARN" | "NAD1983HARN" => "NAD83HIGHACCURACYREFERENCENETWORK",
        "NORTHAMERICAN1983CSRS" | "NAD1983CSRS" => "NAD83CANADIANSPATIALREFERENCESYSTEM",
        "NORTHAMERICAN1983NSRS2007" | "NAD1983NSRS2007" => {
            "NAD83NATIONALSPATIALREFERENCESYSTEM2007"
        }
        "NORTHAMERICAN19832011" | "NAD19832011" => "NAD83NATIONALSPATIALREFERENCESYSTEM2011",
        _ => return k,
    };
    spelled.to_string()
}

/// The words of a CRS name, upper case, for telling apart codes that transform alike.
fn words(name: &str) -> Vec<String> {
    name.split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
        .map(|w| w.to_ascii_uppercase())
        .collect()
}

/// The map projections compared; others are not identified.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Family {
    TransverseMercator,
    LambertConic2,
    LambertConic1,
    Stereographic,
    Mercator,
    Albers,
    LambertAzimuthal,
}

/// What decides where a projected CRS puts a point: projection, its parameters (angles in degrees, false easting
/// and northing in metres, scale), the linear unit in metres, the ellipsoid (semi-major axis, inverse flattening).
#[derive(Debug, Clone, PartialEq)]
struct Projected {
    family: Family,
    params: Vec<f64>,
    unit_m: f64,
    ellipsoid: [f64; 2],
    datum: String,
}

/// The ellipsoid and datum name of a GEOGCS node.
fn geographic(g: &Node) -> Option<([f64; 2], String)> {
    let datum = g.child("DATUM")?;
    let sph = datum
        .child("SPHEROID")
        .or_else(|| datum.child("ELLIPSOID"))?;
    // A prime meridian other than Greenwich shifts every longitude, an angular unit other than the degree (grads)
    // scales them: not compared, so not identified.
    if let Some(pm) = g.child("PRIMEM") {
        if pm.number(1)? != 0.0 {
            return None;
        }
    }
    if let Some(unit) = g.child("UNIT").or_else(|| g.child("ANGLEUNIT")) {
        if (unit.number(1)? - std::f64::consts::PI / 180.0).abs() > 1e-12 {
            return None;
        }
    }
    Some(([sph.number(1)?, sph.number(2)?], datum_key(datum.name())))
}

/// A PROJCS node (Esri or OGC WKT 1) as the figures that decide it.
fn projected(n: &Node) -> Option<Projected> {
    if n.key != "PROJCS" {
        return None;
    }
    let (ellipsoid, datum) = geographic(n.child("GEOGCS")?)?;
    let projection = key(n.child("PROJECTION")?.name());
    let unit_m = n.children().filter(|c| c.key == "UNIT").last()?.number(1)?;
    let mut p = std::collections::BTreeMap::new();
    for c in n.children().filter(|c| c.key == "PARAMETER") {
        let name = match key(c.name()).as_str() {
            "FALSEEASTING" => "fe",
            "FALSENORTHING" => "fn",
            "CENTRALMERIDIAN" | "LONGITUDEOFCENTER" | "LONGITUDEOFORIGIN" => "lon0",
            "LATITUDEOFORIGIN" | "LATITUDEOFCENTER" => "lat0",
            "SCALEFACTOR" => "k",
            "STANDARDPARALLEL1" => "sp1",
            "STANDARDPARALLEL2" => "sp2",
            _ => return None,
        };
        p.insert(name, c.number(1)?);
    }
    let get = |k: &str, default: f64| p.get(k).copied().unwrap_or(default);
    let (fe, fn_) = (get("fe", 0.0) * unit_m, get("fn", 0.0) * unit_m);
    let (lat0, lon0, k) = (get("lat0", 0.0), get("lon0", 0.0), get("k", 1.0));
    let (family, params) = match projection.as_str() {
        "TRANSVERSEMERCATOR" | "GAUSSKRUGER" => {
            (Family::TransverseMercator, vec![lat0, lon0, k, fe, fn_])
        }
        "LAMBERTCONFORMALCONIC" | "LAMBERTCONFORMALCONIC2SP" | "LAMBERTCONFORMALCONIC1SP" => {
            match (p.get("sp1"), p.get("sp2")) {
                (Some(&a), Some(&b)) if (a - b).abs() > 1e-9 && (k - 1.0).abs() < 1e-12 => (
                    Family::LambertConic2,
                    vec![a.min(b), a.max(b), lat0, lon0, fe, fn_],
                ),
                // One standard parallel at the latitude of origin, with a scale there (EPSG's 1SP; an Esri .prj
                // may give the parallel, the origin or both).
                (sp1, _)
                    if sp1.is_none_or(|&a| !p.contains_key("lat0") || (a - lat0).abs() <= 1e-9) =>
                {
                    (
                        Family::LambertConic1,
                        vec![sp1.copied().unwrap_or(lat0), lon0, k, fe, fn_],
                    )
                }
                // Two equal standard parallels away from the origin: a tangent cone whose origin is elsewhere,
                // compared as a 2SP with equal parallels.
                (sp1, _) => {
                    let a = sp1.copied().unwrap_or(lat0);
                    (Family::LambertConic2, vec![a, a, lat0, lon0, fe, fn_])
                }
            }
        }
        "DOUBLESTEREOGRAPHIC" | "OBLIQUESTEREOGRAPHIC" => {
            (Family::Stereographic, vec![lat0, lon0, k, fe, fn_])
        }
        "MERCATOR" | "MERCATOR1SP" | "MERCATOR2SP" => {
            (Family::Mercator, vec![get("sp1", 0.0), lon0, k, fe, fn_])
        }
        "ALBERS" | "ALBERSCONICEQUALAREA" => {
            let (a, b) = (get("sp1", 0.0), get("sp2", 0.0));
            (
                Family::Albers,
                vec![a.min(b), a.max(b), lat0, lon0, fe, fn_],
            )
        }
        "LAMBERTAZIMUTHALEQUALAREA" => (Family::LambertAzimuthal, vec![lat0, lon0, fe, fn_]),
        _ => return None,
    };
    Some(Projected {
        family,
        params,
        unit_m,
        ellipsoid,
        datum,
    })
}

/// Whether two projected CRSs put every point in the same place (within about 0.1 m).
fn same_projection(a: &Projected, b: &Projected) -> bool {
    // Angles and scales to 1e-6 (an angle of 1e-6° is ~0.1 m; .prj files written with six decimals differ from the
    // table by that much), false eastings and northings (over 1 km) to 1 mm.
    a.family == b.family
        && a.params.len() == b.params.len()
        && a.params
            .iter()
            .zip(&b.params)
            .all(|(x, y)| close(*x, *y, 1e-6))
        && (a.unit_m - b.unit_m).abs() <= 1e-9 * a.unit_m
        && same_ellipsoid(a.ellipsoid, b.ellipsoid)
}

/// Whether two parameters agree: within 1 mm for values over 1 km (false eastings and northings in metres), else
/// within `small` (angles in degrees, scales).
fn close(x: f64, y: f64, small: f64) -> bool {
    (x - y).abs()
        <= if x.abs().max(y.abs()) > 1e3 {
            1e-3
        } else {
            small
        }
}

fn same_ellipsoid(a: [f64; 2], b: [f64; 2]) -> bool {
    (a[0] - b[0]).abs() <= 1e-3 && (a[1] - b[1]).abs() <= 1e-6
}

/// Whether two proj4 strings stand for one transformation: the same keys, numbers equal within a millimetre or
/// 1e-8 (`+x_0=800000` and `+x_0=800000.0000101601`), other values equal, after [`transform_key`].
fn same_transform(a: &str, b: &str) -> bool {
    let (a, b) = (transform_key(a), transform_key(b));
    let split = |s: &str| -> Vec<(String, String)> {
        s.split_whitespace()
            .map(|t| match t.split_once('=') {
                Some((k, v)) => (k.to_string(), v.to_string()),
                None => (t.to_string(), String::new()),
            })
            .collect()
    };
    let (a, b) = (split(&a), split(&b));
    let nums = |v: &str| {
        v.split(',')
            .map(str::parse::<f64>)
            .collect::<Result<Vec<_>, _>>()
    };
    a.len() == b.len()
        && a.iter().zip(&b).all(|((ka, va), (kb, vb))| {
            ka == kb
                && (va == vb
                    || matches!((nums(va), nums(vb)), (Ok(x), Ok(y)) if x.len() == y.len()
                        && x.iter().zip(&y).all(|(x, y)| close(*x, *y, 1e-8))))
        })
}

/// The transformation a proj4 string stands for, with the spellings of one datum made alike
/// (`+datum=NAD83` is `+ellps=GRS80 +towgs84=0,0,0`; no datum shift at all is a zero shift), sorted by key.
fn transform_key(proj4: &str) -> String {
    let mut tokens: Vec<String> = Vec::new();
    for t in proj4.split_whitespace() {
        match t {
            "+no_defs" | "+type=crs" | "+wktext" => {}
            "+datum=NAD83" => {
                tokens.extend(["+ellps=GRS80".to_string(), "+towgs84=0,0,0".to_string()])
            }
            "+datum=WGS84" => {
                tokens.extend(["+ellps=WGS84".to_string(), "+towgs84=0,0,0".to_string()])
            }
            t if t.starts_with("+towgs84=") => {
                let v: Vec<&str> = t["+towgs84=".len()..].split(',').collect();
                let all_zero = v.iter().all(|x| x.parse::<f64>().is_ok_and(|f| f == 0.0));
                tokens.push(if all_zero {
                    "+towgs84=0,0,0".to_string()
                } else {
                    t.to_string()
                });
            }
            t => tokens.push(t.to_string()),
        }
    }
    // An ellipsoid with no shift and no grid: proj4rs applies none, as for a zero shift.
    let shifted = tokens.iter().any(|t| {
        t.starts_with("+towgs84=") || t.starts_with("+nadgrids=") || t.starts_with("+datum=")
    });
    if !shifted
        && tokens
            .iter()
            .any(|t| t.starts_with("+ellps=") || t.starts_with("+a="))
    {
        tokens.push("+towgs84=0,0,0".to_string());
    }
    tokens.sort();
    tokens.join(" ")
}

/// The EPSG codes of the offline table whose definitions put every point of `wkt` where it does.
fn candidates(target: &Node) -> Vec<crs_definitions::Def> {
    let projected_target = projected(target);
    let geographic_target = (target.key == "GEOGCS")
        .then(|| geographic(target))
        .flatten();
    let mut out = Vec::new();
    for code in 1..=u16::MAX {
        let Some(def) = crs_definitions::from_code(code) else {
            continue;
        };
        match (&projected_target, &geographic_target) {
            (Some(t), _) if def.wkt.starts_with("PROJCS[") => {
                if let Some(d) = parse(def.wkt).as_ref().and_then(projected) {
                    if same_projection(t, &d) {
                        out.push(def);
                    }
                }
            }
            (None, Some((ellipsoid, datum))) if def.wkt.starts_with("GEOGCS[") => {
                let Some(g) = parse(def.wkt) else { continue };
                if let Some((e, d)) = geographic(&g) {
                    if same_ellipsoid(*ellipsoid, e) && &d == datum {
                        out.push(def);
                    }
                }
            }
            _ => {}
        }
    }
    out
}

/// The name a definition's WKT gives its CRS.
fn def_name(def: &crs_definitions::Def) -> String {
    parse(def.wkt)
        .map(|n| n.name().to_string())
        .unwrap_or_default()
}

fn def_datum(def: &crs_definitions::Def) -> String {
    let Some(n) = parse(def.wkt) else {
        return String::new();
    };
    let g = if n.key == "PROJCS" {
        n.child("GEOGCS").cloned()
    } else {
        Some(n)
    };
    g.and_then(|g| geographic(&g))
        .map(|(_, d)| d)
        .unwrap_or_default()
}

/// Where a WKT came from, for what is said about it: the member an error names and the words a note uses.
pub(crate) struct WktSource {
    pub member: &'static str,
    /// `the .prj's`, as in "identified from the .prj's projection".
    pub whose: &'static str,
}

/// A shapefile's `.prj`.
pub(crate) const PRJ: WktSource = WktSource {
    member: ".prj",
    whose: "the .prj's",
};

/// The CRS a WKT (a `.prj`, a GeoPackage's spatial reference system) declares, and a note when it was identified
/// rather than named.
pub(crate) fn declared_crs(wkt: &str, source: &WktSource) -> (DeclaredCrs, Option<String>) {
    let wkt = wkt.trim().trim_start_matches('\u{feff}').trim();
    let not_understood = |why: String| {
        (
            DeclaredCrs::NotUnderstood {
                member: source.member,
                detail: format!("{why} ({:?})", wkt.chars().take(100).collect::<String>()),
            },
            None,
        )
    };
    let Some(root) = parse(wkt) else {
        return not_understood("it is not WKT".into());
    };
    // The outermost node's own authority: its last `AUTHORITY["EPSG","26986"]` (WKT 1) or `ID["EPSG",26986]` (WKT 2).
    let code = root
        .children()
        .filter(|c| c.key == "AUTHORITY" || c.key == "ID")
        .last()
        .filter(|c| c.name().eq_ignore_ascii_case("EPSG"))
        .and_then(|c| match c.args.get(1)? {
            Arg::Text(t) if !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()) => {
                Some(t.clone())
            }
            Arg::Number(x) if x.fract() == 0.0 && *x > 0.0 => Some(format!("{x}")),
            _ => None,
        });
    if let Some(code) = code {
        return (DeclaredCrs::Name(format!("EPSG:{code}")), None);
    }
    let geographic_key = matches!(root.key.as_str(), "GEOGCS" | "GEOGCRS" | "GEODCRS");
    let wgs84_datum = root
        .child("DATUM")
        .map(|d| datum_key(d.name()))
        .is_some_and(|d| matches!(d.as_str(), "WGS1984" | "WGS84" | "WORLDGEODETICSYSTEM1984"));
    // In degrees from Greenwich: another angular unit (grads) or prime meridian (Paris) would misplace every point.
    let degrees = root
        .children()
        .filter(|c| c.key == "UNIT" || c.key == "ANGLEUNIT")
        .last()
        .and_then(|u| u.number(1))
        .is_none_or(|f| (f - std::f64::consts::PI / 180.0).abs() < 1e-12);
    let greenwich = root
        .child("PRIMEM")
        .and_then(|p| p.number(1))
        .is_none_or(|x| x == 0.0);
    if geographic_key && wgs84_datum && degrees && greenwich {
        return (DeclaredCrs::Name("EPSG:4326".into()), None);
    }
    // Esri's Web Mercator has a projection of its own name.
    if root.key == "PROJCS"
        && root
            .child("PROJECTION")
            .is_some_and(|p| key(p.name()) == "MERCATORAUXILIARYSPHERE")
    {
        let all_zero = root
            .children()
            .filter(|c| c.key == "PARAMETER")
            .all(|c| c.number(1) == Some(0.0));
        let metres = root
            .children()
            .filter(|c| c.key == "UNIT")
            .last()
            .and_then(|u| u.number(1))
            == Some(1.0);
        let wgs84 = root
            .child("GEOGCS")
            .and_then(geographic)
            .is_some_and(|(e, d)| {
                same_ellipsoid(e, [6_378_137.0, 298.257_223_563]) && d == "WGS1984"
            });
        return if all_zero && metres && wgs84 {
            (
                DeclaredCrs::Name("EPSG:3857".into()),
                Some(format!(
                    "CRS EPSG:3857 (WGS 84 / Pseudo-Mercator) identified from {} projection",
                    source.whose
                )),
            )
        } else {
            not_understood(
                "an auxiliary-sphere Mercator with parameters other than Web Mercator's".into(),
            )
        };
    }
    if root.key != "PROJCS" && root.key != "GEOGCS" {
        return not_understood("it names no EPSG code".into());
    }
    if root.key == "PROJCS" && projected(&root).is_none() {
        return not_understood(
            "it names no EPSG code, and its projection is not one citylod identifies".into(),
        );
    }
    let found = candidates(&root);
    let Some(first) = found.first() else {
        return not_understood(
            "it names no EPSG code, and no CRS of the EPSG table has its parameters".into(),
        );
    };
    let datum = match root.key.as_str() {
        "PROJCS" => root.child("GEOGCS").and_then(geographic).map(|(_, d)| d),
        _ => geographic(&root).map(|(_, d)| d),
    }
    .unwrap_or_default();
    // Several codes may share the parameters (NAD83 and its realizations, one zone under several names): one
    // transformation for all of them settles it; else the datum's name must pick the transformation.
    let same_datum: Vec<&crs_definitions::Def> =
        found.iter().filter(|d| def_datum(d) == datum).collect();
    let one_transform = |defs: &[&crs_definitions::Def]| {
        defs.windows(2)
            .all(|w| same_transform(w[0].proj4, w[1].proj4))
    };
    let all: Vec<&crs_definitions::Def> = found.iter().collect();
    // Among codes that transform alike, the label: the datum's name, then the most words shared with the .prj's
    // own name and the fewest others (`ETRS_1989_UTM_Zone_32N` is "ETRS89 / UTM zone 32N", not "… (N-E)"), then the
    // lowest code.
    let own = words(root.name());
    let best = |defs: &[&crs_definitions::Def]| -> Option<crs_definitions::Def> {
        defs.iter()
            .max_by_key(|d| {
                let theirs = words(&def_name(d));
                let shared = theirs.iter().filter(|w| own.contains(w)).count() as i64;
                (
                    !def_name(d).contains("deprecated"),
                    def_datum(d) == datum,
                    2 * shared - theirs.len() as i64,
                    std::cmp::Reverse(d.code),
                )
            })
            .map(|d| **d)
    };
    let chosen = if one_transform(&all) {
        best(&all).unwrap_or(*first)
    } else if !same_datum.is_empty() && one_transform(&same_datum) {
        best(&same_datum).unwrap_or(*first)
    } else {
        let shown: Vec<String> = found
            .iter()
            .take(6)
            .map(|d| format!("EPSG:{}", d.code))
            .collect();
        return not_understood(format!(
            "it names no EPSG code, and its parameters fit CRSs on different datums: {}{}",
            shown.join(", "),
            if found.len() > 6 { ", …" } else { "" }
        ));
    };
    let note = format!(
        "CRS EPSG:{} ({}) identified from {} {}, which names no EPSG code{}",
        chosen.code,
        def_name(&chosen),
        source.whose,
        if root.key == "PROJCS" {
            "projection, parameters, unit and ellipsoid"
        } else {
            "datum and ellipsoid"
        },
        if found.len() > 1 {
            format!("; {} codes share them and transform alike", found.len())
        } else {
            String::new()
        }
    );
    (
        DeclaredCrs::Name(format!("EPSG:{}", chosen.code)),
        Some(note),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn name(w: &str) -> String {
        match declared_crs(w, &PRJ).0 {
            DeclaredCrs::Name(n) => n,
            DeclaredCrs::NotUnderstood { member, detail } => format!("? {member} {detail}"),
        }
    }

    #[test]
    fn prj_files_naming_their_epsg_code() {
        let ogc = r#"PROJCS["NAD83 / Massachusetts Mainland",GEOGCS["NAD83",DATUM["North_American_Datum_1983",SPHEROID["GRS 1980",6378137,298.257222101,AUTHORITY["EPSG","7019"]],AUTHORITY["EPSG","6269"]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433],AUTHORITY["EPSG","4269"]],PROJECTION["Lambert_Conformal_Conic_2SP"],UNIT["metre",1],AUTHORITY["EPSG","26986"]]"#;
        assert_eq!(name(ogc), "EPSG:26986");
        let wkt2 = r#"PROJCRS["Amersfoort / RD New",BASEGEOGCRS["Amersfoort",DATUM["Amersfoort",ELLIPSOID["Bessel 1841",6377397.155,299.1528128]]],CONVERSION["RD New",METHOD["Oblique Stereographic"]],CS[Cartesian,2],AXIS["easting (X)",east],AXIS["northing (Y)",north],ID["EPSG",28992]]"#;
        assert_eq!(name(wkt2), "EPSG:28992");
        let grads = r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Grad",0.01570796326794897]]"#;
        assert!(name(grads).starts_with("? .prj"));
        let wgs84 = "\u{feff}GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]]\n";
        assert_eq!(name(wgs84), "EPSG:4326");
        // A nested authority is not the CRS's.
        let nested_only = r#"PROJCS["x",GEOGCS["NAD83",DATUM["D",SPHEROID["GRS 1980",6378137,298.257222101]],AUTHORITY["EPSG","4269"]],PROJECTION["Polyconic"],UNIT["Meter",1.0]]"#;
        assert!(name(nested_only).starts_with("? .prj"));
    }

    #[test]
    fn esri_prj_files_are_identified_by_their_parameters() {
        let ma = r#"PROJCS["NAD_1983_StatePlane_Massachusetts_Mainland_FIPS_2001",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],PARAMETER["False_Easting",200000.0],PARAMETER["False_Northing",750000.0],PARAMETER["Central_Meridian",-71.5],PARAMETER["Standard_Parallel_1",41.71666666666667],PARAMETER["Standard_Parallel_2",42.68333333333333],PARAMETER["Latitude_Of_Origin",41.0],UNIT["Meter",1.0]]"#;
        let (crs, note) = declared_crs(ma, &PRJ);
        assert_eq!(crs, DeclaredCrs::Name("EPSG:26986".into()));
        assert!(note.unwrap().contains("NAD83 / Massachusetts Mainland"));
        let ny_feet = r#"PROJCS["NAD_1983_StatePlane_New_York_Long_Island_FIPS_3104_Feet",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],PARAMETER["False_Easting",984250.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-74.0],PARAMETER["Standard_Parallel_1",40.66666666666666],PARAMETER["Standard_Parallel_2",41.03333333333333],PARAMETER["Latitude_Of_Origin",40.16666666666666],UNIT["Foot_US",0.3048006096012192]]"#;
        assert_eq!(name(ny_feet), "EPSG:2263");
        let rd = r#"PROJCS["RD_New",GEOGCS["GCS_Amersfoort",DATUM["D_Amersfoort",SPHEROID["Bessel_1841",6377397.155,299.1528128]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Double_Stereographic"],PARAMETER["False_Easting",155000.0],PARAMETER["False_Northing",463000.0],PARAMETER["Central_Meridian",5.38763888888889],PARAMETER["Scale_Factor",0.9999079],PARAMETER["Latitude_Of_Origin",52.15616055555555],UNIT["Meter",1.0]]"#;
        assert_eq!(name(rd), "EPSG:28992");
        let bng = r#"PROJCS["British_National_Grid",GEOGCS["GCS_OSGB_1936",DATUM["D_OSGB_1936",SPHEROID["Airy_1830",6377563.396,299.3249646]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],PARAMETER["False_Easting",400000.0],PARAMETER["False_Northing",-100000.0],PARAMETER["Central_Meridian",-2.0],PARAMETER["Scale_Factor",0.9996012717],PARAMETER["Latitude_Of_Origin",49.0],UNIT["Meter",1.0]]"#;
        assert_eq!(name(bng), "EPSG:27700");
        let utm = r#"PROJCS["WGS_1984_UTM_Zone_33N",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],PARAMETER["False_Easting",500000.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",15.0],PARAMETER["Scale_Factor",0.9996],PARAMETER["Latitude_Of_Origin",0.0],UNIT["Meter",1.0]]"#;
        assert_eq!(name(utm), "EPSG:32633");
        // ETRS89 shares UTM's parameters but not WGS 84's ellipsoid flattening.
        let etrs = utm
            .replace("WGS_1984_UTM_Zone_33N", "ETRS_1989_UTM_Zone_32N")
            .replace("GCS_WGS_1984", "GCS_ETRS_1989")
            .replace("D_WGS_1984", "D_ETRS_1989")
            .replace(
                r#"SPHEROID["WGS_1984",6378137.0,298.257223563]"#,
                r#"SPHEROID["GRS_1980",6378137.0,298.257222101]"#,
            )
            .replace("15.0]", "9.0]");
        assert_eq!(name(&etrs), "EPSG:25832");
        let web = r#"PROJCS["WGS_1984_Web_Mercator_Auxiliary_Sphere",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Mercator_Auxiliary_Sphere"],PARAMETER["False_Easting",0.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",0.0],PARAMETER["Standard_Parallel_1",0.0],PARAMETER["Auxiliary_Sphere_Type",0.0],UNIT["Meter",1.0]]"#;
        assert_eq!(name(web), "EPSG:3857");
        let nad83 = r#"GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#;
        assert_eq!(name(nad83), "EPSG:4269");
    }

    #[test]
    fn esri_prj_files_a_review_found_misread() {
        // NAD83(2011), as ArcGIS names its datum.
        let nyli_2011 = r#"PROJCS["NAD_1983_2011_StatePlane_New_York_Long_Isl_FIPS_3104_Ft_US",GEOGCS["GCS_NAD_1983_2011",DATUM["D_NAD_1983_2011",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],PARAMETER["False_Easting",984250.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-74.0],PARAMETER["Standard_Parallel_1",40.66666666666666],PARAMETER["Standard_Parallel_2",41.03333333333333],PARAMETER["Latitude_Of_Origin",40.16666666666666],UNIT["Foot_US",0.3048006096012192]]"#;
        assert_eq!(name(nyli_2011), "EPSG:6539");
        // Its metre twin differs from a deprecated code by 10 µm of false easting: one transformation.
        let mn = r#"PROJCS["NAD_1983_StatePlane_Minnesota_North_FIPS_2201",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],PARAMETER["False_Easting",800000.0],PARAMETER["False_Northing",100000.0],PARAMETER["Central_Meridian",-93.1],PARAMETER["Standard_Parallel_1",47.03333333333333],PARAMETER["Standard_Parallel_2",48.63333333333333],PARAMETER["Latitude_Of_Origin",46.5],UNIT["Meter",1.0]]"#;
        assert_eq!(name(mn), "EPSG:26991");
        // Two equal standard parallels away from the latitude of origin are not a 1SP at the parallel (166 km off).
        let lcc39 = r#"PROJCS["custom_lcc_origin_39",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Lambert_Conformal_Conic"],PARAMETER["False_Easting",500000.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-84.25],PARAMETER["Standard_Parallel_1",37.96666666666667],PARAMETER["Standard_Parallel_2",37.96666666666667],PARAMETER["Latitude_Of_Origin",39.0],UNIT["Meter",1.0]]"#;
        assert!(name(lcc39).starts_with("? .prj"), "{}", name(lcc39));
        // Esri's Web Mercator in feet is not EPSG:3857.
        let feet = r#"PROJCS["WGS_1984_Web_Mercator_Auxiliary_Sphere",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Mercator_Auxiliary_Sphere"],PARAMETER["False_Easting",0.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",0.0],PARAMETER["Standard_Parallel_1",0.0],PARAMETER["Auxiliary_Sphere_Type",0.0],UNIT["Foot_US",0.3048006096012192]]"#;
        assert!(name(feet).starts_with("? .prj"), "{}", name(feet));
    }

    #[test]
    fn prj_files_that_fit_nothing_or_several_datums_ask_for_the_crs() {
        // Another datum with a shift to WGS 84 is not WGS 84.
        let towgs = r#"GEOGCS["Amersfoort",DATUM["Amersfoort",SPHEROID["Bessel 1841",6377397.155,299.1528128],TOWGS84[565.2369,50.0087,465.658,-0.406857,0.350733,-1.87035,4.0812]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]]"#;
        assert_ne!(name(towgs), "EPSG:4326");
        // A false easting no CRS has.
        let odd = r#"PROJCS["x",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],PARAMETER["False_Easting",123457.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-1.0],PARAMETER["Scale_Factor",0.9996],PARAMETER["Latitude_Of_Origin",0.0],UNIT["Meter",1.0]]"#;
        assert!(
            name(odd).contains("no CRS of the EPSG table"),
            "{}",
            name(odd)
        );
        // A projection not compared, and text that is not WKT.
        assert!(name(r#"PROJCS["x",GEOGCS["g",DATUM["d",SPHEROID["s",6378137,298.3]],PRIMEM["Greenwich",0],UNIT["Degree",0.017]],PROJECTION["Polyconic"],UNIT["Meter",1]]"#).contains("not one citylod identifies"));
        assert!(name("EPSG:26986 please").contains("not WKT"));
        assert!(name(&"PROJCS[".repeat(100)).contains("not WKT"));
    }
}
