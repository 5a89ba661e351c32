//! What `leech shape3d` reports: an equilibrium of the three-tube body in 3D
//! (docs/model3d.md), the cups that hold it and its contacts with a scene,
//! and, where there is one, the planar model beside it.

use serde::Serialize;

use super::Solution;
use crate::body::Body;
use crate::body3::Body3;
use crate::contact::space::Contact3;
use crate::cup::CupVerdict;
use crate::geom3::{Mat3, Vec3};
use crate::hold::{AsBuilt, Hold3, Pose3};
use crate::robot::Robot;
use crate::scene::SceneFile3;
use crate::stance::{self, Held, Hold, Pose};
use crate::stance3::planar::{compare, compare_points, PlanarDifference};
use crate::stance3::{CupState3, Equilibrium3, Held3};
use crate::statics::{Equilibrium, Solver};

/// How far a held plate may be from the x-y plane's frames and its tip from
/// `z = 0` and still have the planar front hold as its counterpart.
const IN_PLANE: f64 = 1e-12;

/// A holding cup of the 3D body, its keys those of the planar held report
/// (`leech shape --hold`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Cup3Report {
    /// The surface's force on the robot (N, world frame).
    pub force_n: [f64; 3],
    /// Its moment about the cup's face centre (N m, world frame): the one
    /// the verdict judges.
    pub moment_nm: [f64; 3],
    /// The verdict's safety factor; `null` when the cup is unloaded.
    pub safety_factor: Option<f64>,
    /// Whether the cup holds (safety factor at least 1).
    pub holds: bool,
    /// Centre of the cup's face (m).
    pub cup_m: [f64; 3],
    /// The surface's outward normal at the cup.
    pub surface_normal: [f64; 3],
    /// Loads, capacities and factors ([`crate::cup`]; the shear includes
    /// the twist about the normal, docs/model3d.md section 8).
    pub verdict: CupVerdict,
}

impl From<&CupState3> for Cup3Report {
    fn from(cup: &CupState3) -> Cup3Report {
        let factor = cup.verdict.safety_factor;
        Cup3Report {
            force_n: cup.reaction.force_n,
            moment_nm: cup.reaction.moment_nm,
            safety_factor: factor.is_finite().then_some(factor),
            holds: cup.verdict.holds,
            cup_m: cup.centre_m,
            surface_normal: cup.normal,
            verdict: cup.verdict,
        }
    }
}

/// A solid pushing on a link tip of the 3D body.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Contact3Report {
    /// The tube: 1, 2 or 3.
    pub tube: usize,
    /// The link whose tip touches (0 the first from the driving unit).
    pub link: usize,
    /// The touching point on the tube's centre line (m).
    pub point_m: [f64; 3],
    /// The surface's outward normal there: the force's direction.
    pub normal: [f64; 3],
    /// The normal force on the body (N).
    pub force_n: f64,
}

impl From<&Contact3> for Contact3Report {
    fn from(c: &Contact3) -> Contact3Report {
        Contact3Report {
            tube: c.row.tube + 1,
            link: c.row.link,
            point_m: c.point_m,
            normal: c.row.plane.normal,
            force_n: c.force_n,
        }
    }
}

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
    /// The planar body held as the 3D one is ([`stance::solve`],
    /// [`stance::solve_in`]), its points in the world.
    Held(Box<Held>),
    /// The situation has none in the plane (a hold out of the x-y plane, a
    /// free front joint, a 3D scene): why.
    Absent(String),
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

    /// The planar counterpart of `body` (built from `robot` at `lengths`,
    /// placed) held by `hold` in `scene` if any: the planar stance's hold
    /// where the 3D one lies in the x-y plane (the rear hold; a front hold
    /// whose tip is at `z = 0` and whose plate turns about z only), in the
    /// planar scene the 3D one was read from. The rear hold of the body
    /// as built, without a scene, is [`PlanarCounterpart::solve`].
    pub fn held(
        robot: &Robot,
        body: &Body3,
        hold: &Hold3,
        scene: Option<&SceneFile3>,
        solver: &Solver,
    ) -> PlanarCounterpart {
        let lengths = [0, 1, 2].map(|i| body.tube(i).tube_length());
        let planar_scene = match scene {
            Some(SceneFile3 { planar: None, .. }) => {
                return PlanarCounterpart::Absent("the scene is a 3D one: the planar model has no scene of it".into())
            }
            Some(file) => file.planar.as_ref(),
            None => None,
        };
        let rear = || {
            let (root, base) = (body.tube(0).root(), body.base_frame());
            Pose { point_m: [root[0], root[1]], angle_rad: base[1][0].atan2(base[0][0]) }
        };
        // A front hold has a planar counterpart only in the x-y plane.
        let front = |tip_m: &Vec3, plate: &Mat3| {
            let flat = (plate[2][2] - 1.0).abs() <= IN_PLANE && tip_m[2].abs() <= IN_PLANE;
            flat.then(|| Pose { point_m: [tip_m[0], tip_m[1]], angle_rad: plate[1][0].atan2(plate[0][0]) })
        };
        let out_of_plane = || PlanarCounterpart::Absent("the front hold is out of the x-y plane".into());
        let planar_hold = match hold {
            Hold3::Rear(AsBuilt) if planar_scene.is_none() => return PlanarCounterpart::solve(robot, lengths, solver),
            Hold3::Rear(AsBuilt) => Hold::Rear(rear()),
            Hold3::Front(Pose3 { point_m: tip_m, frame: plate }) => match front(tip_m, plate) {
                Some(pose) => Hold::Front(pose),
                None => return out_of_plane(),
            },
            Hold3::Both { rear: AsBuilt, front: Pose3 { point_m: tip_m, frame: plate } } => match front(tip_m, plate) {
                Some(pose) => Hold::Both { rear: rear(), front: pose },
                None => return out_of_plane(),
            },
            Hold3::FrontPivot { .. } => {
                return PlanarCounterpart::Absent("the planar model has no free front joint".into())
            }
        };
        if lengths[1] != lengths[2] {
            return PlanarCounterpart::Unequal;
        }
        let planar_lengths = [lengths[0], lengths[1]];
        let held = match planar_scene {
            Some(scene) => stance::solve_in(robot, planar_lengths, planar_hold, scene, solver),
            None => stance::solve(robot, planar_lengths, planar_hold, solver),
        };
        match held {
            Ok(held) => PlanarCounterpart::Held(Box::new(held)),
            Err(e) => PlanarCounterpart::Failed(format!("the planar model's held solve failed: {e}")),
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
    /// Which cup holds: `rear`, `front` or `front_pivot` (the front cup on
    /// a free joint about its face's normal).
    pub hold: &'static str,
    /// The rear cup's reaction and verdict when it holds, else `null`.
    pub rear_cup: Option<Cup3Report>,
    /// The front cup's, likewise.
    pub front_cup: Option<Cup3Report>,
    /// On a free front joint: the plate's turn about the face's normal (rad).
    pub pivot_turn_rad: Option<f64>,
    /// The scene's name, `null` without one.
    pub scene: Option<String>,
    /// The solids pushing on the tubes (none without a scene).
    pub contacts: Vec<Contact3Report>,
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
            PlanarCounterpart::Failed(why) | PlanarCounterpart::Absent(why) => (None, Some(why.clone())),
            PlanarCounterpart::Held(held) => {
                let report = PlanarReport {
                    stable: held.equilibrium.stable,
                    endpoint_m: [held.endpoint_m[0], held.endpoint_m[1], 0.0],
                    difference: compare_points(body, eq, &held.chain_points(robot), [0.0; 3]),
                };
                (Some(report), None)
            }
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
            hold: Hold3::Rear(AsBuilt).name(),
            rear_cup: None,
            front_cup: None,
            pivot_turn_rad: None,
            scene: None,
            contacts: eq.contacts.iter().map(Contact3Report::from).collect(),
        }
    }

    /// The report of `held` (a body of `robot`, in the scene named `scene`
    /// if any): [`Body3Report::new`] of its placed body and equilibrium,
    /// with the hold, its cups and the contacts.
    pub fn held(
        robot: &Robot,
        held: &Held3,
        scene: Option<&str>,
        free_axial_rotation: bool,
        planar: &PlanarCounterpart,
    ) -> Body3Report {
        Body3Report {
            hold: held.hold.name(),
            rear_cup: held.rear.as_ref().map(Cup3Report::from),
            front_cup: held.front.as_ref().map(Cup3Report::from),
            pivot_turn_rad: held.pivot_turn_rad,
            scene: scene.map(str::to_string),
            ..Body3Report::new(robot, &held.body, &held.equilibrium, free_axial_rotation, planar)
        }
    }
}

/// One tube of the constant-curvature model: an arc.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArcTubeReport {
    /// The tube's length (m).
    pub length_m: f64,
    /// Points along it, evenly spaced in arc length from its root (m).
    pub points_m: Vec<[f64; 3]>,
}

/// The result of `leech shape3d --model constant-curvature`: the tri-tube
/// constant-curvature model (docs/model3d.md section 9), as `leech shape
/// --model constant-curvature` reports the planar one.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ConstantCurvature3Report {
    /// Always `"constant-curvature"`.
    pub model: &'static str,
    /// Always `"converged"`: the model is closed-form.
    pub status: &'static str,
    /// Robot name.
    pub robot: String,
    /// Tube lengths L1, L2, L3 (m).
    pub lengths_m: [f64; 3],
    /// The backbone's length `ell` (m).
    pub backbone_length_m: f64,
    /// The bend `theta >= 0` (rad).
    pub bend_rad: f64,
    /// The bend's direction `phi` (rad, from tube 1's side towards tube 2's).
    pub bend_direction_rad: f64,
    /// The backbone's curvature `theta / ell` (1/m).
    pub curvature_per_m: f64,
    /// Endpoint: tube 1's tip (m).
    pub endpoint_m: [f64; 3],
    /// The plate's frame, row by row (its columns the plate's axes).
    pub plate_frame: [[f64; 3]; 3],
    /// Tubes 1, 2, 3.
    pub tubes: Vec<ArcTubeReport>,
}

impl ConstantCurvature3Report {
    /// The report of `cc` (of `robot`), each tube sampled at `samples + 1`
    /// points (`samples >= 1`).
    pub fn new(
        robot: &Robot,
        cc: &crate::body3::ConstantCurvature3,
        samples: usize,
    ) -> Result<ConstantCurvature3Report, crate::error::InputError> {
        let arc = cc.arc();
        let tubes = (0..3)
            .map(|i| Ok(ArcTubeReport { length_m: cc.lengths()[i], points_m: cc.points(i, samples)? }))
            .collect::<Result<_, crate::error::InputError>>()?;
        Ok(ConstantCurvature3Report {
            model: "constant-curvature",
            status: "converged",
            robot: robot.name.clone(),
            lengths_m: cc.lengths(),
            backbone_length_m: arc.length,
            bend_rad: arc.bend,
            bend_direction_rad: arc.plane,
            curvature_per_m: cc.curvature(),
            endpoint_m: cc.endpoint(),
            plate_frame: cc.plate_frame(),
            tubes,
        })
    }
}
