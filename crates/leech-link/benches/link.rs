//! Benchmarks over a real pseudo-terminal: a command's round trip (first
//! send to `Ack`), and telemetry at 100 Hz counting the reports lost.
//!
//! Run with `cargo bench -p leech-link`; besides divan's table each bench
//! prints its own figures (median and p99 of the round trips as the driver
//! measured them; reports expected, received and lost).

use std::sync::mpsc::RecvTimeoutError;
use std::time::{Duration, Instant};

use leech_link::host::{Event, Link, Options};
use leech_link::pty::PtyDevice;
use leech_link::sim::{Sim, SimConfig};
use leech_protocol::message::Command;

fn main() {
    divan::main();
}

fn open() -> (PtyDevice, Link) {
    let device = PtyDevice::spawn(Sim::new(SimConfig::default())).expect("a pseudo-terminal");
    let options = Options { boot_timeout: Duration::from_millis(500), ..Options::default() };
    let link = Link::open(device.path(), options).expect("handshake");
    (device, link)
}

/// The value at fraction `q` of sorted `samples`.
fn quantile(samples: &[Duration], q: f64) -> Duration {
    let i = ((samples.len() - 1) as f64 * q).round() as usize;
    samples[i]
}

#[divan::bench(sample_count = 200, sample_size = 1)]
fn command_to_ack(bencher: divan::Bencher) {
    let (_device, link) = open();
    let mut round_trips = Vec::new();
    bencher.bench_local(|| {
        let acked = link.command(Command::Heartbeat).expect("acked");
        round_trips.push(acked.round_trip);
    });
    round_trips.sort();
    if !round_trips.is_empty() {
        println!(
            "command to ack over the pty: {} round trips, median {:?}, p99 {:?}",
            round_trips.len(),
            quantile(&round_trips, 0.5),
            quantile(&round_trips, 0.99)
        );
    }
}

/// How long the telemetry bench listens.
const LISTEN: Duration = Duration::from_secs(3);

#[divan::bench(sample_count = 1, sample_size = 1)]
fn telemetry_at_100_hz(bencher: divan::Bencher) {
    let (_device, link) = open();
    let events = link.subscribe();
    link.set_telemetry(10).expect("telemetry on");
    bencher.bench_local(|| {
        let (mut received, mut lost, mut last) = (0u64, 0u64, None::<u32>);
        let start = Instant::now();
        while start.elapsed() < LISTEN {
            match events.recv_timeout(Duration::from_millis(100)) {
                Ok(Event::Telemetry(t)) => {
                    received += 1;
                    if let Some(previous) = last {
                        // Reports are 10 ms apart on the device's clock.
                        let gap = t.time_ms.wrapping_sub(previous);
                        lost += u64::from((gap + 5) / 10).saturating_sub(1);
                    }
                    last = Some(t.time_ms);
                }
                Ok(_) | Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
        }
        println!("telemetry at 100 Hz for {LISTEN:?}: {received} received, {lost} lost");
    });
}
