//! Files: pictures (through leech-plot), CSV (through `csv::Writer`, so
//! fields with commas or quotes are quoted), the animation and the fitted
//! robot file.

use std::path::Path;

use anyhow::Context;
use leech::calibration::Calibration;
use leech::dynamics::{Actuation, Sample};
use leech::prelude::*;
use leech::stride::{Plan, Status};
use leech_plot::animation::{animated_svg, Frame};
use leech_plot::figures::Table;
use leech_plot::Figure;
use serde::Serialize;

use crate::args::{Calibrate, Climb, Outputs};
use crate::failure::Failure;

/// The picture at each path asked for; `figure` draws it only if one is.
pub fn pictures(outputs: &Outputs, figure: impl Fn() -> Figure) -> Result<(), Failure> {
    if let Some(path) = &outputs.svg {
        figure().write_svg(path)?;
    }
    if let Some(path) = &outputs.png {
        figure().write_png(path)?;
    }
    Ok(())
}

/// One CSV record per row, the header from the rows' field names.
pub fn csv_rows<T: Serialize>(path: &Path, rows: impl IntoIterator<Item = T>) -> Result<(), Failure> {
    write_csv(path, |w| rows.into_iter().try_for_each(|row| w.serialize(row)))
}

/// The steps of a climb, one row each.
pub fn climb_csv(path: &Path, report: &leech::report::ClimbReport) -> Result<(), Failure> {
    let write = || -> anyhow::Result<()> {
        let file = std::io::BufWriter::new(std::fs::File::create(path)?);
        leech::report::write_climb_csv(file, report)?;
        Ok(())
    };
    Ok(write().with_context(|| format!("writing {}", path.display()))?)
}

/// A figure's data table.
pub fn csv_table(path: &Path, table: &Table) -> Result<(), Failure> {
    write_csv(path, |w| {
        w.write_record(&table.header)?;
        table.rows.iter().try_for_each(|row| w.write_record(row))
    })
}

fn write_csv(
    path: &Path,
    records: impl FnOnce(&mut csv::Writer<std::fs::File>) -> csv::Result<()>,
) -> Result<(), Failure> {
    let write = || -> anyhow::Result<()> {
        let mut writer = csv::Writer::from_path(path)?;
        records(&mut writer)?;
        writer.flush()?;
        Ok(())
    };
    Ok(write().with_context(|| format!("writing {}", path.display()))?)
}

/// The animated SVG of a simulation.
pub fn animation(path: &Path, lengths: [f64; 2], actuation: &Actuation, samples: &[Sample]) -> Result<(), Failure> {
    // At most about 250 frames keeps the file small and the playback smooth.
    let every = samples.len().div_ceil(250).max(1);
    let frames: Vec<Frame> = samples
        .iter()
        .enumerate()
        .filter(|(i, _)| i % every == 0 || *i == samples.len() - 1)
        .map(|(_, s)| Frame {
            time: s.time_s,
            lines: vec![
                s.points_a_m.clone(),
                s.points_b_m.clone(),
                vec![*s.points_a_m.last().expect("a chain"), *s.points_b_m.last().expect("a chain")],
                vec![s.points_a_m[0], s.points_b_m[0]],
            ],
        })
        .collect();
    let mm = |v: [f64; 2]| format!("LA {:.0} mm, LB {:.0} mm", v[0] * 1e3, v[1] * 1e3);
    let motion = match actuation {
        Actuation::Hold => "settling under gravity".to_string(),
        Actuation::Step { to } => format!("step to {}", mm(*to)),
        Actuation::Feed { to, speed } => format!("feeding to {} at {:.0} mm/s", mm(*to), speed * 1e3),
    };
    let title = format!("{}:\n{motion}", mm(lengths));
    std::fs::write(path, animated_svg(&title, &frames)).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// The animated SVG of a planned climb (for an impossible one, its steps to
/// the farthest stance).
pub fn climb_animation(path: &Path, a: &Climb, plan: &Plan) -> Result<(), Failure> {
    let s = &a.scenario;
    if plan.steps.is_empty() {
        return Ok(());
    }
    let strides = if plan.strides == 1 { "1 stride".to_string() } else { format!("{} strides", plan.strides) };
    let outcome = match plan.status {
        Status::Reached => format!("reached in {strides}"),
        Status::Impossible => format!("impossible: {strides} to the farthest stance"),
        Status::Stopped => format!("stopped: {strides} to the farthest stance"),
    };
    let title = format!(
        "{}, {}:\n{outcome}\ncups: filled hold (orange below SF {}), outline released",
        s.name, a.robot.name, a.robot.cup.min_safety_factor
    );
    let svg = leech_plot::climb::climb_svg(&title, &a.robot, &s.scene, &plan.steps, plan.strides, &s.goal);
    std::fs::write(path, svg).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// The fitted robot file, its header saying what it was fitted to.
pub fn fitted_robot(a: &Calibrate, result: &Calibration, fitted: &Robot) -> Result<(), Failure> {
    let mass_line = match result.element_mass_std_error_kg {
        Some(se) => format!("# element_mass_kg fitted: {:.6e} +- {:.2e} kg\n", result.element_mass_kg, se),
        None => format!("# element_mass_kg kept from the starting robot: {:.6e} kg\n", result.element_mass_kg),
    };
    let shapes = a.shapes.as_ref().map_or(String::new(), |s| format!(" and {} ({} shapes)", s.name, s.rows.len()));
    let mut toml = format!(
        "# Fitted by `leech calibrate` to {} ({} tubes){}: {} points, RMS residual {:.3} mm.\n\
         # joint_stiffness_nm_per_rad fitted: {:.6e} +- {:.2e} N m/rad (one standard error).\n{}",
        a.sag.name,
        a.sag.rows.len(),
        shapes,
        result.points,
        result.rms_residual_mm,
        result.stiffness_nm_per_rad,
        result.stiffness_std_error_nm_per_rad,
        mass_line,
    );
    toml.push_str(&fitted.to_toml_string());
    std::fs::write(&a.out, toml).with_context(|| format!("writing {}", a.out.display()))?;
    Ok(())
}
