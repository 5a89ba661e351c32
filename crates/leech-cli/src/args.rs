//! Flags resolved once into what a command needs: the robot, the solver,
//! checked numbers, library enums and where the results go.
//!
//! The library checks most values itself and names the field; the checks
//! here are those of flags the library never sees (`--time-limit`,
//! `--repeat`, `--speed`, ...). Values are resolved in the order the commands
//! always met them, so input with two mistakes still names the same one.

use std::num::NonZeroUsize;
use std::path::{Path, PathBuf};
use std::time::Duration;

use leech::body3::Body3;
use leech::budget::Deadline;
use leech::hold::Hold3;

use leech::calibration::{read_sag, read_shapes, BodyShape, Fit, SagTube};
use leech::chain::Discretization;
use leech::dynamics::{Actuation, Integrator, SimulationOptions, Start};
use leech::error::{non_negative, positive, within, InputError, Num};
use leech::files::{self, check_output, read_text};
use leech::inverse_statics::check_target;
use leech::prelude::*;
use leech::scene::{Scene, SceneFile3};
use leech::stance::{FreeCups, Hold, Pose};
use leech::stride::Scenario;
use leech::sweep::{Grid, Model, SweepOptions};

use crate::failure::Failure;
use crate::flags::{
    self, Command, DiscretizationArg, FitArg, FreeCupsArg, IntegratorArg, ModelArg, RobotChoice, ScenarioCommand,
    SceneCommand, StartArg,
};

mod climb;
mod holds;
mod link;
pub(crate) mod serve;

pub use link::{Action, Drive, Run, SimRobot};
pub use serve::Serve;

pub use climb::{Climb, ClimbSideways};
use holds::{load_scene, load_scene3, pose, situation, situation3};

/// A command with its resolved arguments.
// One value per run, moved once: boxing the large variants would buy nothing.
#[allow(clippy::large_enum_variant)]
pub enum Args {
    /// `leech robot`: `None` prints the built-in robot file with its comments.
    Robot {
        robot: Option<Robot>,
        json: bool,
    },
    Chain(Chain),
    Shape(Shape),
    Shape3d(Shape3d),
    Figure(Figure),
    Workspace(Workspace),
    Reach(Reach),
    Calibrate(Calibrate),
    Compare(Compare),
    Simulate(Simulate),
    /// `leech scene list`.
    Scenes {
        json: bool,
    },
    /// `leech scene show`: a built-in scene's file keeps its comments.
    SceneShow {
        scene: Scene,
        builtin: Option<&'static str>,
        json: bool,
    },
    Climb(Climb),
    /// `leech climb` of a sideways scenario (the 3D body).
    ClimbSideways(ClimbSideways),
    /// `leech scenario list`.
    Scenarios {
        json: bool,
    },
    /// `leech scenario show`: the file's text as given (a built-in one's with its comments).
    ScenarioShow {
        scenario: Scenario,
        text: String,
        json: bool,
    },
    SimRobot(SimRobot),
    Drive(Drive),
    Serve(Serve),
}

/// Where results go: JSON or text on standard output, and the files asked for.
#[derive(Default)]
pub struct Outputs {
    /// JSON instead of text on standard output.
    pub json: bool,
    /// A picture (an animation for `leech simulate`).
    pub svg: Option<PathBuf>,
    pub png: Option<PathBuf>,
    /// A time series (`leech simulate`).
    pub csv: Option<PathBuf>,
}

/// `leech chain`: a built tube.
pub struct Chain {
    pub tube: Cantilever,
    /// What it was built from (a tube in a scene is fed from a shorter length).
    pub spec: CantileverSpec,
    pub elements: usize,
    pub shape_parameter: f64,
    pub solver: Solver,
    /// What the tube rests on, with the tube's radius (m).
    pub scene: Option<(Scene, f64)>,
    pub outputs: Outputs,
}

/// `leech shape`.
pub struct Shape {
    pub robot: Robot,
    pub lengths: [f64; 2],
    pub body: Body,
    /// The models to evaluate, the two-chain model first.
    pub models: Vec<Model>,
    /// The two-chain model's solver; `None` when only the constant-curvature model runs.
    pub solver: Option<Solver>,
    /// Cold solves to time (with the two-chain model only).
    pub repeat: Option<NonZeroUsize>,
    /// Which cups hold, where (by default the rear hold at the scene's start, else at the origin and the base angle).
    pub hold: Hold,
    /// What the tubes rest on.
    pub scene: Option<Scene>,
    /// Whether the free cups' faces rest on the scene's solids too.
    pub free_cups: FreeCups,
    pub outputs: Outputs,
}

impl Shape {
    /// Whether the body is today's clamped body: held by the rear cup at the
    /// origin at the robot's base angle, without a scene.
    pub fn clamped(&self) -> bool {
        self.scene.is_none() && self.hold == Hold::Rear(Pose::from_deg([0.0, 0.0], self.robot.world.base_angle_deg))
    }
}

/// `leech shape3d`: the body held by a cup (the rear one at the origin, or
/// where a scene's start puts it, by default), among a scene's solids if
/// given; or the constant-curvature model.
pub struct Shape3d {
    pub robot: Robot,
    pub lengths: [f64; 3],
    /// Placed for the rear hold (a scene's start moves it).
    pub body: Body3,
    pub free_axial_rotation: bool,
    /// The 3D solve's and the planar one's beside it.
    pub solver: Solver,
    /// `None` with --model constant-curvature.
    pub hold: Option<Hold3>,
    pub scene: Option<SceneFile3>,
    pub outputs: Outputs,
}

/// `leech figure`.
pub struct Figure {
    pub robot: Robot,
    pub names: Vec<String>,
    pub dir: PathBuf,
}

/// `leech workspace`.
pub struct Workspace {
    pub robot: Robot,
    pub options: SweepOptions,
    /// The range as given, for the picture's title.
    pub range: String,
    /// The CSV of every grid point (`--out`).
    pub csv: PathBuf,
    pub outputs: Outputs,
}

/// `leech reach`.
pub struct Reach {
    pub robot: Robot,
    pub target: [f64; 2],
    /// Target plate angle (rad).
    pub angle: Option<f64>,
    pub grid: Grid,
    pub json: bool,
    pub deadline: Deadline,
}

/// A measurement file's contents and its name as the user gave it.
pub struct Measured<T> {
    pub name: String,
    pub rows: Vec<T>,
}

/// `leech calibrate`.
pub struct Calibrate {
    pub robot: Robot,
    pub sag: Measured<SagTube>,
    pub shapes: Option<Measured<BodyShape>>,
    pub fit: Fit,
    pub deadline: Deadline,
    /// The fitted robot file.
    pub out: PathBuf,
    pub outputs: Outputs,
}

/// `leech compare`.
pub struct Compare {
    pub robot: Robot,
    pub shapes: Vec<BodyShape>,
    pub json: bool,
    pub deadline: Deadline,
}

/// `leech simulate`: the animation is `outputs.svg`.
pub struct Simulate {
    pub robot: Robot,
    pub lengths: [f64; 2],
    pub start: Start,
    pub actuation: Actuation,
    pub options: SimulationOptions,
    pub outputs: Outputs,
}

impl Args {
    /// Checks the flags and loads what they name.
    pub fn resolve(command: Command) -> Result<Args, Failure> {
        let args = Args::resolve_flags(command)?;
        args.check_outputs()?;
        Ok(args)
    }

    fn resolve_flags(command: Command) -> Result<Args, Failure> {
        Ok(match command {
            Command::Robot { robot, json } => {
                Args::Robot { robot: robot.as_deref().map(load_robot).transpose()?, json }
            }
            Command::Chain(a) => Args::Chain(chain(a)?),
            Command::Shape(a) => Args::Shape(shape(a)?),
            Command::Shape3d(a) => Args::Shape3d(shape3d(a)?),
            Command::Figure(a) => Args::Figure(Figure {
                robot: tuned(&a.robot, Ok)?,
                names: match a.name.as_str() {
                    "all" => leech_plot::figures::NAMES.iter().map(|n| n.to_string()).collect(),
                    _ => vec![a.name],
                },
                dir: a.out,
            }),
            Command::Workspace(a) => Args::Workspace(workspace(a)?),
            Command::Reach(a) => Args::Reach(reach(a)?),
            Command::Calibrate(a) => {
                // Flags before files, as compare.
                let deadline = deadline(a.time_limit)?;
                Args::Calibrate(Calibrate {
                    robot: tuned(&a.robot, Ok)?,
                    sag: measured(&a.sag, "--sag", read_sag)?,
                    shapes: a.shapes.as_deref().map(|p| measured(p, "--shapes", read_shapes)).transpose()?,
                    fit: a.fit.into(),
                    deadline,
                    out: a.out,
                    outputs: Outputs { json: a.json, svg: a.svg, ..Outputs::default() },
                })
            }
            Command::Compare(a) => {
                // Flags before files: a bad --time-limit is found without reading the file.
                let deadline = deadline(a.time_limit)?;
                Args::Compare(Compare {
                    robot: tuned(&a.robot, Ok)?,
                    shapes: measured(&a.shapes, "--shapes", read_shapes)?.rows,
                    json: a.json,
                    deadline,
                })
            }
            Command::Simulate(a) => Args::Simulate(simulate(a)?),
            Command::Scene(a) => match a.command {
                SceneCommand::List { json } => Args::Scenes { json },
                SceneCommand::Show { scene, json } => {
                    let (scene, builtin) = load_scene(&scene, "scene show")?;
                    Args::SceneShow { scene, builtin, json }
                }
            },
            Command::Climb(a) => match climb::sideways(&a)? {
                Some(sideways) => Args::ClimbSideways(sideways),
                None => Args::Climb(climb::climb(a)?),
            },
            Command::Scenario(a) => match a.command {
                ScenarioCommand::List { json } => Args::Scenarios { json },
                ScenarioCommand::Show { scenario, json } => {
                    let (scenario, text) = climb::load_scenario(&scenario, "scenario show")?;
                    Args::ScenarioShow { scenario, text, json }
                }
            },
            Command::SimRobot(a) => Args::SimRobot(link::sim_robot(a)?),
            Command::Drive(a) => Args::Drive(link::drive(a)?),
            Command::Serve(a) => Args::Serve(serve::serve(a)?),
        })
    }

    /// Checks every file the command will write (and figure's directory)
    /// before any work, so an unwritable path fails at once.
    fn check_outputs(&self) -> Result<(), Failure> {
        let outputs = match self {
            Args::Chain(Chain { outputs, .. })
            | Args::Shape(Shape { outputs, .. })
            | Args::Shape3d(Shape3d { outputs, .. })
            | Args::Simulate(Simulate { outputs, .. })
            | Args::Climb(Climb { outputs, .. }) => Some(outputs),
            Args::Workspace(w) => {
                check_output(&w.csv, "--out", None)?;
                Some(&w.outputs)
            }
            Args::Calibrate(c) => {
                check_output(&c.out, "--out", None)?;
                Some(&c.outputs)
            }
            Args::Figure(f) => return Ok(files::check_output_dir(&f.dir, "--out")?),
            _ => None,
        };
        let Some(o) = outputs else { return Ok(()) };
        let files = [("--svg", &o.svg, None), ("--png", &o.png, Some("png")), ("--csv", &o.csv, None)];
        for (flag, path, extension) in files {
            if let Some(path) = path {
                check_output(path, flag, extension)?;
            }
        }
        Ok(())
    }

    /// Whether standard output is JSON (a failed solve then prints its status as JSON).
    pub fn json(&self) -> bool {
        match self {
            Args::Robot { json, .. }
            | Args::Reach(Reach { json, .. })
            | Args::Compare(Compare { json, .. })
            | Args::Scenes { json }
            | Args::SceneShow { json, .. }
            | Args::Scenarios { json }
            | Args::ScenarioShow { json, .. }
            | Args::ClimbSideways(ClimbSideways { json, .. }) => *json,
            Args::Climb(Climb { outputs, .. }) => outputs.json,
            Args::Chain(Chain { outputs, .. })
            | Args::Shape(Shape { outputs, .. })
            | Args::Shape3d(Shape3d { outputs, .. })
            | Args::Workspace(Workspace { outputs, .. })
            | Args::Calibrate(Calibrate { outputs, .. })
            | Args::Simulate(Simulate { outputs, .. }) => outputs.json,
            Args::Drive(Drive { json, .. }) => *json,
            Args::Figure(_) | Args::SimRobot(_) | Args::Serve(_) => false,
        }
    }
}

fn chain(a: flags::ChainArgs) -> Result<Chain, Failure> {
    let stiffness = match (a.stiffness, a.shape_parameter) {
        (Some(k), _) => k,
        (None, pi) => {
            let pi = positive("--shape-parameter", pi.unwrap_or(f64::NAN))?;
            positive("gravity_m_per_s2 (the shape parameter needs gravity)", a.gravity)?;
            pi * a.element_mass * a.gravity * a.element_length
        }
    };
    let spec = CantileverSpec {
        elements: a.elements,
        element_length_m: a.element_length,
        element_mass_kg: a.element_mass,
        joint_stiffness_nm_per_rad: stiffness,
        tip_mass_kg: a.tip_mass,
        base_angle_deg: a.base_angle,
        gravity_m_per_s2: a.gravity,
        discretization: a.discretization.into(),
    };
    let tube = spec.build()?;
    let solver = solver(a.max_iterations, a.time_limit)?;
    let scene = a.scene.as_deref().map(|path| tube_scene(path, a.outer_diameter, &tube)).transpose()?;
    Ok(Chain {
        tube,
        elements: spec.elements,
        shape_parameter: spec.shape_parameter(),
        spec,
        solver,
        scene,
        outputs: a.output.into(),
    })
}

/// The scene of `leech chain --scene` and the tube's radius (m): the
/// diameter above 0 and at most the tube's length, the clamp (the origin)
/// not inside a solid.
fn tube_scene(path: &Path, diameter: Option<f64>, tube: &Cantilever) -> Result<(Scene, f64), Failure> {
    let length = tube.chain().tube_length();
    let diameter = diameter.unwrap_or(Robot::builtin().tube.outer_diameter_m);
    if !(diameter.is_finite() && diameter > 0.0 && diameter <= length) {
        return Err(Failure::Input(format!(
            "--outer-diameter: got {}, expected a number of m above 0 and at most the tube's length ({} m)",
            Num(diameter),
            Num(length)
        )));
    }
    let (scene, _) = load_scene(path, "--scene")?;
    let on_surface = -leech::scene::ON_SURFACE_M;
    if !scene.is_free([0.0, 0.0], on_surface) {
        return Err(Failure::Input(
            "--scene: the clamp at the origin is inside a solid of the scene, expected free space or a surface".into(),
        ));
    }
    // A tube fed straight into a solid has nowhere to go: say so rather than fail to converge.
    let chain = tube.chain();
    let ahead =
        leech::geom::add_scaled(chain.clamp_point(), chain.lengths()[0], leech::geom::unit(chain.clamp_angle()));
    if !scene.is_free(ahead, on_surface) {
        let deg = chain.clamp_angle().to_degrees();
        return Err(Failure::Input(format!(
            "--base-angle: got {} deg, which points the tube into a solid of the scene; expected a direction into free space",
            Num(deg)
        )));
    }
    Ok((scene, 0.5 * diameter))
}

fn shape(a: flags::ShapeArgs) -> Result<Shape, Failure> {
    if a.free_cups.is_some() && a.scene.is_none() {
        return Err(Failure::Input(
            "--free-cups: --scene not provided, expected --scene <NAME|FILE> with it (the solids the cups rest on)"
                .into(),
        ));
    }
    // --rear's angle is the clamp direction: it sets the base angle.
    let rear = a.rear.map(|p| pose("--rear", p, 360.0)).transpose()?;
    let scene = a.scene.as_deref().map(|p| load_scene(p, "--scene")).transpose()?.map(|(scene, _)| scene);
    // Without --rear or --base-angle, a scene's [start] places the robot.
    let start = scene.as_ref().and_then(|s| s.start).filter(|_| a.rear.is_none() && a.base_angle.is_none());
    let base_angle = match (a.base_angle, &a.rear) {
        (Some(deg), Some(r)) if deg != r[2] => {
            let message = format!(
                "--rear: its angle {} deg differs from --base-angle {}; give one, or both alike",
                Num(r[2]),
                Num(deg)
            );
            return Err(Failure::Input(message));
        }
        (deg, r) => deg.or(r.map(|r| r[2])).or(start.map(|s| s.direction_rad.to_degrees())),
    };
    // Overrides first: the shape parameter sets the stiffness from gravity.
    let robot = tuned(&a.robot, |robot| {
        let mut robot = at_base_angle(robot, base_angle)?;
        if let Some(g) = a.gravity {
            robot = robot.with_gravity(g).flag("--gravity")?;
        }
        if let Some(d) = a.discretization {
            robot = robot.with_discretization(d.into());
        }
        Ok(robot)
    })?;
    let [la, lb] = tube_lengths(&robot, "--lengths", a.lengths, ["LA", "LB"])?;
    // The body checks the lengths for both models.
    let body = robot.body(la, lb)?;
    let models = models(a.model);
    let (solver, repeat) = match models.contains(&Model::TwoChain) {
        true => (Some(solver(a.max_iterations, a.time_limit)?), a.repeat.map(repeat).transpose()?),
        false => (None, None),
    };
    let rear = rear
        .or(start.map(|s| leech::stance::rear_pose_for_cup(&robot, s.rear_cup_m, s.direction_rad)))
        .unwrap_or_else(|| Pose::from_deg([0.0, 0.0], robot.world.base_angle_deg));
    let hold = situation(&a, &robot, rear, scene.as_ref())?;
    let free_cups = match a.free_cups {
        Some(FreeCupsArg::Rest) => FreeCups::Rest,
        Some(FreeCupsArg::PassThrough) | None => FreeCups::PassThrough,
    };
    let outputs = a.output.into();
    let shape = Shape { robot, lengths: a.lengths, body, models, solver, repeat, hold, scene, free_cups, outputs };
    if shape.repeat.is_some() && !shape.clamped() {
        return Err(Failure::Input(
            "--repeat: times the clamped body only (no --scene, rear hold at the origin)".into(),
        ));
    }
    Ok(shape)
}

fn shape3d(a: flags::Shape3dArgs) -> Result<Shape3d, Failure> {
    let scene = a.scene.as_deref().map(|p| load_scene3(p, "--scene")).transpose()?;
    // Without --base-angle, a scene's [start] places the robot.
    let start = scene.as_ref().and_then(|s| s.start).filter(|_| a.base_angle.is_none());
    let base_angle = a.base_angle.or(start.map(|s| s.direction_rad.to_degrees()));
    let robot = tuned(&a.robot, |robot| at_base_angle(robot, base_angle))?;
    let lengths = tube_lengths(&robot, "--lengths", a.lengths, ["L1", "L2", "L3"])?;
    // The body checks the robot for the 3D model (its discretization).
    let mut body = Body3::from_robot(&robot, lengths)?;
    if a.free_axial_rotation {
        body = body.with_free_axial_rotation();
    }
    if let Some(start) = start {
        body = body.with_rear_cup_at(&robot, start.rear_cup_m);
    }
    let hold = situation3(&a, &robot, &body, scene.as_ref(), start.is_some())?;
    let solver = solver(a.max_iterations, a.time_limit)?;
    let outputs = a.output.into();
    Ok(Shape3d { robot, lengths, body, free_axial_rotation: a.free_axial_rotation, solver, hold, scene, outputs })
}

fn repeat(n: usize) -> Result<NonZeroUsize, Failure> {
    NonZeroUsize::new(n)
        .filter(|n| n.get() <= 100_000)
        .ok_or_else(|| Failure::Input(format!("--repeat: got {n}, expected 1 to 100000")))
}

fn workspace(a: flags::WorkspaceArgs) -> Result<Workspace, Failure> {
    let robot = at_base_angle(load_robot_or_builtin(a.robot.as_deref())?, a.base_angle)?;
    let options = SweepOptions {
        grid: Grid::parse(&a.lengths_range).flag("--lengths-range")?,
        shape_parameters: a.shape_parameter,
        models: models(a.model),
        left_longer: a.left_longer,
        deadline: deadline(a.time_limit)?,
    };
    for pi in &options.shape_parameters {
        positive("--shape-parameter", *pi)?;
    }
    let outputs = Outputs { json: a.json, svg: a.svg, ..Outputs::default() };
    Ok(Workspace { robot, options, range: a.lengths_range, csv: a.out, outputs })
}

fn reach(a: flags::ReachArgs) -> Result<Reach, Failure> {
    let robot = at_base_angle(tuned(&a.robot, Ok)?, a.base_angle)?;
    let target = [check_target("--target x", a.target[0])?, check_target("--target y", a.target[1])?];
    let angle = a.angle.map(|deg| within("--angle (deg)", deg, -720.0, 720.0).map(f64::to_radians)).transpose()?;
    let grid = Grid::parse(&a.lengths_range).flag("--lengths-range")?;
    Ok(Reach { robot, target, angle, grid, json: a.json, deadline: deadline(a.time_limit)? })
}

fn simulate(a: flags::SimulateArgs) -> Result<Simulate, Failure> {
    if a.step && a.to.is_none() {
        return Err(Failure::Input(
            "--step: --to not provided, expected --to <LA2,LB2> with it (the lengths to step to)".into(),
        ));
    }
    let robot = at_base_angle(tuned(&a.robot, Ok)?, a.base_angle)?;
    // The library checks these again as it runs; here each is named by its flag.
    tube_lengths(&robot, "--lengths", a.lengths, ["LA", "LB"])?;
    a.to.map(|to| tube_lengths(&robot, "--to", to, ["LA", "LB"])).transpose()?;
    positive("--rest-rate (rad/s)", a.rest_rate)?;
    non_negative("--ramp (s)", a.ramp)?;
    let actuation = match (a.to, a.step) {
        (None, _) => Actuation::Hold,
        (Some(to), true) => Actuation::Step { to },
        (Some(to), false) => Actuation::Feed { to, speed: positive("--speed (mm/s)", a.speed)? / 1e3 },
    };
    // Without --to there is nothing to move to: the body settles from its unloaded shape.
    let start = match (a.start, a.to) {
        (Some(StartArg::Unloaded), _) | (None, None) => Start::Unloaded,
        _ => Start::Static,
    };
    let integrator = a.integrator.into();
    let duration = within("--duration (s)", a.duration, 1e-6, 3600.0)?;
    let dt = a.dt.map(|dt| within("--dt (s)", dt, 1e-9, duration)).transpose()?;
    let options = SimulationOptions {
        integrator,
        dt,
        duration,
        until_rest: a.until_rest,
        gravity_ramp: a.ramp,
        sample_interval: (duration / 500.0).max(1e-4),
        rest_rate: a.rest_rate,
        deadline: deadline(a.time_limit)?,
    };
    let outputs = Outputs { json: a.json, svg: a.svg, csv: a.csv, ..Outputs::default() };
    Ok(Simulate { robot, lengths: a.lengths, start, actuation, options, outputs })
}

/// The solver with the command line's bounds.
pub(crate) fn solver(max_iterations: usize, time_limit: f64) -> Result<Solver, Failure> {
    let deadline = deadline(time_limit)?;
    Ok(Solver::new(SolverOptions { max_iterations, deadline, ..SolverOptions::default() }))
}

/// The longest `--time-limit` (s): a day.
pub(crate) const MAX_TIME_LIMIT_S: f64 = 86_400.0;

/// The command's deadline, `seconds` from now (`--time-limit`).
pub(crate) fn deadline(seconds: f64) -> Result<Deadline, Failure> {
    if !(seconds > 0.0 && seconds <= MAX_TIME_LIMIT_S) {
        let allowed = format!("a number of seconds above 0 and at most {MAX_TIME_LIMIT_S} (a day)");
        return Err(InputError::invalid("--time-limit (s)", seconds, allowed).into());
    }
    Ok(Deadline::after(Duration::from_secs_f64(seconds)))
}

/// The chosen robot, edited by the command's overrides, then at the shape parameter asked for.
pub(crate) fn tuned(
    choice: &RobotChoice,
    edit: impl FnOnce(Robot) -> Result<Robot, InputError>,
) -> Result<Robot, Failure> {
    let robot = edit(load_robot_or_builtin(choice.file.as_deref())?)?;
    match choice.shape_parameter {
        Some(pi) => Ok(robot.with_shape_parameter(pi).flag("--shape-parameter")?),
        None => Ok(robot),
    }
}

/// A library result whose error names the flag that gave the value
/// ([`InputError::for_flag`]): every value the command line resolves
/// through the library goes through here.
pub(crate) trait Flagged<T> {
    fn flag(self, flag: &str) -> Result<T, InputError>;
}

impl<T> Flagged<T> for Result<T, InputError> {
    fn flag(self, flag: &str) -> Result<T, InputError> {
        self.map_err(|e| e.for_flag(flag))
    }
}

/// The tube lengths `flag` gives, checked against the robot; `names` are
/// the tubes' (`LA`, `LB`; `L1`, `L2`, `L3`).
fn tube_lengths<const N: usize>(
    robot: &Robot,
    flag: &str,
    mut lengths: [f64; N],
    names: [&str; N],
) -> Result<[f64; N], InputError> {
    for (i, (length, name)) in lengths.iter_mut().zip(names).enumerate() {
        *length = robot.check_tube_length(&format!("lengths[{i}] ({name})"), *length).flag(flag)?;
    }
    Ok(lengths)
}

/// The robot with the clamp angle the command line asks for, if it does.
fn at_base_angle(robot: Robot, angle: Option<f64>) -> Result<Robot, InputError> {
    match angle {
        Some(angle) => robot.with_base_angle(angle).flag("--base-angle"),
        None => Ok(robot),
    }
}

fn load_robot_or_builtin(path: Option<&Path>) -> Result<Robot, Failure> {
    path.map_or_else(|| Ok(Robot::builtin()), load_robot)
}

fn load_robot(path: &Path) -> Result<Robot, Failure> {
    let text = read_text(path, "--robot", files::ROBOT_FILE)?;
    Robot::from_toml_str(&text).map_err(|e| Failure::Input(format!("{}: {e}", path.display())))
}

/// A measurement file read by the library's reader, which names the file in its errors.
fn measured<T>(
    path: &Path,
    flag: &str,
    parse: impl FnOnce(&str, &str) -> Result<Vec<T>, InputError>,
) -> Result<Measured<T>, Failure> {
    let name = path.display().to_string();
    // The library names its errors by `source`: the flag typed, then the file.
    let source = format!("{flag} {}", files::shown(path));
    let rows = parse(&read_text(path, flag, files::MEASUREMENT_FILE)?, &source)?;
    Ok(Measured { name, rows })
}

/// The models a `--model` choice evaluates, the two-chain model first.
fn models(model: ModelArg) -> Vec<Model> {
    match model {
        ModelArg::TwoChain => vec![Model::TwoChain],
        ModelArg::ConstantCurvature => vec![Model::ConstantCurvature],
        ModelArg::Both => vec![Model::TwoChain, Model::ConstantCurvature],
    }
}

impl From<flags::Output> for Outputs {
    fn from(o: flags::Output) -> Outputs {
        Outputs { json: o.json, svg: o.svg, png: o.png, csv: None }
    }
}

impl From<DiscretizationArg> for Discretization {
    fn from(d: DiscretizationArg) -> Discretization {
        match d {
            DiscretizationArg::Paper => Discretization::Paper,
            DiscretizationArg::Midpoint => Discretization::Midpoint,
        }
    }
}

impl From<FitArg> for Fit {
    fn from(f: FitArg) -> Fit {
        match f {
            FitArg::Stiffness => Fit::Stiffness,
            FitArg::StiffnessMass => Fit::StiffnessAndMass,
        }
    }
}

impl From<IntegratorArg> for Integrator {
    fn from(i: IntegratorArg) -> Integrator {
        match i {
            IntegratorArg::Explicit => Integrator::Explicit,
            IntegratorArg::Implicit => Integrator::Implicit,
            IntegratorArg::Midpoint => Integrator::Midpoint,
        }
    }
}
