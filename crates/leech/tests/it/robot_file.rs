//! Robot files: the built-in robot, continuum keys, and one-line errors.

use leech::prelude::*;
use leech::robot::BUILTIN_TOML;

#[test]
fn builtin_round_trips_through_toml() {
    let robot = Robot::builtin();
    assert!(robot.name.contains("estimated"));
    let again = Robot::from_toml_str(&robot.to_toml_string()).unwrap();
    assert_eq!(robot, again);
    assert!((robot.shape_parameter() - 0.5 / (0.001 * 9.81 * 0.01)).abs() < 1e-9);
}

fn with(replace: &str, by: &str) -> Result<Robot, InputError> {
    assert!(BUILTIN_TOML.contains(replace), "test edits a line that exists: {replace}");
    Robot::from_toml_str(&BUILTIN_TOML.replace(replace, by))
}

fn message(r: Result<Robot, InputError>) -> String {
    let e = r.expect_err("should be rejected").to_string();
    assert!(!e.contains('\n'), "one line: {e}");
    e
}

#[test]
fn bad_values_name_field_value_and_range() {
    let e = message(with("element_length_m = 0.01", "element_length_m = -0.01"));
    assert!(e.contains("tube.element_length_m") && e.contains("-0.01") && e.contains("> 0"), "{e}");
    let e = message(with("tip_spacing_m = 0.012", "tip_spacing_m = 0.0"));
    assert!(e.contains("body.tip_spacing_m") && e.contains("> 0"), "{e}");
    let e = message(with("gravity_m_per_s2 = 9.81", "gravity_m_per_s2 = nan"));
    assert!(e.contains("world.gravity_m_per_s2") && e.contains("NaN"), "{e}");
    let e = message(with("payload_kg = 0.021", "payload_kg = -1"));
    assert!(e.contains("body.payload_kg"), "{e}");
    let e = message(with("base_angle_deg = 90", "base_angle_deg = inf"));
    assert!(e.contains("world.base_angle_deg"), "{e}");
}

#[test]
fn malformed_or_unknown_keys_are_errors() {
    let e = message(with("payload_kg = 0.021", "payload_kg = 0.021\ncolour = \"red\""));
    assert!(e.contains("colour"), "{e}");
    let e = message(with("[world]", "[world"));
    assert!(e.starts_with("robot file"), "{e}");
    let e = message(with("discretization = \"paper\"", "discretization = \"spline\""));
    assert!(e.contains("spline"), "{e}");
    let e = message(with("element_mass_kg = 0.001", "element_mass_kg = 0.001\nmass_per_length_kg_per_m = 0.1"));
    assert!(e.contains("exactly one"), "{e}");
    let e = message(with("element_mass_kg = 0.001", ""));
    assert!(e.contains("missing"), "{e}");
}

#[test]
fn continuum_properties_give_element_properties() {
    let robot = with("joint_stiffness_nm_per_rad = 0.5", "bending_stiffness_nm2 = 0.005").unwrap();
    assert!((robot.tube.joint_stiffness_nm_per_rad - 0.5).abs() < 1e-12);
    assert!((robot.bending_stiffness() - 0.005).abs() < 1e-15);
}

#[test]
fn tube_lengths_are_checked() {
    let robot = Robot::builtin();
    for bad in [0.0, -0.1, 0.005, f64::NAN, f64::INFINITY, 1e6] {
        let e = robot.body(bad, 0.1).expect_err("rejected").to_string();
        assert!(e.contains("LA") && e.contains("tube length"), "{e}");
    }
    assert!(robot.body(0.01, 0.3).is_ok());
}
