//! Issue 15's reproductions: hostile input ends in exit 2 and one short,
//! readable line, never a panic.

use super::rejected;

#[test]
fn an_overflowing_tube_length_is_rejected_not_a_panic() {
    let e = rejected(&[
        "chain",
        "--elements",
        "20",
        "--element-length",
        "1e308",
        "--element-mass",
        "0.001",
        "--stiffness",
        "0.5",
    ]);
    // The element itself is out of its range before any product is formed.
    assert!(e.contains("element_length_m: got 1e308") && e.contains("[0.0001, 1]"), "{e}");
    // Each element sane, together absurd: 2 km of tube.
    let e =
        rejected(&["chain", "--elements", "2000", "--element-length", "1", "--element-mass", "1", "--stiffness", "1"]);
    assert!(e.contains("tube length") && e.contains("1000"), "{e}");
}

/// A scratch file under the system's temporary directory, unique to this test run.
fn scratch(name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let path = std::env::temp_dir().join(format!("leech-harden-{}-{name}", std::process::id()));
    std::fs::write(&path, bytes).unwrap();
    path
}

/// The built-in robot without its tubes' whole length, so that 100 m tubes
/// are valid input (the built-in's are 0.40 m long: a longer range is bad
/// input), as a robot file's path.
fn unbounded_tubes() -> String {
    let text: Vec<&str> = leech::robot::BUILTIN_TOML.lines().filter(|l| !l.starts_with("full_length_m")).collect();
    scratch("no-full-length.toml", text.join("\n").as_bytes()).to_str().unwrap().to_owned()
}

/// No run of more than 17 digits (a shortest round-trip text at most):
/// `1e300`, not 300 digits.
fn no_long_numbers(e: &str) {
    let longest = e.split(|c: char| !c.is_ascii_digit()).map(str::len).max().unwrap_or(0);
    assert!(longest <= 17, "a {longest}-digit number: {e}");
}

#[test]
fn huge_and_tiny_numbers_print_in_scientific_notation() {
    let e = rejected(&["shape", "--lengths", "0.3,0.2", "--time-limit", "1e300"]);
    assert!(e.contains("--time-limit") && e.contains("1e300"), "{e}");
    no_long_numbers(&e);
    let e = rejected(&["shape", "--lengths", "0.3,0.2", "--base-angle", "1e300"]);
    assert!(e.contains("1e300"), "{e}");
    no_long_numbers(&e);
    let e =
        rejected(&["chain", "--elements", "1", "--element-length", "1e308", "--element-mass", "1", "--stiffness", "1"]);
    assert!(e.contains("1e308"), "{e}");
    no_long_numbers(&e);
    for (key, value) in [("element_length_m", "1e308"), ("element_length_m", "1e-300"), ("element_mass_kg", "-1e300")] {
        let path = scratch(&format!("{key}.toml"), builtin_with(key, value).as_bytes());
        let e = rejected(&["shape", "--lengths", "0.3,0.2", "--robot", path.to_str().unwrap()]);
        std::fs::remove_file(&path).ok();
        no_long_numbers(&e);
    }
}

/// The built-in robot file with the line of `key` set to `value`.
fn builtin_with(key: &str, value: &str) -> String {
    let robot = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../leech/robots/leech.toml")).unwrap();
    let lines =
        robot.lines().map(|l| if l.starts_with(&format!("{key} ")) { format!("{key} = {value}") } else { l.into() });
    lines.collect::<Vec<String>>().join("\n")
}

/// A driving unit whose outline does not hold its clamps, or leaves the rear cup's face inside
/// it: exit 2, one line naming the key, its value and what is allowed.
#[test]
fn a_driving_unit_outline_that_misses_its_clamps_is_bad_input() {
    for (key, value, allowed) in [
        ("back_m", "0.08", "at most length_m"),
        ("top_m", "0.001", "tube's radius"),
        ("height_m", "0.06", "on or beyond"),
    ] {
        let path = scratch(&format!("unit-{key}.toml"), builtin_with(key, value).as_bytes());
        let e = rejected(&["shape", "--lengths", "0.3,0.2", "--robot", path.to_str().unwrap()]);
        std::fs::remove_file(&path).ok();
        assert!(e.contains(&format!("driving_unit.{key}")) && e.contains(value) && e.contains(allowed), "{e}");
    }
}

/// A message quoting a file's bytes: short, one line, nothing a terminal would act on.
fn clean(e: &str) {
    assert!(e.chars().count() < 600, "{} characters: {e}", e.chars().count());
    assert!(!e.trim_end().chars().any(|c| c.is_control() || c == '\u{feff}'), "{e:?}");
    assert!(!e.contains("[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[["), "{e}");
}

#[test]
fn messages_quote_short_escaped_excerpts_of_a_file() {
    let brackets = "[".repeat(10_000);
    let robots: [Vec<u8>; 4] = [
        format!("name=\"x\u{1}\0\u{feff}{brackets}\n").into_bytes(),
        format!("\u{feff}{brackets}{}= 1\n", "\u{7}".repeat(100)).into_bytes(),
        format!("[tube]\n{}\u{0} = 1\n", "k".repeat(5000)).into_bytes(),
        format!("name = {brackets}").into_bytes(),
    ];
    for (i, bytes) in robots.iter().enumerate() {
        let path = scratch(&format!("robot{i}.toml"), bytes);
        let e = rejected(&["shape", "--lengths", "0.3,0.2", "--robot", path.to_str().unwrap()]);
        std::fs::remove_file(&path).ok();
        clean(&e);
    }
    let out = std::env::temp_dir().join(format!("leech-harden-{}-fitted.toml", std::process::id()));
    let sag = format!("tube_length_m,base_angle_deg,x_m,y_m\n0.3,0,{}\u{0}\u{feff}{},0\n", "9".repeat(400), brackets);
    let path = scratch("sag.csv", sag.as_bytes());
    let e = rejected(&["calibrate", "--sag", path.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    clean(&e);
    let header = format!("{}\u{1b}[31m,tube_length_m,base_angle_deg,x_m,y_m\n", "q".repeat(3000));
    let path = scratch("header.csv", header.as_bytes());
    let e = rejected(&["calibrate", "--sag", path.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    clean(&e);
    assert!(e.contains("...") && e.contains("unknown column"), "{e}");
}

#[test]
fn a_huge_shape_parameter_prints_short() {
    let out = super::leech().args(["shape", "--lengths", "0.3,0.2", "--gravity", "1e-300"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(text.contains("Pi = 5e304"), "{text}");
    no_long_numbers(&text);
}

#[test]
fn leech_alone_says_a_subcommand_is_needed() {
    let e = rejected(&[]);
    assert!(e.contains("subcommand is needed") && e.contains("shape") && e.contains("chain"), "{e}");
}

#[test]
fn a_non_string_discretization_lists_the_allowed_values() {
    let robot = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../leech/robots/leech.toml")).unwrap();
    for value in ["3", "\"fine\"", "{ a = 1 }"] {
        let text = robot.replace("discretization = \"paper\"", &format!("discretization = {value}"));
        let path = scratch("discretization.toml", text.as_bytes());
        let e = rejected(&["shape", "--lengths", "0.3,0.2", "--robot", path.to_str().unwrap()]);
        std::fs::remove_file(&path).ok();
        assert!(e.contains("discretization") && e.contains("paper") && e.contains("midpoint"), "{value}: {e}");
    }
}

/// Runs `leech` killed after 10 s (a hang fails the test, never a slow
/// machine's timing): its exit code (`None` when killed) and standard error.
fn bounded(args: &[&str]) -> (Option<i32>, String) {
    let out = super::leech().args(args).timeout(std::time::Duration::from_secs(10)).output().unwrap();
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// Exit 2 within the bound, one clean line naming `field`; the line.
fn refused(args: &[&str], field: &str) -> String {
    let (code, e) = bounded(args);
    assert_eq!(code, Some(2), "{args:?}: {e}");
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(e.contains(field), "{field} in {e}");
    clean(&e);
    e
}

/// A scratch path (not created) under the system's temporary directory.
fn scratch_path(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("leech-harden-{}-{name}", std::process::id()))
}

#[cfg(target_os = "linux")]
#[test]
fn device_files_are_read_within_their_caps() {
    let out = scratch_path("dev-fitted.toml");
    let out = out.to_str().unwrap();
    let e = refused(&["robot", "--robot", "/dev/zero"], "--robot");
    assert!(e.contains("got '/dev/zero', which is larger than 1 MiB; expected a robot file of at most 1 MiB"), "{e}");
    let e = refused(&["calibrate", "--sag", "/dev/full", "--out", out], "--sag");
    assert!(e.contains("expected a measurement file of at most 16 MiB"), "{e}");
    refused(&["calibrate", "--sag", "/dev/urandom", "--out", out], "--sag");
    refused(&["compare", "--shapes", "/dev/zero"], "--shapes");
    // /dev/null is an empty file: the robot file's parser says what is missing.
    let e = refused(&["robot", "--robot", "/dev/null"], "name");
    assert!(e.contains("missing field"), "{e}");
}

#[test]
fn directories_missing_files_and_fifos_are_refused_at_once() {
    let dir = std::env::temp_dir();
    let e = refused(&["robot", "--robot", dir.to_str().unwrap()], "--robot");
    assert!(e.contains("is a directory"), "{e}");
    let e = refused(&["compare", "--shapes", "/nonexistent-leech-shapes.csv"], "--shapes");
    assert!(e.contains("does not exist"), "{e}");
    let e = refused(&["shape", "--lengths", "0.3,0.2", "--scene", dir.to_str().unwrap()], "--scene");
    assert!(e.contains("is a directory"), "{e}");
    // Opening a FIFO without a writer would wait forever.
    let fifo = scratch_path("fifo.toml");
    if std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
        let e = refused(&["robot", "--robot", fifo.to_str().unwrap()], "--robot");
        std::fs::remove_file(&fifo).ok();
        assert!(e.contains("named pipe"), "{e}");
    }
}

#[test]
fn text_files_with_a_bom_are_read_and_bad_bytes_located() {
    let robot = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../leech/robots/leech.toml")).unwrap();
    let bom = scratch("bom.toml", &[b"\xef\xbb\xbf".as_slice(), &robot].concat());
    let (code, e) = bounded(&["robot", "--robot", bom.to_str().unwrap()]);
    std::fs::remove_file(&bom).ok();
    assert_eq!(code, Some(0), "{e}");
    let bad = scratch("latin1.toml", b"name = \"caf\xe9\"\n");
    let e = refused(&["robot", "--robot", bad.to_str().unwrap()], "--robot");
    std::fs::remove_file(&bad).ok();
    assert!(e.contains("not UTF-8") && e.contains("byte offset 11"), "{e}");
    let nul = scratch("nul.csv", b"tube_length_m,base_angle_deg,x_m,y_m\n0.3,0,0\0,0\n");
    let e = refused(&["compare", "--shapes", nul.to_str().unwrap()], "--shapes");
    std::fs::remove_file(&nul).ok();
    assert!(e.contains("NUL byte at byte offset 44"), "{e}");
}

#[test]
fn output_paths_are_checked_before_the_work() {
    let dir = std::env::temp_dir();
    let dir = dir.to_str().unwrap();
    let e = refused(&["shape", "--lengths", "0.3,0.2", "--png", dir], "--png");
    assert!(e.contains(".png"), "{e}");
    let e = refused(&["shape", "--lengths", "0.3,0.2", "--png", "/dev/full"], "--png");
    assert!(!e.contains("ImageError"), "{e}");
    let e = refused(&["shape", "--lengths", "0.3,0.2", "--png", &format!("{dir}/x.svg")], "--png");
    assert!(e.contains("expected a name ending in .png"), "{e}");
    let e = refused(&["shape", "--lengths", "0.3,0.2", "--svg", "/nonexistent-leech-dir/x.svg"], "--svg");
    assert!(e.contains("does not exist"), "{e}");
    // The unwritable path is found before the sweep.
    let e = refused(&["workspace", "--out", "/nonexistent-leech-dir/w.csv"], "--out");
    assert!(e.contains("/nonexistent-leech-dir"), "{e}");
    refused(&["workspace", "--out", dir], "--out");
    refused(&["simulate", "--lengths", "0.3,0.2", "--csv", dir], "--csv");
    // A command refused for its input leaves an existing output file as it was.
    let kept = scratch("kept.toml", b"old");
    let sag = scratch("empty-sag.csv", b"tube_length_m,base_angle_deg,x_m,y_m\n");
    refused(&["calibrate", "--sag", sag.to_str().unwrap(), "--out", kept.to_str().unwrap()], "measured points");
    assert_eq!(std::fs::read(&kept).unwrap(), b"old");
    std::fs::remove_file(&kept).ok();
    std::fs::remove_file(&sag).ok();
}

#[cfg(target_os = "linux")]
#[test]
fn a_failed_picture_write_is_one_line_and_exit_1() {
    for (flag, name) in [("--svg", "full.svg"), ("--png", "full.png")] {
        let link = scratch_path(name);
        std::fs::remove_file(&link).ok();
        std::os::unix::fs::symlink("/dev/full", &link).unwrap();
        let (code, e) = bounded(&["shape", "--lengths", "0.3,0.2", flag, link.to_str().unwrap()]);
        std::fs::remove_file(&link).ok();
        assert_eq!(code, Some(1), "{e}");
        assert_eq!(e.trim_end().lines().count(), 1, "{e}");
        assert!(e.contains("No space left on device") && !e.contains("Error("), "{e}");
    }
}

#[test]
fn compare_caps_its_shapes_and_refuses_too_short_tubes() {
    let mut many = String::from("shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m\n");
    for i in 0..100_000 {
        many.push_str(&format!("s{i},0.3,0.3,0,a,0.1,0\n"));
    }
    let path = scratch("many.csv", many.as_bytes());
    let e = refused(&["compare", "--shapes", path.to_str().unwrap()], "at most 1000 shapes");
    std::fs::remove_file(&path).ok();
    assert!(e.contains("many.csv"), "{e}");
    let short = scratch("short.csv", b"shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m\ns,0.01,0.01,0,a,0.005,0\n");
    let e = refused(&["compare", "--shapes", short.to_str().unwrap()], "shape 's' (la_m, lb_m)");
    std::fs::remove_file(&short).ok();
    assert!(e.contains("0.01") && e.contains("at least 4 elements"), "{e}");
}

#[test]
fn a_plan_with_too_many_steps_is_refused() {
    let step = r#"{"phase":"push","lengths_m":[0.2,0.2]}"#;
    let plan = format!(r#"{{"status":"reached","steps":[{}]}}"#, vec![step; 10_001].join(","));
    let path = scratch("plan.json", plan.as_bytes());
    let e = refused(&["drive", "--port", "/nonexistent-leech-port", "run", path.to_str().unwrap()], "steps");
    std::fs::remove_file(&path).ok();
    assert!(e.contains("10001") && e.contains("1 to 10000"), "{e}");
}

/// Runs a job that cannot finish within `--time-limit 1`, killed (and the
/// test failed) if it outlives a generous process timeout; returns stderr,
/// checking exit code 3 and one line.
fn stopped(args: &[&str]) -> String {
    let out = super::leech()
        .args(args)
        .args(["--time-limit", "1"])
        .timeout(std::time::Duration::from_secs(60))
        .output()
        .unwrap();
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(out.status.code(), Some(3), "{args:?} should exit 3 (killed if None): {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains("time limit of 1 s reached after") && err.contains("--time-limit"), "{err}");
    err
}

#[test]
fn a_workspace_far_too_fine_stops_at_its_time_limit_and_writes_no_csv() {
    let csv = std::env::temp_dir().join(format!("leech-harden-{}-fine.csv", std::process::id()));
    let out = csv.to_str().unwrap();
    let e = stopped(&["workspace", "--robot", &unbounded_tubes(), "--lengths-range", "0.05:100:0.05", "--out", out]);
    assert!(e.contains("solves") && e.contains("no CSV written"), "{e}");
    assert!(!csv.exists(), "a partial CSV was written");
}

#[test]
fn a_workspace_of_absurd_shape_parameters_stops_at_its_time_limit() {
    let csv = std::env::temp_dir().join(format!("leech-harden-{}-soft.csv", std::process::id()));
    let e = stopped(&["workspace", "--shape-parameter", "8.2e-06,1.5e-11,5.8e13", "--out", csv.to_str().unwrap()]);
    assert!(e.contains("workspace stopped"), "{e}");
    assert!(!csv.exists(), "a partial CSV was written");
}

#[test]
fn reach_over_a_huge_range_stops_at_its_time_limit() {
    let robot = unbounded_tubes();
    let e = stopped(&["reach", "--robot", &robot, "--target", "1,1", "--lengths-range", "0.05:100:5"]);
    assert!(e.contains("reach stopped") && e.contains("map points"), "{e}");
    let e = rejected(&["reach", "--target", "1,1", "--lengths-range", "0.05:100:5"]);
    assert!(e.contains("lengths range max: got 100") && e.contains("tube.full_length_m = 0.4 m"), "{e}");
}

#[test]
fn shape_repeat_stops_at_its_time_limit() {
    // Unequal tubes: equal ones solve so fast that 100 000 of them (the
    // most --repeat takes) came within 2 % of the limit on a quiet machine.
    let e = stopped(&["shape", "--lengths", "0.3,0.28", "--repeat", "100000"]);
    assert!(e.contains("repeats"), "{e}");
}

#[test]
fn time_limits_are_checked() {
    for bad in ["0", "-1", "inf", "NaN", "1e9"] {
        let e = rejected(&["reach", "--target", "0.1,0.1", "--time-limit", bad]);
        assert!(e.contains("--time-limit (s)") && e.contains("86400"), "{e}");
    }
}

#[test]
fn too_many_workspace_shape_parameters_are_refused_naming_the_cap() {
    let many = vec!["100"; 17].join(",");
    let robot = unbounded_tubes();
    let e = rejected(&[
        "workspace",
        "--robot",
        &robot,
        "--lengths-range",
        "0.05:100:0.05",
        "--shape-parameter",
        &many,
        "--out",
        "x.csv",
    ]);
    assert!(e.contains("shape parameters") && e.contains("8008002 points"), "{e}");
}

/// The lengths `reach` answers with reproduce its endpoint through `shape`.
#[test]
fn reach_answers_with_lengths_shape_reproduces() {
    let answer = super::json_of(&["reach", "--target", "0.19326,0.30155"]);
    let l = &answer["lengths_m"];
    let lengths = format!("{},{}", l[0], l[1]);
    let shape = super::json_of(&["shape", "--lengths", &lengths]);
    for k in 0..2 {
        let (a, b) = (answer["endpoint_m"][k].as_f64().unwrap(), shape["endpoint_m"][k].as_f64().unwrap());
        assert!((a - b).abs() < 1e-6, "{answer} against {shape}");
    }
}

/// A simulation whose step is far too long for its scheme: values that
/// overflow are stopped where they do, and the one line says when, in
/// which iteration, what failed and the residual reached (not a mass
/// matrix that lost definiteness at some link, nor a NaN).
#[test]
fn a_diverging_simulation_says_what_went_non_finite_and_when() {
    for integrator in ["midpoint", "explicit"] {
        let args =
            ["simulate", "--lengths", "0.3,0.2", "--integrator", integrator, "--dt", "0.005", "--duration", "0.5"];
        let out = super::leech().args(args).timeout(std::time::Duration::from_secs(120)).output().unwrap();
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(out.status.code(), Some(3), "{integrator}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
        for part in ["simulation failed", "at t = ", "iteration", "residual", "--dt"] {
            assert!(err.contains(part), "{integrator}: no {part:?} in {err}");
        }
        // The midpoint's iteration diverges and overflows within the step;
        // RK4 lands far off the constraints, which the projection reports.
        let what = if integrator == "midpoint" { "non-finite" } else { "projection" };
        assert!(err.contains(what) && !err.contains("NaN"), "{integrator}: {err}");
        assert!(!err.contains("mass matrix"), "{err}");
    }
}
