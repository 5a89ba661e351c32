//! Phases that continue from where the robot is ([`stance::solve_after`]):
//! releases from the both-held equilibrium, against the cold re-feed.

use leech::prelude::*;
use leech::scene::{Scene, Solid};
use leech::stance::{self, census, FreeCups, Held, Hold, Pose};

/// The rear hold of the census and a front hold with the front cup's face
/// on the top of a 60 mm step, 30 mm beyond its edge.
fn on_the_step(robot: &Robot) -> (Scene, Pose, Pose) {
    let rear = Pose::from_deg(census::REAR.0, census::REAR.1);
    let front = stance::front_pose_for_cup(robot, [census::AHEAD_M + 0.03, 0.06], 0.0);
    (census::step_ahead(0.06), rear, front)
}

fn both_held(robot: &Robot, scene: &Scene, lengths: [f64; 2], rear: Pose, front: Pose) -> Held {
    let both =
        stance::solve_among(robot, lengths, Hold::Both { rear, front }, scene, &Solver::default(), FreeCups::Rest)
            .unwrap_or_else(|e| panic!("{lengths:?}: {e}"));
    assert!(both.penetration_m(robot, scene) <= 1e-9);
    both
}

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// The largest difference between two states' coordinates.
fn max_difference(a: &Held, b: &Held) -> f64 {
    a.equilibrium.q.iter().zip(&b.equilibrium.q).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// The measurement: in front of a step, with the front cup on its
/// top, the rear release fed again from the shortest tubes drags the
/// driving unit through the step's corner at every nearby length; from the
/// both-held equilibrium the unit slides back along the floor (the body
/// unbends) and the front cup carries the robot.
#[test]
fn a_rear_release_in_front_of_a_step_continues_from_both_holds() {
    let robot = Robot::builtin();
    let solver = Solver::default();
    let (scene, rear, front) = on_the_step(&robot);
    for la in [0.15, 0.16, 0.17, 0.18, 0.19] {
        let lengths = [la, la];
        let both = both_held(&robot, &scene, lengths, rear, front);
        let cold = stance::solve_among(&robot, lengths, Hold::Front(front), &scene, &solver, FreeCups::Rest);
        // Refused: the straight step through the corner, and the descent
        // that follows the snap finds no way down through free space.
        let error = cold.expect_err("the re-feed drags the unit through the corner");
        assert!(matches!(error, stance::StanceError::Solve(_)), "{la}: {error}");
        let after = stance::solve_after(&robot, &both, lengths, Hold::Front(front), &scene, &solver, FreeCups::Rest)
            .unwrap_or_else(|e| panic!("{la}: {e}"));
        assert_eq!(after.hold, Hold::Front(front));
        assert!(after.rear.is_none() && after.front.is_some());
        assert!(after.equilibrium.stable, "{la}");
        assert!(after.penetration_m(&robot, &scene) <= 1e-9, "{la}");
        // The front cup and the floor carry the weight.
        let support = after.support();
        assert!(support.force_n[0].abs() < 1e-9 && (support.force_n[1] - after.weight_n).abs() < 1e-9 * after.weight_n);
        // The unit slid back on the floor, in front of the step, by less than the tubes' slack.
        let moved = distance(after.unit.point_m, both.unit.point_m);
        assert!(after.unit.point_m[0] < both.unit.point_m[0] && moved < 0.06, "{la}: moved {moved} m");
        assert!(after.rear_cup_m(&robot)[1] >= -1e-9, "{la}");
    }
}

/// In free space each release ends where the cold solve of the hold left
/// ends (the body hanging from one cup has one equilibrium): two paths, the
/// released hold softened from the both-held state and the load raised
/// from the unloaded shape, reach the same state.
#[test]
fn a_release_in_free_space_is_the_equilibrium_of_the_hold_left() {
    let robot = Robot::builtin();
    let solver = Solver::default();
    let (_, rear, front) = on_the_step(&robot);
    let far = Scene::new("far floor", vec![Solid::HalfPlane { point_m: [0.0, -5.0], normal: [0.0, 1.0] }]).unwrap();
    for lengths in [[0.2, 0.2], [0.22, 0.23]] {
        let both = both_held(&robot, &far, lengths, rear, front);
        for left in [Hold::Front(front), Hold::Rear(rear)] {
            let after = stance::solve_after(&robot, &both, lengths, left, &far, &solver, FreeCups::Rest).unwrap();
            let cold = stance::solve(&robot, lengths, left, &solver).unwrap();
            let d = max_difference(&after, &cold);
            assert!(d < 1e-9, "{lengths:?} {}: {d}", left.name());
            // The release moved the body: the result is not the both-held state.
            assert!(max_difference(&after, &both) > 1e-3, "{lengths:?} {}", left.name());
        }
    }
}

/// Released from the step's top, the front end stays over it (the body
/// unbends and lifts it); fed again from the shortest tubes it ends in
/// front of the step's face instead, a state the robot never passes through.
#[test]
fn a_front_release_on_a_step_keeps_the_front_end_over_it() {
    let robot = Robot::builtin();
    let solver = Solver::default();
    let (scene, rear, front) = on_the_step(&robot);
    for la in [0.15, 0.17, 0.19] {
        let lengths = [la, la];
        let both = both_held(&robot, &scene, lengths, rear, front);
        let after = stance::solve_after(&robot, &both, lengths, Hold::Rear(rear), &scene, &solver, FreeCups::Rest)
            .unwrap_or_else(|e| panic!("{la}: {e}"));
        let cold = stance::solve_among(&robot, lengths, Hold::Rear(rear), &scene, &solver, FreeCups::Rest).unwrap();
        assert!(after.penetration_m(&robot, &scene) <= 1e-9 && after.equilibrium.stable, "{la}");
        let (over, dragged) = (after.front_cup_m(&robot), cold.front_cup_m(&robot));
        assert!(over[0] > census::AHEAD_M && over[1] > 0.06, "{la}: {over:?}");
        assert!(dragged[0] < census::AHEAD_M, "{la}: {dragged:?}");
        assert!(distance(over, dragged) > 0.03, "{la}");
    }
}

/// A change of hold that is no phase (one cup's hold for the other's, or
/// a cup attached at other lengths) is refused.
#[test]
fn a_state_change_that_is_no_phase_is_refused() {
    let robot = Robot::builtin();
    let solver = Solver::default();
    let (scene, rear, front) = on_the_step(&robot);
    let both = both_held(&robot, &scene, [0.17, 0.17], rear, front);
    let released =
        stance::solve_after(&robot, &both, [0.17, 0.17], Hold::Rear(rear), &scene, &solver, FreeCups::Rest).unwrap();
    let swapped =
        stance::solve_after(&robot, &released, [0.17, 0.17], Hold::Front(front), &scene, &solver, FreeCups::Rest);
    assert!(matches!(swapped, Err(stance::StanceError::Input(_))), "{swapped:?}");
    let longer = stance::solve_after(
        &robot,
        &released,
        [0.18, 0.18],
        Hold::Both { rear, front },
        &scene,
        &solver,
        FreeCups::Rest,
    );
    assert!(matches!(longer, Err(stance::StanceError::Input(_))), "{longer:?}");
    // The same hold at the same lengths is the state itself.
    let same = stance::solve_after(&robot, &released, [0.17, 0.17], Hold::Rear(rear), &scene, &solver, FreeCups::Rest);
    assert_eq!(same.unwrap(), released);
}
