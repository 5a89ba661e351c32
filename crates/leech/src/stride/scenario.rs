//! Climb scenarios: a scene, where the rear cup starts and where the climb
//! should end, read from TOML with one-line errors.
//!
//! ```
//! use leech::stride::Scenario;
//! let scenario = Scenario::from_toml_str(r#"
//! name = "crawl on the floor"
//! description = "half a metre ahead"
//! scene = "floor"              # a built-in scene, or an inline [scene] table
//! [start]
//! rear_cup = [0.0, 0.0, 0.0]   # x, y (m), heading (deg)
//! [goal]
//! point_m = [0.5, 0.0]
//! tolerance_m = 0.03
//! "#, "example").unwrap();
//! assert_eq!(scenario.start.centre_m, [0.0, 0.0]);
//! assert_eq!(scenario.goal.point_m, [0.5, 0.0]);
//! ```
//!
//! The file's keys:
//!
//! * `name` (required) and `description` (optional): printable text.
//! * `scene`: a built-in scene's name ([`Scene::builtin_names`]), or instead
//!   an inline `[scene]` table holding a scene file's contents (its own
//!   `name`, `[[scene.half_plane]]` and `[[scene.polygon]]` tables).
//! * `[start] rear_cup = [x, y, heading]`: the rear cup's face centre (m) on
//!   a surface and the body's direction (deg, within +-360), which is the
//!   surface's direction there (free space on the left, the cups on the
//!   right): the face must lie flush ([`Scenario::check_start`]).
//! * `[goal] point_m = [x, y]`, `tolerance_m` (above 0, at most
//!   [`MAX_TOLERANCE_M`]): where the rear cup's face centre should land.
//!
//! Coordinates are bounded as in scene files ([`MAX_COORDINATE_M`]), the
//! text as a scene file's ([`crate::scene::MAX_SCENE_BYTES`]), and unknown keys are errors.
//! Built-in scenarios ([`Scenario::builtin`]) are such files under
//! `crates/leech/scenarios/`.

use serde::Deserialize;

use super::plan::{Foothold, Goal};
use crate::error::{within, InputError};
use crate::robot::{Cup, Robot};
use crate::scene::file::{inline_scene_error, parse_bounded};
use crate::scene::{Scene, MAX_COORDINATE_M};

/// The largest goal tolerance a scenario may ask for (m).
pub const MAX_TOLERANCE_M: f64 = 1.0;

/// A climb to plan: the scene, the rear cup's start and the goal.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// Display name.
    pub name: String,
    /// One line saying what it is (may be empty).
    pub description: String,
    /// The surroundings.
    pub scene: Scene,
    /// The rear cup's face on a surface, the body heading along it.
    pub start: Foothold,
    /// Where the rear cup's face centre should land.
    pub goal: Goal,
}

/// A scenario shipped with the library.
#[derive(Clone, Copy, Debug)]
pub struct BuiltinScenario {
    /// The name [`Scenario::builtin`] takes.
    pub name: &'static str,
    /// The scenario file, comments included.
    pub toml: &'static str,
}

/// Every built-in scenario, simplest first.
pub const BUILTIN_SCENARIOS: [BuiltinScenario; 7] = [
    BuiltinScenario { name: "crawl-floor", toml: include_str!("../../scenarios/crawl-floor.toml") },
    BuiltinScenario { name: "climb-wall-up", toml: include_str!("../../scenarios/climb-wall-up.toml") },
    BuiltinScenario { name: "climb-wall-down", toml: include_str!("../../scenarios/climb-wall-down.toml") },
    BuiltinScenario { name: "floor-to-wall", toml: include_str!("../../scenarios/floor-to-wall.toml") },
    BuiltinScenario { name: "wall-to-floor", toml: include_str!("../../scenarios/wall-to-floor.toml") },
    BuiltinScenario { name: "over-thin-wall", toml: include_str!("../../scenarios/over-thin-wall.toml") },
    BuiltinScenario { name: "wall-to-ceiling", toml: include_str!("../../scenarios/wall-to-ceiling.toml") },
];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScenario {
    name: String,
    #[serde(default)]
    description: String,
    scene: toml::Value,
    start: RawStart,
    goal: RawGoal,
}

/// Lists are read as vectors and their lengths checked here (serde would
/// read a fixed-size array from the first elements of a longer list).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStart {
    rear_cup: Vec<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGoal {
    point_m: Vec<f64>,
    tolerance_m: f64,
}

impl Scenario {
    /// Parses and validates a scenario file; `source` (a path, or a built-in
    /// name) starts every error message. The start is checked against the
    /// built-in robot's cup ([`Scenario::check_start`]); for another robot
    /// use [`Scenario::parse`] and check it against that robot's cup.
    pub fn from_toml_str(text: &str, source: &str) -> Result<Scenario, InputError> {
        let scenario = Scenario::parse(text, source)?;
        scenario.check_cup(&Cup::default(), source)?;
        Ok(scenario)
    }

    /// [`Scenario::from_toml_str`] without the start's check against a cup.
    pub fn parse(text: &str, source: &str) -> Result<Scenario, InputError> {
        let raw: RawScenario = parse_bounded(text, source, "scenario")?;
        let scene = scene(&raw.scene, text, source)?;
        let m = MAX_COORDINATE_M;
        let start = match raw.start.rear_cup.as_slice() {
            [x, y, deg] => Foothold {
                centre_m: [
                    within(&format!("{source}: start.rear_cup x (m)"), *x, -m, m)?,
                    within(&format!("{source}: start.rear_cup y (m)"), *y, -m, m)?,
                ],
                direction_rad: within(&format!("{source}: start.rear_cup heading (deg)"), *deg, -360.0, 360.0)?
                    .to_radians(),
            },
            other => {
                return Err(InputError::Invalid {
                    field: format!("{source}: start.rear_cup"),
                    value: count(other.len()),
                    allowed: "[x, y, heading]: x and y in m, the heading in deg".into(),
                })
            }
        };
        let point_m = match raw.goal.point_m.as_slice() {
            [x, y] => [
                within(&format!("{source}: goal.point_m x (m)"), *x, -m, m)?,
                within(&format!("{source}: goal.point_m y (m)"), *y, -m, m)?,
            ],
            other => {
                return Err(InputError::Invalid {
                    field: format!("{source}: goal.point_m"),
                    value: count(other.len()),
                    allowed: "a point [x, y] of two numbers (m)".into(),
                })
            }
        };
        let tolerance_m = goal_tolerance(source, raw.goal.tolerance_m)?;
        crate::error::printable(&format!("{source}: name"), &raw.name)?;
        crate::error::printable(&format!("{source}: description"), &raw.description)?;
        let scenario = Scenario {
            name: raw.name,
            description: raw.description,
            scene,
            start,
            goal: Goal { point_m, tolerance_m },
        };
        Ok(scenario)
    }

    /// Whether the start lies on a surface for `robot`: the rear cup's face,
    /// centred on the start point along the heading, lies flush on one edge
    /// within the robot file's attach tolerances ([`Scene::flat_on_one_edge`]).
    pub fn check_start(&self, robot: &Robot) -> Result<(), InputError> {
        self.check_cup(&robot.cup, &self.name)
    }

    /// Whether the goal can be reached at all: a rear cup's face centre
    /// lies on a surface, so the goal must be within its tolerance of one.
    pub fn check_goal(&self) -> Result<(), InputError> {
        let Goal { point_m: [x, y], tolerance_m } = self.goal;
        let (d, ..) = self.scene.signed_distance(self.goal.point_m);
        if d.abs() <= tolerance_m {
            return Ok(());
        }
        let place = if d < 0.0 { "inside a solid" } else { "in free space" };
        Err(InputError::Invalid {
            field: format!("{}: goal.point_m", self.name),
            value: format!("[{x}, {y}] ({place}, {:.4} m from the nearest surface)", d.abs()),
            allowed: format!("a point within the goal's tolerance ({tolerance_m} m) of a surface"),
        })
    }

    fn check_cup(&self, cup: &Cup, source: &str) -> Result<(), InputError> {
        let Foothold { centre_m: [x, y], direction_rad } = self.start;
        let flush = self.scene.flat_on_one_edge(
            self.start.centre_m,
            direction_rad,
            0.5 * cup.diameter_m,
            cup.attach_distance_tolerance_m,
            cup.attach_angle_tolerance_deg.to_radians(),
        );
        if flush {
            return Ok(());
        }
        let (d, ..) = self.scene.signed_distance(self.start.centre_m);
        let surface = self.scene.surface_frame(self.start.centre_m).map_or(0.0, |(_, a)| a);
        Err(InputError::Invalid {
            field: format!("{source}: start.rear_cup"),
            value: format!(
                "[{x}, {y}, {:.4}] ({d:.4} m from the nearest surface, whose direction there is {:.1} deg)",
                direction_rad.to_degrees(),
                surface.to_degrees()
            ),
            allowed: format!(
                "the rear cup's face ({} m across) flush on one surface: within {} m of it and {} deg of its \
                 direction (free space on the left)",
                cup.diameter_m, cup.attach_distance_tolerance_m, cup.attach_angle_tolerance_deg
            ),
        })
    }

    /// The built-in scenario called `name` (see [`BUILTIN_SCENARIOS`]).
    pub fn builtin(name: &str) -> Result<Scenario, InputError> {
        match BUILTIN_SCENARIOS.iter().find(|s| s.name == name) {
            Some(s) => Scenario::from_toml_str(s.toml, &format!("built-in scenario {name}")),
            // The paper's sideways climb turns the body in the wall's plane.
            None if name.to_ascii_lowercase().contains("sideways") => Err(InputError::Invalid {
                field: "scenario".into(),
                value: format!("{name:?}"),
                allowed: format!(
                    "a planar scenario (the sideways maneuver bends the body out of this model's plane: the 3D \
                     body plans it, `sideways-wall`): one of {}",
                    BUILTIN_SCENARIOS.map(|s| s.name).join(", ")
                ),
            }),
            None => Err(InputError::Invalid {
                field: "scenario".into(),
                value: format!("{name:?}"),
                allowed: format!("one of {}", BUILTIN_SCENARIOS.map(|s| s.name).join(", ")),
            }),
        }
    }

    /// The built-in scenarios' names with their one-line descriptions.
    pub fn builtin_names() -> impl Iterator<Item = (&'static str, &'static str)> {
        BUILTIN_SCENARIOS.iter().map(|s| (s.name, description(s.toml)))
    }

    /// What `leech scenario list` lists: [`Scenario::builtin_names`], then
    /// the sideways climbs of the 3D body ([`super::sideways::BUILTIN_SIDEWAYS`]).
    pub fn listed() -> impl Iterator<Item = (&'static str, &'static str)> {
        Scenario::builtin_names().chain(super::sideways::BUILTIN_SIDEWAYS.iter().map(|s| (s.name, description(s.toml))))
    }
}

/// The `description = "..."` line of a built-in scenario file.
fn description(toml: &'static str) -> &'static str {
    toml.lines().find_map(|l| l.strip_prefix("description = \"")).and_then(|rest| rest.strip_suffix('"')).unwrap_or("")
}

/// The scene a `scene` value of the file `text` names or holds.
fn scene(value: &toml::Value, text: &str, source: &str) -> Result<Scene, InputError> {
    match value {
        toml::Value::String(name) => Scene::builtin(name).map_err(|e| match e {
            InputError::Invalid { value, allowed, .. } => {
                InputError::Invalid { field: format!("{source}: scene"), value, allowed }
            }
            other => other,
        }),
        toml::Value::Table(table) => {
            let table_text = toml::to_string(table).map_err(|e| InputError::File {
                file: format!("{source}: [scene]"),
                message: e.to_string().split_whitespace().collect::<Vec<_>>().join(" "),
            })?;
            Scene::from_toml_str(&table_text, &format!("{source}: [scene]")).map_err(|e| match e {
                // A reading error: say where in the scenario's own text.
                InputError::File { .. } => inline_scene_error(text, source).unwrap_or(e),
                other => other,
            })
        }
        other => Err(InputError::Invalid {
            field: format!("{source}: scene"),
            value: format!("a {}", other.type_str()),
            allowed: "a built-in scene's name, or a [scene] table holding a scene file's contents".into(),
        }),
    }
}

/// A scenario's `goal.tolerance_m`: above 0 and at most [`MAX_TOLERANCE_M`].
pub(crate) fn goal_tolerance(source: &str, tolerance_m: f64) -> Result<f64, InputError> {
    if tolerance_m.is_finite() && tolerance_m > 0.0 && tolerance_m <= MAX_TOLERANCE_M {
        return Ok(tolerance_m);
    }
    Err(InputError::invalid(
        format!("{source}: goal.tolerance_m"),
        tolerance_m,
        format!("a number of m above 0 and at most {MAX_TOLERANCE_M}"),
    ))
}

fn count(n: usize) -> String {
    format!("{n} number{}", if n == 1 { "" } else { "s" })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "name = \"n\"\nscene = \"floor\"\n[start]\nrear_cup = [0, 0, 0]\n[goal]\npoint_m = [0.5, 0]\ntolerance_m = 0.03\n";

    #[test]
    fn an_inline_scene_error_names_the_line_of_the_scenario() {
        let text = "name = \"n\"\n[start]\nrear_cup = [0, 0, 0]\n[goal]\npoint_m = [0.5, 0]\ntolerance_m = 0.03\n\
                    [scene]\nname = \"s\"\n[[scene.half_plane]]\npoint_m = [0, 0]\nnormal = [0, 1]\ncolour = 2\n";
        let e = Scenario::parse(text, "x.toml").unwrap_err().to_string();
        assert!(e.contains("x.toml: [scene]: line 12: unknown field `colour`"), "{e}");
    }

    #[test]
    fn every_builtin_parses_with_its_start_on_a_surface() {
        let robot = Robot::builtin();
        let names: Vec<_> = Scenario::builtin_names().collect();
        assert_eq!(names.len(), 7);
        for (name, description) in names {
            let s = Scenario::builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(!description.is_empty() && !description.contains('\n'), "{name}");
            assert_eq!(description, s.description);
            s.check_start(&robot).unwrap_or_else(|e| panic!("{name}: {e}"));
            s.check_goal().unwrap_or_else(|e| panic!("{name}: {e}"));
            // The start's face centre is on the surface, heading along it.
            let (d, ..) = s.scene.signed_distance(s.start.centre_m);
            let (_, direction) = s.scene.surface_frame(s.start.centre_m).unwrap();
            assert!(d.abs() < 1e-12, "{name}: {d}");
            assert!(crate::geom::angle_difference(direction, s.start.direction_rad).abs() < 1e-9, "{name}");
            assert!(s.goal.tolerance_m > 0.0);
        }
        let e = Scenario::builtin("moon").unwrap_err().to_string();
        assert!(e.contains("\"moon\"") && e.contains("wall-to-ceiling"), "{e}");
    }

    #[test]
    fn the_downward_wall_faces_the_cups() {
        let s = Scenario::builtin("climb-wall-down").unwrap();
        assert!(s.scene.inside([-0.01, 0.0]) && !s.scene.inside([0.01, 0.0]));
        assert_eq!(s.start.direction_rad, (-90.0_f64).to_radians());
    }

    #[test]
    fn errors_are_one_line_and_name_the_field() {
        let bad = |text: &str| Scenario::from_toml_str(text, "s.toml").unwrap_err().to_string();
        let e = bad(&TEXT.replace("[goal]", "[goal]\ncolour = 1"));
        assert!(e.starts_with("s.toml: line 6: unknown field `colour`"), "{e}");
        let e = bad(&TEXT.replace("[0, 0, 0]", "[0, 0]"));
        assert!(e.contains("start.rear_cup") && e.contains("2 numbers"), "{e}");
        let e = bad(&TEXT.replace("[0, 0, 0]", "[0, 0.1, 0]"));
        assert!(e.contains("start.rear_cup") && e.contains("flush"), "{e}");
        let e = bad(&TEXT.replace("[0, 0, 0]", "[0, 0, 30]"));
        assert!(e.contains("start.rear_cup: got [0, 0, 30.0000]"), "{e}");
        let e = bad(&TEXT.replace("0.03", "0"));
        assert!(e.contains("goal.tolerance_m: got 0"), "{e}");
        let e = bad(&TEXT.replace("\"floor\"", "\"cliff\""));
        assert!(e.starts_with("s.toml: scene: got \"cliff\""), "{e}");
        let e = bad(&TEXT.replace("scene = \"floor\"", "scene = 3"));
        assert!(e.contains("scene: got a integer"), "{e}");
        let inline = TEXT.replace("scene = \"floor\"\n", "")
            + "[scene]\nname = \"f\"\n[[scene.half_plane]]\npoint_m = [0, 0]\nnormal = [0, 2]\n";
        let e = bad(&inline);
        assert!(e.starts_with("s.toml: [scene]: half_plane[0].normal"), "{e}");
        for e in [bad(&inline), bad("x = 1")] {
            assert!(!e.contains('\n'), "{e}");
        }
        let ok = inline.replace("[0, 2]", "[0, 1]");
        assert_eq!(Scenario::from_toml_str(&ok, "s.toml").unwrap().scene.solids.len(), 1);
    }
}
