//! The stride executor: a climb plan (`leech::stride::Plan`), or single
//! steps of one, carried out on a robot through a [`Link`], behind the
//! stride's interlock (`leech::stride::StrideMachine`).
//!
//! Rules (units in names: `_um` micrometres, `_mm_s` mm/s):
//!
//! * **Interlock first.** [`Executor::run`] replays the whole plan through a
//!   copy of the interlock before sending anything: a release is judged on
//!   the plan's safety factor of the other cup after it (the step's
//!   `front_safety_factor` for `release_rear`, `rear_safety_factor` for
//!   `release_front`), an attach on the plan's touchdown (flush). A refusal
//!   is an [`ExecError::Interlock`] and the robot is not touched. Each step
//!   is judged again as it runs, and a release also needs the telemetry to
//!   say the other cup holds.
//! * **Moves** (`start`, `push`, `pull`): `SetLengths` with L1 = LA and
//!   L2 = L3 = LB (um, rounded), then wait until the telemetry's lengths are
//!   all within [`Options::tolerance_um`] of them; the wait is bounded by the
//!   farthest travel at [`Options::speed_mm_s`] plus [`Options::margin`].
//! * **attach_X**: pump X on, wait until the telemetry says X holds (at most
//!   [`Options::cup_timeout`]).
//! * **release_X**: the interlock, then pump X off, wait until the telemetry
//!   says X no longer holds.
//! * **Fresh telemetry.** After each command the executor drops the
//!   reports already received (module rules of [`crate::wait`]): they were
//!   sent before the device took the command, so a step is judged only on
//!   reports sent after it (they are still checked for faults).
//! * **Faults.** A `Fault` report, or a fault bit newly set in
//!   `Telemetry.faults` (the bits latched when the executor started, or in
//!   the report before, are known; a report can be lost), fails the step,
//!   naming the fault. So does a tube leaving position control
//!   (`Telemetry.active`) during a move before it arrived.
//! * **Failure.** A fault, a refused or unanswered command, a wait
//!   that times out, telemetry silent for [`Options::silence`], or a lost
//!   link: the executor sends `Stop` (the motors halt), leaves the pumps as
//!   they are (a cup holding keeps holding), and returns the error naming
//!   the step (index in the plan, phase) and the reason.

use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use leech::error::InputError;
use leech::stride::{
    Command as StrideCommand, Cup as StrideCup, Holding, Phase, Plan, Step, StrideError, StrideMachine,
};
use leech_protocol::message::{Cup, Fault, Faults, Telemetry, Tube};

use crate::host::{Event, Link, LinkError};
use crate::wait::newly_latched;

/// How the executor waits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// How close each tube must come to its target (um).
    pub tolerance_um: i32,
    /// The tube speed a move's timeout assumes (mm/s).
    pub speed_mm_s: f64,
    /// Added to a move's travel time (the loop's settling, telemetry's period).
    pub margin: Duration,
    /// The longest an attach may take to hold, or a release to let go.
    pub cup_timeout: Duration,
    /// The longest the telemetry may be silent.
    pub silence: Duration,
    /// The telemetry period the executor asks for (ms).
    pub telemetry_period_ms: u16,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            tolerance_um: 500,
            speed_mm_s: 20.0,
            margin: Duration::from_secs(2),
            cup_timeout: Duration::from_secs(3),
            silence: Duration::from_millis(500),
            telemetry_period_ms: 20,
        }
    }
}

/// A step carried out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepDone {
    /// Its index in the plan.
    pub index: usize,
    /// Steps in the plan.
    pub total: usize,
    /// Its phase.
    pub phase: Phase,
    /// How long it took.
    pub took: Duration,
}

/// Why a plan or a step was not carried out.
#[derive(Debug, thiserror::Error)]
pub enum ExecError {
    /// The interlock refused the step.
    #[error("step {index} ({}): {source}", phase.name())]
    Interlock {
        /// The step's index.
        index: usize,
        /// Its phase.
        phase: Phase,
        /// The interlock's reason.
        source: StrideError,
    },
    /// A release whose partner cup the telemetry does not show holding.
    #[error("step {index} ({}): the {partner} cup does not hold (telemetry), the {} cup may not release", phase.name(), partner.other())]
    PartnerNotHolding {
        /// The step's index.
        index: usize,
        /// Its phase.
        phase: Phase,
        /// The cup that should hold.
        partner: StrideCup,
    },
    /// A command failed: refused, rejected, unanswered, or the link is down.
    #[error("step {index} ({}): {source}", phase.name())]
    Link {
        /// The step's index.
        index: usize,
        /// Its phase.
        phase: Phase,
        /// The driver's error.
        source: LinkError,
    },
    /// The device reported a fault, or latched one the telemetry shows.
    #[error("step {index} ({}): the device reported {fault}", phase.name())]
    Fault {
        /// The step's index.
        index: usize,
        /// Its phase.
        phase: Phase,
        /// Which, and on what.
        fault: Fault,
    },
    /// A tube left position control during a move, before it arrived.
    #[error("step {index} ({}): the device stopped tube {tube}", phase.name())]
    Stopped {
        /// The step's index.
        index: usize,
        /// Its phase.
        phase: Phase,
        /// The tube.
        tube: Tube,
    },
    /// The telemetry did not confirm the step in time.
    #[error("step {index} ({}): {what} not confirmed within {waited_ms} ms", phase.name())]
    Timeout {
        /// The step's index.
        index: usize,
        /// Its phase.
        phase: Phase,
        /// What was awaited.
        what: &'static str,
        /// How long the executor waited (ms).
        waited_ms: u64,
    },
    /// The link was lost: telemetry silent, commands unanswered, the port
    /// failed, or the device reset.
    #[error("step {index} ({}): the link was lost ({why})", phase.name())]
    LinkLost {
        /// The step's index.
        index: usize,
        /// Its phase.
        phase: Phase,
        /// What showed it.
        why: &'static str,
    },
    /// Before any step: no telemetry to start from.
    #[error("no telemetry from the device within {waited_ms} ms")]
    NoTelemetry {
        /// How long the executor waited (ms).
        waited_ms: u64,
    },
    /// Before any step: the telemetry's holds are no state of the stride
    /// (no cup holds), or the minimum safety factor is not one.
    #[error("cannot start the stride's interlock: {0}")]
    Setup(#[from] InputError),
    /// Before any step: setting the telemetry up failed.
    #[error("cannot set the telemetry up: {0}")]
    Telemetry(LinkError),
}

/// What the executor needs of a plan's step: its phase, the tube lengths
/// at its end and the safety factors the plan found there (the evidence a
/// release is judged on).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    /// The phase.
    pub phase: Phase,
    /// Tube lengths (LA, LB) at its end (m): L1 = LA, L2 = L3 = LB.
    pub lengths_m: [f64; 2],
    /// The rear cup's safety factor at its end, when it holds.
    pub rear_safety_factor: Option<f64>,
    /// The front cup's safety factor at its end, when it holds.
    pub front_safety_factor: Option<f64>,
}

impl From<&Step> for Move {
    fn from(step: &Step) -> Move {
        Move {
            phase: step.phase,
            lengths_m: step.lengths_m,
            rear_safety_factor: step.rear_safety_factor,
            front_safety_factor: step.front_safety_factor,
        }
    }
}

/// The moves of every step of `plan`.
pub fn moves(plan: &Plan) -> Vec<Move> {
    plan.steps.iter().map(Move::from).collect()
}

/// Carries out stride steps on a robot (module doc).
pub struct Executor<'a> {
    link: &'a Link,
    events: Receiver<Event>,
    machine: StrideMachine,
    options: Options,
    /// The last telemetry.
    last: Telemetry,
    /// When it arrived.
    last_at: Instant,
    /// The faults the last telemetry latched.
    latched: Faults,
}

/// The step being carried out: its index and phase, for errors.
#[derive(Clone, Copy)]
struct At {
    index: usize,
    phase: Phase,
}

impl<'a> Executor<'a> {
    /// An executor on `link`: sets the telemetry period, waits for a report
    /// and starts the interlock from the cups it says hold, refusing
    /// releases below `min_safety_factor` (the robot file's
    /// `cup.min_safety_factor`).
    pub fn new(link: &'a Link, min_safety_factor: f64, options: Options) -> Result<Executor<'a>, ExecError> {
        let events = link.subscribe();
        link.set_telemetry(options.telemetry_period_ms).map_err(ExecError::Telemetry)?;
        // Reports sent before the device took the command came in before its
        // answer: drop them, so that the state starts from a fresh report.
        while events.try_recv().is_ok() {}
        let waited = options.silence.max(Duration::from_millis(u64::from(options.telemetry_period_ms) * 5));
        let end = Instant::now() + waited;
        let last = loop {
            let left = end.saturating_duration_since(Instant::now());
            match events.recv_timeout(left) {
                Ok(Event::Telemetry(t)) => break t,
                Ok(_) => {}
                Err(_) => return Err(ExecError::NoTelemetry { waited_ms: waited.as_millis() as u64 }),
            }
        };
        let holding = Holding { rear: last.holding.contains(Cup::Rear), front: last.holding.contains(Cup::Front) };
        let machine = StrideMachine::with_holding(holding, min_safety_factor)?;
        let latched = last.faults;
        Ok(Executor { link, events, machine, options, last, last_at: Instant::now(), latched })
    }

    /// The interlock's state: which cups hold.
    pub fn holding(&self) -> Holding {
        self.machine.holding()
    }

    /// The last telemetry report.
    pub fn telemetry(&self) -> &Telemetry {
        &self.last
    }

    /// Checks every step of `plan` against a copy of the interlock, in
    /// order, without sending anything.
    pub fn check(&self, plan: &[Move]) -> Result<(), ExecError> {
        let mut machine = self.machine;
        for (index, step) in plan.iter().enumerate() {
            machine.apply(command(step)).map_err(|source| ExecError::Interlock { index, phase: step.phase, source })?;
        }
        Ok(())
    }

    /// Carries out every step of `plan` in order (the interlock checked on
    /// the whole plan first), calling `progress` after each.
    pub fn run(&mut self, plan: &[Move], mut progress: impl FnMut(StepDone)) -> Result<(), ExecError> {
        self.check(plan)?;
        let total = plan.len();
        for (index, step) in plan.iter().enumerate() {
            let started = Instant::now();
            self.step(index, step)?;
            progress(StepDone { index, total, phase: step.phase, took: started.elapsed() });
        }
        Ok(())
    }

    /// Carries out one step (`index`: its place in its plan, for errors);
    /// on failure the motors are stopped and the pumps left as they are.
    pub fn step(&mut self, index: usize, step: &Move) -> Result<(), ExecError> {
        let at = At { index, phase: step.phase };
        let result = self.try_step(at, step);
        if result.is_err() {
            // Whatever failed, the tubes must not go on moving; the pumps
            // stay as they are (a cup that holds keeps holding). The Stop
            // may itself fail on a dead line: the device stops on its own
            // when the link is lost (500 ms).
            let _ = self.link.stop();
        }
        result
    }

    fn try_step(&mut self, at: At, step: &Move) -> Result<(), ExecError> {
        let command = command(step);
        // Judged before anything is sent; applied once the telemetry confirms.
        self.machine.check(command).map_err(|source| ExecError::Interlock {
            index: at.index,
            phase: at.phase,
            source,
        })?;
        let link_error = |source| ExecError::Link { index: at.index, phase: at.phase, source };
        match command {
            StrideCommand::Move => {
                let [la, lb] = step.lengths_m.map(|l| (l * 1e6).round() as i32);
                let target = [la, lb, lb];
                let travel_um = (0..3).map(|i| (target[i] - self.last.lengths_um[i]).abs()).max().unwrap_or(0);
                let travel = Duration::from_secs_f64(f64::from(travel_um) / 1000.0 / self.options.speed_mm_s);
                self.link.set_lengths(target).map_err(link_error)?;
                self.after_command(at)?;
                let tolerance = self.options.tolerance_um;
                let (index, phase) = (at.index, at.phase);
                self.wait(at, "the tube lengths", travel + self.options.margin, |t| {
                    if (0..3).all(|i| (t.lengths_um[i] - target[i]).abs() <= tolerance) {
                        return Ok(true);
                    }
                    // Every tube stays under position control until it arrives.
                    match Tube::ALL.into_iter().find(|&tube| !t.active.contains(tube)) {
                        Some(tube) => Err(ExecError::Stopped { index, phase, tube }),
                        None => Ok(false),
                    }
                })?;
            }
            StrideCommand::Attach { cup, .. } => {
                self.link.pump(wire(cup), true).map_err(link_error)?;
                self.after_command(at)?;
                self.wait(at, "the cup's hold", self.options.cup_timeout, |t| Ok(t.holding.contains(wire(cup))))?;
            }
            StrideCommand::Release { cup, .. } => {
                if check_pump_off(wire(cup), &self.last).is_err() {
                    return Err(ExecError::PartnerNotHolding {
                        index: at.index,
                        phase: at.phase,
                        partner: cup.other(),
                    });
                }
                self.link.pump(wire(cup), false).map_err(link_error)?;
                self.after_command(at)?;
                self.wait(at, "the cup's release", self.options.cup_timeout, |t| Ok(!t.holding.contains(wire(cup))))?;
            }
        }
        self.machine.apply(command).map_err(|source| ExecError::Interlock {
            index: at.index,
            phase: at.phase,
            source,
        })?;
        Ok(())
    }

    /// Right after a command was acknowledged: drops the events already
    /// received (sent before the device took the command), failing on a
    /// fault or a lost link among them.
    fn after_command(&mut self, at: At) -> Result<(), ExecError> {
        while let Ok(event) = self.events.try_recv() {
            self.judge(at, event)?;
        }
        Ok(())
    }

    /// Takes in one event: telemetry becomes the last report (true); a
    /// fault, news of a lost link, or a fault bit newly latched is an error.
    fn judge(&mut self, at: At, event: Event) -> Result<bool, ExecError> {
        let (index, phase) = (at.index, at.phase);
        match event {
            Event::Telemetry(t) => {
                self.last = t;
                self.last_at = Instant::now();
                match newly_latched(&mut self.latched, t.faults) {
                    Some(fault) => Err(ExecError::Fault { index, phase, fault }),
                    None => Ok(true),
                }
            }
            Event::Fault { code, detail, .. } => {
                if let Some(bit) = Faults::from_code(code) {
                    // Reported: the telemetry showing its bit is no news.
                    self.latched = self.latched.union(bit);
                }
                Err(ExecError::Fault { index, phase, fault: Fault::reported(code, detail) })
            }
            Event::NoAnswer { .. } => Err(ExecError::LinkLost { index, phase, why: "a command got no answer" }),
            Event::Disconnected => Err(ExecError::LinkLost { index, phase, why: "the port failed" }),
            Event::DeviceReset(_) => Err(ExecError::LinkLost { index, phase, why: "the device reset" }),
            // A reconnection follows a disconnection, a restore a
            // disconnection or a reset: each already an error.
            Event::Reconnected(_) | Event::Restored(_) => Ok(false),
        }
    }

    /// Waits at most `limit` for a telemetry report that satisfies `done`
    /// (or that `done` finds wrong: its error); a fault, a lost link or
    /// silent telemetry ends the wait in an error.
    fn wait(
        &mut self,
        at: At,
        what: &'static str,
        limit: Duration,
        done: impl Fn(&Telemetry) -> Result<bool, ExecError>,
    ) -> Result<(), ExecError> {
        let (index, phase) = (at.index, at.phase);
        let started = Instant::now();
        let end = started + limit;
        loop {
            let now = Instant::now();
            if now >= end {
                return Err(ExecError::Timeout { index, phase, what, waited_ms: limit.as_millis() as u64 });
            }
            let silent_until = self.last_at + self.options.silence;
            if now >= silent_until {
                return Err(ExecError::LinkLost { index, phase, why: "the telemetry went silent" });
            }
            match self.events.recv_timeout(end.min(silent_until) - now) {
                Ok(event) => {
                    if self.judge(at, event)? && done(&self.last)? {
                        return Ok(());
                    }
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(ExecError::LinkLost { index, phase, why: "the driver closed" })
                }
            }
        }
    }
}

/// Whether the stride's interlock lets `cup`'s pump be switched off, judged
/// on the device's latest telemetry `latest`: a cup that holds may let go
/// only while the other cup holds (`StrideError::LastHold` otherwise); a cup
/// that does not hold may always be switched off. The host's own check,
/// before the device's last-cup rule (docs/protocol.md, 9.2).
pub fn check_pump_off(cup: Cup, latest: &Telemetry) -> Result<(), StrideError> {
    let holding = Holding { rear: latest.holding.contains(Cup::Rear), front: latest.holding.contains(Cup::Front) };
    let stride_cup = match cup {
        Cup::Rear => StrideCup::Rear,
        Cup::Front => StrideCup::Front,
    };
    // A cup that holds: the machine has a state. The safety factor is not
    // this check's to judge (any passes the minimum of 1).
    let Ok(machine) = StrideMachine::with_holding(holding, 1.0) else { return Ok(()) };
    match machine.check(StrideCommand::Release { cup: stride_cup, partner_safety_factor: f64::INFINITY }) {
        Ok(_) | Err(StrideError::AlreadyReleased { .. }) => Ok(()),
        Err(e) => Err(e),
    }
}

/// The interlock's command for `step`, with the plan's evidence: the
/// touchdown lies flush; a release leaves the other cup at the safety
/// factor the plan found after it (NaN, which the interlock refuses, when
/// the plan has none).
fn command(step: &Move) -> StrideCommand {
    let after = match step.phase {
        Phase::ReleaseRear => step.front_safety_factor,
        Phase::ReleaseFront => step.rear_safety_factor,
        _ => None,
    };
    step.phase.command(leech::stride::Evidence { flush: true, safety_factor: after.unwrap_or(f64::NAN) })
}

/// The protocol's name of a stride's cup.
fn wire(cup: StrideCup) -> Cup {
    match cup {
        StrideCup::Rear => Cup::Rear,
        StrideCup::Front => Cup::Front,
    }
}
