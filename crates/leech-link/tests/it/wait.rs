//! Waits on telemetry (`wait::Watch`) and the executor: only reports sent
//! after a command are judged, a fault is noticed even when its report is
//! lost, and a tube the device stopped ends a move.

use std::time::Duration;

use leech::robot::Robot;
use leech::stride::Phase;
use leech_link::executor::{ExecError, Executor, Options as ExecOptions};
use leech_link::host::{Event, Link};
use leech_link::sim::{Faults, SimConfig};
use leech_link::wait::{WaitError, Watch};
use leech_protocol::message::{Command, Fault, Tube};

use super::{configure, device, frame, options, wait_until};

/// A long move every test starts: 30 mm on each tube.
const TARGETS: [i32; 3] = [230_000; 3];

#[test]
fn a_report_judged_after_a_command_was_sent_after_the_device_took_it() {
    let config = SimConfig::default();
    let device = device(config);
    let link = Link::open(device.path(), options()).expect("handshake");
    configure(&link, &config, 10);
    // 40 ms each way: about eight reports sent before the command's Ack
    // are waiting when it returns.
    device.set_faults(Faults { delay_s: 0.04, ..Faults::default() });
    let mut watch = Watch::new(link.subscribe());
    let first = watch.start(Duration::from_secs(5)).expect("telemetry");
    assert!(!first.active.contains(Tube::L1));
    let raw = link.subscribe();
    link.jog(Tube::L1, 5_000).expect("jog accepted");
    watch.after_command().expect("no fault");
    // The test means something: reports from before the jog were waiting.
    let stale = raw.try_iter().any(|e| matches!(e, Event::Telemetry(t) if !t.active.contains(Tube::L1)));
    assert!(stale, "reports from before the jog were waiting");
    let fresh = watch.next_telemetry(Duration::from_secs(5)).expect("telemetry");
    assert!(fresh.active.contains(Tube::L1), "{fresh:?}");
}

/// A move on a robot whose L2 motor is blocked; `lose`: its Fault report
/// is lost on the line.
fn stalled_move(lose: bool) -> WaitError {
    let config = SimConfig::default();
    let device = device(config);
    let link = Link::open(device.path(), options()).expect("handshake");
    configure(&link, &config, 20);
    device.set_faults(Faults { stalled: [false, true, false], lose_fault_reports: lose, ..Faults::default() });
    let mut watch = Watch::new(link.subscribe());
    watch.start(Duration::from_secs(5)).expect("telemetry");
    link.set_lengths(TARGETS).expect("accepted");
    watch.after_command().expect("no fault yet");
    watch.until_lengths(TARGETS, 500, Duration::from_secs(10)).expect_err("a stalled motor")
}

#[test]
fn a_stall_ends_a_wait_naming_the_tube() {
    let error = stalled_move(false);
    assert!(matches!(error, WaitError::Fault { fault: Fault { code: 1, detail: Some(1) }, .. }), "{error:?}");
    assert!(error.to_string().starts_with("the device reported a motor stall on tube L2 at "), "{error}");
}

#[test]
fn a_stall_whose_report_is_lost_still_ends_the_wait() {
    // Without the latched bit the wait would run to its deadline (10 s).
    let error = stalled_move(true);
    assert!(matches!(error, WaitError::Fault { fault: Fault { code: 1, detail: None }, .. }), "{error:?}");
    assert!(error.to_string().starts_with("the device reported a motor stall at "), "{error}");
}

/// Another host's `Stop` (a raw frame with a seq of its own) reaches the
/// device once L1 has moved 2 mm from `from_um`.
fn stop_when_moving(device: &leech_link::pty::PtyDevice, from_um: f64) {
    let moving = wait_until(Duration::from_secs(10), || (device.state().lengths_um[0] - from_um).abs() > 2_000.0);
    assert!(moving, "the move started: {:?}", device.state());
    device.with_sim(|sim| sim.receive(&frame(Command::Stop, 200)));
}

#[test]
fn a_tube_the_device_stopped_ends_the_wait() {
    let config = SimConfig::default();
    let device = device(config);
    let link = Link::open(device.path(), options()).expect("handshake");
    configure(&link, &config, 20);
    let mut watch = Watch::new(link.subscribe());
    watch.start(Duration::from_secs(5)).expect("telemetry");
    let from_um = device.state().lengths_um[0];
    link.set_lengths(TARGETS).expect("accepted");
    watch.after_command().expect("no fault");
    let error = std::thread::scope(|scope| {
        scope.spawn(|| stop_when_moving(&device, from_um));
        watch.until_lengths(TARGETS, 500, Duration::from_secs(10)).expect_err("stopped")
    });
    assert!(matches!(error, WaitError::Stopped { tube: Tube::L1, target_um: 230_000, .. }), "{error:?}");
    assert!(error.to_string().starts_with("the device stopped tube L1 before it reached 230000 um"), "{error}");
}

/// A push of the executor on a flat robot holding with its rear cup, while
/// `meanwhile` runs; the error it ends with.
fn push_fails(faults: Faults, meanwhile: impl FnOnce(&leech_link::pty::PtyDevice, f64) + Send) -> ExecError {
    let config = SimConfig::default();
    let device = device(config);
    let link = Link::open(device.path(), options()).expect("handshake");
    configure(&link, &config, 20);
    link.pump(leech_protocol::message::Cup::Rear, true).expect("rear pump");
    assert!(wait_until(Duration::from_secs(3), || device.state().holding[0]), "the rear cup holds");
    device.set_faults(faults);
    let from_um = device.state().lengths_um[0];
    let push = leech_link::executor::Move {
        phase: Phase::Push,
        lengths_m: [0.23, 0.23],
        rear_safety_factor: None,
        front_safety_factor: None,
    };
    std::thread::scope(|scope| {
        let device = &device;
        scope.spawn(move || meanwhile(device, from_um));
        let min_safety_factor = Robot::builtin().cup.min_safety_factor;
        let mut executor = Executor::new(&link, min_safety_factor, ExecOptions::default()).expect("executor");
        executor.step(3, &push).expect_err("the push fails")
    })
}

#[test]
fn the_executor_notices_a_stall_whose_report_is_lost() {
    let faults = Faults { stalled: [true; 3], lose_fault_reports: true, ..Faults::default() };
    let error = push_fails(faults, |_, _| {});
    assert!(
        matches!(error, ExecError::Fault { index: 3, phase: Phase::Push, fault: Fault { code: 1, detail: None } }),
        "{error:?}"
    );
    assert_eq!(error.to_string(), "step 3 (push): the device reported a motor stall");
}

#[test]
fn the_executor_names_a_tube_the_device_stopped() {
    let error = push_fails(Faults::default(), stop_when_moving);
    assert!(matches!(error, ExecError::Stopped { index: 3, phase: Phase::Push, tube: Tube::L1 }), "{error:?}");
    assert_eq!(error.to_string(), "step 3 (push): the device stopped tube L1");
}
