//! Integration tests of leech-link: the simulated device alone, behind a
//! pseudo-terminal, and driven by the host driver; and the protocol suite,
//! which runs the same tests against the simulated device and (feature
//! `firmware`) the Arduino firmware on a simulated chip. Every wait is
//! bounded.

mod executor;
mod faults;
mod fuzz;
mod handshake;
mod motion;
mod reconnect;
mod suite;
mod target;
mod wait;

use std::time::{Duration, Instant};

use leech_link::host::{Link, Options};
use leech_link::pty::PtyDevice;
use leech_link::sim::{Sim, SimConfig};
use leech_protocol::frame::{Decoder, MAX_FRAME};
use leech_protocol::message::{Command, Report, Seq, Tube};

/// Options for a simulated device: it is already running, so its boot
/// `Hello` is waiting in the terminal and the boot wait is short anyway.
pub fn options() -> Options {
    Options { boot_timeout: Duration::from_millis(500), ..Options::default() }
}

/// A default simulated robot behind a pseudo-terminal.
pub fn device(config: SimConfig) -> PtyDevice {
    PtyDevice::spawn(Sim::new(config)).expect("a pseudo-terminal")
}

/// Configures cups and tubes as the simulation's hardware is, and telemetry.
pub fn configure(link: &Link, config: &SimConfig, telemetry_ms: u16) {
    link.configure_cups(Default::default()).expect("cups configured");
    for tube in Tube::ALL {
        link.configure_tube(config.tube_config(tube)).expect("tube configured");
    }
    link.set_telemetry(telemetry_ms).expect("telemetry set");
}

/// Waits until `done` holds, polling every ms, for at most `limit`.
pub fn wait_until(limit: Duration, mut done: impl FnMut() -> bool) -> bool {
    let end = Instant::now() + limit;
    while Instant::now() < end {
        if done() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    done()
}

/// The frame of a command.
pub fn frame(command: Command, seq: u8) -> Vec<u8> {
    let mut wire = [0u8; MAX_FRAME];
    let len = command.encode_frame(Seq::new(seq).expect("seq 1..=255"), &mut wire).expect("fits");
    wire[..len].to_vec()
}

/// Feeds `bytes` to `sim`, handles them, and returns the reports it sends.
pub fn exchange(sim: &mut Sim, bytes: &[u8]) -> Vec<Report> {
    sim.receive(bytes);
    sim.step(0.0);
    let mut out = Vec::new();
    sim.take_output(&mut out);
    let mut decoder = Decoder::new();
    out.iter()
        .filter_map(|&b| match decoder.push(b) {
            Some(Ok(message)) => Report::decode(message).ok(),
            _ => None,
        })
        .collect()
}

/// A fresh simulation with its boot `Hello` taken out.
pub fn fresh_sim(config: SimConfig) -> Sim {
    let mut sim = Sim::new(config);
    let boot = exchange(&mut sim, &[]);
    assert!(matches!(boot.as_slice(), [Report::Hello { reply_to: None, .. }]), "boot hello: {boot:?}");
    sim
}
