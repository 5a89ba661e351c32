//! The climb planner: its plans replayed through the holds-and-contacts
//! statics, independently of the planner, and impossible climbs reported so.

use leech::budget::Deadline;
use leech::prelude::*;
use leech::scene::Scene;
use leech::stance::{self, FreeCups, Held};
use leech::stride::plan::cup_face;
use leech::stride::{self, Command, Cup, Evidence, Foothold, Goal, Phase, PlanOptions, Status, StrideMachine};

/// Replays every step of `plan`: the same equilibrium from the step's own
/// inputs and the state the step before left, the interlock fed the phases with their evidence, every holding
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
        // Each phase continues from where the last one left the robot (the
        // start alone is solved cold), as the robot moves.
        let again = match &previous {
            Some(before) => {
                stance::solve_after(robot, before, step.lengths_m, step.held.hold, scene, &solver, FreeCups::Rest)
            }
            None => stance::solve_among(robot, step.lengths_m, step.held.hold, scene, &solver, FreeCups::Rest),
        }
        .unwrap_or_else(|e| panic!("{:?}: {e}", step.phase));
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

/// The built-in robot's plan in the scene `toml` from the rear cup at the
/// origin heading along +x to a goal on y = 0 at `goal_x` (m): impossible.
fn impossible_on_a_floor(toml: &str, goal_x: f64) -> stride::Plan {
    let scene = Scene::from_toml_str(toml, "test scene").unwrap();
    let start = Foothold { centre_m: [0.0, 0.0], direction_rad: 0.0 };
    let goal = Goal { point_m: [goal_x, 0.0], tolerance_m: 0.03 };
    let plan = stride::plan(&Robot::builtin(), &scene, start, goal, &PlanOptions::default()).unwrap();
    assert_eq!(plan.status, Status::Impossible);
    plan
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
    let plan = impossible_on_a_floor(toml, 0.8);
    let reason = plan.reason.expect("a reason");
    assert_eq!(reason.blocking, stride::Blocking::Reach, "{reason:?}");
    // The farthest stance stays on the near floor.
    let rear = plan.steps.last().unwrap().held.rear_cup_m(&robot);
    assert!(rear[0] < 0.12, "{rear:?}");
}

/// A search cut short by its time limit says so, not that the climb is
/// impossible for a physical reason, wherever the deadline falls: before the
/// first solve (it used to fail the start phase as a snap), inside a solve,
/// or between strides.
#[test]
fn a_search_out_of_time_says_so() {
    let robot = Robot::builtin();
    let floor = Scene::builtin("floor").unwrap();
    let start = Foothold { centre_m: [0.0, 0.0], direction_rad: 0.0 };
    let goal = Goal { point_m: [2.0, 0.0], tolerance_m: 0.03 };
    for us in [0, 200, 1_000, 5_000, 20_000, 100_000] {
        let deadline = Deadline::after(std::time::Duration::from_micros(us));
        let plan =
            stride::plan(&robot, &floor, start, goal, &PlanOptions { deadline, ..PlanOptions::default() }).unwrap();
        assert_eq!(plan.status, Status::Stopped, "{us} us: {:?}", plan.reason);
        assert_eq!(plan.reason.unwrap().blocking, stride::Blocking::TimeLimit, "{us} us");
    }
}

/// Every built-in scenario the planner reaches, replayed step by step.
/// Floor to wall joined them once bodies pushed into the inside corner
/// settled (the contact solve's blocking rows): it had been impossible,
/// first for reach, then for the front cup's force on the way.
#[test]
fn the_builtin_climbs_replay() {
    let robot = Robot::builtin();
    for name in ["crawl-floor", "climb-wall-up", "climb-wall-down", "floor-to-wall"] {
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

/// Every equilibrium of the body among `scene`'s solids with the rear cup
/// held at one of `rears`, the tubes on a grid of `grid` x `grid` lengths over
/// the range, the free front cup resting; those that penetrate a solid or
/// bend a tube tighter than its smallest radius are left out (the planner
/// rejects them). `visit` sees each with its front face's centre and angle
/// (rad); the number seen.
fn each_front_face(
    robot: &Robot,
    scene: &Scene,
    rears: &[leech::stance::Pose],
    grid: usize,
    mut visit: impl FnMut([f64; 2], [f64; 2], f64),
) -> usize {
    use leech::stance::Hold;
    let (lo, hi) = (robot.limits.tube_length_min_m, robot.limits.tube_length_max_m);
    let at = |i: usize| lo + (hi - lo) * i as f64 / (grid - 1) as f64;
    let mut states = 0;
    for rear in rears {
        for i in 0..grid {
            for j in 0..grid {
                let lengths = [at(i), at(j)];
                let Ok(held) =
                    stance::solve_among(robot, lengths, Hold::Rear(*rear), scene, &Solver::default(), FreeCups::Rest)
                else {
                    continue;
                };
                if !(held.penetration_m(robot, scene) <= 1e-9 && held.min_bend_radius() >= robot.tube.min_bend_radius_m)
                {
                    continue;
                }
                states += 1;
                let (centre, angle) = cup_face(robot, &held, Cup::Front);
                visit(lengths, centre, angle);
            }
        }
    }
    states
}

/// The built-in scenario `name` planned for the built-in robot: impossible,
/// blocked by `blocking`.
fn impossible(name: &str, blocking: stride::Blocking) -> (Robot, stride::Scenario, stride::Plan) {
    let robot = Robot::builtin();
    let scenario = stride::Scenario::builtin(name).unwrap();
    let plan = stride::plan(&robot, &scenario.scene, scenario.start, scenario.goal, &PlanOptions::default()).unwrap();
    assert_eq!(plan.status, Status::Impossible, "{name}");
    assert_eq!(plan.reason.as_ref().unwrap().blocking, blocking, "{name}: {:?}", plan.reason);
    (robot, scenario, plan)
}

/// Whether a face (centre, angle) lies flush on `scene` within the robot's tolerances.
fn flush_on(robot: &Robot, scene: &Scene, centre: [f64; 2], angle: f64) -> bool {
    let c = &robot.cup;
    scene.flat_on_one_edge(
        centre,
        angle,
        0.5 * c.diameter_m,
        c.attach_distance_tolerance_m,
        c.attach_angle_tolerance_deg.to_radians(),
    )
}

/// The smallest angle (deg) by which a front face whose centre is within
/// 5 mm of a surface along `surface_deg` misses lying along it, over the
/// states from the footholds `a`..`b`; infinite when no face comes that near.
fn nearest_miss(robot: &Robot, scene: &Scene, [a, b]: [[f64; 2]; 2], heading_deg: f64, surface_deg: f64) -> f64 {
    let rears: Vec<_> = (0..6)
        .map(|k| {
            let t = k as f64 / 5.0;
            let foot = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            stance::rear_pose_for_cup(robot, foot, heading_deg.to_radians())
        })
        .collect();
    let mut nearest = f64::INFINITY;
    let states = each_front_face(robot, scene, &rears, 14, |_, centre, angle| {
        let Some((on, direction)) = scene.surface_frame(centre) else { return };
        let along = leech::geom::angle_difference(direction, surface_deg.to_radians()).abs() < 1e-6;
        let off = ((on[0] - centre[0]).powi(2) + (on[1] - centre[1]).powi(2)).sqrt();
        if along && off <= 0.005 {
            assert!(!flush_on(robot, scene, centre, angle), "a face lands flush at {centre:?}");
            nearest = nearest.min(leech::geom::angle_difference(angle, direction).abs().to_degrees());
        }
    });
    assert!(states > 500, "only {states} states checked");
    nearest
}

/// Up the block's face and onto its top (an outside corner, 90 to 0 deg):
/// impossible for `reach`, and the physics agrees: from every foothold on
/// the face up to the corner, no tube lengths lay the front face on the top.
/// Near the top the face is turned at least 20 deg away from it: the body
/// leans on the corner and its two tube lengths bend it evenly, so it
/// cannot turn down onto the top just past the corner.
#[test]
fn onto_the_top_of_a_block_the_front_face_cannot_land() {
    let (robot, scenario, _) = impossible("wall-to-floor", stride::Blocking::Reach);
    let miss = nearest_miss(&robot, &scenario.scene, [[0.0, 0.0], [0.0, 0.125]], 90.0, 0.0);
    assert!(miss > 20.0, "a face comes within {miss} deg of the top");
}

/// Over the thin wall (90 to 270 deg): impossible for `reach`; from every
/// foothold on the near face, no front face comes within 5 mm of the far
/// face: a U-turn over the 20 mm top would need the tubes straight up past
/// the top and then a bend of 180 deg, and two tube lengths bend them evenly
/// from the clamp.
#[test]
fn over_the_thin_wall_the_front_face_cannot_land() {
    let (robot, scenario, _) = impossible("over-thin-wall", stride::Blocking::Reach);
    let miss = nearest_miss(&robot, &scenario.scene, [[0.2, 0.05], [0.2, 0.225]], 90.0, -90.0);
    assert!(miss.is_infinite(), "a face comes within {miss} deg of the far face");
}

/// Onto the ceiling: the robot gets there (its rear cup seals on the
/// ceiling, held well within its capacity) but cannot walk along it, and the
/// physics agrees: from the stance the plan reached, no tube lengths lay the
/// front face on the ceiling nearer the goal. The unit hangs from its cup and
/// the front end sags away from the ceiling.
#[test]
fn along_the_ceiling_the_front_face_cannot_land() {
    use leech::stance::Hold;
    let (robot, scenario, plan) = impossible("wall-to-ceiling", stride::Blocking::Reach);
    let last = plan.steps.last().unwrap();
    let (rear_cup, rear_angle) = cup_face(&robot, &last.held, Cup::Rear);
    assert!(flush_on(&robot, &scenario.scene, rear_cup, rear_angle), "the rear cup seals on the ceiling");
    assert!((rear_cup[1] - 0.25).abs() < 0.002, "{rear_cup:?}");
    assert!(last.rear_safety_factor.unwrap() >= 2.0 * robot.cup.min_safety_factor);
    let Hold::Rear(unit) = last.held.hold else { panic!("{:?}", last.held.hold) };
    let goal = scenario.goal.point_m;
    let to_goal = |p: [f64; 2]| ((p[0] - goal[0]).powi(2) + (p[1] - goal[1]).powi(2)).sqrt();
    let states = each_front_face(&robot, &scenario.scene, &[unit], 26, |lengths, centre, angle| {
        let nearer = to_goal(centre) < to_goal(rear_cup) - stride::plan::MIN_PROGRESS_M;
        assert!(!(nearer && flush_on(&robot, &scenario.scene, centre, angle)), "{lengths:?} lands at {centre:?}");
    });
    assert!(states > 300, "only {states} states checked");
}

/// A wall taller than any stance allows: a 0.6 m wall between the start and
/// a goal on the floor beyond it. The planner reports it impossible (never a
/// false plan), and its farthest stance stays on the near side.
#[test]
fn a_wall_taller_than_any_stance_allows_is_impossible() {
    let robot = Robot::builtin();
    let toml = r#"
name = "a tall wall"
[[half_plane]]
point_m = [0.0, 0.0]
normal = [0.0, 1.0]
[[polygon]]
points_m = [[0.20, -0.05], [0.22, -0.05], [0.22, 0.6], [0.20, 0.6]]
"#;
    let plan = impossible_on_a_floor(toml, 0.45);
    let reason = plan.reason.expect("a reason");
    assert!(
        matches!(reason.blocking, stride::Blocking::Reach | stride::Blocking::CupForce | stride::Blocking::Collision),
        "a physical block: {reason:?}"
    );
    for step in &plan.steps {
        let rear = step.held.rear_cup_m(&robot);
        assert!(rear[0] < 0.21, "{:?}: the rear cup at {rear:?}", step.phase);
    }
}
