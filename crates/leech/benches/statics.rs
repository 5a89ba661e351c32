//! Benchmarks of the static solver (divan). Run with `cargo bench -p leech`.

use leech::prelude::*;
use leech::statics::Scratch;

fn main() {
    divan::main();
}

/// `leech shape --lengths 0.30,0.28` on the built-in robot (30 + 28 links),
/// from a cold start: feeding at g = 0, then load continuation.
#[divan::bench]
fn shape_cold_30_28(bencher: divan::Bencher) {
    let body = Robot::builtin().body(0.30, 0.28).unwrap();
    let solver = Solver::default();
    bencher.bench_local(|| body.solve(divan::black_box(&solver)).unwrap());
}

/// The same body warm-started from the equilibrium of a neighbouring grid
/// point (LB 1 mm shorter), as a sweep or planner does.
#[divan::bench]
fn shape_warm_30_28(bencher: divan::Bencher) {
    let robot = Robot::builtin();
    let solver = Solver::default();
    let neighbour = robot.body(0.30, 0.279).unwrap().solve(&solver).unwrap();
    let body = robot.body(0.30, 0.28).unwrap();
    let mut ws = Scratch::for_system(&body);
    bencher.bench_local(|| body.solve_from(&solver, divan::black_box(&neighbour.q), &mut ws).unwrap());
}

/// Cold solves across the paper's length range.
#[divan::bench(args = [(0.05, 0.05), (0.15, 0.10), (0.30, 0.20), (0.10, 0.30)])]
fn shape_cold(bencher: divan::Bencher, lengths: (f64, f64)) {
    let body = Robot::builtin().body(lengths.0, lengths.1).unwrap();
    let solver = Solver::default();
    bencher.bench_local(|| body.solve(&solver).unwrap());
}

/// A single 30-element tube held horizontally.
#[divan::bench]
fn chain_cold_30(bencher: divan::Bencher) {
    let robot = Robot::builtin().with_base_angle(0.0).unwrap();
    let tube = robot.cantilever(0.30, 0.0).unwrap();
    let solver = Solver::default();
    bencher.bench_local(|| tube.solve(&solver).unwrap());
}

/// The same physical body (0.30/0.28 m) cut finer: the cost of a cold solve
/// against the number of links per chain A (30, 100, 300, 1000, 3000; chain B
/// has 28/30 as many).
#[divan::bench(args = [30, 100, 300, 1000, 3000], sample_count = 20)]
fn shape_cold_links(bencher: divan::Bencher, links: usize) {
    let robot = Robot::builtin().with_element_length(element_length(links)).unwrap();
    let body = robot.body(0.30, 0.28).unwrap();
    let solver = Solver::default();
    bencher.bench_local(|| body.solve(&solver).unwrap());
}

/// Both tubes 0.30 m cut into 3000 links each (3000 + 3000; the body above
/// at 3000 is 3000 + 2800). Equal tubes need no feeding path (one
/// minimization at g = 0), so only the load continuation remains.
#[divan::bench(args = [3000], sample_count = 20)]
fn shape_cold_equal_links(bencher: divan::Bencher, links: usize) {
    let robot = Robot::builtin().with_element_length(element_length(links)).unwrap();
    let body = robot.body(0.30, 0.30).unwrap();
    let solver = Solver::default();
    bencher.bench_local(|| body.solve(&solver).unwrap());
}

/// The element length that cuts 0.30 m into `links` links: 0.30 / 3000
/// rounds to just below the smallest length a robot file allows, which
/// stands for it (3000 links still).
fn element_length(links: usize) -> f64 {
    (0.30 / links as f64).max(leech::chain::ELEMENT_LENGTH_M.0)
}
