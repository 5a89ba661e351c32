//! The 3D body against independent references: SciPy (Newton on the KKT
//! system in joint rotation vectors, a minimum checked, cross-checked by
//! SLSQP), produced by `validation/body3d_references.py` and committed
//! under `tests/data/body3d.json`. Every link frame to 1e-7 rad, every
//! point to 1e-7 m.

use leech::body3::body3::angle_between;
use leech::body3::Body3;
use leech::prelude::*;
use serde_json::Value;

const TOLERANCE: f64 = 1e-7;

fn num(case: &Value, key: &str) -> f64 {
    case[key].as_f64().unwrap_or_else(|| panic!("{key} missing in {}", case["name"]))
}

#[test]
fn three_tube_bodies_match_scipy() {
    let path = format!("{}/tests/data/body3d.json", env!("CARGO_MANIFEST_DIR"));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let cases = v["cases"].as_array().unwrap();
    assert!(cases.len() >= 5, "at least five 3D references");
    for case in cases {
        let name = case["name"].as_str().unwrap();
        let mut robot = super::robot_from_case(case);
        robot.tube.torsion_stiffness_nm_per_rad = Some(num(case, "torsion_stiffness_nm_per_rad"));
        let l: Vec<f64> = case["lengths_m"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let body = Body3::from_robot(&robot, [l[0], l[1], l[2]]).unwrap();
        let eq = body.solve(&Solver::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(eq.stable && eq.events.is_empty(), "{name}: {:?}", eq.events);
        assert!(num(case, "max_residual") < 1e-11, "{name}: the reference converged");
        assert!(num(case, "slsqp_max_frame_diff") < 1e-5, "{name}: the two methods agree");
        let (mut worst_angle, mut worst_point) = (0.0f64, 0.0f64);
        for (t, tube) in case["tubes"].as_array().unwrap().iter().enumerate() {
            let frames = tube["frames"].as_array().unwrap();
            assert_eq!(frames.len(), body.tube(t).len(), "{name} tube {t}");
            for (j, f) in frames.iter().enumerate() {
                let mut r = [[0.0; 3]; 3];
                for (a, row) in f.as_array().unwrap().iter().enumerate() {
                    for (b, x) in row.as_array().unwrap().iter().enumerate() {
                        r[a][b] = x.as_f64().unwrap();
                    }
                }
                worst_angle = worst_angle.max(angle_between(&body.frame(&eq.frames, t, j), &r));
            }
            let points = body.points(&eq.frames, t);
            for (p, q) in points.iter().zip(tube["points_m"].as_array().unwrap()) {
                let q: Vec<f64> = q.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
                worst_point = worst_point.max((0..3).fold(0.0f64, |m, c| m.max((p[c] - q[c]).abs())));
            }
        }
        // Genuinely 3D: every case turns out of the clamp's plane and twists.
        let (end, twist) = (body.endpoint(&eq.frames), body.max_twist(&eq.frames));
        println!("{name}: frames within {worst_angle:.1e} rad, points within {worst_point:.1e} m (z {:.4} m, twist {twist:.1e} rad)", end[2]);
        assert!(end[2].abs() > 5e-3 && twist > 1e-4, "{name}: z {} m, twist {twist} rad", end[2]);
        assert!(worst_angle < TOLERANCE && worst_point < TOLERANCE, "{name}: {worst_angle:e} rad, {worst_point:e} m");
    }
}
