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
    assert!(e.contains("tube length") && e.contains("element_length_m") && e.contains("1000"), "{e}");
    // Finite but absurd: 10 km of tube.
    let e =
        rejected(&["chain", "--elements", "10", "--element-length", "1000", "--element-mass", "1", "--stiffness", "1"]);
    assert!(e.contains("tube length"), "{e}");
}

/// A scratch file under the system's temporary directory, unique to this test run.
fn scratch(name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let path = std::env::temp_dir().join(format!("leech-harden-{}-{name}", std::process::id()));
    std::fs::write(&path, bytes).unwrap();
    path
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
    let robot = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../leech/robots/leech.toml")).unwrap();
    for (key, value) in [("element_length_m", "1e308"), ("element_length_m", "1e-300"), ("element_mass_kg", "-1e300")] {
        let text: String = robot
            .lines()
            .map(|l| if l.starts_with(&format!("{key} ")) { format!("{key} = {value}") } else { l.to_string() })
            .collect::<Vec<_>>()
            .join("\n");
        let path = scratch(&format!("{key}.toml"), text.as_bytes());
        let e = rejected(&["shape", "--lengths", "0.3,0.2", "--robot", path.to_str().unwrap()]);
        std::fs::remove_file(&path).ok();
        no_long_numbers(&e);
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
