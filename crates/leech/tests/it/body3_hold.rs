//! The rear cup's hold in 3D: its reaction against the whole body's
//! balance, against the planar stance where the body is planar, and the 3D
//! cup verdict.

use leech::body3::Body3;
use leech::geom3::{axpy, cross, dot, exp, mul, rot_z, scale};
use leech::hold::{AsBuilt, Hold3, Pose3};
use leech::prelude::*;
use leech::stance::{Hold, Pose};
use leech::stance3;
use leech::stance3::place3::front_tip;
use leech::stance3::{verdict3, Held3};

/// The whole body's balance: weight `(0, g M, 0)` and, about `c`, the
/// moment `(X - M c) x (0, g, 0)` with `X` the first moment of every mass
/// (links, payload, driving unit): no multiplier and no spring enters it.
fn balance(body: &Body3, eq: &leech::stance3::Equilibrium3, unit_mass: f64, c: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let g = body.gravity();
    let (mass, first) = body.first_moment(&eq.frames, unit_mass);
    ([0.0, g * mass, 0.0], cross(axpy(-mass, c, first), [0.0, g, 0.0]))
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(12))]

    /// The reaction from the forces and spring moments at the roots equals
    /// the whole body's balance, turning bodies included.
    #[test]
    fn rear_reaction_balances_the_whole_body(
        l1 in 0.08f64..0.30, l2 in 0.08f64..0.30, l3 in 0.08f64..0.30, angle in -180.0f64..180.0,
    ) {
        let robot = Robot::builtin().with_base_angle(angle).unwrap();
        let body = Body3::from_robot(&robot, [l1, l2, l3]).unwrap();
        let eq = body.solve(&Solver::default()).unwrap();
        let cup = body.rear_cup(&robot, &eq).unwrap();
        let (force, moment) = balance(&body, &eq, robot.unit_mass_kg(body.tube_lengths()), cup.centre_m);
        let w = force[1];
        for a in 0..3 {
            proptest::prop_assert!((cup.reaction.force_n[a] - force[a]).abs() < 1e-9 * w, "{:?} vs {:?}", cup.reaction.force_n, force);
            proptest::prop_assert!(
                (cup.reaction.moment_nm[a] - moment[a]).abs() < 1e-9 * w * 0.3,
                "{:?} vs {:?}", cup.reaction.moment_nm, moment
            );
        }
    }
}

/// With `L2 = L3`, `b = c` and the planar equilibrium a 3D minimum, the
/// rear cup equals the planar stance's: centre, force, moment (about z;
/// none about x or y) and verdict.
#[test]
fn rear_cup_equals_the_planar_stance() {
    let mut robot = Robot::builtin();
    robot.body.tip_spacing_m = robot.body.base_spacing_m;
    let solver = Solver::default();
    let mut checked = 0;
    for (angle, l1, l23) in [(90.0, 0.25, 0.22), (0.0, 0.20, 0.18), (30.0, 0.12, 0.16), (-60.0, 0.28, 0.24)] {
        let robot = robot.with_base_angle(angle).unwrap();
        let body = Body3::from_robot(&robot, [l1, l23, l23]).unwrap();
        let eq = body.solve(&solver).unwrap();
        let root = body.tube(0).root();
        let pose = Pose { point_m: [root[0], root[1]], angle_rad: f64::to_radians(angle) };
        let held = leech::stance::solve(&robot, [l1, l23], Hold::Rear(pose), &solver).unwrap();
        // The rear hold's path is the clamped body's.
        let planar_eq = held.body.solve(&solver).unwrap();
        let d = leech::stance3::planar::compare(&body, &eq, &held.body, &planar_eq);
        assert!(d.max_point_m < 1e-9, "{angle}: not the planar shape {d:?}");
        let cup = body.rear_cup(&robot, &eq).unwrap();
        let planar = held.cups(&robot).unwrap().0.unwrap();
        let w = planar.force_n[1];
        for a in 0..2 {
            assert!((cup.centre_m[a] - planar.centre_m[a]).abs() < 1e-12, "{angle}: {cup:?} {planar:?}");
            assert!((cup.reaction.force_n[a] - planar.force_n[a]).abs() < 1e-9 * w, "{angle}: {cup:?} {planar:?}");
            assert!(cup.reaction.moment_nm[a].abs() < 1e-9 * w);
        }
        assert!(cup.centre_m[2].abs() < 1e-12 && cup.reaction.force_n[2].abs() < 1e-9 * w);
        assert!((cup.reaction.moment_nm[2] - planar.moment_nm).abs() < 1e-9 * w, "{angle}: {cup:?} {planar:?}");
        let (a, b) = (cup.verdict.safety_factor, planar.verdict.safety_factor);
        assert!((a - b).abs() < 1e-9 * b && cup.verdict.holds == planar.verdict.holds, "{angle}: {a} vs {b}");
        checked += 1;
    }
    assert_eq!(checked, 4);
}

/// The 3D verdict: in-plane loads give the planar verdict; a twist about
/// the normal adds `|M . n| / R` to the shear; a tilt is peel; bad input
/// names the field.
#[test]
fn the_3d_verdict_reduces_to_the_planar_one() {
    let cup = Robot::builtin().cup;
    let radius = 0.5 * cup.diameter_m;
    let (force, moment, normal) = ([1.5, -4.0], 0.02, [0.6, 0.8]);
    let planar = leech::cup::verdict(&cup, force, moment, normal).unwrap();
    let ours = verdict3(&cup, [force[0], force[1], 0.0], [0.0, 0.0, moment], [normal[0], normal[1], 0.0]).unwrap();
    for (a, b) in [
        (ours.safety_factor, planar.safety_factor),
        (ours.shear_n, planar.shear_n),
        (ours.normal_pull_n, planar.normal_pull_n),
        (ours.peel_moment_nm, planar.peel_moment_nm),
    ] {
        assert!((a - b).abs() < 1e-12 * b.abs().max(1.0), "{a} vs {b}");
    }
    // A pure twist about the normal: shear |M|/R, no peel.
    let n = [0.0, 0.0, 1.0];
    let twist = verdict3(&cup, [0.0; 3], scale(0.01, n), n).unwrap();
    assert!((twist.shear_n - 0.01 / radius).abs() < 1e-15 && twist.peel_moment_nm == 0.0);
    // A tilt about a direction in the face: peel, no shear.
    let tilt = verdict3(&cup, [0.0; 3], [0.01, -0.02, 0.0], n).unwrap();
    assert!(
        tilt.shear_n == 0.0 && (tilt.peel_moment_nm - dot([0.01, -0.02, 0.0], [0.01, -0.02, 0.0]).sqrt()).abs() < 1e-15
    );
    let err = verdict3(&cup, [0.0; 3], [0.0; 3], [0.0, 0.0, 2.0]).unwrap_err().to_string();
    assert!(err.contains("surface normal") && err.contains('2'), "{err}");
    let err = verdict3(&cup, [f64::NAN, 0.0, 0.0], [0.0; 3], n).unwrap_err().to_string();
    assert!(err.contains("cup force"), "{err}");
}

/// What the driving unit of a body held at the front needs from outside
/// to stay in balance (force N, moment N m about its centre): the rear
/// reaction from the roots' forces and spring moments, less the front cup's
/// force, which reaches the unit through tube 1's root (tube 1's balance).
/// Zero when the unit hangs free.
pub(crate) fn unit_imbalance(held: &leech::stance3::Held3, unit_mass: f64) -> ([f64; 3], [f64; 3]) {
    let about = held.body.unit_centre();
    let rear = held.body.rear_reaction(&held.equilibrium, unit_mass, about);
    let front = held.front.as_ref().unwrap().reaction.force_n;
    let arm = axpy(-1.0, about, held.body.tube(0).root());
    (axpy(-1.0, front, rear.force_n), axpy(-1.0, cross(arm, front), rear.moment_nm))
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(8))]

    /// Held at the front, the driving unit hangs free: the forces and spring
    /// moments at the roots balance its weight (the rear reaction computed
    /// as for the rear hold is zero), the plate is where the hold put it, and
    /// the front cup carries the whole robot.
    #[test]
    fn the_driving_unit_hangs_free_from_the_front_cup(
        l1 in 0.10f64..0.28, l2 in 0.10f64..0.28, l3 in 0.10f64..0.28,
        axis in proptest::collection::vec(-1.0f64..1.0, 3), turn in -2.0f64..2.0,
    ) {
        let robot = Robot::builtin();
        let body = Body3::from_robot(&robot, [l1, l2, l3]).unwrap();
        let norm = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt().max(1e-3);
        let plate = leech::geom3::exp(scale(turn / norm, [axis[0], axis[1], axis[2]]));
        let tip = [0.3, -0.1, 0.2];
        let held = stance3::solve(&robot, &body, Hold3::Front(Pose3 { point_m: tip, frame: plate }), &Solver::default()).unwrap();
        let eq = &held.equilibrium;
        proptest::prop_assert!(eq.stable && eq.residual < 1e-10 && held.rear.is_none());
        let end = held.body.endpoint(&eq.frames);
        let frame = held.body.plate_frame(&eq.frames);
        for a in 0..3 {
            proptest::prop_assert!((end[a] - tip[a]).abs() < 1e-12, "{:?}", end);
            for b in 0..3 {
                proptest::prop_assert!((frame[a][b] - plate[a][b]).abs() < 1e-12);
            }
        }
        let md = robot.unit_mass_kg(held.body.tube_lengths());
        let front = held.front.clone().unwrap();
        let w = front.reaction.force_n[1];
        let (force, moment) = unit_imbalance(&held, md);
        for a in 0..3 {
            proptest::prop_assert!(force[a].abs() < 1e-9 * w && moment[a].abs() < 1e-9 * w * 0.3, "{:?} {:?}", force, moment);
        }
        let (force, moment) = balance(&held.body, eq, md, front.centre_m);
        for a in 0..3 {
            proptest::prop_assert!((front.reaction.force_n[a] - force[a]).abs() < 1e-12 * w);
            proptest::prop_assert!((front.reaction.moment_nm[a] - moment[a]).abs() < 1e-9 * w * 0.3);
        }
    }
}

/// With `L2 = L3`, `b = c` and an in-plane front hold, the hanging body is
/// the planar stance's: the driving unit's pose, and the front cup's
/// reaction and verdict.
#[test]
fn front_hold_equals_the_planar_stance() {
    let mut robot = Robot::builtin();
    robot.body.tip_spacing_m = robot.body.base_spacing_m;
    let solver = Solver::default();
    for (l1, l23, point, angle) in
        [(0.25, 0.22, [0.3, 0.2], 90.0), (0.18, 0.20, [0.0, 0.5], 180.0), (0.12, 0.15, [0.1, 0.0], 120.0)]
    {
        let pose = Pose::from_deg(point, angle);
        let planar = leech::stance::solve(&robot, [l1, l23], Hold::Front(pose), &solver).unwrap();
        let body = Body3::from_robot(&robot, [l1, l23, l23]).unwrap();
        let hold = Hold3::Front(Pose3 { point_m: [point[0], point[1], 0.0], frame: rot_z(pose.angle_rad) });
        let held = stance3::solve(&robot, &body, hold, &solver).unwrap();
        let root = held.body.tube(0).root();
        let base = held.body.base_frame();
        let unit_angle = base[1][0].atan2(base[0][0]);
        let gap = (root[0] - planar.unit.point_m[0]).hypot(root[1] - planar.unit.point_m[1]);
        let turn = (unit_angle - planar.unit.angle_rad + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        assert!(
            gap < 1e-9 && turn.abs() < 1e-9 && root[2].abs() < 1e-12,
            "{l1} {l23}: {root:?} {unit_angle} vs {:?}",
            planar.unit
        );
        let cup = held.front.clone().unwrap();
        let flat = planar.cups(&robot).unwrap().1.unwrap();
        let w = flat.force_n[1];
        for a in 0..2 {
            assert!((cup.centre_m[a] - flat.centre_m[a]).abs() < 1e-12);
            assert!((cup.reaction.force_n[a] - flat.force_n[a]).abs() < 1e-9 * w, "{cup:?} {flat:?}");
        }
        assert!((cup.reaction.moment_nm[2] - flat.moment_nm).abs() < 1e-9 * w, "{cup:?} {flat:?}");
        let (a, b) = (cup.verdict.safety_factor, flat.verdict.safety_factor);
        assert!((a - b).abs() < 1e-9 * b, "{a} vs {b}");
    }
}

/// The sideways maneuver's swing (paper Fig. 11): on a vertical wall (its
/// outward normal `+z`) the rear cup lets go with the body lying
/// horizontally from the front cup; on a free joint about the wall's normal
/// the body swings down until the centre of mass hangs straight below the
/// pivot, at rest (no moment about the joint) and stable.
#[test]
fn the_body_swings_below_a_free_front_joint() {
    let robot = Robot::builtin();
    let solver = Solver::default();
    // The plate along +x, its y axis (the face's normal) out of the wall.
    let plate = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]];
    let centre = [0.5, 1.0, 0.0];
    for lengths in [[0.20, 0.20, 0.20], [0.25, 0.22, 0.27]] {
        let body = Body3::from_robot(&robot, lengths).unwrap();
        let held = stance3::solve(
            &robot,
            &body,
            Hold3::FrontPivot(Pose3 { point_m: front_tip(&robot, centre, &plate), frame: plate }),
            &solver,
        )
        .unwrap();
        let eq = &held.equilibrium;
        assert!(eq.stable && eq.residual < 1e-10, "{lengths:?}");
        let cup = held.front.clone().unwrap();
        assert!(cup.centre_m.iter().zip(centre).all(|(a, b)| (a - b).abs() < 1e-12), "{:?}", cup.centre_m);
        assert!((cup.normal[2] - 1.0).abs() < 1e-12);
        let w = cup.reaction.force_n[1];
        assert!(cup.reaction.moment_nm[2].abs() < 1e-9 * w * lengths[0], "{:?}", cup.reaction);
        let (mass, first) = held.body.first_moment(&eq.frames, robot.unit_mass_kg(held.body.tube_lengths()));
        let com = scale(1.0 / mass, first);
        assert!((com[0] - centre[0]).abs() < 1e-9, "{lengths:?}: centre of mass {com:?}");
        assert!(com[1] < centre[1] - 0.05, "{lengths:?}: centre of mass {com:?} not below the pivot");
        // It swung down (counter-clockwise about the wall's normal, the unit
        // starting on the -x side), and the swing released energy: the
        // front hold without the joint, where it started, is higher.
        let turn = held.pivot_turn_rad.unwrap();
        let tip = axpy(robot.body.tip_spacing_m + robot.cup.front_offset_m, [0.0, 0.0, 1.0], centre);
        let start = stance3::solve(&robot, &body, Hold3::Front(Pose3 { point_m: tip, frame: plate }), &solver).unwrap();
        assert!(
            turn > 0.0 && eq.energy < start.equilibrium.energy,
            "{lengths:?}: turned {turn}, {} vs {}",
            eq.energy,
            start.equilibrium.energy
        );
        let (force, moment) = unit_imbalance(&held, robot.unit_mass_kg(held.body.tube_lengths()));
        assert!(force.iter().chain(&moment).all(|x| x.abs() < 1e-8 * w), "{force:?} {moment:?}");
    }
    let skew = [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let body = Body3::from_robot(&robot, [0.2; 3]).unwrap();
    let err = stance3::solve(
        &robot,
        &body,
        Hold3::FrontPivot(Pose3 { point_m: front_tip(&robot, centre, &skew), frame: skew }),
        &solver,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("front pivot plate frame"), "{err}");
}

/// The rear-held body of `robot` at `lengths`, and `Hold3::Both` at the
/// target moved from its endpoint `inward` (m) towards tube 1's root (the
/// slack that keeps a target in reach) and by `shift` (m), its plate turned
/// by `turn` (rotation vector, world axes).
fn both_from_rear(
    robot: &Robot,
    lengths: [f64; 3],
    inward: f64,
    shift: [f64; 3],
    turn: [f64; 3],
) -> (Body3, Held3, Hold3) {
    let body = Body3::from_robot(robot, lengths).unwrap();
    let rear = stance3::solve(robot, &body, Hold3::Rear(AsBuilt), &Solver::default()).unwrap();
    let frames = &rear.equilibrium.frames;
    let end = body.endpoint(frames);
    let chord = axpy(-1.0, body.tube(0).root(), end);
    let tip_m = axpy(-inward / dot(chord, chord).sqrt(), chord, axpy(1.0, shift, end));
    let plate = mul(&exp(turn), &body.plate_frame(frames));
    (body, rear, Hold3::Both { rear: AsBuilt, front: Pose3 { point_m: tip_m, frame: plate } })
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]

    /// Both cups holding, a target off where the rear-held endpoint is and
    /// a tilted plate: the front hold is where asked, the equilibrium a
    /// stable one, and the two reactions carry the whole robot in force and
    /// moment (the masses alone, no multiplier or spring).
    #[test]
    fn both_cups_carry_the_whole_body(
        l1 in 0.10f64..0.28, l2 in 0.10f64..0.28, l3 in 0.10f64..0.28, angle in -180.0f64..180.0,
        inward in 0.004f64..0.01, shift in proptest::collection::vec(-0.005f64..0.005, 3),
        turn in proptest::collection::vec(-0.1f64..0.1, 3),
    ) {
        let robot = Robot::builtin().with_base_angle(angle).unwrap();
        let (shift, turn) = ([shift[0], shift[1], shift[2]], [turn[0], turn[1], turn[2]]);
        let (body, _, hold) = both_from_rear(&robot, [l1, l2, l3], inward, shift, turn);
        let held = stance3::solve(&robot, &body, hold, &Solver::default()).unwrap();
        let Hold3::Both { rear: AsBuilt, front: Pose3 { point_m: tip_m, frame: plate } } = hold else { unreachable!() };
        let eq = &held.equilibrium;
        proptest::prop_assert!(eq.stable && eq.residual < 1e-10, "{} {}", eq.stable, eq.residual);
        let end = held.body.endpoint(&eq.frames);
        proptest::prop_assert!((0..3).all(|a| (end[a] - tip_m[a]).abs() < 1e-11), "{:?} {:?}", end, tip_m);
        let frame = held.body.plate_frame(&eq.frames);
        proptest::prop_assert!(leech::body3::body3::angle_between(&frame, &plate) < 1e-11);
        let (rear, front) = (held.rear.clone().unwrap(), held.front.clone().unwrap());
        let about = rear.centre_m;
        let (force, moment) = balance(&held.body, eq, robot.unit_mass_kg(held.body.tube_lengths()), about);
        let w = force[1];
        // The front cup's moment moved to the rear cup's centre.
        let front_moment = axpy(1.0, cross(axpy(-1.0, about, front.centre_m), front.reaction.force_n), front.reaction.moment_nm);
        let total_force = axpy(1.0, rear.reaction.force_n, front.reaction.force_n);
        let total_moment = axpy(1.0, rear.reaction.moment_nm, front_moment);
        let arm = l1.max(l2).max(l3);
        for a in 0..3 {
            proptest::prop_assert!((total_force[a] - force[a]).abs() < 1e-8 * w, "{:?} vs {:?}", total_force, force);
            proptest::prop_assert!((total_moment[a] - moment[a]).abs() < 1e-8 * w * arm, "{:?} vs {:?}", total_moment, moment);
        }
        // The loop carries load: the front cup takes a share.
        proptest::prop_assert!(front.reaction.force_n.iter().any(|f| f.abs() > 1e-6 * w));
    }
}

/// The front hold asked where the rear-held endpoint already is: the shape
/// stays the rear-held one and the front cup carries nothing.
#[test]
fn both_holds_at_the_free_endpoint_change_nothing() {
    let robot = Robot::builtin();
    for lengths in [[0.25, 0.28, 0.22], [0.18, 0.18, 0.18]] {
        let (body, rear, hold) = both_from_rear(&robot, lengths, 0.0, [0.0; 3], [0.0; 3]);
        let held = stance3::solve(&robot, &body, hold, &Solver::default()).unwrap();
        for i in 0..3 {
            for (p, q) in
                held.body.points(&held.equilibrium.frames, i).iter().zip(body.points(&rear.equilibrium.frames, i))
            {
                let d = axpy(-1.0, q, *p);
                assert!(dot(d, d).sqrt() < 1e-9, "{lengths:?}: tube {i} moved {d:?}");
            }
        }
        let front = held.front.clone().unwrap();
        let (r, r0) = (held.rear.clone().unwrap(), rear.rear.clone().unwrap());
        let w = r0.reaction.force_n[1];
        assert!(
            front.reaction.force_n.iter().chain(&front.reaction.moment_nm).all(|x| x.abs() < 1e-11 * w),
            "{front:?}"
        );
        assert!((0..3).all(|a| (r.reaction.force_n[a] - r0.reaction.force_n[a]).abs() < 1e-11 * w));
        assert!(front.verdict.holds && r.verdict.holds);
    }
}

/// With `L2 = L3`, `b = c` and an in-plane target, both cups holding is the
/// planar stance's both-hold: every point, and each cup's reaction and
/// verdict.
#[test]
fn both_holds_equal_the_planar_stance() {
    let mut robot = Robot::builtin();
    robot.body.tip_spacing_m = robot.body.base_spacing_m;
    let solver = Solver::default();
    for (angle, l1, l23, inward, shift, turn) in [
        (90.0, 0.25, 0.22, 0.005, [0.004, -0.006], 0.05),
        (0.0, 0.20, 0.18, 0.004, [-0.003, 0.01], -0.1),
        (30.0, 0.14, 0.16, 0.003, [0.0, 0.0], 0.08),
    ] {
        let robot = robot.with_base_angle(angle).unwrap();
        let (body, rear3, hold) =
            both_from_rear(&robot, [l1, l23, l23], inward, [shift[0], shift[1], 0.0], [0.0, 0.0, turn]);
        let Hold3::Both { rear: AsBuilt, front: Pose3 { point_m: tip_m, frame: plate } } = hold else { unreachable!() };
        let held = stance3::solve(&robot, &body, hold, &solver).unwrap();
        let root = body.tube(0).root();
        let rear = Pose { point_m: [root[0], root[1]], angle_rad: f64::to_radians(angle) };
        let front = Pose { point_m: [tip_m[0], tip_m[1]], angle_rad: plate[1][0].atan2(plate[0][0]) };
        let planar = leech::stance::solve(&robot, [l1, l23], Hold::Both { rear, front }, &solver).unwrap();
        assert!(rear3.equilibrium.stable && held.equilibrium.stable);
        // The planar chains' angles, without the driving unit's pose.
        let mut chains = planar.equilibrium.clone();
        chains.q.truncate(planar.body.dim());
        let d = leech::stance3::planar::compare(&held.body, &held.equilibrium, &planar.body, &chains);
        assert!(d.max_point_m < 1e-9 && d.out_of_plane_m < 1e-12, "{angle}: not the planar shape {d:?}");
        let (rear_flat, front_flat) = planar.cups(&robot).unwrap();
        for (cup, flat) in [(&held.rear, rear_flat), (&held.front, front_flat)] {
            let (cup, flat) = (cup.clone().unwrap(), flat.unwrap());
            let w = planar.weight_n;
            for a in 0..2 {
                assert!((cup.centre_m[a] - flat.centre_m[a]).abs() < 1e-9, "{angle}: {cup:?} {flat:?}");
                assert!((cup.reaction.force_n[a] - flat.force_n[a]).abs() < 1e-7 * w, "{angle}: {cup:?} {flat:?}");
                assert!(cup.reaction.moment_nm[a].abs() < 1e-7 * w * l1, "{angle}: {cup:?}");
            }
            assert!(cup.reaction.force_n[2].abs() < 1e-7 * w, "{angle}: {cup:?}");
            assert!((cup.reaction.moment_nm[2] - flat.moment_nm).abs() < 1e-7 * w * l1, "{angle}: {cup:?} {flat:?}");
            let (a, b) = (cup.verdict.safety_factor, flat.verdict.safety_factor);
            assert!((a - b).abs() < 1e-7 * b && cup.verdict.holds == flat.verdict.holds, "{angle}: {a} vs {b}");
        }
    }
}

/// Both cups holding from a straight rear-held body (equal lengths): a
/// tip pushed towards the driving unit and a plate turned can only be
/// reached by buckling, where the tip rows along tube 1 have no Jacobian.
/// Nearly straight (the built-in robot, `b != c`) and exactly straight
/// (`b = c`, standing up): every target of a grid is held (see
/// [`held_both`]); the exactly straight body reports the buckling it went
/// through.
#[test]
fn both_holds_start_from_a_straight_body() {
    let mut even = Robot::builtin();
    even.body.tip_spacing_m = even.body.base_spacing_m;
    for (robot, straight) in [(Robot::builtin(), false), (even, true)] {
        // Tube 1's tip 0 to 8 cm aside and 5 to 9 cm below where the
        // upright body's reaches, the plate turned 45 or 80 deg from upright.
        for x in [0.0, 0.04, 0.08] {
            for y in [0.16, 0.20] {
                for degrees in [10.0, 45.0] {
                    let held = held_both(&robot, [0.25; 3], [x, y, 0.0], degrees);
                    let events = &held.equilibrium.events;
                    let buckled = events.iter().any(|e| matches!(e, Event::Bifurcation { .. }));
                    assert!(buckled || !straight, "({x}, {y}) at {degrees} deg: {events:?}");
                }
            }
        }
    }
}

/// Bent bodies whose both cups' path loses stability on the way (the tip
/// pushed straight down on an upright body): where no equilibrium is near
/// any more, the solver leaves along the softest mode and lands held.
#[test]
fn both_holds_leave_a_path_that_ends() {
    for (x, y, degrees) in [(0.04, 0.12, 90.0), (0.04, 0.16, 90.0), (-0.08, 0.12, 135.0)] {
        held_both(&Robot::builtin(), [0.25, 0.23, 0.23], [x, y, 0.0], degrees);
    }
}

/// `robot` at `lengths` held at the rear and at the front with tube 1's tip
/// at `tip_m` and the plate at `degrees` about z: the equilibrium is
/// stable, held where asked, and the two cups carry the whole robot in
/// force and moment (the masses alone).
fn held_both(robot: &Robot, lengths: [f64; 3], tip_m: [f64; 3], degrees: f64) -> Held3 {
    let body = Body3::from_robot(robot, lengths).unwrap();
    let plate = rot_z(f64::to_radians(degrees));
    let case = format!("{lengths:?} {:?}, {tip_m:?} at {degrees} deg", robot.body);
    let held = stance3::solve(
        robot,
        &body,
        Hold3::Both { rear: AsBuilt, front: Pose3 { point_m: tip_m, frame: plate } },
        &Solver::default(),
    )
    .expect(&case);
    let eq = &held.equilibrium;
    assert!(eq.stable && eq.residual < 1e-10, "{case}: {} {}", eq.stable, eq.residual);
    let end = held.body.endpoint(&eq.frames);
    assert!((0..3).all(|a| (end[a] - tip_m[a]).abs() < 1e-11), "{case}: {end:?}");
    let frame = held.body.plate_frame(&eq.frames);
    assert!(leech::body3::body3::angle_between(&frame, &plate) < 1e-11, "{case}");
    let (rear, front) = (held.rear.clone().unwrap(), held.front.clone().unwrap());
    let (force, moment) = balance(&held.body, eq, robot.unit_mass_kg(held.body.tube_lengths()), rear.centre_m);
    let arm = cross(axpy(-1.0, rear.centre_m, front.centre_m), front.reaction.force_n);
    let reach = lengths[0].max(lengths[1]).max(lengths[2]);
    for a in 0..3 {
        let total_force = rear.reaction.force_n[a] + front.reaction.force_n[a];
        let total_moment = rear.reaction.moment_nm[a] + front.reaction.moment_nm[a] + arm[a];
        assert!((total_force - force[a]).abs() < 1e-8 * force[1], "{case}: force {a}");
        assert!((total_moment - moment[a]).abs() < 1e-8 * force[1] * reach, "{case}: moment {a}");
    }
    held
}

/// A target beyond tube 1's reach ends in an error (no stretched body);
/// a plate frame that is not a rotation or a tip that is not finite is
/// refused, naming the field.
#[test]
fn both_holds_refuse_what_cannot_be_held() {
    let robot = Robot::builtin();
    let body = Body3::from_robot(&robot, [0.2; 3]).unwrap();
    let solver = Solver::default();
    let far = Hold3::Both {
        rear: AsBuilt,
        front: Pose3 { point_m: [0.0, 0.3, 0.0], frame: rot_z(std::f64::consts::FRAC_PI_2) },
    };
    match stance3::solve(&robot, &body, far, &solver) {
        Err(leech::stance::StanceError::OutOfReach { distance_m, reach_m, .. }) => {
            assert!(distance_m > reach_m && (reach_m - 0.2).abs() < 1e-12, "{distance_m} {reach_m}")
        }
        other => panic!("{other:?}"),
    }
    let skew = [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let err = stance3::solve(
        &robot,
        &body,
        Hold3::Both { rear: AsBuilt, front: Pose3 { point_m: [0.0, 0.1, 0.0], frame: skew } },
        &solver,
    )
    .unwrap_err();
    let err = err.to_string();
    assert!(err.contains("both holds: front plate frame") && !err.contains('\n'), "{err}");
    let nan = Hold3::Both { rear: AsBuilt, front: Pose3 { point_m: [0.0, f64::NAN, 0.0], frame: rot_z(0.0) } };
    let err = stance3::solve(&robot, &body, nan, &solver).unwrap_err().to_string();
    assert!(err.contains("both holds: front tip (m)") && err.contains("NaN"), "{err}");
}
