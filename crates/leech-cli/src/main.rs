//! The `leech` command: parse, call the library, print. Exit codes: 0 done,
//! 1 an unexpected failure (for example an unwritable picture), 2 bad input,
//! 3 a solve that did not converge.

mod flags;

use std::fmt::Write as _;
use std::path::Path;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use leech::constant_curvature::PlanarBody;
use leech::prelude::*;
use leech::report::{BodyReport, CantileverReport, ConstantCurvatureReport, SampleRow, SolveTiming, SweepRow};
use leech_plot::Figure;

use flags::{
    CalibrateArgs, ChainArgs, Cli, Command, CompareArgs, FigureArgs, FitArg, IntegratorArg, ModelArg, Output,
    ReachArgs, ShapeArgs, SimulateArgs, StartArg, WorkspaceArgs,
};

/// Why the command stopped.
enum Failure {
    /// Bad input: one line naming the field, the value and what is allowed.
    Input(String),
    /// A solve that did not converge (with its status for --json).
    Solve(SolveError, bool),
    /// Another computation that did not converge (a fit, a simulation step).
    Unsolved(String),
    /// Anything else.
    Other(anyhow::Error),
}

impl From<InputError> for Failure {
    fn from(e: InputError) -> Self {
        Failure::Input(e.to_string())
    }
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Other(e)
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                print!("{e}");
                return ExitCode::SUCCESS;
            }
            // One line: clap's message without its usage and help hints.
            let rendered = e.to_string();
            let message: Vec<&str> = rendered
                .lines()
                .map(str::trim)
                .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("leech: {}", message.join(" ").trim_start_matches("error: "));
            return ExitCode::from(2);
        }
    };
    let mut out = String::new();
    let result = run(cli, &mut out);
    emit(&out);
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Input(message)) => {
            eprintln!("leech: {message}");
            ExitCode::from(2)
        }
        Err(Failure::Solve(e, json)) => {
            if json {
                emit(&format!("{}\n", solve_failure_json(&e)));
            }
            eprintln!("leech: solve failed: {e}");
            ExitCode::from(3)
        }
        Err(Failure::Unsolved(message)) => {
            eprintln!("leech: {message}");
            ExitCode::from(3)
        }
        Err(Failure::Other(e)) => {
            eprintln!("leech: {e:#}");
            ExitCode::from(1)
        }
    }
}

/// Writes to standard output; a closed pipe (`leech ... | head`) is not an error.
fn emit(text: &str) {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    let _ = stdout.write_all(text.as_bytes()).and_then(|()| stdout.flush());
}

/// Runs a command, appending what it prints to `out`.
fn run(cli: Cli, out: &mut String) -> Result<(), Failure> {
    match cli.command {
        Command::Robot { robot, json } => {
            match (&robot, json) {
                (None, false) => out.push_str(leech::robot::BUILTIN_TOML),
                (_, false) => out.push_str(&load_robot(robot.as_deref())?.to_toml_string()),
                (_, true) => writeln!(out, "{}", to_json(&load_robot(robot.as_deref())?)?).unwrap(),
            }
            Ok(())
        }
        Command::Chain(args) => chain(args, out),
        Command::Shape(args) => shape(args, out),
        Command::Figure(args) => figure(args, out),
        Command::Workspace(args) => workspace(args, out),
        Command::Reach(args) => reach(args, out),
        Command::Calibrate(args) => calibrate(args, out),
        Command::Compare(args) => compare(args, out),
        Command::Simulate(args) => simulate(args, out),
    }
}

/// The robot file (or the built-in robot) with an optional shape parameter.
fn load_tuned(choice: &flags::RobotChoice) -> Result<Robot, Failure> {
    let robot = load_robot(choice.file.as_deref())?;
    match choice.shape_parameter {
        Some(pi) => Ok(robot.with_shape_parameter(pi)?),
        None => Ok(robot),
    }
}

fn load_robot(path: Option<&Path>) -> Result<Robot, Failure> {
    let Some(path) = path else { return Ok(Robot::builtin()) };
    let text = std::fs::read_to_string(path)
        .map_err(|e| Failure::Input(format!("--robot: cannot read '{}': {e}", path.display())))?;
    Robot::from_toml_str(&text).map_err(|e| Failure::Input(format!("{}: {e}", path.display())))
}

fn to_json<T: serde::Serialize>(value: &T) -> anyhow::Result<String> {
    serde_json::to_string_pretty(value).context("serializing the result")
}

fn solve_failure_json(e: &SolveError) -> String {
    let value = match e {
        SolveError::NotConverged { stage, iterations, residual, reason } => serde_json::json!({
            "status": "not_converged", "stage": stage, "iterations": iterations,
            "residual": residual, "reason": reason,
        }),
        SolveError::TimeLimit { iterations, residual, .. } => serde_json::json!({
            "status": "time_limit", "iterations": iterations, "residual": residual,
        }),
        SolveError::BadStart { .. } => serde_json::json!({ "status": "bad_start", "reason": e.to_string() }),
    };
    value.to_string()
}

fn pictures(output: &Output, figure: impl Fn() -> Figure) -> Result<(), Failure> {
    if let Some(path) = &output.svg {
        figure().write_svg(path).map_err(|e| Failure::Other(e.into()))?;
    }
    if let Some(path) = &output.png {
        figure().write_png(path).map_err(|e| Failure::Other(e.into()))?;
    }
    Ok(())
}

/// The human-readable status lines of a solve.
fn describe_solution(eq: &Equilibrium, out: &mut String) {
    writeln!(
        out,
        "converged in {} iterations (residual {:.1e}), {}",
        eq.iterations,
        eq.residual,
        if eq.stable { "stable" } else { "UNSTABLE" }
    )
    .expect("writing to a String");
    for event in &eq.events {
        match event {
            Event::Snap { stage, at, jump_rad } => writeln!(
                out,
                "note: the body snapped through a fold on the {stage} path at {:.1} % (largest angle change {jump_rad:.2} rad)",
                at * 100.0
            ),
            Event::Bifurcation { stage, at, side, jump_rad } => writeln!(
                out,
                "note: the {stage} path crossed a symmetric bifurcation at {:.1} %; the body went to the {side} of the clamp direction (largest angle change {jump_rad:.2} rad)",
                at * 100.0
            ),
        }
        .expect("writing to a String");
    }
}

/// The solver with the command line's bounds.
fn solver(max_iterations: usize, time_limit: f64) -> Result<Solver, Failure> {
    let seconds = leech::error::positive("--time-limit (s)", time_limit)?;
    let time_limit = std::time::Duration::try_from_secs_f64(seconds)
        .map_err(|_| Failure::Input(format!("--time-limit: got {seconds}, expected a number of seconds")))?;
    Ok(Solver::new(SolverOptions { max_iterations, time_limit: Some(time_limit), ..SolverOptions::default() }))
}

fn chain(args: ChainArgs, out: &mut String) -> Result<(), Failure> {
    let stiffness = match (args.stiffness, args.shape_parameter) {
        (Some(k), _) => k,
        (None, pi) => {
            let pi = leech::error::positive("shape parameter", pi.unwrap_or(f64::NAN))?;
            leech::error::positive("gravity_m_per_s2 (the shape parameter needs gravity)", args.gravity)?;
            pi * args.element_mass * args.gravity * args.element_length
        }
    };
    let spec = CantileverSpec {
        elements: args.elements,
        element_length_m: args.element_length,
        element_mass_kg: args.element_mass,
        joint_stiffness_nm_per_rad: stiffness,
        tip_mass_kg: args.tip_mass,
        base_angle_deg: args.base_angle,
        gravity_m_per_s2: args.gravity,
        discretization: args.discretization.into(),
    };
    let tube = spec.build()?;
    let eq =
        tube.solve(&solver(args.max_iterations, args.time_limit)?).map_err(|e| Failure::Solve(e, args.output.json))?;
    let report = CantileverReport::new(spec.shape_parameter(), &tube, &eq);
    if args.output.json {
        writeln!(out, "{}", to_json(&report)?).expect("writing to a String");
    } else {
        writeln!(
            out,
            "tube of {} elements, {:.4} m, shape parameter Pi = {:.4}",
            spec.elements, report.length_m, report.shape_parameter
        )
        .expect("writing to a String");
        writeln!(out, "tip at ({:.3}, {:.3}) mm", report.tip_m[0] * 1e3, report.tip_m[1] * 1e3)
            .expect("writing to a String");
        describe_solution(&eq, out);
    }
    let title = format!("single tube: {} elements, Pi = {:.3}", spec.elements, report.shape_parameter);
    pictures(&args.output, || leech_plot::shape::cantilever_figure(&title, &tube, &eq.q))
}

fn shape(args: ShapeArgs, out: &mut String) -> Result<(), Failure> {
    let mut robot = load_robot(args.robot.file.as_deref())?;
    if let Some(angle) = args.base_angle {
        robot.world.base_angle_deg = angle;
    }
    if let Some(g) = args.gravity {
        robot.world.gravity_m_per_s2 = g;
    }
    if let Some(d) = args.discretization {
        robot.model.discretization = d.into();
    }
    if let Some(pi) = args.robot.shape_parameter {
        robot = robot.with_shape_parameter(pi)?;
    }
    let [la, lb] = args.lengths;
    // The body checks the lengths for both models.
    let body = robot.body(la, lb)?;
    let cc = PlanarBody::of(&robot);
    let cc_report = ConstantCurvatureReport::new(&cc, la, lb, 60);
    let two_chain = match args.model {
        ModelArg::ConstantCurvature => None,
        _ => {
            let solver = solver(args.max_iterations, args.time_limit)?;
            let eq = body.solve(&solver).map_err(|e| Failure::Solve(e, args.output.json))?;
            let report = BodyReport::new(&robot.name, robot.shape_parameter(), &body, &eq);
            Some((eq, report))
        }
    };
    let timing = match (args.repeat, &two_chain) {
        (Some(n), Some(_)) => {
            let n = std::num::NonZeroUsize::new(n)
                .filter(|n| n.get() <= 100_000)
                .ok_or_else(|| Failure::Input(format!("--repeat: got {n}, expected 1 to 100000")))?;
            Some(SolveTiming::measure(&body, &solver(args.max_iterations, args.time_limit)?, n))
        }
        _ => None,
    };
    if args.output.json {
        let json = match (&two_chain, args.model) {
            (Some((_, report)), ModelArg::TwoChain) => match timing {
                Some(t) => {
                    let mut v = serde_json::to_value(report).context("serializing the result")?;
                    v["solve_time_s"] = serde_json::to_value(t).context("serializing the timing")?;
                    to_json(&v)?
                }
                None => to_json(report)?,
            },
            (Some((_, report)), _) => to_json(&serde_json::json!({ "models": [report, cc_report] }))?,
            (None, _) => to_json(&cc_report)?,
        };
        writeln!(out, "{json}").expect("writing to a String");
    } else {
        writeln!(out, "{}: LA = {:.4} m, LB = {:.4} m (Pi = {:.0})", robot.name, la, lb, robot.shape_parameter())
            .expect("writing to a String");
        if let Some((eq, report)) = &two_chain {
            writeln!(
                out,
                "two-chain: endpoint at ({:.3}, {:.3}) mm, plate angle {:.3} deg ({} + {} links)",
                report.endpoint_m[0] * 1e3,
                report.endpoint_m[1] * 1e3,
                report.endpoint_angle_rad.to_degrees(),
                report.links[0],
                report.links[1]
            )
            .expect("writing to a String");
            describe_solution(eq, out);
            if let Some(t) = &timing {
                writeln!(
                    out,
                    "solve time over {} cold solves: median {:.1} us, fastest {:.1} us",
                    t.solves,
                    t.median * 1e6,
                    t.min * 1e6
                )
                .expect("writing to a String");
            }
        }
        if args.model != ModelArg::TwoChain {
            writeln!(
                out,
                "constant curvature: endpoint at ({:.3}, {:.3}) mm, plate angle {:.3} deg (bend {:.3} rad)",
                cc_report.endpoint_m[0] * 1e3,
                cc_report.endpoint_m[1] * 1e3,
                cc_report.endpoint_angle_rad.to_degrees(),
                cc_report.bend_rad
            )
            .expect("writing to a String");
        }
    }
    pictures(&args.output, || match &two_chain {
        Some((eq, _)) if args.model == ModelArg::Both => {
            leech_plot::shape::comparison_figure(&robot.name, &body, &eq.q, &cc)
        }
        Some((eq, _)) => leech_plot::shape::body_figure(&robot.name, &body, &eq.q),
        None => leech_plot::shape::constant_curvature_figure(&robot.name, &cc, la, lb),
    })
}

fn figure(args: FigureArgs, out: &mut String) -> Result<(), Failure> {
    use leech_plot::figures::{build, FigureError, NAMES};
    let robot = load_tuned(&args.robot)?;
    let names: Vec<&str> = if args.name == "all" { NAMES.to_vec() } else { vec![args.name.as_str()] };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating the output directory {}", args.out.display()))?;
    for name in names {
        let output = build(name, &robot).map_err(|e| match e {
            FigureError::Input(e) => Failure::Input(e.to_string()),
            FigureError::Solve { source, .. } => Failure::Solve(source, false),
            FigureError::Plot(e) => Failure::Other(e.into()),
        })?;
        let (svg, csv) = (args.out.join(format!("{name}.svg")), args.out.join(format!("{name}.csv")));
        output.figure.write_svg(&svg).map_err(|e| Failure::Other(e.into()))?;
        output.table.write_csv(&csv).map_err(|e| Failure::Other(e.into()))?;
        writeln!(out, "wrote {} and {}", svg.display(), csv.display()).expect("writing to a String");
    }
    Ok(())
}

fn workspace(args: WorkspaceArgs, out: &mut String) -> Result<(), Failure> {
    use leech::sweep::{point_count, sweep, Grid, Model, SweepOptions};
    let mut robot = load_robot(args.robot.as_deref())?;
    if let Some(angle) = args.base_angle {
        robot.world.base_angle_deg = angle;
    }
    let models = match args.model {
        ModelArg::TwoChain => vec![Model::TwoChain],
        ModelArg::ConstantCurvature => vec![Model::ConstantCurvature],
        ModelArg::Both => vec![Model::TwoChain, Model::ConstantCurvature],
    };
    let options = SweepOptions {
        grid: Grid::parse(&args.lengths_range)?,
        shape_parameters: args.shape_parameter.clone(),
        models,
        left_longer: args.left_longer,
    };
    for pi in &options.shape_parameters {
        leech::error::positive("shape parameter", *pi)?;
    }
    // A bar on a terminal only: indicatif draws nothing when stderr is piped.
    let bar = indicatif::ProgressBar::new(point_count(&options) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} points, {elapsed} ({eta} left)")
            .expect("a valid template"),
    );
    let started = std::time::Instant::now();
    let result = sweep(&robot, &options, &|n| bar.inc(n as u64))?;
    bar.finish_and_clear();
    let elapsed = started.elapsed().as_secs_f64();
    write_csv(&args.out, result.points.iter().map(SweepRow::from))?;
    if let Some(svg) = &args.svg {
        let title = format!("{}: endpoints over LA, LB in {}", robot.name, args.lengths_range);
        leech_plot::figures::sweep_figure(&title, &result).write_svg(svg).map_err(|e| Failure::Other(e.into()))?;
    }
    let failures: usize = result.summaries.iter().map(|s| s.failures.len()).sum();
    if args.json {
        let v = serde_json::json!({
            "points": result.points.len(),
            "failures": failures,
            "elapsed_s": elapsed,
            "summaries": result.summaries,
        });
        writeln!(out, "{}", to_json(&v)?).expect("writing to a String");
    } else {
        writeln!(
            out,
            "{} points in {:.2} s, {} failures; every point in {}",
            result.points.len(),
            elapsed,
            failures,
            args.out.display()
        )
        .expect("writing to a String");
        for s in &result.summaries {
            let pi = s.shape_parameter.map_or("-".to_string(), |p| format!("{p:.0}"));
            let mm = |e: &Option<leech::sweep::Extreme>, k: usize| e.map_or(f64::NAN, |e| e.endpoint_m[k] * 1e3);
            writeln!(
                out,
                "{:<18} Pi {:>7}: highest y {:7.1} mm, lowest y {:7.1} mm, farthest |x| {:6.1} mm, area {:7.0} mm^2; infeasible {}, unstable {}, snapped {}, failures {}",
                s.model.name(), pi, mm(&s.highest, 1), mm(&s.lowest, 1), mm(&s.farthest, 0).abs(), s.area_m2 * 1e6,
                s.infeasible, s.unstable, s.snapped, s.failures.len()
            )
            .expect("writing to a String");
            for f in &s.failures {
                writeln!(out, "  failed at LA = {} m, LB = {} m: {}", f.lengths_m[0], f.lengths_m[1], f.reason)
                    .expect("writing to a String");
            }
        }
    }
    Ok(())
}

/// One CSV record per row, the header from the rows' field names; the csv
/// writer quotes fields with commas or quotes.
fn write_csv<T: serde::Serialize>(path: &Path, rows: impl IntoIterator<Item = T>) -> anyhow::Result<()> {
    let write = || -> anyhow::Result<()> {
        let mut writer = csv::Writer::from_path(path)?;
        for row in rows {
            writer.serialize(row)?;
        }
        writer.flush()?;
        Ok(())
    };
    write().with_context(|| format!("writing {}", path.display()))
}

fn reach(args: ReachArgs, out: &mut String) -> Result<(), Failure> {
    use leech::inverse_statics::{check_target, ReachStatus, Reacher};
    let mut robot = load_tuned(&args.robot)?;
    if let Some(angle) = args.base_angle {
        robot.world.base_angle_deg = angle;
    }
    let target = [check_target("target x", args.target[0])?, check_target("target y", args.target[1])?];
    let angle = match args.angle {
        Some(a) => Some(leech::error::within("angle (deg)", a, -720.0, 720.0)?.to_radians()),
        None => None,
    };
    let grid = leech::sweep::Grid::parse(&args.lengths_range)?;
    let reacher = Reacher::new(&robot, grid)?;
    let answer = reacher.reach(target, angle);
    if args.json {
        writeln!(out, "{}", to_json(&answer)?).expect("writing to a String");
    } else {
        let verdict = match answer.status {
            ReachStatus::Reached => "reached",
            ReachStatus::Unreachable => "UNREACHABLE; nearest point found",
        };
        writeln!(
            out,
            "{verdict}: LA = {:.6} m, LB = {:.6} m, endpoint ({:.4}, {:.4}) mm, error {:.2e} m, plate angle {:.3} deg",
            answer.lengths_m[0],
            answer.lengths_m[1],
            answer.endpoint_m[0] * 1e3,
            answer.endpoint_m[1] * 1e3,
            answer.error_m,
            answer.endpoint_angle_rad.to_degrees()
        )
        .expect("writing to a String");
    }
    Ok(())
}

fn read_input(path: &Path, flag: &str) -> Result<String, Failure> {
    std::fs::read_to_string(path).map_err(|e| Failure::Input(format!("{flag}: cannot read '{}': {e}", path.display())))
}

fn calibration_failure(e: leech::calibration::CalibrationError) -> Failure {
    use leech::calibration::CalibrationError;
    match e {
        CalibrationError::Model(message) => Failure::Unsolved(format!("fit failed: {message}")),
        other => Failure::Input(other.to_string()),
    }
}

fn calibrate(args: CalibrateArgs, out: &mut String) -> Result<(), Failure> {
    use leech::calibration::{calibrate, read_sag, read_shapes, Fit};
    let robot = load_tuned(&args.robot)?;
    let sag_name = args.sag.display().to_string();
    let sag = read_sag(&read_input(&args.sag, "--sag")?, &sag_name)?;
    let shapes = match &args.shapes {
        Some(path) => read_shapes(&read_input(path, "--shapes")?, &path.display().to_string())?,
        None => vec![],
    };
    let fit = match args.fit {
        FitArg::Stiffness => Fit::Stiffness,
        FitArg::StiffnessMass => Fit::StiffnessAndMass,
    };
    let result = calibrate(&robot, &sag, &shapes, fit).map_err(calibration_failure)?;
    let mut fitted = robot.clone();
    fitted.tube.joint_stiffness_nm_per_rad = result.stiffness_nm_per_rad;
    fitted.tube.element_mass_kg = result.element_mass_kg;
    if !fitted.name.contains("fitted") {
        fitted.name = format!("{} (fitted)", fitted.name);
    }
    let mass_line = match result.element_mass_std_error_kg {
        Some(se) => format!("# element_mass_kg fitted: {:.6e} +- {:.2e} kg\n", result.element_mass_kg, se),
        None => format!("# element_mass_kg kept from the starting robot: {:.6e} kg\n", result.element_mass_kg),
    };
    let mut toml = format!(
        "# Fitted by `leech calibrate` to {} ({} tubes){}: {} points, RMS residual {:.3} mm.\n\
         # joint_stiffness_nm_per_rad fitted: {:.6e} +- {:.2e} N m/rad (one standard error).\n{}",
        sag_name,
        sag.len(),
        args.shapes.as_ref().map_or(String::new(), |p| format!(" and {} ({} shapes)", p.display(), shapes.len())),
        result.points,
        result.rms_residual_mm,
        result.stiffness_nm_per_rad,
        result.stiffness_std_error_nm_per_rad,
        mass_line,
    );
    toml.push_str(&fitted.to_toml_string());
    std::fs::write(&args.out, toml).with_context(|| format!("writing {}", args.out.display()))?;
    if let Some(svg) = &args.svg {
        let title =
            format!("Fit: k = {:.4} N m/rad, RMS {:.2} mm", result.stiffness_nm_per_rad, result.rms_residual_mm);
        leech_plot::shape::calibration_figure(&title, &fitted, &sag, &shapes)
            .write_svg(svg)
            .map_err(|e| Failure::Other(e.into()))?;
    }
    if args.json {
        writeln!(out, "{}", to_json(&result)?).expect("writing to a String");
    } else {
        writeln!(out, "k = {:.6} +- {:.6} N m/rad", result.stiffness_nm_per_rad, result.stiffness_std_error_nm_per_rad)
            .expect("writing to a String");
        if let Some(se) = result.element_mass_std_error_kg {
            writeln!(out, "m = {:.6e} +- {:.2e} kg", result.element_mass_kg, se).expect("writing to a String");
        }
        writeln!(
            out,
            "Pi = {:.1}; RMS residual {:.3} mm, largest {:.3} mm over {} points ({} iterations); wrote {}",
            result.shape_parameter,
            result.rms_residual_mm,
            result.max_residual_mm,
            result.points,
            result.iterations,
            args.out.display()
        )
        .expect("writing to a String");
    }
    Ok(())
}

fn compare(args: CompareArgs, out: &mut String) -> Result<(), Failure> {
    use leech::calibration::{compare, read_shapes};
    let robot = load_tuned(&args.robot)?;
    let shapes = read_shapes(&read_input(&args.shapes, "--shapes")?, &args.shapes.display().to_string())?;
    let rows = compare(&robot, &shapes).map_err(calibration_failure)?;
    if args.json {
        writeln!(out, "{}", to_json(&serde_json::json!({ "shapes": rows }))?).expect("writing to a String");
        return Ok(());
    }
    writeln!(
        out,
        "{:<16} {:>7} {:>7} | {:>27} | {:>27}",
        "shape", "LA mm", "LB mm", "two-chain rms/max/end mm", "constant curv. rms/max/end mm"
    )
    .expect("writing to a String");
    let cell = |e: &leech::calibration::ShapeError| {
        format!("{:7.2} {:7.2} {:>9}", e.rms_mm, e.max_mm, e.endpoint_mm.map_or("-".into(), |v| format!("{v:.2}")))
    };
    for r in &rows {
        writeln!(
            out,
            "{:<16} {:>7.1} {:>7.1} | {} | {}",
            r.shape,
            r.lengths_m[0] * 1e3,
            r.lengths_m[1] * 1e3,
            cell(&r.two_chain),
            cell(&r.constant_curvature)
        )
        .expect("writing to a String");
    }
    Ok(())
}

fn simulate(args: SimulateArgs, out: &mut String) -> Result<(), Failure> {
    use leech::dynamics::{simulate, Actuation, Integrator, SimulationError, SimulationOptions, Start};
    let robot = load_tuned(&args.robot)?;
    let actuation = match (args.to, args.step) {
        (None, _) => Actuation::Hold,
        (Some(to), true) => Actuation::Step { to },
        (Some(to), false) => Actuation::Feed { to, speed: leech::error::positive("--speed (mm/s)", args.speed)? / 1e3 },
    };
    let start = match (args.start, args.to) {
        (Some(StartArg::Unloaded), _) | (None, None) => Start::Unloaded,
        _ => Start::Static,
    };
    let integrator = match args.integrator {
        IntegratorArg::Explicit => Integrator::Explicit,
        IntegratorArg::Implicit => Integrator::Implicit,
        IntegratorArg::Midpoint => Integrator::Midpoint,
    };
    let duration = leech::error::within("--duration (s)", args.duration, 1e-6, 3600.0)?;
    let dt = match (args.dt, integrator) {
        (Some(dt), _) => Some(leech::error::within("--dt (s)", dt, 1e-9, duration)?),
        (None, Integrator::Implicit) => Some(5e-3_f64.min(duration)),
        (None, _) => None,
    };
    let options = SimulationOptions {
        integrator,
        dt,
        duration,
        until_rest: args.until_rest,
        gravity_ramp: args.ramp,
        sample_interval: (duration / 500.0).max(1e-4),
        rest_rate: args.rest_rate,
    };
    let bar = indicatif::ProgressBar::new((duration * 1e3) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} ms simulated, {elapsed} ({eta} left)")
            .expect("a valid template"),
    );
    let started = std::time::Instant::now();
    let result = simulate(&robot, args.lengths, start, actuation, &options, &|t| bar.set_position((t * 1e3) as u64))
        .map_err(|e| match e {
            SimulationError::Input(e) => Failure::Input(e.to_string()),
            SimulationError::Start(e) => Failure::Solve(e, args.json),
            other => Failure::Unsolved(format!("simulation failed: {other}")),
        })?;
    bar.finish_and_clear();
    let wall = started.elapsed().as_secs_f64();
    let last = result.samples.last().expect("a simulation records its start");
    if let Some(path) = &args.csv {
        write_csv(path, result.samples.iter().map(SampleRow::from))?;
    }
    if let Some(path) = &args.svg {
        // At most about 250 frames keeps the file small and the playback smooth.
        let every = result.samples.len().div_ceil(250).max(1);
        let frames: Vec<leech_plot::animation::Frame> = result
            .samples
            .iter()
            .enumerate()
            .filter(|(i, _)| i % every == 0 || *i == result.samples.len() - 1)
            .map(|(_, s)| leech_plot::animation::Frame {
                time: s.time_s,
                lines: vec![
                    s.points_a_m.clone(),
                    s.points_b_m.clone(),
                    vec![*s.points_a_m.last().expect("a chain"), *s.points_b_m.last().expect("a chain")],
                    vec![s.points_a_m[0], s.points_b_m[0]],
                ],
            })
            .collect();
        let motion = match actuation {
            Actuation::Hold => "settling under gravity".to_string(),
            Actuation::Step { to } => format!("step to LA {:.0} mm, LB {:.0} mm", to[0] * 1e3, to[1] * 1e3),
            Actuation::Feed { to, speed } => {
                format!("feeding to LA {:.0} mm, LB {:.0} mm at {:.0} mm/s", to[0] * 1e3, to[1] * 1e3, speed * 1e3)
            }
        };
        let title = format!("LA {:.0} mm, LB {:.0} mm:\n{motion}", args.lengths[0] * 1e3, args.lengths[1] * 1e3);
        std::fs::write(path, leech_plot::animation::animated_svg(&title, &frames))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let simulated = last.time_s;
    if args.json {
        let v = serde_json::json!({
            "integrator": integrator,
            "dt_s": result.dt,
            "steps": result.steps,
            "simulated_s": simulated,
            "wall_s": wall,
            "real_time_factor": simulated / wall.max(1e-12),
            "time_to_rest_s": result.time_to_rest,
            "max_constraint_violation": result.max_violation,
            "final": {
                "lengths_m": last.lengths_m,
                "endpoint_m": last.endpoint_m,
                "endpoint_angle_rad": last.angles_a_rad.last(),
                "kinetic_j": last.kinetic_j,
                "potential_j": last.potential_j,
                "chains": {
                    "a": {"points_m": last.points_a_m, "angles_rad": last.angles_a_rad},
                    "b": {"points_m": last.points_b_m, "angles_rad": last.angles_b_rad},
                },
            },
        });
        writeln!(out, "{}", to_json(&v)?).expect("writing to a String");
    } else {
        let rest = result.time_to_rest.map_or("not at rest".to_string(), |t| format!("at rest after {t:.3} s"));
        writeln!(
            out,
            "{:.3} s simulated in {} steps of {:.2e} s ({:.3}x real time); {rest}; largest constraint violation {:.1e}",
            simulated,
            result.steps,
            result.dt,
            simulated / wall.max(1e-12),
            result.max_violation
        )
        .expect("writing to a String");
        writeln!(
            out,
            "final endpoint ({:.3}, {:.3}) mm at LA = {:.4} m, LB = {:.4} m",
            last.endpoint_m[0] * 1e3,
            last.endpoint_m[1] * 1e3,
            last.lengths_m[0],
            last.lengths_m[1]
        )
        .expect("writing to a String");
    }
    Ok(())
}
