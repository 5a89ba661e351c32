//! The 3D body among a scene's solids (leech::body3::contact3): the planar
//! stance on a floor reproduced in the plane, and a turning body resting on
//! a floor checked by balance and complementarity.

use leech::body3::rotation::{axpy, cross, dot, scale, Vec3};
use leech::body3::{Body3, Held3, Hold3};
use leech::prelude::*;
use leech::scene::{Scene3, Solid3};
use leech::stance::{self, Hold, Pose};

/// The built-in robot with its driving unit along a floor (clamp angle 0).
fn flat() -> Robot {
    let mut robot = Robot::builtin();
    robot.world.base_angle_deg = 0.0;
    robot
}

/// The floor under the rear cup's face: the unit's y axis its normal.
fn floor_under(body: &Body3, robot: &Robot) -> Scene3 {
    let base = body.base_frame();
    let normal = [base[0][1], base[1][1], base[2][1]];
    let point_m = body.rear_cup_centre(robot);
    Scene3::new("floor", vec![Solid3::HalfSpace { point_m, normal }]).unwrap()
}

fn on_floor(robot: &Robot, lengths: [f64; 3]) -> (Held3, Scene3) {
    let body = Body3::from_robot(robot, lengths).unwrap();
    let floor = floor_under(&body, robot);
    let held = body.solve_held_among(robot, Hold3::Rear, &floor, &Solver::default()).unwrap();
    (held, floor)
}

/// Every contact pushes and touches, every other link tip keeps the clearance;
/// the rear reaction, the contacts and gravity balance the whole body.
fn check(robot: &Robot, held: &Held3, scene: &Scene3) {
    let (body, eq) = (&held.body, &held.equilibrium);
    assert!(eq.stable);
    let radius = 0.5 * robot.tube.outer_diameter_m;
    let k = robot.tube.joint_stiffness_nm_per_rad;
    for c in &eq.contacts {
        assert!(c.force_n > -1e-9 * k, "{c:?} pulls");
        assert!(body.contact_gap(&eq.frames, &c.row).abs() < 1e-9, "{c:?} does not touch");
    }
    for tube in 0..3 {
        for link in 0..body.tube(tube).len() {
            let p = body.link_tip(&eq.frames, tube, link);
            let (_, _, d) = scene.nearest(p).unwrap();
            assert!(d >= radius - 1e-9, "tube {tube} link {link}: {d} from the solid");
        }
    }
    // Whole-body balance about the rear cup's centre.
    let rear = held.rear.as_ref().unwrap();
    let g = body.gravity();
    let (mass, first) = body.first_moment(&eq.frames, robot.driving_unit.mass_kg);
    let mut force = rear.reaction.force_n;
    let mut moment = rear.reaction.moment_nm;
    for c in &eq.contacts {
        let f = scale(c.force_n, c.row.plane.normal);
        force = axpy(1.0, f, force);
        moment = axpy(1.0, cross(axpy(-1.0, rear.centre_m, c.point_m), f), moment);
    }
    let weight = [0.0, g * mass, 0.0];
    let lever = axpy(-mass, rear.centre_m, first);
    let expected_moment: Vec3 = cross(lever, [0.0, g, 0.0]);
    let w = g * mass;
    for a in 0..3 {
        assert!((force[a] - weight[a]).abs() < 1e-8 * w, "force {force:?} against {weight:?}");
        assert!((moment[a] - expected_moment[a]).abs() < 1e-8 * w, "moment {moment:?} against {expected_moment:?}");
    }
}

#[test]
fn the_planar_body_on_a_floor_is_reproduced_in_the_plane() {
    let mut robot = flat();
    robot.body.tip_spacing_m = robot.body.base_spacing_m;
    let (held, floor) = on_floor(&robot, [0.30, 0.28, 0.28]);
    check(&robot, &held, &floor);
    let eq = &held.equilibrium;
    assert!(!eq.contacts.is_empty(), "the body does not reach the floor");
    let planar_floor = leech::scene::Scene::builtin("floor").unwrap();
    let height = robot.body.base_spacing_m + robot.cup.rear_offset_m;
    let hold = Hold::Rear(Pose::from_deg([0.0, height], 0.0));
    let planar = stance::solve_in(&robot, [0.30, 0.28], hold, &planar_floor, &Solver::default()).unwrap();
    // The endpoint relative to tube 1's root (the planar p0).
    let body = &held.body;
    let tip = axpy(-1.0, body.tube(0).root(), body.endpoint(&eq.frames));
    let planar_tip = [planar.endpoint_m[0] - planar.unit.point_m[0], planar.endpoint_m[1] - planar.unit.point_m[1]];
    assert!(tip[2].abs() < 1e-9, "{tip:?}");
    for a in 0..2 {
        assert!((tip[a] - planar_tip[a]).abs() < 1e-8, "endpoint {tip:?} against {planar_tip:?}");
    }
    // The same contacts: the side pair's force split between tubes 2 and 3.
    let total: f64 = eq.contacts.iter().map(|c| c.force_n).sum();
    let planar_total: f64 = planar.contacts.iter().map(|c| c.force_n).sum();
    assert!((total - planar_total).abs() < 1e-7 * planar_total, "{total} against {planar_total}");
    eprintln!(
        "planar floor: endpoint {:.2e} m apart, contact force {total:.9} N against {planar_total:.9} N ({} rows in 3D, {} planar)",
        (tip[0] - planar_tip[0]).hypot(tip[1] - planar_tip[1]),
        eq.contacts.len(),
        planar.contacts.len()
    );
    let rear = held.rear.as_ref().unwrap().reaction.force_n;
    let planar_rear = planar.rear.unwrap().force_n;
    for a in 0..2 {
        assert!((rear[a] - planar_rear[a]).abs() < 1e-7 * planar_total.max(1.0), "{rear:?} against {planar_rear:?}");
    }
}

#[test]
fn a_turning_body_rests_on_a_floor() {
    let robot = flat();
    let (held, floor) = on_floor(&robot, [0.34, 0.36, 0.28]);
    check(&robot, &held, &floor);
    let eq = &held.equilibrium;
    assert!(!eq.contacts.is_empty());
    // It turns: the endpoint leaves the plane of the clamp.
    assert!(held.body.endpoint(&eq.frames)[2].abs() > 1e-3);
    // Only tubes 2 and 3 lie below tube 1: only they touch.
    assert!(eq.contacts.iter().all(|c| c.row.tube > 0));
    let sides = [1, 2].map(|t| eq.contacts.iter().filter(|c| c.row.tube == t).count());
    let force: f64 = eq.contacts.iter().map(|c| c.force_n).sum();
    eprintln!(
        "contacts on tubes 2 and 3: {sides:?}, {force:.6} N in all, endpoint {:?}",
        held.body.endpoint(&eq.frames)
    );
    let up = held.body.base_frame();
    assert!(dot([up[0][1], up[1][1], up[2][1]], [0.0, 1.0, 0.0]) > 0.99);
}

#[test]
fn a_bad_clearance_or_hold_is_refused() {
    let robot = Robot::builtin();
    let body = Body3::from_robot(&robot, [0.3, 0.3, 0.3]).unwrap();
    let floor = floor_under(&body, &robot);
    let e = body.solve_among(&Solver::default(), &floor, f64::NAN).unwrap_err().to_string();
    assert!(e.starts_with("clearance (m)"), "{e}");
    let hold = Hold3::Front { tip_m: [0.3, 0.0, 0.0], plate: body.base_frame() };
    let e = body.solve_held_among(&robot, hold, &floor, &Solver::default()).unwrap_err().to_string();
    assert!(e.starts_with("hold"), "{e}");
}

#[test]
fn a_turning_body_rests_on_a_box_on_the_floor() {
    let robot = flat();
    let body = Body3::from_robot(&robot, [0.34, 0.36, 0.28]).unwrap();
    let floor = floor_under(&body, &robot);
    let y = body.rear_cup_centre(&robot)[1];
    // A low block under the front half, turned a little about y.
    let block = Solid3::Box {
        centre_m: [0.3, y - 0.045, 0.0],
        half_extents_m: [0.12, 0.05, 0.3],
        frame: leech::body3::rotation::exp([0.0, 0.2, 0.0]),
    };
    let scene = Scene3::new("floor and block", vec![floor.solids[0].clone(), block]).unwrap();
    let held = body.solve_held_among(&robot, Hold3::Rear, &scene, &Solver::default()).unwrap();
    check(&robot, &held, &scene);
    assert!(held.equilibrium.contacts.iter().any(|c| c.row.solid == 1), "nothing rests on the block");
}
