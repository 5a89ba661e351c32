//! Benchmarks of the climb planner (divan): a whole plan per iteration.
//! `cargo bench -p leech --bench climb`.

use leech::prelude::*;
use leech::scene::Scene;
use leech::stride::{self, Foothold, Goal, PlanOptions, Status};

fn main() {
    divan::main();
}

/// The built-in robot crawling `distance` m along the floor from the
/// origin: every stride's touchdowns searched and its phases solved among
/// the solids (the solves a plan costs are printed once).
#[divan::bench(args = [0.25, 0.5], sample_count = 5, sample_size = 1)]
fn crawl_floor(bencher: divan::Bencher, distance: f64) {
    let robot = Robot::builtin();
    let floor = Scene::builtin("floor").unwrap();
    let start = Foothold { centre_m: [0.0, 0.0], direction_rad: 0.0 };
    let goal = Goal { point_m: [distance, 0.0], tolerance_m: 0.03 };
    let options = PlanOptions::default();
    let plan = stride::plan(&robot, &floor, start, goal, &options).unwrap();
    assert_eq!(plan.status, Status::Reached);
    eprintln!("crawl {distance} m: {} strides, {} solves", plan.strides, plan.solves);
    bencher.bench_local(|| stride::plan(&robot, &floor, start, goal, &options).unwrap());
}
