//! Reconnection: the port goes away and comes back under the same name.

use std::path::PathBuf;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use leech_link::host::{Event, Link, LinkError};
use leech_link::sim::SimConfig;

use super::{device, options};

/// A symbolic link standing for a port name that stays while the device
/// behind it changes (as a udev rule's name does for a replugged board).
struct PortName(PathBuf);

impl PortName {
    fn new() -> PortName {
        let dir = std::env::temp_dir().join(format!("leech-link-reconnect-{}", std::process::id()));
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
