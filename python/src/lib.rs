//! `leech._leech`: the native half of the Python package `leech`.
//!
//! Thin by design: every capability is the Rust library's public API; this
//! crate converts arguments, releases the interpreter's lock around each
//! solve (`Python::detach`) and converts results. Reports cross as the JSON
//! the command line prints (the same serde types, so the same names and
//! digits); arrays cross as NumPy arrays. The pure-Python half
//! (`leech/__init__.py`) wraps both in result objects.
//!
//! Errors: a library `InputError` raises `leech.InputError` (a
//! `ValueError`) with `field`, `value` and `allowed`; a failed solve raises
//! `leech.SolveError` (a `RuntimeError`) with `status`, `iterations`,
//! `residual`; a failed fit raises `leech.CalibrationError`. Nothing here
//! unwraps user input; a panic would reach Python as pyo3's PanicException,
//! never unwind across the interpreter.

use std::collections::HashMap;
use std::path::PathBuf;

use leech::batch::{self, BatchOptions, Outcome, Query};
use leech::budget::Deadline;
use leech::calibration::{self, CalibrationError as LibCalibrationError, Fit};
use leech::constant_curvature::PlanarBody;
use leech::error::InputError as LibInputError;
use leech::inverse_statics::Reacher as LibReacher;
use leech::report::{BodyReport, ClimbReport, ConstantCurvatureReport, ShapeReport, StanceReport};
use leech::robot::Robot as LibRobot;
use leech::scene::Scene;
use leech::stance::{self, FreeCups, Hold, Pose, StanceError};
use leech::statics::{SolveError as LibSolveError, Solver};
use leech::stride::{PlanOptions, Scenario};
use leech::sweep::{Grid, Model, SweepOptions};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

pyo3::create_exception!(leech, InputError, PyValueError, "Bad input: `field`, `value` and what is `allowed`.");
pyo3::create_exception!(leech, SolveError, PyRuntimeError, "A solve that failed: `status`, `iterations`, `residual`.");
pyo3::create_exception!(leech, CalibrationError, PyRuntimeError, "A fit that could not be made.");

/// An exception of type `T` with `message` and the given attributes set.
fn raise<T: pyo3::PyTypeInfo>(py: Python<'_>, message: String, attributes: &[(&str, Py<PyAny>)]) -> PyErr {
    let err = PyErr::new::<T, _>(message);
    let value = err.value(py);
    for (name, v) in attributes {
        // Setting an attribute on a fresh exception instance cannot fail.
        let _ = value.setattr(*name, v);
    }
    err
}

fn input_error(e: LibInputError) -> PyErr {
    Python::attach(|py| {
        let message = e.to_string();
        let (field, value, allowed) = match e {
            LibInputError::Invalid { field, value, allowed } => (field, value, allowed),
            LibInputError::Toml { message } => ("robot file".into(), String::new(), message),
            LibInputError::File { file, message } => (file, String::new(), message),
            LibInputError::Unreadable { field, file, allowed, .. } => (field, file, allowed),
        };
        let s = |t: String| t.into_pyobject(py).map(|o| o.into_any().unbind());
        match (s(field), s(value), s(allowed)) {
            (Ok(f), Ok(v), Ok(a)) => raise::<InputError>(py, message, &[("field", f), ("value", v), ("allowed", a)]),
            _ => PyValueError::new_err(message),
        }
    })
}

fn solve_error(e: &LibSolveError, status_override: Option<&str>) -> PyErr {
    Python::attach(|py| {
        let (status, iterations, residual) = match e {
            LibSolveError::NotConverged { iterations, residual, .. } => ("not_converged", Some(*iterations), *residual),
            LibSolveError::Stopped { iterations, residual, .. } => ("stopped", Some(*iterations), *residual),
            LibSolveError::BadStart { .. } => ("bad_start", None, f64::NAN),
        };
        let status = status_override.unwrap_or(status);
        let attrs = (
            status.into_pyobject(py).map(|o| o.into_any().unbind()),
            iterations.into_pyobject(py).map(|o| o.into_any().unbind()),
            residual.into_pyobject(py).map(|o| o.into_any().unbind()),
        );
        match attrs {
            (Ok(s), Ok(i), Ok(r)) => {
                raise::<SolveError>(py, e.to_string(), &[("status", s), ("iterations", i), ("residual", r)])
            }
            _ => PyRuntimeError::new_err(e.to_string()),
        }
    })
}

fn stance_error(e: StanceError) -> PyErr {
    match e {
        StanceError::Input(e) => input_error(e),
        StanceError::Solve(e) => solve_error(&e, None),
        StanceError::OutOfReach { ref source, .. } => {
            let err = solve_error(source, Some("out_of_reach"));
            Python::attach(|py| {
                let _ = err.value(py).setattr("args", (e.to_string(),));
            });
            err
        }
    }
}

/// A job stopped by its deadline (Python jobs have none but a climb's
/// `time_limit_s`; a cancel flag may stop them too).
fn stopped_error(e: leech::budget::Stopped) -> PyErr {
    pyo3::exceptions::PyTimeoutError::new_err(e.to_string())
}

/// A sweep's or an inverse solve's failure: bad input or stopped.
fn job_error(e: leech::error::JobError) -> PyErr {
    match e {
        leech::error::JobError::Input(e) => input_error(e),
        leech::error::JobError::Stopped(e) => stopped_error(e),
    }
}

fn calibration_error(e: LibCalibrationError) -> PyErr {
    match e {
        LibCalibrationError::Input(e) => input_error(e),
        other => CalibrationError::new_err(other.to_string()),
    }
}

fn to_json(value: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| PyRuntimeError::new_err(format!("serializing the result: {e}")))
}

/// A file's text through the library's one reading layer (caps, UTF-8,
/// no FIFO hang), its errors as `InputError`s.
fn read_text(path: &std::path::Path, field: &str, cap: leech::files::Cap) -> PyResult<String> {
    leech::files::read_text(path, field, cap).map_err(input_error)
}

/// A built-in item by name (`builtin`), else a file read with `parse`;
/// `field` and `names` (the built-in names) say what was expected.
fn load_named<T>(
    given: &str,
    field: &str,
    builtin: impl Fn(&str) -> Result<T, LibInputError>,
    names: Vec<&str>,
    parse: impl Fn(&str, &str) -> Result<T, LibInputError>,
) -> PyResult<T> {
    if let Ok(item) = builtin(given) {
        return Ok(item);
    }
    let path = PathBuf::from(given);
    if !path.exists() {
        return Err(input_error(LibInputError::Invalid {
            field: field.into(),
            value: given.into(),
            allowed: format!("a {field} file or one of {}", names.join(", ")),
        }));
    }
    parse(&read_text(&path, field, leech::files::SCENE_FILE)?, given).map_err(input_error)
}

/// A built-in scene by name, else a scene file.
fn load_scene(given: &str) -> PyResult<Scene> {
    let names = Scene::builtin_names().map(|(n, _)| n).collect();
    load_named(given, "scene", Scene::builtin, names, Scene::from_toml_str)
}

/// A built-in scenario by name, else a scenario file.
fn load_scenario(given: &str) -> PyResult<Scenario> {
    let names = Scenario::builtin_names().map(|(n, _)| n).collect();
    load_named(given, "scenario", Scenario::builtin, names, Scenario::parse)
}

fn pose(field: &str, p: [f64; 3]) -> PyResult<Pose> {
    let check = |name: &str, v: f64, lo: f64, hi: f64| leech::error::within(&format!("{field} {name}"), v, lo, hi);
    let m = 1e3;
    let point = [check("x (m)", p[0], -m, m).map_err(input_error)?, check("y (m)", p[1], -m, m).map_err(input_error)?];
    Ok(Pose::from_deg(point, check("angle (deg)", p[2], -720.0, 720.0).map_err(input_error)?))
}

/// A robot: the built-in LEeCH, a robot file, or one derived from either.
#[pyclass(frozen, name = "Robot", module = "leech")]
struct Robot {
    inner: LibRobot,
}

fn derived(r: Result<LibRobot, LibInputError>) -> PyResult<Robot> {
    r.map(|inner| Robot { inner }).map_err(input_error)
}

#[pymethods]
impl Robot {
    /// The built-in robot (estimated LEeCH parameters).
    #[staticmethod]
    fn builtin() -> Robot {
        Robot { inner: LibRobot::builtin() }
    }

    /// A robot file's text (TOML).
    #[staticmethod]
    fn from_toml(text: &str) -> PyResult<Robot> {
        derived(LibRobot::from_toml_str(text))
    }

    /// A robot file (TOML).
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Robot> {
        let text = read_text(&path, "robot file", leech::files::ROBOT_FILE)?;
        LibRobot::from_toml_str(&text)
            .map(|inner| Robot { inner })
            .map_err(|e| input_error(with_source(e, &path.display().to_string())))
    }

    /// A robot from its file's tables as JSON text (what `to_json` gives).
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Robot> {
        let value: toml::Value = serde_json::from_str(text)
            .map_err(|e| input_error(LibInputError::Toml { message: format!("not a robot's tables: {e}") }))?;
        let toml = toml::to_string(&value)
            .map_err(|e| input_error(LibInputError::Toml { message: format!("not a robot's tables: {e}") }))?;
        derived(LibRobot::from_toml_str(&toml))
    }

    /// The robot's file as TOML.
    fn to_toml(&self) -> String {
        self.inner.to_toml_string()
    }

    /// The robot as JSON (`leech robot --json`).
    fn to_json(&self) -> PyResult<String> {
        to_json(&self.inner)
    }

    /// The robot's name.
    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }

    /// Shape parameter `Pi = k/(m g l)` of one tube.
    #[getter]
    fn shape_parameter(&self) -> f64 {
        self.inner.shape_parameter()
    }

    /// The driving unit's base angle (deg).
    #[getter]
    fn base_angle_deg(&self) -> f64 {
        self.inner.world.base_angle_deg
    }

    /// This robot with the stiffness that gives shape parameter `pi`.
    fn with_shape_parameter(&self, pi: f64) -> PyResult<Robot> {
        derived(self.inner.with_shape_parameter(pi))
    }

    /// This robot with the driving unit at `degrees`.
    fn with_base_angle(&self, degrees: f64) -> PyResult<Robot> {
        derived(self.inner.with_base_angle(degrees))
    }

    /// This robot under gravity `g` (m/s^2).
    fn with_gravity(&self, g: f64) -> PyResult<Robot> {
        derived(self.inner.with_gravity(g))
    }

    /// This robot with joint stiffness `stiffness` (N m/rad) and element mass `element_mass` (kg).
    fn with_tube(&self, stiffness: f64, element_mass: f64) -> PyResult<Robot> {
        derived(self.inner.with_tube(stiffness, element_mass))
    }

    /// This robot with every length scaled by `factor`.
    fn scaled(&self, factor: f64) -> PyResult<Robot> {
        derived(self.inner.scaled(factor))
    }

    /// This robot named `name`.
    fn with_name(&self, name: String) -> Robot {
        Robot { inner: self.inner.with_name(name) }
    }

    /// `leech shape --json` for the two-chain model, as JSON text.
    #[pyo3(signature = (la, lb, scene=None, hold="rear", rear=None, front=None, free_cups="pass-through"))]
    #[allow(clippy::too_many_arguments)]
    fn shape_json(
        &self,
        py: Python<'_>,
        la: f64,
        lb: f64,
        scene: Option<&str>,
        hold: &str,
        rear: Option<[f64; 3]>,
        front: Option<[f64; 3]>,
        free_cups: &str,
    ) -> PyResult<String> {
        let scene = scene.map(load_scene).transpose()?;
        let free_cups = match free_cups {
            "pass-through" => FreeCups::PassThrough,
            "rest" => FreeCups::Rest,
            other => return Err(invalid("free_cups", other, "pass-through or rest")),
        };
        let rear = rear.map(|p| pose("rear", p)).transpose()?;
        // As on the command line: --rear's angle, else a scene's start, sets the base angle.
        let start = scene.as_ref().and_then(|s| s.start).filter(|_| rear.is_none());
        let angle = rear.map(|p| p.angle_rad).or(start.map(|s| s.direction_rad));
        let robot = match angle {
            Some(a) => self.inner.with_base_angle(a.to_degrees()).map_err(input_error)?,
            None => self.inner.clone(),
        };
        let rear = rear
            .or(start.map(|s| stance::rear_pose_for_cup(&robot, s.rear_cup_m, s.direction_rad)))
            .unwrap_or_else(|| Pose::from_deg([0.0, 0.0], robot.world.base_angle_deg));
        let front = front.map(|p| pose("front", p)).transpose()?;
        let hold = match (hold, front) {
            ("rear", None) => Hold::Rear(rear),
            ("front", Some(front)) => Hold::Front(front),
            ("both", Some(front)) => Hold::Both { rear, front },
            ("rear", Some(_)) => return Err(invalid("front", "given", "only with hold front or both")),
            ("front" | "both", None) => return Err(invalid("front", "missing", "(x, y, deg) of the endpoint")),
            (other, _) => return Err(invalid("hold", other, "rear, front or both")),
        };
        let body = robot.body(la, lb).map_err(input_error)?;
        let clamped = scene.is_none() && hold == Hold::Rear(Pose::from_deg([0.0, 0.0], robot.world.base_angle_deg));
        let solver = Solver::default();
        let report = py.detach(|| -> Result<ShapeReport, StanceError> {
            let (body_report, held) = if clamped {
                let eq = body.solve(&solver)?;
                let held = stance::rear_held(&robot, &body, &eq, rear, &solver)?;
                (BodyReport::new(&robot.name, robot.shape_parameter(), &body, &eq), held)
            } else {
                let held = match &scene {
                    Some(s) => stance::solve_among(&robot, [la, lb], hold, s, &solver, free_cups)?,
                    None => stance::solve(&robot, [la, lb], hold, &solver)?,
                };
                (BodyReport::held(&robot, &held), held)
            };
            let cups = held.cups(&robot)?;
            let stance = StanceReport::new(&robot, &held, scene.as_ref(), &cups);
            Ok(ShapeReport { body: body_report, stance })
        });
        to_json(&report.map_err(stance_error)?)
    }

    /// `leech shape --model constant-curvature --json`, as JSON text.
    #[pyo3(signature = (la, lb, samples=60))]
    fn constant_curvature_json(&self, la: f64, lb: f64, samples: usize) -> PyResult<String> {
        // The body checks the lengths for both models, as on the command line.
        self.inner.body(la, lb).map_err(input_error)?;
        if !(2..=100_000).contains(&samples) {
            return Err(invalid("samples", &samples.to_string(), "2 to 100000 points per arc"));
        }
        to_json(&ConstantCurvatureReport::new(&PlanarBody::of(&self.inner), la, lb, samples))
    }

    /// The batch solve ([`leech::batch`]): arrays of outcomes; the failed
    /// entries' indices, each with the index of its reason in `reasons`.
    #[pyo3(signature = (la, lb, base_angle_deg=None, warm_step_m=batch::WARM_STEP_M))]
    #[allow(clippy::type_complexity)]
    fn shapes<'py>(
        &self,
        py: Python<'py>,
        la: PyReadonlyArray1<'py, f64>,
        lb: PyReadonlyArray1<'py, f64>,
        base_angle_deg: Option<PyReadonlyArray1<'py, f64>>,
        warm_step_m: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (la, lb) = (la.as_slice()?, lb.as_slice()?);
        let angles = base_angle_deg.as_ref().map(|a| a.as_slice()).transpose()?;
        let query = Query { la_m: la, lb_m: lb, base_angle_deg: angles };
        let n = query.len().map_err(input_error)?;
        let options = BatchOptions { warm_step_m };
        let endpoint = PyArray2::<f64>::zeros(py, [n, 2], false);
        let angle = PyArray1::<f64>::zeros(py, n, false);
        let min_radius = PyArray1::<f64>::zeros(py, n, false);
        let status = PyArray1::<u8>::zeros(py, n, false);
        let [stable, warm, snapped] = [0; 3].map(|_| PyArray1::<bool>::zeros(py, n, false));
        let mut reasons: HashMap<String, u32> = HashMap::new();
        let (mut failure_index, mut failure_reason) = (Vec::new(), Vec::new());
        // Blocks of whole chunks: the results of one solve of the whole
        // batch, with one block of outcomes in memory beside the arrays.
        let block = 64 * batch::CHUNK;
        let mut outcomes = vec![Outcome::default(); block.min(n)];
        for start in (0..n).step_by(block) {
            let end = (start + block).min(n);
            let piece =
                Query { la_m: &la[start..end], lb_m: &lb[start..end], base_angle_deg: angles.map(|a| &a[start..end]) };
            let out = &mut outcomes[..end - start];
            let found = py.detach(|| batch::solve(&self.inner, &piece, &options, out)).map_err(input_error)?;
            for f in found {
                // Reasons repeat (every NaN LA reads alike): each is kept once.
                let next = reasons.len() as u32;
                let code = *reasons.entry(f.reason).or_insert(next);
                failure_index.push((start + f.index) as u64);
                failure_reason.push(code);
            }
            // The arrays are this call's own, not yet shared: writing is safe.
            let mut e = endpoint.readwrite();
            let e = e.as_slice_mut()?;
            let (mut a, mut r, mut s) = (angle.readwrite(), min_radius.readwrite(), status.readwrite());
            let (a, r, s) = (a.as_slice_mut()?, r.as_slice_mut()?, s.as_slice_mut()?);
            let (mut st, mut w, mut sn) = (stable.readwrite(), warm.readwrite(), snapped.readwrite());
            let (st, w, sn) = (st.as_slice_mut()?, w.as_slice_mut()?, sn.as_slice_mut()?);
            for (k, o) in out.iter().enumerate() {
                let i = start + k;
                e[2 * i] = o.endpoint_m[0];
                e[2 * i + 1] = o.endpoint_m[1];
                a[i] = o.endpoint_angle_rad;
                r[i] = o.min_bend_radius_m;
                s[i] = o.status as u8;
                st[i] = o.stable;
                w[i] = o.warm;
                sn[i] = o.snapped;
            }
        }
        let d = PyDict::new(py);
        d.set_item("endpoint_m", endpoint)?;
        d.set_item("endpoint_angle_rad", angle)?;
        d.set_item("min_bend_radius_m", min_radius)?;
        d.set_item("status", status)?;
        d.set_item("stable", stable)?;
        d.set_item("warm", warm)?;
        d.set_item("snapped", snapped)?;
        let mut texts = vec![String::new(); reasons.len()];
        for (text, code) in reasons {
            texts[code as usize] = text;
        }
        d.set_item("failure_index", PyArray1::from_vec(py, failure_index))?;
        d.set_item("failure_reason", PyArray1::from_vec(py, failure_reason))?;
        d.set_item("reasons", texts)?;
        Ok(d)
    }

    /// `leech workspace`: every point's columns (as the CSV's) and the
    /// summaries as JSON text.
    #[pyo3(signature = (min_m, max_m, step_m, shape_parameters=Vec::new(), models=vec!["two-chain".to_string()], left_longer=false))]
    #[allow(clippy::too_many_arguments)]
    fn workspace<'py>(
        &self,
        py: Python<'py>,
        min_m: f64,
        max_m: f64,
        step_m: f64,
        shape_parameters: Vec<f64>,
        models: Vec<String>,
        left_longer: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let models = models
            .iter()
            .map(|m| match m.as_str() {
                "two-chain" => Ok(Model::TwoChain),
                "constant-curvature" => Ok(Model::ConstantCurvature),
                other => Err(invalid("models", other, "two-chain or constant-curvature")),
            })
            .collect::<PyResult<Vec<_>>>()?;
        for pi in &shape_parameters {
            leech::error::positive("shape parameter", *pi).map_err(input_error)?;
        }
        let grid = Grid::new(min_m, max_m, step_m).map_err(input_error)?;
        let options = SweepOptions { grid, shape_parameters, models, left_longer, deadline: Deadline::none() };
        let sweep = py.detach(|| leech::sweep::sweep(&self.inner, &options, &|_| {})).map_err(job_error)?;
        let p = &sweep.points;
        let column = |f: &dyn Fn(&leech::sweep::Point) -> f64| PyArray1::from_vec(py, p.iter().map(f).collect());
        let flag = |f: &dyn Fn(&leech::sweep::Point) -> bool| PyArray1::from_vec(py, p.iter().map(f).collect());
        let d = PyDict::new(py);
        d.set_item("model", p.iter().map(|x| x.model.name()).collect::<Vec<_>>())?;
        d.set_item("shape_parameter", column(&|x| x.shape_parameter.unwrap_or(f64::NAN)))?;
        d.set_item("la_m", column(&|x| x.lengths_m[0]))?;
        d.set_item("lb_m", column(&|x| x.lengths_m[1]))?;
        d.set_item(
            "status",
            p.iter().map(|x| if x.failure.is_none() { "converged" } else { "failed" }).collect::<Vec<_>>(),
        )?;
        d.set_item("stable", flag(&|x| x.stable))?;
        d.set_item("snapped", flag(&|x| x.snapped))?;
        d.set_item("feasible", flag(&|x| x.feasible))?;
        d.set_item("min_bend_radius_m", column(&|x| x.min_bend_radius_m))?;
        d.set_item("endpoint_x_m", column(&|x| x.endpoint_m[0]))?;
        d.set_item("endpoint_y_m", column(&|x| x.endpoint_m[1]))?;
        d.set_item("endpoint_angle_rad", column(&|x| x.endpoint_angle_rad))?;
        d.set_item("fresh_difference_m", column(&|x| x.fresh_difference_m))?;
        d.set_item("summaries_json", to_json(&sweep.summaries)?)?;
        Ok(d)
    }

    /// `leech calibrate`: the fit (JSON text) and the fitted robot. `sag` and
    /// `shapes` are CSV texts as the measurement files hold them.
    #[pyo3(signature = (sag, shapes=None, fit="stiffness"))]
    fn calibrate(&self, py: Python<'_>, sag: &str, shapes: Option<&str>, fit: &str) -> PyResult<(String, Robot)> {
        let fit = match fit {
            "stiffness" => Fit::Stiffness,
            "stiffness-and-mass" => Fit::StiffnessAndMass,
            other => return Err(invalid("fit", other, "stiffness or stiffness-and-mass")),
        };
        let sag = calibration::read_sag(sag, "sag").map_err(input_error)?;
        let shapes = shapes.map(|s| calibration::read_shapes(s, "shapes")).transpose().map_err(input_error)?;
        let shapes = shapes.as_deref().unwrap_or(&[]);
        let result = py
            .detach(|| calibration::calibrate(&self.inner, &sag, shapes, fit, &Deadline::none()))
            .map_err(calibration_error)?;
        let fitted = self.inner.with_tube(result.stiffness_nm_per_rad, result.element_mass_kg).map_err(input_error)?;
        Ok((to_json(&result)?, Robot { inner: fitted }))
    }

    /// `leech climb --json`: a plan for a scenario (built-in name or file), as JSON text.
    #[pyo3(signature = (scenario, time_limit_s=120.0))]
    fn climb_json(&self, py: Python<'_>, scenario: &str, time_limit_s: f64) -> PyResult<String> {
        let s = load_scenario(scenario)?;
        let limit = leech::error::within("time_limit_s", time_limit_s, 1e-3, 86_400.0).map_err(input_error)?;
        let options = PlanOptions {
            deadline: Deadline::after(std::time::Duration::from_secs_f64(limit)),
            ..PlanOptions::default()
        };
        let plan =
            py.detach(|| leech::stride::plan(&self.inner, &s.scene, s.start, s.goal, &options)).map_err(input_error)?;
        to_json(&ClimbReport::new(&s.name, &self.inner, &plan, s.goal.point_m, s.goal.tolerance_m))
    }

    /// A map for inverse statics over `grid` (min, max, step in m).
    fn reacher(&self, py: Python<'_>, min_m: f64, max_m: f64, step_m: f64) -> PyResult<Reacher> {
        let grid = Grid::new(min_m, max_m, step_m).map_err(input_error)?;
        let inner = py.detach(|| LibReacher::new(&self.inner, grid, Deadline::none())).map_err(job_error)?;
        Ok(Reacher { inner })
    }

    fn __repr__(&self) -> String {
        format!("Robot({:?}, shape_parameter={})", self.inner.name, self.inner.shape_parameter())
    }
}

/// Inverse statics over a map built once ([`leech::inverse_statics::Reacher`]).
#[pyclass(frozen, name = "Reacher", module = "leech")]
struct Reacher {
    inner: LibReacher,
}

#[pymethods]
impl Reacher {
    /// `leech reach --json`: tube lengths that put the endpoint on `(x, y)`
    /// (m), with the plate at `angle_deg` when given; JSON text.
    #[pyo3(signature = (x, y, angle_deg=None))]
    fn reach_json(&self, py: Python<'_>, x: f64, y: f64, angle_deg: Option<f64>) -> PyResult<String> {
        let within = leech::error::within;
        let target = [
            within("target x", x, -1e3, 1e3).map_err(input_error)?,
            within("target y", y, -1e3, 1e3).map_err(input_error)?,
        ];
        let angle = angle_deg
            .map(|d| within("angle (deg)", d, -720.0, 720.0).map(f64::to_radians))
            .transpose()
            .map_err(input_error)?;
        to_json(&py.detach(|| self.inner.reach(target, angle)).map_err(stopped_error)?)
    }
}

/// An `InputError` for a text value.
fn invalid(field: &str, value: &str, allowed: &str) -> PyErr {
    input_error(LibInputError::Invalid { field: field.into(), value: value.into(), allowed: allowed.into() })
}

/// A robot file's error, named after its path.
fn with_source(e: LibInputError, source: &str) -> LibInputError {
    match e {
        LibInputError::Toml { message } => LibInputError::File { file: source.into(), message },
        other => other,
    }
}

/// The built-in scenes or scenarios: (name, description) pairs.
#[pyfunction]
fn builtin_names(kind: &str) -> PyResult<Vec<(&'static str, &'static str)>> {
    match kind {
        "scenes" => Ok(Scene::builtin_names().collect()),
        "scenarios" => Ok(Scenario::builtin_names().collect()),
        other => Err(invalid("kind", other, "scenes or scenarios")),
    }
}

#[pymodule]
fn _leech(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<Robot>()?;
    m.add_class::<Reacher>()?;
    m.add_function(wrap_pyfunction!(builtin_names, m)?)?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("SolveError", py.get_type::<SolveError>())?;
    m.add("CalibrationError", py.get_type::<CalibrationError>())?;
    m.add("CHUNK", batch::CHUNK)?;
    m.add("WARM_STEP_M", batch::WARM_STEP_M)?;
    m.add("STATUS_NAMES", batch::Status::ALL.map(|s| s.name()).to_vec())?;
    Ok(())
}
