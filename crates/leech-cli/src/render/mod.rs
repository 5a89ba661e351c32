//! The one place that prints: each command's result as JSON or text on
//! standard output, the files it writes ([`files`]) and progress bars.
//!
//! Standard output is gathered in a `String` and written once by [`emit`],
//! so a command that fails half-way still prints what it had.

mod files;
mod text;

use std::path::Path;

use anyhow::Context;
use leech::body3::ConstantCurvature3;
use leech::budget::Halt;
use leech::calibration::{Calibration, ShapeComparison};
use leech::constant_curvature::PlanarBody;
use leech::dynamics::Simulation;
use leech::inverse_statics::Reach;
use leech::prelude::*;
use leech::report::{
    Body3Report, BodyReport, CantileverReport, ClimbReport, ConstantCurvature3Report, ConstantCurvatureReport,
    PlanarCounterpart, SampleRow, SceneReport, ShapeReport, SolveTiming, StanceReport, SweepRow, TubeInSceneReport,
};
use leech::scene::Scene;
use leech::stance::{Held, TubeHeld};
use leech::stance3::Held3;
use leech::stride::{Plan, Scenario, SidewaysPlan, Status};
use leech::sweep::{Model, Sweep};
use leech_plot::figures::Output;
use serde::Serialize;
use serde_json::json;

use crate::args::{Calibrate, Chain, Climb, ClimbSideways, Shape, Shape3d, Simulate, Workspace};
use crate::failure::Failure;

/// Writes to standard output; a closed pipe (`leech ... | head`) is not an
/// error, any other failure (a full disk) is.
pub fn emit(text: &str) -> std::io::Result<()> {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    match stdout.write_all(text.as_bytes()).and_then(|()| stdout.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e),
        _ => Ok(()),
    }
}

/// The status of a failed solve, one JSON line.
pub fn solve_failure(e: &SolveError) -> String {
    let value = match e {
        SolveError::NotConverged { stage, iterations, residual, reason } => json!({
            "status": "not_converged", "stage": stage, "iterations": iterations,
            "residual": residual, "reason": reason,
        }),
        SolveError::Stopped { halt, iterations, residual } => json!({
            "status": match halt { Halt::TimeLimit(_) => "time_limit", Halt::Cancelled => "cancelled" },
            "iterations": iterations, "residual": residual,
        }),
        SolveError::BadStart { .. } => json!({ "status": "bad_start", "reason": e.to_string() }),
    };
    format!("{value}\n")
}

/// A bar of `len` `unit` on a terminal; indicatif draws nothing when stderr is piped.
pub fn progress(len: u64, unit: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    let template = format!("{{bar:40}} {{pos}}/{{len}} {unit}, {{elapsed}} ({{eta}} left)");
    bar.set_style(indicatif::ProgressStyle::with_template(&template).expect("a valid template"));
    bar
}

fn json(out: &mut String, value: &impl Serialize) -> Result<(), Failure> {
    out.push_str(&serde_json::to_string_pretty(value).context("serializing the result")?);
    out.push('\n');
    Ok(())
}

/// `leech robot`: the built-in robot's file keeps its comments.
pub fn robot(out: &mut String, robot: Option<&Robot>, as_json: bool) -> Result<(), Failure> {
    match (robot, as_json) {
        (None, false) => out.push_str(leech::robot::BUILTIN_TOML),
        (Some(robot), false) => out.push_str(&robot.to_toml_string()),
        (robot, true) => json(out, robot.unwrap_or(&Robot::builtin()))?,
    }
    Ok(())
}

pub fn chain(out: &mut String, a: &Chain, eq: &Equilibrium) -> Result<(), Failure> {
    let report = CantileverReport::new(a.shape_parameter, &a.tube, eq);
    if a.outputs.json {
        json(out, &report)?;
    } else {
        text::chain(out, a.elements, &report);
    }
    let title = format!("single tube: {} elements, Pi = {}", a.elements, text::fixed(report.shape_parameter, 3));
    files::pictures(&a.outputs, || leech_plot::shape::cantilever_figure(&title, &a.tube, &eq.q))
}

/// `leech chain --scene`: the tube's report with its contacts and the
/// clamp's reaction; the picture adds the scene and the forces.
pub fn chain_in_scene(out: &mut String, a: &Chain, scene: &Scene, held: &TubeHeld) -> Result<(), Failure> {
    let report = TubeInSceneReport::new(a.shape_parameter, held, scene);
    if a.outputs.json {
        json(out, &report)?;
    } else {
        text::chain(out, a.elements, &report.tube);
        text::tube_in_scene(out, &report);
    }
    let title = format!(
        "single tube: {} elements, Pi = {}, on {}",
        a.elements,
        text::fixed(report.tube.shape_parameter, 3),
        scene.name
    );
    files::pictures(&a.outputs, || leech_plot::stance::tube_figure(&title, held, scene))
}

/// The two-chain model's results: the clamped body's equilibrium and timing
/// when the situation is today's, and the body where its holds put it.
pub struct Solved {
    pub clamped: Option<(Equilibrium, Option<SolveTiming>)>,
    pub held: Held,
}

/// `leech shape`; `solved` is the two-chain model's when it ran.
pub fn shape(out: &mut String, a: &Shape, solved: Option<&Solved>) -> Result<(), Failure> {
    let [la, lb] = a.lengths;
    let cc = PlanarBody::of(&a.robot);
    let cc_report = ConstantCurvatureReport::new(&cc, la, lb, 60);
    let cups = solved.map(|s| s.held.cups(&a.robot)).transpose()?;
    let two_chain = solved.zip(cups.as_ref()).map(|(s, cups)| {
        let body = match &s.clamped {
            Some((eq, _)) => BodyReport::new(&a.robot.name, a.robot.shape_parameter(), &a.body, eq),
            None => BodyReport::held(&a.robot, &s.held),
        };
        let stance = StanceReport::new(&a.robot, &s.held, a.scene.as_ref(), cups);
        (ShapeReport { body, stance }, s.clamped.as_ref().and_then(|(_, t)| t.as_ref()))
    });
    let with_cc = a.models.contains(&Model::ConstantCurvature);
    if a.outputs.json {
        match (&two_chain, with_cc) {
            // The timing joins the report's keys (sorted, as serde_json's maps are).
            (Some((report, Some(timing))), false) => {
                let mut v = serde_json::to_value(report).context("serializing the result")?;
                v["solve_time_s"] = serde_json::to_value(timing).context("serializing the timing")?;
                json(out, &v)?
            }
            (Some((report, None)), false) => json(out, report)?,
            (Some((report, _)), true) => json(out, &json!({ "models": [report, cc_report] }))?,
            (None, _) => json(out, &cc_report)?,
        }
    } else {
        let body = two_chain.as_ref().map(|(r, t)| (&r.body, *t));
        text::shape(out, &a.robot, a.lengths, body, with_cc.then_some(&cc_report));
        if let Some((report, _)) = &two_chain {
            text::stance(out, &report.stance, a.robot.cup.min_safety_factor);
        }
    }
    files::pictures(&a.outputs, || match (solved.zip(cups.as_ref()), with_cc) {
        (Some((s, _)), true) => {
            let q = s.clamped.as_ref().map_or(&s.held.equilibrium.q, |(eq, _)| &eq.q);
            leech_plot::shape::comparison_figure(&a.robot.name, &a.body, q, &cc)
        }
        (Some((s, cups)), false) => leech_plot::stance::held_figure(&a.robot, &s.held, a.scene.as_ref(), cups),
        (None, _) => leech_plot::shape::constant_curvature_figure(&a.robot.name, &cc, la, lb),
    })
}

/// `leech shape3d`: the held 3D body's report (its cups, its contacts) with
/// the planar model beside it, and its three views with the scene's solids.
pub fn shape3d(out: &mut String, a: &Shape3d, held: &Held3, planar: &PlanarCounterpart) -> Result<(), Failure> {
    let scene = a.scene.as_ref().map(|s| &s.scene);
    let report = Body3Report::held(&a.robot, held, scene.map(|s| s.name.as_str()), a.free_axial_rotation, planar);
    if a.outputs.json {
        json(out, &report)?;
    } else {
        text::shape3d(out, &report, a.robot.cup.min_safety_factor);
    }
    files::pictures(&a.outputs, || leech_plot::body3::held3_figure(&a.robot, held, scene))
}

/// Points along each tube of the constant-curvature model in reports and pictures.
const ARC_SAMPLES: usize = 60;

/// `leech shape3d --model constant-curvature`: the arcs' report and three views.
pub fn constant_curvature3(out: &mut String, a: &Shape3d, cc: &ConstantCurvature3) -> Result<(), Failure> {
    let report = ConstantCurvature3Report::new(&a.robot, cc, ARC_SAMPLES)?;
    if a.outputs.json {
        json(out, &report)?;
    } else {
        text::constant_curvature3(out, &report);
    }
    let tubes = || leech_plot::body3::Tubes([0, 1, 2].map(|i| report.tubes[i].points_m.clone()));
    files::pictures(&a.outputs, || leech_plot::body3::arcs3_figure(&a.robot.name, tubes()))
}

/// `leech scene list`: each built-in scene's name and what it is.
pub fn scenes(out: &mut String, as_json: bool) -> Result<(), Failure> {
    if as_json {
        let list: Vec<_> = Scene::builtin_names().map(|(name, d)| json!({ "name": name, "description": d })).collect();
        return json(out, &json!({ "scenes": list }));
    }
    text::scenes(out);
    Ok(())
}

/// `leech scene show`: a built-in scene's file with its comments, another
/// scene as its file would be; or its JSON form.
pub fn scene(out: &mut String, scene: &Scene, builtin: Option<&str>, as_json: bool) -> Result<(), Failure> {
    match (as_json, builtin) {
        (true, _) => json(out, &SceneReport::from(scene))?,
        (false, Some(text)) => out.push_str(text),
        (false, None) => out.push_str(&scene.to_toml_string()),
    }
    Ok(())
}

/// `leech climb`: the plan as JSON or text, its steps to CSV, its animation
/// to SVG; an impossible
/// climb is a failure (exit 3) after all that is printed and written.
pub fn climb(out: &mut String, a: &Climb, plan: &Plan, elapsed_s: f64) -> Result<(), Failure> {
    let s = &a.scenario;
    let report = ClimbReport::new(&s.name, &a.robot, plan, s.goal.point_m, s.goal.tolerance_m);
    if let Some(path) = &a.outputs.csv {
        files::climb_csv(path, &report)?;
    }
    if let Some(path) = &a.outputs.svg {
        files::climb_animation(path, a, plan)?;
    }
    if a.outputs.json {
        json(out, &report)?;
    } else {
        text::climb(out, &report, elapsed_s);
    }
    let verdict = match plan.status {
        Status::Reached => return Ok(()),
        Status::Impossible => "impossible",
        Status::Stopped => "stopped",
    };
    Err(Failure::Unsolved(match &report.reason {
        Some(r) => {
            format!("climb {verdict}: {} blocked the {} phase: {}", r.blocking.name(), r.phase.name(), r.detail)
        }
        None => format!("climb {verdict}"),
    }))
}

/// `leech climb` of a sideways scenario: JSON (units in the keys) or one
/// line per phase's end; an impossible climb fails with its reason (exit 3).
pub fn sideways(out: &mut String, a: &ClimbSideways, plan: &SidewaysPlan) -> Result<(), Failure> {
    let s = &a.scenario;
    if a.json {
        let cup = |c: &Option<leech::stance3::CupState3>| serde_json::to_value(c).unwrap_or_default();
        let steps: Vec<_> = plan
            .steps
            .iter()
            .map(|step| {
                let (body, frames) = (&step.held.body, &step.held.equilibrium.frames);
                json!({
                    "phase": step.phase.name(),
                    "stride": step.stride,
                    "lengths_m": step.lengths_m,
                    "hold": step.held.hold.name(),
                    "stable": step.held.equilibrium.summary.stable,
                    "endpoint_m": body.endpoint(frames),
                    "plate_frame": body.plate_frame(frames),
                    "pivot_turn_rad": step.held.pivot_turn_rad,
                    "swing_safety_factor": step.swing_safety_factor,
                    "rear_cup": cup(&step.held.rear),
                    "front_cup": cup(&step.held.front),
                    "tubes": (0..3).map(|i| json!({ "points_m": body.points(frames, i) })).collect::<Vec<_>>(),
                })
            })
            .collect();
        json(
            out,
            &json!({
                "scenario": s.name,
                "robot": a.robot.name,
                "status": plan.status,
                "reason": plan.reason,
                "goal_lateral_m": s.lateral_m,
                "tolerance_m": s.tolerance_m,
                "lateral_m": plan.lateral_m,
                "strides": plan.strides,
                "stride_lateral_m": plan.stride_lateral_m,
                "steps": steps,
            }),
        )?;
    } else {
        text::sideways(out, a, plan);
    }
    if let Some(path) = a.svg.as_ref().filter(|_| !plan.steps.is_empty()) {
        // An impossible or stopped plan is drawn to where it got (a plan
        // stopped before its start has nothing to draw).
        leech_plot::body3::sideways_figure(&a.robot, s, plan).write_svg(path)?;
    }
    let reason = plan.reason.as_deref().unwrap_or("no reason");
    match plan.status {
        Status::Reached => Ok(()),
        Status::Impossible => Err(Failure::Unsolved(format!("sideways climb impossible: {reason}"))),
        Status::Stopped => {
            Err(Failure::Unsolved(format!("sideways climb stopped: {reason}; raise --time-limit to go further")))
        }
    }
}

/// `leech scenario list`: each built-in scenario's name and what it is.
pub fn scenarios(out: &mut String, as_json: bool) -> Result<(), Failure> {
    if as_json {
        let list: Vec<_> = Scenario::listed().map(|(name, d)| json!({ "name": name, "description": d })).collect();
        return json(out, &json!({ "scenarios": list }));
    }
    text::scenarios(out);
    Ok(())
}

/// `leech scenario show`: the file's text, or its JSON form.
pub fn scenario(out: &mut String, scenario: &Scenario, text: &str, as_json: bool) -> Result<(), Failure> {
    if !as_json {
        out.push_str(text);
        return Ok(());
    }
    let start = scenario.start;
    json(
        out,
        &json!({
            "name": scenario.name,
            "description": scenario.description,
            "scene": SceneReport::from(&scenario.scene),
            "start": { "rear_cup_m": start.centre_m, "heading_deg": start.direction_rad.to_degrees() },
            "goal": { "point_m": scenario.goal.point_m, "tolerance_m": scenario.goal.tolerance_m },
        }),
    )
}

/// One figure of `leech figure`: its picture and table in `dir`.
pub fn figure(out: &mut String, dir: &Path, output: &Output) -> Result<(), Failure> {
    let (svg, csv) = (dir.join(format!("{}.svg", output.name)), dir.join(format!("{}.csv", output.name)));
    output.figure.write_svg(&svg)?;
    files::csv_table(&csv, &output.table)?;
    text::wrote(out, &svg, &csv);
    Ok(())
}

/// `leech workspace`: every point to CSV, the endpoints to SVG, the summaries printed.
pub fn workspace(out: &mut String, a: &Workspace, sweep: &Sweep, elapsed_s: f64) -> Result<(), Failure> {
    files::csv_rows(&a.csv, sweep.points.iter().map(SweepRow::from))?;
    if let Some(svg) = &a.outputs.svg {
        let title = format!("{}: endpoints over LA, LB in {}", a.robot.name, a.range);
        leech_plot::figures::sweep_figure(&title, sweep).write_svg(svg)?;
    }
    let failures: usize = sweep.summaries.iter().map(|s| s.failures.len()).sum();
    if a.outputs.json {
        let summary = json!({
            "points": sweep.points.len(),
            "failures": failures,
            "elapsed_s": elapsed_s,
            "summaries": sweep.summaries,
        });
        return json(out, &summary);
    }
    text::workspace(out, sweep, failures, elapsed_s, &a.csv);
    Ok(())
}

pub fn reach(out: &mut String, answer: &Reach, as_json: bool) -> Result<(), Failure> {
    if as_json {
        return json(out, answer);
    }
    text::reach(out, answer);
    Ok(())
}

/// `leech calibrate`: the fitted robot file, its picture, the fit printed.
pub fn calibration(out: &mut String, a: &Calibrate, result: &Calibration, fitted: &Robot) -> Result<(), Failure> {
    files::fitted_robot(a, result, fitted)?;
    if let Some(svg) = &a.outputs.svg {
        let title =
            format!("Fit: k = {:.4} N m/rad, RMS {:.2} mm", result.stiffness_nm_per_rad, result.rms_residual_mm);
        let shapes = a.shapes.as_ref().map_or(&[][..], |s| &s.rows);
        leech_plot::shape::calibration_figure(&title, fitted, &a.sag.rows, shapes).write_svg(svg)?;
    }
    if a.outputs.json {
        return json(out, result);
    }
    text::calibration(out, result, &a.out);
    Ok(())
}

pub fn comparison(out: &mut String, rows: &[ShapeComparison], as_json: bool) -> Result<(), Failure> {
    if as_json {
        return json(out, &json!({ "shapes": rows }));
    }
    text::comparison(out, rows);
    Ok(())
}

/// `leech simulate`: the series to CSV, the animation to SVG, a summary printed.
pub fn simulation(out: &mut String, a: &Simulate, result: &Simulation, wall_s: f64) -> Result<(), Failure> {
    if let Some(path) = &a.outputs.csv {
        files::csv_rows(path, result.samples.iter().map(SampleRow::from))?;
    }
    if let Some(path) = &a.outputs.svg {
        files::animation(path, a.lengths, &a.actuation, &result.samples)?;
    }
    let last = result.samples.last().expect("a simulation records its start");
    let real_time_factor = last.time_s / wall_s.max(1e-12);
    if !a.outputs.json {
        text::simulation(out, result, real_time_factor);
        return Ok(());
    }
    json(
        out,
        &json!({
            "integrator": a.options.integrator,
            "dt_s": result.dt,
            "steps": result.steps,
            "simulated_s": last.time_s,
            "wall_s": wall_s,
            "real_time_factor": real_time_factor,
            "time_to_rest_s": result.time_to_rest,
            "max_constraint_violation": result.max_violation,
            "max_energy_gain_j": result.max_energy_gain_j,
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
        }),
    )
}
