//! The controller's settings from a robot file: the tubes' configuration
//! a host sends after the handshake, and a simulated controller that
//! behaves as the file's `[drive]` section says. `leech drive`,
//! `leech sim-robot` and the console (`leech serve`) all start from here,
//! so that a simulated robot and the host agree on one calibration.

use leech::robot::Robot;
use leech_protocol::message::{Tube, TubeConfig};

use crate::sim::SimConfig;

/// Micrometres of a length in metres (rounded).
fn um(m: f64) -> i32 {
    (m * 1e6).round() as i32
}

/// The three tubes' configuration for `robot`: its encoder calibration,
/// zero lengths, length limits, top speed and PID gains (Q16).
pub fn tube_configs(robot: &Robot) -> [TubeConfig; 3] {
    let d = &robot.drive;
    let (lo, hi) = (robot.limits.tube_length_min_m, robot.limits.tube_length_max_m);
    let q16 = |g: f64| (g * 65536.0).round() as i32;
    Tube::ALL.map(|tube| TubeConfig {
        tube,
        reverse_motor: false,
        reverse_encoder: false,
        counts_per_mm_x1000: (d.counts_per_mm * 1e3).round() as u32,
        origin_um: um(d.zero_lengths_m[tube.index()]),
        min_um: um(lo),
        max_um: um(hi),
        max_speed_um_s: (d.max_speed_m_per_s * 1e6).round() as u32,
        max_duty_permille: 1000,
        kp_q16: q16(d.gains[0]),
        ki_q16: q16(d.gains[1]),
        kd_q16: q16(d.gains[2]),
    })
}

/// A simulated controller for `robot`: the encoder's counts per turn stay
/// the default's, a turn feeds what the robot's calibration says, the
/// tubes start at the zero lengths and move at most at the top speed.
pub fn sim_config(robot: &Robot) -> SimConfig {
    let default = SimConfig::default();
    SimConfig {
        mm_per_rev: default.counts_per_rev / robot.drive.counts_per_mm,
        initial_lengths_um: robot.drive.zero_lengths_m.map(um),
        max_tube_speed_mm_s: robot.drive.max_speed_m_per_s * 1e3,
        ..default
    }
}
