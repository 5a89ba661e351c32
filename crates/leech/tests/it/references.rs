//! Agreement with independent engines: SciPy (constrained minimization,
//! polished by Newton on the KKT system) and MuJoCo run to rest, produced by
//! `validation/references.py` and committed under `tests/data/`.

use leech::prelude::*;
use serde_json::Value;

const ANGLE_TOLERANCE_RAD: f64 = 1e-7;
const POSITION_TOLERANCE_M: f64 = 1e-7;

fn fixture(name: &str) -> Vec<Value> {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let v: Value = serde_json::from_str(&text).expect("fixture is JSON");
    v["cases"].as_array().expect("cases").clone()
}

fn num(case: &Value, key: &str) -> f64 {
    case[key].as_f64().unwrap_or_else(|| panic!("{key} missing in {}", case["name"]))
}

fn vector(case: &Value, key: &str) -> Vec<f64> {
    case[key].as_array().unwrap_or_else(|| panic!("{key}")).iter().map(|x| x.as_f64().unwrap()).collect()
}

fn discretization(case: &Value) -> Discretization {
    match case["discretization"].as_str() {
        Some("paper") => Discretization::Paper,
        Some("midpoint") => Discretization::Midpoint,
        other => panic!("unknown discretization {other:?}"),
    }
}

fn assert_close(what: &str, ours: &[f64], theirs: &[f64], tolerance: f64) {
    assert_eq!(ours.len(), theirs.len(), "{what}: sizes");
    for (i, (a, b)) in ours.iter().zip(theirs).enumerate() {
        assert!((a - b).abs() <= tolerance, "{what}[{i}]: leech {a} vs reference {b} (diff {:e})", (a - b).abs());
    }
}

#[test]
fn single_chains_match_scipy_and_mujoco() {
    let cases = fixture("single_chain.json");
    assert!(cases.len() >= 6, "at least six single-chain references");
    let mut shape_parameters = Vec::new();
    for case in &cases {
        let name = case["name"].as_str().unwrap();
        let spec = ChainSpec {
            tube_length: num(case, "tube_length_m"),
            element_length: num(case, "element_length_m"),
            element_mass: num(case, "element_mass_kg"),
            stiffness: num(case, "joint_stiffness_nm_per_rad"),
            damping: 0.0,
            tip_mass: num(case, "tip_mass_kg"),
            clamp_point: [0.0, 0.0],
            clamp_angle: num(case, "base_angle_deg").to_radians(),
            discretization: discretization(case),
        };
        let tube = Cantilever::new(Chain::new(&spec), num(case, "gravity_m_per_s2"));
        let eq = tube.solve(&Solver::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(eq.stable, "{name}");
        assert_close(name, &eq.q, &vector(case, "angles_rad"), ANGLE_TOLERANCE_RAD);
        assert_close(name, &tube.chain().tip(&eq.q), &vector(case, "tip_m"), POSITION_TOLERANCE_M);
        assert!(num(case, "mujoco_max_abs_diff_rad") < 1e-6, "{name}: the two engines agree");
        shape_parameters.push(num(case, "shape_parameter"));
    }
    let (lo, hi) = shape_parameters.iter().fold((f64::MAX, 0.0f64), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    assert!(lo <= 2.0 && hi >= 1000.0, "references span the shape parameter ({lo}..{hi})");
}

#[test]
fn two_chain_bodies_match_scipy_and_mujoco() {
    let cases = fixture("two_chain.json");
    assert!(cases.len() >= 6, "at least six two-chain references");
    for case in &cases {
        let name = case["name"].as_str().unwrap();
        let robot = super::robot_from_case(case);
        let lengths = vector(case, "lengths_m");
        let body = robot.body(lengths[0], lengths[1]).unwrap();
        let eq = body.solve(&Solver::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(eq.stable, "{name}");
        let (qa, qb) = body.split(&eq.q);
        assert_close(&format!("{name} A"), qa, &vector(case, "angles_a_rad"), ANGLE_TOLERANCE_RAD);
        assert_close(&format!("{name} B"), qb, &vector(case, "angles_b_rad"), ANGLE_TOLERANCE_RAD);
        assert_close(name, &body.endpoint(&eq.q), &vector(case, "endpoint_m"), POSITION_TOLERANCE_M);
        assert!(num(case, "mujoco_max_abs_diff") < 1e-6, "{name}: the two engines agree");
    }
}
