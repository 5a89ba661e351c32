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
use leech::stance::{self, FreeCups, Held, Hold, StanceError};
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
    let outline = stance::unit_outline(&Robot::builtin(), free.unit).unwrap();
    let deepest = outline.iter().map(|&x| -scene.signed_distance(x).0).fold(f64::NEG_INFINITY, f64::max);
    println!("without its outline the unit hangs {deepest:.2e} m into the ledge");
    assert!(deepest > 1e-4, "the free unit's outline clears the ledge by {} m", -deepest);
}

/// A rear hold that puts the held unit's outline into a solid is refused by
/// every solve among solids (no solve can move a held unit), naming where;
/// the same hold a little farther out solves.
#[test]
fn a_held_unit_inside_a_solid_is_refused() {
    let robot = Robot::builtin();
    let scene = Scene::builtin("thin-wall").unwrap();
    // The rear cup on the floor 33 mm beyond the thin wall (0.20..0.22 m),
    // the unit's back (35 mm behind the clamp) 2 mm into the wall's far face.
    let into = stance::rear_pose_for_cup(&robot, [0.22 + 0.033, 0.0], 0.0);
    let e = stance::solve_among(&robot, [0.2, 0.2], Hold::Rear(into), &scene, &Solver::default(), FreeCups::Rest)
        .expect_err("the unit is inside the wall");
    let StanceError::Input(e) = e else { panic!("{e}") };
    let e = e.to_string();
    assert!(e.contains("hold (rear)") && e.contains("2.0 mm into one at (218.0,"), "{e}");
    let overlap = stance::held_unit_overlap(&robot, into, &scene).unwrap();
    assert!((overlap.depth_m - 0.002).abs() < 1e-12, "{overlap:?}");
    // A phase continued from a state refuses it too: the same hold on the
    // floor alone solves, fed on among the thin wall it is refused.
    let floor = Scene::builtin("floor").unwrap();
    let held =
        stance::solve_among(&robot, [0.2, 0.2], Hold::Rear(into), &floor, &Solver::default(), FreeCups::Rest).unwrap();
    let fed = stance::solve_after(&robot, &held, [0.21, 0.2], held.hold, &scene, &Solver::default(), FreeCups::Rest);
    assert!(matches!(fed, Err(StanceError::Input(ref e)) if e.to_string().contains("hold (rear)")), "{fed:?}");
    let clear = stance::rear_pose_for_cup(&robot, [0.22 + 0.04, 0.0], 0.0);
    assert!(stance::held_unit_overlap(&robot, clear, &scene).is_none());
    assert!(
        stance::solve_among(&robot, [0.2, 0.2], Hold::Rear(clear), &scene, &Solver::default(), FreeCups::Rest).is_ok()
    );
    // Without an outline nothing of the unit touches.
    let mut point = robot.clone();
    point.driving_unit.length_m = 0.0;
    point.driving_unit.height_m = 0.0;
    assert!(stance::held_unit_overlap(&point, into, &scene).is_none());
}
