//! # leech-link: a LEeCH robot's controller, simulated, and the host's driver
//!
//! * [`sim`]: the controller and its robot as pure logic with an explicit
//!   clock: bytes in, bytes out, motors, encoders, pumps, faults.
//! * [`pty`]: a [`sim::Sim`] running in real time behind a pseudo-terminal,
//!   so that the host driver (or any serial program) talks to it as to a
//!   real Mega's serial port.
//! * [`host`]: the driver: opens a serial port, does the handshake, sends
//!   typed commands with retries, delivers telemetry, keeps the link alive
//!   and reconnects.
//!
//! The protocol itself (frames, messages, link rules) is `leech-protocol`
//! and `docs/protocol.md`.

#![warn(missing_docs)]

pub mod host;
pub mod pty;
pub mod sim;
