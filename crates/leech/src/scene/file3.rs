//! The 3D scene file format (TOML): half-spaces and boxes for the 3D body,
//! with an optional start, parsed with one-line errors (docs/model3d.md
//! section 12).
//!
//! ```toml
//! name = "corner"
//! [start]                        # optional: the rear cup's face centre on a surface
//! rear_cup_m = [0.0, 0.0, 0.0]   # (m)
//! direction_deg = 0.0            # the clamp direction in the x-y plane (as the planar [start])
//! [[half_space]]                 # solid behind the plane: (x - point_m) . normal < 0
//! point_m = [0.0, 0.0, 0.0]
//! normal = [0.0, 1.0, 0.0]       # unit, out of the solid
//! [[box]]
//! centre_m = [0.3, 0.05, 0.0]
//! half_extents_m = [0.02, 0.05, 0.5]
//! rotation_deg = [0.0, 0.0, 0.0] # optional: a rotation vector (axis times angle, deg)
//! ```
//!
//! A box's frame is `Exp(rotation_deg in rad)`: its axes the columns, turned
//! from the world's by the angle `|r|` about `r / |r|`. Every point within
//! [`MAX_COORDINATE_M`] of the origin, a rotation of at most 360 deg, normals
//! unit to [`super::UNIT_TOLERANCE`] ([`Solid3::validate`]). Half-spaces come
//! first in the scene's solids, then boxes, each in file order.

use serde::Deserialize;

use super::file::parse_bounded;
use super::{Scene, Scene3, Solid3, MAX_COORDINATE_M};
use crate::error::{within, InputError};
use crate::geom3::{exp, Vec3};

/// Largest rotation of a box (deg).
const MAX_ROTATION_DEG: f64 = 360.0;

/// Where a scene puts the 3D body by default: the rear cup's face centre
/// (m) and the clamp direction in the x-y plane (rad), the unit turned by it
/// about z as [`crate::body3::Body3::from_robot`] turns it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Start3 {
    /// Centre of the rear cup's face (m).
    pub rear_cup_m: Vec3,
    /// The clamp direction (rad, counter-clockwise from +x about z).
    pub direction_rad: f64,
}

/// A 3D scene read from a file (or a planar scene read in 3D) and its start.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneFile3 {
    /// The solids.
    pub scene: Scene3,
    /// Where the robot starts, when the file says.
    pub start: Option<Start3>,
    /// Whether it came from a planar scene ([`Scene3::from_planar`]): every
    /// z-section is that scene, so the planar model has a counterpart.
    pub planar: Option<Scene>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHalfSpace {
    point_m: Vec<f64>,
    normal: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBox {
    centre_m: Vec<f64>,
    half_extents_m: Vec<f64>,
    #[serde(default)]
    rotation_deg: Option<Vec<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStart {
    rear_cup_m: Vec<f64>,
    direction_deg: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene3 {
    name: String,
    #[serde(default)]
    start: Option<RawStart>,
    #[serde(default)]
    half_space: Vec<RawHalfSpace>,
    #[serde(default, rename = "box")]
    boxes: Vec<RawBox>,
}

/// A point `[x, y, z]` from a list of numbers (serde would read a longer
/// list's first three silently).
fn triple(field: String, v: &[f64]) -> Result<Vec3, InputError> {
    match v {
        [x, y, z] => Ok([*x, *y, *z]),
        _ => Err(InputError::Invalid {
            field,
            value: format!("{} number{}", v.len(), if v.len() == 1 { "" } else { "s" }),
            allowed: "three numbers [x, y, z]".into(),
        }),
    }
}

/// Whether a scene file's `text` is a 3D one: it has `half_space` or `box`
/// tables (a planar file has `half_plane` and `polygon`). Text that is not
/// TOML is not: the planar reader then says what is wrong with it.
pub fn is_scene3(text: &str) -> bool {
    toml::from_str::<toml::Table>(text).is_ok_and(|t| t.contains_key("half_space") || t.contains_key("box"))
}

impl SceneFile3 {
    /// Parses and checks a 3D scene file; `source` (a path) starts every
    /// error message, which names the field as the file does
    /// (`box[1].half_extents_m`). Text beyond [`super::MAX_SCENE_BYTES`] is
    /// refused before parsing.
    pub fn from_toml_str(text: &str, source: &str) -> Result<SceneFile3, InputError> {
        let raw: RawScene3 = parse_bounded(text, source, "scene")?;
        let named = |field: String| format!("{source}: {field}");
        let mut solids = Vec::with_capacity(raw.half_space.len() + raw.boxes.len());
        for (i, h) in raw.half_space.iter().enumerate() {
            let field = format!("half_space[{i}]");
            let solid = Solid3::HalfSpace {
                point_m: triple(named(format!("{field}.point_m")), &h.point_m)?,
                normal: triple(named(format!("{field}.normal")), &h.normal)?,
            };
            solid.validate(&named(field))?;
            solids.push(solid);
        }
        for (i, b) in raw.boxes.iter().enumerate() {
            let field = format!("box[{i}]");
            let rotation = match &b.rotation_deg {
                Some(r) => triple(named(format!("{field}.rotation_deg")), r)?,
                None => [0.0; 3],
            };
            let angle = rotation.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(angle <= MAX_ROTATION_DEG) {
                return Err(InputError::Invalid {
                    field: named(format!("{field}.rotation_deg")),
                    value: format!("{rotation:?} ({angle} deg)"),
                    allowed: format!("a rotation vector of at most {MAX_ROTATION_DEG} deg"),
                });
            }
            let solid = Solid3::Box {
                centre_m: triple(named(format!("{field}.centre_m")), &b.centre_m)?,
                half_extents_m: triple(named(format!("{field}.half_extents_m")), &b.half_extents_m)?,
                frame: exp(rotation.map(f64::to_radians)),
            };
            solid.validate(&named(field))?;
            solids.push(solid);
        }
        let start = raw.start.as_ref().map(|s| start(s, source)).transpose()?;
        let scene = Scene3::new(raw.name, solids).map_err(|e| match e {
            InputError::Invalid { field, value, allowed } if field == "solids" => {
                InputError::Invalid { field: named("half_space, box".into()), value, allowed }
            }
            InputError::Invalid { field, value, allowed } => {
                InputError::Invalid { field: named(field), value, allowed }
            }
            other => other,
        })?;
        Ok(SceneFile3 { scene, start, planar: None })
    }

    /// A planar scene read in 3D ([`Scene3::from_planar`]) with its start
    /// in the plane `z = 0`.
    pub fn from_planar(scene: &Scene) -> SceneFile3 {
        let start = scene
            .start
            .map(|s| Start3 { rear_cup_m: [s.rear_cup_m[0], s.rear_cup_m[1], 0.0], direction_rad: s.direction_rad });
        SceneFile3 { scene: Scene3::from_planar(scene), start, planar: Some(scene.clone()) }
    }
}

/// The `[start]` table: a point within the scenes' bounds, a direction
/// within +-360 deg.
fn start(raw: &RawStart, source: &str) -> Result<Start3, InputError> {
    let point = triple(format!("{source}: start.rear_cup_m"), &raw.rear_cup_m)?;
    let m = MAX_COORDINATE_M;
    let mut checked = [0.0; 3];
    for ((out, axis), x) in checked.iter_mut().zip(["x", "y", "z"]).zip(point) {
        *out = within(&format!("{source}: start.rear_cup_m {axis} (m)"), x, -m, m)?;
    }
    let degrees = within(&format!("{source}: start.direction_deg"), raw.direction_deg, -360.0, 360.0)?;
    Ok(Start3 { rear_cup_m: checked, direction_rad: degrees.to_radians() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom3::apply;

    const TEXT: &str = r#"
name = "corner"
[start]
rear_cup_m = [0.0, 0.0, 0.1]
direction_deg = 90
[[half_space]]
point_m = [0, 0, 0]
normal = [0, 1, 0]
[[box]]
centre_m = [0.3, 0.05, 0.0]
half_extents_m = [0.02, 0.05, 0.5]
rotation_deg = [0, 0, 90]
"#;

    #[test]
    fn a_file_reads_to_its_solids_and_start() {
        assert!(is_scene3(TEXT) && !is_scene3("name = \"f\"\n[[half_plane]]\npoint_m = [0, 0]\nnormal = [0, 1]\n"));
        let file = SceneFile3::from_toml_str(TEXT, "c.toml").unwrap();
        assert_eq!(file.scene.name, "corner");
        let start = file.start.unwrap();
        assert_eq!(start.rear_cup_m, [0.0, 0.0, 0.1]);
        assert!((start.direction_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        let Solid3::Box { frame, .. } = &file.scene.solids[1] else { panic!("a box second") };
        // A quarter turn about z: the box's first axis along +y.
        let axis = apply(frame, [1.0, 0.0, 0.0]);
        assert!((axis[0]).abs() < 1e-15 && (axis[1] - 1.0).abs() < 1e-15, "{axis:?}");
        // The box is 0.04 m long along y after the turn: a point 0.03 m above its centre is outside.
        assert!(file.scene.solids[1].signed_distance([0.3, 0.08, 0.0]) > 0.0);
        assert!(file.scene.solids[1].signed_distance([0.32, 0.05, 0.0]) < 0.0);
        assert!(file.planar.is_none());
    }

    #[test]
    fn bad_files_name_the_field_the_value_and_what_is_allowed() {
        let bad = |from: &str, to: &str| {
            let e = SceneFile3::from_toml_str(&TEXT.replace(from, to), "c.toml").unwrap_err().to_string();
            assert!(!e.contains('\n'), "{e}");
            e
        };
        let e = bad("normal = [0, 1, 0]", "normal = [0, 2, 0]");
        assert!(e.starts_with("c.toml: half_space[0].normal") && e.contains("unit"), "{e}");
        let e = bad("half_extents_m = [0.02, 0.05, 0.5]", "half_extents_m = [0.02, 0, 0.5]");
        assert!(e.starts_with("c.toml: box[0].half_extents_m") && e.contains("above 0"), "{e}");
        let e = bad("centre_m = [0.3, 0.05, 0.0]", "centre_m = [0.3, 0.05]");
        assert!(e.starts_with("c.toml: box[0].centre_m: got 2 numbers"), "{e}");
        let e = bad("centre_m = [0.3, 0.05, 0.0]", "centre_m = [3e3, 0.05, 0.0]");
        assert!(e.starts_with("c.toml: box[0].centre_m") && e.contains("1000"), "{e}");
        let e = bad("rotation_deg = [0, 0, 90]", "rotation_deg = [0, 0, 400]");
        assert!(e.starts_with("c.toml: box[0].rotation_deg") && e.contains("360"), "{e}");
        let e = bad("rotation_deg = [0, 0, 90]", "rotation_deg = [0, nan, 9]");
        assert!(e.starts_with("c.toml: box[0].rotation_deg"), "{e}");
        let e = bad("[[box]]", "[[box]]\ncolour = 1");
        assert!(e.contains("unknown field `colour`"), "{e}");
        let e = bad("direction_deg = 90", "direction_deg = 1e9");
        assert!(e.starts_with("c.toml: start.direction_deg"), "{e}");
        let e = bad("rear_cup_m = [0.0, 0.0, 0.1]", "rear_cup_m = [0.0, 0.0, inf]");
        assert!(e.starts_with("c.toml: start.rear_cup_m z (m)"), "{e}");
        let empty = SceneFile3::from_toml_str("name = \"e\"\nbox = []\n", "e.toml").unwrap_err().to_string();
        assert!(empty.starts_with("e.toml: half_space, box") && empty.contains("1 to"), "{empty}");
    }

    #[test]
    fn a_planar_scene_keeps_its_start_in_the_plane() {
        let planar = Scene::builtin("wall").unwrap();
        let file = SceneFile3::from_planar(&planar);
        let (s, p) = (file.start.unwrap(), planar.start.unwrap());
        assert_eq!(s.rear_cup_m, [p.rear_cup_m[0], p.rear_cup_m[1], 0.0]);
        assert_eq!(s.direction_rad, p.direction_rad);
        assert_eq!(file.planar, Some(planar));
    }
}
