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
mod solver;
mod workspace;

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
