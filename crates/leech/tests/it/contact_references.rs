//! The body fed against a surface ahead, against independent references:
//! `validation/contact_references.py` follows the robot's own path (rear cup on a floor, both
//! tubes fed from the shortest length at full gravity, each step warm from the last) with two
//! methods that share no solver code (trust-constr and Newton on the active set; SLSQP) and stores
//! the Newton-polished state where they agree, as `tests/data/contact.json`.
//!
//! Every case is solved by leech the same way, `stance::solve_among` with the case's scene and
//! free cups (`FreeCups::PassThrough`, or `Rest`: the free front cup's face rests on the solids),
//! and must match: angles to 1e-7 rad, positions to 1e-7 m, the rear reaction and every contact
//! force to 1e-6 N (N m), and leech's own holds and contacts must balance the weight to 1e-9.
//! The comparison is `holds_references`' (the same schema). No case is marked as a known
//! failure: each must match.

use leech::prelude::*;
use leech::scene::Scene;
use leech::stance::{self, FreeCups, Held, StanceError};
use serde_json::Value;

use crate::holds_references::{balance, differences, discretization, hold, num, pair, same_builtin_body, Comparison};

/// The fixture `tests/data/{name}`.
pub(crate) fn fixture(name: &str) -> Value {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).expect("fixture is JSON")
}

/// The fixture's robot is the built-in one, cups and limits included, and
/// `extra` besides.
pub(crate) fn made_for_the_builtin(doc: &Value, extra: &[(&str, f64)]) {
    let builtin = Robot::builtin();
    let cup = &builtin.cup;
    let mut keys = vec![
        ("rear_offset", cup.rear_offset_m),
        ("front_offset", cup.front_offset_m),
        ("cup_diameter", cup.diameter_m),
        ("tube_length_min", builtin.limits.tube_length_min_m),
    ];
    keys.extend_from_slice(extra);
    same_builtin_body(&doc["robot"], &keys);
}

fn free_cups(case: &Value) -> FreeCups {
    match case["free_cups"].as_str() {
        Some("pass_through") => FreeCups::PassThrough,
        Some("rest") => FreeCups::Rest,
        other => panic!("{}: free_cups {other:?}", case["name"]),
    }
}

/// The case solved as `leech shape --scene ... --rear X,Y,DEG [--free-cups rest]` does.
pub(crate) fn solve(case: &Value) -> Result<Held, StanceError> {
    let name = case["name"].as_str().unwrap();
    let robot = Robot::builtin().with_discretization(discretization(case));
    let text = case["scene_toml"].as_str().unwrap_or_else(|| panic!("{name}: no scene"));
    let scene = Scene::from_toml_str(text, name).unwrap_or_else(|e| panic!("{name}: {e}"));
    let lengths = pair(&case["lengths_m"]);
    stance::solve_among(&robot, lengths, hold(case), &scene, &Solver::default(), free_cups(case))
}

/// The reference is sound: Newton converged, stable, balanced, clear of the solids, the forces
/// push, and SLSQP along its own path agrees.
pub(crate) fn check_reference(case: &Value) {
    let name = super::holds_references::reference_converged(case);
    assert!(num(&case["penetration_m"]) < 1e-12, "{name}: reference penetrates");
    let slsqp = &case["agreement"]["slsqp_vs_newton"];
    let weight = num(&case["weight_n"]);
    assert!(num(&slsqp["q"]) < 1e-7, "{name}: SLSQP vs Newton {slsqp}");
    for key in ["hold_multipliers", "contact_forces"] {
        assert!(num(&slsqp[key]) < 1e-7 * weight, "{name}: SLSQP vs Newton {slsqp}");
    }
    let contacts = case["contacts"].as_array().unwrap();
    assert!(!contacts.is_empty(), "{name}: a contact case without contacts");
    for c in contacts {
        assert!(num(&c["force_n"]) > 0.0, "{name}: {c}");
    }
    assert_eq!(case["hold"], "rear", "{name}");
}

/// Solves one case with leech and compares: the held body, or what differs (joined) or the error.
pub(crate) fn outcome(case: &Value) -> Result<Held, String> {
    let name = case["name"].as_str().unwrap();
    let held = solve(case).map_err(|e| format!("error: {e}"))?;
    let mut comparison: Comparison = differences(case, &held);
    if let Err(e) = balance(&held) {
        comparison.failures.push(format!("balance: {e}"));
    }
    // Shown with --nocapture: how close each case is.
    let largest: Vec<String> = comparison.largest.iter().map(|(k, v)| format!("{k} {v:.1e}")).collect();
    println!("{name}: largest differences {}", largest.join(", "));
    if comparison.failures.is_empty() {
        Ok(held)
    } else {
        Err(comparison.failures.join("; "))
    }
}

#[test]
fn bodies_fed_against_walls_and_steps_match_the_scipy_references() {
    let doc = fixture("contact.json");
    made_for_the_builtin(&doc, &[]);
    let cases = doc["cases"].as_array().unwrap();
    assert!(cases.len() >= 12, "at least twelve cases");
    let rest = cases.iter().filter(|c| c["free_cups"] == "rest").count();
    assert!(rest >= 2 && rest < cases.len(), "cases with the free cup resting and passing through");
    let mut report = Vec::new();
    for case in cases {
        let name = case["name"].as_str().unwrap();
        check_reference(case);
        if let Err(e) = outcome(case) {
            report.push(format!("{name}: {e}"));
        }
    }
    assert!(report.is_empty(), "{} of {} cases differ:\n{}", report.len(), cases.len(), report.join("\n"));
}
