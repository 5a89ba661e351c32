//! The solver's contract: honest status, bounded work, warm starts.

use leech::budget::Deadline;
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
    let deadline = Deadline::after(std::time::Duration::ZERO);
    let solver = Solver::new(SolverOptions { deadline, ..SolverOptions::default() });
    assert!(matches!(body.solve(&solver), Err(SolveError::Stopped { .. })));
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

/// Scratch used for a longer body, then refitted (kept allocations, stale
/// values), solves exactly as fresh scratch does.
#[test]
fn refitted_scratch_solves_as_fresh_scratch() {
    let solver = Solver::default();
    let (long, short) = (Robot::builtin().body(0.30, 0.28).unwrap(), Robot::builtin().body(0.21, 0.17).unwrap());
    let fresh = short.solve_in(&solver, &mut Scratch::for_system(&short)).unwrap();
    let mut ws = Scratch::for_system(&long);
    long.solve_in(&solver, &mut ws).unwrap();
    assert!(!ws.fits(&short));
    ws.refit(&short);
    assert!(ws.fits(&short));
    let refitted = short.solve_in(&solver, &mut ws).unwrap();
    assert_eq!(fresh.q, refitted.q);
    assert_eq!(fresh.multipliers, refitted.multipliers);
    assert_eq!(fresh.iterations, refitted.iterations);
}

/// The tubes fed at `g = 0` for one stiffness are the fed state of every
/// other (the potential scales with `k`): loaded from it, a stiffer or softer
/// robot takes the same iterations and steps as its own default solve and
/// lands on its shape to rounding.
#[test]
fn a_fed_state_carries_over_to_another_stiffness() {
    let solver = Solver::default();
    let soft = Robot::builtin().with_shape_parameter(300.0).unwrap();
    for pi in [10.0, 1000.0, 10000.0] {
        let robot = Robot::builtin().with_shape_parameter(pi).unwrap();
        for (la, lb) in [(0.30, 0.20), (0.12, 0.25), (0.2, 0.2)] {
            let (from, body) = (soft.body(la, lb).unwrap(), robot.body(la, lb).unwrap());
            let mut ws = Scratch::for_system(&body);
            let fed = from.feed_in(&solver, &mut ws).unwrap();
            let carried = body.load_in(&solver, fed.for_stiffness(body.moment_scale()), &mut ws).unwrap();
            let own = body.solve_in(&solver, &mut ws).unwrap();
            assert_eq!((carried.iterations, carried.steps), (own.iterations, own.steps), "Pi {pi} at {la}, {lb}");
            assert_eq!(carried.stable, own.stable);
            let worst = carried.q.iter().zip(&own.q).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(worst < 1e-12, "Pi {pi} at {la}, {lb}: {worst:e} rad");
        }
    }
}

/// The softest robot's load passes through the stiffer robots' loaded
/// states (`k V + g U` at full gravity is `k_min V + (k_min / k) g U` scaled):
/// landed on at their gravity fractions, in order, each is the stiffer
/// robot's own default solve to the tolerance, and the load still ends on
/// the softest robot's own.
#[test]
fn the_softest_load_passes_through_the_stiffer_ones() {
    let solver = Solver::default();
    let pis = [10000.0, 1000.0, 300.0];
    let robots: Vec<Robot> = pis.iter().map(|pi| Robot::builtin().with_shape_parameter(*pi).unwrap()).collect();
    for (la, lb) in [(0.30, 0.20), (0.12, 0.25), (0.2, 0.2), (0.25, 0.24)] {
        let bodies: Vec<_> = robots.iter().map(|r| r.body(la, lb).unwrap()).collect();
        let softest = &bodies[2];
        let mut ws = Scratch::for_system(softest);
        let own: Vec<_> = bodies.iter().map(|b| b.solve_in(&solver, &mut ws).unwrap()).collect();
        let stops: Vec<f64> = bodies.iter().map(|b| softest.moment_scale() / b.moment_scale()).collect();
        assert!(stops[0] < stops[1] && stops[2] == 1.0);
        let fed = softest.feed_in(&solver, &mut ws).unwrap();
        let mut landed = Vec::new();
        let last =
            softest.load_through(&solver, fed, &stops, &mut ws, &mut |i, q| landed.push((i, q.to_vec()))).unwrap();
        assert_eq!(landed.iter().map(|(i, _)| *i).collect::<Vec<_>>(), [0, 1, 2], "at {la}, {lb}");
        for ((i, q), own) in landed.iter().zip(&own) {
            let worst = q.iter().zip(&own.q).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(worst < 1e-9, "Pi {} at {la}, {lb}: {worst:e} rad", pis[*i]);
        }
        assert_eq!(last.q, landed[2].1);
        assert!(last.stable);
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

/// A tube whose tip must stay above a floor at height `floor` (m): one
/// inequality row `C = y_tip - floor >= 0` (or an equality, to compare).
struct TipAboveFloor {
    tube: Cantilever,
    floor: f64,
    kind: leech::statics::RowKind,
}

impl Potential for TipAboveFloor {
    fn dim(&self) -> usize {
        self.tube.dim()
    }
    fn moment_scale(&self) -> f64 {
        self.tube.moment_scale()
    }
    fn potential(&self, q: &[f64], t: f64, ev: &mut leech::statics::Evaluation) {
        self.tube.potential(q, t, ev);
    }
}

impl Constraints for TipAboveFloor {
    fn rows(&self) -> usize {
        1
    }
    fn row(&self, _r: usize) -> leech::statics::Row {
        leech::statics::Row { kind: self.kind, scale: 0.01 }
    }
    fn constraints(&self, q: &[f64], _t: f64, ev: &mut leech::statics::Evaluation) {
        let chain = self.tube.chain();
        ev.constraints[0] = chain.tip(q)[1] - self.floor;
        for (j, (l, phi)) in chain.lengths().iter().zip(q).enumerate() {
            ev.jacobian[j] = l * phi.cos();
            ev.curvature[j] = -l * phi.sin();
        }
    }
}

impl StaticSystem for TipAboveFloor {
    fn side_measure(&self, q: &[f64], dq: &[f64]) -> f64 {
        self.tube.side_measure(q, dq)
    }
}

impl Path for TipAboveFloor {
    fn path(&self, q: &[f64], t: f64, ev: &leech::statics::Evaluation, out: &mut leech::statics::PathTerms) {
        self.tube.path(q, t, ev, out);
    }
}

fn solve_tip_above_floor(floor: f64, kind: leech::statics::RowKind) -> (TipAboveFloor, Equilibrium) {
    let tube = Robot::builtin().with_base_angle(0.0).unwrap().cantilever(0.30, 0.0).unwrap();
    let sys = TipAboveFloor { tube, floor, kind };
    let solver = Solver::default();
    let mut ws = Scratch::for_system(&sys);
    let mut it = leech::statics::Iterate::new(sys.tube.chain().straight());
    let residual = solver.continuation(&sys, &mut it, 0.0, leech::statics::Stage::Load, &mut ws).unwrap();
    let eq = solver.finish(&sys, it, residual, &mut ws);
    (sys, eq)
}

/// An inequality row is inactive when the free shape satisfies it, and acts
/// exactly as an equality (with a pushing multiplier) when it does not.
#[test]
fn inequality_rows_switch_on_and_off() {
    use leech::statics::RowKind;
    let free = {
        let tube = Robot::builtin().with_base_angle(0.0).unwrap().cantilever(0.30, 0.0).unwrap();
        let eq = tube.solve(&Solver::default()).unwrap();
        tube.chain().tip(&eq.q)[1]
    };
    assert!(free < -0.01, "the free tube sags ({free} m)");
    // A floor below the sag never touches: the free shape, zero force.
    let (sys, low) = solve_tip_above_floor(free - 0.01, RowKind::Inequality);
    assert_eq!(low.multipliers, vec![0.0]);
    assert!((sys.tube.chain().tip(&low.q)[1] - free).abs() < 1e-12);
    // A floor above it holds the tip up: on the floor, pushing up (lambda > 0),
    // the same equilibrium as the equality row.
    let floor = 0.5 * free;
    let (sys, held) = solve_tip_above_floor(floor, RowKind::Inequality);
    let (_, equal) = solve_tip_above_floor(floor, RowKind::Equality);
    assert!(held.stable && held.multipliers[0] > 0.0, "{:?}", held.multipliers);
    assert!((sys.tube.chain().tip(&held.q)[1] - floor).abs() < 1e-12);
    for (a, b) in held.q.iter().zip(&equal.q) {
        assert!((a - b).abs() < 1e-10);
    }
    assert!((held.multipliers[0] - equal.multipliers[0]).abs() < 1e-9 * equal.multipliers[0].abs());
    // The floor's push is what the tube's weight does not hang on the clamp:
    // at most the tube's weight.
    let weight = sys.tube.chain().total_mass() * 9.81;
    assert!(held.multipliers[0] < weight, "{} N vs weight {weight} N", held.multipliers[0]);
}
