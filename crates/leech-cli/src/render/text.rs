//! Text summaries: what each command prints without --json.

use std::fmt::Write as _;
use std::path::Path;

use leech::calibration::{Calibration, ShapeComparison, ShapeError};
use leech::cup::CupMode;
use leech::dynamics::Simulation;
use leech::inverse_statics::{Reach, ReachStatus};
use leech::prelude::*;
use leech::report::{
    Body3Report, BodyReport, CantileverReport, ClimbReport, ConstantCurvatureReport, Solution, SolveTiming,
    StanceReport, TubeInSceneReport,
};
use leech::sweep::{Extreme, Sweep};

/// `writeln!` into a `String`, which cannot fail.
macro_rules! say {
    ($out:expr, $($format:tt)*) => {{
        let _ = writeln!($out, $($format)*);
    }};
}

/// The status lines of a solve.
fn solution(out: &mut String, s: &Solution) {
    let stability = if s.stable { "stable" } else { "UNSTABLE" };
    say!(out, "converged in {} iterations (residual {:.1e}), {stability}", s.iterations, s.residual);
    for event in &s.events {
        match event {
            Event::Snap { stage, at, jump_rad } => say!(
                out,
                "note: the body snapped through a fold on the {stage} path at {:.1} % (largest angle change {jump_rad:.2} rad)",
                at * 100.0
            ),
            Event::Bifurcation { stage, at, side, jump_rad } => say!(
                out,
                "note: the {stage} path crossed a symmetric bifurcation at {:.1} %; the body went to the {side} of the clamp direction (largest angle change {jump_rad:.2} rad)",
                at * 100.0
            ),
        }
    }
}

pub fn chain(out: &mut String, elements: usize, r: &CantileverReport) {
    say!(out, "tube of {elements} elements, {:.4} m, shape parameter Pi = {}", r.length_m, fixed(r.shape_parameter, 4));
    say!(out, "tip at ({:.3}, {:.3}) mm", r.tip_m[0] * 1e3, r.tip_m[1] * 1e3);
    solution(out, &r.solution);
}

/// `leech chain --scene`: the clamp's reaction and each contact.
pub fn tube_in_scene(out: &mut String, r: &TubeInSceneReport) {
    let [fx, fy] = r.clamp_force_n;
    say!(out, "scene {}: clamp force ({fx:.4}, {fy:.4}) N, moment {:.5} N m", r.scene, r.clamp_moment_nm);
    for c in &r.contacts {
        let [x, y] = c.point_m;
        say!(
            out,
            "contact at node {} + {:.3}: ({:.3}, {:.3}) mm, {:.4} N",
            c.node,
            c.fraction,
            x * 1e3,
            y * 1e3,
            c.force_n
        );
    }
    say!(out, "penetration {:.1e} m", r.penetration_m);
}

/// `leech shape`: the two-chain model's report (with its timing) and the
/// constant-curvature model's, for those that ran.
pub fn shape(
    out: &mut String,
    robot: &Robot,
    [la, lb]: [f64; 2],
    two_chain: Option<(&BodyReport, Option<&SolveTiming>)>,
    constant_curvature: Option<&ConstantCurvatureReport>,
) {
    say!(
        out,
        "{}: LA = {la:.4} m, LB = {lb:.4} m (Pi = {})",
        robot.name,
        leech::error::Num::rounded(robot.shape_parameter(), 3)
    );
    if let Some((r, timing)) = two_chain {
        let links = format_args!("{} + {} links", r.links[0], r.links[1]);
        endpoint(out, "two-chain", r.endpoint_m, r.endpoint_angle_rad, links);
        solution(out, &r.solution);
        if let Some(t) = timing {
            say!(
                out,
                "solve time over {} cold solves: median {:.1} us, fastest {:.1} us",
                t.solves,
                t.median * 1e6,
                t.min * 1e6
            );
        }
    }
    if let Some(r) = constant_curvature {
        let bend = format_args!("bend {:.3} rad", r.bend_rad);
        endpoint(out, "constant curvature", r.endpoint_m, r.endpoint_angle_rad, bend);
    }
}

/// `leech shape3d`: the endpoint and the plate's tangent, the solve, the
/// twist, which cups hold and their verdicts (against the robot's `minimum`
/// safety factor), the contacts, and the planar model beside the 3D body.
pub fn shape3d(out: &mut String, r: &Body3Report, minimum: f64) {
    let [l1, l2, l3] = r.lengths_m;
    let free = if r.free_axial_rotation { ", axial rotation free at the driving unit" } else { "" };
    say!(
        out,
        "{}: L1 = {l1:.4} m, L2 = {l2:.4} m, L3 = {l3:.4} m (Pi = {}){free}",
        r.robot,
        fixed(r.shape_parameter, 0)
    );
    let links = r.tubes.iter().map(|t| t.links.to_string()).collect::<Vec<_>>().join(" + ");
    let tangent = r.plate_frame.map(|row| unsigned_zero(row[0], 4));
    say!(
        out,
        "three-tube 3D: endpoint at {}, plate tangent ({:.4}, {:.4}, {:.4}) ({links} links)",
        mm3(r.endpoint_m),
        tangent[0],
        tangent[1],
        tangent[2]
    );
    solution(out, &r.solution);
    say!(out, "largest twist {:.2e} rad", r.max_twist_rad);
    let hold = r.hold.replace('_', " ");
    match r.pivot_turn_rad {
        Some(turn) => say!(out, "{hold} hold: the plate turned {:.4} rad about the front cup's normal", turn),
        None => say!(out, "{hold} hold"),
    }
    for (name, cup) in [("rear", &r.rear_cup), ("front", &r.front_cup)] {
        let Some(c) = cup else { continue };
        let [fx, fy, fz] = c.force_n;
        let [mx, my, mz] = c.moment_nm;
        say!(
            out,
            "{name} cup at {}: force ({fx:.4}, {fy:.4}, {fz:.4}) N, moment ({mx:.5}, {my:.5}, {mz:.5}) N m; {}",
            mm3(c.cup_m),
            cup_verdict(&c.verdict, minimum)
        );
    }
    if let Some(scene) = &r.scene {
        let total: f64 = r.contacts.iter().map(|c| c.force_n).sum();
        say!(out, "scene {scene}: {} contacts, {total:.4} N in all", r.contacts.len());
    }
    match (&r.planar, &r.planar_note) {
        (Some(p), _) => say!(
            out,
            "planar model: endpoint at {}, {:.2e} m from the 3D body's (points up to {:.2e} m apart, {:.2e} m out of its plane){}",
            mm3(p.endpoint_m),
            p.difference.endpoint_m,
            p.difference.max_point_m,
            p.difference.out_of_plane_m,
            if p.stable { "" } else { ", the planar equilibrium UNSTABLE" }
        ),
        (None, Some(note)) => say!(out, "planar model: none ({note})"),
        (None, None) => {}
    }
}

/// A point in 3D, in mm to 3 decimals.
fn mm3(p: [f64; 3]) -> String {
    let [x, y, z] = p.map(|v| unsigned_zero(v * 1e3, 3));
    format!("({x:.3}, {y:.3}, {z:.3}) mm")
}

/// `v` shown to `digits` decimals, 0 where it rounds to 0: `0.000`, not
/// `-0.000`, for the round-off of a symmetric body.
fn unsigned_zero(v: f64, digits: i32) -> f64 {
    if v.abs() < 0.5 * 10f64.powi(-digits) {
        0.0
    } else {
        v
    }
}

/// Where the holds put the driving unit, what each cup carries and whether
/// it holds, and the contacts with the scene.
/// A cup's verdict in words: holds (with its safety factor, below the
/// `minimum` or not) or fails, and what limits it.
fn cup_verdict(v: &leech::cup::CupVerdict, minimum: f64) -> String {
    let mode = match v.limited_by {
        Some(CupMode::Normal) => " (pull-off and peel)",
        Some(CupMode::Shear) => " (sliding)",
        None => "",
    };
    match (v.holds, v.meets_minimum) {
        _ if v.safety_factor.is_infinite() => "holds, unloaded".to_string(),
        (true, true) => format!("holds, safety factor {}{mode}", fixed(v.safety_factor, 2)),
        (true, false) => {
            format!("holds, safety factor {} below the minimum {minimum}{mode}", fixed(v.safety_factor, 2))
        }
        (false, _) => format!("FAILS, safety factor {}{mode}", fixed(v.safety_factor, 2)),
    }
}

pub fn stance(out: &mut String, s: &StanceReport, minimum: f64) {
    let mm = |p: [f64; 2]| format!("({:.3}, {:.3}) mm", p[0] * 1e3, p[1] * 1e3);
    say!(
        out,
        "driving unit at {}, clamp direction {:.3} deg; weight {:.4} N, centre of mass at {}",
        mm(s.driving_unit_m),
        s.driving_unit_angle_rad.to_degrees(),
        s.weight_n,
        mm(s.centre_of_mass_m)
    );
    for (name, hold, cup) in [("rear", &s.holds.rear, s.rear_cup_m), ("front", &s.holds.front, s.front_cup_m)] {
        let Some(h) = hold else {
            say!(out, "{name} cup at {}, free", mm(cup));
            continue;
        };
        let f = h.force_n;
        let verdict = cup_verdict(&h.verdict, minimum);
        say!(
            out,
            "{name} hold: force ({:.4}, {:.4}) N, moment {:.5} N m; cup at {}: {verdict}",
            f[0],
            f[1],
            h.moment_nm,
            mm(h.cup_m)
        );
    }
    if let Some(scene) = &s.scene {
        let total = s.contacts.iter().fold(0.0, |sum, c| sum + c.force_n);
        let (n, plural) = (s.contacts.len(), if s.contacts.len() == 1 { "" } else { "s" });
        say!(
            out,
            "scene {scene}: {n} contact{plural} carrying {total:.4} N in all; deepest penetration {:.1e} m",
            s.penetration_m
        );
    }
}

/// `leech scene list`.
pub fn scenes(out: &mut String) {
    for (name, description) in leech::scene::Scene::builtin_names() {
        say!(out, "{name:<14} {description}");
    }
}

/// `leech shape3d --model constant-curvature`: the arc and the endpoint.
pub fn constant_curvature3(out: &mut String, r: &leech::report::ConstantCurvature3Report) {
    let [l1, l2, l3] = r.lengths_m;
    say!(out, "{}: L1 = {l1:.4} m, L2 = {l2:.4} m, L3 = {l3:.4} m", r.robot);
    let tangent = r.plate_frame.map(|row| unsigned_zero(row[0], 4));
    say!(
        out,
        "constant curvature: endpoint at {}, plate tangent ({:.4}, {:.4}, {:.4}); backbone {:.4} m, bend {:.4} rad \
         towards {:.4} rad, curvature {:.4} 1/m",
        mm3(r.endpoint_m),
        tangent[0],
        tangent[1],
        tangent[2],
        r.backbone_length_m,
        r.bend_rad,
        r.bend_direction_rad,
        r.curvature_per_m
    );
}

/// `leech scenario list`.
pub fn scenarios(out: &mut String) {
    for (name, description) in leech::stride::Scenario::listed() {
        say!(out, "{name:<16} {description}");
    }
}

/// `leech climb` of a sideways scenario: one line per phase's end (the
/// lengths, each holding cup's face centre y, z and safety factor), then the totals.
pub fn sideways(out: &mut String, a: &crate::args::ClimbSideways, plan: &leech::stride::SidewaysPlan) {
    use leech::stride::Status;
    let s = &a.scenario;
    say!(out, "{} ({}): {} m sideways within {} m", s.name, a.robot.name, s.lateral_m, s.tolerance_m);
    say!(out, "stride  phase          L1/L2/L3 (mm)          rear cup y, z (mm)  SF     front cup y, z (mm)  SF");
    let cup = |c: &Option<leech::stance3::CupState3>| match c {
        Some(c) => {
            format!(
                "({:7.1}, {:7.1})  {:>5}",
                c.centre_m[1] * 1e3,
                c.centre_m[2] * 1e3,
                safety_factor(c.verdict.safety_factor)
            )
        }
        None => format!("{:<25}", "-"),
    };
    for step in &plan.steps {
        let [l1, l2, l3] = step.lengths_m.map(|l| l * 1e3);
        say!(
            out,
            "{:>6}  {:<13}  {l1:6.1}/{l2:6.1}/{l3:6.1}  {}  {}",
            step.stride,
            step.phase.name(),
            cup(&step.held.rear),
            cup(&step.held.front)
        );
    }
    say!(
        out,
        "{}: {} strides of {:.4} m, {:.4} m sideways",
        match plan.status {
            Status::Reached => "reached",
            Status::Impossible => "IMPOSSIBLE",
            Status::Stopped => "STOPPED (time limit)",
        },
        plan.strides,
        plan.stride_lateral_m,
        plan.lateral_m
    );
    if let Some(reason) = &plan.reason {
        say!(out, "reason: {reason}");
    }
}

/// A safety factor in a table: two decimals, or powers of ten where a cup
/// carries next to nothing (a loop closed without preload leaves one cup
/// rounding's load).
fn safety_factor(f: f64) -> String {
    if f < 1e3 {
        format!("{f:.2}")
    } else {
        format!("{f:.1e}")
    }
}

/// `leech climb`: one line per phase's end, then the totals (and why an
/// impossible climb is).
pub fn climb(out: &mut String, r: &ClimbReport, elapsed_s: f64) {
    let mm = |p: [f64; 2]| format!("({:7.1}, {:7.1})", p[0] * 1e3, p[1] * 1e3);
    let factor = |f: Option<f64>| f.map_or("-".to_string(), safety_factor);
    say!(out, "{} ({}): to ({:.3}, {:.3}) m within {} m", r.scenario, r.robot, r.goal_m[0], r.goal_m[1], r.tolerance_m);
    for s in &r.steps {
        say!(
            out,
            "stride {:>2} {:<13} LA {:.4} LB {:.4} m  hold {:<5}  unit {} mm  rear cup {} mm  front cup {} mm  \
             safety factor rear {} front {}{}",
            s.stride,
            s.phase,
            s.lengths_m[0],
            s.lengths_m[1],
            s.hold,
            mm(s.driving_unit_m),
            mm(s.rear_cup_m),
            mm(s.front_cup_m),
            factor(s.safety_factor.rear),
            factor(s.safety_factor.front),
            if s.snapped { "  SNAPPED" } else { "" }
        );
    }
    let status = match r.status {
        leech::stride::Status::Reached => "reached",
        leech::stride::Status::Impossible => "IMPOSSIBLE",
        leech::stride::Status::Stopped => "STOPPED",
    };
    say!(
        out,
        "{status} in {} stride{}: tube travel {:.4} m, {:.1} s at {} mm/s, min safety factor {}, {} solves ({elapsed_s:.1} s)",
        r.strides,
        if r.strides == 1 { "" } else { "s" },
        r.tube_travel_m,
        r.duration_s,
        leech::stride::plan::TUBE_SPEED_M_PER_S * 1e3,
        factor(r.min_safety_factor),
        r.solves
    );
    if let Some(reason) = &r.reason {
        say!(out, "reason: {} in the {} phase: {}", reason.blocking.name(), reason.phase.name(), reason.detail);
    }
}

/// A model's endpoint and plate angle, then `detail` in parentheses.
fn endpoint(out: &mut String, model: &str, [x, y]: [f64; 2], angle_rad: f64, detail: std::fmt::Arguments) {
    let angle_deg = angle_rad.to_degrees();
    say!(out, "{model}: endpoint at ({:.3}, {:.3}) mm, plate angle {angle_deg:.3} deg ({detail})", x * 1e3, y * 1e3);
}

/// The files a figure was written to.
pub fn wrote(out: &mut String, svg: &Path, csv: &Path) {
    say!(out, "wrote {} and {}", svg.display(), csv.display());
}

pub fn workspace(out: &mut String, sweep: &Sweep, failures: usize, elapsed_s: f64, csv: &Path) {
    say!(
        out,
        "{} points in {elapsed_s:.2} s, {failures} failures; every point in {}",
        sweep.points.len(),
        csv.display()
    );
    let mm = |e: &Option<Extreme>, k: usize| e.map_or(f64::NAN, |e| e.endpoint_m[k] * 1e3);
    for s in &sweep.summaries {
        let pi = s.shape_parameter.map_or("-".to_string(), |p| format!("{p:.0}"));
        say!(
            out,
            "{:<18} Pi {:>7}: highest y {:7.1} mm, lowest y {:7.1} mm, farthest |x| {:6.1} mm, area {:7.0} mm^2; infeasible {}, unstable {}, snapped {}, failures {}, differ from a fresh solve {} (up to {:.1} mm)",
            s.model.name(), pi, mm(&s.highest, 1), mm(&s.lowest, 1), mm(&s.farthest, 0).abs(), s.area_m2 * 1e6,
            s.infeasible, s.unstable, s.snapped, s.failures.len(), s.differ_from_fresh, s.largest_fresh_difference_m * 1e3
        );
        for f in &s.failures {
            say!(out, "  failed at LA = {} m, LB = {} m: {}", f.lengths_m[0], f.lengths_m[1], f.reason);
        }
    }
}

pub fn reach(out: &mut String, answer: &Reach) {
    let verdict = match answer.status {
        ReachStatus::Reached => "reached",
        ReachStatus::Unreachable => "UNREACHABLE; nearest point found",
    };
    say!(
        out,
        "{verdict}: LA = {:.6} m, LB = {:.6} m, endpoint ({:.4}, {:.4}) mm, error {:.2e} m, plate angle {:.3} deg",
        answer.lengths_m[0],
        answer.lengths_m[1],
        answer.endpoint_m[0] * 1e3,
        answer.endpoint_m[1] * 1e3,
        answer.error_m,
        answer.endpoint_angle_rad.to_degrees()
    );
}

pub fn calibration(out: &mut String, r: &Calibration, fitted_file: &Path) {
    say!(out, "k = {:.6} +- {:.6} N m/rad", r.stiffness_nm_per_rad, r.stiffness_std_error_nm_per_rad);
    if let Some(se) = r.element_mass_std_error_kg {
        say!(out, "m = {:.6e} +- {se:.2e} kg", r.element_mass_kg);
    }
    say!(
        out,
        "Pi = {}; RMS residual {:.3} mm, largest {:.3} mm over {} points ({} iterations); wrote {}",
        fixed(r.shape_parameter, 1),
        r.rms_residual_mm,
        r.max_residual_mm,
        r.points,
        r.iterations,
        fitted_file.display()
    );
}

pub fn comparison(out: &mut String, rows: &[ShapeComparison]) {
    say!(
        out,
        "{:<16} {:>7} {:>7} | {:>27} | {:>27}",
        "shape",
        "LA mm",
        "LB mm",
        "two-chain rms/max/end mm",
        "constant curv. rms/max/end mm"
    );
    let cell = |e: &ShapeError| {
        format!("{:7.2} {:7.2} {:>9}", e.rms_mm, e.max_mm, e.endpoint_mm.map_or("-".into(), |v| format!("{v:.2}")))
    };
    for r in rows {
        say!(
            out,
            "{:<16} {:>7.1} {:>7.1} | {} | {}",
            r.shape,
            r.lengths_m[0] * 1e3,
            r.lengths_m[1] * 1e3,
            cell(&r.two_chain),
            cell(&r.constant_curvature)
        );
    }
}

pub fn simulation(out: &mut String, result: &Simulation, real_time_factor: f64) {
    let last = result.samples.last().expect("a simulation records its start");
    let rest = result.time_to_rest.map_or("not at rest".to_string(), |t| format!("at rest after {t:.3} s"));
    say!(
        out,
        "{:.3} s simulated in {} steps of {:.2e} s ({real_time_factor:.3}x real time); {rest}; largest constraint violation {:.1e}",
        last.time_s,
        result.steps,
        result.dt,
        result.max_violation
    );
    say!(
        out,
        "final endpoint ({:.3}, {:.3}) mm at LA = {:.4} m, LB = {:.4} m",
        last.endpoint_m[0] * 1e3,
        last.endpoint_m[1] * 1e3,
        last.lengths_m[0],
        last.lengths_m[1]
    );
}

/// `x` with `digits` decimals, or as [`leech::error::Num`] prints it where
/// that would run past a dozen digits (a shape parameter of 1e300).
pub(crate) fn fixed(x: f64, digits: usize) -> String {
    if x.is_finite() && x.abs() >= 1e6 {
        leech::error::Num(x).to_string()
    } else {
        format!("{x:.digits$}")
    }
}
