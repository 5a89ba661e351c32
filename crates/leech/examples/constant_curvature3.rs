//! How far the 3D body is from the tri-tube constant-curvature model
//! (docs/model3d.md section 9): the built-in robot on a wall, without
//! gravity and `b = c`, without gravity, and as built, at growing bends in
//! its plane (`L2 = L3`) and sideways (`L2 != L3`).
//!
//! `cargo run --release -p leech --example constant_curvature3`

use leech::body3::{Body3, ConstantCurvature3};
use leech::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let builtin = Robot::builtin();
    let mut equal = builtin.with_gravity(0.0)?;
    equal.body.tip_spacing_m = equal.body.base_spacing_m;
    let robots = [("g = 0, b = c", equal), ("g = 0", builtin.with_gravity(0.0)?), ("built-in (g = 9.81)", builtin)];
    let l = 0.25;
    println!("robot | lengths (m) | bend (rad) | endpoint (m) | plate (rad) | largest point (m)");
    for (name, robot) in &robots {
        for delta in [0.0, 0.001, 0.002, 0.004, 0.008, 0.016] {
            let sideways = [l, l + delta, l - delta];
            for lengths in [[l, l + delta, l + delta], sideways].into_iter().take(if delta == 0.0 { 1 } else { 2 }) {
                let body = Body3::from_robot(robot, lengths)?;
                let eq = body.solve(&Solver::default())?;
                let cc = ConstantCurvature3::new(robot, lengths)?;
                let d = cc.difference(&body, &eq.frames)?;
                let events = if eq.events.is_empty() { "" } else { " (events)" };
                println!(
                    "{name} | {:.3}/{:.3}/{:.3} | {:.3} | {:.2e} | {:.2e} | {:.2e}{events}",
                    lengths[0],
                    lengths[1],
                    lengths[2],
                    cc.arc().bend,
                    d.endpoint_m,
                    d.plate_angle_rad,
                    d.max_point_m
                );
            }
        }
    }
    Ok(())
}
