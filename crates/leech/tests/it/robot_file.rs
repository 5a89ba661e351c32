//! Robot files: the built-in robot, continuum keys, and one-line errors.

use leech::hold::{Hold, Pose};
use leech::prelude::*;
use leech::robot::{Cup, DrivingUnit, Limits, BUILTIN_TOML};
use leech::stance;

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
    assert!(e.contains("tube.element_length_m") && e.contains("-0.01") && e.contains("[0.0001, 1]"), "{e}");
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
    // No tube reaches farther than it is long: the built-in's are 0.40 m.
    assert!(robot.body(0.40, 0.40).is_ok());
    let e = robot.body(0.2, 0.41).expect_err("longer than the tube").to_string();
    assert!(e.contains("lengths[1] (LB)") && e.contains("0.41") && e.contains("tube.full_length_m = 0.4 m"), "{e}");
    // Without the key a tube is bounded by the links a chain may have.
    let mut unbounded = robot.clone();
    unbounded.tube.full_length_m = None;
    assert!(unbounded.body(0.2, 0.41).is_ok() && unbounded.body(0.2, 2.0).is_ok());
}

#[test]
fn builtin_weighs_the_papers_240_g_on_board_at_every_extension() {
    let robot = Robot::builtin();
    let rho = robot.mass_per_length();
    for lengths in [[0.05, 0.05, 0.05], [0.3, 0.2, 0.25], [0.4, 0.1, 0.4]] {
        let ahead = rho * lengths.iter().sum::<f64>();
        let total = robot.unit_mass_kg(lengths) + ahead + robot.body.payload_kg;
        assert!((total - 0.240).abs() < 1e-15, "{lengths:?}: {total} kg");
    }
    // What a held stance carries: the chains ahead of the clamps (chain B
    // two tubes), the payload and the unit with the tails.
    for [la, lb] in [[0.25, 0.20], [0.05, 0.30], [0.30, 0.12]] {
        let pose = Pose { point_m: [0.0, 0.0], angle_rad: std::f64::consts::FRAC_PI_2 };
        let held = stance::solve(&robot, [la, lb], Hold::Rear(pose), &Solver::default()).unwrap();
        let w = 0.240 * robot.world.gravity_m_per_s2;
        assert!((held.weight_n - w).abs() < 1e-12 * w, "{la}, {lb}: {} N", held.weight_n);
        assert!((robot.planar_unit_mass_kg(la, lb) - robot.unit_mass_kg([la, lb, lb])).abs() == 0.0);
    }
    // Without the tails the unit carries its own mass alone.
    let mut no_tails = robot.clone();
    no_tails.tube.full_length_m = None;
    assert_eq!(no_tails.unit_mass_kg([0.1, 0.2, 0.3]), robot.driving_unit.mass_kg);
}

/// The built-in file's text from its first line up to (not including) `marker`.
fn builtin_before(marker: &str) -> &'static str {
    let end = BUILTIN_TOML.find(marker).expect("the marker is in the built-in file");
    &BUILTIN_TOML[..end]
}

#[test]
fn files_without_the_optional_keys_take_the_builtin_values() {
    let old = builtin_before("# The sections below are optional");
    assert!(!old.contains("[cup]") && !old.contains("[driving_unit]") && !old.contains("[limits]"));
    let line = old.lines().find(|l| l.starts_with("outer_diameter_m")).unwrap();
    let old = old.replace(&format!("{line}\n"), "");
    let robot = Robot::from_toml_str(&old).unwrap();
    assert_eq!(robot, Robot::builtin());
    assert_eq!(robot.tube.outer_diameter_m, leech::robot::DEFAULT_TUBE_OUTER_DIAMETER_M);
    assert_eq!(robot.driving_unit, DrivingUnit::default());
    assert_eq!(robot.cup, Cup::default());
    assert_eq!(robot.limits, Limits::default());
}

#[test]
fn builtin_states_the_documented_values() {
    let robot = Robot::builtin();
    assert_eq!(robot.tube.outer_diameter_m, 0.010);
    assert_eq!(robot.driving_unit.mass_kg, 0.099);
    assert_eq!(robot.tube.full_length_m, Some(0.40));
    // The unit's outline: 50 mm by 36 mm, chain A's clamp 35 mm from its back and 12 mm from its
    // top, the rear cup's face (b + rear_offset = 32 mm across) 8 mm beyond its bottom.
    let outline = robot.driving_unit.outline_m().unwrap();
    let expected = [[-0.035, -0.012], [0.015, -0.012], [0.015, 0.024], [-0.035, 0.024]];
    for (got, want) in outline.iter().flatten().zip(expected.iter().flatten()) {
        assert!((got - want).abs() < 1e-15, "{outline:?}");
    }
    assert_eq!(robot.driving_unit.centre_of_mass_m, None);
    let cup = &robot.cup;
    assert_eq!((cup.diameter_m, cup.min_safety_factor, cup.preload_m), (0.05, 1.5, 0.0));
    assert_eq!((cup.attach_distance_tolerance_m, cup.attach_angle_tolerance_deg), (0.002, 5.0));
    // One cup holds the paper's 1.7 kg on a vertical wall through friction.
    let shear_hold_kg = cup.friction_coefficient * cup.pull_off_force_n / 9.81;
    assert!((shear_hold_kg - 1.7).abs() < 0.01, "{shear_hold_kg}");
    assert_eq!((robot.limits.tube_length_min_m, robot.limits.tube_length_max_m), (0.05, 0.30));
}

#[test]
fn optional_sections_take_single_keys() {
    let base = builtin_before("[driving_unit]");
    let robot = Robot::from_toml_str(&format!("{base}[cup]\nfriction_coefficient = 0.8\n")).unwrap();
    assert_eq!(robot.cup, Cup { friction_coefficient: 0.8, ..Cup::default() });
    let robot = Robot::from_toml_str(&format!("{base}[limits]\ntube_length_max_m = 0.35\n")).unwrap();
    assert_eq!(robot.limits, Limits { tube_length_max_m: 0.35, ..Limits::default() });
    let e = message(Robot::from_toml_str(&format!("{base}[cup]\nsuction_n = 3\n")));
    assert!(e.contains("suction_n"), "{e}");
}

#[test]
fn bad_new_values_name_field_value_and_range() {
    for (line, bad, field, allowed) in [
        ("outer_diameter_m = 0.010 ", "outer_diameter_m = 0 ", "tube.outer_diameter_m", "[0.0001, 1]"),
        ("outer_diameter_m = 0.010 ", "outer_diameter_m = 1e308 ", "tube.outer_diameter_m", "[0.0001, 1]"),
        ("element_length_m = 0.01 ", "element_length_m = 1e308 ", "tube.element_length_m", "[0.0001, 1]"),
        ("element_mass_kg = 0.001 ", "element_mass_kg = 1e-320 ", "tube.element_mass_kg", "[1e-9, 1000]"),
        ("base_spacing_m = 0.017", "base_spacing_m = 1e308", "body.base_spacing_m", "at most 10"),
        ("mass_kg = 0.099 ", "mass_kg = -0.25 ", "driving_unit.mass_kg", ">= 0"),
        ("full_length_m = 0.40 ", "full_length_m = 0.2 ", "tube.full_length_m", "tube_length_max_m (0.3 m"),
        ("full_length_m = 0.40 ", "full_length_m = nan ", "tube.full_length_m", "at most 10000 elements"),
        ("\nlength_m = 0.05 ", "\nlength_m = 0 ", "driving_unit.length_m", "> 0 where height_m is"),
        ("\nlength_m = 0.05 ", "\nlength_m = 2 ", "driving_unit.length_m", "[0, 1]"),
        ("\nback_m = 0.035 ", "\nback_m = 0.06 ", "driving_unit.back_m", "at most length_m (0.05 m)"),
        ("\ntop_m = 0.012 ", "\ntop_m = 0.002 ", "driving_unit.top_m", "at least the tube's radius (0.005 m)"),
        ("\nheight_m = 0.036 ", "\nheight_m = 0.02 ", "driving_unit.height_m", "top_m + b + r = 0.034 m"),
        ("\nheight_m = 0.036 ", "\nheight_m = 0.05 ", "driving_unit.height_m", "rear_offset_m = 0.044 m"),
        ("rear_cup_behind_m = 0.0 ", "rear_cup_behind_m = -3 ", "driving_unit.rear_cup_behind_m", "[-1, 1]"),
        ("\ndiameter_m = 0.05 ", "\ndiameter_m = 0 ", "cup.diameter_m", "> 0"),
        ("pull_off_force_n = 33.4 ", "pull_off_force_n = nan ", "cup.pull_off_force_n", "> 0"),
        ("friction_coefficient = 0.5 ", "friction_coefficient = -0.5 ", "cup.friction_coefficient", "> 0"),
        ("min_safety_factor = 1.5 ", "min_safety_factor = 0.9 ", "cup.min_safety_factor", ">= 1"),
        ("attach_distance_tolerance_m = 0.002 ", "attach_distance_tolerance_m = 0 ", "cup.attach_distance", "> 0"),
        ("attach_angle_tolerance_deg = 5 ", "attach_angle_tolerance_deg = 95 ", "cup.attach_angle", "(0, 90]"),
        ("attach_angle_tolerance_deg = 5 ", "attach_angle_tolerance_deg = 0 ", "cup.attach_angle", "(0, 90]"),
        ("rear_offset_m = 0.015 ", "rear_offset_m = 0.004 ", "cup.rear_offset_m", "tube's radius (0.005"),
        ("front_offset_m = 0.016 ", "front_offset_m = -0.02 ", "cup.front_offset_m", ">= 0"),
        ("preload_m = 0.0 ", "preload_m = -0.001 ", "cup.preload_m", "[0, 0.01]"),
        ("preload_m = 0.0 ", "preload_m = 5 ", "cup.preload_m", "[0, 0.01]"),
        ("\ndiameter_m = 0.05 ", "\ndiameter_m = 2 ", "cup.diameter_m", "at most 1 m"),
        ("front_offset_m = 0.016 ", "front_offset_m = 3 ", "cup.front_offset_m", "at most 1 m"),
        (
            "attach_distance_tolerance_m = 0.002 ",
            "attach_distance_tolerance_m = 5 ",
            "cup.attach_distance",
            "at most 1 m",
        ),
        ("tube_length_min_m = 0.05 ", "tube_length_min_m = 0 ", "limits.tube_length_min_m", "at least two elements"),
        ("tube_length_min_m = 0.05 ", "tube_length_min_m = 0.01 ", "limits.tube_length_min_m", "0.02 m"),
        ("tube_length_max_m = 0.30", "tube_length_max_m = 1000", "limits.tube_length_max_m", "at most"),
        (
            "tube_length_max_m = 0.30",
            "tube_length_max_m = 0.05",
            "limits.tube_length_max_m",
            "> limits.tube_length_min_m",
        ),
    ] {
        let e = message(with(line, bad));
        let value = bad.split('=').nth(1).unwrap().trim();
        let value = if value == "nan" { "NaN" } else { value };
        assert!(e.contains(field) && e.contains(allowed) && e.contains(value), "{bad}: {e}");
    }
}

#[test]
fn cup_offsets_follow_the_tube_diameter() {
    // A thicker tube needs its cups further out: the same offsets are rejected.
    let e = message(with("outer_diameter_m = 0.010 ", "outer_diameter_m = 0.05 "));
    assert!(e.contains("cup.rear_offset_m") && e.contains("0.025"), "{e}");
    let robot = Robot::builtin();
    let e = robot.with_cup(Cup { rear_offset_m: 0.001, ..robot.cup.clone() }).unwrap_err().to_string();
    assert!(e.contains("cup.rear_offset_m"), "{e}");
    let wider = robot.with_cup(Cup { diameter_m: 0.08, ..robot.cup.clone() }).unwrap();
    assert_eq!(wider.cup.diameter_m, 0.08);
}

#[test]
fn scaling_scales_the_new_lengths_and_masses() {
    let base = Robot::builtin();
    let r = base.scaled(2.0).unwrap();
    assert_eq!(r.tube.outer_diameter_m, 2.0 * base.tube.outer_diameter_m);
    assert_eq!(r.driving_unit.mass_kg, 2.0 * base.driving_unit.mass_kg);
    let outline = |r: &Robot| r.driving_unit.outline_m().unwrap();
    for (scaled, unscaled) in outline(&r).iter().flatten().zip(outline(&base).iter().flatten()) {
        assert_eq!(*scaled, 2.0 * unscaled);
    }
    assert_eq!(r.cup.rear_offset_m, 2.0 * base.cup.rear_offset_m);
    assert_eq!(r.cup.pull_off_force_n, 2.0 * base.cup.pull_off_force_n);
    assert_eq!(r.cup.friction_coefficient, base.cup.friction_coefficient);
    assert_eq!(r.cup.attach_angle_tolerance_deg, base.cup.attach_angle_tolerance_deg);
    assert_eq!(r.limits.tube_length_max_m, 2.0 * base.limits.tube_length_max_m);
    // The tubes' whole length too: the scaled robot weighs s times as much
    // (mass per length kept, every length and the unit's mass times s).
    assert_eq!(r.tube.full_length_m, base.tube.full_length_m.map(|full| 2.0 * full));
    let on_board = |r: &Robot, l: f64| r.unit_mass_kg([l; 3]) + 3.0 * l * r.mass_per_length() + r.body.payload_kg;
    assert!((on_board(&r, 0.4) - 2.0 * on_board(&base, 0.2)).abs() < 1e-15);
}

#[test]
fn the_front_cups_free_joint_is_a_robot_file_option() {
    let robot = Robot::builtin();
    assert!(robot.cup.front_free_joint, "the paper's robot has it");
    let fixed = with("front_free_joint = true ", "front_free_joint = false ").unwrap();
    assert!(!fixed.cup.front_free_joint);
    let e = message(with("front_free_joint = true ", "front_free_joint = 1 "));
    assert!(e.contains("front_free_joint") && e.contains("bool"), "{e}");
    // Planar: held alike either way, and the pivot hold refused without the joint.
    let pose = Pose { point_m: [0.0, 0.4], angle_rad: 0.0 };
    let pivot = stance::solve(&robot, [0.2, 0.2], Hold::FrontPivot(pose), &Solver::default()).unwrap();
    let front = stance::solve(&fixed, [0.2, 0.2], Hold::Front(pose), &Solver::default()).unwrap();
    assert_eq!(pivot.equilibrium.q, front.equilibrium.q);
    let e = stance::solve(&fixed, [0.2, 0.2], Hold::FrontPivot(pose), &Solver::default()).unwrap_err().to_string();
    assert!(e.contains("hold") && e.contains("front pivot") && e.contains("cup.front_free_joint = false"), "{e}");
    // 3D: the swing needs the joint; so does the sideways maneuver.
    let body = leech::body3::Body3::from_robot(&fixed, [0.2; 3]).unwrap();
    let plate = leech::stance3::place3::plate_frame_from_angles(-std::f64::consts::FRAC_PI_2, 0.0, 0.0);
    let tip = [0.0, 0.4, 0.0];
    let hold = leech::hold::Hold3::FrontPivot(leech::hold::Pose3 { point_m: tip, frame: plate });
    let e = leech::stance3::solve(&fixed, &body, hold, &Solver::default()).unwrap_err().to_string();
    assert!(e.contains("cup.front_free_joint = false"), "{e}");
    let scenario = leech::stride::SidewaysScenario::builtin("sideways-wall").unwrap().unwrap();
    let options = leech::stride::SidewaysOptions::default();
    let plan = leech::stride::plan_sideways(&fixed, &scenario, &options, &Solver::default()).unwrap();
    assert_eq!(plan.status, leech::stride::Status::Impossible);
    assert!(plan.reason.unwrap().contains("front cup's free joint"));
}
