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
//! * [`executor`]: a climb plan (`leech::stride::Plan`) carried out on a
//!   [`host::Link`] behind the stride's interlock, each step confirmed by
//!   telemetry.
//! * [`body`]: the simulated robot's body from leech's statics, as the
//!   [`sim::Cups`] model that says where a cup's face seals.
//! * [`settings`]: the tubes' configuration and a simulated controller
//!   from a robot file's `[drive]` and `[limits]` sections.
//! * [`chip`]: the robot's Arduino firmware (`firmware/`) on a simulated
//!   ATmega2560 behind a pseudo-terminal, to test a host against the
//!   firmware itself.
//!
//! ```
//! use std::time::Duration;
//!
//! use leech_link::host::{Link, Options};
//! use leech_link::pty::PtyDevice;
//! use leech_link::sim::{Sim, SimConfig};
//! use leech_link::wait::Watch;
//! use leech_protocol::message::Tube;
//!
//! let config = SimConfig::default();
//! let device = PtyDevice::spawn(Sim::new(config))?;
//! // A real robot: Link::open("/dev/ttyACM0", ...), the same from here on.
//! let link = Link::open(device.path(), Options::default())?;
//! for tube in Tube::ALL {
//!     link.configure_tube(config.tube_config(tube))?;
//! }
//! let mut watch = Watch::new(link.subscribe());
//! link.set_telemetry(10)?; // 100 Hz
//! watch.start(Duration::from_secs(1))?; // the faults latched already
//! link.jog(Tube::L1, 2_000)?; // 2 mm longer, at up to 20 mm/s
//! watch.after_command()?; // drops the reports sent before the jog
//! let first = watch.next_telemetry(Duration::from_secs(1))?;
//! assert!(first.active.contains(Tube::L1));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The protocol itself (frames, messages, link rules) is `leech-protocol`
//! and `docs/protocol.md`.

#![warn(missing_docs)]

pub mod body;
pub mod chip;
pub mod executor;
pub mod host;
pub mod pty;
pub mod settings;
pub mod sim;
pub mod wait;
