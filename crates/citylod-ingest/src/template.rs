//! CityJSON geometry templates (CityJSON 1.1/2.0 "Geometry templates", CityGML implicit geometry): a
//! `GeometryInstance` stands for its template's geometry with every template vertex v placed at
//! referencePoint + M·(v, 1), M the row-major 4×4 `transformationMatrix`. Template vertices are real
//! coordinates (`transform` does not apply to them); the reference point is a vertex of the file.
//! [`expand`] rewrites instances into plain geometries over placed vertices appended to the file's.

use serde_json::{Map, Value};
use std::collections::HashMap;

/// Member that an instance which could not be resolved carries instead of boundaries: why.
pub(crate) const UNRESOLVED: &str = "citylod:unresolved";

/// The `geometry-templates` of a document: template geometries and their vertices.
#[derive(Debug, Default)]
pub(crate) struct Templates {
    geometries: Vec<Value>,
    vertices: Vec<[f64; 3]>,
}

impl Templates {
    /// The document's templates (none when it has no `geometry-templates`). `Err` when the member is
    /// there but broken: every instance would depend on it.
    pub fn of(doc: &Value) -> Result<Self, String> {
        let Some(t) = doc.get("geometry-templates") else {
            return Ok(Self::default());
        };
        let geometries = t
            .get("templates")
            .and_then(Value::as_array)
            .ok_or("geometry-templates without a \"templates\" array")?
            .clone();
        let vertices = t
            .get("vertices-templates")
            .and_then(Value::as_array)
            .ok_or("geometry-templates without a \"vertices-templates\" array")?
            .iter()
            .enumerate()
            .map(|(i, v)| {
                crate::cityjson::three_numbers(v).ok_or_else(|| {
                    format!(
                        "geometry-templates.vertices-templates: vertex {i} is not three numbers: {v}"
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(Templates {
            geometries,
            vertices,
        })
    }
}

/// The objects of the building family (`Building`, `BuildingPart`, `BuildingInstallation`, …) with each
/// `GeometryInstance` replaced by its template's geometry, whose vertices are appended to `vertices`.
/// `None` when no such object holds an instance (nothing to change). An instance that cannot be
/// resolved (no such template, a bad reference point or matrix) stays a `GeometryInstance` carrying
/// [`UNRESOLVED`]: why, for the object's reader to report.
pub(crate) fn expand(
    objects: &Map<String, Value>,
    vertices: &mut Vec<[f64; 3]>,
    templates: &Templates,
) -> Option<Map<String, Value>> {
    let is_instance = |g: &Value| g.get("type").and_then(Value::as_str) == Some("GeometryInstance");
    let building_family = |o: &Value| {
        o.get("type")
            .and_then(Value::as_str)
            .is_some_and(|t| t.starts_with("Building"))
    };
    let holds_instance = |o: &Value| {
        building_family(o)
            && o.get("geometry")
                .and_then(Value::as_array)
                .is_some_and(|gs| gs.iter().any(is_instance))
    };
    if !objects.values().any(holds_instance) {
        return None;
    }
    let mut out = objects.clone();
    for o in out.values_mut().filter(|o| holds_instance(o)) {
        let Some(Value::Array(geoms)) = o.get_mut("geometry") else {
            continue;
        };
        for g in geoms.iter_mut().filter(|g| is_instance(g)) {
            *g = match resolve(g, vertices, templates) {
                Ok(plain) => plain,
                Err(why) => {
                    let mut m = Map::new();
                    m.insert("type".into(), "GeometryInstance".into());
                    m.insert(UNRESOLVED.into(), why.into());
                    Value::Object(m)
                }
            };
        }
    }
    Some(out)
}

/// One instance as a plain geometry: the template with its vertex indices renumbered to the placed
/// copies of the vertices it uses, appended to `vertices` in the order the template first uses them.
fn resolve(
    instance: &Value,
    vertices: &mut Vec<[f64; 3]>,
    templates: &Templates,
) -> Result<Value, String> {
    let t = instance
        .get("template")
        .and_then(Value::as_u64)
        .ok_or("GeometryInstance without a template index")?;
    let template =
        templates
            .geometries
            .get(t as usize)
            .ok_or_else(|| match templates.geometries.len() {
                0 => format!(
                    "GeometryInstance of template {t}, but the file has no geometry-templates"
                ),
                n => format!("GeometryInstance of template {t}, but the file has {n}"),
            })?;
    let reference = match instance.get("boundaries").and_then(Value::as_array) {
        Some(b) if b.len() == 1 => b[0]
            .as_u64()
            .and_then(|i| vertices.get(i as usize).copied())
            .ok_or_else(|| format!("GeometryInstance reference point {} is not a vertex", b[0]))?,
        _ => return Err("GeometryInstance boundaries are not one reference vertex".into()),
    };
    let m: Vec<f64> = match instance
        .get("transformationMatrix")
        .and_then(Value::as_array)
    {
        Some(a) if a.len() == 16 => a.iter().filter_map(Value::as_f64).collect(),
        _ => Vec::new(),
    };
    let m: [f64; 16] = m
        .try_into()
        .map_err(|_| "GeometryInstance transformationMatrix is not 16 numbers".to_string())?;
    let mut placed: HashMap<u64, u64> = HashMap::new();
    let mut geometry = template.clone();
    let boundaries = geometry
        .get_mut("boundaries")
        .ok_or("the template has no boundaries")?;
    renumber(boundaries, &mut |i| {
        if let Some(&j) = placed.get(&i) {
            return Ok(j);
        }
        let v = templates
            .vertices
            .get(i as usize)
            .ok_or_else(|| format!("template {t}: template vertex {i} out of range"))?;
        let p = place(&m, reference, *v)
            .ok_or_else(|| format!("template {t}: vertex {i} placed at a non-finite position"))?;
        let j = vertices.len() as u64;
        vertices.push(p);
        placed.insert(i, j);
        Ok(j)
    })?;
    Ok(geometry)
}

/// Replaces every integer of nested boundary arrays by `f` of it.
fn renumber(b: &mut Value, f: &mut impl FnMut(u64) -> Result<u64, String>) -> Result<(), String> {
    match b {
        Value::Array(items) => items.iter_mut().try_for_each(|x| renumber(x, f)),
        Value::Number(n) => {
            let i = n
                .as_u64()
                .ok_or_else(|| format!("template vertex index {n} is not an index"))?;
            *b = f(i)?.into();
            Ok(())
        }
        other => Err(format!(
            "template boundaries hold {other}, not vertex indices"
        )),
    }
}

/// reference + M·(v, 1), with the homogeneous divide; `None` when not finite.
fn place(m: &[f64; 16], reference: [f64; 3], v: [f64; 3]) -> Option<[f64; 3]> {
    let row = |r: usize| m[4 * r] * v[0] + m[4 * r + 1] * v[1] + m[4 * r + 2] * v[2] + m[4 * r + 3];
    let w = row(3);
    let p: [f64; 3] = std::array::from_fn(|k| reference[k] + row(k) / w);
    p.iter().all(|c| c.is_finite()).then_some(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn templates() -> Templates {
        Templates::of(&json!({"geometry-templates": {
            "templates": [{"type": "MultiSurface", "lod": "1", "boundaries": [[[0, 1, 2]]]}],
            "vertices-templates": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [9, 9, 9]]}}))
        .unwrap()
    }

    #[test]
    fn instances_become_their_template_placed_by_matrix_and_reference_point() {
        // Scale 2, rotate 90° about z, lift by 1, at reference vertex 1 = (100, 200, 5).
        let objects = json!({
            "B": {"type": "Building", "geometry": [{"type": "GeometryInstance", "template": 0, "boundaries": [1],
                "transformationMatrix": [0, -2, 0, 0,  2, 0, 0, 0,  0, 0, 2, 1,  0, 0, 0, 1]}]},
            "T": {"type": "SolitaryVegetationObject", "geometry": [{"type": "GeometryInstance", "template": 0,
                "boundaries": [0], "transformationMatrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]}});
        let mut vertices = vec![[0.0; 3], [100.0, 200.0, 5.0]];
        let out = expand(objects.as_object().unwrap(), &mut vertices, &templates()).unwrap();
        let g = &out["B"]["geometry"][0];
        assert_eq!(g["type"], "MultiSurface");
        assert_eq!(g["lod"], "1");
        assert_eq!(g["boundaries"], json!([[[2, 3, 4]]]));
        assert_eq!(
            &vertices[2..],
            &[[100.0, 200.0, 6.0], [100.0, 202.0, 6.0], [98.0, 200.0, 6.0]]
        );
        assert_eq!(
            out["T"], objects["T"],
            "only the building family is expanded"
        );
    }

    #[test]
    fn unresolvable_instances_say_why_and_files_without_instances_are_untouched() {
        let identity = json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
        let cases = [
            (
                json!({"template": 3, "boundaries": [0], "transformationMatrix": identity}),
                "has 1",
            ),
            (
                json!({"template": 0, "boundaries": [7], "transformationMatrix": identity}),
                "reference point 7",
            ),
            (
                json!({"template": 0, "boundaries": [0], "transformationMatrix": [1, 0]}),
                "16 numbers",
            ),
            (
                json!({"template": 0, "boundaries": [0], "transformationMatrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,0]}),
                "non-finite",
            ),
        ];
        for (mut instance, why) in cases {
            instance["type"] = json!("GeometryInstance");
            let objects = json!({"B": {"type": "Building", "geometry": [instance]}});
            let mut vertices = vec![[0.0; 3]];
            let out = expand(objects.as_object().unwrap(), &mut vertices, &templates()).unwrap();
            let reason = out["B"]["geometry"][0][UNRESOLVED].as_str().unwrap();
            assert!(reason.contains(why), "{reason} should say {why}");
            assert_eq!(vertices.len(), 1, "nothing placed for a failed instance");
        }
        let none = Templates::default();
        let objects = json!({"B": {"type": "Building", "geometry": [{"type": "GeometryInstance",
            "template": 0, "boundaries": [0], "transformationMatrix": identity}]}});
        let out = expand(objects.as_object().unwrap(), &mut vec![[0.0; 3]], &none).unwrap();
        let reason = out["B"]["geometry"][0][UNRESOLVED].as_str().unwrap();
        assert!(reason.contains("no geometry-templates"), "{reason}");
        let plain = json!({"B": {"type": "Building", "geometry": [{"type": "MultiSurface", "boundaries": []}]}});
        assert!(expand(plain.as_object().unwrap(), &mut Vec::new(), &templates()).is_none());
    }

    #[test]
    fn broken_template_vertices_are_a_file_error() {
        let e = Templates::of(&json!({"geometry-templates": {"templates": [],
            "vertices-templates": [[0, 0, 0], [1, null, 0, 2]]}}))
        .unwrap_err();
        assert!(e.contains("vertex 1"), "{e}");
    }
}
