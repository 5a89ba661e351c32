//! `leech sim-robot` and `leech drive` together, as a user runs them: the
//! simulated robot in one process behind a real pseudo-terminal, the
//! driver in others. Bounded: the simulation ends by itself and is killed
//! when the test ends.

use std::io::{BufRead, BufReader};
use std::process::{Child, Stdio};

use super::*;

/// A running `leech sim-robot`, killed on drop.
struct SimRobot {
    child: Child,
    port: String,
}

impl SimRobot {
    fn start(extra: &[&str]) -> SimRobot {
        let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("leech"))
            .args(["sim-robot", "--duration", "60"])
            .args(extra)
            .stdout(Stdio::piped())
            .spawn()
            .expect("leech sim-robot starts");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let port = line.trim().strip_prefix("port ").unwrap_or_else(|| panic!("first line: {line}")).to_string();
        SimRobot { child, port }
    }

    fn drive(&self, args: &[&str]) -> std::process::Output {
        leech()
            .args(["drive", "--port", &self.port])
            .args(args)
            .timeout(std::time::Duration::from_secs(30))
            .output()
            .unwrap()
    }
}

impl Drop for SimRobot {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn the_simulated_robot_is_driven_over_its_port() {
    let sim = SimRobot::start(&[]);
    let out = sim.drive(&["status", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["action"], "status");
    // The built-in robot's [drive]: every tube 0.2 m at power-up.
    for l in v["state"]["lengths_m"].as_array().unwrap() {
        assert!((l.as_f64().unwrap() - 0.2).abs() < 1e-4, "{v}");
    }
    // A move is waited for: the tubes arrive within 0.5 mm.
    let out = sim.drive(&["lengths", "0.23,0.21,0.21", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let got: Vec<f64> = v["state"]["lengths_m"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    for (g, want) in got.iter().zip([0.23, 0.21, 0.21]) {
        assert!((g - want).abs() <= 5e-4, "{got:?}");
    }
    assert_eq!(v["sends"], 1);
    // The host refuses to let go of the last holding cup before sending
    // anything (the controller would refuse too): exit 3, the rule named.
    assert!(sim.drive(&["pump", "rear", "on"]).status.success());
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let out = sim.drive(&["pump", "rear", "off"]);
    assert_eq!(out.status.code(), Some(3));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains(
            "pump rear off: refused on the host, the front cup does not hold by the device's latest telemetry"
        ) && err.contains("one cup must always hold"),
        "{err}"
    );
    let v: Value = serde_json::from_slice(&sim.drive(&["stop", "--json"]).stdout).unwrap();
    assert_eq!(v["state"]["pumps_on"]["rear"], true, "the pump stays on: {v}");
    // Phases by hand, behind the interlock: a release below the minimum safety factor is refused.
    assert!(sim.drive(&["stride", "attach_front"]).status.success());
    let out = sim.drive(&["stride", "release_rear", "--safety-factor", "1.2"]);
    assert_eq!(out.status.code(), Some(3));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("release rear: refused") && err.contains("1.200"), "{err}");
    let v: Value =
        serde_json::from_slice(&sim.drive(&["stride", "release_rear", "--safety-factor", "3", "--json"]).stdout)
            .unwrap();
    assert_eq!(v["action"], "stride");
    assert_eq!(v["state"]["pumps_on"]["rear"], false, "{v}");
    assert_eq!(v["state"]["holding"]["front"], true, "{v}");
}

#[test]
fn bad_drives_exit_2_with_one_line() {
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "status"]);
    assert!(e.contains("--port") && e.contains("/nonexistent-leech-port"), "{e}");
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "lengths", "0.5,0.2,0.2"]);
    assert!(e.contains("L1 = 0.5") && e.contains("[0.05, 0.3]"), "{e}");
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "jog", "4", "1"]);
    assert!(e.contains("tube 4"), "{e}");
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "run", "/nonexistent-plan.json"]);
    assert!(e.contains("run: got '/nonexistent-plan.json', which does not exist"), "{e}");
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "stride", "push"]);
    assert!(e.contains("--lengths"), "{e}");
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "stride", "release_front"]);
    assert!(e.contains("--safety-factor"), "{e}");
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "stride", "hop"]);
    assert!(e.contains("'hop'") && e.contains("attach_front"), "{e}");
    let e = rejected(&["sim-robot", "--faults", "corrupt=2"]);
    assert!(e.contains("corrupt=2") && e.contains("probability"), "{e}");
    let dir = std::env::temp_dir().join(format!("leech-cli-bare-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bare = dir.join("bare.toml");
    std::fs::write(&bare, "name = \"bare\"\n[[half_plane]]\npoint_m = [0.0, 0.0]\nnormal = [0.0, 1.0]\n").unwrap();
    let e = rejected(&["sim-robot", "--scene", bare.to_str().unwrap()]);
    assert!(e.contains("--scene") && e.contains("[start]"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
    let e = rejected(&["sim-robot", "--duration", "0"]);
    assert!(e.contains("--duration"), "{e}");
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "clear-faults", "motor-stall,jam"]);
    assert!(e.contains("'jam'") && e.contains("motor-stall") && e.contains("all"), "{e}");
}

#[test]
fn oversized_and_endless_input_files_exit_2_with_one_line() {
    let dir = std::env::temp_dir().join(format!("leech-cli-big-robot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let big = dir.join("big.toml");
    // A comment past the limit: valid TOML, too long to be read.
    std::fs::write(&big, format!("# {}\n", "x".repeat(2 << 20))).unwrap();
    let e = rejected(&["sim-robot", "--robot", big.to_str().unwrap()]);
    assert!(e.contains("--robot") && e.contains("larger than 1 MiB"), "{e}");
    // A device file is read only up to the limit.
    let e = rejected(&["sim-robot", "--robot", "/dev/zero"]);
    assert!(e.contains("--robot") && e.contains("/dev/zero"), "{e}");
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "--robot", "/dev/zero", "status"]);
    assert!(e.contains("--robot"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_plan_files_exit_2_with_one_line() {
    let dir = std::env::temp_dir().join(format!("leech-cli-bad-plans-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let plan = |name: &str, steps: &str| {
        let path = dir.join(name);
        std::fs::write(&path, format!("{{\"status\": \"reached\", \"steps\": {steps}}}")).unwrap();
        path.to_str().unwrap().to_string()
    };
    let three = plan("three.json", r#"[{"phase": "push", "lengths_m": [0.3, 0.3, 99]}]"#);
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "run", &three]);
    assert!(e.contains("steps[0].lengths_m") && e.contains("[0.3,0.3,99]") && e.contains("[LA, LB]"), "{e}");
    let one = plan("one.json", r#"[{"phase": "push", "lengths_m": [0.2]}]"#);
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "run", &one]);
    assert!(e.contains("steps[0].lengths_m"), "{e}");
    let empty = plan("empty.json", "[]");
    let e = rejected(&["drive", "--port", "/nonexistent-leech-port", "run", &empty]);
    assert!(e.contains("steps: got 0") && e.contains("1 to 10000 steps"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The report after a command comes from telemetry the device sent after
/// it took the command: with 40 ms each way on the line, several older
/// reports are waiting when the command's answer arrives.
#[test]
fn the_state_after_a_command_is_fresh() {
    let sim = SimRobot::start(&["--faults", "delay=0.04"]);
    let out = sim.drive(&["jog", "1", "5", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["state"]["active"][0], true, "the jog is under way: {v}");
}

/// A stalled motor: the move fails naming the stall and its tube, motion
/// is refused until `clear-faults`, then allowed again.
#[test]
fn a_motor_stall_is_named_and_cleared() {
    let sim = SimRobot::start(&["--faults", "stall=2"]);
    let out = sim.drive(&["lengths", "0.23,0.23,0.23"]);
    assert_eq!(out.status.code(), Some(3));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("the device reported a motor stall on tube L2"), "{err}");
    let out = sim.drive(&["jog", "1", "1"]);
    assert_eq!(out.status.code(), Some(3));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("refused Jog"), "{err}");
    let out = sim.drive(&["status"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("faults: link-lost, motor-stall") || text.contains("faults: motor-stall"), "{text}");
    let out = sim.drive(&["clear-faults", "motor-stall,link-lost", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["action"], "clear-faults");
    assert_eq!(v["state"]["faults"], 0, "{v}");
    let out = sim.drive(&["jog", "1", "1", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(sim.drive(&["clear-faults"]).status.success(), "all by default");
}

/// The stall's Fault report lost on the line: the latched bit in the
/// telemetry still ends the move.
#[test]
fn a_motor_stall_whose_report_is_lost_still_fails_the_move() {
    let sim = SimRobot::start(&["--faults", "stall=2,lose-fault-reports"]);
    let out = sim.drive(&["lengths", "0.23,0.23,0.23"]);
    assert_eq!(out.status.code(), Some(3));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("the device reported a motor stall at"), "{err}");
}

/// A planned climb (`leech climb --json`, then `leech drive run PLAN.json`)
/// carried out on the simulated robot, whose body is the scenario's (a cup seals only where its face lies flush): one stride on the
/// floor, each step confirmed by telemetry, ending with the rear cup holding
/// and the tubes back at their shortest.
#[test]
fn a_planned_climb_runs_on_the_simulated_robot() {
    let dir = std::env::temp_dir().join(format!("leech-cli-run-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("short.toml");
    let text = "name = \"short crawl\"\nscene = \"floor\"\n[start]\nrear_cup = [0.0, 0.0, 0.0]\n\
                [goal]\npoint_m = [0.12, 0.0]\ntolerance_m = 0.03\n";
    std::fs::write(&file, text).unwrap();
    let scenario = file.to_str().unwrap();
    let sim = SimRobot::start(&["--scenario", scenario]);
    assert!(sim.drive(&["pump", "rear", "on"]).status.success());
    std::thread::sleep(std::time::Duration::from_millis(1500));
    // The plan as `leech climb --json` writes it, carried out from the file.
    let plan = leech().args(["climb", "--scenario", scenario, "--json"]).output().unwrap();
    assert!(plan.status.success());
    let plan_file = dir.join("plan.json");
    std::fs::write(&plan_file, &plan.stdout).unwrap();
    let out = sim.drive(&["run", plan_file.to_str().unwrap(), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["state"]["holding"]["rear"], true, "{v}");
    assert_eq!(v["state"]["pumps_on"]["front"], false, "{v}");
    for l in v["state"]["lengths_m"].as_array().unwrap() {
        assert!((l.as_f64().unwrap() - 0.05).abs() < 1e-3, "{v}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
