//! Inverse statics: forward(inverse(target)) hits the target; unreachable
//! targets are reported with the nearest point, never as a solution.

use leech::budget::Deadline;
use leech::inverse_statics::{ReachStatus, Reacher};
use leech::prelude::*;
use leech::sweep::Grid;

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn random_reachable_targets_are_reached() {
    let robot = Robot::builtin();
    let reacher = Reacher::new(&robot, Grid::new(0.05, 0.30, 0.005).unwrap(), Deadline::none()).unwrap();
    let solver = Solver::default();
    let mut seed = 7;
    let count = if cfg!(debug_assertions) { 120 } else { 1000 };
    for k in 0..count {
        let (la, lb) = (0.05 + 0.25 * lcg(&mut seed), 0.05 + 0.25 * lcg(&mut seed));
        let body = robot.body(la, lb).unwrap();
        let eq = body.solve(&solver).unwrap();
        let target = body.endpoint(&eq.q);
        let angle = (k % 2 == 0).then(|| body.endpoint_angle(&eq.q));
        let answer = reacher.reach(target, angle).unwrap();
        assert_eq!(answer.status, ReachStatus::Reached, "target {target:?} from {la}, {lb}: {answer:?}");
        // forward(inverse(target)), by a fresh default solve:
        let check = robot.body(answer.lengths_m[0], answer.lengths_m[1]).unwrap();
        let ceq = check.solve(&solver).unwrap();
        let e = check.endpoint(&ceq.q);
        assert!((e[0] - target[0]).hypot(e[1] - target[1]) < 1e-6);
        if let Some(a) = angle {
            assert!((check.endpoint_angle(&ceq.q) - a).abs() < 1e-4);
        }
        assert!(answer.lengths_m.iter().all(|l| (0.05..=0.30).contains(l)));
    }
}

#[test]
fn unreachable_targets_report_the_nearest_point() {
    let robot = Robot::builtin();
    let reacher = Reacher::new(&robot, Grid::new(0.05, 0.30, 0.01).unwrap(), Deadline::none()).unwrap();
    for target in [[1.0, 1.0], [0.0, -0.5], [0.0, 0.01]] {
        let answer = reacher.reach(target, None).unwrap();
        assert_eq!(answer.status, ReachStatus::Unreachable, "{target:?}");
        assert!(answer.error_m > 1e-3);
        // The reported point is a real equilibrium at the reported lengths.
        let body = robot.body(answer.lengths_m[0], answer.lengths_m[1]).unwrap();
        let eq = body.solve(&Solver::default()).unwrap();
        let e = body.endpoint(&eq.q);
        assert!((e[0] - answer.endpoint_m[0]).abs() < 1e-12 && (e[1] - answer.endpoint_m[1]).abs() < 1e-12);
        assert!((e[0] - target[0]).hypot(e[1] - target[1]) - answer.error_m < 1e-12);
    }
}

/// One reacher for the property test (a 25 mm map: 121 fresh solves).
fn coarse_reacher() -> &'static Reacher {
    static REACHER: std::sync::OnceLock<Reacher> = std::sync::OnceLock::new();
    REACHER.get_or_init(|| {
        Reacher::new(&Robot::builtin(), Grid::new(0.05, 0.30, 0.025).unwrap(), Deadline::none()).unwrap()
    })
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config::with_cases(24))]

    /// For any target, reached or not, the answer's lengths solved fresh the
    /// way `leech shape` does reproduce its endpoint.
    #[test]
    fn any_answer_is_reproduced_by_a_fresh_solve(x in -0.4f64..0.4, y in -0.2f64..0.5) {
        let answer = coarse_reacher().reach([x, y], None).unwrap();
        let body = Robot::builtin().body(answer.lengths_m[0], answer.lengths_m[1]).unwrap();
        let eq = body.solve(&Solver::default()).unwrap();
        let e = body.endpoint(&eq.q);
        proptest::prop_assert!((e[0] - answer.endpoint_m[0]).hypot(e[1] - answer.endpoint_m[1]) < 1e-6, "{answer:?}");
    }
}

#[test]
fn a_spent_deadline_stops_the_map() {
    let spent = Deadline::after(std::time::Duration::ZERO);
    let e = Reacher::new(&Robot::builtin(), Grid::new(0.05, 0.30, 0.025).unwrap(), spent).err().unwrap();
    assert!(matches!(e, leech::inverse_statics::ReachError::Stopped(_)), "{e}");
}
