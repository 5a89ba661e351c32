//! Motion: the tubes reach their targets at the speed the drive allows, and
//! telemetry arrives at the configured rate.

use std::sync::mpsc::RecvTimeoutError;
use std::time::{Duration, Instant};

use leech_link::host::{Event, Link};
use leech_link::sim::SimConfig;
use leech_protocol::message::{Command, Tube};

use super::{configure, device, exchange, frame, fresh_sim, options, wait_until};

/// Tolerance on a reached length, um.
const TOLERANCE_UM: f64 = 200.0;

#[test]
fn the_simulated_tubes_reach_their_targets_at_20_mm_per_s() {
    let config = SimConfig::default();
    let mut sim = fresh_sim(config);
    let mut seq = 0;
    let mut send = |sim: &mut leech_link::sim::Sim, command| {
        seq += 1;
        exchange(sim, &frame(command, seq))
    };
    for tube in Tube::ALL {
        send(&mut sim, Command::ConfigureTube(config.tube_config(tube)));
    }
    let targets = [250_000, 230_000, 170_000];
    send(&mut sim, Command::SetLengths { lengths_um: targets });
    // The longest travel, 50 mm at 20 mm/s: 2.5 s.
    let mut arrived = None;
    for ms in 1..=4000 {
        sim.step(0.001);
        // Keep the link alive as a host would.
        if ms % 100 == 0 {
            send(&mut sim, Command::Heartbeat);
        }
        let state = sim.state();
        let near = state.lengths_um.iter().zip(targets).all(|(l, t)| (l - f64::from(t)).abs() <= TOLERANCE_UM);
        if near && arrived.is_none() {
            arrived = Some(ms);
        }
        for speed in state.speeds_mm_s {
            assert!(speed.abs() <= 20.0 * 1.15, "{speed} mm/s at {ms} ms");
        }
    }
    let arrived = arrived.expect("the tubes arrived");
    assert!((2400..=3000).contains(&arrived), "arrived after {arrived} ms");
    let state = sim.state();
    for (length, target) in state.lengths_um.iter().zip(targets) {
        assert!((length - f64::from(target)).abs() <= TOLERANCE_UM, "{length} um for {target} um");
    }
    assert_eq!(state.faults, 0);
}

#[test]
fn set_lengths_over_the_pty_and_telemetry_at_50_hz() {
    let config = SimConfig::default();
    let device = device(config);
    let link = Link::open(device.path(), options()).expect("handshake");
    let events = link.subscribe();
    configure(&link, &config, 20);
    let targets = [220_000, 210_000, 210_000];
    let start = Instant::now();
    link.set_lengths(targets).expect("accepted");
    let reached = || {
        let state = device.state();
        state.lengths_um.iter().zip(targets).all(|(l, t)| (l - f64::from(t)).abs() <= TOLERANCE_UM)
    };
    // 20 mm at 20 mm/s: 1 s, and settling.
    assert!(wait_until(Duration::from_secs(3), reached), "{:?}", device.state());
    let took = start.elapsed();
    assert!(took >= Duration::from_millis(950) && took <= Duration::from_millis(1600), "{took:?}");

    // Count the telemetry of one second.
    while events.try_recv().is_ok() {}
    let window = Instant::now();
    let mut reports = 0;
    let mut last_time = None;
    while window.elapsed() < Duration::from_secs(1) {
        match events.recv_timeout(Duration::from_millis(100)) {
            Ok(Event::Telemetry(t)) => {
                reports += 1;
                last_time = Some(t);
            }
            Ok(_) | Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
    }
    assert!((45..=55).contains(&reports), "{reports} reports in 1 s");
    let last = last_time.expect("telemetry");
    for (measured, target) in last.lengths_um.iter().zip(targets) {
        assert!((measured - target).abs() <= TOLERANCE_UM as i32, "{measured} um for {target} um");
    }
}

#[test]
fn the_state_round_trips_through_json() {
    let mut sim = fresh_sim(SimConfig::default());
    exchange(&mut sim, &frame(Command::ConfigureTube(SimConfig::default().tube_config(Tube::L3)), 1));
    exchange(&mut sim, &frame(Command::Jog { tube: Tube::L3, delta_um: 3000 }, 2));
    sim.step(0.1);
    let state = sim.state();
    let json = serde_json::to_string(&state).expect("serializes");
    assert!(json.contains("\"lengths_um\"") && json.contains("\"vacuum_kpa\""), "{json}");
    let back: leech_link::sim::SimState = serde_json::from_str(&json).expect("deserializes");
    assert_eq!(back, state);
}

/// The front cup is flush only while the centre tube is at most 205 mm long.
struct ShortReach;

impl leech_link::sim::Cups for ShortReach {
    fn sealed(&self, cup: leech_protocol::message::Cup, lengths_m: [f64; 3]) -> bool {
        cup == leech_protocol::message::Cup::Rear || lengths_m[0] <= 0.205
    }
}

#[test]
fn a_cup_off_the_surface_builds_no_vacuum() {
    use leech_protocol::message::Cup;
    let config = SimConfig::default();
    let mut sim = leech_link::sim::Sim::with_cups(config, Box::new(ShortReach));
    exchange(&mut sim, &[]);
    exchange(&mut sim, &frame(Command::ConfigureTube(config.tube_config(Tube::L1)), 1));
    exchange(&mut sim, &frame(Command::Pump { cup: Cup::Front, on: true }, 2));
    sim.step(1.0);
    assert!(sim.state().holding[1], "sealed at 200 mm");
    exchange(&mut sim, &frame(Command::Pump { cup: Cup::Front, on: false }, 3));
    exchange(&mut sim, &frame(Command::Jog { tube: Tube::L1, delta_um: 10_000 }, 4));
    for seq in 5..=20 {
        sim.step(0.1);
        exchange(&mut sim, &frame(Command::Heartbeat, seq));
    }
    exchange(&mut sim, &frame(Command::Pump { cup: Cup::Front, on: true }, 21));
    sim.step(0.05);
    exchange(&mut sim, &frame(Command::Heartbeat, 22));
    sim.step(0.05);
    let state = sim.state();
    assert!(state.lengths_um[0] > 209_000.0, "{state:?}");
    assert!(state.pumps[1] && !state.holding[1] && state.vacuum_kpa[1] < 1.0, "{state:?}");
}
