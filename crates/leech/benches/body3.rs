//! Benchmarks of the 3D body's static solver (divan). Run with
//! `cargo bench -p leech --bench body3`.

use leech::body3::Body3;
use leech::prelude::*;

fn main() {
    divan::main();
}

/// The 25/30/22-link body (built-in robot, up a vertical wall) from
/// a cold start: the tubes fed at g = 0, then gravity raised.
#[divan::bench]
fn body3_cold_25_30_22(bencher: divan::Bencher) {
    let body = Body3::from_robot(&Robot::builtin(), [0.25, 0.30, 0.22]).unwrap();
    let solver = Solver::default();
    bencher.bench_local(|| body.solve(divan::black_box(&solver)).unwrap());
}

/// The planar body of the same robot at 0.30/0.28 m in 3D (side tubes equal).
#[divan::bench]
fn body3_cold_30_28_28(bencher: divan::Bencher) {
    let body = Body3::from_robot(&Robot::builtin(), [0.30, 0.28, 0.28]).unwrap();
    let solver = Solver::default();
    bencher.bench_local(|| body.solve(divan::black_box(&solver)).unwrap());
}
