//! The benchmarks of `--bench link` against the Arduino firmware on a
//! simulated ATmega2560 (`leech_link::chip`): a command's round trip, and
//! telemetry at 100 Hz counting the reports lost.
//!
//! Run with `cargo bench -p leech-link --features firmware` (both benches,
//! the Rust simulated robot's first). The simulator runs the chip in real
//! time only while it has a core to itself: each bench also prints the
//! slowest and fastest `sim_rate` (simulated seconds per wall second) the
//! harness reported during the measurement; figures taken far from 1.0 mean
//! nothing.

mod common;

use std::path::Path;
use std::time::Duration;

use leech_link::chip::{self, Built, Chip};
use leech_link::host::{Link, Options};
use leech_link::sim::SimConfig;
use leech_protocol::message::Tube;

fn main() {
    divan::main();
}

fn built() -> &'static Built {
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("firmware");
    chip::build_once(&out).unwrap_or_else(|e| panic!("{e}"))
}

/// The firmware, started, its link open and its three tubes configured as
/// for the simulated hardware, so that the control loop runs as on a robot
/// (holding its tubes) while it answers.
fn open() -> (Chip, Link) {
    let chip = Chip::spawn(built()).unwrap_or_else(|e| panic!("{e}"));
    let options = Options { boot_timeout: Duration::from_millis(500), ..Options::default() };
    let link = Link::open(chip.path(), options).expect("handshake");
    let sim = SimConfig::default();
    for tube in [Tube::L1, Tube::L2, Tube::L3] {
        link.configure_tube(sim.tube_config(tube)).expect("tube configured");
    }
    link.set_lengths(sim.initial_lengths_um).expect("holding");
    (chip, link)
}

/// The range of `sim_rate` the harness reports while a bench runs.
struct SimRate(Option<(f64, f64)>);

impl SimRate {
    fn watch(&mut self, chip: &Chip) {
        if let Some(state) = chip.observe(Duration::ZERO).filter(|s| s.sim_rate > 0.0) {
            let (low, high) = self.0.unwrap_or((state.sim_rate, state.sim_rate));
            self.0 = Some((low.min(state.sim_rate), high.max(state.sim_rate)));
        }
    }

    fn print(&self) {
        match self.0 {
            Some((low, high)) => println!("  sim_rate meanwhile: {low:.3} to {high:.3}"),
            None => println!("  sim_rate meanwhile: not reported"),
        }
    }
}

#[divan::bench(sample_count = 200, sample_size = 1)]
fn command_to_ack(bencher: divan::Bencher) {
    let (chip, link) = open();
    let mut rate = SimRate(None);
    common::command_to_ack(bencher, &link, "firmware on simavr", || rate.watch(&chip));
    rate.print();
}

#[divan::bench(sample_count = 1, sample_size = 1)]
fn telemetry_at_100_hz(bencher: divan::Bencher) {
    let (chip, link) = open();
    let mut rate = SimRate(None);
    common::telemetry_at_100_hz(bencher, &link, "firmware on simavr", || rate.watch(&chip));
    rate.print();
}
