//! The paper's figures, regenerated from the model for any robot: each is a
//! [`Figure`] and the [`Table`] of its data (CSV, units in the column names).
//!
//! * `tube-sag` (Fig. 3a): single tubes of several lengths, clamped
//!   horizontally, sagging under gravity.
//! * `model-comparison` (Figs. 3b and 7): the two-chain body against the
//!   constant-curvature body for a set of tube lengths on a vertical wall.
//! * `scaling` (Fig. 9): three robots with the same shape parameter but
//!   different `k`, `m`, `l` (with `b`, `c` and the tube lengths scaled),
//!   overlaid in units of `l`: the shapes coincide.
//! * `pi-sweep` (Fig. 10): endpoints of both models as `Pi` varies over
//!   decades, for lengths whose constant-curvature endpoints form a line.
//! * `workspace` (Fig. 12): endpoints for tube lengths 0.05..0.30 m (left
//!   tube, chain A, longer), payload on, for several `Pi`; the
//!   constant-curvature reach shaded.

use std::path::Path;

use leech::constant_curvature::PlanarBody;
use leech::prelude::*;

use crate::figure::{Axes, Figure, PlotError, SeriesStyle, PALETTE};

/// The figure names, in gallery order.
pub const NAMES: [&str; 5] = ["tube-sag", "model-comparison", "scaling", "pi-sweep", "workspace"];

/// Why a figure could not be made.
#[derive(Debug, thiserror::Error)]
pub enum FigureError {
    /// An unknown name or a robot that cannot make the figure.
    #[error(transparent)]
    Input(#[from] InputError),
    /// A solve behind the figure failed.
    #[error("{what}: {source}")]
    Solve {
        /// Which shape.
        what: String,
        /// The solver's error.
        source: SolveError,
    },
    /// Drawing or writing failed.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// A table of numbers and labels, written as CSV.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// Column names, with units.
    pub header: Vec<&'static str>,
    /// Rows, already formatted.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    fn new(header: &[&'static str]) -> Table {
        Table { header: header.to_vec(), rows: Vec::new() }
    }

    fn push(&mut self, row: Vec<String>) {
        debug_assert_eq!(row.len(), self.header.len());
        self.rows.push(row);
    }

    /// The table as CSV text.
    pub fn to_csv_string(&self) -> String {
        let mut out = self.header.join(",");
        out.push('\n');
        for row in &self.rows {
            out.push_str(&row.join(","));
            out.push('\n');
        }
        out
    }

    /// Writes the table as CSV.
    pub fn write_csv(&self, path: &Path) -> Result<(), PlotError> {
        std::fs::write(path, self.to_csv_string())
            .map_err(|e| PlotError::Write { path: path.display().to_string(), message: e.to_string() })
    }
}

/// A figure with its data.
#[derive(Clone, Debug)]
pub struct Output {
    /// The figure's name (one of [`NAMES`]).
    pub name: &'static str,
    /// The picture.
    pub figure: Figure,
    /// The data behind it.
    pub table: Table,
}

/// Builds figure `name` for `robot`.
pub fn build(name: &str, robot: &Robot) -> Result<Output, FigureError> {
    match name {
        "tube-sag" => tube_sag(robot),
        "model-comparison" => model_comparison(robot),
        "scaling" => scaling(robot),
        "pi-sweep" => pi_sweep(robot),
        "workspace" => workspace(robot),
        other => Err(InputError::Invalid {
            field: "figure name".into(),
            value: other.into(),
            allowed: format!("one of {} or all", NAMES.join(", ")),
        }
        .into()),
    }
}

fn num(x: f64) -> String {
    format!("{x}")
}

fn solve_body(robot: &Robot, la: f64, lb: f64) -> Result<(Body, Equilibrium), FigureError> {
    let body = robot.body(la, lb)?;
    let eq = body
        .solve(&Solver::default())
        .map_err(|source| FigureError::Solve { what: format!("LA = {la} m, LB = {lb} m"), source })?;
    Ok((body, eq))
}

fn pi_label(pi: f64) -> String {
    leech::error::Num::rounded(pi, 2).to_string()
}

/// Fig. 3a: tubes of 50 to 300 mm clamped horizontally.
fn tube_sag(robot: &Robot) -> Result<Output, FigureError> {
    let horizontal = robot.with_base_angle(0.0).expect("a valid robot with another angle");
    let mut fig = Figure::new(format!(
        "Single tubes sagging under gravity, horizontal clamp (Pi = {})",
        pi_label(robot.shape_parameter())
    ));
    let mut table = Table::new(&["tube_length_m", "point", "x_m", "y_m"]);
    for (i, length) in [0.05, 0.10, 0.15, 0.20, 0.25, 0.30].into_iter().enumerate() {
        let tube = horizontal.cantilever(length, 0.0)?;
        let eq = tube
            .solve(&Solver::default())
            .map_err(|source| FigureError::Solve { what: format!("tube of {length} m"), source })?;
        let points = tube.chain().points(&eq.q);
        for (j, p) in points.iter().enumerate() {
            table.push(vec![num(length), j.to_string(), num(p[0]), num(p[1])]);
        }
        fig.push(format!("L = {:.0} mm", length * 1e3), points, SeriesStyle::LineAndDots, PALETTE[i % PALETTE.len()]);
    }
    fig.gravity_arrow = true;
    Ok(Output { name: "tube-sag", figure: fig, table })
}

/// Figs. 3b and 7: the two models side by side on a vertical wall.
fn model_comparison(robot: &Robot) -> Result<Output, FigureError> {
    let wall = robot.with_base_angle(90.0).expect("a valid robot with another angle");
    let cc = PlanarBody::of(&wall);
    let mut fig = Figure::new("Two-chain model (solid) vs constant curvature (dashed)");
    let mut table = Table::new(&["la_m", "lb_m", "model", "chain", "point", "x_m", "y_m"]);
    for (i, (la, lb)) in [(0.10, 0.09), (0.20, 0.17), (0.30, 0.24), (0.30, 0.30)].into_iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let (body, eq) = solve_body(&wall, la, lb)?;
        let (qa, qb) = body.split(&eq.q);
        let (arc_a, arc_b) = cc.chain_points(la, lb, 60);
        let shapes = [
            ("two-chain", "a", body.chain_a().points(qa)),
            ("two-chain", "b", body.chain_b().points(qb)),
            ("constant-curvature", "a", arc_a),
            ("constant-curvature", "b", arc_b),
        ];
        for (model, chain, points) in shapes {
            for (j, p) in points.iter().enumerate() {
                table.push(vec![num(la), num(lb), model.into(), chain.into(), j.to_string(), num(p[0]), num(p[1])]);
            }
            let (label, style) = match (model, chain) {
                ("two-chain", "a") => (format!("LA/LB = {:.0}/{:.0} mm", la * 1e3, lb * 1e3), SeriesStyle::Line),
                ("two-chain", _) => (String::new(), SeriesStyle::Line),
                _ => (String::new(), SeriesStyle::Dashed),
            };
            fig.push(label, points, style, color);
        }
    }
    fig.gravity_arrow = true;
    Ok(Output { name: "model-comparison", figure: fig, table })
}

/// Fig. 9: same Pi, three sizes, shapes in units of l.
fn scaling(robot: &Robot) -> Result<Output, FigureError> {
    let (la, lb) = (0.25, 0.21);
    let mut fig = Figure::new(format!(
        "Same shape parameter Pi = {}, three sizes (k, m, l, b, c scaled)",
        pi_label(robot.shape_parameter())
    ));
    fig.axes = Axes { scale: 1.0, x_label: "x / l".into(), y_label: "y / l".into() };
    let mut table = Table::new(&[
        "scale",
        "element_length_m",
        "element_mass_kg",
        "joint_stiffness_nm_per_rad",
        "chain",
        "point",
        "x_over_l",
        "y_over_l",
    ]);
    let styles = [SeriesStyle::Line, SeriesStyle::Dashed, SeriesStyle::Dots];
    for (i, s) in [0.5, 1.0, 2.0].into_iter().enumerate() {
        let scaled = robot.scaled(s)?;
        let l = scaled.tube.element_length_m;
        let (body, eq) = solve_body(&scaled, la * s, lb * s)?;
        let (qa, qb) = body.split(&eq.q);
        for (chain, points) in [("a", body.chain_a().points(qa)), ("b", body.chain_b().points(qb))] {
            let over_l: Vec<[f64; 2]> = points.iter().map(|p| [p[0] / l, p[1] / l]).collect();
            for (j, p) in over_l.iter().enumerate() {
                table.push(vec![
                    num(s),
                    num(l),
                    num(scaled.tube.element_mass_kg),
                    num(scaled.tube.joint_stiffness_nm_per_rad),
                    chain.into(),
                    j.to_string(),
                    num(p[0]),
                    num(p[1]),
                ]);
            }
            let label = if chain == "a" {
                format!(
                    "l = {:.1} mm, m = {:.2} g, k = {:.3} N m/rad",
                    l * 1e3,
                    scaled.tube.element_mass_kg * 1e3,
                    scaled.tube.joint_stiffness_nm_per_rad
                )
            } else {
                String::new()
            };
            fig.push(label, over_l, styles[i], PALETTE[i]);
        }
    }
    fig.gravity_arrow = true;
    Ok(Output { name: "scaling", figure: fig, table })
}

/// One point of the Pi sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepPoint {
    /// Shape parameter.
    pub pi: f64,
    /// Tube lengths (m).
    pub lengths: [f64; 2],
    /// Two-chain endpoint (m).
    pub two_chain: [f64; 2],
    /// Constant-curvature endpoint (m).
    pub constant_curvature: [f64; 2],
}

/// The shape parameters of the sweep: five decades.
pub const SWEEP_PIS: [f64; 5] = [1e2, 1e3, 1e4, 1e5, 1e6];

/// Fig. 10's data: the lengths whose constant-curvature endpoints lie on a
/// horizontal line 150 mm above the driving unit of a robot on a vertical
/// wall (x from -100 to 100 mm), solved with the two-chain model for each Pi.
pub fn pi_sweep_data(robot: &Robot) -> Result<Vec<SweepPoint>, FigureError> {
    let wall = robot.with_base_angle(90.0).expect("a valid robot with another angle");
    let cc = PlanarBody::of(&wall);
    let mut out = Vec::new();
    for pi in SWEEP_PIS {
        let tuned = wall.with_shape_parameter(pi)?;
        for i in 0..=10 {
            let target = [-0.10 + 0.02 * i as f64, 0.15];
            let [la, lb] = cc.lengths_for(target)?;
            let (body, eq) = solve_body(&tuned, la, lb)?;
            out.push(SweepPoint {
                pi,
                lengths: [la, lb],
                two_chain: body.endpoint(&eq.q),
                constant_curvature: cc.pose(la, lb).endpoint,
            });
        }
    }
    Ok(out)
}

/// Fig. 10.
fn pi_sweep(robot: &Robot) -> Result<Output, FigureError> {
    let data = pi_sweep_data(robot)?;
    let mut fig = Figure::new("Endpoints as Pi grows; constant-curvature endpoints on a line");
    let mut table = Table::new(&["pi", "la_m", "lb_m", "model", "x_m", "y_m"]);
    for (i, pi) in SWEEP_PIS.into_iter().enumerate() {
        let points: Vec<[f64; 2]> = data.iter().filter(|p| p.pi == pi).map(|p| p.two_chain).collect();
        fig.push(format!("two-chain, Pi = {}", pi_label(pi)), points, SeriesStyle::LineAndDots, PALETTE[i]);
    }
    let cc: Vec<[f64; 2]> = data.iter().filter(|p| p.pi == SWEEP_PIS[0]).map(|p| p.constant_curvature).collect();
    fig.push("constant curvature", cc, SeriesStyle::Dashed, (0, 0, 0));
    for p in &data {
        for (model, e) in [("two-chain", p.two_chain), ("constant-curvature", p.constant_curvature)] {
            table.push(vec![num(p.pi), num(p.lengths[0]), num(p.lengths[1]), model.into(), num(e[0]), num(e[1])]);
        }
    }
    fig.push("driving unit", vec![[0.0, 0.0], [robot.body.base_spacing_m, 0.0]], SeriesStyle::Thick, (90, 90, 90));
    fig.gravity_arrow = true;
    Ok(Output { name: "pi-sweep", figure: fig, table })
}

/// One solved point of the workspace.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReachPoint {
    /// Shape parameter.
    pub pi: f64,
    /// Tube lengths (m).
    pub lengths: [f64; 2],
    /// Two-chain endpoint (m).
    pub endpoint: [f64; 2],
    /// Whether the equilibrium is stable.
    pub stable: bool,
}

/// The shape parameters of the workspace figure.
pub const WORKSPACE_PIS: [f64; 4] = [300.0, 1000.0, 3000.0, 10000.0];

/// Fig. 12's data: LA >= LB in 0.05..0.30 m at `step` m, payload on, wall.
pub fn workspace_data(robot: &Robot, step: f64) -> Result<Vec<ReachPoint>, FigureError> {
    let wall = robot.with_base_angle(90.0).expect("a valid robot with another angle");
    let count = ((0.30 - 0.05) / step).round() as usize;
    let mut out = Vec::new();
    for pi in WORKSPACE_PIS {
        let tuned = wall.with_shape_parameter(pi)?;
        for i in 0..=count {
            for j in 0..=i {
                let (la, lb) = (0.05 + step * i as f64, 0.05 + step * j as f64);
                let (body, eq) = solve_body(&tuned, la, lb)?;
                out.push(ReachPoint { pi, lengths: [la, lb], endpoint: body.endpoint(&eq.q), stable: eq.stable });
            }
        }
    }
    Ok(out)
}

/// Side of the cells that shade the constant-curvature reach (m).
pub const REACH_CELL: f64 = 0.005;

/// The constant-curvature reach for LA >= LB in 0.05..0.30 m, as the cells
/// (squares of [`REACH_CELL`], lower-left corners in m) that its endpoints
/// visit on a 0.25 mm grid of lengths (fine enough that neighbouring
/// endpoints are less than a cell apart where the bend is large). Large bends wrap the arcs round the
/// clamp, so the reach is not the image of the domain's boundary.
pub fn constant_curvature_reach(robot: &Robot) -> Vec<[f64; 2]> {
    let wall = robot.with_base_angle(90.0).expect("a valid robot with another angle");
    let cc = PlanarBody::of(&wall);
    let mut cells = std::collections::BTreeSet::new();
    for i in 0..=1000 {
        for j in 0..=i {
            let (la, lb) = (0.05 + 0.00025 * i as f64, 0.05 + 0.00025 * j as f64);
            let p = cc.pose(la, lb).endpoint;
            cells.insert(((p[0] / REACH_CELL).floor() as i64, (p[1] / REACH_CELL).floor() as i64));
        }
    }
    cells.into_iter().map(|(x, y)| [x as f64 * REACH_CELL, y as f64 * REACH_CELL]).collect()
}

/// Fig. 12.
fn workspace(robot: &Robot) -> Result<Output, FigureError> {
    let data = workspace_data(robot, 0.01)?;
    let mut fig = Figure::new("Reachable endpoints, LA >= LB in 50..300 mm, payload on");
    for (i, c) in constant_curvature_reach(robot).into_iter().enumerate() {
        let h = REACH_CELL;
        let square = vec![c, [c[0] + h, c[1]], [c[0] + h, c[1] + h], [c[0], c[1] + h]];
        let label = if i == 0 { "constant curvature reach" } else { "" };
        fig.push(label, square, SeriesStyle::Area, (150, 150, 150));
    }
    let mut table = Table::new(&["pi", "la_m", "lb_m", "stable", "x_m", "y_m"]);
    for (i, pi) in WORKSPACE_PIS.into_iter().enumerate() {
        let points: Vec<[f64; 2]> = data.iter().filter(|p| p.pi == pi).map(|p| p.endpoint).collect();
        fig.push(format!("two-chain, Pi = {}", pi_label(pi)), points, SeriesStyle::Dots, PALETTE[i]);
    }
    for p in &data {
        table.push(vec![
            num(p.pi),
            num(p.lengths[0]),
            num(p.lengths[1]),
            p.stable.to_string(),
            num(p.endpoint[0]),
            num(p.endpoint[1]),
        ]);
    }
    fig.push("driving unit", vec![[0.0, 0.0], [robot.body.base_spacing_m, 0.0]], SeriesStyle::Thick, (90, 90, 90));
    fig.gravity_arrow = true;
    Ok(Output { name: "workspace", figure: fig, table })
}

/// The endpoints of a [`leech::sweep::Sweep`]: one colour per model and
/// shape parameter, feasible converged points only; constant curvature grey.
pub fn sweep_figure(title: &str, sweep: &leech::sweep::Sweep) -> Figure {
    use leech::sweep::Model;
    let mut fig = Figure::new(title);
    let mut colour = 0;
    for summary in &sweep.summaries {
        let points: Vec<[f64; 2]> = sweep
            .points
            .iter()
            .filter(|p| p.model == summary.model && p.shape_parameter == summary.shape_parameter)
            .filter(|p| p.failure.is_none() && p.feasible)
            .map(|p| p.endpoint_m)
            .collect();
        let (label, color) = match (summary.model, summary.shape_parameter) {
            (Model::ConstantCurvature, _) => ("constant curvature".to_string(), (170, 170, 170)),
            (Model::TwoChain, pi) => {
                colour += 1;
                (format!("two-chain, Pi = {}", pi_label(pi.unwrap_or(f64::NAN))), PALETTE[(colour - 1) % PALETTE.len()])
            }
        };
        if !points.is_empty() {
            fig.push(label, points, SeriesStyle::Dots, color);
        }
    }
    fig.gravity_arrow = true;
    fig
}
