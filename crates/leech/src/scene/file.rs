//! The scene file format (TOML): parsing with one-line errors, and writing.

use serde::{Deserialize, Serialize};

use super::{Scene, Solid, Start, MAX_COORDINATE_M, MAX_SCENE_BYTES};
use crate::error::{one_line, within, InputError};
use crate::geom::Vec2;

/// A `[[half_plane]]` table. Points are read as lists and checked for two
/// numbers here: serde reads a fixed-size array from the first elements of a
/// longer list, so `[x, y, z]` would silently lose `z`.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHalfPlane {
    point_m: Vec<f64>,
    normal: Vec<f64>,
}

/// A `[[polygon]]` table.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPolygon {
    points_m: Vec<Vec<f64>>,
}

/// A point `[x, y]` from a list of numbers.
fn pair(field: String, v: &[f64]) -> Result<Vec2, InputError> {
    match v {
        [x, y] => Ok([*x, *y]),
        _ => Err(InputError::Invalid {
            field,
            value: format!("{} number{}", v.len(), if v.len() == 1 { "" } else { "s" }),
            allowed: "a point [x, y] of two numbers".into(),
        }),
    }
}

/// The solids of a parsed file, half-planes first; `source` starts error fields.
/// The `[start]` table: a finite point within the scenes' bounds and a
/// direction within +-360 deg.
fn start(raw: &RawStart, source: &str) -> Result<Start, InputError> {
    let [x, y] = pair(format!("{source}: start.rear_cup_m"), &raw.rear_cup_m)?;
    let m = MAX_COORDINATE_M;
    let point = [
        within(&format!("{source}: start.rear_cup_m x (m)"), x, -m, m)?,
        within(&format!("{source}: start.rear_cup_m y (m)"), y, -m, m)?,
    ];
    let degrees = within(&format!("{source}: start.direction_deg"), raw.direction_deg, -360.0, 360.0)?;
    Ok(Start { rear_cup_m: point, direction_rad: degrees.to_radians() })
}

fn solids(raw: RawScene, source: &str) -> Result<Vec<Solid>, InputError> {
    let mut solids = Vec::with_capacity(raw.half_plane.len() + raw.polygon.len());
    for (i, h) in raw.half_plane.iter().enumerate() {
        solids.push(Solid::HalfPlane {
            point_m: pair(format!("{source}: half_plane[{i}].point_m"), &h.point_m)?,
            normal: pair(format!("{source}: half_plane[{i}].normal"), &h.normal)?,
        });
    }
    for (i, p) in raw.polygon.iter().enumerate() {
        let points_m =
            p.points_m.iter().enumerate().map(|(j, q)| pair(format!("{source}: polygon[{i}].points_m[{j}]"), q));
        solids.push(Solid::Polygon { points_m: points_m.collect::<Result<_, _>>()? });
    }
    Ok(solids)
}

/// The whole file. The two kinds sit in separate arrays of tables, so the file
/// cannot say how they interleave: half-planes come first.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStart {
    rear_cup_m: Vec<f64>,
    direction_deg: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    start: Option<RawStart>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    half_plane: Vec<RawHalfPlane>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    polygon: Vec<RawPolygon>,
}

impl Scene {
    /// Parses and validates a scene file; `source` (a path, or a built-in
    /// name) starts every error message.
    ///
    /// The solids are the half-planes, then the polygons, each in file order.
    /// Text longer than [`MAX_SCENE_BYTES`] is rejected before parsing.
    pub fn from_toml_str(text: &str, source: &str) -> Result<Scene, InputError> {
        let raw: RawScene = parse_bounded(text, source, "scene")?;
        let name = raw.name.clone();
        let start = raw.start.as_ref().map(|s| start(s, source)).transpose()?;
        let scene = Scene { name, solids: solids(raw, source)?, start };
        scene.validate().map_err(|e| match e {
            InputError::Invalid { field, value, allowed } => {
                InputError::Invalid { field: format!("{source}: {field}"), value, allowed }
            }
            other => other,
        })?;
        Ok(scene)
    }

    /// The scene file for this scene (values only, no comments). It reads back
    /// to an equal scene when the half-planes come before the polygons in
    /// [`Scene::solids`], as in every scene read from a file.
    pub fn to_toml_string(&self) -> String {
        let start = self
            .start
            .map(|s| RawStart { rear_cup_m: s.rear_cup_m.to_vec(), direction_deg: s.direction_rad.to_degrees() });
        let mut raw = RawScene { name: self.name.clone(), start, half_plane: Vec::new(), polygon: Vec::new() };
        for solid in &self.solids {
            match solid {
                Solid::HalfPlane { point_m, normal } => {
                    raw.half_plane.push(RawHalfPlane { point_m: point_m.to_vec(), normal: normal.to_vec() })
                }
                Solid::Polygon { points_m } => {
                    raw.polygon.push(RawPolygon { points_m: points_m.iter().map(|p| p.to_vec()).collect() })
                }
            }
        }
        toml::to_string(&raw).expect("a scene always serializes")
    }
}

/// A file that holds a scene file's contents in its `[scene]` table (a
/// scenario), the rest of it left as it is.
#[derive(Deserialize)]
struct InlineScene {
    // Read only for its errors.
    #[serde(rename = "scene")]
    _scene: RawScene,
    #[serde(flatten)]
    _rest: toml::Table,
}

/// Where the `[scene]` table of `text` (a file from `source`) fails to read
/// as a scene file, with the line in `text`: a scene read from the table on
/// its own would count its lines from the table.
pub(crate) fn inline_scene_error(text: &str, source: &str) -> Option<InputError> {
    let error = toml::from_str::<InlineScene>(text).err()?;
    Some(InputError::File { file: format!("{source}: [scene]"), message: one_line(text, &error) })
}

/// `text` (a `what` file from `source`) parsed as TOML into `T`, refused
/// beyond [`MAX_SCENE_BYTES`] before parsing; errors on one line.
pub(crate) fn parse_bounded<T: serde::de::DeserializeOwned>(
    text: &str,
    source: &str,
    what: &str,
) -> Result<T, InputError> {
    if text.len() > MAX_SCENE_BYTES {
        return Err(InputError::Invalid {
            field: source.into(),
            value: format!("{} bytes", text.len()),
            allowed: format!("a {what} file of at most {MAX_SCENE_BYTES} bytes"),
        });
    }
    toml::from_str(text).map_err(|e| InputError::File { file: source.into(), message: one_line(text, &e) })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "name = \"box\"\n[[polygon]]\npoints_m = [[0, 0], [1, 0], [1, 1]]\n";

    #[test]
    fn integers_read_as_metres_and_round_trip() {
        let scene = Scene::from_toml_str(TEXT, "box.toml").unwrap();
        assert_eq!(scene.solids, vec![Solid::Polygon { points_m: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]] }]);
        let text = scene.to_toml_string();
        assert!(!text.contains("half_plane"), "empty arrays are left out:\n{text}");
        assert_eq!(Scene::from_toml_str(&text, "again").unwrap(), scene);
    }

    #[test]
    fn parse_errors_name_the_file_and_line() {
        let e = Scene::from_toml_str(&TEXT.replace("[[polygon]]", "[[polygon]]\ncolour = 1"), "box.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("box.toml: line 3: unknown field `colour`"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }

    #[test]
    fn type_errors_and_duplicates_name_their_key() {
        let bad = |text: &str| Scene::from_toml_str(text, "box.toml").unwrap_err().to_string();
        let e = bad(&TEXT.replace("[[0, 0], [1, 0], [1, 1]]", "\"origin\" # a comment"));
        assert_eq!(e, "box.toml: line 3: polygon.points_m: got string \"origin\", expected an array");
        let e = bad(&TEXT.replace("name = \"box\"", "name = \"box\"\nname = \"b\""));
        assert_eq!(e, "box.toml: line 2: name: got it a second time, expected each key and table once");
        let e = bad(&format!("{} = 1\n{TEXT}", "k".repeat(1000)));
        assert!(e.len() < 200 && e.contains("expected one of"), "{e}");
    }
}
