//! What `leech shape3d` reports: an equilibrium of the three-tube body in 3D
//! (docs/model3d.md) and, where there is one, the planar model beside it.

use serde::Serialize;

use super::Solution;
use crate::body::Body;
use crate::body3::planar::{compare, PlanarDifference};
use crate::body3::{Body3, Equilibrium3};
use crate::robot::Robot;
use crate::statics::{Equilibrium, Solver};

/// One tube of the 3D body.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TubeReport {
    /// The tube's length (m).
    pub length_m: f64,
    /// Its links.
    pub links: usize,
    /// The centre line from its root on the driving unit to its tip (m).
    pub points_m: Vec<[f64; 3]>,
}

/// The planar model of the same robot at `(L1, L2)`, beside the 3D body at
/// `(L1, L2, L2)`: its endpoint placed in the 3D world (its clamp on tube
/// 1's root, its plane `z = 0`) and how far the 3D body is from it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PlanarReport {
    /// Whether the planar equilibrium is stable (in the plane).
    pub stable: bool,
    /// The planar model's endpoint, chain A's tip (m).
    pub endpoint_m: [f64; 3],
    /// Point by point and frame by frame ([`PlanarDifference`]).
    pub difference: PlanarDifference,
}

/// The planar model of a 3D body: its counterpart solved, or why there is
/// none to report.
#[derive(Clone, Debug)]
pub enum PlanarCounterpart {
    /// `L2 != L3`: the planar model has no body of these lengths.
    Unequal,
    /// The planar body at `(L1, L2)` and its equilibrium.
    Solved(Box<(Body, Equilibrium)>),
    /// The planar model refused the body (fewer than 4 links in all) or
    /// its solve failed where the 3D one did not: why.
    Failed(String),
}

impl PlanarCounterpart {
    /// The planar body of `robot` at `(L1, L2)` solved on its default path
    /// when `L2 = L3` (exactly: the planar model lumps two equal tubes).
    /// `robot` is the one [`Body3::from_robot`] was given, so its lengths
    /// and discretization are already checked.
    pub fn solve(robot: &Robot, [l1, l2, l3]: [f64; 3], solver: &Solver) -> PlanarCounterpart {
        if l2 != l3 {
            return PlanarCounterpart::Unequal;
        }
        let body = match robot.body(l1, l2) {
            Ok(body) => body,
            Err(e) => return PlanarCounterpart::Failed(format!("the planar model refused the body: {e}")),
        };
        match body.solve(solver) {
            Ok(eq) => PlanarCounterpart::Solved(Box::new((body, eq))),
            Err(e) => PlanarCounterpart::Failed(format!("the planar model's solve failed: {e}")),
        }
    }
}

/// The result of `leech shape3d`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Body3Report {
    /// Always `"three-tube"`.
    pub model: &'static str,
    /// How the solve went (`status`, `stable`, `iterations`, `residual`,
    /// `steps`, `events`: folds and bifurcations as `leech shape` reports them).
    #[serde(flatten)]
    pub solution: Solution,
    /// Robot name.
    pub robot: String,
    /// Tube lengths L1, L2, L3 (m).
    pub lengths_m: [f64; 3],
    /// Shape parameter `Pi = k/(m g l)` of one tube.
    pub shape_parameter: f64,
    /// Whether each tube's axial rotation at the driving unit is free.
    pub free_axial_rotation: bool,
    /// Endpoint: tube 1's tip (m).
    pub endpoint_m: [f64; 3],
    /// The endpoint plate's frame, row by row: its columns are the plate's
    /// axes in world coordinates (the first the centre tube's tangent).
    pub plate_frame: [[f64; 3]; 3],
    /// Potential energy (J).
    pub energy_j: f64,
    /// The largest twist of any joint (rad).
    pub max_twist_rad: f64,
    /// Tubes 1, 2, 3.
    pub tubes: Vec<TubeReport>,
    /// Distance from the endpoint to the planar model's (m); `null` when
    /// there is no planar counterpart (`planar_note` says why).
    pub planar_difference_m: Option<f64>,
    /// The planar model beside the 3D body; `null` as `planar_difference_m`.
    pub planar: Option<PlanarReport>,
    /// Why there is no planar comparison, or `null`.
    pub planar_note: Option<String>,
}

impl Body3Report {
    /// The report of `eq`, an equilibrium of `body` (built from `robot`),
    /// with the planar model beside it.
    pub fn new(
        robot: &Robot,
        body: &Body3,
        eq: &Equilibrium3,
        free_axial_rotation: bool,
        planar: &PlanarCounterpart,
    ) -> Body3Report {
        let tubes: Vec<TubeReport> = (0..3)
            .map(|i| TubeReport {
                length_m: body.tube(i).tube_length(),
                links: body.tube(i).len(),
                points_m: body.points(&eq.frames, i),
            })
            .collect();
        let (planar, planar_note) = match planar {
            PlanarCounterpart::Unequal => (None, Some("L2 != L3: the planar model has no counterpart".to_string())),
            PlanarCounterpart::Failed(why) => (None, Some(why.clone())),
            PlanarCounterpart::Solved(solved) => {
                let (flat, flat_eq) = &**solved;
                let origin = body.tube(0).root();
                let [x, y] = flat.endpoint(&flat_eq.q);
                let report = PlanarReport {
                    stable: flat_eq.stable,
                    endpoint_m: [origin[0] + x, origin[1] + y, origin[2]],
                    difference: compare(body, eq, flat, flat_eq),
                };
                (Some(report), None)
            }
        };
        Body3Report {
            model: "three-tube",
            solution: (&eq.summary).into(),
            robot: robot.name.clone(),
            lengths_m: [0, 1, 2].map(|i| body.tube(i).tube_length()),
            shape_parameter: robot.shape_parameter(),
            free_axial_rotation,
            endpoint_m: body.endpoint(&eq.frames),
            plate_frame: body.plate_frame(&eq.frames),
            energy_j: eq.energy,
            max_twist_rad: body.max_twist(&eq.frames),
            tubes,
            planar_difference_m: planar.as_ref().map(|p| p.difference.endpoint_m),
            planar,
            planar_note,
        }
    }
}
