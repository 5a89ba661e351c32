//! The measurements both benches make, over whatever device a [`Link`] has
//! opened: a command's round trip and telemetry at 100 Hz.

use std::sync::mpsc::RecvTimeoutError;
use std::time::{Duration, Instant};

use leech_link::host::{Event, Link};
use leech_protocol::message::Command;

/// The value at fraction `q` of sorted `samples`.
fn quantile(samples: &[Duration], q: f64) -> Duration {
    let i = ((samples.len() - 1) as f64 * q).round() as usize;
    samples[i]
}

/// Round trips of `Heartbeat` (first send to `Ack`, as the driver measures
/// them), one per divan sample; `between` runs after each (the firmware
/// bench watches the simulator's speed with it). Prints median and p99.
pub fn command_to_ack(bencher: divan::Bencher, link: &Link, device: &str, mut between: impl FnMut()) {
    let mut round_trips = Vec::new();
    bencher.bench_local(|| {
        let acked = link.command(Command::Heartbeat).expect("acked");
        round_trips.push(acked.round_trip);
        between();
    });
    round_trips.sort();
    if !round_trips.is_empty() {
        println!(
            "command to ack, {device}: {} round trips, median {:?}, p99 {:?}",
            round_trips.len(),
            quantile(&round_trips, 0.5),
            quantile(&round_trips, 0.99)
        );
    }
}

/// How long the telemetry bench listens.
const LISTEN: Duration = Duration::from_secs(3);

/// The telemetry period, ms (100 Hz).
const PERIOD_MS: u16 = 10;

/// Switches telemetry to 100 Hz and counts the reports of `LISTEN`: those
/// received, and those lost (gaps in the device's clock). `between` runs
/// after each report. Prints expected, received and lost.
pub fn telemetry_at_100_hz(bencher: divan::Bencher, link: &Link, device: &str, mut between: impl FnMut()) {
    let events = link.subscribe();
    link.set_telemetry(PERIOD_MS).expect("telemetry on");
    bencher.bench_local(|| {
        let (mut received, mut lost, mut last) = (0u64, 0u64, None::<u32>);
        let start = Instant::now();
        while start.elapsed() < LISTEN {
            match events.recv_timeout(Duration::from_millis(100)) {
                Ok(Event::Telemetry(t)) => {
                    received += 1;
                    if let Some(previous) = last {
                        let gap = t.time_ms.wrapping_sub(previous);
                        let period = u32::from(PERIOD_MS);
                        lost += u64::from((gap + period / 2) / period).saturating_sub(1);
                    }
                    last = Some(t.time_ms);
                    between();
                }
                Ok(_) | Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
        }
        let expected = LISTEN.as_millis() / u128::from(PERIOD_MS);
        println!(
            "telemetry at 100 Hz, {device}, for {LISTEN:?}: {expected} expected, {received} received, {lost} lost"
        );
    });
}
