//! Command-line flags. Parsing only: values are checked by the library, which
//! names the offending field, or in [`crate::args`] for flags it never sees.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};
use leech::statics::SolverOptions;

/// Exact statics of LEeCH-type soft climbing robots.
#[derive(Debug, Parser)]
#[command(name = "leech", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Print a robot description (the built-in robot unless --robot is given).
    Robot {
        /// Robot file (TOML, at most 1 MiB).
        #[arg(long, value_name = "FILE")]
        robot: Option<PathBuf>,
        /// Print JSON instead of TOML.
        #[arg(long)]
        json: bool,
    },
    /// Shape of a single clamped tube under gravity.
    Chain(ChainArgs),
    /// Shape of the two-chain body for given tube lengths.
    Shape(ShapeArgs),
    /// Shape of the three-tube body in 3D (tubes 2 and 3 may differ: the body turns).
    Shape3d(Shape3dArgs),
    /// Regenerate one of the paper's figures (SVG and CSV) for a robot.
    Figure(FigureArgs),
    /// Sweep both tube lengths over a grid: endpoints, reach metrics (CSV, JSON, SVG).
    Workspace(WorkspaceArgs),
    /// Inverse statics: tube lengths that put the endpoint on a target.
    Reach(ReachArgs),
    /// Fit the tube's stiffness (and mass) to measured sag curves and body shapes.
    Calibrate(CalibrateArgs),
    /// Compare the two-chain and constant-curvature models with measured bodies.
    Compare(CompareArgs),
    /// Simulate the body's motion: settling, a step of lengths, or feeding at a speed.
    Simulate(SimulateArgs),
    /// The built-in scenes and scene files: floors, walls, steps.
    Scene(SceneArgs),
    /// Plan a climb: a scenario, or a scene with a start and a goal.
    Climb(ClimbArgs),
    /// The built-in climb scenarios and scenario files.
    Scenario(ScenarioArgs),
    /// Run the simulated robot behind a pseudo-terminal: prints the port's path, serves until stopped.
    SimRobot(SimRobotArgs),
    /// Drive the robot (or the simulated one) over its serial port.
    Drive(DriveArgs),
    /// The operator's web console: see, plan and drive the robot (simulated by default) from a browser.
    Serve(ServeArgs),
}

/// `leech serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// The robot (`[drive]` configures the controller's tubes, `[limits]` bounds every command).
    #[command(flatten)]
    pub robot: RobotChoice,
    /// The controller's serial port; without it, the built-in simulated robot.
    #[arg(long, value_name = "PATH", conflicts_with = "simulate")]
    pub port: Option<PathBuf>,
    /// Drive the built-in simulated robot (the default).
    #[arg(long)]
    pub simulate: bool,
    /// The climb scenario whose scene, start and goal the console shows (`leech scenario list`);
    /// crawl-floor by default.
    #[arg(long, value_name = "NAME|FILE", conflicts_with = "scene")]
    pub scenario: Option<PathBuf>,
    /// Instead: a scene with a `[start]` (`leech scene list`).
    #[arg(long, value_name = "NAME|FILE")]
    pub scene: Option<PathBuf>,
    /// Where to listen (default 127.0.0.1:8080, or a free port if that one is taken). Any
    /// address but a loopback one needs --token.
    #[arg(long, value_name = "ADDR:PORT")]
    pub listen: Option<std::net::SocketAddr>,
    /// A token the page and its websocket must carry (`?token=T`): 8 or more letters, digits, '-', '_', '.'.
    #[arg(long, value_name = "T")]
    pub token: Option<String>,
}

/// `leech sim-robot`.
#[derive(Debug, Args)]
pub struct SimRobotArgs {
    /// The robot whose drive (`[drive]`: encoder calibration, lengths at power-up) the simulation has.
    #[command(flatten)]
    pub robot: RobotChoice,
    /// Simulate the body in a climb scenario's scene from its start (`leech scenario list`): a cup
    /// seals only where leech's statics put its face flush on a surface. Without it every cup seals.
    #[arg(long, value_name = "NAME|FILE", conflicts_with = "scene")]
    pub scenario: Option<PathBuf>,
    /// Instead: the body in a scene (`leech scene list`) from the scene's `[start]`.
    #[arg(long, value_name = "NAME|FILE")]
    pub scene: Option<PathBuf>,
    /// Faults to inject, comma-separated: drop=P, corrupt=P (per byte, each way), delay=S, cut,
    /// vacuum-loss=rear|front, stall=1|2|3, lose-fault-reports (Fault reports lost, the faults
    /// still latched), seed=N.
    #[arg(long, value_name = "SPEC")]
    pub faults: Option<String>,
    /// Print the simulated robot's state as one JSON line every S seconds (0: never).
    #[arg(long, value_name = "S", default_value_t = 0.0, allow_hyphen_values = true)]
    pub status_every: f64,
    /// Stop after S seconds (default: until interrupted).
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub duration: Option<f64>,
}

/// `leech drive`.
#[derive(Debug, Args)]
pub struct DriveArgs {
    /// The controller's serial port (a real Arduino Mega's, or the path `leech sim-robot` prints).
    #[arg(long, value_name = "PATH")]
    pub port: PathBuf,
    /// The robot whose `[drive]` section configures the controller's tubes.
    #[command(flatten)]
    pub robot: RobotChoice,
    /// Print JSON (units in the keys) instead of text.
    #[arg(long, global = true)]
    pub json: bool,
    /// What to do.
    #[command(subcommand)]
    pub action: DriveAction,
}

/// The `leech drive` actions.
#[derive(Debug, Subcommand)]
pub enum DriveAction {
    /// The controller's state: lengths, duties, pumps, cups, faults (and with --json the link's health).
    Status,
    /// Move the tubes to L1,L2,L3 (m; planar use sets L2 = L3) and wait until they are there.
    Lengths {
        /// Target lengths L1,L2,L3 in m.
        #[arg(value_name = "L1,L2,L3", value_parser = parse_triple)]
        lengths: [f64; 3],
    },
    /// Move one tube (1, 2 or 3) by MM millimetres (negative draws it in).
    #[command(allow_negative_numbers = true)]
    Jog {
        /// The tube: 1 (centre), 2 or 3.
        tube: u8,
        /// How far, mm.
        mm: f64,
    },
    /// Switch a cup's pump on or off (the controller refuses to let go of the last holding cup).
    Pump {
        /// Which cup.
        cup: CupArg,
        /// On or off.
        state: OnOff,
    },
    /// Stop the motors (the pumps stay as they are).
    Stop,
    /// Clear latched faults (a motor stall blocks motion until cleared); a fault whose cause
    /// persists latches again.
    ClearFaults {
        /// The faults, comma-separated: link-lost, motor-stall, vacuum-lost, limit-hit,
        /// watchdog-reset, brownout-reset; or all.
        #[arg(value_name = "NAMES|all", default_value = "all")]
        faults: String,
    },
    /// One stride phase by hand, behind the stride interlock, confirmed by telemetry: push or pull
    /// to --lengths, attach_front or attach_rear, release_rear or release_front (with the holding
    /// cup's safety factor after the release, e.g. from `leech shape --hold`).
    Stride {
        /// The phase: push, attach_front, release_rear, pull, attach_rear or release_front.
        phase: String,
        /// For push and pull: the tube lengths LA,LB in m (L1 = LA, L2 = L3 = LB).
        #[arg(long, value_name = "LA,LB", value_parser = parse_pair, allow_hyphen_values = true)]
        lengths: Option<[f64; 2]>,
        /// For a release: the safety factor of the cup that will hold alone after it.
        #[arg(long, value_name = "SF", allow_hyphen_values = true)]
        safety_factor: Option<f64>,
    },
    /// Carry out a climb step by step, each confirmed by telemetry, behind the stride interlock: a
    /// plan from `leech climb --json`, or a scenario planned first; a cup must hold to begin.
    Run {
        /// A plan as `leech climb --json` writes it (status "reached"; at most 16 MiB, 10000 steps).
        #[arg(value_name = "PLAN.json", required_unless_present = "scenario", conflicts_with = "scenario")]
        plan: Option<PathBuf>,
        /// Instead: a built-in scenario's name or a scenario file, planned as `leech climb` does.
        #[arg(long, value_name = "NAME|FILE")]
        scenario: Option<PathBuf>,
    },
}

/// A cup on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CupArg {
    /// The rear cup, on the driving unit.
    Rear,
    /// The front cup, on the endpoint.
    Front,
}

/// A pump's state on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    /// Pump on.
    On,
    /// Pump off.
    Off,
}

/// `leech climb`.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct ClimbArgs {
    /// A built-in scenario's name (`leech scenario list`) or a scenario file (TOML, at most 1 MiB).
    #[arg(long, value_name = "NAME|FILE", required_unless_present = "scene", conflicts_with = "scene")]
    pub scenario: Option<PathBuf>,
    /// Instead of a scenario: a built-in scene's name (`leech scene list`) or a scene file (TOML, at
    /// most 1 MiB).
    #[arg(long, value_name = "NAME|FILE", requires_all = ["start", "goal"])]
    pub scene: Option<PathBuf>,
    /// With --scene: the rear cup's face centre X,Y (m) on a surface and the body's heading DEG.
    #[arg(long, value_name = "X,Y,DEG", value_parser = parse_pose, allow_hyphen_values = true, requires = "scene")]
    pub start: Option<[f64; 3]>,
    /// With --scene: where the rear cup's face centre should land, X,Y (m).
    #[arg(long, value_name = "X,Y", value_parser = parse_pair, allow_hyphen_values = true, requires = "scene")]
    pub goal: Option<[f64; 2]>,
    /// With --scene: how close to the goal the rear cup must land (m).
    #[arg(long, value_name = "M", requires = "scene", allow_hyphen_values = true)]
    pub tolerance: Option<f64>,
    #[command(flatten)]
    pub robot: RobotChoice,
    /// Wall-clock limit of the whole search (s, at most a day); the built-in scenarios plan in seconds.
    #[arg(long, value_name = "S", default_value_t = 60.0, allow_hyphen_values = true)]
    pub time_limit: f64,
    /// Print the plan as JSON (units in the keys) instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write one CSV row per step (units in the headers).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Write an animated SVG (SMIL) of the climb: one frame per step, the scene and the goal.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
}

/// `leech scenario`.
#[derive(Debug, Args)]
pub struct ScenarioArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: ScenarioCommand,
}

/// The `leech scenario` subcommands.
#[derive(Debug, Subcommand)]
pub enum ScenarioCommand {
    /// List the built-in scenarios with one line each.
    List {
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Print a scenario file: a built-in one with its comments, a file as given once checked.
    Show {
        /// A built-in scenario's name, or a scenario file (TOML).
        #[arg(value_name = "NAME|FILE")]
        scenario: PathBuf,
        /// Print JSON (units in the keys) instead of TOML.
        #[arg(long)]
        json: bool,
    },
}

/// What besides the tubes rests on a scene's solids in `leech shape`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FreeCupsArg {
    /// Only the tubes touch the solids; the free cups pass through them.
    PassThrough,
    /// The faces of the cups that do not hold rest on the solids too (as the climb planner solves).
    Rest,
}

/// `leech scene`.
#[derive(Debug, Args)]
pub struct SceneArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: SceneCommand,
}

/// The `leech scene` subcommands.
#[derive(Debug, Subcommand)]
pub enum SceneCommand {
    /// List the built-in scenes with one line each.
    List {
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Print a scene file: a built-in one with its comments, a file checked and rewritten.
    Show {
        /// A built-in scene's name, or a scene file (TOML).
        #[arg(value_name = "NAME|FILE")]
        scene: PathBuf,
        /// Print JSON (units in the keys) instead of TOML.
        #[arg(long)]
        json: bool,
    },
}

/// Which cups hold the body in `leech shape`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum HoldArg {
    /// The rear cup (on the driving unit): today's clamped body.
    Rear,
    /// The front cup (on the endpoint plate); needs --front.
    Front,
    /// Both cups: a closed loop; needs --front.
    Both,
}

/// Integrators for `leech simulate`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IntegratorArg {
    /// RK4 at its stability limit (tiny steps with the stiff dampers).
    Explicit,
    /// Backward Euler with Newton iterations: large steps, damps fast modes.
    Implicit,
    /// Implicit midpoint: energy-conserving, needs small steps.
    Midpoint,
}

/// Where `leech simulate` starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum StartArg {
    /// The unloaded (g = 0) shape at rest, gravity then on (the paper's method).
    Unloaded,
    /// The static equilibrium.
    Static,
}

/// `leech simulate`.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub robot: RobotChoice,
    /// Starting tube lengths LA,LB in m.
    #[arg(long, value_name = "LA,LB", value_parser = parse_pair, allow_hyphen_values = true)]
    pub lengths: [f64; 2],
    /// Clamp direction (deg), overriding the robot file.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub base_angle: Option<f64>,
    /// Move the tubes to these lengths (m).
    #[arg(long, value_name = "LA2,LB2", value_parser = parse_pair, allow_hyphen_values = true)]
    pub to: Option<[f64; 2]>,
    /// Feeding speed of each motor (mm/s), as the paper's robot.
    #[arg(long, value_name = "MM_PER_S", default_value_t = 20.0, allow_hyphen_values = true)]
    pub speed: f64,
    /// Change the lengths at once instead of feeding them.
    #[arg(long)]
    pub step: bool,
    /// Start shape (default: unloaded without --to, static with it).
    #[arg(long, value_enum)]
    pub start: Option<StartArg>,
    /// Simulated time (s); the longest run with --until-rest.
    #[arg(long, value_name = "S", default_value_t = 5.0, allow_hyphen_values = true)]
    pub duration: f64,
    /// Time step (s); default 5 ms implicit, the stability limit otherwise.
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub dt: Option<f64>,
    /// Time-stepping scheme.
    #[arg(long, value_enum, default_value_t = IntegratorArg::Implicit)]
    pub integrator: IntegratorArg,
    /// Stop when the body is at rest (every rate below --rest-rate).
    #[arg(long)]
    pub until_rest: bool,
    /// Rates counting as rest (rad/s).
    #[arg(long, value_name = "RAD_PER_S", default_value_t = 1e-6, allow_hyphen_values = true)]
    pub rest_rate: f64,
    /// Raise gravity over this time (s) instead of at once.
    #[arg(long, value_name = "S", default_value_t = 0.0, allow_hyphen_values = true)]
    pub ramp: f64,
    /// CSV time series (time, lengths, endpoint, energies, violation, angles).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Animated SVG (SMIL) of the body with a time stamp.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// Print a summary as JSON.
    #[arg(long)]
    pub json: bool,
    /// Wall-clock limit of the run (s, at most a day): a second simulated takes seconds at the
    /// most; 10 minutes stops a step far too small, and nothing is written.
    #[arg(long, value_name = "S", default_value_t = 600.0, allow_hyphen_values = true)]
    pub time_limit: f64,
}

/// What `leech calibrate` fits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FitArg {
    /// The joint stiffness k.
    Stiffness,
    /// k and the element mass m (needs a known mass in the data).
    #[value(name = "stiffness,mass")]
    StiffnessMass,
}

/// `leech calibrate`.
#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// Tube-sag measurements (CSV: `tube_length_m,base_angle_deg,x_m,y_m[,tip_mass_kg]`; at most
    /// 16 MiB, 100000 rows, 1000 tubes).
    #[arg(long, value_name = "FILE")]
    pub sag: PathBuf,
    /// Body-shape measurements (CSV: shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m; at most 16 MiB,
    /// 100000 rows, 1000 shapes).
    #[arg(long, value_name = "FILE")]
    pub shapes: Option<PathBuf>,
    /// What to fit.
    #[arg(long, value_enum, default_value_t = FitArg::Stiffness)]
    pub fit: FitArg,
    #[command(flatten)]
    pub robot: RobotChoice,
    /// Robot file to write with the fitted values.
    #[arg(long, value_name = "ROBOT.toml")]
    pub out: PathBuf,
    /// Picture of the measurements over the fitted shapes.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// Print the result as JSON.
    #[arg(long)]
    pub json: bool,
    /// Wall-clock limit of the fit (s, at most a day): fits take seconds; 5 minutes stops a
    /// runaway, and no robot file is written.
    #[arg(long, value_name = "S", default_value_t = 300.0, allow_hyphen_values = true)]
    pub time_limit: f64,
}

/// `leech compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// Body-shape measurements (CSV: shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m; at most 16 MiB,
    /// 100000 rows, 1000 shapes).
    #[arg(long, value_name = "FILE")]
    pub shapes: PathBuf,
    #[command(flatten)]
    pub robot: RobotChoice,
    /// Print the result as JSON.
    #[arg(long)]
    pub json: bool,
    /// Wall-clock limit of all the shapes' solves (s, at most a day): each takes milliseconds.
    #[arg(long, value_name = "S", default_value_t = 60.0, allow_hyphen_values = true)]
    pub time_limit: f64,
}

/// `leech workspace`.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct WorkspaceArgs {
    /// Robot file (TOML, at most 1 MiB); the built-in LEeCH robot if absent.
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Tube lengths for both tubes, MIN:MAX:STEP in m.
    #[arg(long, value_name = "MIN:MAX:STEP", default_value = "0.05:0.3:0.005")]
    pub lengths_range: String,
    /// Shape parameters to sweep, comma-separated (the robot's own if absent).
    #[arg(long, value_name = "P1,P2,...", value_delimiter = ',')]
    pub shape_parameter: Vec<f64>,
    /// Which models to sweep.
    #[arg(long, value_enum, default_value_t = ModelArg::Both)]
    pub model: ModelArg,
    /// Only LA >= LB (the left tube, chain A, longer; the paper's Fig. 12).
    #[arg(long)]
    pub left_longer: bool,
    /// Clamp direction (deg), overriding the robot file.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub base_angle: Option<f64>,
    /// CSV file for every grid point.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
    /// Write a picture of the endpoints as SVG.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    /// Wall-clock limit of the whole sweep (s, at most a day): the paper's 1 mm sweep takes
    /// seconds; 10 minutes stops a grid far too fine or a body far too soft, and no CSV is written.
    #[arg(long, value_name = "S", default_value_t = 600.0, allow_hyphen_values = true)]
    pub time_limit: f64,
}

/// `leech reach`.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct ReachArgs {
    #[command(flatten)]
    pub robot: RobotChoice,
    /// Target for the endpoint, X,Y in m (driving unit at the origin).
    #[arg(long, value_name = "X,Y", value_parser = parse_pair, allow_hyphen_values = true)]
    pub target: [f64; 2],
    /// Target plate angle (deg from +x), for the front cup to land flat.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub angle: Option<f64>,
    /// Allowed tube lengths and the grid of the starting map, MIN:MAX:STEP in m.
    #[arg(long, value_name = "MIN:MAX:STEP", default_value = "0.05:0.3:0.01")]
    pub lengths_range: String,
    /// Clamp direction (deg), overriding the robot file.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub base_angle: Option<f64>,
    /// Print the answer as JSON.
    #[arg(long)]
    pub json: bool,
    /// Wall-clock limit of the map and the search together (s, at most a day): the default map
    /// and a target take about a second; 2 minutes stops a range far too fine.
    #[arg(long, value_name = "S", default_value_t = 120.0, allow_hyphen_values = true)]
    pub time_limit: f64,
}

/// Which model `leech shape` evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ModelArg {
    /// The two-chain multibody model with gravity (exact statics).
    TwoChain,
    /// The kinematic constant-curvature model.
    ConstantCurvature,
    /// Both, one JSON object per model in a `models` list.
    Both,
}

/// `leech figure`.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct FigureArgs {
    /// tube-sag, model-comparison, scaling, pi-sweep, workspace, or all.
    #[arg(value_name = "NAME")]
    pub name: String,
    #[command(flatten)]
    pub robot: RobotChoice,
    /// Directory for NAME.svg and NAME.csv (created if missing).
    #[arg(long, value_name = "DIR", default_value = "figures")]
    pub out: PathBuf,
}

/// Which robot: a file or the built-in one, optionally at another shape parameter.
#[derive(Debug, Args)]
pub struct RobotChoice {
    /// Robot file (TOML, at most 1 MiB); the built-in LEeCH robot if absent.
    #[arg(long = "robot", value_name = "FILE")]
    pub file: Option<PathBuf>,
    /// Shape parameter Pi = k/(m g l), set by scaling the joint stiffness.
    #[arg(long, value_name = "P")]
    pub shape_parameter: Option<f64>,
}

/// Where results go.
#[derive(Debug, Args)]
pub struct Output {
    /// Print the result as JSON on standard output.
    #[arg(long)]
    pub json: bool,
    /// Write a picture as SVG.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// Write a picture as PNG (a name ending in .png).
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
}

/// Discretization choices.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum DiscretizationArg {
    /// Springs at element starts, masses at element tips (the paper's).
    Paper,
    /// Joints at element midpoints (second order in the element length).
    Midpoint,
}

/// `leech chain`.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct ChainArgs {
    /// Number of elements.
    #[arg(long, value_name = "N")]
    pub elements: usize,
    /// Element length (m).
    #[arg(long, value_name = "M")]
    pub element_length: f64,
    /// Element mass (kg).
    #[arg(long, value_name = "KG")]
    pub element_mass: f64,
    /// Joint stiffness (N m/rad); or give --shape-parameter.
    #[arg(long, value_name = "NM_PER_RAD", required_unless_present = "shape_parameter")]
    pub stiffness: Option<f64>,
    /// Shape parameter Pi = k/(m g l): sets the stiffness to Pi m g l.
    #[arg(long, value_name = "P", conflicts_with = "stiffness")]
    pub shape_parameter: Option<f64>,
    /// Point mass at the tip (kg).
    #[arg(long, value_name = "KG", default_value_t = 0.0, allow_hyphen_values = true)]
    pub tip_mass: f64,
    /// Clamp direction (deg from +x; 90 points up).
    #[arg(long, value_name = "DEG", default_value_t = 0.0, allow_hyphen_values = true)]
    pub base_angle: f64,
    /// Gravity (m/s^2).
    #[arg(long, value_name = "M_PER_S2", default_value_t = 9.81, allow_hyphen_values = true)]
    pub gravity: f64,
    /// How the tube is cut into links.
    #[arg(long, value_enum, default_value_t = DiscretizationArg::Paper)]
    pub discretization: DiscretizationArg,
    /// Newton iterations allowed for the whole solve.
    #[arg(long, value_name = "N", default_value_t = SolverOptions::default().max_iterations)]
    pub max_iterations: usize,
    /// Wall-clock limit of the command (s, at most a day; with --repeat all the solves together):
    /// a solve takes milliseconds, 60 s only stops a runaway.
    #[arg(long, value_name = "S", default_value_t = 60.0, allow_hyphen_values = true)]
    pub time_limit: f64,
    /// Surroundings the tube rests on (its clamp stays at the origin): a built-in scene's name
    /// (`leech scene list`) or a scene file.
    #[arg(long, value_name = "NAME|FILE")]
    pub scene: Option<PathBuf>,
    /// The tube's outer diameter (m), its clearance from the scene (default: the built-in robot's
    /// `[tube] outer_diameter_m`).
    #[arg(long, value_name = "M", requires = "scene", allow_hyphen_values = true)]
    pub outer_diameter: Option<f64>,
    #[command(flatten)]
    pub output: Output,
}

/// `leech shape`.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct ShapeArgs {
    #[command(flatten)]
    pub robot: RobotChoice,
    /// Tube lengths LA (centre tube) and LB (side pair), in m.
    #[arg(long, value_name = "LA,LB", value_parser = parse_pair, allow_hyphen_values = true)]
    pub lengths: [f64; 2],
    /// Clamp direction (deg), overriding the robot file.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub base_angle: Option<f64>,
    /// Gravity (m/s^2), overriding the robot file.
    #[arg(long, value_name = "M_PER_S2", allow_hyphen_values = true)]
    pub gravity: Option<f64>,
    /// Discretization, overriding the robot file.
    #[arg(long, value_enum)]
    pub discretization: Option<DiscretizationArg>,
    /// Which model to evaluate.
    #[arg(long, value_enum, default_value_t = ModelArg::TwoChain)]
    pub model: ModelArg,
    /// Newton iterations allowed for the whole solve.
    #[arg(long, value_name = "N", default_value_t = SolverOptions::default().max_iterations)]
    pub max_iterations: usize,
    /// Wall-clock limit of the command (s, at most a day; with --repeat all the solves together):
    /// a solve takes milliseconds, 60 s only stops a runaway.
    #[arg(long, value_name = "S", default_value_t = 60.0, allow_hyphen_values = true)]
    pub time_limit: f64,
    /// Solve N times (cold each time, N <= 100000) and report the solve time (`solve_time_s` in JSON).
    #[arg(long, value_name = "N")]
    pub repeat: Option<usize>,
    /// Surroundings the tubes rest on: a built-in scene's name (`leech scene list`) or a scene file.
    #[arg(long, value_name = "NAME|FILE")]
    pub scene: Option<PathBuf>,
    /// Which cups hold (default: rear).
    #[arg(long, value_enum)]
    pub hold: Option<HoldArg>,
    /// The rear hold: the driving unit's point X,Y (m) and clamp direction DEG; it sets the base angle
    /// (default: the scene's start, its rear cup on a surface; else the origin at the robot's base angle).
    #[arg(long, value_name = "X,Y,DEG", value_parser = parse_pose, allow_hyphen_values = true)]
    pub rear: Option<[f64; 3]>,
    /// The front hold: the endpoint X,Y (m) and the plate's angle DEG.
    #[arg(long, value_name = "X,Y,DEG", value_parser = parse_pose, allow_hyphen_values = true)]
    pub front: Option<[f64; 3]>,
    /// With --scene: whether the free cups' faces rest on the solids (default pass-through).
    #[arg(long, value_enum, value_name = "MODE")]
    pub free_cups: Option<FreeCupsArg>,
    #[command(flatten)]
    pub output: Output,
}

/// `leech shape3d`: the three-tube body held by a cup, among a scene's
/// solids if given, or the constant-curvature model.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct Shape3dArgs {
    #[command(flatten)]
    pub robot: RobotChoice,
    /// Tube lengths L1 (centre tube), L2 and L3 (side tubes, tube 2 towards +z), in m.
    #[arg(long, value_name = "L1,L2,L3", value_parser = parse_triple, allow_hyphen_values = true)]
    pub lengths: [f64; 3],
    /// Clamp direction (deg), overriding the robot file.
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub base_angle: Option<f64>,
    /// Leave each tube's axial rotation at the driving unit free (no torsional spring there).
    #[arg(long)]
    pub free_axial_rotation: bool,
    /// Newton iterations allowed for the whole solve.
    #[arg(long, value_name = "N", default_value_t = SolverOptions::default().max_iterations)]
    pub max_iterations: usize,
    /// Wall-clock limit of the command (s, at most a day): the 3D solve and, with L2 = L3, the
    /// planar one beside it take milliseconds; 60 s only stops a runaway.
    #[arg(long, value_name = "S", default_value_t = 60.0, allow_hyphen_values = true)]
    pub time_limit: f64,
    /// Which model: the three-tube chain body (statics) or the constant-curvature arcs.
    #[arg(long, value_enum, default_value_t = Model3Arg::Chain)]
    pub model: Model3Arg,
    /// Surroundings: a built-in scene's name or a planar scene file (prisms along z), or a 3D
    /// scene file (half-spaces and boxes); a scene's [start] places the rear cup.
    #[arg(long, value_name = "NAME|FILE")]
    pub scene: Option<PathBuf>,
    /// Which cup holds (default: rear).
    #[arg(long, value_enum)]
    pub hold: Option<Hold3Arg>,
    /// The front hold: tube 1's tip X,Y,Z (m), the plate's tangent angle DEG in the x-y plane (as
    /// `shape --front`), then turns about the cup's face normal YAW_DEG and about the tangent
    /// ROLL_DEG (default 0).
    #[arg(long, value_name = "X,Y,Z,DEG[,YAW_DEG[,ROLL_DEG]]", value_parser = parse_front3, allow_hyphen_values = true)]
    pub front: Option<[f64; 6]>,
    #[command(flatten)]
    pub output: Output,
}

/// Which model `leech shape3d` evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Model3Arg {
    /// The three tubes as chains of rigid links under gravity (exact statics).
    Chain,
    /// The tri-tube constant-curvature arcs (kinematic).
    ConstantCurvature,
}

/// Which cups hold the body in `leech shape3d`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Hold3Arg {
    /// The rear cup (on the driving unit).
    Rear,
    /// The front cup (on the endpoint plate); needs --front.
    Front,
    /// The front cup on a free joint about its face's normal (the body swings until gravity's
    /// moment about it vanishes); needs --front.
    FrontPivot,
    /// Both cups: a closed loop; needs --front.
    Both,
}

/// Parses `LA,LB` into two numbers.
fn parse_pair(text: &str) -> Result<[f64; 2], String> {
    numbers(text, "two numbers in m separated by a comma", "a number in m")
}

/// Parses `X,Y,DEG` into three numbers.
fn parse_triple(text: &str) -> Result<[f64; 3], String> {
    numbers(text, "three numbers in m separated by commas", "a number in m")
}

/// Parses `X,Y,Z,DEG[,YAW_DEG[,ROLL_DEG]]` into six numbers, the turns 0 when left out.
fn parse_front3(text: &str) -> Result<[f64; 6], String> {
    let all = "X,Y,Z in m, DEG, then optionally YAW_DEG and ROLL_DEG, separated by commas";
    let mut out = [0.0; 6];
    out[..].iter_mut().zip(list(text, 4..=6, all, "a number")?).for_each(|(o, x)| *o = x);
    Ok(out)
}

fn parse_pose(text: &str) -> Result<[f64; 3], String> {
    numbers(text, "X,Y in m and DEG separated by commas", "a number")
}

/// `N` numbers separated by commas; `all` and `one` say what was expected.
fn numbers<const N: usize>(text: &str, all: &str, one: &str) -> Result<[f64; N], String> {
    let mut out = [0.0; N];
    out.iter_mut().zip(list(text, N..=N, all, one)?).for_each(|(o, x)| *o = x);
    Ok(out)
}

/// Numbers separated by commas, as many as `count` allows; `all` and `one`
/// say what was expected.
fn list(text: &str, count: std::ops::RangeInclusive<usize>, all: &str, one: &str) -> Result<Vec<f64>, String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if !count.contains(&parts.len()) {
        return Err(format!("got {}, expected {all}", leech::error::quoted(text)));
    }
    parts
        .iter()
        .map(|s| {
            s.parse::<f64>().map_err(|_| {
                format!("got {} in {}, expected {one}", leech::error::quoted(s), leech::error::quoted(text))
            })
        })
        .collect()
}
