//! # leech-protocol: the wire between a LEeCH robot's PC and its controller
//!
//! A PC (the *host*) drives the robot's controller (the *device*, an Arduino
//! Mega or a simulator) over a serial line. Everything on the line is a
//! frame: a message (`type`, `seq`, a fixed-length little-endian body), its
//! CRC-16, COBS-encoded and ended by `0x00`. The host sends commands, each
//! numbered; the device answers each with an `Ack` and sends `Telemetry` on
//! its own. `docs/protocol.md` in the repository is the full specification,
//! written for a firmware author; this crate is its reference
//! implementation, `no_std`, without allocation, and without a panic on any
//! input.
//!
//! ## Sending a command
//!
//! ```
//! use leech_protocol::frame::MAX_FRAME;
//! use leech_protocol::message::{Command, Seq, Tube};
//!
//! let seq = Seq::FIRST; // then seq.next(), ...
//! let mut wire = [0u8; MAX_FRAME];
//! let len = Command::Jog { tube: Tube::L1, delta_um: 1500 }.encode_frame(seq, &mut wire)?;
//! // port.write_all(&wire[..len])?;
//! assert_eq!(wire[len - 1], 0x00); // the delimiter
//! assert!(!wire[..len - 1].contains(&0x00));
//! # Ok::<(), leech_protocol::frame::EncodeError>(())
//! ```
//!
//! ## Answering it on the device
//!
//! A [`frame::Decoder`] takes bytes as they come and hands on the message of
//! each good frame; a [`link::Responder`] executes each command once and
//! builds its answer.
//!
//! ```
//! use leech_protocol::frame::{Decoder, MAX_FRAME};
//! use leech_protocol::link::Responder;
//! use leech_protocol::message::*;
//!
//! let hello = Hello {
//!     protocol: PROTOCOL_VERSION,
//!     firmware: FirmwareVersion { major: 0, minor: 1, patch: 0 },
//!     kind: DeviceKind::SIMULATOR,
//!     capabilities: Capabilities::default(),
//! };
//! let mut responder = Responder::new(hello);
//! let mut decoder = Decoder::new();
//!
//! let mut wire = [0u8; MAX_FRAME];
//! let len = Command::Stop.encode_frame(Seq::FIRST, &mut wire).unwrap();
//!
//! let mut answers = Vec::new();
//! for &byte in &wire[..len] {
//!     if let Some(Ok(message)) = decoder.push(byte) {
//!         let answer = responder.handle(message, |command| {
//!             assert_eq!(command, Command::Stop); // stop the motors here
//!             AckStatus::Ok
//!         });
//!         answers.extend(answer);
//!     }
//! }
//! assert_eq!(answers, [Report::Ack { seq: Seq::FIRST, status: AckStatus::Ok }]);
//! ```
//!
//! ## Reading a stream on the host
//!
//! Whatever precedes a frame (noise, half a frame from before a reset) is
//! dropped at the next `0x00`, counted, and the frames after it decode.
//!
//! ```
//! use leech_protocol::frame::{Decoder, FrameError, MAX_FRAME};
//! use leech_protocol::message::{AckStatus, Report, Seq};
//!
//! let ack = Report::Ack { seq: Seq::FIRST, status: AckStatus::Ok };
//! let mut stream = vec![0x13, 0x37, 0x00]; // garbage, then a delimiter
//! let mut frame = [0u8; MAX_FRAME];
//! let len = ack.encode_frame(&mut frame).unwrap();
//! stream.extend_from_slice(&frame[..len]);
//!
//! let mut decoder = Decoder::new();
//! let mut rest = &stream[..];
//! let mut reports = Vec::new();
//! while !rest.is_empty() {
//!     let (event, more) = decoder.feed(rest);
//!     match event {
//!         Some(Ok(message)) => reports.push(Report::decode(message).unwrap()),
//!         Some(Err(FrameError::Cobs(_) | FrameError::TooShort { .. } | FrameError::BadCrc { .. })) => {}
//!         Some(Err(e)) => panic!("unexpected {e}"),
//!         None => {}
//!     }
//!     rest = more;
//! }
//! assert_eq!(reports, [ack]);
//! assert_eq!(decoder.counters().frames, 1);
//! assert_eq!(decoder.counters().bad_frames + decoder.counters().bad_crc, 1);
//! ```
//!
//! ## Modules
//!
//! * [`cobs`]: byte stuffing, so that `0x00` only ends frames.
//! * [`crc`]: the checksum, CRC-16/CCITT-FALSE.
//! * [`frame`]: message bytes to wire bytes and back; the streaming [`frame::Decoder`].
//! * [`message`]: the typed [`message::Command`]s and [`message::Report`]s.
//! * [`link`]: sequence numbers, retries, duplicates, link loss, the last-cup rule, counters.

#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

use core::fmt;

pub mod cobs;
pub mod crc;
pub mod frame;
pub mod link;
pub mod message;
mod wire;

/// An output buffer too short for what was to be written into it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BufferTooSmall {
    /// Bytes needed.
    pub needed: usize,
    /// Bytes the buffer has.
    pub available: usize,
}

impl fmt::Display for BufferTooSmall {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "the output buffer holds {} bytes, {} are needed", self.available, self.needed)
    }
}

impl core::error::Error for BufferTooSmall {}
