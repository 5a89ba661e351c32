//! Benchmarks of the climb planner (divan): a whole plan per iteration.
//! `cargo bench -p leech --bench climb`.

use leech::prelude::*;
use leech::stride::{self, PlanOptions, Scenario};

fn main() {
    divan::main();
}

/// Each built-in scenario planned with the built-in robot: every stride's
/// touchdowns searched and its phases solved among the solids, to the goal
/// or to the block that makes it impossible (the outcome, strides and
/// statics solves a plan costs are printed once).
#[divan::bench(args = ["crawl-floor", "climb-wall-up", "climb-wall-down", "floor-to-wall", "wall-to-floor", "over-thin-wall", "wall-to-ceiling"], sample_count = 5, sample_size = 1)]
fn scenario(bencher: divan::Bencher, name: &str) {
    let robot = Robot::builtin();
    let scenario = Scenario::builtin(name).unwrap();
    let options = PlanOptions::default();
    let run = || stride::plan(&robot, &scenario.scene, scenario.start, scenario.goal, &options).unwrap();
    let plan = run();
    eprintln!("{name}: {:?} in {} strides, {} solves", plan.status, plan.strides, plan.solves);
    bencher.bench_local(run);
}
