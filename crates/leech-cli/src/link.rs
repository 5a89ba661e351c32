//! `leech sim-robot` and `leech drive`: run the library's simulated robot
//! and host driver (`leech_link`), and print what they report.
//!
//! Exit codes: a port that cannot be opened is bad input (2); a command the
//! controller refused (which rule, why) or a move that did not arrive is a
//! failed operation (3); anything else (no device, another protocol
//! version, a lost link) is 1.

use std::fmt::Write as _;
use std::io::Write as _;
use std::time::{Duration, Instant};

use leech_link::body::BodyCups;
use leech_link::executor::{self, Executor};
use leech_link::host::{Acked, Link, LinkError, Options};
use leech_link::pty::PtyDevice;
use leech_link::sim::Sim;
use leech_link::wait::{WaitError, Watch};
use leech_protocol::message::{Cup, Faults, Telemetry, NO_SENSOR};
use serde::Serialize;

use crate::args::{Action, Drive, Run, SimRobot};
use crate::failure::Failure;

/// Runs the simulated robot: prints its port's path at once (a line of
/// text, `port PATH`), then its state as a JSON line every `status_every`,
/// until `duration` (or until the process is stopped).
pub fn sim_robot(a: SimRobot) -> Result<(), Failure> {
    let sim = match a.body {
        Some((robot, scene, start)) => Sim::with_cups(a.config, Box::new(BodyCups::new(robot, scene, start))),
        None => Sim::new(a.config),
    };
    let device = PtyDevice::spawn(sim).map_err(|e| Failure::Other(e.into()))?;
    device.set_faults(a.faults);
    let mut stdout = std::io::stdout();
    let say = |stdout: &mut std::io::Stdout, line: String| -> Result<(), Failure> {
        writeln!(stdout, "{line}").and_then(|()| stdout.flush()).map_err(|e| Failure::Other(e.into()))
    };
    say(&mut stdout, format!("port {}", device.path().display()))?;
    let started = Instant::now();
    let tick = a.status_every.unwrap_or(Duration::from_millis(100));
    let mut next_status = started;
    loop {
        if a.duration.is_some_and(|d| started.elapsed() >= d) {
            return Ok(());
        }
        if a.status_every.is_some() && Instant::now() >= next_status {
            let state = serde_json::to_string(&device.state()).map_err(|e| Failure::Other(e.into()))?;
            say(&mut stdout, state)?;
            next_status += tick;
        }
        std::thread::sleep(Duration::from_millis(10).min(tick));
    }
}

/// What `leech drive` reports.
#[derive(Serialize)]
struct DriveReport {
    /// The action done.
    action: &'static str,
    /// The command's acknowledgement: round trip (s) and sends (1 without retries).
    round_trip_s: Option<f64>,
    sends: Option<u32>,
    /// The controller's state after it.
    state: State,
    /// The link's health.
    link: Health,
}

/// The controller's state from a telemetry report, with units.
#[derive(Serialize)]
struct State {
    time_s: f64,
    lengths_m: [f64; 3],
    counts: [i32; 3],
    duty_permille: [i16; 3],
    /// Tubes under position control (L1, L2, L3).
    active: [bool; 3],
    pumps_on: Pair,
    holding: Pair,
    /// Vacuum per cup (kPa), `null` without a sensor.
    vacuum_kpa: [Option<f64>; 2],
    /// Latched fault bits (docs/protocol.md).
    faults: u16,
}

#[derive(Serialize)]
struct Pair {
    rear: bool,
    front: bool,
}

#[derive(Serialize)]
struct Health {
    last_round_trip_s: Option<f64>,
    sent: u64,
    resends: u64,
    bad_crc: u64,
    bad_frames: u64,
}

impl State {
    fn new(t: &Telemetry) -> State {
        let pair = |set: leech_protocol::message::CupSet| Pair {
            rear: set.contains(Cup::Rear),
            front: set.contains(Cup::Front),
        };
        State {
            time_s: f64::from(t.time_ms) / 1e3,
            lengths_m: t.lengths_um.map(|l| f64::from(l) / 1e6),
            counts: t.counts,
            duty_permille: t.duty_permille,
            active: leech_protocol::message::Tube::ALL.map(|tube| t.active.contains(tube)),
            pumps_on: pair(t.pumps),
            holding: pair(t.holding),
            vacuum_kpa: t.vacuum_kpa_x10.map(|v| (v != NO_SENSOR).then(|| f64::from(v) / 10.0)),
            faults: t.faults.0,
        }
    }
}

/// How a link error ends the command.
fn failure(e: LinkError) -> Failure {
    match e {
        LinkError::Open { .. } => Failure::Input(format!("--port: {e}")),
        LinkError::Refused { .. } | LinkError::Rejected { .. } => Failure::Unsolved(e.to_string()),
        other => Failure::Other(other.into()),
    }
}

fn waited(e: WaitError) -> Failure {
    match e {
        WaitError::NotReached { .. } | WaitError::Fault { .. } | WaitError::Stopped { .. } => {
            Failure::Unsolved(e.to_string())
        }
        other => Failure::Other(other.into()),
    }
}

/// Telemetry period while a command waits on it (ms).
const TELEMETRY_MS: u16 = 20;

/// How long a command waits for a telemetry report.
const TELEMETRY_WAIT: Duration = Duration::from_secs(2);

/// How close the tubes must come to their targets (um).
const ARRIVED_UM: i32 = 500;

/// Opens the port, configures the tubes from the robot file, does the
/// action and reports the state after it.
pub fn drive(out: &mut String, a: Drive) -> Result<(), Failure> {
    // A scenario is planned before the port is opened: the controller waits on nothing.
    let moves = match &a.action {
        Action::Run(Run::Phase(one)) => Some(vec![*one]),
        Action::Run(Run::Moves(moves)) => Some(moves.clone()),
        Action::Run(Run::Scenario(robot, s)) => {
            let options = leech::stride::PlanOptions::default();
            let plan = leech::stride::plan(robot, &s.scene, s.start, s.goal, &options)?;
            if plan.status != leech::stride::Status::Reached {
                let why = plan.reason.map_or_else(String::new, |r| format!(": {}", r.detail));
                return Err(Failure::Unsolved(format!("run: the climb cannot be planned{why}")));
            }
            Some(executor::moves(&plan))
        }
        _ => None,
    };
    let link = Link::open(&a.port, Options { reconnect: false, ..Options::default() }).map_err(failure)?;
    for tube in a.tubes {
        link.configure_tube(tube).map_err(failure)?;
    }
    // Every report judged is one the device sent after it took the last
    // command (wait::Watch); the faults latched before this command are
    // known from the first report, a fault latched since is news.
    let mut watch = Watch::new(link.subscribe());
    link.set_telemetry(TELEMETRY_MS).map_err(failure)?;
    let first = watch.start(TELEMETRY_WAIT).map_err(waited)?;
    // The next report sent after the command just acknowledged.
    let after = |watch: &mut Watch| -> Result<Telemetry, Failure> {
        watch.after_command().map_err(waited)?;
        watch.next_telemetry(TELEMETRY_WAIT).map_err(waited)
    };
    let (name, acked, state): (&str, Option<Acked>, Telemetry) = match a.action {
        Action::Status => ("status", None, first),
        Action::Lengths(targets) => {
            let acked = link.set_lengths(targets).map_err(failure)?;
            let travel_um = (0..3).map(|i| (targets[i] - first.lengths_um[i]).unsigned_abs()).max().unwrap_or(0);
            let speed_um_s = f64::from(a.tubes[0].max_speed_um_s.max(1));
            let timeout = Duration::from_secs_f64(f64::from(travel_um) / speed_um_s * 1.5 + 3.0);
            watch.after_command().map_err(waited)?;
            let t = watch.until_lengths(targets, ARRIVED_UM, timeout).map_err(waited)?;
            ("lengths", Some(acked), t)
        }
        Action::Jog(tube, delta_um) => {
            let acked = link.jog(tube, delta_um).map_err(failure)?;
            ("jog", Some(acked), after(&mut watch)?)
        }
        Action::Pump(cup, on) => {
            if !on {
                // The host's interlock first (the device's last-cup rule
                // stays behind it): judged on the latest report.
                executor::check_pump_off(cup, &first).map_err(|e| {
                    Failure::Unsolved(format!(
                        "pump {cup} off: refused on the host, the {} cup does not hold by the device's latest \
                         telemetry ({e})",
                        cup.other()
                    ))
                })?;
            }
            let acked = link.pump(cup, on).map_err(failure)?;
            ("pump", Some(acked), after(&mut watch)?)
        }
        Action::Stop => {
            let acked = link.stop().map_err(failure)?;
            ("stop", Some(acked), after(&mut watch)?)
        }
        Action::ClearFaults(faults) => {
            let acked = link.clear_faults(faults).map_err(failure)?;
            // The faults left are shown, not judged: a fault whose cause
            // persists latches again.
            ("clear-faults", Some(acked), watch.start(TELEMETRY_WAIT).map_err(waited)?)
        }
        Action::Run(run) => {
            let name = if matches!(run, Run::Phase(_)) { "stride" } else { "run" };
            let moves = moves.unwrap_or_default();
            let mut executor = Executor::new(&link, a.min_safety_factor, executor::Options::default())
                .map_err(|e| Failure::Unsolved(format!("run: {e}")))?;
            let bar = crate::render::progress(moves.len() as u64, "steps");
            executor
                .run(&moves, |done| bar.set_position(done.index as u64 + 1))
                .map_err(|e| Failure::Unsolved(format!("{name}: {e}")))?;
            bar.finish_and_clear();
            // The reports queued during the run are stale: the state now.
            (name, None, watch.start(TELEMETRY_WAIT).map_err(waited)?)
        }
    };
    let health = link.health();
    let report = DriveReport {
        action: name,
        round_trip_s: acked.map(|a| a.round_trip.as_secs_f64()),
        sends: acked.map(|a| a.sends),
        state: State::new(&state),
        link: Health {
            last_round_trip_s: health.last_round_trip().map(|d| d.as_secs_f64()),
            sent: health.sent,
            resends: health.resends,
            bad_crc: health.bad_crc,
            bad_frames: health.bad_frames,
        },
    };
    if a.json {
        let text = serde_json::to_string_pretty(&report).map_err(|e| Failure::Other(e.into()))?;
        let _ = writeln!(out, "{text}");
    } else {
        let s = &report.state;
        let mm = s.lengths_m.map(|l| l * 1e3);
        let _ = writeln!(
            out,
            "{}: lengths {:.2} {:.2} {:.2} mm, duty {:?} per mille",
            report.action, mm[0], mm[1], mm[2], s.duty_permille
        );
        let _ = writeln!(
            out,
            "pumps rear {} front {}; holding rear {} front {}; faults: {}",
            on(s.pumps_on.rear),
            on(s.pumps_on.front),
            s.holding.rear,
            s.holding.front,
            fault_names(s.faults)
        );
        if let (Some(rt), Some(n)) = (report.round_trip_s, report.sends) {
            let _ = writeln!(out, "acknowledged in {:.2} ms after {n} send(s)", rt * 1e3);
        }
    }
    Ok(())
}

/// The latched faults by name (docs/protocol.md, as `clear-faults` takes
/// them), `none` without any.
fn fault_names(bits: u16) -> String {
    Faults(bits).to_string().replace('_', "-").replace('+', ", ")
}

fn on(b: bool) -> &'static str {
    if b {
        "on"
    } else {
        "off"
    }
}
