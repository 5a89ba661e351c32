//! Benchmarks over a real pseudo-terminal against the Rust simulated robot:
//! a command's round trip (first send to `Ack`), and telemetry at 100 Hz
//! counting the reports lost. `--bench firmware` (feature `firmware`) makes
//! the same measurements against the Arduino firmware on a simulated chip.
//!
//! Run with `cargo bench -p leech-link`; besides divan's table each bench
//! prints its own figures (median and p99 of the round trips as the driver
//! measured them; reports expected, received and lost).

mod common;

use std::time::Duration;

use leech_link::host::{Link, Options};
use leech_link::pty::PtyDevice;
use leech_link::sim::{Sim, SimConfig};

fn main() {
    divan::main();
}

fn open() -> (PtyDevice, Link) {
    let device = PtyDevice::spawn(Sim::new(SimConfig::default())).expect("a pseudo-terminal");
    let options = Options { boot_timeout: Duration::from_millis(500), ..Options::default() };
    let link = Link::open(device.path(), options).expect("handshake");
    (device, link)
}

#[divan::bench(sample_count = 200, sample_size = 1)]
fn command_to_ack(bencher: divan::Bencher) {
    let (_device, link) = open();
    common::command_to_ack(bencher, &link, "Rust simulated robot", || {});
}

#[divan::bench(sample_count = 1, sample_size = 1)]
fn telemetry_at_100_hz(bencher: divan::Bencher) {
    let (_device, link) = open();
    common::telemetry_at_100_hz(bencher, &link, "Rust simulated robot", || {});
}
