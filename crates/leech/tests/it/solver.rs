//! The solver's contract: honest status, bounded work, warm starts.

use leech::prelude::*;
use leech::statics::Scratch;

#[test]
fn too_few_iterations_is_an_error_not_a_shape() {
    let body = Robot::builtin().body(0.3, 0.2).unwrap();
    let solver = Solver::new(SolverOptions { max_iterations: 3, ..SolverOptions::default() });
    match body.solve(&solver) {
        Err(SolveError::NotConverged { iterations, residual, .. }) => {
            assert!(iterations <= 3);
            assert!(residual > 0.0);
        }
        other => panic!("expected NotConverged, got {other:?}"),
    }
}

#[test]
fn time_limit_is_honoured() {
    let mut robot = Robot::builtin();
    robot.tube.joint_stiffness_nm_per_rad = 50.0 * 0.001 * 9.81 * 0.01;
    let body = robot.body(0.15, 0.15).unwrap();
    let solver = Solver::new(SolverOptions { time_limit: Some(std::time::Duration::ZERO), ..SolverOptions::default() });
    assert!(matches!(body.solve(&solver), Err(SolveError::TimeLimit { .. })));
}

#[test]
fn warm_start_from_the_solution_stays_there() {
    let body = Robot::builtin().body(0.27, 0.22).unwrap();
    let solver = Solver::default();
    let eq = body.solve(&solver).unwrap();
    let mut ws = Scratch::for_system(&body);
    let again = body.solve_from(&solver, &eq.q, &mut ws).unwrap();
    assert!(again.iterations <= 1);
    for (a, b) in eq.q.iter().zip(&again.q) {
        assert!((a - b).abs() < 1e-10);
    }
    // From a neighbouring shape (as a sweep would) it converges to the same one.
    let neighbour = Robot::builtin().body(0.27, 0.22).unwrap();
    let perturbed: Vec<f64> = eq.q.iter().enumerate().map(|(i, x)| x + 1e-3 * (i as f64).sin()).collect();
    let warm = neighbour.solve_from(&solver, &perturbed, &mut ws).unwrap();
    for (a, b) in eq.q.iter().zip(&warm.q) {
        assert!((a - b).abs() < 1e-9);
    }
}

#[test]
fn bad_warm_start_is_rejected() {
    let body = Robot::builtin().body(0.1, 0.1).unwrap();
    let mut ws = Scratch::for_system(&body);
    let solver = Solver::default();
    assert!(matches!(body.solve_from(&solver, &[0.0; 3], &mut ws), Err(SolveError::BadStart { .. })));
    let mut q = body.straight();
    q[2] = f64::NAN;
    assert!(matches!(body.solve_from(&solver, &q, &mut ws), Err(SolveError::BadStart { .. })));
}

/// Angles are continuous, never wrapped: a clamp at 350 deg gives link angles
/// near 6.1 rad, and the parallel row of the weld holds exactly.
#[test]
fn angles_are_not_wrapped() {
    let mut robot = Robot::builtin();
    robot.world.base_angle_deg = 350.0;
    let body = robot.body(0.2, 0.15).unwrap();
    let eq = body.solve(&Solver::default()).unwrap();
    assert!(eq.q.iter().all(|phi| *phi > 4.0 && *phi < 8.0), "{:?}", eq.q);
    let (qa, qb) = body.split(&eq.q);
    assert_eq!(qa.last(), qb.last());
    // The same robot rotated by a full turn has the same shape, shifted by 2 pi.
    robot.world.base_angle_deg = -10.0;
    let turned = robot.body(0.2, 0.15).unwrap();
    let other = turned.solve(&Solver::default()).unwrap();
    for (a, b) in eq.q.iter().zip(&other.q) {
        assert!((a - b - 2.0 * std::f64::consts::PI).abs() < 1e-9);
    }
}

#[test]
fn every_solution_satisfies_its_equations() {
    let robot = Robot::builtin();
    for (la, lb) in [(0.05, 0.3), (0.3, 0.05), (0.123, 0.2345), (0.3, 0.3)] {
        let body = robot.body(la, lb).unwrap();
        let eq = body.solve(&Solver::default()).unwrap();
        assert!(eq.stable && eq.residual < 1e-10);
        assert!(body.constraints(&eq.q).iter().all(|c| c.abs() < 1e-12));
        assert!((eq.energy - body.energy(&eq.q)).abs() < 1e-12);
    }
}
