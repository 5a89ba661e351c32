//! Suction cups: the worked checks against the paper's hold, each failure
//! mode, monotonicity, and rejected input.

use leech::cup::{verdict, Cup, CupMode, CupVerdict};
use leech::prelude::*;
use proptest::prelude::*;

const G: f64 = 9.81;
/// The robot the paper hung from one cup (kg).
const HELD_KG: f64 = 1.7;

const WALL: [f64; 2] = [1.0, 0.0];
const FLOOR: [f64; 2] = [0.0, 1.0];
const CEILING: [f64; 2] = [0.0, -1.0];

fn cup() -> Cup {
    Robot::builtin().cup
}

/// The cup holding up a hanging weight `w` (N) with no moment: the surface
/// exerts `+w` along +y on the robot.
fn holding(w: f64, normal: [f64; 2]) -> CupVerdict {
    verdict(&cup(), [0.0, w], 0.0, normal).unwrap()
}

#[test]
fn the_papers_hold_on_a_vertical_wall_is_at_the_limit() {
    let v = holding(HELD_KG * G, WALL);
    assert_eq!((v.normal_pull_n, v.normal_push_n, v.peel_moment_nm), (0.0, 0.0, 0.0));
    assert!((v.shear_n - HELD_KG * G).abs() < 1e-12);
    assert!((v.safety_factor - 1.0).abs() < 0.01, "{}", v.safety_factor);
    assert_eq!(v.limited_by, Some(CupMode::Shear));
    assert!(v.holds && !v.meets_minimum);
    assert!(v.safety_factor_normal.is_infinite());
    // A little more and it slides.
    assert!(!holding(1.01 * HELD_KG * G, WALL).holds);
}

#[test]
fn a_floor_under_the_weight_only_presses_the_cup_on() {
    let v = holding(HELD_KG * G, FLOOR);
    assert_eq!((v.normal_pull_n, v.shear_n), (0.0, 0.0));
    assert!((v.normal_push_n - HELD_KG * G).abs() < 1e-12);
    assert!(v.safety_factor.is_infinite() && v.limited_by.is_none());
    assert!(v.holds && v.meets_minimum);
    // Even a hundred times the weight does not pull the cup off.
    assert!(holding(100.0 * HELD_KG * G, FLOOR).holds);
}

#[test]
fn a_ceiling_takes_the_whole_weight_as_pull_off() {
    let w = HELD_KG * G;
    let v = holding(w, CEILING);
    assert!((v.normal_pull_n - w).abs() < 1e-12 && v.shear_n.abs() < 1e-12);
    assert!((v.safety_factor - cup().pull_off_force_n / w).abs() < 1e-12);
    assert_eq!(v.limited_by, Some(CupMode::Normal));
    // Twice the shear hold: pull-off is the cup's strong direction.
    assert!((v.safety_factor - 1.0 / cup().friction_coefficient).abs() < 0.01);
    assert!(v.holds && v.meets_minimum);
}

#[test]
fn a_moment_peels_like_a_pull_of_two_moments_over_the_radius() {
    let c = cup();
    let radius = 0.5 * c.diameter_m;
    for moment in [0.3, -0.3] {
        let v = verdict(&c, [0.0, 0.0], moment, WALL).unwrap();
        assert_eq!(v.peel_moment_nm, 0.3);
        assert!((v.rim_pull_n - 2.0 * 0.3 / radius).abs() < 1e-12);
        assert!((v.safety_factor - c.pull_off_force_n * radius / 0.6).abs() < 1e-12);
        assert_eq!(v.limited_by, Some(CupMode::Normal));
    }
    // The moment that just opens the lip.
    let limit = c.pull_off_force_n * radius / 2.0;
    assert!(verdict(&c, [0.0, 0.0], 0.999 * limit, WALL).unwrap().holds);
    assert!(!verdict(&c, [0.0, 0.0], 1.001 * limit, WALL).unwrap().holds);
    // Pull and peel add at the rim.
    let v = verdict(&c, [-10.0, 0.0], 0.1, WALL).unwrap();
    assert!((v.rim_pull_n - (10.0 + 0.2 / radius)).abs() < 1e-12);
}

#[test]
fn a_push_adds_to_both_capacities() {
    let c = cup();
    let v = verdict(&c, [20.0, 12.0], 0.2, WALL).unwrap();
    assert_eq!((v.normal_push_n, v.shear_n, v.normal_pull_n), (20.0, 12.0, 0.0));
    assert!((v.capacity_normal_n - (c.pull_off_force_n + 20.0)).abs() < 1e-12);
    assert!((v.capacity_shear_n - c.friction_coefficient * (c.pull_off_force_n + 20.0)).abs() < 1e-12);
    let without_push = verdict(&c, [0.0, 12.0], 0.2, WALL).unwrap();
    assert!(v.safety_factor_shear > without_push.safety_factor_shear);
    assert!(v.safety_factor_normal > without_push.safety_factor_normal);
}

#[test]
fn the_normal_may_point_anywhere() {
    // The same hold turned by any angle gives the same verdict.
    let c = cup();
    let reference = verdict(&c, [-5.0, 7.0], 0.05, WALL).unwrap();
    for degrees in [30.0_f64, 135.0, -100.0] {
        let a = degrees.to_radians();
        let turn = |v: [f64; 2]| [a.cos() * v[0] - a.sin() * v[1], a.sin() * v[0] + a.cos() * v[1]];
        let v = verdict(&c, turn([-5.0, 7.0]), 0.05, turn(WALL)).unwrap();
        assert!((v.safety_factor - reference.safety_factor).abs() < 1e-9);
        assert!((v.shear_n - reference.shear_n).abs() < 1e-12);
    }
}

#[test]
fn bad_input_is_an_error() {
    let c = cup();
    let cases = [
        ([f64::NAN, 0.0], 0.0, WALL, "cup force"),
        ([0.0, f64::INFINITY], 0.0, WALL, "cup force"),
        ([0.0, 1.0], f64::NAN, WALL, "cup moment"),
        ([0.0, 1.0], 0.0, [f64::NAN, 0.0], "surface normal"),
        ([0.0, 1.0], 0.0, [0.0, 0.0], "surface normal"),
        ([0.0, 1.0], 0.0, [2.0, 0.0], "surface normal"),
    ];
    for (force, moment, normal, field) in cases {
        let e = verdict(&c, force, moment, normal).unwrap_err().to_string();
        assert!(e.contains(field) && !e.contains('\n'), "{e}");
    }
    let bad = Cup { friction_coefficient: f64::NAN, ..c };
    let e = verdict(&bad, [0.0, 1.0], 0.0, WALL).unwrap_err().to_string();
    assert!(e.contains("cup.friction_coefficient"), "{e}");
}

#[test]
fn a_scaled_robot_keeps_its_cups_safety_factors() {
    let base = Robot::builtin();
    let s = 3.0;
    let scaled = base.scaled(s).unwrap();
    // Forces grow as s, moments as s^2.
    let v = verdict(&base.cup, [-4.0, 6.0], 0.1, WALL).unwrap();
    let w = verdict(&scaled.cup, [-4.0 * s, 6.0 * s], 0.1 * s * s, WALL).unwrap();
    assert!((v.safety_factor - w.safety_factor).abs() < 1e-12 * v.safety_factor);
}

#[test]
fn verdicts_serialize_with_units_in_the_names() {
    let v = serde_json::to_value(holding(HELD_KG * G, WALL)).unwrap();
    assert_eq!(v["limited_by"], "shear");
    assert!(v["shear_n"].as_f64().unwrap() > 0.0 && v["peel_moment_nm"] == 0.0);
    // An unloaded mode's infinite factor is written as null.
    assert!(v["safety_factor_normal"].is_null());
}

proptest! {
    /// More of the same load never raises the safety factor.
    #[test]
    fn more_load_lowers_the_factor(
        fx in -50.0..50.0_f64, fy in -50.0..50.0_f64, m in -1.0..1.0_f64,
        normal_deg in -180.0..180.0_f64, scale in 1.0..10.0_f64,
    ) {
        let n = [normal_deg.to_radians().cos(), normal_deg.to_radians().sin()];
        let c = cup();
        let v = verdict(&c, [fx, fy], m, n).unwrap();
        let more = verdict(&c, [scale * fx, scale * fy], scale * m, n).unwrap();
        prop_assert!(more.safety_factor <= v.safety_factor * (1.0 + 1e-12));
        // So does a larger moment or a larger pull alone.
        let peeled = verdict(&c, [fx, fy], m + m.signum() * 0.5, n).unwrap();
        prop_assert!(peeled.safety_factor_normal <= v.safety_factor_normal * (1.0 + 1e-12));
        let pulled = verdict(&c, [fx - 10.0 * n[0], fy - 10.0 * n[1]], m, n).unwrap();
        prop_assert!(pulled.safety_factor_normal <= v.safety_factor_normal * (1.0 + 1e-12));
    }
}
