//! The climb planner: its plans replayed through the holds-and-contacts
//! statics, independently of the planner, and impossible climbs reported so.

use leech::prelude::*;
use leech::scene::Scene;
use leech::stance::{self, FreeCups, Held};
use leech::stride::plan::cup_face;
use leech::stride::{self, Command, Cup, Evidence, Foothold, Goal, Phase, PlanOptions, Status, StrideMachine};

/// Replays every step of `plan`: the same equilibrium from the step's own
/// inputs, the interlock fed the phases with their evidence, every holding
/// cup at its minimum safety factor, nothing in a solid, the tubes within
/// their range, and the goal reached.
fn replay(robot: &Robot, scene: &Scene, plan: &stride::Plan, goal: Goal) {
    let solver = Solver::default();
    let minimum = robot.cup.min_safety_factor;
    let mut machine = StrideMachine::new(minimum).unwrap();
    let flush = |held: &Held, cup: Cup| {
        let (centre, angle) = cup_face(robot, held, cup);
        let c = &robot.cup;
        scene.flat_on_one_edge(
            centre,
            angle,
            0.5 * c.diameter_m,
            c.attach_distance_tolerance_m,
            c.attach_angle_tolerance_deg.to_radians(),
        )
    };
    let mut previous: Option<Held> = None;
    for step in &plan.steps {
        let again = stance::solve_among(robot, step.lengths_m, step.held.hold, scene, &solver, FreeCups::Rest).unwrap();
        for (a, b) in again.equilibrium.q.iter().zip(&step.held.equilibrium.q) {
            assert!((a - b).abs() < 1e-9, "{:?}: q differs by {}", step.phase, (a - b).abs());
        }
        for l in step.lengths_m {
            assert!((robot.limits.tube_length_min_m - 1e-12..=robot.limits.tube_length_max_m + 1e-12).contains(&l));
        }
        assert!(again.penetration_m(robot, scene) <= 1e-9, "{:?} penetrates", step.phase);
        // The faces of the cups that do not hold rest on the solids, never in them.
        let free = [(Cup::Rear, again.rear.is_none()), (Cup::Front, again.front.is_none())];
        for (cup, _) in free.into_iter().filter(|(_, free)| *free) {
            let (centre, angle) = cup_face(robot, &again, cup);
            for side in [-1.0, 1.0] {
                let w = side * 0.5 * robot.cup.diameter_m;
                let rim = [centre[0] + w * angle.cos(), centre[1] + w * angle.sin()];
                assert!(
                    scene.signed_distance(rim).0 > -1e-9,
                    "{:?}: the {cup} cup's rim {rim:?} in a solid",
                    step.phase
                );
            }
        }
        for c in &again.contacts {
            assert!(scene.signed_distance(c.point_m).0 > -1e-9, "{:?}: contact {c:?} inside a solid", step.phase);
        }
        let (rear, front) = again.cups(robot).unwrap();
        for cup in [&rear, &front].into_iter().flatten() {
            assert!(
                cup.verdict.safety_factor >= minimum,
                "{:?}: safety factor {}",
                step.phase,
                cup.verdict.safety_factor
            );
        }
        // The evidence of the phase: an attaching cup's face as the previous
        // phase left it; a release's partner safety factor after it.
        let (none, held_before) = (f64::NAN, previous.as_ref());
        let evidence = match step.phase {
            Phase::AttachFront => Evidence { flush: flush(held_before.unwrap(), Cup::Front), safety_factor: none },
            Phase::AttachRear => Evidence { flush: flush(held_before.unwrap(), Cup::Rear), safety_factor: none },
            Phase::ReleaseRear => {
                Evidence { flush: false, safety_factor: front.as_ref().unwrap().verdict.safety_factor }
            }
            Phase::ReleaseFront => {
                Evidence { flush: false, safety_factor: rear.as_ref().unwrap().verdict.safety_factor }
            }
            Phase::Start | Phase::Push | Phase::Pull => Evidence { flush: false, safety_factor: none },
        };
        let command = step.phase.command(evidence);
        if matches!(step.phase, Phase::Start | Phase::Push | Phase::Pull) {
            assert_eq!(command, Command::Move);
        }
        let holding = machine.apply(command).unwrap_or_else(|e| panic!("{:?}: {e}", step.phase));
        assert_eq!(holding.name(), Some(again.hold.name()), "{:?}", step.phase);
        previous = Some(again);
    }
    let last = plan.steps.last().unwrap();
    assert_eq!(last.phase, Phase::ReleaseFront);
    let rear = last.held.rear_cup_m(robot);
    let off = ((rear[0] - goal.point_m[0]).powi(2) + (rear[1] - goal.point_m[1]).powi(2)).sqrt();
    assert!(off <= goal.tolerance_m, "the rear cup ends {off} m from the goal");
}

#[test]
fn the_robot_crawls_along_the_floor() {
    let robot = Robot::builtin();
    let floor = Scene::builtin("floor").unwrap();
    let start = Foothold { centre_m: [0.0, 0.0], direction_rad: 0.0 };
    let goal = Goal { point_m: [0.25, 0.0], tolerance_m: 0.03 };
    let plan = stride::plan(&robot, &floor, start, goal, &PlanOptions::default()).unwrap();
    assert_eq!(plan.status, Status::Reached, "{:?}", plan.reason);
    assert!(plan.strides >= 1, "{} strides for 0.25 m", plan.strides);
    assert_eq!(plan.steps.len(), 1 + 6 * plan.strides);
    replay(&robot, &floor, &plan, goal);
}

/// Two floors with a 0.5 m gap between them, wider than the tubes reach:
/// the robot crawls to the edge and no stride crosses.
#[test]
fn a_gap_wider_than_the_reach_is_impossible() {
    let robot = Robot::builtin();
    let toml = r#"
name = "a gap"
[[polygon]]
points_m = [[-1.0, -0.2], [0.12, -0.2], [0.12, 0.0], [-1.0, 0.0]]
[[polygon]]
points_m = [[0.62, -0.2], [2.0, -0.2], [2.0, 0.0], [0.62, 0.0]]
"#;
    let scene = Scene::from_toml_str(toml, "gap").unwrap();
    let start = Foothold { centre_m: [0.0, 0.0], direction_rad: 0.0 };
    let goal = Goal { point_m: [0.8, 0.0], tolerance_m: 0.03 };
    let plan = stride::plan(&robot, &scene, start, goal, &PlanOptions::default()).unwrap();
    assert_eq!(plan.status, Status::Impossible);
    let reason = plan.reason.expect("a reason");
    assert_eq!(reason.blocking, stride::Blocking::Reach, "{reason:?}");
    // The farthest stance stays on the near floor.
    let rear = plan.steps.last().unwrap().held.rear_cup_m(&robot);
    assert!(rear[0] < 0.12, "{rear:?}");
}

/// A search cut short by its time limit says so, not that the climb is impossible for a physical reason.
#[test]
fn a_search_out_of_time_says_so() {
    let robot = Robot::builtin();
    let floor = Scene::builtin("floor").unwrap();
    let start = Foothold { centre_m: [0.0, 0.0], direction_rad: 0.0 };
    let goal = Goal { point_m: [2.0, 0.0], tolerance_m: 0.03 };
    let options = PlanOptions { time_limit: Some(std::time::Duration::from_millis(100)), ..PlanOptions::default() };
    let plan = stride::plan(&robot, &floor, start, goal, &options).unwrap();
    assert_eq!(plan.status, Status::Impossible);
    assert_eq!(plan.reason.unwrap().blocking, stride::Blocking::TimeLimit);
}

/// Every built-in scenario the planner reaches, replayed step by step.
#[test]
fn the_builtin_climbs_replay() {
    let robot = Robot::builtin();
    for name in ["climb-wall-up", "climb-wall-down", "floor-to-wall"] {
        let scenario = stride::Scenario::builtin(name).unwrap();
        let plan =
            stride::plan(&robot, &scenario.scene, scenario.start, scenario.goal, &PlanOptions::default()).unwrap();
        assert_eq!(plan.status, Status::Reached, "{name}: {:?}", plan.reason);
        replay(&robot, &scenario.scene, &plan, scenario.goal);
    }
}

/// A goal more strides away than the search allows is reported as the stride limit, not as a physical block.
#[test]
fn a_goal_beyond_the_stride_limit_says_so() {
    let robot = Robot::builtin();
    let floor = Scene::builtin("floor").unwrap();
    let start = Foothold { centre_m: [0.0, 0.0], direction_rad: 0.0 };
    let goal = Goal { point_m: [0.5, 0.0], tolerance_m: 0.03 };
    let options = PlanOptions { max_strides: 1, ..PlanOptions::default() };
    let plan = stride::plan(&robot, &floor, start, goal, &options).unwrap();
    assert_eq!(plan.status, Status::Impossible);
    assert_eq!(plan.reason.unwrap().blocking, stride::Blocking::StrideLimit);
    assert_eq!(plan.strides, 1);
}
