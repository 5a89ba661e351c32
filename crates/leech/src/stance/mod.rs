//! The body in a situation: which cups hold it, where, and the forces on them.
//! (The single clamped tube resting on a scene's solids is [`tube`]; both
//! share the contact machinery through [`Touching`].)
//!
//! # Equations
//!
//! The driving unit is a rigid body with pose `(p0, phi0)`: `p0` (m) is
//! chain A's clamp and `phi0` (rad) the clamp direction; chain B's clamp is
//! at `p0 + b nu(phi0)`. Its mass `Md` (kg) sits at `y_unit = p0 + a e(phi0)
//! + c nu(phi0)` ([`Unit`]: `[driving_unit] centre_of_mass_m = [a, c]`, the
//! clamps' midpoint `(0, b/2)` by default), the rigid root pieces of the
//! `midpoint` discretization ride on it too, and where the rear cup does not
//! hold its outline rests on a scene's solids (docs/model.md section 7.3.3). With the chains' angles the unknowns are
//! `q = (phi^A, phi^B, p0_x, p0_y, phi0)` and the potential is
//!
//! ```text
//! V = sum_j k_j/2 (phi_j - phi_{j-1})^2 (phi_0 of each chain = phi0)
//!   + g (sum_i m_i y_i + ms y_tip + Md y_unit + root pieces)           (J)
//! ```
//!
//! Every point of a chain sits where the reference clamp (the body's own)
//! puts it, shifted by `p0 - p_ref + off(phi0) - off(phi_ref)` with
//! `off = 0` for chain A and `b nu(phi0)` for chain B (plus the root piece
//! `r e(phi0)`): `p0` enters linearly and only through gravity and the
//! holds, `phi0` through the first springs, the offsets' weight and the weld.
//! The Hessian keeps the chains banded and couples `(p0, phi0)` only through
//! the first springs: three *free* coordinates bordering the chains
//! ([`crate::statics::Potential::free`]).
//!
//! Situations are constraint rows on the same unknowns: the endpoint weld
//! always (docs/model.md section 6); a **rear hold** `p0 = P_r`, `phi0 = Th_r`
//! (3 rows: today's clamped body); a **front hold** `tip_A = P_f`,
//! `phi^A_nA = Th_f` (3 rows); or both (6 rows: a closed loop, statically
//! indeterminate, determined by the tubes' elasticity).
//!
//! # Reactions
//!
//! With the KKT conditions written `grad V - J^T lambda = 0`, a hold's
//! multipliers are the **reaction**: the force (N, world frame) the surface
//! exerts on the robot at the hold point and the moment (N m, counter-clockwise)
//! about it (`p0` for the rear hold, the endpoint for the front). The rear
//! hold's angle row carries the moment because a change of `phi0` alone turns
//! the driving unit about `p0`; the front's angle row acts on the plate alone.
//! All reactions together carry the whole weight `g (M_chains + ms + Md)`:
//! the driving unit's own weight goes straight into the rear hold when it holds
//! (it does not change the shape then).
//!
//! # Paths
//!
//! * rear: the clamped body's default path (feeding at `g = 0`, then gravity),
//!   then one Newton step in the floating form for the reactions;
//! * front: the unloaded shape moved rigidly so that its endpoint sits on the
//!   front hold, then gravity raised from 0 to `g`: the driving unit swings
//!   down, as after the rear cup releases;
//! * both: the rear-held equilibrium, then the front hold's target moved from
//!   where the endpoint is to where it is asked for, under full gravity, with
//!   the front hold's rows compliant, `C + c lambda = 0` (chain A as a
//!   cantilever times [`START_SOFTNESS`]: `c = s L^3/(k l)` m/N for the
//!   endpoint, `s L/(k l)` rad/(N m) for the plate); then that compliance
//!   taken to zero, the target held. Rigid rows from the start fail where
//!   chain A is straight: its tip cannot move along itself, a zero row of the
//!   Jacobian; compliant ones load it as a column, which buckles (a reported
//!   bifurcation). A target out of reach fails to converge: an error with the
//!   residual, never a stretched body.

pub mod census;

mod feeding;
mod floating;
mod phases;
mod points;
mod scene_solve;
pub mod tube;
mod unit;

pub use crate::cantilever::{start_compliance, START_SOFTNESS};
pub use crate::contact::planar::{
    detect, penetration, swept_clear, ContactOptions, ContactRow, Face, Touching, FRONT_CUP, REAR_CUP, UNIT,
};
pub use crate::error::StanceError;
pub use crate::hold::{Hold, Pose};
pub use crate::hose::{StopMoment, StopRow};
pub use feeding::{FALLBACK_STEP_M, FEED_STEP_M, MIN_FEED_STEP_M};
pub use floating::{Approach, CupFaces, FloatingBody, FREE, HOLD_ROWS};
pub use phases::{solve_after, RELEASE_SPAN_M};
pub use tube::{tube_in, Tube, TubeHeld, TUBE_FEED_START_M};
pub use unit::Unit;

use crate::body::{Body, WELD_ROWS};
use crate::error::InputError;
use crate::geom::{rotate, sub, Vec2};
use crate::hose;
use crate::robot::Robot;
use crate::scene::Scene;
use crate::statics::{Equilibrium, Iterate, Potential, Scratch, SolveError, Solver, Stage};
use feeding::{Fed, Feeding};

/// The force (N) and moment (N m, counter-clockwise) a hold's surface exerts
/// on the robot, about the hold point.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Reaction {
    /// Force on the robot, world frame (N).
    pub force_n: Vec2,
    /// Moment on the robot about the hold point (N m).
    pub moment_nm: f64,
}

/// An equilibrium of the body in a situation.
#[derive(Clone, Debug, PartialEq)]
pub struct Held {
    /// The situation.
    pub hold: Hold,
    /// The clamped body whose chains the solution's angles belong to.
    pub body: Body,
    /// The equilibrium of the floating form: `q = (phi^A, phi^B, p0, phi0)`.
    pub equilibrium: Equilibrium,
    /// The driving unit's pose.
    pub unit: Pose,
    /// The endpoint (chain A's tip, m).
    pub endpoint_m: Vec2,
    /// The rear hold's reaction, when it holds.
    pub rear: Option<Reaction>,
    /// The front hold's reaction, when it holds.
    pub front: Option<Reaction>,
    /// The weight carried (N).
    pub weight_n: f64,
    /// Where that weight acts: the centre of mass (m).
    pub centre_of_mass: Vec2,
    /// The contacts that push (normal force above zero).
    pub contacts: Vec<ContactForce>,
    /// The contact rows the equilibrium was solved with (the system's last
    /// rows, in the order of the multipliers): what a phase that continues
    /// from it starts resting on ([`solve_after`]).
    pub contact_rows: Vec<ContactRow>,
    /// The joints locked at the hose's stop (a moment above zero;
    /// [`crate::hose`]).
    pub stops: Vec<StopMoment>,
    /// The stop rows the equilibrium was solved with (just before the
    /// contact rows, in the order of the multipliers).
    pub stop_rows: Vec<StopRow>,
}

/// A surface pushing on a tube, or on the face of a cup that does not hold.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ContactForce {
    /// `"a"` (centre tube) or `"b"` (side pair), `"rear_cup"` or
    /// `"front_cup"` (a face's rim); empty for the single tube ([`Tube`]),
    /// which has one chain (and then left out of JSON).
    #[serde(skip_serializing_if = "str::is_empty")]
    pub chain: &'static str,
    /// The node (0 is the clamp; node `i` the tip of link `i`); for a corner
    /// touching a link between nodes, the link's start node; on a cup's
    /// face, the rim (0 behind, 1 ahead).
    pub node: usize,
    /// How far along the link from that node the point is (0 at a node).
    pub fraction: f64,
    /// The touching point on the tube's centre line (m).
    pub point_m: Vec2,
    /// The surface's outward normal there.
    pub normal: Vec2,
    /// The normal force (N), along `normal`.
    pub force_n: f64,
}

/// Solves the body of `robot` at tube lengths `[LA, LB]` (m) held by `hold`.
///
/// ```
/// use leech::prelude::*;
/// use leech::stance::{self, Hold, Pose};
/// let robot = Robot::builtin();
/// let hold = Hold::Rear(Pose::from_deg([0.0, 0.0], 90.0));
/// let held = stance::solve(&robot, [0.25, 0.2], hold, &Solver::default()).unwrap();
/// // The rear cup carries the whole weight.
/// let rear = held.rear.unwrap();
/// assert!((rear.force_n[1] - held.weight_n).abs() < 1e-9 * held.weight_n);
/// ```
pub fn solve(robot: &Robot, lengths: [f64; 2], hold: Hold, solver: &Solver) -> Result<Held, StanceError> {
    crate::hold::check_front_joint(robot, matches!(hold, Hold::FrontPivot(_)))?;
    match hold {
        Hold::Rear(pose) => {
            let body = rear_body(robot, lengths, pose)?;
            let eq = body.solve(solver)?;
            rear_held(robot, &body, &eq, pose, solver)
        }
        Hold::Front(pose) | Hold::FrontPivot(pose) => {
            let body = robot.body(lengths[0], lengths[1])?;
            let q = placed(&body, &unloaded(robot, lengths, solver)?, pose);
            let floating = FloatingBody::of(robot, &body, hold, Approach::Load);
            continued(&floating, q, solver)
        }
        Hold::Both { rear, front } => {
            attach_front(robot, &solve(robot, lengths, Hold::Rear(rear), solver)?, front, solver)
        }
    }
}

/// [`solve`] warm from `near`, an equilibrium of the same hold at nearby
/// lengths: the chains' angles carried over, the driving unit's pose kept,
/// Newton at full load (a front hold's cold solve follows the load from the
/// unloaded shape). Where Newton fails or ends unstable, the cold solve.
/// The equilibrium is the one nearest `near`, not necessarily the one
/// [`solve`] finds: a search's probe, to be confirmed cold.
pub fn solve_near(robot: &Robot, lengths: [f64; 2], near: &Held, solver: &Solver) -> Result<Held, StanceError> {
    let (Hold::Front(_) | Hold::FrontPivot(_)) = near.hold else { return solve(robot, lengths, near.hold, solver) };
    let body = robot.body(lengths[0], lengths[1])?;
    let chains = near.body.dim();
    let mut q = body.carry_over(&near.body, &near.equilibrium.q[..chains]);
    q.extend_from_slice(&near.equilibrium.q[chains..]);
    let floating = FloatingBody::of(robot, &body, near.hold, Approach::Load);
    let warm = Scratch::with_spare(&floating, |ws| {
        let mut it = Iterate::new(q);
        let residual = solver.minimize(&floating, &mut it, 1.0, Stage::Load, ws)?;
        Ok::<_, SolveError>(solver.finish(&floating, it, residual, ws))
    });
    match warm {
        Ok(equilibrium) if equilibrium.stable => Ok(Held::new(&floating, equilibrium)),
        _ => solve(robot, lengths, near.hold, solver),
    }
}

/// The rear-held equilibrium `held` (no scene) with the front cup attached
/// at `front`: the front hold's target moved from where the endpoint is to
/// `front` under full gravity (warm: from `held`'s shape). A target out of
/// reach fails to converge.
///
/// ```
/// use leech::prelude::*;
/// use leech::stance::{self, Hold, Pose};
/// let robot = Robot::builtin();
/// let free = stance::solve(&robot, [0.25, 0.2], Hold::Rear(Pose::from_deg([0.0, 0.0], 90.0)), &Solver::default()).unwrap();
/// // Attached 2 mm beyond where the endpoint hangs: both cups carry the robot.
/// let front = Pose { point_m: [free.endpoint_m[0], free.endpoint_m[1] + 0.002], angle_rad: free.plate_angle() };
/// let both = stance::attach_front(&robot, &free, front, &Solver::default()).unwrap();
/// let total = both.rear.unwrap().force_n[1] + both.front.unwrap().force_n[1];
/// assert!((total - both.weight_n).abs() < 1e-9 * both.weight_n);
/// ```
pub fn attach_front(robot: &Robot, held: &Held, front: Pose, solver: &Solver) -> Result<Held, StanceError> {
    let Some(rear) = held.hold.rear() else {
        return Err(InputError::Invalid {
            field: "hold".into(),
            value: "front".into(),
            allowed: "a rear-held equilibrium to attach the front cup to".into(),
        }
        .into());
    };
    let from = Pose { point_m: held.endpoint_m, angle_rad: held.plate_angle() };
    let hold = Hold::Both { rear, front };
    let floating = FloatingBody::of(robot, &held.body, hold, Approach::Front(from));
    continued(&floating, held.equilibrium.q.clone(), solver).map_err(|e| beyond_reach(e, &held.body, rear, front))
}

/// `e`, a failed solve with both holds, as [`StanceError::OutOfReach`] when
/// the front hold lies farther from the driving unit than chain A reaches.
fn beyond_reach(e: StanceError, body: &Body, rear: Pose, front: Pose) -> StanceError {
    let distance_m = crate::geom::norm(sub(front.point_m, rear.point_m));
    let reach_m = body.chain_a().tube_length();
    match e {
        StanceError::Solve(source) if distance_m > reach_m => StanceError::OutOfReach { distance_m, reach_m, source },
        other => other,
    }
}

/// The clamped `body`'s equilibrium `eq` (its clamp at the origin, at the
/// hold's angle) held by the rear cup at `pose`: one Newton step in the
/// floating form, which gives the reactions and leaves the angles as they are.
pub fn rear_held(
    robot: &Robot,
    body: &Body,
    eq: &Equilibrium,
    pose: Pose,
    solver: &Solver,
) -> Result<Held, StanceError> {
    let floating = FloatingBody::of(robot, body, Hold::Rear(pose), Approach::Load);
    let mut ws = Scratch::for_system(&floating);
    // The weld's rows come first and are the clamped body's, so its
    // multipliers carry over (the Lagrangian's curvature is right from the
    // start); the hold's rows are linear in the pose, one Newton step finds
    // theirs.
    let mut it = Iterate::new(with_pose(&eq.q, pose));
    it.lambda = eq.multipliers.clone();
    it.lambda.resize(crate::statics::Constraints::rows(&floating), 0.0);
    it.active = vec![true; it.lambda.len()];
    let eq = solver.warm_start_from(&floating, it, &mut ws)?;
    Ok(Held::new(&floating, eq))
}

/// The centre of the rear cup's face for the driving unit at `unit`:
/// `b + rear_offset` from `p0` along `nu(phi0)` (the surfaces lie on chain
/// B's side, docs/model.md section 3) and `rear_cup_behind` behind it
/// along `-e(phi0)`.
pub fn rear_cup_centre(robot: &Robot, unit: Pose) -> Vec2 {
    crate::geom::add_scaled(unit.point_m, 1.0, rear_cup_offset(robot, unit.angle_rad))
}

/// The driving unit's outline in the world with the unit at `unit` (m):
/// [`crate::robot::DrivingUnit::outline_m`]'s corners placed by its clamp
/// point and direction; `None` for a unit without an outline.
pub fn unit_outline(robot: &Robot, unit: Pose) -> Option<[Vec2; 4]> {
    let outline = robot.driving_unit.outline_m()?;
    Some(outline.map(|corner| unit::placed(unit.point_m, corner, unit.angle_rad)[0]))
}

/// Where the driving unit held at `unit` (a rear hold's pose) overlaps
/// `scene`'s solids ([`Scene::overlap`]), deeper than the robot file's
/// preload (to rounding): no solve can move a held unit out of a solid.
pub fn held_unit_overlap(robot: &Robot, unit: Pose, scene: &Scene) -> Option<crate::scene::Overlap> {
    scene.overlap(&unit_outline(robot, unit)?, crate::scene::ON_SURFACE_M + robot.cup.preload_m)
}

/// Refuses a hold whose rear pose (a rear hold, or both) puts the driving
/// unit's outline into `scene`'s solids ([`held_unit_overlap`]), naming
/// where: the solves among solids check it before they start.
pub fn check_held_unit(robot: &Robot, hold: Hold, scene: &Scene) -> Result<(), InputError> {
    let Some(rear) = hold.rear() else { return Ok(()) };
    let Some(overlap) = held_unit_overlap(robot, rear, scene) else { return Ok(()) };
    let [x, y] = rear.point_m.map(|c| crate::error::Num(c).to_string());
    let [px, py] = overlap.point_m.map(|c| c * 1e3);
    Err(InputError::Invalid {
        field: "hold (rear)".into(),
        value: format!("the driving unit at ({x}, {y}) m, {:.3} deg", rear.angle_rad.to_degrees()),
        allowed: format!(
            "a pose whose driving unit lies clear of the solids (its outline reaches {:.1} mm into one at ({px:.1}, {py:.1}) mm)",
            overlap.depth_m * 1e3
        ),
    })
}

/// The rear cup's face centre from `p0` for the clamp direction `angle` (m).
fn rear_cup_offset(robot: &Robot, angle: f64) -> Vec2 {
    let faces = cup_faces(robot);
    unit::placed([0.0, 0.0], [-faces.rear_behind_m, faces.rear_m], angle)[0]
}

/// The driving unit's pose that puts the rear cup's face centre at `cup`
/// (m) with the clamp direction `direction` (rad): the inverse of
/// [`rear_cup_centre`].
pub fn rear_pose_for_cup(robot: &Robot, cup: Vec2, direction: f64) -> Pose {
    Pose { point_m: sub(cup, rear_cup_offset(robot, direction)), angle_rad: direction }
}

/// The endpoint pose (chain A's tip and the plate's angle) that puts the
/// front cup's face centre at `cup` (m) with the plate along `direction`
/// (rad): the inverse of [`front_cup_centre`].
pub fn front_pose_for_cup(robot: &Robot, cup: Vec2, direction: f64) -> Pose {
    let d = robot.body.tip_spacing_m + robot.cup.front_offset_m;
    Pose { point_m: crate::geom::add_scaled(cup, -d, crate::geom::right_normal(direction)), angle_rad: direction }
}

/// The centre of the front cup's face for the endpoint and plate at
/// `endpoint`: `c + front_offset` from the endpoint along `nu` of the plate
/// (`front_offset` from chain B's tip).
pub fn front_cup_centre(robot: &Robot, endpoint: Pose) -> Vec2 {
    let d = robot.body.tip_spacing_m + robot.cup.front_offset_m;
    crate::geom::add_scaled(endpoint.point_m, d, crate::geom::right_normal(endpoint.angle_rad))
}

/// Each chain's stiffness at the hose's stop (N m/rad): the tube's times
/// the tubes the chain stands for.
fn hose_stiffness(robot: &Robot) -> [f64; 2] {
    crate::robot::TUBES_PER_CHAIN.map(|tubes| tubes * robot.tube.stop_stiffness())
}

/// What besides the tubes touches a scene's solids.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FreeCups {
    /// Only the tubes (the validated model of the holds-and-contacts references).
    #[default]
    PassThrough,
    /// The face of a cup that does not hold rests on what it meets too (its
    /// two rims get contact rows, no clearance): a released cup lying on a
    /// floor or pressed on a wall, as the climb planner needs.
    Rest,
}

impl FreeCups {
    /// `floating` as it is among solids: with `robot`'s hose stop, and its
    /// cup faces when they rest on the solids.
    fn on<'a>(self, robot: &Robot, floating: FloatingBody<'a>) -> FloatingBody<'a> {
        let floating = floating.with_hose_stop(robot.tube.min_bend_radius_m, hose_stiffness(robot));
        match self {
            FreeCups::Rest => floating.with_cup_faces(cup_faces(robot)),
            FreeCups::PassThrough => floating,
        }
    }
}

/// [`solve`] among the solids of `scene`: the tubes keep their radius of
/// clearance and rest on what they touch (see [`detect`]).
///
/// The path is the robot's own: the tubes start at the shortest length
/// (`[limits] tube_length_min_m`, or the shorter of the two if less), held
/// as asked and under gravity, and are fed to their lengths in steps of at
/// most [`FEED_STEP_M`], the contact rows refreshed at every step; with both
/// holds, the front hold's target then moves from where the endpoint is to
/// where it is asked for, in stages.
pub fn solve_in(
    robot: &Robot,
    lengths: [f64; 2],
    hold: Hold,
    scene: &Scene,
    solver: &Solver,
) -> Result<Held, StanceError> {
    solve_among(robot, lengths, hold, scene, solver, FreeCups::PassThrough)
}

/// [`solve_in`], with the free cups' faces touching the solids as `cups` says.
///
/// This is the cold start: where the robot is in an equilibrium already, a
/// phase (a move of the tubes, a release, an attach) continues from it with
/// [`solve_after`] instead. A rear hold that puts the driving unit's outline
/// into a solid is refused ([`check_held_unit`]), as [`solve_after`] refuses it.
pub fn solve_among(
    robot: &Robot,
    lengths: [f64; 2],
    hold: Hold,
    scene: &Scene,
    solver: &Solver,
    cups: FreeCups,
) -> Result<Held, StanceError> {
    check_held_unit(robot, hold, scene)?;
    crate::hold::check_front_joint(robot, matches!(hold, Hold::FrontPivot(_)))?;
    let radius = 0.5 * robot.tube.outer_diameter_m;
    let first = match hold {
        Hold::Both { rear, .. } => Hold::Rear(rear),
        other => other,
    };
    let short = robot.limits.tube_length_min_m.min(lengths[0]).min(lengths[1]);
    let start = solve(robot, [short; 2], first, solver)?;
    let fed = BodyFeed { robot, hold: first, from: [short; 2], to: lengths, cups };
    let end = Feeding { fed, scene, radius, solver }.run(start.body, start.equilibrium.q)?;
    let Hold::Both { .. } = hold else { return Ok(fed_end(robot, end, first, cups)) };
    front_attached(robot, &end.shape, &end.equilibrium.q, hold, scene, solver, cups)
}

/// The held body where a feed (or a release) ended, `hold` holding it.
fn fed_end(robot: &Robot, end: feeding::FedEnd<Body>, hold: Hold, cups: FreeCups) -> Held {
    let floating = cups
        .on(robot, FloatingBody::of(robot, &end.shape, hold, Approach::Load))
        .with_stops(end.stops)
        .with_contacts(end.contacts);
    Held::settled(scene_solve::Settled { system: floating, equilibrium: end.equilibrium })
}

/// The rear-held equilibrium `q` of `body` among `scene`'s solids with the
/// front cup attached too, as `hold` (both cups) says: the front hold's
/// target moved from where the endpoint is to the hold's, in stages.
fn front_attached(
    robot: &Robot,
    body: &Body,
    q: &[f64],
    hold: Hold,
    scene: &Scene,
    solver: &Solver,
    cups: FreeCups,
) -> Result<Held, StanceError> {
    let radius = 0.5 * robot.tube.outer_diameter_m;
    let (Some(rear), Some(front)) = (hold.rear(), hold.front()) else {
        return Err(InputError::Invalid {
            field: "hold".into(),
            value: hold.name().into(),
            allowed: "both cups holding, to attach the front cup".into(),
        }
        .into());
    };
    let at = FloatingBody::of(robot, body, Hold::Rear(rear), Approach::Load).endpoint(q);
    let from = Pose { point_m: at, angle_rad: body.endpoint_angle(q) };
    let both = cups.on(robot, FloatingBody::of(robot, body, hold, Approach::Front(from)));
    match scene_solve::approached(both, q.to_vec(), scene, radius, solver) {
        Ok(approached) => Ok(Held::settled(approached)),
        Err(e) => Err(beyond_reach(e, body, rear, front)),
    }
}

/// Where `robot`'s cup faces sit on the driving unit and the plate.
pub fn cup_faces(robot: &Robot) -> CupFaces {
    CupFaces {
        rear_m: robot.body.base_spacing_m + robot.cup.rear_offset_m,
        rear_behind_m: robot.driving_unit.rear_cup_behind_m,
        front_m: robot.body.tip_spacing_m + robot.cup.front_offset_m,
        half_width_m: 0.5 * robot.cup.diameter_m,
    }
}

/// The body's tubes fed from `from` to `to` (m), held by `hold`.
struct BodyFeed<'a> {
    robot: &'a Robot,
    hold: Hold,
    from: [f64; 2],
    to: [f64; 2],
    cups: FreeCups,
}

impl Fed for BodyFeed<'_> {
    type Shape = Body;
    type System<'s> = FloatingBody<'s>;

    fn span(&self) -> f64 {
        (self.to[0] - self.from[0]).abs().max((self.to[1] - self.from[1]).abs())
    }

    /// The clamped body at the fed lengths.
    fn shape_at(&self, fraction: f64) -> Result<Body, InputError> {
        let fed = [0, 1].map(|i| self.from[i] + fraction * (self.to[i] - self.from[i]));
        match self.hold {
            Hold::Rear(pose) => rear_body(self.robot, fed, pose),
            _ => self.robot.body(fed[0], fed[1]),
        }
    }

    fn system<'s>(&self, body: &'s Body) -> FloatingBody<'s> {
        self.cups.on(self.robot, FloatingBody::of(self.robot, body, self.hold, Approach::Load))
    }

    /// The chains' angles carried over, the driving unit's pose kept.
    fn carried(&self, next: &Body, body: &Body, q: &[f64]) -> Vec<f64> {
        let chains = body.dim();
        let mut carried = next.carry_over(body, &q[..chains]);
        carried.extend_from_slice(&q[chains..]);
        carried
    }
}

/// The body clamped at the rear hold's angle (its clamp at the origin; the
/// floating form moves it to the hold's point).
fn rear_body(robot: &Robot, lengths: [f64; 2], pose: Pose) -> Result<Body, InputError> {
    robot.with_base_angle(pose.angle_rad.to_degrees())?.body(lengths[0], lengths[1])
}

/// The unloaded (`g = 0`) shape at the robot's base angle.
fn unloaded(robot: &Robot, lengths: [f64; 2], solver: &Solver) -> Result<Vec<f64>, StanceError> {
    Ok(robot.with_gravity(0.0)?.body(lengths[0], lengths[1])?.solve(solver)?.q)
}

/// Follows `floating`'s approach from `q` (an equilibrium at `t = 0`) to
/// `t = 1`, then the one that follows it from where it ended
/// ([`Approach::then`]: a front approach's rows stiffened).
fn continued(floating: &FloatingBody<'_>, q: Vec<f64>, solver: &Solver) -> Result<Held, StanceError> {
    let stiffened = floating.approach().then().map(|next| floating.clone().with_approach(next));
    let last = stiffened.as_ref().unwrap_or(floating);
    Scratch::with_spare(floating, |ws| {
        let mut it = Iterate::new(q);
        let mut residual = 0.0;
        for phase in std::iter::once(floating).chain(stiffened.as_ref()) {
            residual = solver.continuation(phase, &mut it, 0.0, Stage::Load, ws)?;
        }
        Ok(Held::new(last, solver.finish(last, it, residual, ws)))
    })
}

/// The chains' angles with the driving unit's pose appended.
fn with_pose(q: &[f64], pose: Pose) -> Vec<f64> {
    let mut out = q.to_vec();
    out.extend([pose.point_m[0], pose.point_m[1], pose.angle_rad]);
    out
}

/// The body's shape `q` (at its own clamp) moved rigidly so that its
/// endpoint and plate sit on `pose`.
fn placed(body: &Body, q: &[f64], pose: Pose) -> Vec<f64> {
    let turn = pose.angle_rad - body.endpoint_angle(q);
    let clamp = body.chain_a().clamp_point();
    let arm = rotate(sub(body.endpoint(q), clamp), turn);
    let p0 = sub(pose.point_m, arm);
    let turned: Vec<f64> = q.iter().map(|phi| phi + turn).collect();
    with_pose(&turned, Pose { point_m: p0, angle_rad: body.chain_a().clamp_angle() + turn })
}

impl Held {
    /// The tube lengths (LA, LB) (m).
    pub fn lengths(&self) -> [f64; 2] {
        [self.body.chain_a().tube_length(), self.body.chain_b().tube_length()]
    }

    /// The tightest bend of the tubes (m), the clamp along the driving
    /// unit's direction ([`Chain::min_bend_radius`](crate::chain::Chain::min_bend_radius)).
    pub fn min_bend_radius(&self) -> f64 {
        let (qa, rest) = self.equilibrium.q.split_at(self.body.chain_a().len());
        let qb = &rest[..self.body.chain_b().len()];
        let angle = self.unit.angle_rad;
        self.body.chain_a().min_bend_radius_from(angle, qa).min(self.body.chain_b().min_bend_radius_from(angle, qb))
    }

    /// Whether no joint of `robot`'s tubes is turned past the hose's stop
    /// (`[tube] min_bend_radius_m`) but a locked one, by what its moment
    /// gives ([`hose::overturn`]) and at most [`hose::GIVE_FRACTION`] of the
    /// stop: a shape among solids whose joints lock there is; one solved in
    /// free space that bends past the stop is not, and neither is one whose
    /// locked hose is crushed.
    pub fn within_stop(&self, robot: &Robot) -> bool {
        let floating = FloatingBody::new(&self.body, robot.body.base_spacing_m, 0.0, self.hold, Approach::Load)
            .with_hose_stop(robot.tube.min_bend_radius_m, hose_stiffness(robot))
            .with_stops(self.stop_rows.clone());
        hose::overturn(&floating, &self.equilibrium.q, &self.equilibrium.multipliers) <= hose::AT_STOP_RAD
            && self.min_bend_radius() >= robot.tube.min_bend_radius_m / (1.0 + hose::GIVE_FRACTION)
    }

    fn new(floating: &FloatingBody<'_>, equilibrium: Equilibrium) -> Held {
        let hold = floating.hold();
        let reaction = |row: usize| Reaction {
            force_n: [equilibrium.multipliers[row], equilibrium.multipliers[row + 1]],
            moment_nm: equilibrium.multipliers[row + 2],
        };
        let rear = hold.rear().map(|_| reaction(WELD_ROWS));
        let front_row = WELD_ROWS + if rear.is_some() { HOLD_ROWS } else { 0 };
        let front = hold.front().map(|_| reaction(front_row));
        let contacts = scene_solve::contact_forces(floating, &equilibrium, |c| match c {
            0 => "a",
            1 => "b",
            REAR_CUP => "rear_cup",
            FRONT_CUP => "front_cup",
            _ => "unit",
        });
        let stops = hose::locked(floating, &equilibrium.multipliers)
            .map(|(stop, moment_nm)| {
                let points = floating.chain_points(&equilibrium.q, stop.chain);
                let joint = points.len() - floating.chain_len(stop.chain) - 1 + stop.joint;
                StopMoment {
                    chain: ["a", "b"][stop.chain],
                    joint: stop.joint,
                    point_m: points[joint],
                    sign: stop.sign,
                    moment_nm,
                }
            })
            .collect();
        Held {
            contacts,
            contact_rows: floating.contacts().to_vec(),
            stops,
            stop_rows: floating.stops().to_vec(),
            hold,
            body: floating.body().clone(),
            unit: floating.unit_pose(&equilibrium.q),
            endpoint_m: floating.endpoint(&equilibrium.q),
            rear,
            front,
            weight_n: floating.weight(),
            centre_of_mass: floating.centre_of_mass(&equilibrium.q),
            equilibrium,
        }
    }
}

/// A suction cup where a hold puts it: its face, the surface's normal, and
/// whether it holds under the hold's reaction ([`crate::cup`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CupState {
    /// Centre of the cup's face (m).
    pub centre_m: Vec2,
    /// The surface's outward normal at the face (from the surface into free space).
    pub normal: Vec2,
    /// The reaction moved to the face's centre: force (N) and moment (N m).
    pub force_n: Vec2,
    /// Moment about the face's centre (N m, counter-clockwise).
    pub moment_nm: f64,
    /// The verdict.
    pub verdict: crate::cup::CupVerdict,
}

impl Held {
    /// Everything the surfaces exert on the robot, summed: the holds'
    /// reactions and the contact forces (N), and their moment about the
    /// origin (N m, counter-clockwise). At equilibrium it carries the weight:
    /// `(0, W)` and `x_G W`.
    pub fn support(&self) -> Reaction {
        let mut total = Reaction { force_n: [0.0, 0.0], moment_nm: 0.0 };
        let mut add = |at: Vec2, force: Vec2, moment: f64| {
            total.force_n[0] += force[0];
            total.force_n[1] += force[1];
            total.moment_nm += moment + crate::geom::cross(at, force);
        };
        if let Some(r) = &self.rear {
            add(self.unit.point_m, r.force_n, r.moment_nm);
        }
        if let Some(r) = &self.front {
            add(self.endpoint_m, r.force_n, r.moment_nm);
        }
        for c in &self.contacts {
            add(c.point_m, [c.force_n * c.normal[0], c.force_n * c.normal[1]], 0.0);
        }
        total
    }

    /// The plate's angle (rad): chain A's last link.
    pub fn plate_angle(&self) -> f64 {
        self.body.endpoint_angle(&self.equilibrium.q)
    }

    /// Where the rear cup's face is ([`rear_cup_centre`]).
    pub fn rear_cup_m(&self, robot: &Robot) -> Vec2 {
        rear_cup_centre(robot, self.unit)
    }

    /// The driving unit's outline in the world, its corners as
    /// [`crate::robot::DrivingUnit::outline_m`] orders them (m); `None` for
    /// a unit without one.
    pub fn unit_outline_m(&self, robot: &Robot) -> Option<[Vec2; 4]> {
        let Pose { point_m, angle_rad } = self.unit;
        robot.driving_unit.outline_m().map(|corners| corners.map(|c| unit::placed(point_m, c, angle_rad)[0]))
    }

    /// Where the front cup's face is ([`front_cup_centre`]).
    pub fn front_cup_m(&self, robot: &Robot) -> Vec2 {
        let plate = self.body.endpoint_angle(&self.equilibrium.q);
        front_cup_centre(robot, Pose { point_m: self.endpoint_m, angle_rad: plate })
    }

    /// The cups that hold, with their verdicts: each reaction moved to its
    /// cup's centre (`M_c = M + (p - c) x F`), the surface facing the cup
    /// (outward normal `-nu`).
    pub fn cups(&self, robot: &Robot) -> Result<(Option<CupState>, Option<CupState>), InputError> {
        let state = |reaction: &Reaction, at: Vec2, centre: Vec2, angle: f64| -> Result<CupState, InputError> {
            let nu = crate::geom::right_normal(angle);
            let normal = [-nu[0], -nu[1]];
            let arm = sub(at, centre);
            let moment = reaction.moment_nm + crate::geom::cross(arm, reaction.force_n);
            let verdict = crate::cup::verdict(&robot.cup, reaction.force_n, moment, normal)?;
            Ok(CupState { centre_m: centre, normal, force_n: reaction.force_n, moment_nm: moment, verdict })
        };
        let rear = self.rear.as_ref().map(|r| state(r, self.unit.point_m, self.rear_cup_m(robot), self.unit.angle_rad));
        let plate = self.body.endpoint_angle(&self.equilibrium.q);
        let front = self.front.as_ref().map(|r| state(r, self.endpoint_m, self.front_cup_m(robot), plate));
        Ok((rear.transpose()?, front.transpose()?))
    }

    /// The deepest penetration of the tubes into `scene` (m; 0 when clear).
    pub fn penetration_m(&self, robot: &Robot, scene: &Scene) -> f64 {
        let floating = FloatingBody::new(&self.body, robot.body.base_spacing_m, 0.0, self.hold, Approach::Load);
        penetration(&floating, &self.equilibrium.q, scene, 0.5 * robot.tube.outer_diameter_m).max(0.0)
    }
}
