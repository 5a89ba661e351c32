//! The contact census (`leech::stance::census`): the built-in robot's body,
//! its rear cup on a floor, fed against a wall and against 60 mm and 30 mm
//! steps ahead over 136 length pairs each, the free front cup's face resting
//! on the solids (and, for the wall and the 60 mm step, passing through
//! them: the tubes alone touching). Prints solved and failed by reason per grid, and the
//! failed lengths.
//!
//! `cargo run --release -p leech --example contact_census`

use leech::prelude::*;
use leech::stance::census::{self, Tally};
use leech::stance::FreeCups;

fn main() {
    let robot = Robot::builtin();
    let solver = Solver::default();
    let rest = [census::wall_ahead(), census::step_ahead(0.06), census::step_ahead(0.03)].map(|s| (s, FreeCups::Rest));
    let through = [census::wall_ahead(), census::step_ahead(0.06)].map(|s| (s, FreeCups::PassThrough));
    let (mut solved, mut total) = (0, 0);
    for (scene, cups) in rest.iter().chain(&through) {
        let mut tally = Tally::default();
        let start = std::time::Instant::now();
        for lengths in census::lengths() {
            tally.count(lengths, &census::solve(&robot, scene, lengths, *cups, &solver));
        }
        let seconds = start.elapsed().as_secs_f64();
        println!("{}, free cups {cups:?}: {} of {} solved ({seconds:.2} s)", scene.name, tally.solved, tally.total());
        for (reason, count) in &tally.failed {
            println!("  {count:4} failed: {reason}");
        }
        for [la, lb] in &tally.failures {
            println!("       LA {la:.3} m, LB {lb:.3} m");
        }
        (solved, total) = (solved + tally.solved, total + tally.total());
    }
    println!("all: {solved} of {total} solved ({:.1} %)", 100.0 * solved as f64 / total as f64);
}
