//! Machine-readable results: what `leech ... --json` prints, as serde types
//! with units in the key names.

use serde::Serialize;

use crate::body::Body;
use crate::cantilever::Cantilever;
use crate::statics::{Equilibrium, Event};

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
