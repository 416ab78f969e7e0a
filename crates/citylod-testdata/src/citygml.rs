//! A CityGML 2.0 writer for tests and benchmarks: a CityJSON document's buildings written the way the 3D City
//! Database exports them — each object's LoD 2 solid as `xlink:href`s to the polygons of its thematic surfaces
//! (`boundedBy`), its parts as `consistsOfBuildingPart`, its attributes as generic string attributes — so that the
//! same real city can be read from both formats and compared.

use serde_json::Value;
use std::io::{self, Write};

/// Writes `doc`'s buildings (solids with semantics, as Den Haag's CityJSON has them) `copies` times, each copy
/// `shift_m` further east than the one before, its ids suffixed `_COPY` when there is more than one. Other city
/// objects become empty `dem:TINRelief`s (non-building members). `srs` is the envelope's `srsName`.
///
/// # Panics
/// On a CityJSON document of another shape (no transform, geometry other than semantic Solids).
pub fn from_cityjson(
    doc: &Value,
    copies: usize,
    shift_m: f64,
    srs: &str,
    out: &mut impl Write,
) -> io::Result<()> {
    let t = &doc["transform"];
    let scale: Vec<f64> = (0..3).map(|i| t["scale"][i].as_f64().unwrap()).collect();
    let shift: Vec<f64> = (0..3)
        .map(|i| t["translate"][i].as_f64().unwrap())
        .collect();
    let vertices: Vec<[f64; 3]> = doc["vertices"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| std::array::from_fn(|i| v[i].as_f64().unwrap() * scale[i] + shift[i]))
        .collect();
    let objects = doc["CityObjects"].as_object().unwrap();
    writeln!(
        out,
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<CityModel xmlns=\"http://www.opengis.net/citygml/2.0\" \
         xmlns:bldg=\"http://www.opengis.net/citygml/building/2.0\" xmlns:gml=\"http://www.opengis.net/gml\" \
         xmlns:xlink=\"http://www.w3.org/1999/xlink\" xmlns:dem=\"http://www.opengis.net/citygml/relief/2.0\" \
         xmlns:gen=\"http://www.opengis.net/citygml/generics/2.0\">\n<gml:boundedBy><gml:Envelope srsName=\"{srs}\" \
         srsDimension=\"3\"><gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>1 1 1</gml:upperCorner>\
         </gml:Envelope></gml:boundedBy>"
    )?;
    for copy in 0..copies {
        let dx = copy as f64 * shift_m;
        let id = |key: &str| {
            if copies > 1 {
                format!("{key}_{copy}")
            } else {
                key.to_string()
            }
        };
        let pos_list = |r: &Value| -> String {
            let idx = r.as_array().unwrap();
            idx.iter()
                .chain(idx.first())
                .map(|i| {
                    let p = vertices[i.as_u64().unwrap() as usize];
                    format!("{} {} {}", p[0] + dx, p[1], p[2])
                })
                .collect::<Vec<_>>()
                .join(" ")
        };
        let object = |key: &str, o: &Value, out: &mut dyn Write| -> io::Result<()> {
            for g in o["geometry"].as_array().into_iter().flatten() {
                assert_eq!(g["type"], "Solid");
                let types = &g["semantics"]["surfaces"];
                let mut refs = String::new();
                for (s, (surface, value)) in g["boundaries"][0]
                    .as_array()
                    .unwrap()
                    .iter()
                    .zip(g["semantics"]["values"][0].as_array().unwrap())
                    .enumerate()
                {
                    let kind = types[value.as_u64().unwrap() as usize]["type"]
                        .as_str()
                        .unwrap();
                    let pid = format!("{}_{s}", id(key));
                    let rings = surface.as_array().unwrap();
                    let interiors: String = rings[1..]
                        .iter()
                        .map(|r| {
                            format!(
                                "<gml:interior><gml:LinearRing><gml:posList>{}</gml:posList></gml:LinearRing>\
                                 </gml:interior>",
                                pos_list(r)
                            )
                        })
                        .collect();
                    writeln!(
                        out,
                        "<bldg:boundedBy><bldg:{kind}><bldg:lod2MultiSurface><gml:MultiSurface><gml:surfaceMember>\
                         <gml:Polygon gml:id=\"{pid}\"><gml:exterior><gml:LinearRing><gml:posList>{}</gml:posList>\
                         </gml:LinearRing></gml:exterior>{interiors}</gml:Polygon></gml:surfaceMember>\
                         </gml:MultiSurface></bldg:lod2MultiSurface></bldg:{kind}></bldg:boundedBy>",
                        pos_list(&rings[0])
                    )?;
                    refs.push_str(&format!("<gml:surfaceMember xlink:href=\"#{pid}\"/>"));
                }
                writeln!(
                    out,
                    "<bldg:lod2Solid><gml:Solid><gml:exterior><gml:CompositeSurface>{refs}\
                     </gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod2Solid>"
                )?;
            }
            for (k, v) in o["attributes"].as_object().into_iter().flatten() {
                let text = match v {
                    Value::String(s) => s.clone(),
                    v => v.to_string(),
                };
                writeln!(
                    out,
                    "<gen:stringAttribute name=\"{k}\"><gen:value>{}</gen:value></gen:stringAttribute>",
                    text.replace('&', "&amp;").replace('<', "&lt;")
                )?;
            }
            Ok(())
        };
        for (key, o) in objects {
            match o["type"].as_str().unwrap() {
                "Building" => {
                    writeln!(
                        out,
                        "<cityObjectMember><bldg:Building gml:id=\"{}\">",
                        id(key)
                    )?;
                    object(key, o, out)?;
                    for c in o["children"].as_array().into_iter().flatten() {
                        let c = c.as_str().unwrap();
                        writeln!(
                            out,
                            "<bldg:consistsOfBuildingPart><bldg:BuildingPart gml:id=\"{}\">",
                            id(c)
                        )?;
                        object(c, &objects[c], out)?;
                        writeln!(out, "</bldg:BuildingPart></bldg:consistsOfBuildingPart>")?;
                    }
                    writeln!(out, "</bldg:Building></cityObjectMember>")?;
                }
                "BuildingPart" => {}
                _ => writeln!(
                    out,
                    "<cityObjectMember><dem:TINRelief gml:id=\"{}\"/></cityObjectMember>",
                    id(key)
                )?,
            }
        }
    }
    writeln!(out, "</CityModel>")
}
