//! Waiting on the device's telemetry: the next report, or the tubes at
//! their targets. A command line or an executor asks the device to act
//! (`host::Link`) and then waits here for the telemetry that confirms it.
//!
//! Rules:
//!
//! * **Fresh telemetry only.** A command's effect shows in reports the
//!   device sent after it took the command. The driver publishes events in
//!   wire order, so every report sent before the command's `Ack` is already
//!   in the subscription when the command returns:
//!   [`Watch::after_command`] drops them (judging them for faults first),
//!   and what the wait reads after that was sent after the command.
//! * **Faults.** A `Fault` report ends a wait with an error naming the
//!   fault ([`Fault`]'s Display). Since a report can be lost on the line,
//!   a bit newly set in `Telemetry.faults` (not set in the report before:
//!   the first report a [`Watch`] sees gives the faults already latched)
//!   counts as a fault too.
//! * **Lengths** count as reached when every tube's measured length is
//!   within the tolerance (um) of its target and every motor's duty is
//!   below 5 per mille (the position loop has settled). A tube that leaves
//!   position control (`Telemetry.active`) before that was stopped by the
//!   device: an error naming the tube.
//! * A disconnection or the deadline ends the wait with an error naming
//!   what was last seen.

use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError};
use std::time::{Duration, Instant};

use leech_protocol::message::{Fault, Faults, Telemetry, Tube};

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
    /// The device stopped a tube before it reached its target.
    #[error("the device stopped tube {tube} before it reached {target_um} um (last measured {last_um:?} um)")]
    Stopped {
        /// The tube that left position control.
        tube: Tube,
        /// Its target, um.
        target_um: i32,
        /// The last measured lengths, um.
        last_um: [i32; 3],
    },
    /// The device reported a fault, or latched one the telemetry shows.
    #[error("the device reported {fault} at {time_ms} ms")]
    Fault {
        /// Which, and on what.
        fault: Fault,
        /// The device's clock, ms.
        time_ms: u32,
    },
    /// The link went down.
    #[error("the link went down while waiting")]
    Disconnected,
}

/// The fault that a report with `faults` latched shows newly set against
/// `latched` (the bits of the report before), and `latched` updated to it.
/// A bit cleared (by `ClearFaults`) and set again counts as new.
pub fn newly_latched(latched: &mut Faults, faults: Faults) -> Option<Fault> {
    let new = faults.without(*latched);
    *latched = faults;
    Fault::latched(new)
}

/// A subscription's events, judged as the module rules say.
pub struct Watch {
    events: Receiver<Event>,
    /// The faults the last report latched; `None` before the first.
    latched: Option<Faults>,
}

impl Watch {
    /// Watches `events` (from `Link::subscribe`); the first telemetry report
    /// gives the faults already latched.
    pub fn new(events: Receiver<Event>) -> Watch {
        Watch { events, latched: None }
    }

    /// The faults latched as of the last report seen.
    pub fn latched(&self) -> Option<Faults> {
        self.latched
    }

    /// The first fresh report: drops what came before (a command's reports,
    /// say `Link::set_telemetry`'s), then waits for the next telemetry,
    /// whose latched faults are taken as known (a `Fault` report meanwhile
    /// is no error: the faults are shown, not waited on).
    pub fn start(&mut self, timeout: Duration) -> Result<Telemetry, WaitError> {
        loop {
            match self.events.try_recv() {
                Ok(Event::Disconnected) | Err(TryRecvError::Disconnected) => return Err(WaitError::Disconnected),
                Ok(_) => {}
                Err(TryRecvError::Empty) => break,
            }
        }
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.events.recv_timeout(left) {
                Ok(Event::Telemetry(t)) => {
                    self.latched = Some(t.faults);
                    return Ok(t);
                }
                Ok(Event::Disconnected) | Err(RecvTimeoutError::Disconnected) => return Err(WaitError::Disconnected),
                Ok(_) => {}
                Err(RecvTimeoutError::Timeout) => return Err(WaitError::NoTelemetry(timeout)),
            }
        }
    }

    /// Right after a command returned (acknowledged): drops the events
    /// already received, which the device sent before it took the command,
    /// after judging them for faults; the last telemetry among them, if any.
    pub fn after_command(&mut self) -> Result<Option<Telemetry>, WaitError> {
        let mut last = None;
        loop {
            match self.events.try_recv() {
                Ok(event) => {
                    if let Some(t) = self.judge(event)? {
                        last = Some(t);
                    }
                }
                Err(TryRecvError::Empty) => return Ok(last),
                Err(TryRecvError::Disconnected) => return Err(WaitError::Disconnected),
            }
        }
    }

    /// A telemetry event, or an error for a fault or a disconnection.
    fn judge(&mut self, event: Event) -> Result<Option<Telemetry>, WaitError> {
        match event {
            Event::Telemetry(t) => {
                let fault = match self.latched.as_mut() {
                    Some(latched) => newly_latched(latched, t.faults),
                    None => {
                        self.latched = Some(t.faults);
                        None
                    }
                };
                match fault {
                    Some(fault) => Err(WaitError::Fault { fault, time_ms: t.time_ms }),
                    None => Ok(Some(t)),
                }
            }
            Event::Fault { code, detail, time_ms } => {
                if let (Some(latched), Some(bit)) = (self.latched.as_mut(), Faults::from_code(code)) {
                    // Reported: the telemetry showing its bit is no news.
                    *latched = latched.union(bit);
                }
                Err(WaitError::Fault { fault: Fault::reported(code, detail), time_ms })
            }
            Event::Disconnected => Err(WaitError::Disconnected),
            _ => Ok(None),
        }
    }

    /// The next telemetry report within `timeout`.
    pub fn next_telemetry(&mut self, timeout: Duration) -> Result<Telemetry, WaitError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.events.recv_timeout(left) {
                Ok(event) => {
                    if let Some(t) = self.judge(event)? {
                        return Ok(t);
                    }
                }
                Err(RecvTimeoutError::Disconnected) => return Err(WaitError::Disconnected),
                Err(RecvTimeoutError::Timeout) => return Err(WaitError::NoTelemetry(timeout)),
            }
        }
    }

    /// Waits until the telemetry shows every tube within `tolerance_um` of
    /// `targets_um` and settled, within `timeout`; the report that showed
    /// it. Call [`Watch::after_command`] between the `SetLengths` and this.
    pub fn until_lengths(
        &mut self,
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
            let t = match self.next_telemetry(left) {
                Ok(t) => t,
                Err(WaitError::NoTelemetry(_)) => {
                    return Err(WaitError::NotReached { targets_um, last_um, waited: start.elapsed() })
                }
                Err(e) => return Err(e),
            };
            last_um = t.lengths_um;
            let near = (0..3)
                .all(|i| (i64::from(t.lengths_um[i]) - i64::from(targets_um[i])).abs() <= i64::from(tolerance_um));
            let settled = t.duty_permille.iter().all(|d| d.unsigned_abs() < 5);
            if near && settled {
                return Ok(t);
            }
            if let Some(tube) = Tube::ALL.into_iter().find(|&tube| !t.active.contains(tube)) {
                return Err(WaitError::Stopped { tube, target_um: targets_um[tube.index()], last_um });
            }
        }
    }
}
