//! `leech climb` and `leech scenario`: scenarios by name or file, or built
//! from a scene and the start and goal flags; the planner's options.

use std::path::Path;

use leech::error::within;
use leech::prelude::*;
use leech::scene::MAX_COORDINATE_M;
use leech::stride::scenario::MAX_TOLERANCE_M;
use leech::stride::sideways::BUILTIN_SIDEWAYS;
use leech::stride::{Foothold, Goal, PlanOptions, Scenario, SidewaysScenario, BUILTIN_SCENARIOS};

use super::holds::{load_scene, pose};
use super::{tuned, Outputs};
use crate::failure::Failure;
use crate::flags;

/// The goal tolerance `--tolerance` defaults to (m): a little more than half the built-in robot's cup.
pub const DEFAULT_TOLERANCE_M: f64 = 0.03;

/// `leech climb`: the robot, the climb and the planner's options.
pub struct Climb {
    pub robot: Robot,
    pub scenario: Scenario,
    pub options: PlanOptions,
    /// JSON or text on standard output; `csv` the steps' table, `svg` the animation.
    pub outputs: Outputs,
}

/// `leech climb` of a sideways scenario: the robot and the climb (JSON or
/// text, and its picture).
pub struct ClimbSideways {
    pub robot: Robot,
    pub scenario: SidewaysScenario,
    /// Its solves share `--time-limit`'s deadline.
    pub solver: Solver,
    pub json: bool,
    /// The plan's three views.
    pub svg: Option<std::path::PathBuf>,
}

/// The sideways climb `--scenario` names (a built-in one, or a file with a
/// `[wall]` table), if it is one. Its plan has a picture, no table yet.
pub(super) fn sideways(a: &flags::ClimbArgs) -> Result<Option<ClimbSideways>, Failure> {
    let Some(given) = &a.scenario else { return Ok(None) };
    let scenario = match given.to_str().and_then(SidewaysScenario::builtin) {
        Some(builtin) => builtin?,
        None if given.is_file() => {
            let text = leech::files::read_text(given, "--scenario", leech::files::SCENE_FILE)?;
            if !SidewaysScenario::is_sideways(&text) {
                return Ok(None);
            }
            SidewaysScenario::parse(&text, &given.display().to_string())?
        }
        None => return Ok(None),
    };
    if a.csv.is_some() {
        return Err(Failure::Input("--csv: a sideways climb (the 3D body) has no table yet; expected no --csv".into()));
    }
    if let Some(svg) = &a.svg {
        leech::files::check_output(svg, "--svg", None)?;
    }
    let solver = Solver::new(SolverOptions { deadline: super::deadline(a.time_limit)?, ..SolverOptions::default() });
    Ok(Some(ClimbSideways { robot: tuned(&a.robot, Ok)?, scenario, solver, json: a.json, svg: a.svg.clone() }))
}

pub(super) fn climb(a: flags::ClimbArgs) -> Result<Climb, Failure> {
    let scenario = match (&a.scenario, &a.scene) {
        (Some(path), _) => load_scenario(path, "--scenario")?.0,
        (None, Some(scene)) => flagged(&a, scene)?,
        (None, None) => return Err(Failure::Input("--scenario or --scene: give one".into())),
    };
    let robot = tuned(&a.robot, Ok)?;
    scenario.check_start(&robot).map_err(|e| match (&a.scenario, e) {
        (None, InputError::Invalid { value, allowed, .. }) => {
            Failure::Input(format!("--start: got {value}, expected {allowed}"))
        }
        (_, e) => e.into(),
    })?;
    scenario.check_goal().map_err(|e| match (&a.scenario, e) {
        (None, InputError::Invalid { value, allowed, .. }) => {
            Failure::Input(format!("--goal: got {value}, expected {allowed}"))
        }
        (_, e) => e.into(),
    })?;
    let options = PlanOptions { deadline: super::deadline(a.time_limit)?, ..PlanOptions::default() };
    let outputs = Outputs { json: a.json, csv: a.csv, svg: a.svg, ..Outputs::default() };
    Ok(Climb { robot, scenario, options, outputs })
}

/// The climb `--scene`, `--start`, `--goal` and `--tolerance` describe.
fn flagged(a: &flags::ClimbArgs, scene: &Path) -> Result<Scenario, Failure> {
    let (scene, _) = load_scene(scene, "--scene")?;
    let (Some(start), Some([x, y])) = (a.start, a.goal) else {
        return Err(Failure::Input("--scene: needs --start X,Y,DEG and --goal X,Y".into()));
    };
    let start = pose("--start", start, 360.0)?;
    let m = MAX_COORDINATE_M;
    let point_m = [within("--goal x (m)", x, -m, m)?, within("--goal y (m)", y, -m, m)?];
    let tolerance_m = a.tolerance.unwrap_or(DEFAULT_TOLERANCE_M);
    if !(tolerance_m.is_finite() && tolerance_m > 0.0 && tolerance_m <= MAX_TOLERANCE_M) {
        return Err(InputError::invalid(
            "--tolerance (m)",
            tolerance_m,
            format!("a number above 0 and at most {MAX_TOLERANCE_M}"),
        )
        .into());
    }
    Ok(Scenario {
        name: scene.name.clone(),
        description: String::new(),
        scene,
        start: Foothold { centre_m: start.point_m, direction_rad: start.angle_rad },
        goal: Goal { point_m, tolerance_m },
    })
}

/// A built-in scenario by name (with its file's text), else a scenario file (and its text).
pub(super) fn load_scenario(given: &Path, flag: &str) -> Result<(Scenario, String), Failure> {
    if let Some(b) = given.to_str().and_then(|name| BUILTIN_SCENARIOS.iter().find(|s| s.name == name)) {
        return Ok((Scenario::builtin(b.name)?, b.toml.to_string()));
    }
    if !given.exists() {
        if let Some(b) = given.to_str().and_then(|name| BUILTIN_SIDEWAYS.iter().find(|s| s.name == name)) {
            return Err(Failure::Input(format!(
                "{flag}: got '{}', a sideways climb (the 3D body): `leech climb --scenario {}` plans it",
                b.name, b.name
            )));
        }
        // Not a file: the library says which names it knows (and why a sideways climb is not one).
        let allowed = match Scenario::builtin(&given.to_string_lossy()) {
            Err(InputError::Invalid { allowed, .. }) => allowed,
            _ => String::new(),
        };
        return Err(Failure::Input(format!(
            "{flag}: got '{}', expected a scenario file or {allowed}",
            given.display()
        )));
    }
    let text = leech::files::read_text(given, flag, leech::files::SCENE_FILE)?;
    let scenario = Scenario::parse(&text, &given.display().to_string())?;
    Ok((scenario, text))
}
