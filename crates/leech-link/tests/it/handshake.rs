//! The handshake over a real pseudo-terminal, beyond the suite's: a device
//! of another version, no device, a device already running.

use leech_link::host::{Link, LinkError};
use leech_link::sim::SimConfig;
use leech_protocol::message::Version;

use super::{device, options};

#[test]
fn another_major_version_is_refused_naming_both() {
    let device = device(SimConfig::default().with_protocol(Version { major: 2, minor: 1 }));
    let error = match Link::open(device.path(), options()) {
        Ok(_) => panic!("a 2.1 device was accepted"),
        Err(e) => e,
    };
    assert!(matches!(error, LinkError::Version(_)), "{error:?}");
    let text = error.to_string();
    assert!(text.contains("1.0") && text.contains("2.1"), "{text}");
}

#[test]
fn no_device_is_a_clear_error() {
    let error = Link::open("/nonexistent/leech-port", options()).err().expect("no port");
    assert!(matches!(error, LinkError::Open { .. }), "{error:?}");
    assert!(error.to_string().contains("leech-port"), "{error}");
}

#[test]
fn a_device_already_running_is_greeted_after_the_boot_wait() {
    let device = device(SimConfig::default());
    drop(Link::open(device.path(), options()).expect("first session"));
    // No boot Hello this time: the driver waits it out, then says Hello.
    let start = std::time::Instant::now();
    let link = Link::open(device.path(), options()).expect("second session");
    assert!(start.elapsed() >= options().boot_timeout, "{:?}", start.elapsed());
    link.stop().expect("acked");
}
