//! Benchmarks of the simulator (divan): the paper's method, damped dynamics
//! run to rest, against one static solve. `cargo bench -p leech --bench dynamics`.

use leech::dynamics::{simulate, Actuation, Integrator, SimulationOptions, Start};
use leech::prelude::*;

fn main() {
    divan::main();
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
