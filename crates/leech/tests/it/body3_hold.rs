//! The rear cup's hold in 3D: its reaction against the whole body's
//! balance, against the planar stance where the body is planar, and the 3D
//! cup verdict.

use leech::body3::rotation::{axpy, cross, dot, scale};
use leech::body3::{verdict3, Body3};
use leech::prelude::*;
use leech::stance::{Hold, Pose};

/// The whole body's balance: weight `(0, g M, 0)` and, about `c`, the
/// moment `(X - M c) x (0, g, 0)` with `X` the first moment of every mass
/// (links, payload, driving unit): no multiplier and no spring enters it.
fn balance(body: &Body3, eq: &leech::body3::Equilibrium3, unit_mass: f64, c: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let g = body.gravity();
    let (mut mass, mut first) = (unit_mass, scale(unit_mass, body.unit_centre()));
    for i in 0..3 {
        let tube = body.tube(i);
        mass += tube.total_mass();
        first = axpy(tube.total_mass(), tube.root(), first);
        for (j, w) in tube.levers().iter().enumerate() {
            let r = body.frame(&eq.frames, i, j);
            first = axpy(*w, [r[0][0], r[1][0], r[2][0]], first);
        }
    }
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
        let (force, moment) = balance(&body, &eq, robot.driving_unit.mass_kg, cup.centre_m);
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
        let d = leech::body3::planar::compare(&body, &eq, &held.body, &planar_eq);
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
    assert!(tilt.shear_n == 0.0 && (tilt.peel_moment_nm - dot([0.01, -0.02, 0.0], [0.01, -0.02, 0.0]).sqrt()).abs() < 1e-15);
    let err = verdict3(&cup, [0.0; 3], [0.0; 3], [0.0, 0.0, 2.0]).unwrap_err().to_string();
    assert!(err.contains("surface normal") && err.contains('2'), "{err}");
    let err = verdict3(&cup, [f64::NAN, 0.0, 0.0], [0.0; 3], n).unwrap_err().to_string();
    assert!(err.contains("cup force"), "{err}");
}
