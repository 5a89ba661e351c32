//! The `leech` command: parse the flags, resolve them ([`args`]), run the
//! library, print ([`render`]). Exit codes: 0 done, 1 an unexpected failure
//! (for example an unwritable picture), 2 bad input, 3 a solve that did not
//! converge (or a climb that cannot be planned).

mod args;
mod failure;
mod flags;
mod link;
mod render;
mod serve;

use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use leech::calibration::Calibration;
use leech::inverse_statics::Reacher;
use leech::prelude::*;
use leech::report::{PlanarCounterpart, SolveTiming};
use leech::stance;
use leech::stance3;

use args::{Args, Shape};
use failure::Failure;
use flags::Cli;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return clap_failure(&e),
    };
    let args = match Args::resolve(cli.command) {
        Ok(args) => args,
        Err(failure) => return exit_code(failure, false),
    };
    let json = args.json();
    let mut out = String::new();
    let result = run(args, &mut out);
    if let Err(e) = render::emit(&out) {
        eprintln!("leech: writing the output: {e}");
        return ExitCode::from(1);
    }
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => exit_code(failure, json),
    }
}

/// Says why on standard error (and a failed solve's status as JSON on
/// standard output with --json); the exit code says what kind of failure.
fn exit_code(failure: Failure, json: bool) -> ExitCode {
    match failure {
        Failure::Input(message) => {
            eprintln!("leech: {message}");
            ExitCode::from(2)
        }
        Failure::Solve(e, message) => {
            if json {
                if let Err(e) = render::emit(&render::solve_failure(&e)) {
                    eprintln!("leech: writing the output: {e}");
                }
            }
            eprintln!("leech: {message}");
            ExitCode::from(3)
        }
        Failure::Unsolved(message) => {
            eprintln!("leech: {message}");
            ExitCode::from(3)
        }
        Failure::Other(e) => {
            eprintln!("leech: {e:#}");
            ExitCode::from(1)
        }
    }
}

/// Help and version on standard output; a parse error as one line, exit 2,
/// naming what was wrong and what is allowed (clap's own text says the
/// first but often not the second, and runs over several lines).
fn clap_failure(e: &clap::Error) -> ExitCode {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
        // `leech --help | head` closes the pipe early: not an error.
        return match render::emit(&e.to_string()) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("leech: writing the output: {e}");
                ExitCode::from(1)
            }
        };
    }
    let rendered = e.to_string();
    // `leech shape` of `Usage: leech shape [OPTIONS] --lengths <LA,LB>`: the command that failed.
    let usage = rendered.lines().find_map(|l| l.trim().strip_prefix("Usage: ")).unwrap_or("leech <COMMAND>");
    let command: Vec<&str> = usage.split(' ').take_while(|w| !w.starts_with(['[', '-', '<'])).collect();
    let command = command.join(" ");
    let context = |kind| match e.get(kind) {
        Some(ContextValue::String(s)) => Some(s.clone()),
        Some(ContextValue::Strings(s)) => s.first().cloned(),
        Some(ContextValue::StyledStr(s)) => Some(s.to_string()),
        _ => None,
    };
    let suggested = |kind| context(kind).map(|s| format!("; did you mean '{s}'?")).unwrap_or_default();
    let message = match e.kind() {
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand | ErrorKind::MissingSubcommand => {
            // `leech` or `leech drive` alone.
            format!("a subcommand is needed ({usage}), one of {}; see {command} --help", subcommands(&command))
        }
        ErrorKind::InvalidSubcommand => format!(
            "{command} <COMMAND>: got {}, expected one of {}{}",
            leech::error::quoted(&context(ContextKind::InvalidSubcommand).unwrap_or_default()),
            subcommands(&command),
            suggested(ContextKind::SuggestedSubcommand)
        ),
        ErrorKind::UnknownArgument => format!(
            "unexpected argument {}, expected one of the flags of '{command}' (see {command} --help){}",
            leech::error::quoted(&context(ContextKind::InvalidArg).unwrap_or_default()),
            suggested(ContextKind::SuggestedArg)
        ),
        ErrorKind::InvalidUtf8 => not_utf8(),
        _ => {
            // One line: clap's message without its usage and help hints.
            let lines: Vec<&str> = rendered
                .lines()
                .map(str::trim)
                .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
                .filter(|l| !l.is_empty())
                .collect();
            lines.join(" ").trim_start_matches("error: ").to_string()
        }
    };
    eprintln!("leech: {message}");
    ExitCode::from(2)
}

/// The subcommands of `command` (`leech drive`), comma-separated, `help` left out.
fn subcommands(command: &str) -> String {
    use clap::CommandFactory;
    let mut at = flags::Cli::command();
    for name in command.split(' ').skip(1) {
        match at.find_subcommand(name) {
            Some(sub) => at = sub.clone(),
            None => break,
        }
    }
    let names: Vec<&str> = at.get_subcommands().map(|c| c.get_name()).filter(|n| *n != "help").collect();
    names.join(", ")
}

/// The first argument that is not UTF-8, named by its flag (`--lengths`,
/// `--lengths=...`) or its place, in the house format.
fn not_utf8() -> String {
    let args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let Some(at) = args.iter().skip(1).position(|a| a.to_str().is_none()).map(|i| i + 1) else {
        return "an argument: got text that is not UTF-8, expected UTF-8 text".into();
    };
    let lossy = args[at].to_string_lossy();
    let field = match lossy.split_once('=') {
        Some((flag, _)) if flag.starts_with("--") => flag.to_string(),
        _ => match args[at - 1].to_str() {
            Some(flag) if flag.starts_with("--") => flag.to_string(),
            _ => format!("argument {at}"),
        },
    };
    format!("{field}: got {}, which is not UTF-8; expected UTF-8 text", leech::error::quoted(&lossy))
}

/// Runs a command, appending what it prints to `out`.
fn run(args: Args, out: &mut String) -> Result<(), Failure> {
    match args {
        Args::Robot { robot, json } => render::robot(out, robot.as_ref(), json),
        Args::Chain(a) => match &a.scene {
            None => {
                let eq = a.tube.solve(&a.solver)?;
                render::chain(out, &a, &eq)
            }
            Some((scene, radius)) => {
                let held = stance::tube_in(&a.spec, scene, *radius, &a.solver)?;
                render::chain_in_scene(out, &a, scene, &held)
            }
        },
        Args::Shape(a) => {
            let solved = a.solver.as_ref().map(|solver| solve_shape(&a, solver)).transpose()?;
            render::shape(out, &a, solved.as_ref())
        }
        Args::Shape3d(a) => {
            let Some(hold) = a.hold else {
                let cc = leech::body3::ConstantCurvature3::new(&a.robot, a.lengths)?;
                return render::constant_curvature3(out, &a, &cc);
            };
            let held = match &a.scene {
                Some(file) => stance3::solve_in(&a.robot, &a.body, hold, &file.scene, &a.solver)?,
                None => stance3::solve(&a.robot, &a.body, hold, &a.solver)?,
            };
            let planar = PlanarCounterpart::held(&a.robot, &a.body, &hold, a.scene.as_ref(), &a.solver);
            render::shape3d(out, &a, &held, &planar)
        }
        Args::Figure(a) => {
            // The directory exists: resolving checked it (and made it).
            for name in &a.names {
                render::figure(out, &a.dir, &leech_plot::figures::build(name, &a.robot)?)?;
            }
            Ok(())
        }
        Args::Workspace(a) => {
            let bar = render::progress(leech::sweep::work_count(&a.options) as u64, "solves");
            let started = Instant::now();
            let sweep = leech::sweep::sweep(&a.robot, &a.options, &|n| bar.inc(n as u64))
                .map_err(|e| failure::grid_job(e, "workspace", ", no CSV written"))?;
            bar.finish_and_clear();
            render::workspace(out, &a, &sweep, started.elapsed().as_secs_f64())
        }
        Args::Reach(a) => {
            let reach = |e| failure::grid_job(e, "reach", "");
            let answer = Reacher::new(&a.robot, a.grid, a.deadline)
                .map_err(reach)?
                .reach(a.target, a.angle)
                .map_err(|e| reach(e.into()))?;
            render::reach(out, &answer, a.json)
        }
        Args::Calibrate(a) => {
            let shapes = a.shapes.as_ref().map_or(&[][..], |s| &s.rows);
            let result = leech::calibration::calibrate(&a.robot, &a.sag.rows, shapes, a.fit, &a.deadline)?;
            render::calibration(out, &a, &result, &fitted(&a.robot, &result)?)
        }
        Args::Compare(a) => {
            render::comparison(out, &leech::calibration::compare(&a.robot, &a.shapes, &a.deadline)?, a.json)
        }
        Args::Simulate(a) => {
            let bar = render::progress((a.options.duration * 1e3) as u64, "ms simulated");
            let started = Instant::now();
            let progress = |t: f64| bar.set_position((t * 1e3) as u64);
            let result = leech::dynamics::simulate(&a.robot, a.lengths, a.start, a.actuation, &a.options, &progress)?;
            bar.finish_and_clear();
            render::simulation(out, &a, &result, started.elapsed().as_secs_f64())
        }
        Args::Scenes { json } => render::scenes(out, json),
        Args::SceneShow { scene, builtin, json } => render::scene(out, &scene, builtin, json),
        Args::Climb(a) => {
            let started = Instant::now();
            let s = &a.scenario;
            // The bar counts millimetres of the way to the goal (the rear cup's).
            let to_go = |p: [f64; 2]| ((p[0] - s.goal.point_m[0]).hypot(p[1] - s.goal.point_m[1]) * 1e3) as u64;
            let bar = render::progress(to_go(s.start.centre_m), "mm towards the goal");
            let mut progress = |p: leech::stride::Progress| {
                bar.set_position(bar.length().unwrap_or(0).saturating_sub((p.distance_m * 1e3) as u64));
            };
            let plan =
                leech::stride::plan_with_progress(&a.robot, &s.scene, s.start, s.goal, &a.options, &mut progress)?;
            bar.finish_and_clear();
            render::climb(out, &a, &plan, started.elapsed().as_secs_f64())
        }
        Args::ClimbSideways(a) => {
            let options = leech::stride::SidewaysOptions::default();
            let plan = leech::stride::plan_sideways(&a.robot, &a.scenario, &options, &a.solver)?;
            render::sideways(out, &a, &plan)
        }
        Args::Scenarios { json } => render::scenarios(out, json),
        Args::ScenarioShow { scenario, text, json } => render::scenario(out, &scenario, &text, json),
        Args::SimRobot(a) => link::sim_robot(a),
        Args::Drive(a) => link::drive(out, a),
        Args::Serve(a) => serve::serve(a),
    }
}

/// The two-chain body where its holds put it. Today's clamped body is solved
/// as always (its report and timing unchanged), then held by the rear cup,
/// which takes one Newton step from it; its angles must not move.
fn solve_shape(a: &Shape, solver: &Solver) -> Result<render::Solved, Failure> {
    if !a.clamped() {
        let held = match &a.scene {
            Some(scene) => stance::solve_among(&a.robot, a.lengths, a.hold, scene, solver, a.free_cups)?,
            None => stance::solve(&a.robot, a.lengths, a.hold, solver)?,
        };
        return Ok(render::Solved { clamped: None, held });
    }
    let eq = a.body.solve(solver)?;
    let timing = a.repeat.map(|n| SolveTiming::measure(&a.body, solver, n)).transpose()?;
    let rear = a.hold.rear().expect("the clamped body is held by its rear cup");
    let held = stance::rear_held(&a.robot, &a.body, &eq, rear, solver)?;
    let moved = eq.q.iter().zip(&held.equilibrium.q).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    if moved > HELD_ANGLES_RAD {
        eprintln!(
            "leech: warning: holding the body moved its angles by {moved:.1e} rad; reactions are the held body's"
        );
    }
    Ok(render::Solved { clamped: Some((eq, timing)), held })
}

/// How far the rear-held body's angles may be from the clamped body's (rad)
/// before a warning: above the rounding of two converged solves (the free
/// space shapes differed by 2e-12 rad, which warned at 1e-12), far below
/// anything a reaction shows (1e-9 rad over a 0.3 m tube is 0.3 nm).
const HELD_ANGLES_RAD: f64 = 1e-9;

/// The starting robot with the fitted stiffness and mass, named as fitted.
fn fitted(robot: &Robot, result: &Calibration) -> Result<Robot, InputError> {
    let fitted = robot.with_tube(result.stiffness_nm_per_rad, result.element_mass_kg)?;
    if fitted.name.contains("fitted") {
        return Ok(fitted);
    }
    Ok(fitted.with_name(format!("{} (fitted)", fitted.name)))
}
