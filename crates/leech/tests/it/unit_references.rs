//! The driving unit's outline against independent references: `validation/unit_references.py`
//! hangs the body from a front hold on a wall, the driving unit below it, over a ledge that
//! catches the unit's outline (a corner on the ledge's top, the ledge's corner on an edge), with
//! the unit's rigid geometry written from docs/model.md section 7.3.3; `tests/data/unit.json`.
//!
//! Every case is solved by leech as `leech shape --hold front --front X,Y,DEG --scene ...
//! --free-cups rest` does and must match as the holds references do (angles 1e-7 rad, positions
//! 1e-7 m, the front reaction and every contact force 1e-6 N, the outline's rows among them), and
//! leech's own holds and contacts must balance the weight to 1e-9.

use leech::prelude::*;
use leech::scene::Scene;
use leech::stance::{self, FreeCups, Held, StanceError};
use serde_json::Value;

use crate::contact_references::fixture;
use crate::holds_references::{
    balance, differences, discretization, hold, num, pair, reference_converged, same_builtin_body,
};

/// The case solved as `leech shape --hold front ... --free-cups rest` does.
fn solve(case: &Value) -> Result<Held, StanceError> {
    let name = case["name"].as_str().unwrap();
    let robot = Robot::builtin().with_discretization(discretization(case));
    let scene =
        Scene::from_toml_str(case["scene_toml"].as_str().unwrap(), name).unwrap_or_else(|e| panic!("{name}: {e}"));
    stance::solve_among(&robot, pair(&case["lengths_m"]), hold(case), &scene, &Solver::default(), FreeCups::Rest)
}

#[test]
fn a_hanging_unit_caught_by_its_outline_matches_the_scipy_references() {
    let doc = fixture("unit.json");
    let builtin = Robot::builtin();
    let unit = &builtin.driving_unit;
    same_builtin_body(
        &doc["robot"],
        &[
            ("rear_offset", builtin.cup.rear_offset_m),
            ("front_offset", builtin.cup.front_offset_m),
            ("cup_diameter", builtin.cup.diameter_m),
            ("min_bend_radius", builtin.tube.min_bend_radius_m),
            ("unit_length", unit.length_m),
            ("unit_height", unit.height_m),
            ("unit_back", unit.back_m),
            ("unit_top", unit.top_m),
            ("rear_cup_behind", unit.rear_cup_behind_m),
        ],
    );
    assert!(unit.centre_of_mass_m.is_none(), "the references put the unit's mass at the clamps' midpoint");
    let cases = doc["cases"].as_array().unwrap();
    assert!(cases.len() >= 2, "at least two cases");
    let mut kinds = Vec::new();
    let mut report = Vec::new();
    for case in cases {
        let name = reference_converged(case);
        assert!(num(&case["penetration_m"]) < 1e-12, "{name}: reference penetrates");
        assert!(num(&case["agreement"]["slsqp_vs_newton"]["q"]) < 1e-7, "{name}: SLSQP vs Newton");
        let on_unit: Vec<&Value> =
            case["contacts"].as_array().unwrap().iter().filter(|c| c["chain"] == "unit").collect();
        assert!(!on_unit.is_empty(), "{name}: the outline carries nothing");
        kinds.extend(on_unit.iter().map(|c| num(&c["fraction"]) > 0.0));
        let held = match solve(case) {
            Ok(held) => held,
            Err(e) => {
                report.push(format!("{name}: error: {e}"));
                continue;
            }
        };
        let mut comparison = differences(case, &held);
        // Shown with --nocapture: how close each case is.
        let largest: Vec<String> = comparison.largest.iter().map(|(k, v)| format!("{k} {v:.1e}")).collect();
        println!("{name}: largest differences {}", largest.join(", "));
        if let Err(e) = balance(&held) {
            comparison.failures.push(format!("balance: {e}"));
        }
        if !held.contacts.iter().any(|c| c.chain == "unit") {
            comparison.failures.push("leech's outline carries nothing".into());
        }
        if !comparison.failures.is_empty() {
            report.push(format!("{name}: {}", comparison.failures.join("; ")));
        }
    }
    assert!(kinds.contains(&true) && kinds.contains(&false), "a corner of the outline and an edge of it touch");
    assert!(report.is_empty(), "{} of {} cases differ:\n{}", report.len(), cases.len(), report.join("\n"));
}

/// Without its outline (a point mass at the same place) the unit resting on the ledge's top
/// hangs through the ledge: the outline is what holds it.
#[test]
fn without_its_outline_the_unit_hangs_through_the_ledge() {
    let doc = fixture("unit.json");
    let case = doc["cases"].as_array().unwrap().iter().find(|c| c["name"] == "unit_on_ledge_top").unwrap();
    let mut robot = Robot::builtin();
    robot.driving_unit.length_m = 0.0;
    robot.driving_unit.height_m = 0.0;
    let scene = Scene::from_toml_str(case["scene_toml"].as_str().unwrap(), "ledge").unwrap();
    let free =
        stance::solve_among(&robot, pair(&case["lengths_m"]), hold(case), &scene, &Solver::default(), FreeCups::Rest)
            .unwrap();
    let caught = solve(case).unwrap();
    assert!(free.contacts.iter().all(|c| c.chain != "unit"));
    assert!(caught.contacts.iter().any(|c| c.chain == "unit"));
    // The outline's corners where the free unit hangs: one of them is inside the ledge.
    let outline = Robot::builtin().driving_unit.outline_m().unwrap();
    let deepest = outline
        .iter()
        .map(|&[a, c]| {
            let (s, k) = free.unit.angle_rad.sin_cos();
            let x = [free.unit.point_m[0] + a * k + c * s, free.unit.point_m[1] + a * s - c * k];
            -scene.signed_distance(x).0
        })
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(deepest > 1e-4, "the free unit's outline clears the ledge by {} m", -deepest);
}
