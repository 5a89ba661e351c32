//! Fitting k (and m) to synthetic measurements with known truth.

use leech::budget::Deadline;
use leech::calibration::{calibrate, compare, read_sag, read_shapes, synthetic, CalibrationError, Fit, SagTube};
use leech::prelude::*;

const K: f64 = 0.42;
const M: f64 = 0.0012;
const LENGTHS: [f64; 5] = [0.10, 0.15, 0.20, 0.25, 0.30];

fn truth() -> Robot {
    let mut r = Robot::builtin();
    r.tube.joint_stiffness_nm_per_rad = K;
    r.tube.element_mass_kg = M;
    r
}

#[test]
fn recovers_stiffness_and_mass_for_twenty_seeds() {
    let truth = truth();
    // Stiffness only: the starting robot has the true mass.
    let mut start_k = Robot::builtin();
    start_k.tube.element_mass_kg = M;
    let start_both = Robot::builtin();
    let (mut covered_k, mut covered_both) = (0, 0);
    for seed in 0..20 {
        let sag = synthetic::sag(&truth, &LENGTHS, 0.0, 0.02, 0.0005, seed);
        let fit = calibrate(&start_k, &sag, &[], Fit::Stiffness, &Deadline::none()).unwrap();
        let error = fit.stiffness_nm_per_rad - K;
        assert!(error.abs() < 0.02 * K, "seed {seed}: k = {}", fit.stiffness_nm_per_rad);
        assert!((fit.rms_residual_mm - 0.5).abs() < 0.2, "seed {seed}: rms {} mm", fit.rms_residual_mm);
        covered_k += usize::from(error.abs() <= 2.0 * fit.stiffness_std_error_nm_per_rad);

        let shapes = synthetic::shapes(&truth, &[[0.2, 0.17], [0.3, 0.24], [0.25, 0.25]], 90.0, 0.02, 0.0005, seed);
        let both = calibrate(&start_both, &sag, &shapes, Fit::StiffnessAndMass, &Deadline::none()).unwrap();
        assert!((both.stiffness_nm_per_rad - K).abs() < 0.02 * K, "seed {seed}: k = {}", both.stiffness_nm_per_rad);
        assert!((both.element_mass_kg - M).abs() < 0.05 * M, "seed {seed}: m = {}", both.element_mass_kg);
        let se_m = both.element_mass_std_error_kg.unwrap();
        covered_both += usize::from(
            (both.stiffness_nm_per_rad - K).abs() <= 2.0 * both.stiffness_std_error_nm_per_rad
                && (both.element_mass_kg - M).abs() <= 2.0 * se_m,
        );
    }
    // Two standard errors cover the truth about 95 % of the time.
    assert!(covered_k >= 16, "k covered {covered_k} of 20");
    assert!(covered_both >= 15, "k and m covered {covered_both} of 20");
}

#[test]
fn point_order_and_tip_only_data_do_not_matter() {
    let truth = truth();
    let mut start = Robot::builtin();
    start.tube.element_mass_kg = M;
    let sag = synthetic::sag(&truth, &LENGTHS, 0.0, 0.02, 0.0005, 3);
    let fit = calibrate(&start, &sag, &[], Fit::Stiffness, &Deadline::none()).unwrap();
    let mut shuffled: Vec<SagTube> = sag.iter().rev().cloned().collect();
    for (i, tube) in shuffled.iter_mut().enumerate() {
        tube.points.rotate_left(i + 1);
        tube.points.reverse();
    }
    let again = calibrate(&start, &shuffled, &[], Fit::Stiffness, &Deadline::none()).unwrap();
    assert!((fit.stiffness_nm_per_rad - again.stiffness_nm_per_rad).abs() < 1e-9 * K);
    // The same tubes measured at their tips only.
    let tips: Vec<SagTube> =
        sag.iter().map(|t| SagTube { points: vec![*t.points.last().unwrap()], ..t.clone() }).collect();
    let exact = synthetic::sag(&truth, &LENGTHS, 0.0, 0.001, 0.0, 0);
    let tips_exact: Vec<SagTube> =
        exact.iter().map(|t| SagTube { points: vec![*t.points.last().unwrap()], ..t.clone() }).collect();
    let from_tips = calibrate(&start, &tips_exact, &[], Fit::Stiffness, &Deadline::none()).unwrap();
    assert!((from_tips.stiffness_nm_per_rad - K).abs() < 1e-4 * K, "{}", from_tips.stiffness_nm_per_rad);
    let noisy_tips = calibrate(&start, &tips, &[], Fit::Stiffness, &Deadline::none()).unwrap();
    assert!((noisy_tips.stiffness_nm_per_rad - K).abs() < 0.05 * K);
}

#[test]
fn degenerate_data_is_an_error() {
    let robot = Robot::builtin();
    let one = vec![SagTube { length: 0.2, base_angle_deg: 0.0, tip_mass: 0.0, points: vec![[0.19, -0.02]] }];
    assert!(matches!(calibrate(&robot, &one, &[], Fit::Stiffness, &Deadline::none()), Err(CalibrationError::Input(_))));
    let clamp = vec![SagTube { length: 0.2, base_angle_deg: 0.0, tip_mass: 0.0, points: vec![[0.0, 0.0]; 5] }];
    let e = calibrate(&robot, &clamp, &[], Fit::Stiffness, &Deadline::none()).unwrap_err().to_string();
    assert!(e.contains("clamp"), "{e}");
    let short = vec![SagTube { length: 0.005, base_angle_deg: 0.0, tip_mass: 0.0, points: vec![[0.004, 0.0]; 3] }];
    let e = calibrate(&robot, &short, &[], Fit::Stiffness, &Deadline::none()).unwrap_err().to_string();
    assert!(e.contains("0.005") && e.contains("one element"), "{e}");
    let sag = synthetic::sag(&truth(), &LENGTHS, 0.0, 0.02, 0.0005, 1);
    assert_eq!(
        calibrate(&robot, &sag, &[], Fit::StiffnessAndMass, &Deadline::none()),
        Err(CalibrationError::MassNotIdentifiable)
    );
}

#[test]
fn malformed_files_name_row_and_column() {
    let e = read_sag("tube_length_m,base_angle_deg,x_m,y_m\n0.2,0,0.1,-0.01\n0.2,0,nan,-0.02\n", "sag.csv")
        .unwrap_err()
        .to_string();
    assert!(e.contains("sag.csv row 3") && e.contains("x_m") && e.contains("nan"), "{e}");
    let e = read_sag("tube_length_m,base_angle_deg,x_m,y_m\n0.2,0,abc,1\n", "s.csv").unwrap_err().to_string();
    assert!(e.contains("row 2") && e.contains("abc"), "{e}");
    let e = read_sag("tube_length_m,angle,x_m,y_m\n", "s.csv").unwrap_err().to_string();
    assert!(e.contains("angle"), "{e}");
    let e = read_sag("tube_length_m,base_angle_deg,x_m\n", "s.csv").unwrap_err().to_string();
    assert!(e.contains("y_m"), "{e}");
    let e = read_shapes("shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m\ns,0.2,0.2,90,c,0,0.1\n", "b.csv")
        .unwrap_err()
        .to_string();
    assert!(e.contains("row 2") && e.contains("chain"), "{e}");
    let e = read_shapes(
        "shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m\ns,0.2,0.2,90,a,0,0.1\ns,0.2,0.3,90,a,0,0.1\n",
        "b.csv",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("row 3"), "{e}");
    // Comments are allowed.
    let ok = read_sag("# synthetic\ntube_length_m,base_angle_deg,x_m,y_m\n0.2,0,0.1,-0.01\n", "c.csv").unwrap();
    assert_eq!(ok[0].points.len(), 1);
}

/// The paper's Fig. 7 claim, made quantitative: on bodies made by the
/// two-chain model, that model fits to the noise and constant curvature does
/// not when the tubes are long.
#[test]
fn comparison_favours_the_model_that_made_the_data() {
    let truth = truth();
    let shapes = synthetic::shapes(&truth, &[[0.1, 0.09], [0.3, 0.24]], 90.0, 0.02, 0.0005, 2);
    let rows = compare(&truth, &shapes, &Deadline::none()).unwrap();
    for r in &rows {
        assert!(r.two_chain.rms_mm < 1.0, "{r:?}");
    }
    assert!(rows[1].constant_curvature.rms_mm > 10.0 * rows[1].two_chain.rms_mm);
}

#[test]
fn rows_group_by_key_and_files_are_capped() {
    // Interleaved rows of two tubes (one at -0 deg, the same as 0) and of two shapes.
    let sag = "tube_length_m,base_angle_deg,x_m,y_m\n0.2,0,0.1,0\n0.3,0,0.1,0\n0.2,-0,0.2,0\n0.3,0,0.2,0\n";
    let tubes = read_sag(sag, "s.csv").unwrap();
    assert_eq!(tubes.iter().map(|t| (t.length, t.points.len())).collect::<Vec<_>>(), [(0.2, 2), (0.3, 2)]);
    let header = "shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m\n";
    let shapes = format!("{header}p,0.3,0.2,0,a,0,0.1\nq,0.3,0.3,0,b,0,0.1\np,0.3,0.2,0,b,0.03,0.1\n");
    let shapes = read_shapes(&shapes, "b.csv").unwrap();
    assert_eq!(shapes.len(), 2);
    assert_eq!((shapes[0].points_a.len(), shapes[0].points_b.len()), (1, 1));
    let many = |n: usize| {
        let mut text = header.to_string();
        (0..n).for_each(|i| text.push_str(&format!("s{i},0.3,0.3,0,a,0.1,0\n")));
        read_shapes(&text, "many.csv").map(|s| s.len())
    };
    assert_eq!(many(leech::calibration::MAX_SHAPES), Ok(leech::calibration::MAX_SHAPES));
    let e = many(leech::calibration::MAX_SHAPES + 1).unwrap_err().to_string();
    assert!(e.contains("many.csv") && e.contains("at most 1000 shapes"), "{e}");
    let rows = format!("{header}{}", "s,0.3,0.3,0,a,0.1,0\n".repeat(leech::calibration::MAX_ROWS + 1));
    let e = read_shapes(&rows, "rows.csv").unwrap_err().to_string();
    assert!(e.contains("at most 100000 rows"), "{e}");
}

#[test]
fn a_body_too_short_for_its_plate_is_bad_input() {
    let text = "shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m\nstub\u{1},0.01,0.01,0,a,0.005,0\n";
    let shapes = read_shapes(text, "short.csv").unwrap();
    match compare(&Robot::builtin(), &shapes, &Deadline::none()) {
        Err(CalibrationError::Input(e)) => {
            let e = e.to_string();
            assert!(e.starts_with("shape 'stub\\u{1}' (la_m, lb_m): got 0.01, 0.01"), "{e}");
        }
        other => panic!("expected bad input, got {other:?}"),
    }
}
