//! Fitting the model to measured tubes and bodies, and measuring how well
//! each model fits.
//!
//! # Measurement files (CSV, units in the column names, `#` starts a comment)
//!
//! * Tube sag, one row per measured point of a single tube clamped at the
//!   origin: `tube_length_m,base_angle_deg,x_m,y_m` and optionally
//!   `tip_mass_kg`. Rows with the same length, angle and tip mass belong to
//!   one tube; a tube with a single row is measured at its tip only.
//! * Body shapes, one row per measured point of a body whose driving unit
//!   (chain A's clamp) is at the origin:
//!   `shape,la_m,lb_m,base_angle_deg,chain,x_m,y_m` where `chain` is `a`
//!   (a point on the centre tube), `b` (on the side tubes) or `endpoint`
//!   (chain A's tip). `shape` names the body; its lengths and angle must agree
//!   on every row.
//!
//! A file has at most [`MAX_ROWS`] rows, [`MAX_TUBES`] tubes and
//! [`MAX_SHAPES`] shapes (each is a solve per evaluation of the fit); rows
//! are grouped by a hash of their key, so reading is linear in the rows.
//!
//! # The fit
//!
//! The residual of a point on a tube or chain is its distance (m) to the
//! predicted centre line (point-to-curve: measured points need not sit at the
//! model's joints); a tip-only or `endpoint` point is compared with the
//! predicted tip. With `x = (ln k)` or `(ln k, ln m)` (positive by
//! construction), Levenberg-Marquardt ([`crate::least_squares`], Marquardt
//! scaling, no bounds) minimizes the sum of squared residuals `S(x)`, the
//! Jacobian by central differences of default solves. Standard errors come
//! from `sigma^2 (J^T J)^-1`, `J` at the fit, with `sigma^2 = S / (N - p)`,
//! mapped back from logarithms (`se_k = k se_ln k`).
//!
//! A single tube without a tip mass depends on `k` and `m` only through
//! `Pi = k/(m g l)`, so the mass is identifiable only with a known mass in the
//! data: a tip mass in the sag file, or body shapes (the payload). Fitting it
//! without one is an error, not a meaningless number.

use std::collections::{BTreeMap, HashMap};

use crate::body::Body;
use crate::budget::{Deadline, Stopped};
use crate::constant_curvature::PlanarBody;
use crate::error::{quoted, InputError};
use crate::least_squares::{central_differences, levenberg_marquardt, LeastSquares, Options, Stop, UNBOUNDED};
use crate::robot::Robot;
use crate::statics::{Solver, SolverOptions};

/// Most data rows a measurement file may have.
pub const MAX_ROWS: usize = 100_000;

/// Most tubes a sag file may describe.
pub const MAX_TUBES: usize = 1_000;

/// Most shapes a body-shapes file may describe.
pub const MAX_SHAPES: usize = 1_000;

/// An error for a file with more than `max` of `what` (`rows`, `shapes`).
fn too_many(source: &str, what: &str, max: usize) -> InputError {
    InputError::Invalid {
        field: source.into(),
        value: format!("more than {max} {what}"),
        allowed: format!("at most {max} {what}"),
    }
}

/// One tube of a sag experiment.
#[derive(Clone, Debug, PartialEq)]
pub struct SagTube {
    /// Tube length (m).
    pub length: f64,
    /// Clamp angle (deg).
    pub base_angle_deg: f64,
    /// Tip mass (kg).
    pub tip_mass: f64,
    /// Measured points (m), clamp at the origin.
    pub points: Vec<[f64; 2]>,
}

/// One measured body.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyShape {
    /// Name of the shape.
    pub name: String,
    /// Tube lengths LA, LB (m).
    pub lengths: [f64; 2],
    /// Clamp angle (deg).
    pub base_angle_deg: f64,
    /// Points on chain A (m).
    pub points_a: Vec<[f64; 2]>,
    /// Points on chain B (m).
    pub points_b: Vec<[f64; 2]>,
    /// The measured endpoint (m), if any.
    pub endpoint: Option<[f64; 2]>,
}

/// A parsed CSV: column index by name, rows of fields with their line number.
struct Table {
    columns: BTreeMap<String, usize>,
    rows: Vec<(usize, Vec<String>)>,
    source: String,
}

impl Table {
    fn parse(text: &str, source: &str, required: &[&str], optional: &[&str]) -> Result<Table, InputError> {
        let bad = |row: usize, message: String| InputError::Invalid {
            field: format!("{source} row {row}"),
            value: crate::error::clip(&message, crate::error::MESSAGE_CHARS),
            allowed: "CSV with the documented columns".into(),
        };
        let mut reader =
            csv::ReaderBuilder::new().comment(Some(b'#')).trim(csv::Trim::All).from_reader(text.as_bytes());
        let header = reader.headers().map_err(|e| bad(1, e.to_string()))?.clone();
        let mut columns = BTreeMap::new();
        for (i, name) in header.iter().enumerate() {
            if !required.contains(&name) && !optional.contains(&name) {
                return Err(InputError::Invalid {
                    field: format!("{source} header"),
                    value: format!("unknown column {}", crate::error::quoted(name)),
                    allowed: format!("the columns {}", [required, optional].concat().join(", ")),
                });
            }
            if columns.insert(name.to_string(), i).is_some() {
                return Err(InputError::Invalid {
                    field: format!("{source} header"),
                    value: format!("column {} twice", crate::error::quoted(name)),
                    allowed: "each column once".into(),
                });
            }
        }
        for name in required {
            if !columns.contains_key(*name) {
                return Err(InputError::Invalid {
                    field: format!("{source} header"),
                    value: format!("no column '{name}'"),
                    allowed: format!("the columns {}", required.join(", ")),
                });
            }
        }
        let mut rows = Vec::new();
        for record in reader.records() {
            if rows.len() == MAX_ROWS {
                return Err(too_many(source, "rows", MAX_ROWS));
            }
            let record = record.map_err(|e| bad(e.position().map_or(0, |p| p.line() as usize), e.to_string()))?;
            let line = record.position().map_or(0, |p| p.line() as usize);
            rows.push((line, record.iter().map(str::to_string).collect()));
        }
        Ok(Table { columns, rows, source: source.to_string() })
    }

    fn text(&self, row: &(usize, Vec<String>), column: &str) -> Option<String> {
        self.columns.get(column).and_then(|i| row.1.get(*i)).cloned()
    }

    fn number(&self, row: &(usize, Vec<String>), column: &str) -> Result<f64, InputError> {
        let value = self.text(row, column).unwrap_or_default();
        // Lengths, angles and masses of a robot are far below 1e6 in SI units.
        match value.parse::<f64>() {
            Ok(v) if v.is_finite() && v.abs() < 1e6 => Ok(v),
            _ => Err(InputError::Invalid {
                field: format!("{} row {}, column {column}", self.source, row.0),
                value: crate::error::quoted(&value),
                allowed: "a finite number of magnitude below 1e6".into(),
            }),
        }
    }
}

/// Reads a tube-sag file (see the module doc); `source` names it in errors.
pub fn read_sag(text: &str, source: &str) -> Result<Vec<SagTube>, InputError> {
    let table = Table::parse(text, source, &["tube_length_m", "base_angle_deg", "x_m", "y_m"], &["tip_mass_kg"])?;
    let mut tubes: Vec<SagTube> = Vec::new();
    // Tube by its key: the bits of its length, angle and tip mass (finite, -0 made +0).
    let mut index: HashMap<[u64; 3], usize> = HashMap::new();
    for row in &table.rows {
        let length = table.number(row, "tube_length_m")?;
        let angle = table.number(row, "base_angle_deg")?;
        let tip_mass = if table.columns.contains_key("tip_mass_kg") { table.number(row, "tip_mass_kg")? } else { 0.0 };
        let point = [table.number(row, "x_m")?, table.number(row, "y_m")?];
        let key = [length, angle, tip_mass].map(|v| (v + 0.0).to_bits());
        match index.get(&key) {
            Some(&i) => tubes[i].points.push(point),
            None if tubes.len() == MAX_TUBES => return Err(too_many(source, "tubes", MAX_TUBES)),
            None => {
                index.insert(key, tubes.len());
                tubes.push(SagTube { length, base_angle_deg: angle, tip_mass, points: vec![point] });
            }
        }
    }
    Ok(tubes)
}

/// Reads a body-shapes file (see the module doc).
pub fn read_shapes(text: &str, source: &str) -> Result<Vec<BodyShape>, InputError> {
    let table = Table::parse(text, source, &["shape", "la_m", "lb_m", "base_angle_deg", "chain", "x_m", "y_m"], &[])?;
    let mut shapes: Vec<BodyShape> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    for row in &table.rows {
        let name = table.text(row, "shape").unwrap_or_default();
        let lengths = [table.number(row, "la_m")?, table.number(row, "lb_m")?];
        let angle = table.number(row, "base_angle_deg")?;
        let point = [table.number(row, "x_m")?, table.number(row, "y_m")?];
        let at = match index.get(&name) {
            Some(&i) => {
                if shapes[i].lengths != lengths || shapes[i].base_angle_deg != angle {
                    return Err(InputError::Invalid {
                        field: format!("{source} row {}, shape {}", row.0, quoted(&name)),
                        value: format!("lengths {lengths:?} at {angle} deg"),
                        allowed: "the same lengths and angle on every row of a shape".into(),
                    });
                }
                i
            }
            None if shapes.len() == MAX_SHAPES => return Err(too_many(source, "shapes", MAX_SHAPES)),
            None => {
                index.insert(name.clone(), shapes.len());
                shapes.push(BodyShape {
                    name,
                    lengths,
                    base_angle_deg: angle,
                    points_a: vec![],
                    points_b: vec![],
                    endpoint: None,
                });
                shapes.len() - 1
            }
        };
        let shape = &mut shapes[at];
        match table.text(row, "chain").as_deref() {
            Some("a") => shape.points_a.push(point),
            Some("b") => shape.points_b.push(point),
            Some("endpoint") if shape.endpoint.is_none() => shape.endpoint = Some(point),
            other => {
                return Err(InputError::Invalid {
                    field: format!("{source} row {}, column chain", row.0),
                    value: crate::error::quoted(other.unwrap_or("")),
                    allowed: "a, b or endpoint (one endpoint per shape)".into(),
                })
            }
        }
    }
    Ok(shapes)
}

/// Distance (m) from `p` to a polyline.
pub fn distance_to_polyline(p: [f64; 2], line: &[[f64; 2]]) -> f64 {
    let mut best = f64::INFINITY;
    for w in line.windows(2) {
        let (a, b) = (w[0], w[1]);
        let d = [b[0] - a[0], b[1] - a[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        let t = if len2 > 0.0 { (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0) } else { 0.0 };
        best = best.min((p[0] - a[0] - t * d[0]).hypot(p[1] - a[1] - t * d[1]));
    }
    if line.len() == 1 {
        best = (p[0] - line[0][0]).hypot(p[1] - line[0][1]);
    }
    best
}

/// What to fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fit {
    /// The joint stiffness `k` only.
    Stiffness,
    /// `k` and the element mass `m`.
    StiffnessAndMass,
}

/// The result of a fit.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Calibration {
    /// Fitted joint stiffness `k` (N m/rad).
    pub stiffness_nm_per_rad: f64,
    /// Its standard error (N m/rad).
    pub stiffness_std_error_nm_per_rad: f64,
    /// Element mass (kg): fitted, or the robot's.
    pub element_mass_kg: f64,
    /// Its standard error (kg) when fitted.
    pub element_mass_std_error_kg: Option<f64>,
    /// Root-mean-square point residual (mm).
    pub rms_residual_mm: f64,
    /// Largest point residual (mm).
    pub max_residual_mm: f64,
    /// Measured points used.
    pub points: usize,
    /// Levenberg-Marquardt iterations.
    pub iterations: usize,
    /// Shape parameter `Pi` of the fitted tube.
    pub shape_parameter: f64,
}

/// Why a fit could not be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    /// Bad or insufficient data.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The model could not be solved even at the starting parameters.
    #[error("the model cannot be solved for these measurements at the starting parameters: {0}")]
    Model(String),
    /// The predicted points do not move with the stiffness (the data are out
    /// of the model's reach, or the tube is far too soft or stiff to start with).
    #[error("the measured points do not depend on the stiffness here: check the data's units and the starting robot (--shape-parameter)")]
    Insensitive,
    /// The deadline ran out (or the job was cancelled) first.
    #[error("stopped: {0}")]
    Stopped(#[from] Stopped),
    /// The data do not determine the mass.
    #[error("the element mass is not determined by these data (a single tube sags by Pi = k/(m g l) alone): add body shapes (the payload sets the scale) or sag data with tip_mass_kg, or fit the stiffness only")]
    MassNotIdentifiable,
}

/// Everything the fit compares: measured tubes and bodies.
struct Problem<'a> {
    robot: &'a Robot,
    sag: &'a [SagTube],
    shapes: &'a [BodyShape],
    fit: Fit,
    /// Residual rows: one per measured point.
    points: usize,
    /// The default solver bounded by the fit's deadline.
    solver: Solver,
}

impl Problem<'_> {
    fn robot_at(&self, x: &[f64]) -> Result<Robot, String> {
        let mass = if self.fit == Fit::StiffnessAndMass { x[1].exp() } else { self.robot.tube.element_mass_kg };
        self.robot.with_tube(x[0].exp(), mass).map_err(|e| e.to_string())
    }

    /// Point residuals (m), or why the model could not be solved.
    fn residuals(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        let robot = self.robot_at(x)?;
        let solver = &self.solver;
        let mut out = Vec::new();
        for tube in self.sag {
            let r = robot.with_base_angle(tube.base_angle_deg).map_err(|e| e.to_string())?;
            let cantilever = r.cantilever(tube.length, tube.tip_mass).map_err(|e| e.to_string())?;
            let eq = cantilever.solve(solver).map_err(|e| e.to_string())?;
            let line = cantilever.chain().points(&eq.q);
            if tube.points.len() == 1 {
                out.push(distance_to_polyline(tube.points[0], &line[line.len() - 1..]));
            } else {
                out.extend(tube.points.iter().map(|p| distance_to_polyline(*p, &line)));
            }
        }
        for shape in self.shapes {
            let (body, q) = solve_shape(&robot, shape, solver)?;
            let (qa, qb) = body.split(&q);
            let (line_a, line_b) = (body.chain_a().points(qa), body.chain_b().points(qb));
            out.extend(shape.points_a.iter().map(|p| distance_to_polyline(*p, &line_a)));
            out.extend(shape.points_b.iter().map(|p| distance_to_polyline(*p, &line_b)));
            if let Some(e) = shape.endpoint {
                let tip = body.endpoint(&q);
                out.push((e[0] - tip[0]).hypot(e[1] - tip[1]));
            }
        }
        Ok(out)
    }
}

fn solve_shape(robot: &Robot, shape: &BodyShape, solver: &Solver) -> Result<(Body, Vec<f64>), String> {
    let name = quoted(&shape.name);
    let r = robot.with_base_angle(shape.base_angle_deg).map_err(|e| format!("shape {name}: {e}"))?;
    let body = r.body(shape.lengths[0], shape.lengths[1]).map_err(|e| format!("shape {name}: {e}"))?;
    let eq = body.solve(solver).map_err(|e| format!("shape {name}: {e}"))?;
    Ok((body, eq.q))
}

fn check_data(robot: &Robot, sag: &[SagTube], shapes: &[BodyShape], parameters: usize) -> Result<usize, InputError> {
    for tube in sag {
        robot.check_tube_length(&format!("sag tube_length_m {}", tube.length), tube.length)?;
        crate::error::within("sag base_angle_deg", tube.base_angle_deg, -360.0, 360.0)?;
        crate::error::non_negative("sag tip_mass_kg", tube.tip_mass)?;
    }
    for shape in shapes {
        let name = quoted(&shape.name);
        robot.check_tube_length(&format!("shape {name} la_m"), shape.lengths[0])?;
        robot.check_tube_length(&format!("shape {name} lb_m"), shape.lengths[1])?;
        crate::error::within("shape base_angle_deg", shape.base_angle_deg, -360.0, 360.0)?;
        // Too few elements for the plate's three constraints is bad data, not a failed fit.
        robot.body(shape.lengths[0], shape.lengths[1]).map_err(|e| match e {
            InputError::Invalid { value, allowed, .. } => {
                InputError::Invalid { field: format!("shape {name} (la_m, lb_m)"), value, allowed }
            }
            e => e,
        })?;
    }
    let points: usize = sag.iter().map(|t| t.points.len()).sum::<usize>()
        + shapes.iter().map(|s| s.points_a.len() + s.points_b.len() + usize::from(s.endpoint.is_some())).sum::<usize>();
    if points <= parameters {
        return Err(InputError::invalid(
            "measured points",
            points as f64,
            format!("more than {parameters} (the parameters fitted)"),
        ));
    }
    // Points at the clamp are where every model puts the tube: no information.
    let informative =
        sag.iter().flat_map(|t| t.points.iter()).any(|p| p[0].hypot(p[1]) > 1e-3 * robot.tube.element_length_m)
            || !shapes.is_empty();
    if !informative {
        return Err(InputError::Invalid {
            field: "sag points".into(),
            value: "all at the clamp".into(),
            allowed: "points along the tube away from the clamp".into(),
        });
    }
    Ok(points)
}

/// Central-difference step on `ln k` and `ln m`: a relative change of 1e-5,
/// far above the solves' 1e-11 and far below the parameters' uncertainty.
const LOG_STEP: f64 = 1e-5;

impl LeastSquares for Problem<'_> {
    type Error = String;

    fn rows(&self) -> usize {
        self.points
    }

    fn residual(&mut self, x: &[f64], r: &mut [f64]) -> Result<(), String> {
        r.copy_from_slice(&self.residuals(x)?);
        Ok(())
    }

    fn jacobian(&mut self, x: &[f64], r: &[f64], jac: &mut [f64]) -> Result<(), String> {
        let mut scratch = vec![0.0; r.len()];
        central_differences(x, LOG_STEP, &[UNBOUNDED; 2][..x.len()], jac, &mut scratch, |y, out| {
            out.copy_from_slice(&self.residuals(y)?);
            Ok(())
        })
    }
}

/// The default solver bounded by `deadline`.
fn bounded(deadline: &Deadline) -> Solver {
    Solver::new(SolverOptions { deadline: deadline.clone(), ..SolverOptions::default() })
}

/// Fits `k` (and `m`) of `robot`'s tube to the measurements, within
/// `deadline` (checked by every solve; a fit it stops is
/// [`CalibrationError::Stopped`]).
pub fn calibrate(
    robot: &Robot,
    sag: &[SagTube],
    shapes: &[BodyShape],
    fit: Fit,
    deadline: &Deadline,
) -> Result<Calibration, CalibrationError> {
    robot.validate()?;
    let p = if fit == Fit::Stiffness { 1 } else { 2 };
    let n = check_data(robot, sag, shapes, p)?;
    let mut problem = Problem { robot, sag, shapes, fit, points: n, solver: bounded(deadline) };
    let mut x = vec![robot.tube.joint_stiffness_nm_per_rad.ln()];
    if fit == Fit::StiffnessAndMass {
        x.push(robot.tube.element_mass_kg.ln());
    }
    // The logarithms need no bounds: k and m are positive by construction.
    // The covariance needs the curvature at the fit itself.
    let options = Options { jacobian_at_solution: true, ..Options::default() };
    let result = levenberg_marquardt(&mut problem, &x, &[UNBOUNDED; 2][..p], &options);
    // A solve the deadline stopped fails the evaluation: say so, not why the solve failed.
    deadline.guard(result.iterations, options.max_iterations, "fit iterations")?;
    if let Stop::EvaluationFailed(e) = result.stop {
        return Err(CalibrationError::Model(e));
    }
    let jtj = result.jtj.expect("the Jacobian at the solution was asked for and evaluated");
    let undetermined = if p == 2 { CalibrationError::MassNotIdentifiable } else { CalibrationError::Insensitive };
    let covariance = jtj.inverse().ok_or(undetermined)?;
    if p == 2 {
        // The correlation of ln k and ln m tends to 1 when only Pi is seen.
        let correlation = covariance[(0, 1)] / (covariance[(0, 0)] * covariance[(1, 1)]).sqrt();
        if !(correlation.abs() < 1.0 - 1e-6) {
            return Err(CalibrationError::MassNotIdentifiable);
        }
    }
    let rss = 2.0 * result.cost;
    let sigma2 = rss / (n - p).max(1) as f64;
    let k = result.x[0].exp();
    let m = if p == 2 { result.x[1].exp() } else { robot.tube.element_mass_kg };
    let fitted = robot.with_tube(k, m).map_err(|e| CalibrationError::Model(e.to_string()))?;
    Ok(Calibration {
        stiffness_nm_per_rad: k,
        stiffness_std_error_nm_per_rad: k * (sigma2 * covariance[(0, 0)]).sqrt(),
        element_mass_kg: m,
        element_mass_std_error_kg: (p == 2).then(|| m * (sigma2 * covariance[(1, 1)]).sqrt()),
        rms_residual_mm: 1e3 * (rss / n as f64).sqrt(),
        max_residual_mm: 1e3 * result.residual.iter().fold(0.0f64, |a, v| a.max(v.abs())),
        points: n,
        iterations: result.iterations,
        shape_parameter: fitted.shape_parameter(),
    })
}

/// How far a model's shape is from a measured body.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ShapeError {
    /// RMS of the point-to-curve distances (mm).
    pub rms_mm: f64,
    /// Largest point-to-curve distance (mm).
    pub max_mm: f64,
    /// Endpoint distance (mm), when the endpoint was measured.
    pub endpoint_mm: Option<f64>,
}

/// Both models against one measured body.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ShapeComparison {
    /// Shape name.
    pub shape: String,
    /// Tube lengths (m).
    pub lengths_m: [f64; 2],
    /// The two-chain model.
    pub two_chain: ShapeError,
    /// The constant-curvature model.
    pub constant_curvature: ShapeError,
}

fn shape_error(shape: &BodyShape, line_a: &[[f64; 2]], line_b: &[[f64; 2]], tip: [f64; 2]) -> ShapeError {
    let d: Vec<f64> = shape
        .points_a
        .iter()
        .map(|p| distance_to_polyline(*p, line_a))
        .chain(shape.points_b.iter().map(|p| distance_to_polyline(*p, line_b)))
        .collect();
    let endpoint_mm = shape.endpoint.map(|e| 1e3 * (e[0] - tip[0]).hypot(e[1] - tip[1]));
    let all: Vec<f64> = d.iter().copied().chain(endpoint_mm.map(|e| e / 1e3)).collect();
    let rms = (all.iter().map(|v| v * v).sum::<f64>() / all.len().max(1) as f64).sqrt();
    ShapeError { rms_mm: 1e3 * rms, max_mm: 1e3 * all.iter().fold(0.0f64, |a, v| a.max(*v)), endpoint_mm }
}

/// The two-chain and constant-curvature models against measured bodies,
/// within `deadline` (checked by every solve).
pub fn compare(
    robot: &Robot,
    shapes: &[BodyShape],
    deadline: &Deadline,
) -> Result<Vec<ShapeComparison>, CalibrationError> {
    robot.validate()?;
    check_data(robot, &[], shapes, 0)?;
    let solver = bounded(deadline);
    shapes
        .iter()
        .enumerate()
        .map(|(i, shape)| {
            deadline.guard(i, shapes.len(), "shapes")?;
            let (body, q) =
                solve_shape(robot, shape, &solver).map_err(|e| match deadline.guard(i, shapes.len(), "shapes") {
                    Err(stopped) => stopped.into(),
                    Ok(()) => CalibrationError::Model(e),
                })?;
            let (qa, qb) = body.split(&q);
            let two_chain =
                shape_error(shape, &body.chain_a().points(qa), &body.chain_b().points(qb), body.endpoint(&q));
            let r = robot.with_base_angle(shape.base_angle_deg).map_err(|e| CalibrationError::Model(e.to_string()))?;
            let cc = PlanarBody::of(&r);
            let (a, b) = cc.chain_points(shape.lengths[0], shape.lengths[1], 200);
            let tip = cc.pose(shape.lengths[0], shape.lengths[1]).endpoint;
            Ok(ShapeComparison {
                shape: shape.name.clone(),
                lengths_m: shape.lengths,
                two_chain,
                constant_curvature: shape_error(shape, &a, &b, tip),
            })
        })
        .collect()
}

/// Synthetic measurements made by the model itself, for examples and tests:
/// points every `spacing` m of arc length along each tube, plus Gaussian noise
/// of standard deviation `noise` (m) on each coordinate, from a seeded
/// generator (the same seed gives the same data).
pub mod synthetic {
    use super::{BodyShape, SagTube};
    use crate::robot::Robot;
    use crate::statics::Solver;

    /// A small deterministic generator of normal deviates (xorshift + Box-Muller).
    pub struct Noise {
        state: u64,
        spare: Option<f64>,
    }

    impl Noise {
        /// A generator from a seed.
        pub fn new(seed: u64) -> Noise {
            Noise { state: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1, spare: None }
        }

        fn uniform(&mut self) -> f64 {
            self.state ^= self.state << 13;
            self.state ^= self.state >> 7;
            self.state ^= self.state << 17;
            ((self.state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }

        /// A standard normal deviate.
        pub fn normal(&mut self) -> f64 {
            if let Some(s) = self.spare.take() {
                return s;
            }
            let (u, v) = (self.uniform(), self.uniform());
            let r = (-2.0 * u.ln()).sqrt();
            self.spare = Some(r * (2.0 * std::f64::consts::PI * v).sin());
            r * (2.0 * std::f64::consts::PI * v).cos()
        }
    }

    /// Points every `spacing` along a polyline (from its start, excluded, to its end).
    fn sample(line: &[[f64; 2]], spacing: f64) -> Vec<[f64; 2]> {
        let mut out = Vec::new();
        let mut next = spacing;
        let mut walked = 0.0;
        for w in line.windows(2) {
            let len = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
            while next <= walked + len + 1e-12 && len > 0.0 {
                let t = ((next - walked) / len).min(1.0);
                out.push([w[0][0] + t * (w[1][0] - w[0][0]), w[0][1] + t * (w[1][1] - w[0][1])]);
                next += spacing;
            }
            walked += len;
        }
        out
    }

    fn noisy(points: Vec<[f64; 2]>, noise: f64, rng: &mut Noise) -> Vec<[f64; 2]> {
        points.into_iter().map(|p| [p[0] + noise * rng.normal(), p[1] + noise * rng.normal()]).collect()
    }

    /// Sag measurements of tubes of the given lengths clamped at `angle_deg`.
    pub fn sag(robot: &Robot, lengths: &[f64], angle_deg: f64, spacing: f64, noise: f64, seed: u64) -> Vec<SagTube> {
        let mut rng = Noise::new(seed);
        let r = robot.with_base_angle(angle_deg).expect("valid synthetic angle");
        lengths
            .iter()
            .map(|&length| {
                let tube = r.cantilever(length, 0.0).expect("valid synthetic tube");
                let eq = tube.solve(&Solver::default()).expect("synthetic tube solves");
                let points = noisy(sample(&tube.chain().points(&eq.q), spacing), noise, &mut rng);
                SagTube { length, base_angle_deg: angle_deg, tip_mass: 0.0, points }
            })
            .collect()
    }

    /// Body shapes for the given tube lengths at `angle_deg`.
    pub fn shapes(
        robot: &Robot,
        lengths: &[[f64; 2]],
        angle_deg: f64,
        spacing: f64,
        noise: f64,
        seed: u64,
    ) -> Vec<BodyShape> {
        let mut rng = Noise::new(seed ^ 0x5EED);
        let r = robot.with_base_angle(angle_deg).expect("valid synthetic angle");
        lengths
            .iter()
            .map(|&[la, lb]| {
                let body = r.body(la, lb).expect("valid synthetic body");
                let eq = body.solve(&Solver::default()).expect("synthetic body solves");
                let (qa, qb) = body.split(&eq.q);
                let tip = body.endpoint(&eq.q);
                BodyShape {
                    name: format!("LA{:.0}_LB{:.0}", la * 1e3, lb * 1e3),
                    lengths: [la, lb],
                    base_angle_deg: angle_deg,
                    points_a: noisy(sample(&body.chain_a().points(qa), spacing), noise, &mut rng),
                    points_b: noisy(sample(&body.chain_b().points(qb), spacing), noise, &mut rng),
                    endpoint: Some([tip[0] + noise * rng.normal(), tip[1] + noise * rng.normal()]),
                }
            })
            .collect()
    }
}
