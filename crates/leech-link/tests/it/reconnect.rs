//! Reconnection: the port goes away and comes back under the same name;
//! the session's configuration is restored after it and after a reset.

use std::path::PathBuf;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use leech_link::host::{Event, Link, LinkError, Restored};
use leech_link::sim::SimConfig;
use leech_protocol::message::{Tube, TubeSet};

use super::{configure, device, exchange, frame, options, wait_until};

/// A symbolic link standing for a port name that stays while the device
/// behind it changes (as a udev rule's name does for a replugged board).
struct PortName(PathBuf);

impl PortName {
    fn new() -> PortName {
        // One name per test: tests run in parallel in one process.
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("leech-link-reconnect-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("a temporary directory");
        PortName(dir.join("port"))
    }

    fn point_to(&self, target: &std::path::Path) {
        let _ = std::fs::remove_file(&self.0);
        std::os::unix::fs::symlink(target, &self.0).expect("a symbolic link");
    }
}

impl Drop for PortName {
    fn drop(&mut self) {
        if let Some(dir) = self.0.parent() {
            let _ = std::fs::remove_dir_all(dir);
        }
    }
}

fn wait_for(events: &Receiver<Event>, limit: Duration, wanted: impl Fn(&Event) -> bool) -> bool {
    let end = Instant::now() + limit;
    while let Some(left) = end.checked_duration_since(Instant::now()) {
        match events.recv_timeout(left) {
            Ok(event) if wanted(&event) => return true,
            Ok(_) => {}
            Err(_) => return false,
        }
    }
    false
}

#[test]
fn the_driver_reconnects_when_the_port_comes_back() {
    let name = PortName::new();
    let first = device(SimConfig::default());
    name.point_to(first.path());
    let link = Link::open(&name.0, options()).expect("handshake");
    let events = link.subscribe();
    link.stop().expect("acked");

    first.stop();
    assert!(wait_for(&events, Duration::from_secs(2), |e| *e == Event::Disconnected), "no disconnection seen");
    assert!(matches!(link.stop(), Err(LinkError::Disconnected)));
    assert!(!link.health().connected);

    let second = device(SimConfig::default());
    name.point_to(second.path());
    assert!(wait_for(&events, Duration::from_secs(3), |e| matches!(e, Event::Reconnected(_))), "no reconnection seen");
    link.stop().expect("acked after reconnecting");
    let health = link.health();
    assert!(health.connected && health.reconnects == 1, "{health:?}");
    assert!(second.state().counters.rx_frames >= 2);
}

/// Waits for the restore that follows a reconnection or a reset.
fn restored(events: &Receiver<Event>) -> Restored {
    let end = Instant::now() + Duration::from_secs(5);
    while let Some(left) = end.checked_duration_since(Instant::now()) {
        if let Ok(Event::Restored(restored)) = events.recv_timeout(left) {
            return restored;
        }
    }
    panic!("no restore seen");
}

/// L1 moved 5 mm, stopped, and measured in the last telemetry.
fn move_l1(link: &Link, device: &leech_link::pty::PtyDevice) {
    link.jog(Tube::L1, 5_000).expect("jog acked");
    assert!(wait_until(Duration::from_secs(3), || (device.state().lengths_um[0] - 205_000.0).abs() < 100.0));
    link.stop().expect("stop acked");
    // The motor runs down (tau 20 ms), then two telemetry periods pass, so
    // that the driver has the length it stopped at.
    assert!(wait_until(Duration::from_secs(1), || device.state().speeds_mm_s[0].abs() < 1e-3));
    std::thread::sleep(Duration::from_millis(50));
}

/// The telemetry lengths match the tubes' true lengths within two counts:
/// the length measured before the loss is up to one count short of the
/// truth (counts are whole), and the restarted count is again.
fn measured_right(link: &Link, device: &leech_link::pty::PtyDevice) {
    let events = link.subscribe();
    let Ok(Event::Telemetry(t)) = events.recv_timeout(Duration::from_secs(1)) else { panic!("telemetry resumes") };
    let truth = device.state().lengths_um;
    for i in 0..3 {
        let two_counts = 2000.0 / device.with_sim(|s| s.config().counts_per_mm());
        assert!((f64::from(t.lengths_um[i]) - truth[i]).abs() <= two_counts, "tube {i}: {t:?} for {truth:?}");
    }
}

/// A simulated robot behind a port name, linked and configured.
fn configured_through_a_name() -> (PortName, SimConfig, leech_link::pty::PtyDevice, Link) {
    let name = PortName::new();
    let config = SimConfig::default();
    let first = device(config);
    name.point_to(first.path());
    let link = Link::open(&name.0, options()).expect("handshake");
    configure(&link, &config, 20);
    (name, config, first, link)
}

#[test]
fn a_reconnection_restores_the_configuration_with_the_lengths_measured() {
    let (name, config, first, link) = configured_through_a_name();
    move_l1(&link, &first);
    let events = link.subscribe();

    // The same robot behind a controller that reset while unplugged.
    let lengths = first.state().lengths_um.map(|l| l.round() as i32);
    first.stop();
    let second = device(SimConfig { initial_lengths_um: lengths, ..config });
    name.point_to(second.path());
    let restored = restored(&events);
    assert_eq!(restored, Restored { rezeroed: TubeSet::ALL, ..Restored::default() });
    assert_eq!(second.state().telemetry_period_ms, 20, "the telemetry period is restored");
    measured_right(&link, &second);
    link.jog(Tube::L1, -5_000).expect("motion works again");
    assert!(wait_until(Duration::from_secs(3), || (second.state().lengths_um[0] - 200_000.0).abs() < 100.0));
    assert_eq!(link.health().restores, 1);
}

#[test]
fn a_reset_in_mid_session_is_reported_and_the_configuration_restored() {
    let config = SimConfig::default();
    let device = device(config);
    let link = Link::open(device.path(), options()).expect("handshake");
    configure(&link, &config, 20);
    move_l1(&link, &device);
    link.pump(leech_protocol::message::Cup::Rear, true).expect("pump on");
    let events = link.subscribe();

    device.with_sim(|sim| sim.reset());
    assert!(wait_for(&events, Duration::from_secs(2), |e| matches!(e, Event::DeviceReset(_))), "no reset seen");
    assert_eq!(restored(&events), Restored { rezeroed: TubeSet::ALL, ..Restored::default() });
    measured_right(&link, &device);
    let state = device.state();
    assert_eq!(state.configured, [true; 3]);
    assert_eq!(state.pumps, [false; 2], "a reset lets go, and the driver does not switch pumps on by itself");
}

#[test]
fn a_reconnection_to_a_device_that_kept_its_configuration_keeps_it() {
    let (name, config, first, link) = configured_through_a_name();
    let events = link.subscribe();
    first.stop();
    // A controller that kept running (auto-reset disabled) and has its
    // tubes configured: the driver must not re-zero them.
    let second = device(config);
    second.with_sim(|sim| {
        for (seq, tube) in (1..).zip(Tube::ALL) {
            exchange(sim, &frame(leech_protocol::message::Command::ConfigureTube(config.tube_config(tube)), seq));
        }
    });
    name.point_to(second.path());
    assert_eq!(restored(&events), Restored { kept: TubeSet::ALL, ..Restored::default() });
}
