//! Batch solves equal single solves, report bad entries one by one and
//! give the same results whole or in pieces.

use leech::batch::{solve_vec, BatchOptions, Outcome, Query, Status, CHUNK};
use leech::prelude::*;

const COLD: BatchOptions = BatchOptions { warm_step_m: 0.0 };

fn query<'a>(la: &'a [f64], lb: &'a [f64]) -> Query<'a> {
    Query { la_m: la, lb_m: lb, base_angle_deg: None }
}

/// Lengths scattered over the robot's range, far apart (no warm starts).
fn scattered(n: usize) -> (Vec<f64>, Vec<f64>) {
    let la = (0..n).map(|i| 0.06 + 0.23 * ((i * 37 % 101) as f64 / 100.0)).collect();
    let lb = (0..n).map(|i| 0.06 + 0.23 * ((i * 53 % 97) as f64 / 96.0)).collect();
    (la, lb)
}

/// A cold batch entry is the default cold solve of its body, bit for bit,
/// whatever the entries before it (here the same body twice).
#[test]
fn cold_entries_equal_single_solves() {
    let robot = Robot::builtin();
    let (mut la, mut lb) = scattered(12);
    la.push(la[11]);
    lb.push(lb[11]);
    let (out, failures) = solve_vec(&robot, &query(&la, &lb), &COLD).unwrap();
    assert!(failures.is_empty());
    for (i, o) in out.iter().enumerate() {
        let body = robot.body(la[i], lb[i]).unwrap();
        let eq = body.solve_in(&Solver::default(), &mut Scratch::for_system(&body)).unwrap();
        assert_eq!(o.status, Status::Converged);
        assert!(!o.warm && !o.snapped);
        assert_eq!(o.stable, eq.stable);
        assert_eq!(o.endpoint_m, body.endpoint(&eq.q));
        assert_eq!(o.endpoint_angle_rad, body.endpoint_angle(&eq.q));
    }
}

/// Base angles per entry: each entry is the robot turned to its angle.
#[test]
fn base_angles_per_entry() {
    let robot = Robot::builtin();
    let (la, lb) = (vec![0.2, 0.2, 0.25], vec![0.18, 0.18, 0.22]);
    let angles = [0.0, 90.0, 45.0];
    let q = Query { la_m: &la, lb_m: &lb, base_angle_deg: Some(&angles) };
    let (out, _) = solve_vec(&robot, &q, &BatchOptions::default()).unwrap();
    for i in 0..3 {
        let body = robot.with_base_angle(angles[i]).unwrap().body(la[i], lb[i]).unwrap();
        let eq = body.solve(&Solver::default()).unwrap();
        assert_eq!(out[i].endpoint_m, body.endpoint(&eq.q), "entry {i}");
        // Same lengths, another angle: no warm start across angles.
        assert!(!out[i].warm);
    }
}

/// NaN, out-of-range lengths and angles fail their own entries only.
#[test]
fn bad_entries_are_reported_one_by_one() {
    let robot = Robot::builtin();
    let la = [0.2, f64::NAN, 0.25, 1e3, 0.22];
    let lb = [0.18, 0.2, f64::INFINITY, 0.2, 0.2];
    let angles = [0.0, 0.0, 0.0, 0.0, 400.0];
    let q = Query { la_m: &la, lb_m: &lb, base_angle_deg: Some(&angles) };
    let (out, failures) = solve_vec(&robot, &q, &COLD).unwrap();
    let statuses: Vec<Status> = out.iter().map(|o| o.status).collect();
    assert_eq!(statuses, [Status::Converged, Status::Invalid, Status::Invalid, Status::Invalid, Status::Invalid]);
    assert_eq!(failures.iter().map(|f| f.index).collect::<Vec<_>>(), [1, 2, 3, 4]);
    assert!(failures[0].reason.contains("LA") && failures[0].reason.contains("NaN"), "{}", failures[0].reason);
    assert!(failures[3].reason.contains("base_angle_deg") && failures[3].reason.contains("400"));
    assert!(out[1].endpoint_m[0].is_nan() && !out[1].stable);
    let one = Query { la_m: &la[..1], lb_m: &lb[..1], base_angle_deg: Some(&angles[..1]) };
    let (alone, _) = solve_vec(&robot, &one, &COLD).unwrap();
    assert_eq!(alone[0], out[0]);
}

/// Arrays of different lengths are one input error naming the array.
#[test]
fn mismatched_arrays_name_the_field() {
    let robot = Robot::builtin();
    let e = solve_vec(&robot, &query(&[0.2, 0.2], &[0.2]), &COLD).unwrap_err();
    assert!(e.to_string().starts_with("lb_m: got 1 entries"), "{e}");
    let q = Query { la_m: &[0.2], lb_m: &[0.2], base_angle_deg: Some(&[]) };
    assert!(solve_vec(&robot, &q, &COLD).unwrap_err().to_string().starts_with("base_angle_deg"));
    let bad = BatchOptions { warm_step_m: f64::NAN };
    assert!(solve_vec(&robot, &query(&[], &[]), &bad).unwrap_err().to_string().starts_with("warm_step_m"));
}

#[test]
fn empty_batch_is_empty() {
    let (out, failures) = solve_vec(&Robot::builtin(), &query(&[], &[]), &BatchOptions::default()).unwrap();
    assert!(out.is_empty() && failures.is_empty());
}

/// A path of 1 mm steps: entries after each chunk's first are warm, and
/// land on the cold solve's equilibrium (no snap on this smooth path).
#[test]
fn warm_starts_follow_a_smooth_path() {
    let robot = Robot::builtin();
    let n = CHUNK + 40;
    let la: Vec<f64> = (0..n).map(|i| 0.08 + 0.2 * i as f64 / n as f64).collect();
    let lb: Vec<f64> = la.iter().map(|l| 0.9 * l).collect();
    let (out, _) = solve_vec(&robot, &query(&la, &lb), &BatchOptions::default()).unwrap();
    let (cold, _) = solve_vec(&robot, &query(&la, &lb), &COLD).unwrap();
    for (i, (w, c)) in out.iter().zip(&cold).enumerate() {
        assert_eq!(w.warm, i % CHUNK != 0, "entry {i}");
        assert!(!w.snapped);
        assert!((w.endpoint_m[0] - c.endpoint_m[0]).abs() < 1e-9 && (w.endpoint_m[1] - c.endpoint_m[1]).abs() < 1e-9);
    }
    // A bad entry in the path: the next is warm-started from the one before it.
    let mut holed = la.clone();
    holed[5] = f64::NAN;
    let (out, _) = solve_vec(&robot, &query(&holed, &lb), &BatchOptions::default()).unwrap();
    assert!(out[6].warm && out[5].status == Status::Invalid);
}

/// Solved in pieces of whole chunks, a batch gives the results of the whole.
#[test]
fn pieces_of_whole_chunks_equal_the_whole() {
    let robot = Robot::builtin();
    let n = 2 * CHUNK + 17;
    let la: Vec<f64> = (0..n).map(|i| 0.1 + 0.0007 * (i % 300) as f64).collect();
    let lb: Vec<f64> = (0..n).map(|i| 0.1 + 0.0005 * (i % 200) as f64).collect();
    let options = BatchOptions::default();
    let (whole, _) = solve_vec(&robot, &query(&la, &lb), &options).unwrap();
    let mut pieces: Vec<Outcome> = Vec::new();
    for start in (0..n).step_by(CHUNK) {
        let end = (start + CHUNK).min(n);
        pieces.extend(solve_vec(&robot, &query(&la[start..end], &lb[start..end]), &options).unwrap().0);
    }
    assert_eq!(whole.len(), pieces.len());
    for (a, b) in whole.iter().zip(&pieces) {
        assert_eq!(a.endpoint_m.map(f64::to_bits), b.endpoint_m.map(f64::to_bits));
        assert_eq!((a.status, a.warm, a.stable), (b.status, b.warm, b.stable));
    }
}
