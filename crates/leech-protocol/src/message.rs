//! The typed messages: [`Command`]s from the host, [`Report`]s from the
//! device, and their bytes.
//!
//! Rules:
//!
//! * A message is `type: u8`, `seq: u8`, then a body of fixed length for its
//!   type; every multi-byte field is little-endian. The type's high bit says
//!   who sends it: `0x01..=0x7F` the host ([`Command`]), `0x80..=0xFF` the
//!   device ([`Report`]). [`types`] lists the type bytes and body lengths.
//! * Every command carries a sequence number [`Seq`] in `1..=255`. The device
//!   answers it with an `Ack` carrying the same number (a `Hello` request is
//!   answered by a `Hello`, with the same number). `seq = 0` marks the
//!   device's unsolicited reports: `Telemetry`, `Fault` and the `Hello` sent
//!   at reset.
//! * Units are in the field names: `_um` micrometres, `_ms` milliseconds,
//!   `_um_s` micrometres per second, `_kpa_x10` tenths of a kilopascal of
//!   vacuum (ambient minus absolute pressure), `_permille` parts per
//!   thousand of full motor duty, `_x1000` thousandths, `_q16` signed 16.16
//!   fixed point (the raw `i32` divided by 65536).
//! * Tubes are indexed `0 = L1` (the centre tube), `1 = L2`, `2 = L3`; a
//!   planar robot sets `L2 = L3`. Cups are `0 = rear` (driving unit),
//!   `1 = front` (endpoint). Bit sets use bit `i` for index `i`.
//! * Decoding checks, in order: the two header bytes are present; for a
//!   command, the seq is not 0 (a command that cannot be answered is
//!   dropped, whatever its type); the type is one this side receives; the
//!   body has the type's exact length; for a report, the seq fits the type;
//!   every field with a closed set of values (tube, cup, boolean, status,
//!   reason, fault code) holds one of them. Reserved bits in bit sets are
//!   sent as 0 and ignored on receipt; numeric ranges (lengths against
//!   limits, duty) are the receiver's business, not the decoder's. Decoding
//!   never panics.
//! * Within one major protocol version a message's layout never changes; a
//!   minor version only adds message types and bits.

use core::fmt;
use core::num::NonZeroU8;

use crate::frame::{self, MAX_MESSAGE};
use crate::link::LinkCounters;
use crate::wire::{Reader, Writer};
use crate::BufferTooSmall;

/// The protocol version this crate speaks.
pub const PROTOCOL_VERSION: Version = Version { major: 1, minor: 0 };

/// A vacuum reading from a cup without a sensor.
pub const NO_SENSOR: u16 = 0xFFFF;

/// Type bytes and body lengths (bytes) of every message.
pub mod types {
    /// Host: ask for the device's `Hello` (and start a session).
    pub const HELLO: u8 = 0x01;
    /// Host: nothing to do, the link is alive.
    pub const HEARTBEAT: u8 = 0x02;
    /// Host: stop all motors.
    pub const STOP: u8 = 0x03;
    /// Host: move the three tubes to lengths.
    pub const SET_LENGTHS: u8 = 0x04;
    /// Host: move one tube by a distance.
    pub const JOG: u8 = 0x05;
    /// Host: switch a cup's vacuum pump.
    pub const PUMP: u8 = 0x06;
    /// Host: set the telemetry period.
    pub const SET_TELEMETRY: u8 = 0x07;
    /// Host: clear latched faults.
    pub const CLEAR_FAULTS: u8 = 0x08;
    /// Host: one tube's encoder scale, limits and gains.
    pub const CONFIGURE_TUBE: u8 = 0x09;
    /// Host: the cups' holding thresholds.
    pub const CONFIGURE_CUPS: u8 = 0x0A;
    /// Device: the answer to a command.
    pub const ACK: u8 = 0x80;
    /// Device: versions and capabilities.
    pub const DEVICE_HELLO: u8 = 0x81;
    /// Device: the periodic state report.
    pub const TELEMETRY: u8 = 0x82;
    /// Device: a fault was raised.
    pub const FAULT: u8 = 0x83;

    /// The body length of a known type, in bytes.
    pub const fn body_len(type_byte: u8) -> Option<usize> {
        Some(match type_byte {
            HELLO | HEARTBEAT | STOP => 0,
            SET_LENGTHS => 12,
            JOG => 5,
            PUMP | SET_TELEMETRY | CLEAR_FAULTS => 2,
            CONFIGURE_TUBE => 36,
            CONFIGURE_CUPS => 6,
            ACK => 2,
            DEVICE_HELLO => 8,
            TELEMETRY => 52,
            FAULT => 6,
            _ => return None,
        })
    }

    /// The name of a known type, as the spec writes it.
    pub const fn name(type_byte: u8) -> Option<&'static str> {
        Some(match type_byte {
            HELLO => "Hello",
            HEARTBEAT => "Heartbeat",
            STOP => "Stop",
            SET_LENGTHS => "SetLengths",
            JOG => "Jog",
            PUMP => "Pump",
            SET_TELEMETRY => "SetTelemetry",
            CLEAR_FAULTS => "ClearFaults",
            CONFIGURE_TUBE => "ConfigureTube",
            CONFIGURE_CUPS => "ConfigureCups",
            ACK => "Ack",
            DEVICE_HELLO => "DeviceHello",
            TELEMETRY => "Telemetry",
            FAULT => "Fault",
            _ => return None,
        })
    }

    /// Whether the device sends this type (the high bit).
    pub const fn from_device(type_byte: u8) -> bool {
        type_byte & 0x80 != 0
    }
}

/// A command's sequence number, `1..=255` (0 marks unsolicited reports).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Seq(NonZeroU8);

impl Seq {
    /// The first number of a session.
    pub const FIRST: Seq = Seq(NonZeroU8::MIN);

    /// `value` as a sequence number; `None` for 0.
    pub const fn new(value: u8) -> Option<Seq> {
        match NonZeroU8::new(value) {
            Some(v) => Some(Seq(v)),
            None => None,
        }
    }

    /// The number.
    pub const fn get(self) -> u8 {
        self.0.get()
    }

    /// The number after this one: 255 is followed by 1, never 0.
    pub const fn next(self) -> Seq {
        match Seq::new(self.get().wrapping_add(1)) {
            Some(next) => next,
            None => Seq::FIRST,
        }
    }
}

impl fmt::Display for Seq {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.get())
    }
}

/// One of the three tubes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Tube {
    /// The centre tube (index 0).
    L1,
    /// The second tube (index 1).
    L2,
    /// The third tube (index 2).
    L3,
}

impl Tube {
    /// The three tubes in index order.
    pub const ALL: [Tube; 3] = [Tube::L1, Tube::L2, Tube::L3];

    /// Its index on the wire and in arrays.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The tube at wire index `index`.
    pub const fn from_index(index: u8) -> Option<Tube> {
        match index {
            0 => Some(Tube::L1),
            1 => Some(Tube::L2),
            2 => Some(Tube::L3),
            _ => None,
        }
    }
}

impl fmt::Display for Tube {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "L{}", self.index() + 1)
    }
}

/// One of the two suction cups.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Cup {
    /// The cup on the driving unit (index 0).
    Rear,
    /// The cup on the endpoint (index 1).
    Front,
}

impl Cup {
    /// Both cups in index order.
    pub const BOTH: [Cup; 2] = [Cup::Rear, Cup::Front];

    /// Its index on the wire and in arrays.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The cup at wire index `index`.
    pub const fn from_index(index: u8) -> Option<Cup> {
        match index {
            0 => Some(Cup::Rear),
            1 => Some(Cup::Front),
            _ => None,
        }
    }

    /// The other cup.
    pub const fn other(self) -> Cup {
        match self {
            Cup::Rear => Cup::Front,
            Cup::Front => Cup::Rear,
        }
    }
}

impl fmt::Display for Cup {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Cup::Rear => "rear",
            Cup::Front => "front",
        })
    }
}

/// A set of cups, bit `i` for cup index `i` (bits 2..=7 reserved).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct CupSet(pub u8);

impl CupSet {
    /// Whether `cup` is in the set.
    pub const fn contains(self, cup: Cup) -> bool {
        self.0 & (1 << cup as u8) != 0
    }

    /// The set with `cup` in it or not.
    pub const fn with(self, cup: Cup, member: bool) -> CupSet {
        let bit = 1 << cup as u8;
        CupSet(if member { self.0 | bit } else { self.0 & !bit })
    }
}

/// A set of tubes, bit `i` for tube index `i` (bits 3..=7 reserved).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TubeSet(pub u8);

impl TubeSet {
    /// All three tubes.
    pub const ALL: TubeSet = TubeSet(0b111);

    /// Whether `tube` is in the set.
    pub const fn contains(self, tube: Tube) -> bool {
        self.0 & (1 << tube as u8) != 0
    }

    /// The set with `tube` in it or not.
    pub const fn with(self, tube: Tube, member: bool) -> TubeSet {
        let bit = 1 << tube as u8;
        TubeSet(if member { self.0 | bit } else { self.0 & !bit })
    }
}

/// Latched device faults, one bit each (bits 6..=15 reserved). The bit's
/// number is the fault's code in a [`Report::Fault`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Faults(pub u16);

impl Faults {
    /// No valid frame for `LINK_TIMEOUT_MS`: motors stopped, pumps kept.
    pub const LINK_LOST: Faults = Faults(1 << 0);
    /// A motor drove without its encoder moving: motors stopped, motion
    /// refused until cleared. Detail: the tube index.
    pub const MOTOR_STALL: Faults = Faults(1 << 1);
    /// A holding cup stopped holding with its pump on: motors stopped.
    /// Detail: the cup index.
    pub const VACUUM_LOST: Faults = Faults(1 << 2);
    /// A tube's measured length left its configured limits: motors stopped.
    /// Detail: the tube index.
    pub const LIMIT_HIT: Faults = Faults(1 << 3);
    /// The last reset was the watchdog's.
    pub const WATCHDOG_RESET: Faults = Faults(1 << 4);
    /// The last reset was a brown-out (supply voltage dip).
    pub const BROWNOUT_RESET: Faults = Faults(1 << 5);

    const NAMES: [&'static str; 6] =
        ["link_lost", "motor_stall", "vacuum_lost", "limit_hit", "watchdog_reset", "brownout_reset"];

    /// The fault with code (bit number) `code`, if it is below 16.
    pub const fn from_code(code: u8) -> Option<Faults> {
        if code < 16 {
            Some(Faults(1 << code))
        } else {
            None
        }
    }

    /// Whether every fault of `other` is set here.
    pub const fn contains(self, other: Faults) -> bool {
        self.0 & other.0 == other.0
    }

    /// The faults of both.
    pub const fn union(self, other: Faults) -> Faults {
        Faults(self.0 | other.0)
    }

    /// These faults without those of `other`.
    pub const fn without(self, other: Faults) -> Faults {
        Faults(self.0 & !other.0)
    }

    /// The name of fault code `code`, for the codes this version defines.
    pub fn name(code: u8) -> Option<&'static str> {
        Faults::NAMES.get(usize::from(code)).copied()
    }
}

impl fmt::Display for Faults {
    /// The names joined by `+` (`bit N` for reserved bits), or `none`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0 == 0 {
            return f.write_str("none");
        }
        let mut first = true;
        for code in 0..16u8 {
            if self.0 & (1 << code) == 0 {
                continue;
            }
            if !first {
                f.write_str("+")?;
            }
            first = false;
            match Faults::name(code) {
                Some(name) => f.write_str(name)?,
                None => write!(f, "bit {code}")?,
            }
        }
        Ok(())
    }
}

/// One fault as a person reads it (the Display): "a motor stall on tube
/// L2", "link lost", "vacuum lost on the rear cup". From a `Fault` report
/// ([`Fault::reported`]: code and detail) or from a bit newly set in
/// `Telemetry.faults` ([`Fault::latched`]: the detail unknown).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Fault {
    /// Its code: its bit number in [`Faults`].
    pub code: u8,
    /// The tube or cup it concerns, when known (a `Fault` report's detail).
    pub detail: Option<u8>,
}

impl Fault {
    /// The fault of a `Fault` report.
    pub const fn reported(code: u8, detail: u8) -> Fault {
        Fault { code, detail: Some(detail) }
    }

    /// The lowest fault of `faults` (a bit newly set in `Telemetry.faults`,
    /// its detail unknown); `None` for no fault.
    pub const fn latched(faults: Faults) -> Option<Fault> {
        if faults.0 == 0 {
            None
        } else {
            // At most 15.
            Some(Fault { code: faults.0.trailing_zeros() as u8, detail: None })
        }
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // What the detail names: a tube, a cup or nothing (section 9.4).
        let on_tube = |f: &mut fmt::Formatter<'_>| match self.detail {
            Some(d) => match Tube::from_index(d) {
                Some(tube) => write!(f, " on tube {tube}"),
                None => write!(f, " on tube index {d} (no such tube)"),
            },
            None => Ok(()),
        };
        let on_cup = |f: &mut fmt::Formatter<'_>| match self.detail {
            Some(d) => match Cup::from_index(d) {
                Some(cup) => write!(f, " on the {cup} cup"),
                None => write!(f, " on cup index {d} (no such cup)"),
            },
            None => Ok(()),
        };
        match self.code {
            0 => f.write_str("link lost"),
            1 => f.write_str("a motor stall").and_then(|()| on_tube(f)),
            2 => f.write_str("vacuum lost").and_then(|()| on_cup(f)),
            3 => f.write_str("a tube past its length limits").and_then(|()| on_tube(f)),
            4 => f.write_str("a watchdog reset"),
            5 => f.write_str("a brown-out reset"),
            code => match self.detail {
                Some(d) => write!(f, "fault {code} (detail {d})"),
                None => write!(f, "fault {code}"),
            },
        }
    }
}

/// What the device can do, one bit each (bits 2..=15 reserved).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Capabilities(pub u16);

impl Capabilities {
    /// The rear cup has a vacuum sensor.
    pub const REAR_VACUUM_SENSOR: Capabilities = Capabilities(1 << 0);
    /// The front cup has a vacuum sensor.
    pub const FRONT_VACUUM_SENSOR: Capabilities = Capabilities(1 << 1);

    /// Whether every capability of `other` is here.
    pub const fn contains(self, other: Capabilities) -> bool {
        self.0 & other.0 == other.0
    }
}

/// What kind of device answers (values other than those named are kept as
/// they are, for devices newer than this crate).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DeviceKind(pub u8);

impl DeviceKind {
    /// The LEeCH controller firmware on an Arduino Mega 2560.
    pub const MEGA: DeviceKind = DeviceKind(1);
    /// A simulated robot.
    pub const SIMULATOR: DeviceKind = DeviceKind(2);
}

impl fmt::Display for DeviceKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            DeviceKind::MEGA => f.write_str("Arduino Mega controller"),
            DeviceKind::SIMULATOR => f.write_str("simulator"),
            DeviceKind(other) => write!(f, "device kind {other}"),
        }
    }
}

/// A protocol version: a different major is a different protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Version {
    /// Layouts and rules change only with it.
    pub major: u8,
    /// Additions only (new message types, new bits).
    pub minor: u8,
}

impl fmt::Display for Version {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}", self.major, self.minor)
    }
}

/// The firmware's own version (informative only).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FirmwareVersion {
    /// Major.
    pub major: u8,
    /// Minor.
    pub minor: u8,
    /// Patch.
    pub patch: u8,
}

impl fmt::Display for FirmwareVersion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}.{}", self.major, self.minor, self.patch)
    }
}

/// What the device says about itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Hello {
    /// The protocol version the device speaks.
    pub protocol: Version,
    /// Its firmware version.
    pub firmware: FirmwareVersion,
    /// What kind of device it is.
    pub kind: DeviceKind,
    /// What it can do.
    pub capabilities: Capabilities,
}

/// Why the device refused a well-formed command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Refusal {
    /// Switching this pump off would release the last holding cup: the other
    /// cup's pump is off.
    LastCup = 1,
    /// Switching this pump off would release the last holding cup: the other
    /// cup's pump is on but it does not hold (yet).
    NotHolding = 2,
    /// A value outside its allowed range (a length beyond the tube's limits,
    /// a telemetry period under 10 ms, an invalid configuration).
    OutOfRange = 3,
    /// Motion refused while a blocking fault (motor stall) is latched.
    Faulted = 4,
    /// Not allowed in the device's state (configuring a moving tube).
    BadState = 5,
    /// Motion of a tube that has not been configured since reset.
    NotConfigured = 6,
}

impl Refusal {
    /// The reason at wire code `code`.
    pub const fn from_code(code: u8) -> Option<Refusal> {
        Some(match code {
            1 => Refusal::LastCup,
            2 => Refusal::NotHolding,
            3 => Refusal::OutOfRange,
            4 => Refusal::Faulted,
            5 => Refusal::BadState,
            6 => Refusal::NotConfigured,
            _ => return None,
        })
    }
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Refusal::LastCup => "the other cup's pump is off: this cup is the last one holding",
            Refusal::NotHolding => "the other cup does not hold yet: this cup is the last one holding",
            Refusal::OutOfRange => "a value is outside its allowed range",
            Refusal::Faulted => "a fault is latched (clear it first)",
            Refusal::BadState => "not allowed in the device's present state",
            Refusal::NotConfigured => "a tube is not configured",
        })
    }
}

/// The device's answer to a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AckStatus {
    /// Done (or started, for motion).
    Ok,
    /// Understood and refused; nothing changed.
    Refused(Refusal),
    /// The type byte is not a command this device knows.
    UnknownType,
    /// The body's length is wrong for its type.
    BadLength {
        /// The body length the type has, in bytes.
        expected: u8,
    },
    /// A field holds a value outside its closed set (tube 3, cup 2, a
    /// boolean 2).
    BadValue {
        /// The field's offset in the body, in bytes.
        offset: u8,
    },
}

impl AckStatus {
    /// Wire codes of the status byte.
    const OK: u8 = 0;
    const REFUSED: u8 = 1;
    const UNKNOWN_TYPE: u8 = 2;
    const BAD_LENGTH: u8 = 3;
    const BAD_VALUE: u8 = 4;
}

impl fmt::Display for AckStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AckStatus::Ok => f.write_str("ok"),
            AckStatus::Refused(reason) => write!(f, "refused: {reason}"),
            AckStatus::UnknownType => f.write_str("unknown message type"),
            AckStatus::BadLength { expected } => write!(f, "bad length: the body must be {expected} bytes"),
            AckStatus::BadValue { offset } => write!(f, "bad value at body offset {offset}"),
        }
    }
}

/// Why a configuration would be refused (`Refusal::OutOfRange` on the wire).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ConfigError {
    /// The field's name.
    pub field: &'static str,
    /// What it may be.
    pub allowed: &'static str,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} must be {}", self.field, self.allowed)
    }
}

impl core::error::Error for ConfigError {}

/// One tube's encoder scale, travel limits and position controller.
///
/// The device measures `length_um = origin_um + counts * 1_000_000 /
/// counts_per_mm_x1000` ([`TubeConfig::length_um`]) and drives
/// `duty = kp * e + ki * integral(e dt) + kd * de/dt` (per mille of full
/// duty, clamped to `max_duty_permille`), with `e` the target minus the
/// measured length in um and `t` in s.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TubeConfig {
    /// Which tube.
    pub tube: Tube,
    /// Positive duty shortens the tube instead of lengthening it.
    pub reverse_motor: bool,
    /// Encoder counts decrease as the tube lengthens (the device negates
    /// them, so reported counts always grow with length).
    pub reverse_encoder: bool,
    /// Encoder counts per millimetre of tube, times 1000 (at least 1).
    pub counts_per_mm_x1000: u32,
    /// The tube's length at count 0 (counts are 0 at reset), um.
    pub origin_um: i32,
    /// The shortest length a target may have, um.
    pub min_um: i32,
    /// The longest length a target may have, um (at least `min_um`).
    pub max_um: i32,
    /// The fastest the target moves, um/s (at least 1).
    pub max_speed_um_s: u32,
    /// The largest duty magnitude, per mille (1..=1000).
    pub max_duty_permille: u16,
    /// Proportional gain, per mille duty per um, Q16.16 (not negative).
    pub kp_q16: i32,
    /// Integral gain, per mille duty per (um s), Q16.16 (not negative).
    pub ki_q16: i32,
    /// Derivative gain, per mille duty per (um/s), Q16.16 (not negative).
    pub kd_q16: i32,
}

impl TubeConfig {
    /// Bit 0 of the flags byte.
    const REVERSE_MOTOR: u8 = 1 << 0;
    /// Bit 1 of the flags byte.
    const REVERSE_ENCODER: u8 = 1 << 1;

    /// Whether the device accepts it; the first field out of range if not.
    pub fn check(&self) -> Result<(), ConfigError> {
        let fail = |field, allowed| Err(ConfigError { field, allowed });
        if self.counts_per_mm_x1000 == 0 {
            return fail("counts_per_mm_x1000", "at least 1");
        }
        if self.min_um > self.max_um {
            return fail("max_um", "at least min_um");
        }
        if self.max_speed_um_s == 0 {
            return fail("max_speed_um_s", "at least 1");
        }
        if !(1..=1000).contains(&self.max_duty_permille) {
            return fail("max_duty_permille", "1..=1000");
        }
        for (field, gain) in [("kp_q16", self.kp_q16), ("ki_q16", self.ki_q16), ("kd_q16", self.kd_q16)] {
            if gain < 0 {
                return fail(field, "0 or more");
            }
        }
        Ok(())
    }

    /// The length at encoder count `counts`, um: `origin_um + counts *
    /// 1_000_000 / counts_per_mm_x1000`, the division truncated toward zero
    /// (as C's integer division), the result saturated to `i32`. A zero
    /// scale (refused by [`check`](TubeConfig::check)) gives `origin_um`.
    pub fn length_um(&self, counts: i32) -> i32 {
        let travel = match i64::from(counts).checked_mul(1_000_000) {
            Some(scaled) => scaled.checked_div(i64::from(self.counts_per_mm_x1000)).unwrap_or(0),
            None => 0,
        };
        let length = i64::from(self.origin_um) + travel;
        i32::try_from(length).unwrap_or(if length < 0 { i32::MIN } else { i32::MAX })
    }
}

/// When a cup counts as holding (the same for both cups).
///
/// With a sensor, a cup whose pump is on holds once its vacuum reaches
/// `attach_kpa_x10` and keeps holding until it falls below
/// `detach_kpa_x10` (hysteresis). Without a sensor, it holds once its pump
/// has been on for `attach_ms`. A cup whose pump is off never holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CupConfig {
    /// Vacuum at which a cup starts holding, 0.1 kPa (at least 1).
    pub attach_kpa_x10: u16,
    /// Vacuum below which a holding cup stops holding, 0.1 kPa (at most
    /// `attach_kpa_x10`).
    pub detach_kpa_x10: u16,
    /// Without a sensor: how long the pump runs before the cup holds, ms.
    pub attach_ms: u16,
}

impl Default for CupConfig {
    /// What the device uses from reset until it is configured: 30 kPa to
    /// attach, 20 kPa to detach, 1 s without a sensor.
    fn default() -> Self {
        CupConfig { attach_kpa_x10: 300, detach_kpa_x10: 200, attach_ms: 1000 }
    }
}

impl CupConfig {
    /// Whether the device accepts it; the first field out of range if not.
    pub fn check(&self) -> Result<(), ConfigError> {
        if self.attach_kpa_x10 == 0 {
            return Err(ConfigError { field: "attach_kpa_x10", allowed: "at least 1" });
        }
        if self.detach_kpa_x10 > self.attach_kpa_x10 {
            return Err(ConfigError { field: "detach_kpa_x10", allowed: "at most attach_kpa_x10" });
        }
        Ok(())
    }
}

/// The device's periodic state report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Telemetry {
    /// The device's clock, ms since reset (wraps after about 49.7 days).
    pub time_ms: u32,
    /// Encoder counts per tube (growing with length), counts since reset.
    pub counts: [i32; 3],
    /// Measured lengths per tube, um (0 for a tube not configured).
    pub lengths_um: [i32; 3],
    /// Motor duty per tube, -1000..=1000 per mille (positive lengthens).
    pub duty_permille: [i16; 3],
    /// Vacuum per cup (rear, front), 0.1 kPa; [`NO_SENSOR`] without a sensor.
    pub vacuum_kpa_x10: [u16; 2],
    /// Latched faults.
    pub faults: Faults,
    /// The device's link counters.
    pub counters: LinkCounters,
    /// Pumps that are on.
    pub pumps: CupSet,
    /// Cups that hold (by the rule of [`CupConfig`]).
    pub holding: CupSet,
    /// Tubes under position control (moving to or holding a target).
    pub active: TubeSet,
    /// Tubes configured since reset.
    pub configured: TubeSet,
}

/// A message from the host to the device. Each is sent with a [`Seq`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Command {
    /// Ask for the device's `Hello`; starts a session (the device forgets
    /// the last seq it executed). Answered by [`Report::Hello`], not `Ack`.
    Hello,
    /// Nothing to do: keeps the link alive.
    Heartbeat,
    /// All motors off and out of position control. Always allowed.
    Stop,
    /// Move every tube to a length (the targets replace any before).
    SetLengths {
        /// Targets for L1, L2, L3, um.
        lengths_um: [i32; 3],
    },
    /// Move one tube by a distance from its target (or from its measured
    /// length if it is not under position control).
    Jog {
        /// Which tube.
        tube: Tube,
        /// How far, um (positive lengthens).
        delta_um: i32,
    },
    /// Switch a cup's vacuum pump; switching off is subject to the last-cup
    /// rule ([`crate::link::last_cup_allows`]).
    Pump {
        /// Which cup.
        cup: Cup,
        /// On or off.
        on: bool,
    },
    /// Send telemetry every `period_ms` (0 = off, else at least 10 ms).
    SetTelemetry {
        /// The period, ms.
        period_ms: u16,
    },
    /// Clear latched faults; a fault whose cause persists latches again.
    ClearFaults {
        /// The faults to clear.
        faults: Faults,
    },
    /// Configure one tube; refused while it is under position control.
    ConfigureTube(TubeConfig),
    /// Configure when cups count as holding.
    ConfigureCups(CupConfig),
}

/// A message from the device to the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Report {
    /// Versions and capabilities: sent once at reset, and as the answer to
    /// a `Hello` command.
    Hello {
        /// The seq of the `Hello` command answered; `None` at reset.
        reply_to: Option<Seq>,
        /// What the device says.
        hello: Hello,
    },
    /// The answer to a command.
    Ack {
        /// The command's seq.
        seq: Seq,
        /// What became of it.
        status: AckStatus,
    },
    /// The periodic state report (seq 0).
    Telemetry(Telemetry),
    /// A fault was raised (seq 0; sent at each detection, latched already or not).
    Fault {
        /// The device's clock, ms.
        time_ms: u32,
        /// The fault's code: its bit number in [`Faults`] (0..=15).
        code: u8,
        /// The tube or cup index it concerns, or 0.
        detail: u8,
    },
}

/// What was wrong with a message's bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DecodeError {
    /// Fewer than the two header bytes.
    TooShort {
        /// The message's length in bytes.
        len: usize,
    },
    /// A command with seq 0, an `Ack` with seq 0, or a `Telemetry` or
    /// `Fault` with a seq other than 0.
    BadSeq {
        /// The type byte.
        type_byte: u8,
        /// The seq byte.
        seq: u8,
    },
    /// A type byte this side does not receive.
    UnknownType {
        /// The type byte.
        type_byte: u8,
        /// The seq byte.
        seq: u8,
    },
    /// A body whose length is wrong for its type.
    BadLength {
        /// The type byte.
        type_byte: u8,
        /// The seq byte.
        seq: u8,
        /// The type's body length, bytes.
        expected: u8,
        /// The body's length, bytes.
        found: usize,
    },
    /// A field outside its closed set of values.
    BadValue {
        /// The type byte.
        type_byte: u8,
        /// The seq byte.
        seq: u8,
        /// The field's name.
        field: &'static str,
        /// The field's offset in the body, bytes.
        offset: u8,
        /// The value found.
        value: u8,
    },
}

impl DecodeError {
    /// How the device answers a command that failed to decode: its seq and
    /// the `Ack` status, or `None` when it cannot be answered (no header, or
    /// seq 0) and is only counted.
    pub fn ack(&self) -> Option<(Seq, AckStatus)> {
        let (seq, status) = match *self {
            DecodeError::TooShort { .. } | DecodeError::BadSeq { .. } => return None,
            DecodeError::UnknownType { seq, .. } => (seq, AckStatus::UnknownType),
            DecodeError::BadLength { seq, expected, .. } => (seq, AckStatus::BadLength { expected }),
            DecodeError::BadValue { seq, offset, .. } => (seq, AckStatus::BadValue { offset }),
        };
        Some((Seq::new(seq)?, status))
    }
}

/// A type byte as the error messages name it.
struct TypeName(u8);

impl fmt::Display for TypeName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match types::name(self.0) {
            Some(name) => write!(f, "{name} ({:#04x})", self.0),
            None => write!(f, "type {:#04x}", self.0),
        }
    }
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            DecodeError::TooShort { len } => {
                write!(f, "a {len}-byte message has no type and sequence bytes (2 bytes)")
            }
            DecodeError::BadSeq { type_byte, seq } => write!(
                f,
                "{} with seq {seq}: commands and acks need 1..=255, telemetry and faults 0",
                TypeName(type_byte)
            ),
            DecodeError::UnknownType { type_byte, seq } => {
                write!(f, "unknown message {} (seq {seq})", TypeName(type_byte))
            }
            DecodeError::BadLength { type_byte, seq, expected, found } => {
                write!(f, "{} (seq {seq}): a {found}-byte body, the type has {expected} bytes", TypeName(type_byte))
            }
            DecodeError::BadValue { type_byte, seq, field, offset, value } => write!(
                f,
                "{} (seq {seq}): {field} = {value} at body offset {offset} is not an allowed value",
                TypeName(type_byte)
            ),
        }
    }
}

impl core::error::Error for DecodeError {}

impl Command {
    /// Its type byte.
    pub const fn type_byte(&self) -> u8 {
        match self {
            Command::Hello => types::HELLO,
            Command::Heartbeat => types::HEARTBEAT,
            Command::Stop => types::STOP,
            Command::SetLengths { .. } => types::SET_LENGTHS,
            Command::Jog { .. } => types::JOG,
            Command::Pump { .. } => types::PUMP,
            Command::SetTelemetry { .. } => types::SET_TELEMETRY,
            Command::ClearFaults { .. } => types::CLEAR_FAULTS,
            Command::ConfigureTube(_) => types::CONFIGURE_TUBE,
            Command::ConfigureCups(_) => types::CONFIGURE_CUPS,
        }
    }

    /// Writes its message bytes (type, seq, body) into `out`; returns their
    /// number. An `out` of [`MAX_MESSAGE`] bytes always suffices.
    pub fn encode(&self, seq: Seq, out: &mut [u8]) -> Result<usize, BufferTooSmall> {
        encode_with(self.type_byte(), seq.get(), out, |w| self.write_body(w))
    }

    /// Writes its whole frame (ready for the wire) into `out`; returns its
    /// length. An `out` of [`frame::MAX_FRAME`] bytes always suffices.
    pub fn encode_frame(&self, seq: Seq, out: &mut [u8]) -> Result<usize, frame::EncodeError> {
        let mut message = [0u8; MAX_MESSAGE];
        let len = self.encode(seq, &mut message).map_err(frame::EncodeError::BufferTooSmall)?;
        frame::encode(message.get(..len).unwrap_or_default(), out)
    }

    fn write_body(&self, w: &mut Writer<'_>) {
        match *self {
            Command::Hello | Command::Heartbeat | Command::Stop => {}
            Command::SetLengths { lengths_um } => lengths_um.into_iter().for_each(|l| w.i32(l)),
            Command::Jog { tube, delta_um } => {
                w.u8(tube as u8);
                w.i32(delta_um);
            }
            Command::Pump { cup, on } => {
                w.u8(cup as u8);
                w.u8(u8::from(on));
            }
            Command::SetTelemetry { period_ms } => w.u16(period_ms),
            Command::ClearFaults { faults } => w.u16(faults.0),
            Command::ConfigureTube(c) => {
                w.u8(c.tube as u8);
                let reverse_motor = if c.reverse_motor { TubeConfig::REVERSE_MOTOR } else { 0 };
                let reverse_encoder = if c.reverse_encoder { TubeConfig::REVERSE_ENCODER } else { 0 };
                w.u8(reverse_motor | reverse_encoder);
                w.u32(c.counts_per_mm_x1000);
                w.i32(c.origin_um);
                w.i32(c.min_um);
                w.i32(c.max_um);
                w.u32(c.max_speed_um_s);
                w.u16(c.max_duty_permille);
                w.i32(c.kp_q16);
                w.i32(c.ki_q16);
                w.i32(c.kd_q16);
            }
            Command::ConfigureCups(c) => {
                w.u16(c.attach_kpa_x10);
                w.u16(c.detach_kpa_x10);
                w.u16(c.attach_ms);
            }
        }
    }

    /// Reads a command from message bytes (type, seq, body), as the
    /// [`frame::Decoder`] hands them on.
    pub fn decode(message: &[u8]) -> Result<(Seq, Command), DecodeError> {
        let (type_byte, seq, body) = split(message)?;
        let Some(seq) = Seq::new(seq) else {
            return Err(DecodeError::BadSeq { type_byte, seq });
        };
        let mut r = Body::open(type_byte, seq.get(), body, types::from_device(type_byte))?;
        let command = match type_byte {
            types::HELLO => Command::Hello,
            types::HEARTBEAT => Command::Heartbeat,
            types::STOP => Command::Stop,
            types::SET_LENGTHS => Command::SetLengths { lengths_um: [r.i32(), r.i32(), r.i32()] },
            types::JOG => Command::Jog { tube: r.tube()?, delta_um: r.i32() },
            types::PUMP => Command::Pump { cup: r.cup()?, on: r.bool("on")? },
            types::SET_TELEMETRY => Command::SetTelemetry { period_ms: r.u16() },
            types::CLEAR_FAULTS => Command::ClearFaults { faults: Faults(r.u16()) },
            types::CONFIGURE_TUBE => {
                let tube = r.tube()?;
                let flags = r.u8();
                Command::ConfigureTube(TubeConfig {
                    tube,
                    reverse_motor: flags & TubeConfig::REVERSE_MOTOR != 0,
                    reverse_encoder: flags & TubeConfig::REVERSE_ENCODER != 0,
                    counts_per_mm_x1000: r.u32(),
                    origin_um: r.i32(),
                    min_um: r.i32(),
                    max_um: r.i32(),
                    max_speed_um_s: r.u32(),
                    max_duty_permille: r.u16(),
                    kp_q16: r.i32(),
                    ki_q16: r.i32(),
                    kd_q16: r.i32(),
                })
            }
            types::CONFIGURE_CUPS => Command::ConfigureCups(CupConfig {
                attach_kpa_x10: r.u16(),
                detach_kpa_x10: r.u16(),
                attach_ms: r.u16(),
            }),
            // Body::open refused every other type.
            _ => return Err(DecodeError::UnknownType { type_byte, seq: seq.get() }),
        };
        Ok((seq, command))
    }
}

impl Report {
    /// Its type byte.
    pub const fn type_byte(&self) -> u8 {
        match self {
            Report::Hello { .. } => types::DEVICE_HELLO,
            Report::Ack { .. } => types::ACK,
            Report::Telemetry(_) => types::TELEMETRY,
            Report::Fault { .. } => types::FAULT,
        }
    }

    /// Its seq byte: the command's for an answer, 0 for an unsolicited report.
    pub const fn seq_byte(&self) -> u8 {
        match self {
            Report::Hello { reply_to: Some(seq), .. } | Report::Ack { seq, .. } => seq.get(),
            Report::Hello { reply_to: None, .. } | Report::Telemetry(_) | Report::Fault { .. } => 0,
        }
    }

    /// Writes its message bytes (type, seq, body) into `out`; returns their
    /// number. An `out` of [`MAX_MESSAGE`] bytes always suffices.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, BufferTooSmall> {
        encode_with(self.type_byte(), self.seq_byte(), out, |w| self.write_body(w))
    }

    /// Writes its whole frame (ready for the wire) into `out`; returns its
    /// length. An `out` of [`frame::MAX_FRAME`] bytes always suffices.
    pub fn encode_frame(&self, out: &mut [u8]) -> Result<usize, frame::EncodeError> {
        let mut message = [0u8; MAX_MESSAGE];
        let len = self.encode(&mut message).map_err(frame::EncodeError::BufferTooSmall)?;
        frame::encode(message.get(..len).unwrap_or_default(), out)
    }

    fn write_body(&self, w: &mut Writer<'_>) {
        match *self {
            Report::Hello { hello, .. } => {
                w.u8(hello.protocol.major);
                w.u8(hello.protocol.minor);
                w.u8(hello.firmware.major);
                w.u8(hello.firmware.minor);
                w.u8(hello.firmware.patch);
                w.u8(hello.kind.0);
                w.u16(hello.capabilities.0);
            }
            Report::Ack { status, .. } => {
                let (code, detail) = match status {
                    AckStatus::Ok => (AckStatus::OK, 0),
                    AckStatus::Refused(reason) => (AckStatus::REFUSED, reason as u8),
                    AckStatus::UnknownType => (AckStatus::UNKNOWN_TYPE, 0),
                    AckStatus::BadLength { expected } => (AckStatus::BAD_LENGTH, expected),
                    AckStatus::BadValue { offset } => (AckStatus::BAD_VALUE, offset),
                };
                w.u8(code);
                w.u8(detail);
            }
            Report::Telemetry(t) => {
                w.u32(t.time_ms);
                t.counts.into_iter().for_each(|v| w.i32(v));
                t.lengths_um.into_iter().for_each(|v| w.i32(v));
                t.duty_permille.into_iter().for_each(|v| w.i16(v));
                t.vacuum_kpa_x10.into_iter().for_each(|v| w.u16(v));
                w.u16(t.faults.0);
                let c = t.counters;
                [c.rx_frames, c.bad_crc, c.bad_frames, c.duplicates].into_iter().for_each(|v| w.u16(v));
                w.u8(t.pumps.0);
                w.u8(t.holding.0);
                w.u8(t.active.0);
                w.u8(t.configured.0);
            }
            Report::Fault { time_ms, code, detail } => {
                w.u32(time_ms);
                w.u8(code);
                w.u8(detail);
            }
        }
    }

    /// Reads a report from message bytes (type, seq, body), as the
    /// [`frame::Decoder`] hands them on.
    pub fn decode(message: &[u8]) -> Result<Report, DecodeError> {
        let (type_byte, seq, body) = split(message)?;
        let bad_seq = Err(DecodeError::BadSeq { type_byte, seq });
        let mut r = Body::open(type_byte, seq, body, !types::from_device(type_byte))?;
        Ok(match type_byte {
            types::DEVICE_HELLO => Report::Hello {
                reply_to: Seq::new(seq),
                hello: Hello {
                    protocol: Version { major: r.u8(), minor: r.u8() },
                    firmware: FirmwareVersion { major: r.u8(), minor: r.u8(), patch: r.u8() },
                    kind: DeviceKind(r.u8()),
                    capabilities: Capabilities(r.u16()),
                },
            },
            types::ACK => {
                let Some(seq) = Seq::new(seq) else { return bad_seq };
                Report::Ack { seq, status: r.ack_status()? }
            }
            types::TELEMETRY if seq != 0 => return bad_seq,
            types::TELEMETRY => Report::Telemetry(Telemetry {
                time_ms: r.u32(),
                counts: [r.i32(), r.i32(), r.i32()],
                lengths_um: [r.i32(), r.i32(), r.i32()],
                duty_permille: [r.i16(), r.i16(), r.i16()],
                vacuum_kpa_x10: [r.u16(), r.u16()],
                faults: Faults(r.u16()),
                counters: LinkCounters {
                    rx_frames: r.u16(),
                    bad_crc: r.u16(),
                    bad_frames: r.u16(),
                    duplicates: r.u16(),
                },
                pumps: CupSet(r.u8()),
                holding: CupSet(r.u8()),
                active: TubeSet(r.u8()),
                configured: TubeSet(r.u8()),
            }),
            types::FAULT if seq != 0 => return bad_seq,
            types::FAULT => {
                let time_ms = r.u32();
                let code = r.field("code", |code| Faults::from_code(code).map(|_| code))?;
                Report::Fault { time_ms, code, detail: r.u8() }
            }
            // Body::open refused every other type.
            _ => return Err(DecodeError::UnknownType { type_byte, seq }),
        })
    }
}

/// Writes a header and, through `body`, the body into `out`, after checking
/// that the type's whole message fits.
fn encode_with(
    type_byte: u8,
    seq: u8,
    out: &mut [u8],
    body: impl FnOnce(&mut Writer<'_>),
) -> Result<usize, BufferTooSmall> {
    let needed = frame::HEADER_LEN + types::body_len(type_byte).unwrap_or(0);
    if out.len() < needed {
        return Err(BufferTooSmall { needed, available: out.len() });
    }
    let mut w = Writer::new(out);
    w.u8(type_byte);
    w.u8(seq);
    body(&mut w);
    Ok(w.len())
}

/// The type byte, the seq byte and the body.
fn split(message: &[u8]) -> Result<(u8, u8, &[u8]), DecodeError> {
    match message {
        [type_byte, seq, body @ ..] => Ok((*type_byte, *seq, body)),
        _ => Err(DecodeError::TooShort { len: message.len() }),
    }
}

/// A body being read, with what its errors need to say.
struct Body<'a> {
    reader: Reader<'a>,
    type_byte: u8,
    seq: u8,
}

impl<'a> Body<'a> {
    /// Checks that the type is one this side receives (`wrong_side` says it
    /// is not) and that the body has its length.
    fn open(type_byte: u8, seq: u8, body: &'a [u8], wrong_side: bool) -> Result<Body<'a>, DecodeError> {
        let expected = match types::body_len(type_byte) {
            Some(len) if !wrong_side => len,
            _ => return Err(DecodeError::UnknownType { type_byte, seq }),
        };
        if body.len() != expected {
            // Every body length fits a byte (the longest is 52).
            let expected = u8::try_from(expected).unwrap_or(u8::MAX);
            return Err(DecodeError::BadLength { type_byte, seq, expected, found: body.len() });
        }
        Ok(Body { reader: Reader::new(body), type_byte, seq })
    }

    fn u8(&mut self) -> u8 {
        self.reader.u8()
    }

    fn u16(&mut self) -> u16 {
        self.reader.u16()
    }

    fn i16(&mut self) -> i16 {
        self.reader.i16()
    }

    fn u32(&mut self) -> u32 {
        self.reader.u32()
    }

    fn i32(&mut self) -> i32 {
        self.reader.i32()
    }

    /// A one-byte field with a closed set of values.
    fn field<T>(&mut self, field: &'static str, parse: impl FnOnce(u8) -> Option<T>) -> Result<T, DecodeError> {
        let offset = u8::try_from(self.reader.offset()).unwrap_or(u8::MAX);
        let value = self.reader.u8();
        parse(value).ok_or(DecodeError::BadValue { type_byte: self.type_byte, seq: self.seq, field, offset, value })
    }

    fn tube(&mut self) -> Result<Tube, DecodeError> {
        self.field("tube", Tube::from_index)
    }

    fn cup(&mut self) -> Result<Cup, DecodeError> {
        self.field("cup", Cup::from_index)
    }

    fn bool(&mut self, field: &'static str) -> Result<bool, DecodeError> {
        self.field(field, |v| match v {
            0 => Some(false),
            1 => Some(true),
            _ => None,
        })
    }

    /// The status byte and its detail byte.
    fn ack_status(&mut self) -> Result<AckStatus, DecodeError> {
        let code = self.field("status", |code| (code <= AckStatus::BAD_VALUE).then_some(code))?;
        Ok(match code {
            AckStatus::REFUSED => AckStatus::Refused(self.field("reason", Refusal::from_code)?),
            AckStatus::UNKNOWN_TYPE => AckStatus::UnknownType,
            AckStatus::BAD_LENGTH => AckStatus::BadLength { expected: self.u8() },
            AckStatus::BAD_VALUE => AckStatus::BadValue { offset: self.u8() },
            _ => AckStatus::Ok,
        })
    }
}
