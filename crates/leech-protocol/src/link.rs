//! The reliability and safety rules both ends share: sequence numbers,
//! retries, duplicates, link loss, the last-cup rule, and counters.
//!
//! Rules (times in ms of each side's own clock; `u32` clocks wrap, so every
//! comparison here is of a wrapping difference):
//!
//! * **One command in flight.** The host numbers its commands 1, 2, ...,
//!   255, 1, ... ([`Seq::next`]) and sends the next only once the last one
//!   is answered (`Ack`, or `Hello` for a `Hello`) or given up. The one
//!   exception is `Stop`, which the host may send at any time: the command
//!   it overtakes is given up and never sent again.
//! * **Retries.** With no answer [`ACK_TIMEOUT_MS`] after a send, the host
//!   sends the same bytes again, same seq, up to [`MAX_RETRIES`] times, then
//!   gives up and reports the link as failing ([`Pending`]). All the tries
//!   take at most 300 ms, less than [`LINK_TIMEOUT_MS`], so the device never
//!   sees a retry of a command from before a link loss.
//! * **Duplicates.** The device remembers the seq of the last command it
//!   answered and its `Ack` status. A command with that same seq is a retry:
//!   it is not executed again, the remembered `Ack` is sent again, and it is
//!   counted as a duplicate. A `Hello` command (the start of a session), a
//!   link loss and a reset make the device forget, so that the next command
//!   is always carried out ([`Responder`]).
//! * **Link loss.** After the first frame from a host (a valid frame of a
//!   host-to-device type with a seq: [`from_a_host`]), the device expects
//!   another within [`LINK_TIMEOUT_MS`]; the host sends a `Heartbeat`
//!   whenever it has sent nothing for [`HEARTBEAT_MS`]. Frames with seq 0
//!   and report types (an echo of the device's own) do not count. When the
//!   time passes ([`LinkWatch`]) the device stops the motors and keeps the
//!   pumps as they are (a robot on a wall must not let go), latches
//!   `LINK_LOST`, reports it, forgets the remembered seq and stays stopped
//!   until a new motion command arrives.
//! * **Last cup.** The device refuses to switch off the pump of a cup that
//!   holds while the other cup does not hold ([`last_cup_allows`]): defence in
//!   depth behind the host's own interlock. `Stop` is always allowed;
//!   switching a pump on is always allowed.
//! * **Counters.** The device reports what it received in every
//!   `Telemetry` ([`LinkCounters`]).

use core::fmt;

use crate::frame;
use crate::message::{
    AckStatus, Command, Cup, CupConfig, Hello, Refusal, Report, Seq, Version, NO_SENSOR, PROTOCOL_VERSION,
};

/// The serial line's speed, bits per second (8 data bits, no parity, 1 stop bit).
pub const BAUD_RATE: u32 = 115_200;

/// How long the host waits for an answer before sending a command again, ms.
pub const ACK_TIMEOUT_MS: u32 = 50;

/// How many times the host sends a command again before giving up.
pub const MAX_RETRIES: u32 = 5;

/// How long the device waits for a valid frame before it stops the motors, ms.
pub const LINK_TIMEOUT_MS: u32 = 500;

/// The longest the host stays silent: it sends a `Heartbeat` then, ms.
pub const HEARTBEAT_MS: u32 = 100;

/// How long the host waits for the device's `Hello` after opening the port
/// (the Arduino's bootloader runs first), ms.
pub const BOOT_TIMEOUT_MS: u32 = 3000;

/// The shortest telemetry period the device accepts, ms (100 Hz).
pub const MIN_TELEMETRY_PERIOD_MS: u16 = 10;

/// How far beyond its configured limits a tube's measured length may go
/// (overshoot of the position controller) before the device stops the
/// motors and latches `LIMIT_HIT`, um.
pub const LIMIT_MARGIN_UM: i32 = 2_000;

// Every try of a command ends before the device could declare the link lost.
const _: () = assert!((MAX_RETRIES + 1) * ACK_TIMEOUT_MS < LINK_TIMEOUT_MS);
// Several heartbeats fit in the link timeout, so one lost frame is no loss.
const _: () = assert!(3 * HEARTBEAT_MS < LINK_TIMEOUT_MS);

/// The device's link counters as `Telemetry` carries them; each wraps at
/// `u16::MAX`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct LinkCounters {
    /// Frames received whose CRC matched.
    pub rx_frames: u16,
    /// Frames dropped for a CRC mismatch.
    pub bad_crc: u16,
    /// Frames dropped for anything else: oversize, bad COBS, too short, or
    /// a command with seq 0 (which cannot be answered).
    pub bad_frames: u16,
    /// Commands received again with the seq just answered (host retries).
    pub duplicates: u16,
}

impl LinkCounters {
    /// The counters of a device's frame decoder and its responder (each
    /// count's low 16 bits).
    pub fn collect(frames: frame::Counters, responder: &Responder) -> LinkCounters {
        // Truncation is the wrap of a 16-bit counter.
        let low = |count: u32| count as u16;
        LinkCounters {
            rx_frames: low(frames.frames),
            bad_crc: low(frames.bad_crc),
            bad_frames: low(frames.bad_frames.wrapping_add(responder.dropped)),
            duplicates: low(responder.duplicates),
        }
    }
}

/// What the host does next about a command in flight.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Retry {
    /// Keep waiting for its answer.
    Wait,
    /// Send the same bytes again now.
    Resend,
    /// No answer after every try: the link is failing.
    GiveUp,
}

/// The host's command in flight: its seq and when it was sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Pending {
    seq: Seq,
    sent_ms: u32,
    sends: u32,
}

impl Pending {
    /// A command with `seq` sent (for the first time) at `now_ms`.
    pub const fn new(seq: Seq, now_ms: u32) -> Pending {
        Pending { seq, sent_ms: now_ms, sends: 1 }
    }

    /// Its seq.
    pub const fn seq(&self) -> Seq {
        self.seq
    }

    /// How many times it has been sent.
    pub const fn sends(&self) -> u32 {
        self.sends
    }

    /// Whether `report` answers it: an `Ack`, or a `Hello`, with its seq.
    pub fn is_answered_by(&self, report: &Report) -> bool {
        match report {
            Report::Ack { seq, .. } | Report::Hello { reply_to: Some(seq), .. } => *seq == self.seq,
            _ => false,
        }
    }

    /// What to do at `now_ms`; a `Resend` counts as sent at `now_ms`.
    pub fn poll(&mut self, now_ms: u32) -> Retry {
        if now_ms.wrapping_sub(self.sent_ms) < ACK_TIMEOUT_MS {
            Retry::Wait
        } else if self.sends <= MAX_RETRIES {
            self.sends += 1;
            self.sent_ms = now_ms;
            Retry::Resend
        } else {
            Retry::GiveUp
        }
    }
}

/// The device's side of the command rules: answers `Hello`, executes each
/// new command once, answers retries from memory, counts what it drops.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Responder {
    hello: Hello,
    /// The last command answered (since reset or the last `Hello`) and its answer.
    last: Option<(Seq, AckStatus)>,
    duplicates: u32,
    dropped: u32,
}

impl Responder {
    /// A device that introduces itself with `hello`.
    pub const fn new(hello: Hello) -> Responder {
        Responder { hello, last: None, duplicates: 0, dropped: 0 }
    }

    /// The `Hello` the device sends unsolicited once it has started.
    pub const fn boot_hello(&self) -> Report {
        Report::Hello { reply_to: None, hello: self.hello }
    }

    /// Handles the message bytes of one valid frame. A new command is handed
    /// to `execute`, whose status is sent back and remembered; a retry of
    /// the last command gets the remembered `Ack` without executing it; a
    /// command that does not decode is answered with why (without calling
    /// `execute`) when it has a seq, and dropped and counted when not. A
    /// report type is never answered (an echo of the device's own answers
    /// must not ping-pong): dropped and counted. Returns the report to send,
    /// if any.
    pub fn handle(&mut self, message: &[u8], execute: impl FnOnce(Command) -> AckStatus) -> Option<Report> {
        if message.first().is_some_and(|&kind| kind >= 0x80) {
            self.dropped = self.dropped.wrapping_add(1);
            return None;
        }
        let (seq, status) = match Command::decode(message) {
            Ok((seq, Command::Hello)) => {
                self.last = None;
                return Some(Report::Hello { reply_to: Some(seq), hello: self.hello });
            }
            Ok((seq, command)) => match self.repeat(seq) {
                Some(report) => return Some(report),
                None => (seq, execute(command)),
            },
            Err(error) => match error.ack() {
                Some((seq, status)) => match self.repeat(seq) {
                    Some(report) => return Some(report),
                    None => (seq, status),
                },
                None => {
                    self.dropped = self.dropped.wrapping_add(1);
                    return None;
                }
            },
        };
        self.last = Some((seq, status));
        Some(Report::Ack { seq, status })
    }

    /// The remembered answer if `seq` is the last command's (a retry).
    fn repeat(&mut self, seq: Seq) -> Option<Report> {
        let (last, status) = self.last?;
        if last != seq {
            return None;
        }
        self.duplicates = self.duplicates.wrapping_add(1);
        Some(Report::Ack { seq, status })
    }

    /// Forgets the last command (at a link loss): the next one is new
    /// whatever its seq.
    pub fn forget(&mut self) {
        self.last = None;
    }

    /// Retries answered from memory (wraps at `u32::MAX`).
    pub const fn duplicates(&self) -> u32 {
        self.duplicates
    }

    /// Valid frames dropped unanswered: commands with seq 0 and report types
    /// (wraps at `u32::MAX`).
    pub const fn dropped(&self) -> u32 {
        self.dropped
    }
}

/// Whether a valid frame's `message` comes from a host and so restarts the
/// link timer: a host-to-device type (below `0x80`, known or not) with a
/// seq other than 0. A report type, as a line that echoes would send back,
/// does not.
pub fn from_a_host(message: &[u8]) -> bool {
    matches!(message, [kind, seq, ..] if *kind < 0x80 && *seq != 0)
}

/// The device's link-loss timer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct LinkWatch {
    /// When the last frame from a host arrived; `None` before the first one
    /// and after a loss (the timer is disarmed).
    last_ms: Option<u32>,
}

impl LinkWatch {
    /// A timer not yet armed: the link cannot be lost before a host spoke.
    pub const fn new() -> LinkWatch {
        LinkWatch { last_ms: None }
    }

    /// A frame from a host ([`from_a_host`]) arrived at `now_ms`: arm or
    /// restart the timer.
    pub fn frame(&mut self, now_ms: u32) {
        self.last_ms = Some(now_ms);
    }

    /// Whether the link is lost at `now_ms`: true once, when
    /// [`LINK_TIMEOUT_MS`] have passed since the last frame from a host; the timer
    /// is then disarmed until the next one.
    pub fn expired(&mut self, now_ms: u32) -> bool {
        match self.last_ms {
            Some(last) if now_ms.wrapping_sub(last) >= LINK_TIMEOUT_MS => {
                self.last_ms = None;
                true
            }
            _ => false,
        }
    }
}

/// A cup's pump and whether it holds, as the device knows them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct CupState {
    /// Its pump is on.
    pub pump_on: bool,
    /// It holds (by [`holds`]).
    pub holding: bool,
}

/// The last-cup rule: whether `Pump { cup, on }` may be carried out with
/// the cups in `cups` (indexed by [`Cup::index`]).
///
/// Switching a pump on is always allowed, and so is switching off a cup
/// that does not hold (it changes nothing that keeps the robot up).
/// Switching off a holding cup is refused while the other cup does not
/// hold: with [`Refusal::LastCup`] when the other cup's pump is off, with
/// [`Refusal::NotHolding`] when it is on but the cup has not attached yet.
pub fn last_cup_allows(cup: Cup, on: bool, cups: [CupState; 2]) -> Result<(), Refusal> {
    let [rear, front] = cups;
    let (this, other) = match cup {
        Cup::Rear => (rear, front),
        Cup::Front => (front, rear),
    };
    if on || !this.holding || other.holding {
        Ok(())
    } else if other.pump_on {
        Err(Refusal::NotHolding)
    } else {
        Err(Refusal::LastCup)
    }
}

/// Whether a cup holds now (the rule of [`CupConfig`]): `was_holding` its
/// last verdict, `vacuum_kpa_x10` its reading ([`NO_SENSOR`] without a
/// sensor), `pump_on_ms` how long its pump has been on.
pub fn holds(was_holding: bool, pump_on: bool, vacuum_kpa_x10: u16, pump_on_ms: u32, config: &CupConfig) -> bool {
    if !pump_on {
        false
    } else if vacuum_kpa_x10 == NO_SENSOR {
        pump_on_ms >= u32::from(config.attach_ms)
    } else if was_holding {
        vacuum_kpa_x10 >= config.detach_kpa_x10
    } else {
        vacuum_kpa_x10 >= config.attach_kpa_x10
    }
}

/// A device whose protocol major version differs from the host's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct VersionMismatch {
    /// The host's version ([`PROTOCOL_VERSION`]).
    pub host: Version,
    /// The device's version, from its `Hello`.
    pub device: Version,
}

impl fmt::Display for VersionMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "protocol version mismatch: the host speaks {}, the device speaks {} (the major versions must match)",
            self.host, self.device
        )
    }
}

impl core::error::Error for VersionMismatch {}

/// Whether the host may talk to a device speaking `device`: the major
/// versions must be equal. A different minor version is fine (a minor
/// version only adds; each side uses what both know).
pub fn check_version(device: Version) -> Result<(), VersionMismatch> {
    if device.major == PROTOCOL_VERSION.major {
        Ok(())
    } else {
        Err(VersionMismatch { host: PROTOCOL_VERSION, device })
    }
}
