//! Injected faults: a noisy line, a cut line, and the last-cup rule.

use std::time::{Duration, Instant};

use leech_link::host::{Event, Link, LinkError};
use leech_link::sim::{Faults, SimConfig};
use leech_protocol::frame::Decoder;
use leech_protocol::link::{BAUD_RATE, LINK_TIMEOUT_MS};
use leech_protocol::message::{AckStatus, Command, Cup, Faults as FaultBits, Refusal, Report};

use super::{configure, device, frame, options, wait_until};

/// Sends 200 commands through a line with `faults`; each must be acked.
fn commands_arrive_through(faults: Faults) -> (leech_link::host::Health, leech_link::sim::Counters) {
    let config = SimConfig::default();
    let device = device(config);
    let link = Link::open(device.path(), options()).expect("handshake");
    configure(&link, &config, 50);
    device.set_faults(faults);
    for i in 0..200 {
        link.clear_faults(FaultBits(0)).unwrap_or_else(|e| panic!("command {i}: {e}"));
    }
    let health = link.health();
    assert!(health.resends > 0, "{health:?}");
    let counters = device.state().counters;
    assert!(counters.duplicates > 0, "lost acks make retries the device answers from memory");
    (health, counters)
}

#[test]
fn every_command_arrives_through_one_percent_corruption() {
    let (health, device) = commands_arrive_through(Faults { corrupt_rate: 0.01, ..Faults::default() });
    assert!(health.bad_crc + health.bad_frames > 0, "host counted no bad frame: {health:?}");
    assert!(device.bad_crc + device.bad_frames > 0, "{device:?}");
}

#[test]
fn every_command_arrives_through_one_percent_loss() {
    let (health, device) = commands_arrive_through(Faults { drop_rate: 0.01, ..Faults::default() });
    // A lost byte leaves a frame short or merges two: bad frames or CRCs.
    assert!(health.bad_crc + health.bad_frames > 0, "{health:?}");
    assert!(device.bad_crc + device.bad_frames > 0, "{device:?}");
}

#[test]
fn a_stop_overtakes_the_command_in_flight() {
    let config = SimConfig::default();
    let device = device(config);
    let link = Link::open(device.path(), options()).expect("handshake");
    configure(&link, &config, 0);
    device.set_faults(Faults { cut: true, ..Faults::default() });
    // The Stop must leave while the SetLengths is in flight (the driver
    // gives it up 300 ms after its first send): seen in the link's health,
    // not guessed with a sleep. A loaded machine may still hold this thread
    // past the give-up; then the SetLengths ends NoAck and the try is done
    // again (a few tries, each bounded).
    for attempt in 1..=5 {
        let outcome = std::thread::scope(|scope| {
            let moving = scope.spawn(|| link.set_lengths([210_000; 3]));
            let in_flight = wait_until(Duration::from_secs(5), || link.health().in_flight == Some("SetLengths"));
            assert!(in_flight, "the SetLengths was sent: {:?}", link.health());
            // Nothing gets through the cut line: the Stop itself is not acked.
            let stop = link.stop();
            assert!(matches!(stop, Err(LinkError::NoAck { command: "Stop", sends: 6, .. })), "{stop:?}");
            moving.join().expect("no panic")
        });
        match outcome {
            Err(LinkError::Overtaken { command: "SetLengths" }) => return,
            Err(LinkError::NoAck { command: "SetLengths", .. }) if attempt < 5 => continue,
            other => panic!("try {attempt}: {other:?}"),
        }
    }
}

#[test]
fn a_refusal_comes_back_as_an_error_with_its_reason() {
    let config = SimConfig::default();
    let device = device(config);
    let link = Link::open(device.path(), options()).expect("handshake");
    let error = link.jog(leech_protocol::message::Tube::L1, 1000).expect_err("not configured");
    assert!(matches!(error, LinkError::Refused { reason: Refusal::NotConfigured, .. }), "{error:?}");
    configure(&link, &config, 0);
    let error = link.set_lengths([10_000; 3]).expect_err("below the limits");
    assert!(matches!(error, LinkError::Refused { reason: Refusal::OutOfRange, .. }), "{error:?}");
    let text = error.to_string();
    assert!(text.contains("SetLengths") && !text.contains('\n'), "{text}");
}

#[test]
fn a_cut_link_stops_the_motors_and_keeps_the_pumps() {
    let config = SimConfig::default();
    let device = device(config);
    let link = Link::open(device.path(), options()).expect("handshake");
    let events = link.subscribe();
    configure(&link, &config, 0);
    link.pump(Cup::Rear, true).expect("rear pump");
    link.pump(Cup::Front, true).expect("front pump");
    link.set_lengths([400_000; 3]).expect("a long move");
    let moving = wait_until(Duration::from_secs(3), || device.state().speeds_mm_s.iter().all(|s| *s > 10.0));
    assert!(moving, "{:?}", device.state());

    device.set_faults(Faults { cut: true, ..Faults::default() });
    let stopped = |state: &leech_link::sim::SimState| {
        state.targets_um.iter().all(Option::is_none) && state.duty_permille.iter().all(|d| *d == 0)
    };
    // Every look at the device, in device time: the rule is judged on its
    // clock, from the last frame it received, whatever the scheduler did.
    let mut seen = Vec::new();
    let halted = wait_until(Duration::from_millis(u64::from(LINK_TIMEOUT_MS) + 3000), || {
        let state = device.state();
        let done = stopped(&state);
        seen.push((state.time_s, done));
        done
    });
    assert!(halted, "{:?}", device.state());
    let state = device.state();
    let last_frame_s = state.last_host_frame_s.expect("the host's frames arrived");
    let timeout_s = f64::from(LINK_TIMEOUT_MS) / 1e3;
    for &(time_s, done) in &seen {
        let since = time_s - last_frame_s;
        // Not before the timeout, and at the control tick that reaches it.
        assert!(!(done && since < timeout_s), "stopped {since} s after the last frame");
        assert!(done || since < timeout_s + 0.002, "still moving {since} s after the last frame");
    }
    // The motors spin down within a few time constants (device time).
    let spun_down = wait_until(Duration::from_secs(3), || {
        let state = device.state();
        state.time_s >= last_frame_s + timeout_s + 0.15 && state.speeds_mm_s.iter().all(|s| s.abs() < 0.5)
    });
    let state = device.state();
    assert!(spun_down, "{state:?}");
    assert_eq!(state.pumps, [true, true]);
    assert_eq!(state.holding, [true, true]);
    assert!(FaultBits(state.faults).contains(FaultBits::LINK_LOST));
    // The host saw its heartbeats go unanswered.
    assert!(wait_until(Duration::from_secs(3), || link.health().give_ups > 0), "{:?}", link.health());
    let failing = events.try_iter().any(|e| matches!(e, Event::NoAnswer { command: "Heartbeat", .. }));
    assert!(failing);
}

/// Sends `command` with `seq` on a raw port and returns the answer to it.
fn ask(port: &mut dyn serialport::SerialPort, decoder: &mut Decoder, command: Command, seq: u8) -> Report {
    port.write_all(&frame(command, seq)).expect("write");
    let end = Instant::now() + Duration::from_secs(1);
    let mut byte = [0u8; 1];
    while Instant::now() < end {
        if port.read(&mut byte).unwrap_or(0) == 0 {
            continue;
        }
        if let Some(Ok(message)) = decoder.push(byte[0]) {
            match Report::decode(message) {
                Ok(report @ (Report::Ack { .. } | Report::Hello { reply_to: Some(_), .. })) => return report,
                _ => continue,
            }
        }
    }
    panic!("no answer to {command:?}");
}

#[test]
fn the_device_refuses_to_release_the_last_holding_cup() {
    let device = device(SimConfig::default());
    let mut port = serialport::new(device.path().to_string_lossy(), BAUD_RATE)
        .timeout(Duration::from_millis(5))
        .open()
        .expect("the pty opens as a serial port");
    let mut decoder = Decoder::new();
    assert!(matches!(ask(&mut *port, &mut decoder, Command::Hello, 1), Report::Hello { .. }));
    let ok = |report| assert!(matches!(report, Report::Ack { status: AckStatus::Ok, .. }), "{report:?}");
    ok(ask(&mut *port, &mut decoder, Command::Pump { cup: Cup::Rear, on: true }, 2));
    assert!(wait_until(Duration::from_secs(1), || device.state().holding[0]), "the rear cup attaches");
    let refused = ask(&mut *port, &mut decoder, Command::Pump { cup: Cup::Rear, on: false }, 3);
    assert!(matches!(refused, Report::Ack { status: AckStatus::Refused(Refusal::LastCup), .. }), "{refused:?}");
    assert_eq!(device.state().pumps, [true, false]);
    // With the front pump on but not yet holding, the reason changes.
    ok(ask(&mut *port, &mut decoder, Command::Pump { cup: Cup::Front, on: true }, 4));
    let refused = ask(&mut *port, &mut decoder, Command::Pump { cup: Cup::Rear, on: false }, 5);
    assert!(matches!(refused, Report::Ack { status: AckStatus::Refused(Refusal::NotHolding), .. }), "{refused:?}");
    // Once both hold, either may let go.
    assert!(wait_until(Duration::from_secs(1), || device.state().holding == [true, true]));
    ok(ask(&mut *port, &mut decoder, Command::Pump { cup: Cup::Rear, on: false }, 6));
}

/// A fresh simulation with its tubes configured and the link kept alive by
/// `run`.
struct Bench {
    sim: leech_link::sim::Sim,
    seq: u8,
}

impl Bench {
    fn new() -> Bench {
        let config = SimConfig::default();
        let mut bench = Bench { sim: super::fresh_sim(config), seq: 0 };
        for tube in leech_protocol::message::Tube::ALL {
            bench.ask(Command::ConfigureTube(config.tube_config(tube)));
        }
        bench
    }

    fn ask(&mut self, command: Command) -> Vec<Report> {
        self.seq = self.seq.wrapping_add(1).max(1);
        super::exchange(&mut self.sim, &frame(command, self.seq))
    }

    /// Runs `ms` milliseconds with a heartbeat every 100 ms; returns the
    /// faults reported.
    fn run(&mut self, ms: u32) -> Vec<Report> {
        let mut reports = Vec::new();
        for t in 1..=ms {
            self.sim.step(0.001);
            let answers = if t % 100 == 0 { self.ask(Command::Heartbeat) } else { super::exchange(&mut self.sim, &[]) };
            reports.extend(answers.into_iter().filter(|r| matches!(r, Report::Fault { .. })));
        }
        reports
    }
}

#[test]
fn a_stalled_motor_latches_a_fault_that_blocks_motion_until_cleared() {
    let mut bench = Bench::new();
    bench.sim.set_faults(Faults { stalled: [false, true, false], ..Faults::default() });
    bench.ask(Command::SetLengths { lengths_um: [210_000; 3] });
    let faults = bench.run(1500);
    assert!(faults.iter().any(|f| matches!(f, Report::Fault { code: 1, detail: 1, .. })), "{faults:?}");
    let state = bench.sim.state();
    assert!(FaultBits(state.faults).contains(FaultBits::MOTOR_STALL));
    assert!(state.targets_um.iter().all(Option::is_none), "motors stopped");
    let refused = bench.ask(Command::Jog { tube: leech_protocol::message::Tube::L1, delta_um: 1000 });
    assert!(matches!(refused[..], [Report::Ack { status: AckStatus::Refused(Refusal::Faulted), .. }]), "{refused:?}");
    bench.ask(Command::ClearFaults { faults: FaultBits::MOTOR_STALL });
    let accepted = bench.ask(Command::Jog { tube: leech_protocol::message::Tube::L1, delta_um: 1000 });
    assert!(matches!(accepted[..], [Report::Ack { status: AckStatus::Ok, .. }]), "{accepted:?}");
}

#[test]
fn a_leaking_cup_latches_vacuum_lost_and_keeps_its_pump() {
    let mut bench = Bench::new();
    bench.ask(Command::Pump { cup: Cup::Front, on: true });
    bench.run(1000);
    assert!(bench.sim.state().holding[1]);
    bench.sim.set_faults(Faults { vacuum_loss: [false, true], ..Faults::default() });
    let faults = bench.run(1000);
    assert!(faults.iter().any(|f| matches!(f, Report::Fault { code: 2, detail: 1, .. })), "{faults:?}");
    let state = bench.sim.state();
    assert_eq!((state.pumps, state.holding), ([false, true], [false, false]));
    assert!(FaultBits(state.faults).contains(FaultBits::VACUUM_LOST));
}

#[test]
fn an_added_delay_holds_bytes_both_ways() {
    let mut sim = super::fresh_sim(SimConfig::default());
    sim.set_faults(Faults { delay_s: 0.040, ..Faults::default() });
    assert!(super::exchange(&mut sim, &frame(Command::Heartbeat, 1)).is_empty());
    // 40 ms in, 40 ms out.
    sim.step(0.079);
    assert!(super::exchange(&mut sim, &[]).is_empty());
    sim.step(0.002);
    let answers = super::exchange(&mut sim, &[]);
    assert!(matches!(answers[..], [Report::Ack { status: AckStatus::Ok, .. }]), "{answers:?}");
}
