//! The 3D body among a scene's solids (leech::contact::space): the planar
//! stance on a floor reproduced in the plane, and a turning body resting on
//! a floor checked by balance and complementarity.

use leech::body3::Body3;
use leech::geom3::{axpy, cross, dot, scale, Vec3};
use leech::hold::{AsBuilt, Hold3, Pose3};
use leech::prelude::*;
use leech::scene::{Scene3, Solid3};
use leech::stance::{self, Hold, Pose};
use leech::stance3;
use leech::stance3::place3::front_tip;
use leech::stance3::Held3;

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
    let held = stance3::solve_in(robot, &body, Hold3::Rear(AsBuilt), &floor, &Solver::default()).unwrap();
    (held, floor)
}

/// Every contact pushes and touches, every other link tip keeps the clearance;
/// the holding cup's reaction, the contacts and gravity balance the whole
/// body. Held at the front, the driving unit also hangs free: the forces and
/// spring moments at the tubes' roots (the weld's and the contacts'
/// multipliers) balance its weight with the front cup's force.
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
    // Whole-body balance about the holding cup's centre (the rear one when
    // both hold, the front cup's force and moment carried there).
    let rear = held.rear.as_ref().or(held.front.as_ref()).unwrap();
    let g = body.gravity();
    let (mass, first) = body.first_moment(&eq.frames, robot.unit_mass_kg(body.tube_lengths()));
    let mut force = rear.reaction.force_n;
    let mut moment = rear.reaction.moment_nm;
    if let (Some(_), Some(front)) = (&held.rear, &held.front) {
        force = axpy(1.0, front.reaction.force_n, force);
        let arm = cross(axpy(-1.0, rear.centre_m, front.centre_m), front.reaction.force_n);
        moment = axpy(1.0, axpy(1.0, arm, front.reaction.moment_nm), moment);
    }
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
    if held.front.is_some() && held.rear.is_none() {
        let (force, moment) = crate::body3_hold::unit_imbalance(held, robot.unit_mass_kg(held.body.tube_lengths()));
        assert!(force.iter().chain(&moment).all(|x| x.abs() < 1e-8 * w), "the unit: {force:?} {moment:?}");
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
    let plate = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]];
    let hold = Hold3::Front(Pose3 { point_m: [0.3, 0.0, 0.0], frame: plate });
    let e = stance3::solve_in(&robot, &body, hold, &floor, &Solver::default()).unwrap_err().to_string();
    assert!(e.starts_with("front hold plate frame"), "{e}");
    let hold = Hold3::FrontPivot(Pose3 { point_m: [f64::NAN, 0.0, 0.0], frame: body.base_frame() });
    let e = stance3::solve_in(&robot, &body, hold, &floor, &Solver::default()).unwrap_err().to_string();
    assert!(e.starts_with("front pivot tip (m)"), "{e}");
    // The clamp points up, so the rear cup's surface is a wall on the +x
    // side (the unit's y axis its outward normal): a plate 0.2 m into it.
    let hold = Hold3::Front(Pose3 { point_m: [0.2, 0.1, 0.0], frame: body.base_frame() });
    let e = stance3::solve_in(&robot, &body, hold, &floor, &Solver::default()).unwrap_err().to_string();
    assert!(e.starts_with("hold: ") && e.contains("the endpoint plate at (") && !e.contains('\n'), "{e}");
}

/// The front cup on a vertical wall (outward normal `+z`), the plate along
/// `+x` (so the body lies along the wall, tubes 2 and 3 on the wall's side),
/// and the floor `drop` (m) below the face's centre; the face's centre.
fn wall_and_floor(drop: f64) -> (Scene3, [[f64; 3]; 3], [f64; 3]) {
    let plate = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]];
    let centre = [0.5, 1.0, 0.0];
    let wall = Solid3::HalfSpace { point_m: [0.0, 0.0, 0.0], normal: [0.0, 0.0, 1.0] };
    let floor = Solid3::HalfSpace { point_m: [0.0, centre[1] - drop, 0.0], normal: [0.0, 1.0, 0.0] };
    (Scene3::new("wall and floor", vec![wall, floor]).unwrap(), plate, centre)
}

/// Held by the front cup on a wall, the body lying along it sags onto a
/// floor a little below: contacts on the floor, each pushing and touching,
/// the whole body in balance with the front cup and the unit hanging free.
#[test]
fn a_body_held_on_a_wall_rests_on_the_floor() {
    let robot = Robot::builtin();
    let (scene, plate, centre) = wall_and_floor(0.03);
    let tip = axpy(robot.body.tip_spacing_m + robot.cup.front_offset_m, [0.0, 0.0, 1.0], centre);
    for lengths in [[0.25, 0.25, 0.25], [0.25, 0.22, 0.27]] {
        let body = Body3::from_robot(&robot, lengths).unwrap();
        let held = stance3::solve_in(
            &robot,
            &body,
            Hold3::Front(Pose3 { point_m: tip, frame: plate }),
            &scene,
            &Solver::default(),
        );
        let held = held.unwrap();
        check(&robot, &held, &scene);
        let eq = &held.equilibrium;
        assert!(eq.contacts.iter().any(|c| c.row.solid == 1), "{lengths:?}: nothing rests on the floor");
        let force: f64 = eq.contacts.iter().map(|c| c.force_n).sum();
        let front = held.front.as_ref().unwrap();
        eprintln!(
            "front hold on a wall, {lengths:?}: {} contacts ({} on the wall), {force:.6} N, front cup {:?} N, safety {:.3}",
            eq.contacts.len(),
            eq.contacts.iter().filter(|c| c.row.solid == 0).count(),
            front.reaction.force_n,
            front.verdict.safety_factor
        );
        // Without the floor it hangs lower: the floor holds it up.
        let free =
            stance3::solve(&robot, &body, Hold3::Front(Pose3 { point_m: tip, frame: plate }), &Solver::default())
                .unwrap();
        let low = |h: &Held3| {
            (0..3).flat_map(|i| h.body.points(&h.equilibrium.frames, i)).fold(f64::INFINITY, |m, p| m.min(p[1]))
        };
        assert!(low(&free) < low(&held) - 1e-3, "{} {}", low(&free), low(&held));
    }
}

/// Solids out of reach change nothing: the front hold and the free front
/// joint among them are the holds without a scene.
#[test]
fn far_solids_change_nothing_under_the_front_holds() {
    let robot = Robot::builtin();
    let solver = Solver::default();
    let (_, plate, centre) = wall_and_floor(0.0);
    let far = Scene3::new("far", vec![Solid3::HalfSpace { point_m: [0.0, -50.0, 0.0], normal: [0.0, 1.0, 0.0] }]);
    let far = far.unwrap();
    let tip = axpy(robot.body.tip_spacing_m + robot.cup.front_offset_m, [0.0, 0.0, 1.0], centre);
    let body = Body3::from_robot(&robot, [0.25, 0.22, 0.27]).unwrap();
    for (hold, tolerance) in [
        (Hold3::Front(Pose3 { point_m: tip, frame: plate }), 1e-12),
        (Hold3::FrontPivot(Pose3 { point_m: tip, frame: plate }), 1e-12),
    ] {
        let alone = stance3::solve(&robot, &body, hold, &solver).unwrap();
        let among = stance3::solve_in(&robot, &body, hold, &far, &solver).unwrap();
        assert!(among.equilibrium.contacts.is_empty());
        let mut apart = 0.0f64;
        for i in 0..3 {
            let a = alone.body.points(&alone.equilibrium.frames, i);
            let b = among.body.points(&among.equilibrium.frames, i);
            for (p, q) in a.iter().zip(&b) {
                apart = apart.max((0..3).fold(0.0f64, |m, k| m.max((p[k] - q[k]).abs())));
            }
        }
        eprintln!("far solids, {hold:?}: points {apart:.2e} m apart");
        assert!(apart < tolerance, "{hold:?}: {apart}");
    }
}

/// With `L2 = L3`, `b = c` and the hold in the plane, the front hold on a
/// floor (the face on it, the body lying back from the plate and sagging
/// onto it) is the planar stance's among the same planar scene: the
/// driving unit's pose, the contact force and the front cup's reaction.
#[test]
fn the_front_hold_on_a_floor_is_the_planar_stance() {
    let mut robot = Robot::builtin();
    robot.body.tip_spacing_m = robot.body.base_spacing_m;
    let solver = Solver::default();
    let planar_floor = leech::scene::Scene::builtin("floor").unwrap();
    let floor = Scene3::from_planar(&planar_floor);
    let height = robot.body.tip_spacing_m + robot.cup.front_offset_m;
    let (l1, l23) = (0.30, 0.28);
    let pose = Pose::from_deg([0.5, height], 0.0);
    let planar = stance::solve_in(&robot, [l1, l23], Hold::Front(pose), &planar_floor, &solver).unwrap();
    let body = Body3::from_robot(&robot, [l1, l23, l23]).unwrap();
    let hold = Hold3::Front(Pose3 { point_m: [0.5, height, 0.0], frame: leech::geom3::rot_z(0.0) });
    let held = stance3::solve_in(&robot, &body, hold, &floor, &solver).unwrap();
    check(&robot, &held, &floor);
    let eq = &held.equilibrium;
    assert!(!eq.contacts.is_empty() && !planar.contacts.is_empty(), "the body does not reach the floor");
    let root = held.body.tube(0).root();
    let base = held.body.base_frame();
    let unit_angle = base[1][0].atan2(base[0][0]);
    let gap = (root[0] - planar.unit.point_m[0]).hypot(root[1] - planar.unit.point_m[1]);
    let turn = (unit_angle - planar.unit.angle_rad).sin();
    let total: f64 = eq.contacts.iter().map(|c| c.force_n).sum();
    let planar_total: f64 = planar.contacts.iter().map(|c| c.force_n).sum();
    eprintln!(
        "planar front hold on a floor: unit {gap:.2e} m, {turn:.2e} rad apart, contact force {total:.9} N against {planar_total:.9} N ({} rows in 3D, {} planar)",
        eq.contacts.len(),
        planar.contacts.len()
    );
    assert!(gap < 1e-7 && turn.abs() < 1e-7 && root[2].abs() < 1e-12, "{root:?} {unit_angle} vs {:?}", planar.unit);
    assert!((total - planar_total).abs() < 1e-7 * planar_total, "{total} against {planar_total}");
    let cup = held.front.as_ref().unwrap();
    let flat = planar.cups(&robot).unwrap().1.unwrap();
    let w = flat.force_n[1].abs().max(1.0);
    for a in 0..2 {
        assert!((cup.reaction.force_n[a] - flat.force_n[a]).abs() < 1e-7 * w, "{cup:?} {flat:?}");
    }
    assert!((cup.reaction.moment_nm[2] - flat.moment_nm).abs() < 1e-7 * w, "{cup:?} {flat:?}");
}

/// On a free front joint on a wall, a floor too high for the body to hang
/// straight down stops the swing: it ends leaning on the floor, at rest
/// about the joint (the floor's forces' moment balancing gravity's), the
/// whole body in balance and the unit hanging free.
#[test]
fn the_swing_on_a_free_front_joint_ends_on_the_floor() {
    let robot = Robot::builtin();
    let (scene, plate, centre) = wall_and_floor(0.12);
    let body = Body3::from_robot(&robot, [0.25, 0.22, 0.27]).unwrap();
    let hold = Hold3::FrontPivot(Pose3 { point_m: front_tip(&robot, centre, &plate), frame: plate });
    let held = stance3::solve_in(&robot, &body, hold, &scene, &Solver::default()).unwrap();
    check(&robot, &held, &scene);
    let eq = &held.equilibrium;
    assert!(eq.contacts.iter().any(|c| c.row.solid == 1), "nothing rests on the floor");
    let cup = held.front.as_ref().unwrap();
    let w = cup.reaction.force_n[1] + eq.contacts.iter().map(|c| c.force_n * c.row.plane.normal[1]).sum::<f64>();
    let about = dot(cup.reaction.moment_nm, cup.normal);
    let turn = held.pivot_turn_rad.unwrap();
    eprintln!(
        "swing onto a floor: turned {turn:.6} rad, {} contacts, moment about the joint {about:.2e} N m (weight {w:.4} N)",
        eq.contacts.len()
    );
    assert!(about.abs() < 1e-9 * w * 0.25, "{about}");
    // It swung down, but the floor stopped it short of hanging straight.
    let (mass, first) = held.body.first_moment(&eq.frames, robot.unit_mass_kg(held.body.tube_lengths()));
    let com = scale(1.0 / mass, first);
    assert!(turn > 0.0 && (com[0] - centre[0]).abs() > 1e-3, "{turn} {com:?}");
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
        frame: leech::geom3::exp([0.0, 0.2, 0.0]),
    };
    let scene = Scene3::new("floor and block", vec![floor.solids[0].clone(), block]).unwrap();
    let held = stance3::solve_in(&robot, &body, Hold3::Rear(AsBuilt), &scene, &Solver::default()).unwrap();
    check(&robot, &held, &scene);
    assert!(held.equilibrium.contacts.iter().any(|c| c.row.solid == 1), "nothing rests on the block");
}

/// Both cups holding on a floor: the body along it (clamp angle 0) rests on
/// it held at the rear; the front cup then holds on the floor, level, 3 cm
/// back from where that endpoint rests: the loop arches and sags onto the
/// floor, every contact pushing and touching, the cups and the floor
/// carrying the whole body, the front hold where asked. Solids out of reach
/// change nothing.
#[test]
fn both_cups_hold_a_body_resting_on_a_floor() {
    let robot = flat();
    let solver = Solver::default();
    for lengths in [[0.3, 0.28, 0.28], [0.3, 0.27, 0.29]] {
        let (rear, floor) = on_floor(&robot, lengths);
        assert!(!rear.equilibrium.contacts.is_empty(), "{lengths:?}: the rear-held body does not rest on the floor");
        let end = rear.body.endpoint(&rear.equilibrium.frames);
        // The cup's centre on the floor: tube 1's tip `c + front_offset` above it.
        let lift = robot.body.tip_spacing_m + robot.cup.front_offset_m;
        let tip_m = [end[0] - 0.03, rear.body.rear_cup_centre(&robot)[1] + lift, 0.0];
        let hold = Hold3::Both { rear: AsBuilt, front: Pose3 { point_m: tip_m, frame: rear.body.base_frame() } };
        let held = stance3::solve_in(&robot, &rear.body, hold, &floor, &solver).unwrap();
        check(&robot, &held, &floor);
        let eq = &held.equilibrium;
        assert!(!eq.contacts.is_empty(), "{lengths:?}: the loop does not rest on the floor");
        let end = held.body.endpoint(&eq.frames);
        assert!((0..3).all(|a| (end[a] - tip_m[a]).abs() < 1e-11), "{lengths:?}: {end:?} {tip_m:?}");
        let force: f64 = eq.contacts.iter().map(|c| c.force_n).sum();
        let front = held.front.as_ref().unwrap();
        eprintln!(
            "both cups on a floor, {lengths:?}: {} contacts, {force:.6} N, front cup {:?} N, safety {:.3}",
            eq.contacts.len(),
            front.reaction.force_n,
            front.verdict.safety_factor
        );
        let far = Scene3::new("far", vec![Solid3::HalfSpace { point_m: [0.0, -50.0, 0.0], normal: [0.0, 1.0, 0.0] }]);
        let among = stance3::solve_in(&robot, &rear.body, hold, &far.unwrap(), &solver).unwrap();
        let alone = stance3::solve(&robot, &rear.body, hold, &solver).unwrap();
        assert!(among.equilibrium.contacts.is_empty());
        for i in 0..3 {
            let a = alone.body.points(&alone.equilibrium.frames, i);
            let b = among.body.points(&among.equilibrium.frames, i);
            for (p, q) in a.iter().zip(&b) {
                assert!((0..3).all(|k| (p[k] - q[k]).abs() < 1e-9), "{lengths:?}: far solids moved {p:?} to {q:?}");
            }
        }
    }
}
