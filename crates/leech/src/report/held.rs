//! What `leech shape` adds for a held body: where the driving unit is, what
//! the cups carry and whether they hold, the contacts with a scene; and the
//! scene files' JSON form.

use serde::Serialize;

use super::{BodyReport, ChainShape, Chains};
use crate::cup::CupVerdict;
use crate::geom::Vec2;
use crate::robot::Robot;
use crate::scene::{Scene, Solid};
use crate::stance::{ContactForce, CupState, Held, Reaction, StopMoment};

/// The rear and the front cup as [`Held::cups`] judges them.
pub type Cups = (Option<CupState>, Option<CupState>);

/// The result of `leech shape` for the two-chain model: the body's report
/// followed by the holds' (their keys side by side in one JSON object).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShapeReport {
    /// The body.
    #[serde(flatten)]
    pub body: BodyReport,
    /// The holds, the cups and the contacts.
    #[serde(flatten)]
    pub stance: StanceReport,
}

/// One hold: the surface's reaction on the robot and its cup's verdict.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HoldReport {
    /// Force on the robot, world frame (N).
    pub force_n: Vec2,
    /// Moment on the robot about the hold point (N m, counter-clockwise):
    /// the driving unit's point for the rear hold, the endpoint for the front.
    pub moment_nm: f64,
    /// The cup's verdict's safety factor; `null` when the cup is unloaded.
    pub safety_factor: Option<f64>,
    /// Whether the cup holds (safety factor at least 1).
    pub holds: bool,
    /// Centre of the cup's face (m).
    pub cup_m: Vec2,
    /// Moment about the cup's centre (N m), the one the verdict judges.
    pub cup_moment_nm: f64,
    /// The surface's outward normal at the cup.
    pub surface_normal: Vec2,
    /// Loads, capacities and factors ([`crate::cup`]).
    pub verdict: CupVerdict,
}

impl HoldReport {
    fn new(reaction: &Reaction, cup: &CupState) -> HoldReport {
        let factor = cup.verdict.safety_factor;
        HoldReport {
            force_n: reaction.force_n,
            moment_nm: reaction.moment_nm,
            safety_factor: factor.is_finite().then_some(factor),
            holds: cup.verdict.holds,
            cup_m: cup.centre_m,
            cup_moment_nm: cup.moment_nm,
            surface_normal: cup.normal,
            verdict: cup.verdict,
        }
    }
}

/// The holds that act.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Holds {
    /// The rear cup's, when it holds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rear: Option<HoldReport>,
    /// The front cup's, when it holds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub front: Option<HoldReport>,
}

/// Where the holds put the body and what carries its weight.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StanceReport {
    /// Chain A's clamp on the driving unit (m).
    pub driving_unit_m: Vec2,
    /// The clamp direction (rad).
    pub driving_unit_angle_rad: f64,
    /// The holds' reactions and verdicts.
    pub holds: Holds,
    /// The surfaces pushing on the tubes (none without a scene).
    pub contacts: Vec<ContactForce>,
    /// The joints locked at the hose's stop and the moments it carries
    /// there (among solids; none in free space).
    pub hose_stops: Vec<StopMoment>,
    /// Where the rear cup's face is, holding or not (m).
    pub rear_cup_m: Vec2,
    /// Where the front cup's face is, holding or not (m).
    pub front_cup_m: Vec2,
    /// Deepest penetration of the tubes into the scene (m; 0 without one).
    pub penetration_m: f64,
    /// The weight the holds and contacts carry (N).
    pub weight_n: f64,
    /// `"rear"`, `"front"` or `"both"`.
    pub hold: &'static str,
    /// The scene's name, `null` without one.
    pub scene: Option<String>,
    /// Where the weight acts (m).
    pub centre_of_mass_m: Vec2,
}

impl StanceReport {
    /// The report of `held` (a body of `robot`, in `scene` if any), with
    /// the cups as [`Held::cups`] judged them.
    pub fn new(robot: &Robot, held: &Held, scene: Option<&Scene>, cups: &Cups) -> StanceReport {
        let hold = |reaction: &Option<Reaction>, cup: &Option<CupState>| match (reaction, cup) {
            (Some(r), Some(c)) => Some(HoldReport::new(r, c)),
            _ => None,
        };
        StanceReport {
            driving_unit_m: held.unit.point_m,
            driving_unit_angle_rad: held.unit.angle_rad,
            holds: Holds { rear: hold(&held.rear, &cups.0), front: hold(&held.front, &cups.1) },
            contacts: held.contacts.clone(),
            hose_stops: held.stops.clone(),
            rear_cup_m: held.rear_cup_m(robot),
            front_cup_m: held.front_cup_m(robot),
            penetration_m: scene.map_or(0.0, |s| held.penetration_m(robot, s)),
            weight_n: held.weight_n,
            hold: held.hold.name(),
            scene: scene.map(|s| s.name.clone()),
            centre_of_mass_m: held.centre_of_mass,
        }
    }
}

impl BodyReport {
    /// The report of a held body of `robot`: its chains where the holds put
    /// them. `energy_j` is the floating form's potential, the driving unit's
    /// weight included.
    pub fn held(robot: &Robot, held: &Held) -> BodyReport {
        let (body, q) = (&held.body, &held.equilibrium.q);
        let (qa, qb) = body.split(&q[..body.chain_a().len() + body.chain_b().len()]);
        let [a, b] = held.chain_points(robot);
        BodyReport {
            model: "two-chain",
            solution: (&held.equilibrium).into(),
            robot: robot.name.clone(),
            lengths_m: [body.chain_a().tube_length(), body.chain_b().tube_length()],
            links: [qa.len(), qb.len()],
            shape_parameter: robot.shape_parameter(),
            endpoint_m: held.endpoint_m,
            endpoint_angle_rad: body.endpoint_angle(q),
            energy_j: held.equilibrium.energy,
            chains: Chains {
                a: ChainShape { points_m: a, angles_rad: qa.to_vec() },
                b: ChainShape { points_m: b, angles_rad: qb.to_vec() },
            },
        }
    }
}

/// A half-plane as JSON.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HalfPlaneReport {
    /// A point on the surface line (m).
    pub point_m: Vec2,
    /// Unit outward normal, into free space.
    pub normal: Vec2,
}

/// A polygon as JSON.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PolygonReport {
    /// The vertices, counter-clockwise (m).
    pub points_m: Vec<Vec2>,
}

/// A scene as `leech scene show --json` prints it: the file's keys.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneReport {
    /// Display name.
    pub name: String,
    /// The half-planes, in order.
    pub half_plane: Vec<HalfPlaneReport>,
    /// The polygons, in order.
    pub polygon: Vec<PolygonReport>,
}

impl From<&Scene> for SceneReport {
    fn from(scene: &Scene) -> SceneReport {
        let mut report = SceneReport { name: scene.name.clone(), half_plane: Vec::new(), polygon: Vec::new() };
        for solid in &scene.solids {
            match solid {
                Solid::HalfPlane { point_m, normal } => {
                    report.half_plane.push(HalfPlaneReport { point_m: *point_m, normal: *normal })
                }
                Solid::Polygon { points_m } => report.polygon.push(PolygonReport { points_m: points_m.clone() }),
            }
        }
        report
    }
}
