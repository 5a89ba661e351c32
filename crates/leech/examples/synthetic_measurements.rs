//! Writes the synthetic example measurements under `examples/data/`:
//! `cargo run -p leech --example synthetic_measurements -- examples/data`.
//!
//! The "true" tube is the built-in robot's with k = 0.42 N m/rad and
//! m = 1.2 g per element (not the built-in values, so that a fit has to move);
//! points every 20 mm of arc length with Gaussian noise of 0.5 mm, seed 1.

use std::fmt::Write as _;

use leech::calibration::synthetic;
use leech::prelude::*;

const STIFFNESS: f64 = 0.42;
const MASS: f64 = 0.0012;
const NOISE_M: f64 = 0.0005;
const SEED: u64 = 1;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| "examples/data".into());
    std::fs::create_dir_all(&dir)?;
    let truth = Robot::builtin().with_tube(STIFFNESS, MASS)?;
    let provenance = format!(
        "# SYNTHETIC DATA, not measurements: made by crates/leech/examples/synthetic_measurements.rs\n\
         # from the built-in robot with k = {STIFFNESS} N m/rad, m = {MASS} kg per element,\n\
         # points every 20 mm plus Gaussian noise of {} mm on x and y, seed {SEED}.\n",
        NOISE_M * 1e3
    );

    let sag = synthetic::sag(&truth, &[0.10, 0.15, 0.20, 0.25, 0.30], 0.0, 0.02, NOISE_M, SEED);
    let mut text = provenance.clone();
    text.push_str("tube_length_m,base_angle_deg,x_m,y_m\n");
    for tube in &sag {
        for p in &tube.points {
            writeln!(text, "{},{},{:.6},{:.6}", tube.length, tube.base_angle_deg, p[0], p[1])?;
        }
    }
    std::fs::write(format!("{dir}/tube_sag.csv"), text)?;

    let shapes =
        synthetic::shapes(&truth, &[[0.10, 0.09], [0.20, 0.17], [0.30, 0.24], [0.25, 0.25]], 90.0, 0.02, NOISE_M, SEED);
    let mut text = provenance;
    text.push_str("shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m\n");
    for s in &shapes {
        let rows = s.points_a.iter().map(|p| ("a", p)).chain(s.points_b.iter().map(|p| ("b", p)));
        for (chain, p) in rows.chain(s.endpoint.iter().map(|p| ("endpoint", p))) {
            writeln!(
                text,
                "{},{},{},{},{chain},{:.6},{:.6}",
                s.name, s.lengths[0], s.lengths[1], s.base_angle_deg, p[0], p[1]
            )?;
        }
    }
    std::fs::write(format!("{dir}/body_shapes.csv"), text)?;
    println!("wrote {dir}/tube_sag.csv and {dir}/body_shapes.csv");
    Ok(())
}
