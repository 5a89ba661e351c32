//! `leech serve`: refusals before anything listens, and the URL it prints.

use std::io::{BufRead, BufReader};
use std::process::Stdio;
use std::time::{Duration, Instant};

use super::{leech, rejected};

#[test]
fn serve_refuses_another_address_without_a_token() {
    let err = rejected(&["serve", "--listen", "0.0.0.0:0"]);
    assert!(err.contains("--token"), "{err}");
    let err = rejected(&["serve", "--listen", "127.0.0.1:0", "--token", "short"]);
    assert!(err.contains("--token"), "{err}");
    let err = rejected(&["serve", "--scene", "no-such-scene"]);
    assert!(err.contains("--scene"), "{err}");
}

#[test]
fn serve_prints_the_url_of_its_page() {
    let mut child = std::process::Command::new(leech().get_program())
        .args(["serve", "--listen", "127.0.0.1:0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = BufReader::new(stdout).read_line(&mut line);
        let _ = tx.send(line);
    });
    let started = Instant::now();
    let line = rx.recv_timeout(Duration::from_secs(30));
    child.kill().unwrap();
    child.wait().unwrap();
    let line = line.expect("a line within 30 s");
    assert!(line.starts_with("leech console: open http://127.0.0.1:"), "{line}");
    assert!(started.elapsed() < Duration::from_secs(30));
}
