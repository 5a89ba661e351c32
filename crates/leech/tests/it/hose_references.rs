//! The hose's stop against independent references: `validation/hose_references.py` feeds bodies
//! along a floor (contact_references' path and two methods) with the stop written as a one-sided
//! spring in the potential, not as rows, until joints lock; `tests/data/hose.json`.
//!
//! Every case is solved by leech as `leech shape --scene ... --rear X,Y,DEG` does and must match
//! as the contact references do (angles 1e-7 rad, positions 1e-7 m, reactions and contact forces
//! 1e-6 N), its locked joints the reference's, each carrying the same moment to 1e-6 N m, and
//! the external forces must balance the weight to 1e-9 (the hose's moments are internal).

use leech::prelude::*;

use crate::contact_references::{check_reference, fixture, made_for_the_builtin, outcome, solve};
use crate::holds_references::num;

#[test]
fn bodies_locked_at_the_hose_stop_match_the_scipy_references() {
    let doc = fixture("hose.json");
    let builtin = Robot::builtin();
    made_for_the_builtin(
        &doc,
        &[("min_bend_radius", builtin.tube.min_bend_radius_m), ("k_stop", builtin.tube.stop_stiffness())],
    );
    let cases = doc["cases"].as_array().unwrap();
    assert!(cases.len() >= 4, "at least four cases");
    let chain_b = cases.iter().filter(|c| c["hose_stops"].as_array().unwrap().iter().any(|s| s["chain"] == "b"));
    assert!(chain_b.count() >= 1, "a case with joints of chain B locked");
    let mut report = Vec::new();
    for case in cases {
        let name = case["name"].as_str().unwrap();
        check_reference(case);
        let expected = case["hose_stops"].as_array().unwrap();
        assert!(!expected.is_empty(), "{name}: a hose case with no joint locked");
        let held = match outcome(case) {
            Ok(held) => held,
            Err(e) => {
                report.push(format!("{name}: {e}"));
                continue;
            }
        };
        if held.stops.len() != expected.len() {
            report.push(format!("{name}: {} joints locked, the reference {}", held.stops.len(), expected.len()));
            continue;
        }
        for (got, want) in held.stops.iter().zip(expected) {
            let same_joint = got.chain == want["chain"].as_str().unwrap()
                && got.joint as u64 == want["joint"].as_u64().unwrap()
                && got.sign == num(&want["sign"]);
            let moment = (got.moment_nm - num(&want["moment_nm"])).abs();
            let at = want["point_m"].as_array().unwrap();
            let point = (0..2).map(|i| (got.point_m[i] - num(&at[i])).abs()).fold(0.0, f64::max);
            if !same_joint || moment > 1e-6 || point > 1e-7 {
                report.push(format!("{name}: locked {got:?}, the reference {want}"));
            }
            assert!(got.moment_nm > 0.0, "{name}: {got:?}");
        }
    }
    assert!(report.is_empty(), "{} of {} cases differ:\n{}", report.len(), cases.len(), report.join("\n"));
}

/// The stop is what shapes these bodies: without it (a radius of 0) the same lengths bend their
/// tubes tighter than the hose allows, and leech locks nothing.
#[test]
fn without_the_stop_the_reference_bodies_bend_past_it() {
    let doc = fixture("hose.json");
    let case = &doc["cases"][0];
    let free =
        Robot { tube: leech::robot::Tube { min_bend_radius_m: 0.0, ..Robot::builtin().tube }, ..Robot::builtin() };
    let locked = solve(case).unwrap();
    let scene = leech::scene::Scene::from_toml_str(case["scene_toml"].as_str().unwrap(), "floor").unwrap();
    let hold = crate::holds_references::hold(case);
    let lengths = crate::holds_references::pair(&case["lengths_m"]);
    let bent = leech::stance::solve_among(
        &free,
        lengths,
        hold,
        &scene,
        &Solver::default(),
        leech::stance::FreeCups::PassThrough,
    )
    .unwrap();
    let radius = Robot::builtin().tube.min_bend_radius_m;
    assert!(bent.stops.is_empty() && bent.min_bend_radius() < 0.99 * radius, "{}", bent.min_bend_radius());
    assert!(!locked.stops.is_empty() && locked.min_bend_radius() > 0.99 * radius, "{}", locked.min_bend_radius());
    assert!(locked.within_stop(&Robot::builtin()) && !bent.within_stop(&Robot::builtin()));
}
