//! The holds and the scene of `leech shape` and `leech shape3d` (and the
//! scene of `leech scene show`): poses checked, scene files read by
//! `leech::files`, holds clear of the solids.

use std::path::Path;

use leech::body3::Body3;
use leech::error::{within, Num};
use leech::hold::{AsBuilt, Hold3, Pose3};
use leech::prelude::*;
use leech::scene::{is_scene3, Scene, SceneFile3, BUILTIN_SCENES, MAX_COORDINATE_M, ON_SURFACE_M};
use leech::stance::{self, Hold, Pose};
use leech::stance3::place3::{first_inside, hold_points, plate_frame_from_angles};

use crate::failure::Failure;
use crate::flags::{self, Hold3Arg, HoldArg, Model3Arg, ModelArg};

/// The holds of `leech shape` in its scene, checked before any solve.
pub(super) fn situation(
    a: &flags::ShapeArgs,
    robot: &Robot,
    rear: Pose,
    scene: Option<&Scene>,
) -> Result<Hold, Failure> {
    let given = a.scene.is_some() || a.hold.is_some() || a.rear.is_some() || a.front.is_some();
    if given && a.model != ModelArg::TwoChain {
        return Err(Failure::Input("--scene, --hold, --rear, --front: only with --model two-chain".into()));
    }
    let front = a.front.map(|p| pose("--front", p, 720.0)).transpose()?;
    let hold = match (a.hold.unwrap_or(HoldArg::Rear), front) {
        (HoldArg::Rear, None) => Hold::Rear(rear),
        (HoldArg::Rear, Some(_)) => return Err(Failure::Input("--front: only with --hold front or both".into())),
        (HoldArg::Front, Some(_)) if a.rear.is_some() => {
            return Err(Failure::Input("--rear: only with --hold rear or both".into()))
        }
        (HoldArg::Front, Some(front)) => Hold::Front(front),
        (HoldArg::Both, Some(front)) => Hold::Both { rear, front },
        (held, None) => {
            let name = if held == HoldArg::Front { "front" } else { "both" };
            return Err(Failure::Input(format!(
                "--hold {name}: needs --front X,Y,DEG (the endpoint and the plate's angle)"
            )));
        }
    };
    if let Some(scene) = scene {
        clear_of(scene, robot, hold, [a.rear, a.front])?;
    }
    Ok(hold)
}

/// The hold of `leech shape3d` (`None` for the constant-curvature model),
/// checked before any solve: `body` is placed for the rear hold (`placed`
/// when a scene's start put it there), and no hold may put the body or a
/// cup inside a solid of `scene`.
pub(super) fn situation3(
    a: &flags::Shape3dArgs,
    robot: &Robot,
    body: &Body3,
    scene: Option<&SceneFile3>,
    placed: bool,
) -> Result<Option<Hold3>, Failure> {
    let given = a.scene.is_some() || a.hold.is_some() || a.front.is_some();
    if a.model == Model3Arg::ConstantCurvature {
        if given {
            return Err(Failure::Input("--scene, --hold, --front: only with --model chain, expected --model chain (the constant-curvature model has no holds)".into()));
        }
        return Ok(None);
    }
    let front = a.front.map(front3).transpose()?;
    let hold = match (a.hold.unwrap_or(Hold3Arg::Rear), front) {
        (Hold3Arg::Rear, None) => Hold3::Rear(AsBuilt),
        (Hold3Arg::Rear, Some(_)) => {
            let given = a.front.map_or(String::new(), |v| v.map(|c| Num(c).to_string()).join(","));
            return Err(Failure::Input(format!(
                "--front: got {given} with the rear hold, expected --hold front, front-pivot or both with it"
            )));
        }
        (Hold3Arg::Front, Some(pose)) => Hold3::Front(pose),
        (Hold3Arg::FrontPivot, Some(pose)) => Hold3::FrontPivot(pose),
        (Hold3Arg::Both, Some(pose)) => Hold3::Both { rear: AsBuilt, front: pose },
        (held, None) => {
            let name = match held {
                Hold3Arg::Front => "front",
                Hold3Arg::FrontPivot => "front-pivot",
                _ => "both",
            };
            return Err(Failure::Input(format!(
                "--hold {name}: needs --front X,Y,Z,DEG[,YAW_DEG[,ROLL_DEG]] (tube 1's tip and the plate's angles)"
            )));
        }
    };
    if let Some(file) = scene {
        if let Some(p) = first_inside(&file.scene, &hold_points(robot, body, &hold)) {
            let [x, y, z] = p.point_m.map(|c| c * 1e3);
            let (flag, value) = match (a.front, placed) {
                (Some(v), _) => ("--front", v.map(|c| Num(c).to_string()).join(",")),
                (None, true) => ("--scene", "the scene's [start]".to_string()),
                (None, false) => ("--scene", "the rear hold at the origin".to_string()),
            };
            return Err(Failure::Input(format!(
                "{flag}: got {value}, which puts {} at ({x:.1}, {y:.1}, {z:.1}) mm inside a solid of the scene; \
                 expected free space or a surface",
                p.what
            )));
        }
    }
    Ok(Some(hold))
}

/// `--front X,Y,Z,DEG,YAW_DEG,ROLL_DEG`: tube 1's tip within the scenes'
/// bounds and the plate's frame (`place3::plate_frame_from_angles`), the
/// tangent angle within +-720 deg as `shape --front`, the turns within +-360 deg.
fn front3([x, y, z, deg, yaw, roll]: [f64; 6]) -> Result<Pose3, InputError> {
    let m = MAX_COORDINATE_M;
    let tip =
        [within("--front x (m)", x, -m, m)?, within("--front y (m)", y, -m, m)?, within("--front z (m)", z, -m, m)?];
    let angle = within("--front angle (deg)", deg, -720.0, 720.0)?;
    let yaw = within("--front yaw (deg)", yaw, -360.0, 360.0)?;
    let roll = within("--front roll (deg)", roll, -360.0, 360.0)?;
    Ok(Pose3 { point_m: tip, frame: plate_frame_from_angles(angle.to_radians(), yaw.to_radians(), roll.to_radians()) })
}

/// A pose from `X,Y,DEG`: coordinates within the scenes' bounds, the angle within `+-max_deg`.
pub(super) fn pose(flag: &str, [x, y, deg]: [f64; 3], max_deg: f64) -> Result<Pose, InputError> {
    let m = MAX_COORDINATE_M;
    let point = [within(&format!("{flag} x (m)"), x, -m, m)?, within(&format!("{flag} y (m)"), y, -m, m)?];
    Ok(Pose::from_deg(point, within(&format!("{flag} angle (deg)"), deg, -max_deg, max_deg)?))
}

/// Rejects holds inside the scene's solids: the driving unit's point and
/// the endpoint deeper than [`ON_SURFACE_M`], the cups' centres (each cup
/// sits on chain B's side: `b` or `c` plus its offset along `nu`) deeper
/// than that plus the robot file's preload (a planner presses them in by it).
/// `given` is --rear's and --front's values as typed, which a refusal quotes.
fn clear_of(scene: &Scene, robot: &Robot, hold: Hold, given: [Option<[f64; 3]>; 2]) -> Result<(), Failure> {
    let (point, pressed) = (ON_SURFACE_M, ON_SURFACE_M + robot.cup.preload_m);
    let mut points = Vec::new();
    if let Some(p) = hold.rear() {
        let cup = stance::rear_cup_centre(robot, p);
        points.extend([
            ("--rear", given[0], "the driving unit", p.point_m, point),
            ("--rear", given[0], "the rear cup's centre", cup, pressed),
        ]);
    }
    if let Some(p) = hold.front() {
        let cup = stance::front_cup_centre(robot, p);
        points.extend([
            ("--front", given[1], "the endpoint", p.point_m, point),
            ("--front", given[1], "the front cup's centre", cup, pressed),
        ]);
    }
    // A point on a surface is clear, to rounding; so is the held unit's
    // outline (on the surface it rests on, pressed in by the preload).
    let outline = hold.rear().and_then(|p| stance::held_unit_overlap(robot, p, scene)).map(|overlap| {
        let what = format!("the driving unit's outline {:.1} mm deep", overlap.depth_m * 1e3);
        ("--rear", given[0], what, overlap.point_m)
    });
    let inside = points.into_iter().find(|(_, _, _, p, depth)| !scene.is_free(*p, -depth));
    match inside.map(|(flag, typed, what, p, _)| (flag, typed, what.to_owned(), p)).or(outline) {
        Some((flag, typed, what, [x, y])) => {
            // Without --rear, the scene's [start] placed the robot.
            let value = match typed {
                Some(v) => v.map(|c| Num(c).to_string()).join(","),
                None => "the scene's [start]".into(),
            };
            Err(Failure::Input(format!(
                "{flag}: got {value}, which puts {what} at ({:.1}, {:.1}) mm inside a solid of the scene; expected free space or a surface",
                x * 1e3,
                y * 1e3
            )))
        }
        None => Ok(()),
    }
}

/// A built-in scene by name (with its file's text), else a scene file.
pub(super) fn load_scene(given: &Path, flag: &str) -> Result<(Scene, Option<&'static str>), Failure> {
    if let Some(b) = given.to_str().and_then(|name| BUILTIN_SCENES.iter().find(|s| s.name == name)) {
        return Ok((Scene::builtin(b.name)?, Some(b.toml)));
    }
    if !given.exists() {
        let names: Vec<&str> = BUILTIN_SCENES.iter().map(|s| s.name).collect();
        let given = given.display();
        return Err(Failure::Input(format!(
            "{flag}: got '{given}', expected a scene file or one of {}",
            names.join(", ")
        )));
    }
    let text = leech::files::read_text(given, flag, leech::files::SCENE_FILE)?;
    Ok((Scene::from_toml_str(&text, &given.display().to_string())?, None))
}

/// A scene for the 3D body: a built-in scene's name or a planar scene file
/// read in 3D (prisms along z), or a 3D scene file (`half_space`, `box`).
pub(super) fn load_scene3(given: &Path, flag: &str) -> Result<SceneFile3, Failure> {
    let builtin = given.to_str().is_some_and(|name| BUILTIN_SCENES.iter().any(|s| s.name == name));
    if builtin || !given.is_file() {
        return Ok(SceneFile3::from_planar(&load_scene(given, flag)?.0));
    }
    let text = leech::files::read_text(given, flag, leech::files::SCENE_FILE)?;
    let source = given.display().to_string();
    if is_scene3(&text) {
        return Ok(SceneFile3::from_toml_str(&text, &source)?);
    }
    Ok(SceneFile3::from_planar(&Scene::from_toml_str(&text, &source)?))
}
