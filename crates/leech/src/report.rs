//! Machine-readable results: what `leech ... --json` prints and the rows of
//! the CSV files it writes, as serde types with units in the key names.

use std::num::NonZeroUsize;
use std::time::Instant;

use serde::{Serialize, Serializer};

use crate::body::Body;
use crate::budget::Stopped;
use crate::cantilever::Cantilever;
use crate::dynamics::Sample;
use crate::statics::{Equilibrium, Event, Solver};
use crate::sweep::{Model, Point};

mod body3;
mod climb;
mod held;

pub use body3::{
    ArcTubeReport, Body3Report, ConstantCurvature3Report, Contact3Report, Cup3Report, PlanarCounterpart, PlanarReport,
    TubeReport,
};
pub use climb::{write_climb_csv, ClimbReport, ClimbRow, ClimbStep, SafetyFactors};
pub use held::{Cups, HalfPlaneReport, HoldReport, Holds, PolygonReport, SceneReport, ShapeReport, StanceReport};

/// How the solve went.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Solution {
    /// Always `"converged"` here; failures are errors (exit code 3 on the command line).
    pub status: &'static str,
    /// Whether the equilibrium is stable (reduced Hessian positive definite).
    pub stable: bool,
    /// Newton iterations, all stages together.
    pub iterations: usize,
    /// Scaled residual sup norm (moments over k, lengths over l, angles in rad).
    pub residual: f64,
    /// Continuation steps accepted.
    pub steps: usize,
    /// Folds (snaps) and bifurcations met on the way.
    pub events: Vec<Event>,
}

impl From<&Equilibrium> for Solution {
    fn from(eq: &Equilibrium) -> Self {
        Solution {
            status: "converged",
            stable: eq.stable,
            iterations: eq.iterations,
            residual: eq.residual,
            steps: eq.steps,
            events: eq.events.clone(),
        }
    }
}

/// One chain's shape.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ChainShape {
    /// The centre line from the clamp to the tip (m).
    pub points_m: Vec<[f64; 2]>,
    /// Absolute link angles (rad, counter-clockwise from +x, not wrapped).
    pub angles_rad: Vec<f64>,
}

/// Both chains of the body.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Chains {
    /// The centre tube.
    pub a: ChainShape,
    /// The side pair.
    pub b: ChainShape,
}

/// The result of `leech shape` for the two-chain model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BodyReport {
    /// Always `"two-chain"`.
    pub model: &'static str,
    /// How the solve went.
    #[serde(flatten)]
    pub solution: Solution,
    /// Robot name.
    pub robot: String,
    /// Tube lengths LA, LB (m).
    pub lengths_m: [f64; 2],
    /// Links in chains A and B.
    pub links: [usize; 2],
    /// Shape parameter `Pi = k/(m g l)` of one tube.
    pub shape_parameter: f64,
    /// Endpoint: chain A's tip (m).
    pub endpoint_m: [f64; 2],
    /// Endpoint plate angle (rad).
    pub endpoint_angle_rad: f64,
    /// Potential energy (J).
    pub energy_j: f64,
    /// Both chains.
    pub chains: Chains,
}

impl BodyReport {
    /// Collects the report of an equilibrium of `body`.
    pub fn new(robot: &str, shape_parameter: f64, body: &Body, eq: &Equilibrium) -> BodyReport {
        let (qa, qb) = body.split(&eq.q);
        BodyReport {
            model: "two-chain",
            solution: eq.into(),
            robot: robot.to_string(),
            lengths_m: [body.chain_a().tube_length(), body.chain_b().tube_length()],
            links: [qa.len(), qb.len()],
            shape_parameter,
            endpoint_m: body.endpoint(&eq.q),
            endpoint_angle_rad: body.endpoint_angle(&eq.q),
            energy_j: eq.energy,
            chains: Chains {
                a: ChainShape { points_m: body.chain_a().points(qa), angles_rad: qa.to_vec() },
                b: ChainShape { points_m: body.chain_b().points(qb), angles_rad: qb.to_vec() },
            },
        }
    }
}

/// The result of `leech chain`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CantileverReport {
    /// How the solve went.
    #[serde(flatten)]
    pub solution: Solution,
    /// Tube length (m).
    pub length_m: f64,
    /// Shape parameter `Pi = k/(m g l)`.
    pub shape_parameter: f64,
    /// Tip of the tube (m).
    pub tip_m: [f64; 2],
    /// The centre line from the clamp to the tip (m).
    pub points_m: Vec<[f64; 2]>,
    /// Absolute link angles (rad).
    pub angles_rad: Vec<f64>,
    /// Potential energy (J).
    pub energy_j: f64,
}

impl CantileverReport {
    /// Collects the report of an equilibrium of `tube`.
    pub fn new(shape_parameter: f64, tube: &Cantilever, eq: &Equilibrium) -> CantileverReport {
        CantileverReport {
            solution: eq.into(),
            length_m: tube.chain().tube_length(),
            shape_parameter,
            tip_m: tube.chain().tip(&eq.q),
            points_m: tube.chain().points(&eq.q),
            angles_rad: eq.q.clone(),
            energy_j: eq.energy,
        }
    }
}

/// The result of `leech chain --scene`: the tube's report, then what it
/// rests on and what the clamp carries.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TubeInSceneReport {
    /// The tube's own report, its keys first.
    #[serde(flatten)]
    pub tube: CantileverReport,
    /// The surfaces pushing on the tube.
    pub contacts: Vec<crate::stance::ContactForce>,
    /// The clamp's force on the tube (N).
    pub clamp_force_n: [f64; 2],
    /// The clamp's moment on the tube about the clamp (N m, counter-clockwise).
    pub clamp_moment_nm: f64,
    /// Deepest penetration of the tube into the scene (m).
    pub penetration_m: f64,
    /// The scene's name.
    pub scene: String,
}

impl TubeInSceneReport {
    /// The report of `held`, a tube in `scene`.
    pub fn new(shape_parameter: f64, held: &crate::stance::TubeHeld, scene: &crate::scene::Scene) -> Self {
        TubeInSceneReport {
            tube: CantileverReport::new(shape_parameter, &held.tube, &held.equilibrium),
            contacts: held.contacts.clone(),
            clamp_force_n: held.clamp.force_n,
            clamp_moment_nm: held.clamp.moment_nm,
            penetration_m: held.penetration_m,
            scene: scene.name.clone(),
        }
    }
}

/// Points along each chain of the constant-curvature model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArcChains {
    /// Chain A's arc, sampled (m).
    pub a: Vec<[f64; 2]>,
    /// Chain B's arc, sampled (m).
    pub b: Vec<[f64; 2]>,
}

/// The result of `leech shape --model constant-curvature`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ConstantCurvatureReport {
    /// Always `"constant-curvature"`.
    pub model: &'static str,
    /// Always `"converged"`: the model is closed-form.
    pub status: &'static str,
    /// Tube lengths LA, LB (m).
    pub lengths_m: [f64; 2],
    /// Bending angle `(LB - LA)/w` (rad).
    pub bend_rad: f64,
    /// Chain A's curvature (1/m).
    pub curvature_a_per_m: f64,
    /// Endpoint: chain A's tip (m).
    pub endpoint_m: [f64; 2],
    /// Endpoint plate angle (rad).
    pub endpoint_angle_rad: f64,
    /// Sampled arcs (`points_m` of each chain).
    pub chains: ArcChains,
}

impl ConstantCurvatureReport {
    /// The constant-curvature body for lengths `la`, `lb` (m), arcs sampled at `samples` points.
    pub fn new(cc: &crate::constant_curvature::PlanarBody, la: f64, lb: f64, samples: usize) -> Self {
        let pose = cc.pose(la, lb);
        let (a, b) = cc.chain_points(la, lb, samples);
        ConstantCurvatureReport {
            model: "constant-curvature",
            status: "converged",
            lengths_m: [la, lb],
            bend_rad: pose.bend,
            curvature_a_per_m: pose.curvature_a,
            endpoint_m: pose.endpoint,
            endpoint_angle_rad: pose.endpoint_angle,
            chains: ArcChains { a, b },
        }
    }
}

/// Wall-clock time of repeated cold solves of one body (s): what
/// `leech shape --repeat` reports as `solve_time_s`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SolveTiming {
    /// Solves timed.
    pub solves: usize,
    /// Median time (s); the upper of the two middle times for an even count.
    pub median: f64,
    /// Fastest time (s).
    pub min: f64,
}

impl SolveTiming {
    /// Solves `body` from scratch `n` times with `solver` and times each solve.
    /// A failed solve is timed like a converged one: the solve is
    /// deterministic, so time the body once it is known to converge. The
    /// solver's deadline bounds all the solves together: past it the timing
    /// would time failures, so it stops ([`Stopped`] says how many were done).
    pub fn measure(body: &Body, solver: &Solver, n: NonZeroUsize) -> Result<SolveTiming, Stopped> {
        let mut times = Vec::with_capacity(n.get());
        for done in 0..n.get() {
            let start = Instant::now();
            // black_box: the result is unused, and the solve must not be optimized away.
            let _ = std::hint::black_box(body.solve(solver));
            times.push(start.elapsed().as_secs_f64());
            solver.options.deadline.guard(done + 1, n.get(), "repeats")?;
        }
        times.sort_by(f64::total_cmp);
        Ok(SolveTiming { solves: times.len(), median: times[times.len() / 2], min: times[0] })
    }
}

/// One row of the sweep CSV (`leech workspace --out`): a grid point, with
/// units in the column names.
///
/// Meant for CSV: numbers are written as text in Rust's plain decimal
/// notation (every digit, no exponent, `0` not `0.0`), as the sweep files
/// have always been; a missing shape parameter is an empty field.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SweepRow {
    /// Model (`two-chain` or `constant-curvature`).
    pub model: Model,
    /// Shape parameter (empty for the constant-curvature model).
    #[serde(serialize_with = "optional_decimal")]
    pub shape_parameter: Option<f64>,
    /// Tube length LA (m).
    #[serde(serialize_with = "decimal")]
    pub la_m: f64,
    /// Tube length LB (m).
    #[serde(serialize_with = "decimal")]
    pub lb_m: f64,
    /// `converged` or `failed`.
    pub status: &'static str,
    /// Stable equilibrium.
    pub stable: bool,
    /// The actuation path snapped to reach this point.
    pub snapped: bool,
    /// Not bent tighter than the tube allows.
    pub feasible: bool,
    /// Smallest bending radius of the tubes (m).
    #[serde(serialize_with = "decimal")]
    pub min_bend_radius_m: f64,
    /// Endpoint x (m); NaN for a failure.
    #[serde(serialize_with = "decimal")]
    pub endpoint_x_m: f64,
    /// Endpoint y (m); NaN for a failure.
    #[serde(serialize_with = "decimal")]
    pub endpoint_y_m: f64,
    /// Endpoint plate angle (rad); NaN for a failure.
    #[serde(serialize_with = "decimal")]
    pub endpoint_angle_rad: f64,
    /// Distance from a fresh solve's endpoint (m): 0 when it agrees, `inf`
    /// when the fresh solve fails, NaN for a failure (see [`crate::sweep`]).
    #[serde(serialize_with = "decimal")]
    pub fresh_difference_m: f64,
}

impl From<&Point> for SweepRow {
    fn from(p: &Point) -> SweepRow {
        SweepRow {
            model: p.model,
            shape_parameter: p.shape_parameter,
            la_m: p.lengths_m[0],
            lb_m: p.lengths_m[1],
            status: if p.failure.is_some() { "failed" } else { "converged" },
            stable: p.stable,
            snapped: p.snapped,
            feasible: p.feasible,
            min_bend_radius_m: p.min_bend_radius_m,
            endpoint_x_m: p.endpoint_m[0],
            endpoint_y_m: p.endpoint_m[1],
            endpoint_angle_rad: p.endpoint_angle_rad,
            fresh_difference_m: p.fresh_difference_m,
        }
    }
}

/// One row of the simulation CSV (`leech simulate --csv`): a sample, with
/// units in the column names. Numbers are written as in [`SweepRow`]; each
/// chain's angles are one field, separated by spaces.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SampleRow<'a> {
    /// Time (s).
    #[serde(serialize_with = "decimal")]
    pub time_s: f64,
    /// Tube length LA (m).
    #[serde(serialize_with = "decimal")]
    pub la_m: f64,
    /// Tube length LB (m).
    #[serde(serialize_with = "decimal")]
    pub lb_m: f64,
    /// Endpoint x (m).
    #[serde(serialize_with = "decimal")]
    pub endpoint_x_m: f64,
    /// Endpoint y (m).
    #[serde(serialize_with = "decimal")]
    pub endpoint_y_m: f64,
    /// Kinetic energy (J).
    #[serde(serialize_with = "decimal")]
    pub kinetic_j: f64,
    /// Potential energy (J).
    #[serde(serialize_with = "decimal")]
    pub potential_j: f64,
    /// Largest constraint violation (m or rad).
    #[serde(serialize_with = "decimal")]
    pub constraint_violation: f64,
    /// Chain A's angles (rad).
    #[serde(serialize_with = "spaced")]
    pub angles_a_rad: &'a [f64],
    /// Chain B's angles (rad).
    #[serde(serialize_with = "spaced")]
    pub angles_b_rad: &'a [f64],
}

impl<'a> From<&'a Sample> for SampleRow<'a> {
    fn from(s: &'a Sample) -> SampleRow<'a> {
        SampleRow {
            time_s: s.time_s,
            la_m: s.lengths_m[0],
            lb_m: s.lengths_m[1],
            endpoint_x_m: s.endpoint_m[0],
            endpoint_y_m: s.endpoint_m[1],
            kinetic_j: s.kinetic_j,
            potential_j: s.potential_j,
            constraint_violation: s.violation,
            angles_a_rad: &s.angles_a_rad,
            angles_b_rad: &s.angles_b_rad,
        }
    }
}

// Serializers write numbers through `Display`: CSV writers would otherwise
// pick their own float format (the csv crate's shortest form uses exponents
// and writes `0.0`), which changes the files byte for byte.
fn decimal<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(x)
}

fn optional_decimal<S: Serializer>(x: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match x {
        Some(x) => s.collect_str(x),
        None => s.serialize_none(),
    }
}

fn spaced<S: Serializer>(values: &&[f64], s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(&Spaced(values))
}

/// Numbers separated by single spaces.
struct Spaced<'a>(&'a [f64]);

impl std::fmt::Display for Spaced<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, x) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str(" ")?;
            }
            write!(f, "{x}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn csv_of<T: Serialize>(rows: impl IntoIterator<Item = T>) -> String {
        let mut writer = csv::Writer::from_writer(vec![]);
        for row in rows {
            writer.serialize(row).unwrap();
        }
        String::from_utf8(writer.into_inner().unwrap()).unwrap()
    }

    #[test]
    fn sweep_rows_keep_plain_decimals_and_empty_shape_parameters() {
        let point = Point {
            model: Model::ConstantCurvature,
            shape_parameter: None,
            lengths_m: [0.05, 0.1],
            failure: Some("diverged".into()),
            stable: true,
            snapped: false,
            min_bend_radius_m: 0.0,
            feasible: true,
            endpoint_m: [f64::NAN, 2.7755575615628914e-17],
            endpoint_angle_rad: 1.0,
            fresh_difference_m: f64::INFINITY,
        };
        assert_eq!(
            csv_of([SweepRow::from(&point)]),
            "model,shape_parameter,la_m,lb_m,status,stable,snapped,feasible,min_bend_radius_m,endpoint_x_m,endpoint_y_m,endpoint_angle_rad,fresh_difference_m\n\
             constant-curvature,,0.05,0.1,failed,true,false,true,0,NaN,0.000000000000000027755575615628914,1,inf\n"
        );
    }

    #[test]
    fn sample_rows_put_each_chain_in_one_field() {
        let sample = Sample {
            time_s: 0.0,
            lengths_m: [0.2, 0.18],
            angles_a_rad: vec![1.5, 1.25],
            angles_b_rad: vec![],
            points_a_m: vec![],
            points_b_m: vec![],
            endpoint_m: [0.1, -0.2],
            kinetic_j: 0.0,
            potential_j: 0.125,
            violation: 1e-3,
        };
        assert_eq!(
            csv_of([SampleRow::from(&sample)]),
            "time_s,la_m,lb_m,endpoint_x_m,endpoint_y_m,kinetic_j,potential_j,constraint_violation,angles_a_rad,angles_b_rad\n\
             0,0.2,0.18,0.1,-0.2,0,0.125,0.001,1.5 1.25,\n"
        );
    }
}
