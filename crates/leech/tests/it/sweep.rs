//! Workspace sweeps follow the actuation path and agree with single solves.

use leech::budget::Deadline;
use leech::prelude::*;
use leech::sweep::{sweep, Grid, Model, SweepOptions};

fn options(models: Vec<Model>, left_longer: bool) -> SweepOptions {
    SweepOptions {
        grid: Grid::new(0.05, 0.30, 0.025).unwrap(),
        shape_parameters: vec![],
        models,
        left_longer,
        deadline: Deadline::none(),
    }
}

/// Each grid point equals a solve warm-started from its neighbour's state,
/// and equals the default cold solve wherever the cold path lands on the same
/// equilibrium (checked: all but the points flagged as snapped agree).
#[test]
fn sweep_points_equal_independent_solves() {
    let robot = Robot::builtin();
    let result = sweep(&robot, &options(vec![Model::TwoChain], false), &|_| {}).unwrap();
    let values = Grid::new(0.05, 0.30, 0.025).unwrap().values();
    let n = values.len();
    assert_eq!(result.points.len(), n * n);
    assert!(result.points.iter().all(|p| p.failure.is_none() && p.stable));
    let solver = Solver::default();
    let mut agree_cold = 0;
    for i in 0..n {
        for j in 0..n {
            let p = &result.points[i * n + j];
            assert_eq!(p.lengths_m, [values[i], values[j]]);
            let body = robot.body(values[i], values[j]).unwrap();
            // The neighbour this point was fed from: left in the row, or below in the first column.
            let (ni, nj) = if j > 0 {
                (i, j - 1)
            } else if i > 0 {
                (i - 1, 0)
            } else {
                (0, 0)
            };
            if (ni, nj) != (i, j) {
                let neighbour = robot.body(values[ni], values[nj]).unwrap();
                let seed = replay(&robot, &values, ni, nj);
                let mut ws = leech::statics::Scratch::for_system(&body);
                let warm = body.solve_from(&solver, &body.carry_over(&neighbour, &seed), &mut ws).unwrap();
                let e = body.endpoint(&warm.q);
                assert!((e[0] - p.endpoint_m[0]).abs() < 1e-9 && (e[1] - p.endpoint_m[1]).abs() < 1e-9);
            }
            let cold = body.solve(&solver).unwrap();
            let e = body.endpoint(&cold.q);
            if (e[0] - p.endpoint_m[0]).hypot(e[1] - p.endpoint_m[1]) < 1e-9 {
                agree_cold += 1;
            } else {
                // Two different stable equilibria of one body: not unique, so
                // the actuation history decides and the paths may differ.
                assert!(cold.stable && p.stable, "{:?}", p.lengths_m);
                assert!((e[0] - p.endpoint_m[0]).hypot(e[1] - p.endpoint_m[1]) > 1e-6);
            }
        }
    }
    // Non-uniqueness is the exception on this grid.
    assert!(agree_cold as f64 >= 0.9 * (n * n) as f64, "{agree_cold} of {}", n * n);
}

/// The state the sweep had at grid point (i, j), replayed along its path.
fn replay(robot: &Robot, values: &[f64], i: usize, j: usize) -> Vec<f64> {
    let solver = Solver::default();
    let mut path = vec![(0, 0)];
    path.extend((1..=i).map(|k| (k, 0)));
    path.extend((1..=j).map(|k| (i, k)));
    let mut body = robot.body(values[0], values[0]).unwrap();
    let mut q = body.solve(&solver).unwrap().q;
    for &(a, b) in &path[1..] {
        let next = robot.body(values[a], values[b]).unwrap();
        let mut ws = leech::statics::Scratch::for_system(&next);
        q = next.solve_from(&solver, &next.carry_over(&body, &q), &mut ws).unwrap().q;
        body = next;
    }
    q
}

#[test]
fn left_longer_and_constant_curvature() {
    let robot = Robot::builtin();
    let result = sweep(&robot, &options(vec![Model::TwoChain, Model::ConstantCurvature], true), &|_| {}).unwrap();
    let n = 11;
    assert_eq!(result.points.len(), 2 * n * (n + 1) / 2);
    assert!(result.points.iter().all(|p| p.lengths_m[0] >= p.lengths_m[1]));
    assert_eq!(result.summaries.len(), 2);
    for s in &result.summaries {
        assert!(s.area_m2 > 0.0 && s.highest.is_some() && s.failures.is_empty());
        let high = s.highest.unwrap().endpoint_m[1];
        let low = s.lowest.unwrap().endpoint_m[1];
        assert!(high >= low);
    }
    // A tube cannot bend tighter than 25 mm: sharp constant-curvature bends are infeasible.
    let cc = result.points.iter().filter(|p| p.model == Model::ConstantCurvature);
    for p in cc {
        let bend = ((p.lengths_m[1] - p.lengths_m[0]) / (0.5 * (0.017 + 0.012))).abs();
        let radius = p.lengths_m[1] / bend;
        assert_eq!(p.feasible, radius >= 0.025 || bend == 0.0, "{:?}", p.lengths_m);
    }
}

#[test]
fn bad_grids_are_rejected() {
    assert!(Grid::parse("0.05:0.3").is_err());
    assert!(Grid::parse("0.3:0.05:0.01").is_err());
    assert!(Grid::parse("0.05:0.3:0").is_err());
    assert!(Grid::parse("0.05:0.3:1e-9").is_err());
    assert!(Grid::parse("a:b:c").is_err());
    let robot = Robot::builtin();
    let mut o = options(vec![Model::TwoChain], false);
    o.grid = Grid::new(0.001, 0.3, 0.05).unwrap();
    assert!(sweep(&robot, &o, &|_| {}).is_err(), "shorter than one element");
}

/// Every point of a sweep over several shape parameters (soft ones among
/// them, where the path and fresh solves differ) either agrees with a fresh
/// solve of its own robot to 1e-6 m or says by how much it does not, to
/// rounding: the sweep feeds the tubes once for all shape parameters.
#[test]
fn every_point_reports_its_difference_from_a_fresh_solve() {
    let mut options = options(vec![Model::TwoChain], false);
    options.grid = Grid::new(0.05, 0.30, 0.05).unwrap();
    options.shape_parameters = vec![10.0, 300.0, 3000.0];
    let result = sweep(&Robot::builtin(), &options, &|_| {}).unwrap();
    for summary in &result.summaries {
        let pi = summary.shape_parameter.unwrap();
        let robot = Robot::builtin().with_shape_parameter(pi).unwrap();
        let mut differing = 0;
        let points = result.points.iter().filter(|p| p.shape_parameter == Some(pi) && p.failure.is_none());
        for p in points {
            let body = robot.body(p.lengths_m[0], p.lengths_m[1]).unwrap();
            let Ok(eq) = body.solve(&Solver::default()) else {
                assert!(p.fresh_difference_m.is_infinite(), "{p:?}");
                continue;
            };
            let e = body.endpoint(&eq.q);
            let d = (e[0] - p.endpoint_m[0]).hypot(e[1] - p.endpoint_m[1]);
            if d <= 1e-6 {
                assert_eq!(p.fresh_difference_m, 0.0, "{p:?}");
            } else {
                assert!((p.fresh_difference_m - d).abs() < 1e-12, "{p:?}: {d}");
                differing += 1;
            }
        }
        assert_eq!(summary.differ_from_fresh, differing, "Pi {pi}");
        if pi == 10.0 {
            assert!(differing > 0, "the soft robot's path and fresh solves differ somewhere on this grid");
        }
    }
}

#[test]
fn a_spent_deadline_stops_the_sweep_and_too_many_points_are_refused() {
    let mut spent = options(vec![Model::TwoChain], false);
    spent.deadline = Deadline::after(std::time::Duration::ZERO);
    let e = sweep(&Robot::builtin(), &spent, &|_| {}).unwrap_err();
    assert!(matches!(e, leech::sweep::SweepError::Stopped(_)), "{e}");
    let mut huge = options(vec![Model::TwoChain], false);
    huge.grid = Grid::new(0.05, 100.0, 0.05).unwrap();
    huge.shape_parameters = vec![100.0; 3];
    let e = sweep(&Robot::builtin(), &huge, &|_| {}).unwrap_err();
    assert!(e.to_string().contains(&leech::sweep::MAX_POINTS.to_string()), "{e}");
}

/// The two-chain points of all shape parameters are solved together; a
/// model listed twice still gets its points and summaries twice, in order.
#[test]
fn a_model_listed_twice_is_reported_twice() {
    let mut o = options(vec![Model::TwoChain, Model::ConstantCurvature, Model::TwoChain], true);
    o.grid = Grid::new(0.05, 0.30, 0.05).unwrap();
    o.shape_parameters = vec![300.0, 3000.0];
    let result = sweep(&Robot::builtin(), &o, &|_| {}).unwrap();
    let models: Vec<(Model, Option<i64>)> =
        result.summaries.iter().map(|s| (s.model, s.shape_parameter.map(|p| p.round() as i64))).collect();
    let (two, cc) = (Model::TwoChain, Model::ConstantCurvature);
    assert_eq!(models, [(two, Some(300)), (two, Some(3000)), (cc, None), (two, Some(300)), (two, Some(3000))]);
    let per = result.summaries[0].points;
    assert_eq!(result.points.len(), 5 * per);
    assert_eq!(result.points[..2 * per], result.points[3 * per..]);
    assert_eq!(result.summaries[..2], result.summaries[3..]);
}
