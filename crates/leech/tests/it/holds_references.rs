//! Holds and contacts against independent references: `validation/holds_references.py`
//! writes the model again from its equations (floating driving unit, weld, holds, frictionless
//! contacts) and solves it with SciPy (`trust-constr`, then SLSQP and Newton on the active set);
//! the results are committed as `tests/data/holds.json`.
//!
//! Every case is solved by leech the ordinary way (`stance::solve`, or `stance::solve_in` with
//! the case's scene; a single tube's case, `kind: "chain"`, with `stance::tube_in`) and must
//! match: angles to 1e-7 rad, positions to 1e-7 m, reactions and contact forces to 1e-6 N
//! (N m), and balance the weight to 1e-9. A case leech does not solve
//! or does not match is marked `known_failure` in the fixture: the test then checks that it still
//! fails the same way, so that a fix shows up here (remove the mark then).

use std::collections::BTreeMap;

use leech::cantilever::CantileverSpec;
use leech::prelude::*;
use leech::scene::Scene;
use leech::stance::{self, Held, Hold, Pose, StanceError, TubeHeld};
use serde_json::Value;

const ANGLE_TOLERANCE_RAD: f64 = 1e-7;
const POSITION_TOLERANCE_M: f64 = 1e-7;
const FORCE_TOLERANCE_N: f64 = 1e-6;
const BALANCE_TOLERANCE: f64 = 1e-9;

fn fixture() -> Value {
    let path = format!("{}/tests/data/holds.json", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).expect("fixture is JSON")
}

pub(crate) fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

pub(crate) fn numbers(v: &Value) -> Vec<f64> {
    v.as_array().unwrap_or_else(|| panic!("not a list: {v}")).iter().map(num).collect()
}

pub(crate) fn pair(v: &Value) -> [f64; 2] {
    let x = numbers(v);
    assert_eq!(x.len(), 2, "{v}");
    [x[0], x[1]]
}

fn pose(v: &Value) -> Option<Pose> {
    (!v.is_null()).then(|| Pose { point_m: pair(&v["point_m"]), angle_rad: num(&v["angle_rad"]) })
}

pub(crate) fn hold(case: &Value) -> Hold {
    match (pose(&case["rear"]), pose(&case["front"])) {
        (Some(rear), None) => Hold::Rear(rear),
        (None, Some(front)) => Hold::Front(front),
        (Some(rear), Some(front)) => Hold::Both { rear, front },
        (None, None) => panic!("{}: no hold", case["name"]),
    }
}

pub(crate) fn discretization(case: &Value) -> Discretization {
    match case["discretization"].as_str() {
        Some("paper") => Discretization::Paper,
        Some("midpoint") => Discretization::Midpoint,
        other => panic!("{}: discretization {other:?}", case["name"]),
    }
}

/// The robot the fixture was made for: the built-in one with the cup
/// offsets the fixture records (they place its scenes' cup faces; the
/// built-in estimates may move on), in the case's discretization.
fn robot(case: &Value) -> Robot {
    let doc = fixture();
    let builtin = Robot::builtin();
    let cup = leech::cup::Cup {
        rear_offset_m: num(&doc["robot"]["rear_offset"]),
        front_offset_m: num(&doc["robot"]["front_offset"]),
        ..builtin.cup.clone()
    };
    builtin.with_cup(cup).expect("the fixture's cup offsets are valid").with_discretization(discretization(case))
}

fn scene(case: &Value) -> Option<Scene> {
    let name = case["name"].as_str().unwrap();
    case["scene_toml"].as_str().map(|text| Scene::from_toml_str(text, name).unwrap_or_else(|e| panic!("{name}: {e}")))
}

fn solve(case: &Value) -> Result<Held, StanceError> {
    let robot = robot(case);
    let lengths = pair(&case["lengths_m"]);
    let solver = Solver::default();
    match scene(case) {
        None => stance::solve(&robot, lengths, hold(case), &solver),
        Some(scene) => stance::solve_in(&robot, lengths, hold(case), &scene, &solver),
    }
}

/// A single tube's case as `leech chain` builds it (clamped at the origin), and its radius (m).
fn tube_spec(case: &Value) -> (CantileverSpec, f64) {
    let t = &case["tube"];
    let clamp = &case["clamp"];
    assert_eq!(pair(&clamp["point_m"]), [0.0, 0.0], "{}: tube_in clamps at the origin", case["name"]);
    let spec = CantileverSpec {
        elements: t["elements"].as_u64().unwrap() as usize,
        element_length_m: num(&t["element_length_m"]),
        element_mass_kg: num(&t["element_mass_kg"]),
        joint_stiffness_nm_per_rad: num(&t["joint_stiffness_nm_per_rad"]),
        tip_mass_kg: num(&t["tip_mass_kg"]),
        base_angle_deg: num(&clamp["base_angle_deg"]),
        gravity_m_per_s2: num(&t["gravity_m_per_s2"]),
        discretization: discretization(case),
    };
    (spec, num(&t["radius_m"]))
}

fn solve_tube(case: &Value) -> Result<TubeHeld, StanceError> {
    let (spec, radius) = tube_spec(case);
    let scene = scene(case).unwrap_or_else(|| panic!("{}: a single tube's case has a scene", case["name"]));
    stance::tube_in(&spec, &scene, radius, &Solver::default())
}

/// The comparison of one case: what differs beyond its tolerance (one line each), and the
/// largest difference of each kind.
#[derive(Default)]
pub(crate) struct Comparison {
    pub(crate) failures: Vec<String>,
    pub(crate) largest: BTreeMap<&'static str, f64>,
}

impl Comparison {
    /// Compares `ours` with `theirs` entry by entry: `kind` is "rad", "m" or "N".
    fn close(&mut self, what: &str, kind: &'static str, ours: &[f64], theirs: &[f64], tolerance: f64) {
        if ours.len() != theirs.len() {
            self.failures.push(format!("{what}: {} values, reference {}", ours.len(), theirs.len()));
            return;
        }
        let (i, diff) = ours.iter().zip(theirs).map(|(a, b)| (a - b).abs()).enumerate().fold((0, 0.0), |m, (i, d)| {
            if d > m.1 || d.is_nan() {
                (i, d)
            } else {
                m
            }
        });
        let largest = self.largest.entry(kind).or_insert(0.0);
        *largest = largest.max(diff);
        if !(diff <= tolerance) {
            self.failures.push(format!(
                "{what}[{i}]: leech {} vs reference {} (max diff {diff:.3e} > {tolerance:e})",
                ours[i], theirs[i]
            ));
        }
    }
}

/// Everything that differs beyond its tolerance, one line each (empty: leech matches).
pub(crate) fn differences(case: &Value, held: &Held) -> Comparison {
    let mut out = Comparison::default();
    let q = &held.equilibrium.q;
    let na = held.body.chain_a().len();
    let nb = held.body.chain_b().len();
    out.close("angles A (rad)", "rad", &q[..na], &numbers(&case["angles_a_rad"]), ANGLE_TOLERANCE_RAD);
    out.close("angles B (rad)", "rad", &q[na..na + nb], &numbers(&case["angles_b_rad"]), ANGLE_TOLERANCE_RAD);
    out.close("unit point (m)", "m", &held.unit.point_m, &numbers(&case["unit_point_m"]), POSITION_TOLERANCE_M);
    out.close("unit angle (rad)", "rad", &[held.unit.angle_rad], &[num(&case["unit_angle_rad"])], ANGLE_TOLERANCE_RAD);
    out.close("endpoint (m)", "m", &held.endpoint_m, &numbers(&case["endpoint_m"]), POSITION_TOLERANCE_M);
    let plate = held.body.endpoint_angle(q);
    out.close("plate angle (rad)", "rad", &[plate], &[num(&case["plate_angle_rad"])], ANGLE_TOLERANCE_RAD);
    let weight = num(&case["weight_n"]);
    out.close("weight (N)", "weight N", &[held.weight_n], &[weight], 1e-12 * weight);
    // A contact on the last link of either chain (the nodes a front hold fixes) cannot be told
    // from the front hold's reaction: the reference leaves those rows out, so add leech's forces
    // there to its front reaction (force, and moment about the endpoint).
    let fixed: Vec<(String, u64)> = case["fixed_nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| (v[0].as_str().unwrap().to_string(), v[1].as_u64().unwrap()))
        .collect();
    let is_fixed = |c: &stance::ContactForce| fixed.contains(&(c.chain.to_string(), c.node as u64));
    let mut front = held.front;
    for c in held.contacts.iter().filter(|c| is_fixed(c)) {
        let r = front.as_mut().expect("fixed nodes only with a front hold");
        let f = [c.force_n * c.normal[0], c.force_n * c.normal[1]];
        let arm = [c.point_m[0] - held.endpoint_m[0], c.point_m[1] - held.endpoint_m[1]];
        r.force_n[0] += f[0];
        r.force_n[1] += f[1];
        r.moment_nm += arm[0] * f[1] - arm[1] * f[0];
    }
    for (key, ours) in [("rear_reaction", &held.rear), ("front_reaction", &front)] {
        match (ours, case[key].is_null()) {
            (Some(r), false) => {
                let theirs = [numbers(&case[key]["force_n"]), vec![num(&case[key]["moment_nm"])]].concat();
                let ours = [r.force_n[0], r.force_n[1], r.moment_nm];
                out.close(&format!("{key} (N, N, N m)"), "N", &ours, &theirs, FORCE_TOLERANCE_N);
            }
            (None, true) => {}
            _ => out.failures.push(format!("{key}: leech {ours:?}, reference {}", case[key])),
        }
    }
    compare_contacts(&mut out, held.contacts.iter().filter(|c| !is_fixed(c)), case);
    if !held.equilibrium.stable {
        out.failures.push("leech's equilibrium is not stable".into());
    }
    out
}

/// Contacts: the force vectors summed per touching point (chain, node, fraction), a point
/// missing on one side counting as no force; the points where both push must coincide. (A
/// single tube's contacts have no chain: "" on both sides.)
fn compare_contacts<'c>(out: &mut Comparison, ours: impl Iterator<Item = &'c stance::ContactForce>, case: &Value) {
    let key = |chain: &str, node: u64, fraction: f64| (chain.to_string(), node, (fraction * 1e6).round() as i64);
    let mut forces: BTreeMap<_, ([f64; 2], [f64; 2], Option<[f64; 2]>, Option<[f64; 2]>)> = BTreeMap::new();
    for c in ours {
        let e = forces.entry(key(c.chain, c.node as u64, c.fraction)).or_default();
        e.0[0] += c.force_n * c.normal[0];
        e.0[1] += c.force_n * c.normal[1];
        e.2 = Some(c.point_m);
    }
    for c in case["contacts"].as_array().unwrap() {
        let f = num(&c["force_n"]);
        let n = pair(&c["normal"]);
        let chain = c["chain"].as_str().unwrap_or("");
        let e = forces.entry(key(chain, c["node"].as_u64().unwrap(), num(&c["fraction"]))).or_default();
        e.1[0] += f * n[0];
        e.1[1] += f * n[1];
        e.3 = Some(pair(&c["point_m"]));
    }
    for ((chain, node, fraction), (ours, theirs, at_ours, at_theirs)) in &forces {
        let name = format!("contact force on {chain} node {node} (+{:.6}) (N)", *fraction as f64 * 1e-6);
        out.close(&name, "N", ours, theirs, FORCE_TOLERANCE_N);
        if let (Some(a), Some(b)) = (at_ours, at_theirs) {
            out.close(&format!("contact point on {chain} node {node} (m)"), "m", a, b, POSITION_TOLERANCE_M);
        }
    }
}

/// A single tube's case: everything that differs beyond its tolerance.
fn tube_differences(case: &Value, held: &TubeHeld) -> Comparison {
    let mut out = Comparison::default();
    out.close("angles (rad)", "rad", &held.equilibrium.q, &numbers(&case["angles_rad"]), ANGLE_TOLERANCE_RAD);
    let flat = |points: &[[f64; 2]]| points.iter().flatten().copied().collect::<Vec<f64>>();
    let theirs: Vec<[f64; 2]> = case["points_m"].as_array().unwrap().iter().map(pair).collect();
    out.close("points (m)", "m", &flat(&held.points_m), &flat(&theirs), POSITION_TOLERANCE_M);
    let weight = num(&case["weight_n"]);
    out.close("weight (N)", "weight N", &[held.weight_n], &[weight], 1e-12 * weight);
    let clamp = &case["clamp_reaction"];
    let theirs = [numbers(&clamp["force_n"]), vec![num(&clamp["moment_nm"])]].concat();
    let ours = [held.clamp.force_n[0], held.clamp.force_n[1], held.clamp.moment_nm];
    out.close("clamp reaction (N, N, N m)", "N", &ours, &theirs, FORCE_TOLERANCE_N);
    compare_contacts(&mut out, held.contacts.iter(), case);
    if !held.equilibrium.stable {
        out.failures.push("leech's equilibrium is not stable".into());
    }
    if held.penetration_m > 1e-9 {
        out.failures.push(format!("leech's tube penetrates the scene by {:e} m", held.penetration_m));
    }
    out
}

/// Force balance of leech's clamp reaction and contact forces against the tube's weight, and
/// its moment balance about the clamp (`TubeHeld::moment_about_clamp`, over weight x length).
fn tube_balance(held: &TubeHeld) -> Result<(), String> {
    let w = held.weight_n;
    let mut force = held.clamp.force_n;
    for c in &held.contacts {
        force[0] += c.force_n * c.normal[0];
        force[1] += c.force_n * c.normal[1];
    }
    let moment = held.moment_about_clamp();
    let length = held.tube.chain().tube_length();
    if force[0].abs() <= BALANCE_TOLERANCE * w
        && (force[1] - w).abs() <= BALANCE_TOLERANCE * w
        && moment.abs() <= BALANCE_TOLERANCE * w * length
    {
        Ok(())
    } else {
        Err(format!("force {force:?} vs weight {w}, moment about the clamp {moment}"))
    }
}

/// Solves one case with leech and compares: what differs (joined), or an error.
fn outcome(case: &Value) -> Result<(), String> {
    let name = case["name"].as_str().unwrap();
    let mut comparison = if case["kind"].as_str() == Some("chain") {
        let held = solve_tube(case).map_err(|e| format!("error: {e}"))?;
        let mut comparison = tube_differences(case, &held);
        if let Err(e) = tube_balance(&held) {
            comparison.failures.push(format!("balance: {e}"));
        }
        comparison
    } else {
        let held = solve(case).map_err(|e| format!("error: {e}"))?;
        let mut comparison = differences(case, &held);
        if let Err(e) = balance(&held) {
            comparison.failures.push(format!("balance: {e}"));
        }
        comparison
    };
    // Shown with --nocapture: how close each case is.
    let largest: Vec<String> = comparison.largest.iter().map(|(k, v)| format!("{k} {v:.1e}")).collect();
    println!("{name}: largest differences {}", largest.join(", "));
    if comparison.failures.is_empty() {
        Ok(())
    } else {
        Err(std::mem::take(&mut comparison.failures).join("; "))
    }
}

/// Force and moment balance of leech's reactions and contact forces against the weight.
pub(crate) fn balance(held: &Held) -> Result<(), String> {
    let w = held.weight_n;
    let stance::Reaction { force_n: force, moment_nm: moment } = held.support();
    let gravity = held.centre_of_mass[0] * w;
    let ok = force[0].abs() <= BALANCE_TOLERANCE * w
        && (force[1] - w).abs() <= BALANCE_TOLERANCE * w
        && (moment - gravity).abs() <= BALANCE_TOLERANCE * w * 0.3;
    if ok {
        Ok(())
    } else {
        Err(format!("force {force:?} vs weight {w}, moment {moment} vs {gravity}"))
    }
}

/// The reference is sound: converged, stable, balanced, clear of the solids, and its two
/// polishing methods agree.
fn check_reference(case: &Value) {
    let name = reference_converged(case);
    if !case["penetration_m"].is_null() {
        assert!(num(&case["penetration_m"]) < 1e-12, "{name}: reference penetrates");
    }
    let slsqp = &case["agreement"]["slsqp_vs_newton"];
    assert!(num(&slsqp["q"]) < 1e-6 && num(&slsqp["multipliers"]) < 1e-5, "{name}: SLSQP vs Newton {slsqp}");
    for c in case["contacts"].as_array().unwrap() {
        assert!(num(&c["force_n"]) > 0.0, "{name}: {c}");
    }
    // Where a second path (feeding the tubes) was followed, it ends on the same equilibrium.
    if !case["feeding_path"].is_null() {
        assert!(num(&case["feeding_path"]["max_abs_diff_q"]) < 1e-9, "{name}: feeding path");
    }
}

/// Asserts that a reference case's Newton converged (every KKT residual
/// below 1e-12), to a stable point that balances the weight; returns its name.
pub(crate) fn reference_converged(case: &Value) -> &str {
    let name = case["name"].as_str().unwrap();
    let newton = &case["residuals"]["newton"];
    for key in ["stationarity", "equality", "violation", "complementarity", "negative_force"] {
        assert!(num(&newton[key]) < 1e-12, "{name}: reference Newton {key} {}", newton[key]);
    }
    assert!(case["stable"].as_bool().unwrap() && num(&case["reduced_hessian_min"]) > 0.0, "{name}");
    for key in ["force_x_rel", "force_y_rel", "moment_rel"] {
        assert!(num(&case["balance"][key]) < 1e-12, "{name}: reference balance {key}");
    }
    name
}

/// Asserts that the fixture's `robot` record holds the built-in robot's
/// tube and body parameters, and the `extra` keys with their values.
pub(crate) fn same_builtin_body(r: &Value, extra: &[(&str, f64)]) {
    let builtin = Robot::builtin();
    let body = [
        ("l", builtin.tube.element_length_m),
        ("m", builtin.tube.element_mass_kg),
        ("k", builtin.tube.joint_stiffness_nm_per_rad),
        ("r", 0.5 * builtin.tube.outer_diameter_m),
        ("b", builtin.body.base_spacing_m),
        ("c", builtin.body.tip_spacing_m),
        ("ms", builtin.body.payload_kg),
        ("g", builtin.world.gravity_m_per_s2),
        ("Md", builtin.driving_unit.mass_kg),
        ("full", builtin.tube.full_length_m.expect("the built-in robot gives its tubes' whole length")),
    ];
    for (key, ours) in body.iter().chain(extra) {
        assert_eq!(num(&r[key]), *ours, "built-in robot's {key} changed: regenerate the fixture");
    }
}

#[test]
fn holds_and_contacts_match_the_scipy_references() {
    let doc = fixture();
    // The fixture was made for the built-in robot (but for its cup offsets: `robot`).
    same_builtin_body(&doc["robot"], &[]);
    let cases = doc["cases"].as_array().unwrap();
    assert!(cases.len() >= 8, "at least eight cases");
    assert!(cases.iter().filter(|c| !c["scene_toml"].is_null()).count() >= 4, "contact cases");
    assert!(cases.iter().filter(|c| c["kind"].as_str() == Some("chain")).count() >= 2, "single-tube cases");
    let mut report = Vec::new();
    for case in cases {
        let name = case["name"].as_str().unwrap();
        check_reference(case);
        match (case["known_failure"].as_str(), outcome(case)) {
            (None, Ok(())) => {}
            (None, Err(e)) => report.push(format!("{name}: {e}")),
            (Some(known), Ok(())) => report.push(format!(
                "{name}: marked known_failure ({known}) but leech now matches the reference: remove the mark"
            )),
            (Some(known), Err(e)) => {
                println!("{name}: known failure, still failing: {e}");
                // Still failing: the same way?
                let patterns = case["known_failure_contains"].as_array().expect("known_failure_contains");
                for p in patterns {
                    let p = p.as_str().unwrap();
                    if !e.contains(p) {
                        report.push(format!("{name}: fails differently from its mark ({known}): {e}"));
                        break;
                    }
                }
            }
        }
    }
    assert!(report.is_empty(), "\n{}", report.join("\n"));
}
