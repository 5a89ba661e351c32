//! Benchmarks of workspace sweeps and inverse statics (divan).
//! Run with `cargo bench -p leech --bench reach`.

use leech::budget::Deadline;
use leech::inverse_statics::Reacher;
use leech::prelude::*;
use leech::sweep::{sweep, Grid, Model, SweepOptions};

fn main() {
    divan::main();
}

/// The paper's Fig. 12 sweep: both lengths 0.05..0.30 m at 5 mm, five shape
/// parameters, both models (15 606 points), on all cores.
#[divan::bench(sample_count = 10)]
fn sweep_fig12_5mm(bencher: divan::Bencher) {
    let robot = Robot::builtin();
    let options = SweepOptions {
        grid: Grid::new(0.05, 0.30, 0.005).unwrap(),
        shape_parameters: vec![300.0, 1000.0, 3000.0, 5097.0, 10000.0],
        models: vec![Model::TwoChain, Model::ConstantCurvature],
        left_longer: false,
        deadline: Deadline::none(),
    };
    bencher.bench_local(|| sweep(&robot, &options, &|_| {}).unwrap());
}

/// One inverse solve for a reachable target (map of 10 mm built once).
#[divan::bench]
fn reach_one_target(bencher: divan::Bencher) {
    let robot = Robot::builtin();
    let reacher = Reacher::new(&robot, Grid::new(0.05, 0.30, 0.01).unwrap(), Deadline::none()).unwrap();
    let body = robot.body(0.2345, 0.1789).unwrap();
    let eq = body.solve(&Solver::default()).unwrap();
    let target = body.endpoint(&eq.q);
    bencher.bench_local(|| reacher.reach(divan::black_box(target), None).unwrap());
}

/// Fitting k to five sag curves (the paper's Fig. 3a experiment), 5 x 10..15 points.
#[divan::bench]
fn calibrate_five_sag_curves(bencher: divan::Bencher) {
    use leech::calibration::{calibrate, synthetic, Fit};
    let builtin = Robot::builtin();
    let truth = builtin.with_tube(0.42, builtin.tube.element_mass_kg).unwrap();
    let sag = synthetic::sag(&truth, &[0.10, 0.15, 0.20, 0.25, 0.30], 0.0, 0.02, 0.0005, 1);
    let start = Robot::builtin();
    bencher.bench_local(|| calibrate(&start, &sag, &[], Fit::Stiffness, &Deadline::none()).unwrap());
}
