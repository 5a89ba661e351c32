//! Benchmarks of the simulator (divan): single steps of both integrators
//! against the number of links, the paper's method (damped dynamics run to
//! rest) and a stretch of real time. `cargo bench -p leech --bench dynamics`.

use leech::dynamics::{simulate, Actuation, Integrator, Motion, SimulationOptions, Simulator, Start};
use leech::prelude::*;

fn main() {
    divan::main();
}

/// Links per chain of the stepped bodies: the built-in 30 + 28, then equal
/// tubes of 0.3 m cut ever finer.
const LINKS: [usize; 5] = [30, 100, 300, 1000, 3000];

/// The body with `links` links per chain, from its static equilibrium, with
/// a smooth velocity field projected onto `J v = 0` so that a step has work
/// to do. Finer bodies keep the tube's continuum `EI`, `rho` and damping per
/// length, so that every size is the same physical robot.
fn moving_body(links: usize) -> (Body, Motion) {
    let mut robot = Robot::builtin();
    let (la, lb) = if links == 30 { (0.30, 0.28) } else { (0.30, 0.30) };
    let l0 = robot.tube.element_length_m;
    let l = if links == 30 { l0 } else { la / links as f64 };
    robot.tube.element_length_m = l;
    robot.tube.element_mass_kg *= l / l0;
    robot.tube.joint_stiffness_nm_per_rad *= l0 / l;
    robot.tube.joint_damping_nms_per_rad *= l0 / l;
    let body = robot.body(la, lb).unwrap();
    let q = body.solve(&Solver::default()).unwrap().q;
    let n = q.len();
    let v = (0..n).map(|i| 0.2 * (7.0 * i as f64 / n as f64).sin()).collect();
    let mut motion = Motion { q, v };
    Simulator::new(&body).project(&mut motion).unwrap();
    (body, motion)
}

/// One step of `dt` (s), or of [`Simulator::stable_step`] when `None`.
fn bench_step(bencher: divan::Bencher, links: usize, integrator: Integrator, dt: Option<f64>) {
    let (body, start) = moving_body(links);
    let mut sim = Simulator::new(&body);
    let dt = dt.unwrap_or_else(|| sim.stable_step(&start.q).unwrap());
    bencher.with_inputs(|| start.clone()).bench_local_refs(|motion| sim.step(motion, dt, integrator).unwrap());
}

/// One backward-Euler step of 2 ms (Newton iterations and the projection).
#[divan::bench(args = LINKS, max_time = 3)]
fn implicit_step(bencher: divan::Bencher, links: usize) {
    bench_step(bencher, links, Integrator::Implicit, Some(2e-3));
}

/// One RK4 step at the stability limit (four constrained accelerations and
/// the projection).
#[divan::bench(args = LINKS, max_time = 3)]
fn explicit_step(bencher: divan::Bencher, links: usize) {
    bench_step(bencher, links, Integrator::Explicit, None);
}

fn settle_options(integrator: Integrator, dt: Option<f64>) -> SimulationOptions {
    SimulationOptions {
        integrator,
        dt,
        duration: 300.0,
        until_rest: true,
        gravity_ramp: 0.0,
        sample_interval: 1.0,
        rest_rate: 1e-6,
        deadline: leech::budget::Deadline::none(),
    }
}

/// Built-in robot, 30 + 28 links: from the unloaded shape, gravity on, run
/// to rest (rates below 1e-6 rad/s), backward Euler at 5 ms.
#[divan::bench(sample_count = 5)]
fn settle_to_rest_30_28_implicit(bencher: divan::Bencher) {
    let robot = Robot::builtin();
    let options = settle_options(Integrator::Implicit, Some(5e-3));
    bencher.bench_local(|| {
        let run = simulate(&robot, [0.30, 0.28], Start::Unloaded, Actuation::Hold, &options, &|_| {}).unwrap();
        assert!(run.time_to_rest.is_some());
        run
    });
}

/// Ten seconds of motion of the same body (real-time factor).
#[divan::bench(sample_count = 5)]
fn ten_seconds_30_28_implicit(bencher: divan::Bencher) {
    let robot = Robot::builtin();
    let options =
        SimulationOptions { duration: 10.0, until_rest: false, ..settle_options(Integrator::Implicit, Some(5e-3)) };
    bencher
        .bench_local(|| simulate(&robot, [0.30, 0.28], Start::Unloaded, Actuation::Hold, &options, &|_| {}).unwrap());
}
