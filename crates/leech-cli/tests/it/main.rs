//! The `leech` binary as a user meets it: exit codes, JSON keys, pictures,
//! one-line errors.

use assert_cmd::Command;
use serde_json::Value;

fn leech() -> Command {
    Command::cargo_bin("leech").expect("binary built")
}

fn json_of(args: &[&str]) -> Value {
    succeeds(leech().args(args).arg("--json"))
}

/// Runs a prepared command (its arguments may be paths), checks it succeeded
/// and parses its standard output as JSON.
fn succeeds(command: &mut Command) -> Value {
    let out = command.output().unwrap();
    assert!(out.status.success(), "{command:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("stdout is JSON")
}

/// Runs with bad input and returns stderr, checking exit code 2 and one line.
fn rejected(args: &[&str]) -> String {
    let out = leech().args(args).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "{args:?} should exit 2");
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(!err.contains("panicked"));
    err
}

#[test]
fn shape_json_has_the_documented_keys() {
    let v = json_of(&["shape", "--lengths", "0.25,0.20"]);
    for key in ["status", "stable", "iterations", "residual", "lengths_m", "endpoint_m", "endpoint_angle_rad", "chains"]
    {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["status"], "converged");
    assert_eq!(v["stable"], true);
    assert_eq!(v["lengths_m"][0].as_f64().unwrap(), 0.25);
    for chain in ["a", "b"] {
        let c = &v["chains"][chain];
        let points = c["points_m"].as_array().unwrap();
        let angles = c["angles_rad"].as_array().unwrap();
        assert_eq!(points.len(), angles.len() + 1, "base then every link tip");
    }
    assert_eq!(v["endpoint_m"], v["chains"]["a"]["points_m"].as_array().unwrap().last().unwrap().clone());
}

#[test]
fn chain_json_has_the_documented_keys() {
    let v = json_of(&[
        "chain",
        "--elements",
        "12",
        "--element-length",
        "0.01",
        "--element-mass",
        "0.001",
        "--stiffness",
        "0.05",
        "--tip-mass",
        "0.002",
        "--base-angle",
        "45",
        "--discretization",
        "midpoint",
    ]);
    for key in ["status", "angles_rad", "points_m", "tip_m"] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["angles_rad"].as_array().unwrap().len(), 12);
    // Midpoint: clamp, first joint, then 12 link tips.
    assert_eq!(v["points_m"].as_array().unwrap().len(), 14);
}

#[test]
fn svg_and_png_are_written() {
    let dir = std::env::temp_dir().join(format!("leech-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (svg, png) = (dir.join("shape.svg"), dir.join("shape.png"));
    leech().args(["shape", "--lengths", "0.3,0.28", "--svg"]).arg(&svg).arg("--png").arg(&png).assert().success();
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.contains("x (mm)"));
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn robot_prints_the_builtin_description() {
    let out = leech().arg("robot").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("ESTIMATE") && text.contains("payload_kg = 0.021"));
    let v = json_of(&["robot"]);
    assert_eq!(v["body"]["payload_kg"], 0.021);
}

#[test]
fn bad_input_exits_2_with_one_line() {
    let e = rejected(&["shape", "--lengths", "0.25,-0.2"]);
    assert!(e.contains("LB") && e.contains("-0.2"), "{e}");
    let e = rejected(&["shape", "--lengths", "0.005,0.2"]);
    assert!(e.contains("LA") && e.contains("one element"), "{e}");
    let e = rejected(&["shape", "--lengths", "0.25"]);
    assert!(e.contains("--lengths"), "{e}");
    // A rear hold whose driving unit lies in a solid: 2 mm into the thin wall's far face.
    let e = rejected(&["shape", "--lengths", "0.2,0.2", "--scene", "thin-wall", "--rear", "0.253,0.032,0"]);
    assert!(e.contains("--rear: got 0.253,0.032,0") && e.contains("outline 2.0 mm deep at (218.0, 44.0) mm"), "{e}");
    // No tube reaches farther than it is long (the built-in's are 0.40 m), nor in 3D.
    let e = rejected(&["shape", "--lengths", "0.45,0.2"]);
    assert!(e.contains("LA") && e.contains("0.45") && e.contains("tube.full_length_m = 0.4 m"), "{e}");
    let e = rejected(&["shape3d", "--lengths", "0.2,0.2,0.41"]);
    assert!(e.contains("0.41") && e.contains("tube.full_length_m"), "{e}");
    rejected(&["shape", "--lengths", "abc,0.2"]);
    rejected(&["shape", "--lengths", "0.3,nan"]);
    rejected(&["shape", "--lengths", "0.3,inf"]);
    rejected(&["shape", "--lengths", "0.3,0.2", "--gravity", "-1"]);
    rejected(&["shape", "--lengths", "0.3,0.2", "--base-angle", "1e9"]);
    let e = rejected(&["shape", "--lengths", "0.3,0.2", "--robot", "/no/such/robot.toml"]);
    assert!(e.contains("--robot"), "{e}");
    let e = rejected(&[
        "chain",
        "--elements",
        "0",
        "--element-length",
        "0.01",
        "--element-mass",
        "0.001",
        "--stiffness",
        "1",
    ]);
    assert!(e.contains("elements"), "{e}");
    let e =
        rejected(&["chain", "--elements", "5", "--element-length", "0.01", "--element-mass", "-1", "--stiffness", "1"]);
    assert!(e.contains("element_mass_kg") && e.contains("-1"), "{e}");
    rejected(&["chain", "--elements", "5", "--element-length", "0.01", "--element-mass", "0.001", "--stiffness", "0"]);
    rejected(&["frobnicate"]);
}

#[test]
fn malformed_robot_files_exit_2() {
    let dir = std::env::temp_dir().join(format!("leech-cli-robot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let builtin = String::from_utf8(leech().arg("robot").output().unwrap().stdout).unwrap();
    for (name, text) in [
        ("unknown.toml", builtin.replace("payload_kg = 0.021", "payload_kg = 0.021\nwings = 2")),
        ("broken.toml", builtin.replace("[body]", "[body")),
        ("negative.toml", builtin.replace("element_length_m = 0.01", "element_length_m = -0.01")),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let e = rejected(&["shape", "--lengths", "0.2,0.2", "--robot", path.to_str().unwrap()]);
        assert!(e.contains(name), "names the file: {e}");
    }
    // The hose's stop: one no joint can reach, a stiffness that is no stiffness.
    for (name, text, field) in [
        (
            "tight.toml",
            builtin.replace("min_bend_radius_m = 0.025", "min_bend_radius_m = 0.004"),
            "tube.min_bend_radius_m",
        ),
        (
            "soft_stop.toml",
            builtin.replace("# stop_stiffness_nm_per_rad = 50", "stop_stiffness_nm_per_rad = -50"),
            "tube.stop_stiffness_nm_per_rad",
        ),
        (
            "nan_stop.toml",
            builtin.replace("min_bend_radius_m = 0.025", "min_bend_radius_m = nan"),
            "tube.min_bend_radius_m",
        ),
    ] {
        assert_ne!(text, builtin, "{name}");
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let e = rejected(&["shape", "--lengths", "0.2,0.2", "--robot", path.to_str().unwrap()]);
        assert!(e.contains(field) && e.contains(name), "names the file and the field: {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn snap_through_is_reported() {
    let dir = std::env::temp_dir().join(format!("leech-cli-snap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let builtin = String::from_utf8(leech().arg("robot").output().unwrap().stdout).unwrap();
    let soft = builtin.replace("joint_stiffness_nm_per_rad = 0.5 ", "joint_stiffness_nm_per_rad = 0.004905 ");
    assert_ne!(soft, builtin);
    let path = dir.join("soft.toml");
    std::fs::write(&path, soft).unwrap();
    let v = json_of(&["shape", "--lengths", "0.15,0.15", "--robot", path.to_str().unwrap()]);
    assert_eq!(v["events"][0]["kind"], "snap");
    assert!(v["events"][0]["at_path_fraction"].as_f64().unwrap() > 0.0);
    std::fs::remove_dir_all(&dir).ok();
}

/// Runs a solve given 2 Newton iterations (with --json): exit 3, its
/// status on standard output, the residual said on standard error.
fn not_converged(args: &[&str]) {
    let out = leech().args(args).args(["--max-iterations", "2", "--json"]).output().unwrap();
    assert_eq!(out.status.code(), Some(3), "{args:?}");
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["status"], "not_converged");
    assert!(v["iterations"].as_u64().unwrap() <= 2);
    assert!(v["residual"].as_f64().unwrap() > 0.0);
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("not converged") && err.contains("residual"), "{err}");
}

#[test]
fn failed_solve_exits_3_with_status() {
    not_converged(&["shape", "--lengths", "0.3,0.2"]);
    let out = leech()
        .args([
            "chain",
            "--elements",
            "30",
            "--element-length",
            "0.01",
            "--element-mass",
            "0.001",
            "--stiffness",
            "0.01",
            "--max-iterations",
            "1",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3));
}

#[test]
fn both_models_are_listed() {
    let v = json_of(&["shape", "--lengths", "0.3,0.24", "--model", "both"]);
    let models = v["models"].as_array().unwrap();
    assert_eq!(models[0]["model"], "two-chain");
    assert_eq!(models[1]["model"], "constant-curvature");
    let w = 0.5 * (0.017 + 0.012);
    assert!((models[1]["bend_rad"].as_f64().unwrap() - (0.24 - 0.3) / w).abs() < 1e-12);
    let cc = json_of(&["shape", "--lengths", "0.3,0.24", "--model", "constant-curvature"]);
    assert_eq!(cc["endpoint_m"], models[1]["endpoint_m"]);
}

#[test]
fn shape_parameter_flag_sets_pi() {
    let v = json_of(&["shape", "--lengths", "0.2,0.18", "--shape-parameter", "800"]);
    assert!((v["shape_parameter"].as_f64().unwrap() - 800.0).abs() < 1e-9);
    let v = json_of(&[
        "chain",
        "--elements",
        "10",
        "--element-length",
        "0.01",
        "--element-mass",
        "0.001",
        "--shape-parameter",
        "40",
    ]);
    assert!((v["shape_parameter"].as_f64().unwrap() - 40.0).abs() < 1e-9);
    rejected(&["shape", "--lengths", "0.2,0.18", "--shape-parameter", "-3"]);
    rejected(&["chain", "--elements", "10", "--element-length", "0.01", "--element-mass", "0.001"]);
}

#[test]
fn figures_are_regenerated_by_one_command() {
    let dir = std::env::temp_dir().join(format!("leech-cli-figures-{}", std::process::id()));
    leech().args(["figure", "all", "--out"]).arg(&dir).assert().success();
    for name in ["tube-sag", "model-comparison", "scaling", "pi-sweep", "workspace"] {
        let svg = std::fs::read_to_string(dir.join(format!("{name}.svg"))).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "{name}");
        let csv = std::fs::read_to_string(dir.join(format!("{name}.csv"))).unwrap();
        assert!(csv.lines().count() > 10, "{name}");
    }
    let e = rejected(&["figure", "fig-13"]);
    assert!(e.contains("fig-13") && e.contains("workspace"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn workspace_writes_every_point_and_a_summary() {
    let dir = std::env::temp_dir().join(format!("leech-cli-ws-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (csv, svg) = (dir.join("ws.csv"), dir.join("ws.svg"));
    let v = succeeds(
        leech()
            .args([
                "workspace",
                "--lengths-range",
                "0.05:0.3:0.05",
                "--shape-parameter",
                "1000,5000",
                "--left-longer",
                "--json",
                "--out",
            ])
            .arg(&csv)
            .arg("--svg")
            .arg(&svg),
    );
    assert_eq!(v["points"], 63);
    assert_eq!(v["failures"], 0);
    let summaries = v["summaries"].as_array().unwrap();
    assert_eq!(summaries.len(), 3);
    for s in summaries {
        for key in [
            "model",
            "points",
            "failures",
            "infeasible",
            "highest",
            "lowest",
            "farthest",
            "area_m2",
            "differ_from_fresh",
        ] {
            assert!(s.get(key).is_some(), "missing {key}");
        }
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    assert_eq!(
        header,
        "model,shape_parameter,la_m,lb_m,status,stable,snapped,feasible,min_bend_radius_m,endpoint_x_m,endpoint_y_m,endpoint_angle_rad,fresh_difference_m"
    );
    assert_eq!(lines.count(), 63);
    assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg"));
    rejected(&["workspace", "--lengths-range", "0.05:0.3", "--out", "x.csv"]);
    rejected(&["workspace", "--lengths-range", "0.001:0.3:0.01", "--out", "x.csv"]);
    rejected(&["workspace", "--shape-parameter", "0", "--out", "x.csv"]);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn reach_finds_lengths_or_says_unreachable() {
    let shape = json_of(&["shape", "--lengths", "0.21,0.17"]);
    let target = format!("{},{}", shape["endpoint_m"][0], shape["endpoint_m"][1]);
    let v = json_of(&["reach", "--target", &target]);
    assert_eq!(v["status"], "reached");
    assert!(v["error_m"].as_f64().unwrap() < 1e-6);
    for key in ["lengths_m", "endpoint_m", "error_m"] {
        assert!(v.get(key).is_some());
    }
    let far = json_of(&["reach", "--target", "1,1"]);
    assert_eq!(far["status"], "unreachable");
    assert!(far["error_m"].as_f64().unwrap() > 0.5);
    rejected(&["reach", "--target", "nan,0.1"]);
    rejected(&["reach", "--target", "0.1"]);
}

fn example(name: &str) -> String {
    format!("{}/../../examples/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn calibrate_writes_a_fitted_robot() {
    let dir = std::env::temp_dir().join(format!("leech-cli-cal-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (toml, svg) = (dir.join("fitted.toml"), dir.join("fit.svg"));
    let v = succeeds(
        leech()
            .args(["calibrate", "--sag", &example("tube_sag.csv"), "--shapes", &example("body_shapes.csv")])
            .args(["--fit", "stiffness,mass", "--json", "--out"])
            .arg(&toml)
            .arg("--svg")
            .arg(&svg),
    );
    for key in ["stiffness_nm_per_rad", "stiffness_std_error_nm_per_rad", "rms_residual_mm", "element_mass_kg"] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    // The example data were made with k = 0.42, m = 1.2 g.
    assert!((v["stiffness_nm_per_rad"].as_f64().unwrap() - 0.42).abs() < 0.02 * 0.42);
    let text = std::fs::read_to_string(&toml).unwrap();
    assert!(text.starts_with("# Fitted by `leech calibrate`"));
    // The fitted robot is a valid robot file.
    let shape = leech().args(["shape", "--lengths", "0.2,0.18", "--robot"]).arg(&toml).output().unwrap();
    assert!(shape.status.success());
    assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg"));
    let e = rejected(&["calibrate", "--sag", &example("tube_sag.csv"), "--fit", "stiffness,mass", "--out", "x.toml"]);
    assert!(e.contains("not determined"), "{e}");
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "tube_length_m,base_angle_deg,x_m,y_m\n0.2,0,0.1,oops\n").unwrap();
    let e = rejected(&["calibrate", "--sag", bad.to_str().unwrap(), "--out", "x.toml"]);
    assert!(e.contains("row 2") && e.contains("y_m"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn compare_reports_both_models() {
    let v = json_of(&["compare", "--shapes", &example("body_shapes.csv")]);
    let shapes = v["shapes"].as_array().unwrap();
    assert_eq!(shapes.len(), 4);
    for s in shapes {
        for model in ["two_chain", "constant_curvature"] {
            for key in ["rms_mm", "max_mm", "endpoint_mm"] {
                assert!(s[model].get(key).is_some(), "missing {model}.{key}");
            }
        }
    }
    let out = leech().args(["compare", "--shapes", &example("body_shapes.csv")]).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("two-chain") && text.contains("LA300_LB240"));
}

#[test]
fn simulate_writes_series_animation_and_summary() {
    let dir = std::env::temp_dir().join(format!("leech-cli-sim-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (csv, svg) = (dir.join("sim.csv"), dir.join("sim.svg"));
    let v = succeeds(
        leech()
            .args([
                "simulate",
                "--lengths",
                "0.12,0.12",
                "--to",
                "0.15,0.11",
                "--until-rest",
                "--duration",
                "30",
                "--json",
            ])
            .arg("--csv")
            .arg(&csv)
            .arg("--svg")
            .arg(&svg),
    );
    for key in ["time_to_rest_s", "steps", "max_constraint_violation", "final", "real_time_factor"] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert!(v["max_constraint_violation"].as_f64().unwrap() < 1e-9);
    // At rest on the static equilibrium of the final lengths.
    let statics = json_of(&["shape", "--lengths", "0.15,0.11"]);
    let (a, b) = (&v["final"]["endpoint_m"], &statics["endpoint_m"]);
    let d = (a[0].as_f64().unwrap() - b[0].as_f64().unwrap()).hypot(a[1].as_f64().unwrap() - b[1].as_f64().unwrap());
    assert!(d < 1e-5, "final endpoint {d} m from the static one");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("time_s,la_m,lb_m,endpoint_x_m,endpoint_y_m,kinetic_j,potential_j,constraint_violation"));
    assert!(text.lines().count() > 10);
    let anim = std::fs::read_to_string(&svg).unwrap();
    assert!(
        anim.starts_with("<svg") && anim.contains("<animate attributeName=\"points\"") && anim.contains("t = 0.000 s")
    );
    rejected(&["simulate", "--lengths", "0.2,0.2", "--dt", "-1"]);
    rejected(&["simulate", "--lengths", "0.2,0.2", "--duration", "0"]);
    rejected(&["simulate", "--lengths", "0.2,0.2", "--to", "0.2,0.001"]);
    rejected(&["simulate", "--lengths", "0.2,0.2", "--step"]);
    std::fs::remove_dir_all(&dir).ok();
}

/// `--base-angle` turns the clamp as it does for `shape`: the body settles
/// on the static equilibrium at that angle.
#[test]
fn simulate_takes_the_base_angle() {
    let args = ["simulate", "--lengths", "0.15,0.11", "--until-rest", "--duration", "30", "--json"];
    let v = succeeds(leech().args(args).args(["--base-angle", "0"]));
    let statics = json_of(&["shape", "--lengths", "0.15,0.11", "--base-angle", "0"]);
    let (a, b) = (&v["final"]["endpoint_m"], &statics["endpoint_m"]);
    let d = (a[0].as_f64().unwrap() - b[0].as_f64().unwrap()).hypot(a[1].as_f64().unwrap() - b[1].as_f64().unwrap());
    assert!(d < 1e-5, "final endpoint {d} m from the static one at 0 deg");
    // Out along +x and sagging, not up the default wall.
    let (x, y) = (a[0].as_f64().unwrap(), a[1].as_f64().unwrap());
    assert!(x > 0.05 && y < 0.0, "endpoint {a} not out along +x and below it");
    rejected(&["simulate", "--lengths", "0.2,0.2", "--base-angle", "nan"]);
}

mod climb;
mod corpus;
mod drive;
mod harden;
mod holds;
mod serve;
mod shape3d;
mod tube;

/// Help into a pipe closed early (`leech shape --help | head -0`) is not a panic.
#[test]
fn help_into_a_closed_pipe_does_not_panic() {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_leech"))
        .args(["shape", "--help"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Close the reading end at once: the help is written into a closed pipe
    // (the process takes milliseconds to start; this takes microseconds).
    drop(child.stdout.take());
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(output.status.success(), "{:?}", output.status);
}

/// Output that cannot be written (a full disk) is a failure, exit 1, said on
/// standard error; a pipe closed early is not.
#[test]
fn an_unwritable_standard_output_fails() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else { return };
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_leech"))
        .args(["robot", "--json"])
        .stdout(full)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("writing the output"));
}
