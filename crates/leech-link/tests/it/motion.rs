//! Motion: the tubes reach their targets at the speed the drive allows, and
//! telemetry arrives at the configured rate.

use std::sync::mpsc::RecvTimeoutError;
use std::time::{Duration, Instant};

use leech_link::host::{Event, Link};
use leech_link::sim::SimConfig;
use leech_protocol::message::{Command, Telemetry, Tube};

use super::{configure, device, exchange, frame, fresh_sim, options};

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
    // A report before the command, so that its start can be told.
    let mut reports: Vec<Telemetry> = Vec::new();
    while reports.is_empty() {
        match events.recv_timeout(Duration::from_secs(5)) {
            Ok(Event::Telemetry(t)) => reports.push(t),
            Ok(_) => {}
            Err(e) => panic!("no telemetry: {e}"),
        }
    }
    let targets = [220_000, 210_000, 210_000];
    link.set_lengths(targets).expect("accepted");
    // Every report in wire order, until one second of device time after the
    // tubes arrived: everything is judged on the device's clock, so that a
    // loaded machine (a late host, a late simulation thread) changes nothing.
    let near = |t: &Telemetry| {
        t.lengths_um.iter().zip(targets).all(|(l, target)| f64::from((l - target).abs()) <= TOLERANCE_UM)
    };
    let end = Instant::now() + Duration::from_secs(20);
    let mut arrived: Option<u32> = None;
    while arrived.is_none_or(|at| reports.last().is_some_and(|t| t.time_ms < at + 1000)) {
        let left = end.saturating_duration_since(Instant::now());
        match events.recv_timeout(left) {
            Ok(Event::Telemetry(t)) => {
                let moving = t.active.contains(Tube::L1);
                if arrived.is_none() && moving && near(&t) {
                    arrived = Some(t.time_ms);
                }
                reports.push(t);
            }
            Ok(other) => panic!("{other:?}"),
            Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => panic!("{} reports", reports.len()),
        }
    }
    let arrived = arrived.expect("arrived");
    // The device took the command between the last report without the move
    // and the first with it (20 ms apart).
    let first = reports.iter().position(|t| t.active.contains(Tube::L1)).expect("the move started");
    assert!(first > 0, "a report before the command");
    let (before, after) = (reports[first - 1].time_ms, reports[first].time_ms);
    assert_eq!(after - before, 20);
    // 20 mm at 20 mm/s: 1 s, and settling.
    let (at_least, at_most) = (arrived - after, arrived - before);
    assert!(at_least >= 950 && at_most <= 1600, "arrived {at_least}..{at_most} ms after the command");

    // The telemetry of one second of device time, from the arrival: 50 Hz,
    // none lost.
    let window: Vec<&Telemetry> = reports.iter().filter(|t| (arrived..arrived + 1000).contains(&t.time_ms)).collect();
    assert_eq!(window.len(), 50, "{} reports in 1 s", window.len());
    assert!(reports.windows(2).all(|w| w[1].time_ms - w[0].time_ms == 20), "one report every 20 ms");
    let last = reports.last().expect("telemetry");
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
