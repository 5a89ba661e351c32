//! Waiting on the device's telemetry: the next report, or the tubes at
//! their targets. A command line or an executor asks the device to act
//! (`host::Link`) and then waits here for the telemetry that confirms it.
//!
//! Rules: lengths count as reached when every tube's measured length is
//! within the tolerance (um) of its target and every motor's duty is
//! below 5 per mille (the position loop has settled);
//! a fault report, a disconnection or the deadline ends the wait with an
//! error naming what was last seen.

use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use leech_protocol::message::Telemetry;

use crate::host::Event;

/// Why a wait ended without what it waited for.
#[derive(Debug, thiserror::Error)]
pub enum WaitError {
    /// No telemetry within the time.
    #[error("no telemetry from the device within {0:?}")]
    NoTelemetry(Duration),
    /// The tubes did not reach their targets in time.
    #[error("the tubes did not reach {targets_um:?} um within {waited:?} (last measured {last_um:?} um)")]
    NotReached {
        /// The targets, um.
        targets_um: [i32; 3],
        /// The last measured lengths, um.
        last_um: [i32; 3],
        /// How long it waited.
        waited: Duration,
    },
    /// The device reported a fault.
    #[error("the device reported fault {code} (detail {detail}) at {time_ms} ms")]
    Fault {
        /// Fault code (docs/protocol.md).
        code: u8,
        /// Its detail byte.
        detail: u8,
        /// The device's clock, ms.
        time_ms: u32,
    },
    /// The link went down.
    #[error("the link went down while waiting")]
    Disconnected,
}

/// The next telemetry report on `events`, within `timeout`.
pub fn next_telemetry(events: &Receiver<Event>, timeout: Duration) -> Result<Telemetry, WaitError> {
    let deadline = Instant::now() + timeout;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match events.recv_timeout(left) {
            Ok(Event::Telemetry(t)) => return Ok(t),
            Ok(Event::Fault { code, detail, time_ms }) => return Err(WaitError::Fault { code, detail, time_ms }),
            Ok(Event::Disconnected) | Err(RecvTimeoutError::Disconnected) => return Err(WaitError::Disconnected),
            Ok(_) => {}
            Err(RecvTimeoutError::Timeout) => return Err(WaitError::NoTelemetry(timeout)),
        }
    }
}

/// Waits until the telemetry on `events` shows every tube within
/// `tolerance_um` of `targets_um` and settled, within `timeout`; the report
/// that showed it.
pub fn until_lengths(
    events: &Receiver<Event>,
    targets_um: [i32; 3],
    tolerance_um: i32,
    timeout: Duration,
) -> Result<Telemetry, WaitError> {
    let start = Instant::now();
    let mut last_um = [0; 3];
    loop {
        let left = timeout.saturating_sub(start.elapsed());
        if left.is_zero() {
            return Err(WaitError::NotReached { targets_um, last_um, waited: start.elapsed() });
        }
        let t = match next_telemetry(events, left) {
            Ok(t) => t,
            Err(WaitError::NoTelemetry(_)) => {
                return Err(WaitError::NotReached { targets_um, last_um, waited: start.elapsed() })
            }
            Err(e) => return Err(e),
        };
        last_um = t.lengths_um;
        let near =
            (0..3).all(|i| (i64::from(t.lengths_um[i]) - i64::from(targets_um[i])).abs() <= i64::from(tolerance_um));
        let settled = t.duty_permille.iter().all(|d| d.unsigned_abs() < 5);
        if near && settled {
            return Ok(t);
        }
    }
}
