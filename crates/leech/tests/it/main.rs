//! Integration tests of the `leech` library: one binary, one module per topic.

mod batch;
mod body3;
mod body3_constant_curvature;
mod body3_contact;
mod body3_hold;
mod body3_references;
mod calibration;
mod climb;
mod constant_curvature;
mod contact_census;
mod contact_references;
mod continuum;
mod cup;
mod derivatives;
mod dynamics;
mod holds_references;
mod hose_references;
mod inverse_statics;
mod limits;
mod linalg;
mod phases;
mod references;
mod robot_file;
mod scene;
mod solver;
mod stance;
mod stride;
mod sweep;
mod tube;
mod unit_references;

use leech::prelude::*;

/// A single chain with the given shape, clamped at the origin.
pub fn chain(n: usize, pi: f64, clamp_deg: f64, tip_mass: f64, d: Discretization) -> Cantilever {
    let (l, m, g) = (0.01, 0.001, 9.81);
    let spec = ChainSpec {
        tube_length: n as f64 * l,
        element_length: l,
        element_mass: m,
        stiffness: pi * m * g * l,
        damping: 0.0,
        tip_mass,
        clamp_point: [0.0, 0.0],
        clamp_angle: clamp_deg.to_radians(),
        discretization: d,
    };
    Cantilever::new(Chain::new(&spec), g)
}

/// The robot a reference case describes: the built-in one with the case's
/// values for whichever of these keys it has.
pub fn robot_from_case(case: &serde_json::Value) -> Robot {
    let mut robot = Robot::builtin();
    let fields: [(&str, &mut f64); 9] = [
        ("element_length_m", &mut robot.tube.element_length_m),
        ("element_mass_kg", &mut robot.tube.element_mass_kg),
        ("joint_stiffness_nm_per_rad", &mut robot.tube.joint_stiffness_nm_per_rad),
        ("joint_damping_nms_per_rad", &mut robot.tube.joint_damping_nms_per_rad),
        ("base_spacing_m", &mut robot.body.base_spacing_m),
        ("tip_spacing_m", &mut robot.body.tip_spacing_m),
        ("payload_kg", &mut robot.body.payload_kg),
        ("base_angle_deg", &mut robot.world.base_angle_deg),
        ("gravity_m_per_s2", &mut robot.world.gravity_m_per_s2),
    ];
    for (key, field) in fields {
        if let Some(v) = case[key].as_f64() {
            *field = v;
        }
    }
    if case["discretization"] == "midpoint" {
        robot.model.discretization = Discretization::Midpoint;
    }
    robot
}

/// The dense symmetric matrix (row-major) of quasiseparable generators,
/// entry by entry from their definition.
pub fn dense<const R: usize>(rows: impl Iterator<Item = leech::linalg::quasiseparable::Generators<R>>) -> Vec<f64> {
    let rows: Vec<_> = rows.collect();
    let n = rows.len();
    let mut a = vec![0.0; n * n];
    for k in 0..n {
        a[k * n + k] = rows[k].diagonal;
        let mut t = rows[k].q;
        for j in k + 1..n {
            let v: f64 = (0..R).map(|i| rows[j].p[i] * t[i]).sum();
            a[j * n + k] = v;
            a[k * n + j] = v;
            for i in 0..R {
                t[i] *= rows[j].a[i];
            }
        }
    }
    a
}

/// A chain's mass matrix from the kinematics of its mass points, `sum_i m_i
/// J_i^T J_i` plus the links' own rotational inertia: the reference for
/// [`Chain::mass_generators`]. Link `i`'s mass sits at its tip (`paper`) or
/// centre (`midpoint`), the tip mass at the last tip; point `i` moves with
/// `d r_i / d phi_k = lever_ik e'(phi_k)` for `k <= i`.
pub fn kinematic_mass_matrix(chain: &Chain, q: &[f64], d: Discretization) -> Vec<f64> {
    let n = chain.len();
    let (l, m) = (chain.lengths(), chain.masses());
    let offset = |j: usize| if d == Discretization::Midpoint { 0.5 * l[j] } else { l[j] };
    let mut a = vec![0.0; n * n];
    let mut add_point = |mass: f64, levers: &[f64]| {
        for j in 0..levers.len() {
            for k in 0..levers.len() {
                a[j * n + k] += mass * levers[j] * levers[k] * (q[j] - q[k]).cos();
            }
        }
    };
    for i in 0..n {
        let levers: Vec<f64> = (0..=i).map(|k| if k == i { offset(i) } else { l[k] }).collect();
        add_point(m[i], &levers);
    }
    add_point(chain.tip_mass(), l);
    if d == Discretization::Midpoint {
        for j in 0..n {
            a[j * n + j] += m[j] * l[j] * l[j] / 12.0;
        }
    }
    a
}
