//! Integration tests of the `leech` library: one binary, one module per topic.

mod calibration;
mod constant_curvature;
mod continuum;
mod derivatives;
mod dynamics;
mod inverse_statics;
mod limits;
mod references;
mod robot_file;
mod scene;
mod solver;
mod sweep;

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
