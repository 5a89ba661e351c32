//! Throughput of batch solves (divan): shapes per second on all cores, the
//! Rust library's own figure that the Python binding is measured against.
//! Run with `cargo bench -p leech --bench batch`.

use leech::batch::{solve, BatchOptions, Outcome, Query};
use leech::prelude::*;

fn main() {
    divan::main();
}

/// Entries per benchmarked batch.
const N: usize = 4096;

/// Lengths 0.06..0.29 m scattered over the range: every entry solved cold.
fn scattered() -> (Vec<f64>, Vec<f64>) {
    let la = (0..N).map(|i| 0.06 + 0.23 * ((i * 37 % 101) as f64 / 100.0)).collect();
    let lb = (0..N).map(|i| 0.06 + 0.23 * ((i * 53 % 97) as f64 / 96.0)).collect();
    (la, lb)
}

/// An actuation path in steps under 1 mm: entries warm-started along chunks.
fn path() -> (Vec<f64>, Vec<f64>) {
    let la = (0..N).map(|i| 0.08 + 0.2 * (i as f64 / N as f64)).collect();
    let lb = (0..N).map(|i| 0.08 + 0.15 * (i as f64 / N as f64) + 0.005 * (i as f64 * 0.05).sin()).collect();
    (la, lb)
}

fn run(bencher: divan::Bencher, (la, lb): (Vec<f64>, Vec<f64>), options: BatchOptions) {
    let robot = Robot::builtin();
    let query = Query { la_m: &la, lb_m: &lb, base_angle_deg: None };
    let mut out = vec![Outcome::default(); N];
    bencher
        .counter(divan::counter::ItemsCount::new(N))
        .bench_local(|| solve(&robot, &query, &options, &mut out).unwrap());
}

/// 4096 scattered shapes, each solved cold (what `leech shape` does per call).
#[divan::bench(sample_count = 10)]
fn shapes_cold_4096(bencher: divan::Bencher) {
    run(bencher, scattered(), BatchOptions { warm_step_m: 0.0 })
}

/// 4096 shapes along a path, warm-started (the default options).
#[divan::bench(sample_count = 10)]
fn shapes_path_4096(bencher: divan::Bencher) {
    run(bencher, path(), BatchOptions::default())
}
