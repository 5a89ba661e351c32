//! Analytic limits and the paper's qualitative statements.

use super::chain;
use leech::prelude::*;

fn solve(body: &Body) -> Equilibrium {
    let eq = body.solve(&Solver::default()).expect("solves");
    assert!(eq.stable);
    eq
}

#[test]
fn equal_tubes_with_equal_spacings_are_straight_without_gravity() {
    let mut robot = Robot::builtin();
    robot.world.gravity_m_per_s2 = 0.0;
    robot.body.tip_spacing_m = robot.body.base_spacing_m;
    for angle in [0.0, 37.0, 90.0, 135.0] {
        robot.world.base_angle_deg = angle;
        let body = robot.body(0.237, 0.237).unwrap();
        let eq = solve(&body);
        for phi in &eq.q {
            assert!((phi - angle.to_radians()).abs() < 1e-12, "angle {phi} at clamp {angle}");
        }
    }
}

/// With g = 0 the shape is pure geometry: it does not depend on the masses,
/// and scaling the stiffness of both chains changes nothing.
#[test]
fn unloaded_body_is_bent_by_the_constraints_only() {
    let mut robot = Robot::builtin();
    robot.world.gravity_m_per_s2 = 0.0;
    let reference = solve(&robot.body(0.25, 0.20).unwrap());
    robot.tube.element_mass_kg *= 7.0;
    robot.tube.joint_stiffness_nm_per_rad *= 3.0;
    robot.body.payload_kg = 0.5;
    let body = robot.body(0.25, 0.20).unwrap();
    let other = solve(&body);
    for (a, b) in reference.q.iter().zip(&other.q) {
        assert!((a - b).abs() < 1e-9);
    }
    // Chain A longer than B: the body bends to the right (clockwise) of the clamp.
    assert!(body.endpoint_angle(&other.q) < 80f64.to_radians());
}

/// A large length difference has several unloaded shapes (docs/model.md
/// section 7.4): feeding from equal lengths lands on the low-energy one with chain A
/// bowing out (about 0.13 J for 30 + 20 elements), not on the tightly bent
/// one a constant-curvature guess converges to (about 0.19 J).
#[test]
fn feeding_picks_the_bowed_unloaded_shape() {
    let mut robot = Robot::builtin();
    robot.world.gravity_m_per_s2 = 0.0;
    let body = robot.body(0.30, 0.20).unwrap();
    let eq = solve(&body);
    assert!(eq.energy > 0.12 && eq.energy < 0.15, "energy {} J", eq.energy);
    // The bend is far less than the constant-curvature (LB - LA)/w = -3.4 rad.
    let bend = body.endpoint_angle(&eq.q) - 90f64.to_radians();
    assert!(bend < -0.5 && bend > -2.0, "bend {bend}");
}

/// The paper: short tubes barely move under gravity.
#[test]
fn short_tubes_barely_sag() {
    let robot = Robot::builtin();
    let mut unloaded = robot.clone();
    unloaded.world.gravity_m_per_s2 = 0.0;
    for (la, lb) in [(0.05, 0.05), (0.05, 0.045), (0.045, 0.05)] {
        let loaded = robot.body(la, lb).unwrap();
        let free = unloaded.body(la, lb).unwrap();
        let (p, q) = (loaded.endpoint(&solve(&loaded).q), free.endpoint(&solve(&free).q));
        let shift = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
        assert!(shift < 0.5e-3, "{la}/{lb}: endpoint moved {shift} m under gravity");
        assert!(shift > 0.0);
    }
    // ... while long ones move by centimetres.
    let long = robot.body(0.3, 0.25).unwrap();
    let free = unloaded.body(0.3, 0.25).unwrap();
    let (p, q) = (long.endpoint(&solve(&long).q), free.endpoint(&solve(&free).q));
    assert!(((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt() > 5e-3);
}

/// A vertical column under its own weight buckles at beta = rho g L^3 / EI =
/// 7.837 (Greenhill); the continuation brackets the bifurcation.
#[test]
fn vertical_tube_buckles_at_the_greenhill_load() {
    let n = 40;
    let beta = 16.0;
    let tube = chain(n, (n as f64).powi(3) / beta, 90.0, 0.0, Discretization::Midpoint);
    let eq = tube.solve(&Solver::default()).unwrap();
    let at = match eq.events.as_slice() {
        [Event::Bifurcation { at, side, .. }] => {
            assert_eq!(*side, "right");
            *at
        }
        other => panic!("expected one bifurcation, got {other:?}"),
    };
    let critical = at * beta;
    assert!((critical - 7.837).abs() < 0.02, "critical beta {critical}");
    // The documented side: the tip falls to the right of the clamp direction (+x here).
    assert!(tube.chain().tip(&eq.q)[0] > 0.0);
    // Below the critical load the straight column is kept.
    let stiff = chain(n, (n as f64).powi(3) / 6.0, 90.0, 0.0, Discretization::Midpoint);
    let eq = stiff.solve(&Solver::default()).unwrap();
    assert!(eq.events.is_empty());
    assert!(eq.q.iter().all(|phi| (phi - 90f64.to_radians()).abs() < 1e-12));
}

/// Equal tubes with b != c and weak springs meet a fold on the load path
/// (docs/model.md section 7.5): the solver reports the snap and lands on a stable
/// equilibrium far from the branch it left.
#[test]
fn weak_s_shaped_body_snaps_through() {
    let mut robot = Robot::builtin();
    robot.tube.joint_stiffness_nm_per_rad = 50.0 * 0.001 * 9.81 * 0.01;
    let body = robot.body(0.15, 0.15).unwrap();
    let eq = solve(&body);
    match eq.events.as_slice() {
        [Event::Snap { stage, at, jump_rad }] => {
            assert_eq!(*stage, "load");
            assert!(*at > 0.05 && *at < 0.6, "fold at {at} of g");
            assert!(*jump_rad > 0.5);
        }
        other => panic!("expected one snap, got {other:?}"),
    }
}

/// Scaling l, b, c by s with Pi and ms/m fixed gives the same angles
/// (docs/model.md section 8, paper Fig. 9), for one tube and for the body.
#[test]
fn shape_parameter_scaling_keeps_angles() {
    let base = Robot::builtin();
    let reference = solve(&base.body(0.24, 0.21).unwrap());
    let tube = base.cantilever(0.27, 0.004).unwrap();
    let tube_reference = tube.solve(&Solver::default()).unwrap();
    for s in [0.1, 0.37, 3.0, 10.0] {
        let r = base.scaled(s).unwrap();
        assert!((r.shape_parameter() - base.shape_parameter()).abs() < 1e-9 * base.shape_parameter());
        let body = r.body(0.24 * s, 0.21 * s).unwrap();
        let eq = solve(&body);
        for (a, b) in reference.q.iter().zip(&eq.q) {
            assert!((a - b).abs() < 1e-9, "scale {s}: {a} vs {b}");
        }
        let p = body.endpoint(&eq.q);
        let p0 = base.body(0.24, 0.21).unwrap().endpoint(&reference.q);
        assert!((p[0] - s * p0[0]).abs() < 1e-9 * s && (p[1] - s * p0[1]).abs() < 1e-9 * s);
        let scaled_tube = r.cantilever(0.27 * s, 0.004 * s).unwrap();
        let teq = scaled_tube.solve(&Solver::default()).unwrap();
        for (a, b) in tube_reference.q.iter().zip(&teq.q) {
            assert!((a - b).abs() < 1e-9, "tube, scale {s}: {a} vs {b}");
        }
    }
}

/// Setting the shape parameter scales the stiffness only.
#[test]
fn shape_parameter_sets_the_stiffness() {
    let robot = Robot::builtin().with_shape_parameter(250.0).unwrap();
    assert!((robot.shape_parameter() - 250.0).abs() < 1e-9);
    assert_eq!(robot.tube.element_mass_kg, Robot::builtin().tube.element_mass_kg);
    assert!(Robot::builtin().with_shape_parameter(-1.0).is_err());
    let mut weightless = Robot::builtin();
    weightless.world.gravity_m_per_s2 = 0.0;
    assert!(weightless.with_shape_parameter(100.0).is_err());
}

/// Shapes are continuous in the tube lengths, also where a tube crosses a
/// whole number of elements and a new (short, stiff) element appears.
#[test]
fn shapes_are_continuous_across_element_boundaries() {
    for d in [Discretization::Paper, Discretization::Midpoint] {
        let mut robot = Robot::builtin();
        robot.model.discretization = d;
        for (la, lb) in [(0.18, 0.11), (0.2, 0.25), (0.13, 0.13)] {
            let endpoint = |la: f64, lb: f64| {
                let body = robot.body(la, lb).unwrap();
                body.endpoint(&solve(&body).q)
            };
            let here = endpoint(la, lb);
            for (da, db) in [(1e-6, 0.0), (-1e-6, 0.0), (0.0, 1e-6), (0.0, -1e-6)] {
                let there = endpoint(la + da, lb + db);
                let moved = (there[0] - here[0]).hypot(there[1] - here[1]);
                assert!(moved < 2e-5, "{d:?} {la}+{da}, {lb}+{db}: moved {moved} m");
            }
        }
    }
}
