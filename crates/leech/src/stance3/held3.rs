//! Holds in 3D: the rear cup (the driving unit fixed), the front cup (the
//! plate fixed, the driving unit hanging from it) or both (a closed loop),
//! each holding cup's reaction as a 6-vector and its verdict
//! (docs/model3d.md section 8). [`solve`] and
//! [`solve_in`] are the entry points.
//!
//! # The front hold: gravity turning with the plate
//!
//! Held at the front, tube 1's tip sits at `P_f` and the plate's frame is
//! `R_f`; the driving unit hangs free. Rather than adding its pose as six
//! unknowns, the solver keeps it fixed where [`Body3::from_robot`] put it and
//! turns the world instead. In that picture (frames `R'`, points `x'`) the
//! world is `x = G (x' - x'_tip) + P_f` with `G = R_f R'_P^T` (so that the
//! plate's world frame is `R_f`), and the potential of every mass `m` is
//! `g m e_y . x`:
//!
//! ```text
//! V_g = g (R'_P u) . (X' - M x'_tip),     u = R_f^T e_y                       (J)
//! X' - M x'_tip = K + sum_ij c_ij R'_ij e_x
//! K    = sum_i M_i root_i + Md x_unit - M root_1                               (kg m)
//! c_ij = W_ij - M l_1j [i = 1]                                                (kg m)
//! ```
//!
//! `M` the whole robot's mass (tubes, payload, driving unit `Md`), `W_ij` the
//! levers of docs/model3d.md section 3. Every term is bilinear in the plate's
//! frame and one link's frame (the plate's own term is the constant `u . e_x`):
//! with `s = R'_P u` and `d = R'_ij e_x`, the link's derivatives are those of
//! a linear term (docs/model3d.md section 4) with `w = g c_ij s`, the plate's
//! those of a linear term with `w = g (K + sum c_ij d)` and `a = u`, and the
//! cross block (rows the plate, columns the link)
//!
//! ```text
//! d2/ddelta_P ddelta_ij = -g c_ij [u] R'_P^T R'_ij [e_x]                      (J/rad^2)
//! ```
//!
//! The plate is already a dense (border) coordinate of the factorization, so
//! the cross blocks cost nothing new: still O(n) per step. The path is the
//! planar front hold's: the unloaded shape (feeding at `g = 0`, the same
//! whichever cup holds), then gravity raised from 0 to `g` on the hanging
//! body. The answer is turned back into the world (`G`, the body placed
//! there so that its points are world points).
//!
//! The front cup carries the whole robot but what a scene's solids carry
//! ([`crate::contact::space`]: in this picture the solids turn with the plate
//! too): by the whole body's balance, with contact forces `f_c = mu_c n_c`
//! at the points `p_c`, about the face's centre `c`,
//!
//! ```text
//! F = (0, g M, 0) - sum_c f_c                                                  (N)
//! M = (X - M c) x (0, g, 0) - sum_c (p_c - c) x f_c                            (N m)
//! ```
//!
//! (`X` the first moment of every mass, kg m).
//!
//! # Both cups: six rows
//!
//! With both cups holding, the driving unit stays where it was built (the
//! rear hold) and the front hold adds six rows on the target `(P_f, R_f)`:
//!
//! ```text
//! C_tip = root_1 + sum_j l_1j R_1j e_x - P_f = 0                      (m, 3 rows)
//! C_ori = Log(R_f^T R_P) = 0                                          (rad, 3 rows)
//! ```
//!
//! with multipliers `mu_tip` (N) and `mu_ori` (N m); the Lagrangian gets
//! `-mu_tip . C_tip - mu_ori . C_ori`. Row `c` of `C_tip` is a sum of
//! linear terms `e_c . (R_1j Exp(delta) a_j)`, `a_j = l_1j e_x`
//! (docs/model3d.md section 4), so on every link `j` of tube 1
//!
//! ```text
//! dC_tip,c/ddelta_j = a_j x (R_1j^T e_c)                                   (m/rad)
//! d2(-mu_tip . C_tip)/ddelta_j^2 = -(sym(w a_j^T) - (w . a_j) I),  w = R_1j^T mu_tip   (J/rad^2)
//! ```
//!
//! and no second derivative couples two links: the rows are a contact's
//! rows ([`crate::contact::space`]) with the normals `e_x, e_y, e_z`, bilateral.
//! `C_ori` is a relative term (section 4) with the fixed `R_f` in place of
//! the first frame, so only the plate moves it:
//!
//! ```text
//! dC_ori/ddelta_P = Jr^-1(theta),   theta = Log(R_f^T R_P)                  (1)
//! d2(-mu_ori . C_ori)/ddelta_P^2 = sym(D P),   D at w = -mu_ori            (J/rad^2)
//! ```
//!
//! (`P = Jr^-1(theta)`, `D` section 4's derivative of `P^T w`). The six rows
//! are run-time border rows of the factorization after the weld's 12 and
//! before any contact's: the tip rows reach tube 1's links, the rotation
//! rows only the plate, which is already a border coordinate; their
//! Hessians add to the diagonal blocks and the plate's corner: still O(n)
//! per step, and a constrained minimum has `12 + 6` negative eigenvalues.
//!
//! **The path** is the planar stance's both-hold: the rear hold's
//! equilibrium (feeding, then gravity), then the target moved from where the
//! endpoint is, `(p_tip, R_P)`, to `(P_f, R_f)` under full gravity by
//! continuation in `t` from 0 to 1: `P(t) = p_tip + t (P_f - p_tip)`,
//! `R(t) = R_P Exp(t Log(R_P^T R_f))` (the geodesic). At `t = 0` the rows
//! hold with zero multipliers. Along it the rows are compliant, `C + c mu =
//! 0` (`c` on the tip rows `1e-3 L1^3 / (k l)` m/N, on the frame's `1e-3 L1 /
//! (k l)` rad/(N m)), which keeps the KKT matrix regular where a straight
//! tube 1 gives the tip rows no Jacobian (the body then buckles under the
//! rows' force, a bifurcation like any other); at `t = 1` a second
//! continuation takes `c` to 0 with the target held. A target out of reach
//! ends in an error with the residual, never a stretched body.
//!
//! **The front reaction** is the six multipliers: `J^T mu` is the
//! generalized force of a force `mu_tip` at tube 1's tip and of a moment
//! `M` on the plate whose virtual work `M . (R_P delta_P)` equals
//! `(Jr^-1(theta)^T mu_ori) . delta_P`. About the front cup's centre `c_f`:
//!
//! ```text
//! F_f = mu_tip                                                         (N)
//! M_f = R_P Jr^-1(theta)^T mu_ori + (p_tip - c_f) x mu_tip              (N m)
//! ```
//!
//! The rear reaction is the rear hold's below, with `mu_tip` among the
//! forces on tube 1. The two together carry the whole robot: the test
//! `body3_hold::both_cups_carry_the_whole_body` checks the force and moment
//! balance against the masses alone.
//!
//! # The rear hold
//!
//! With the driving unit fixed (the body as built), the rear cup's surface
//! carries everything: the tubes, the payload and the
//! driving unit's own mass `Md` (kg), which sits where the planar model puts
//! it, at the midpoint of tube 1's root and the midpoint of tubes 2 and 3's
//! roots (`p0 + R0 (0, r_b/4, 0)`; it does not change the shape).
//!
//! # The reaction, from the forces at the roots
//!
//! Each tube `i` is held at its root by the unit with a force `F_i` and,
//! through its first joint's spring, a moment `M_i`. The tube's own balance
//! gives the force: everything else on it is gravity (its links' masses and
//! tip mass, `M_i` kg in all) and the weld (docs/model3d.md section 5: the
//! multipliers of the position rows act as forces `+lambda_s` on tube
//! `s + 1`'s tip and `-lambda_s` on the plate, which is tube 1's):
//!
//! ```text
//! F_i = (0, g M_i, 0) - W_i - sum_c mu_c n_c,     W_2 = lambda_pos,2,  W_3 = lambda_pos,3,  W_1 = -(W_2 + W_3) + mu_tip  (N)
//! M_i = -R_i1 Jr^-1(theta_1)^T K_1 theta_1,    theta_1 = Log(R0^T R_i1)                          (N m)
//! ```
//!
//! (the sum over the tube's contacts with a scene's solids, forces `mu_c`
//! along their planes' normals `n_c`, [`crate::contact::space`]; `mu_tip` the
//! front hold's force on tube 1's tip when both cups hold, else 0; the
//! spring's moment on the tube's first link: `-dE/ddelta` in the link's
//! frame, turned to the world). The unit is in balance under the
//! tubes' reactions, its weight and the surface, so the surface exerts, about
//! the cup's centre `c`,
//!
//! ```text
//! F = sum_i F_i + (0, g Md, 0)                                                  (N)
//! M = sum_i (M_i + (root_i - c) x F_i) + (x_unit - c) x (0, g Md, 0)            (N m)
//! ```
//!
//! Only at an equilibrium do these equal the whole body's balance,
//! `F = (0, g M_total, 0)` and `M = (X - M_total c) x (0, g, 0)` with
//! `X = sum m x` the first moment of every mass: the test
//! `body3_hold::rear_reaction_balances_the_whole_body` checks one against
//! the other.
//!
//! # The cup
//!
//! The rear cup's face centre is `b + rear_offset` from tube 1's root along
//! the unit's right normal `nu = -R0 e_y` (towards tubes 2 and 3), the
//! surface's outward normal `n = -nu`, as in the planar stance. The verdict
//! is [`crate::cup`]'s with the 3D loads: the pull or push `F . n`, the shear
//! `|F - (F . n) n|` plus the twist `|M . n|` taken up by friction at the
//! lip (`|M . n| / R`: the ring's friction force carrying the moment about
//! its axis), and the peel moment `|M - (M . n) n|` (tilting the cup). With
//! an in-plane load the twist is zero and the verdict the planar one.
use super::equilibrium3::Equilibrium3;
use super::place3::{first_inside, front_cup_centre, hold_points};
use crate::body3::body3::{Body3, Derivatives, Frames, Param, Terms3, PLATE_ROWS};
use crate::contact::space::{row_sink, ContactRow3};
use crate::cup::{Cup, CupVerdict};
use crate::error::StanceError;
use crate::error::{InputError, Num};
use crate::geom3::{
    apply, axpy, column, cross, dot, exp, hat, jr_inv, linear_terms, log, mul, mul_tn, pair_terms, scale, scale_mat,
    transpose, Mat3, Vec3,
};
use crate::hold::front3::{FrontHold, FrontTarget, Hanging, FRONT_ROWS};
use crate::hold::{AsBuilt, Hold3, Pose3};
use crate::robot::Robot;
use crate::scene::Scene3;
use crate::statics::{Evaluation, Solver};

const E_X: Vec3 = [1.0, 0.0, 0.0];

/// The swing's step about a free front joint (rad): short enough for a warm
/// start to land on the same branch.
pub const SWING_STEP: f64 = 0.1;

/// Steps of [`SWING_STEP`] before the swing gives up: one full turn.
const SWING_STEPS: usize = 63;

/// The free joint's moment about its axis, relative to `W L1`, below which
/// the swing has come to rest.
pub const PIVOT_TOLERANCE: f64 = 1e-11;

/// Regula falsi iterations on the turn.
const PIVOT_ITERATIONS: usize = 100;

/// A term of [`Body3::plate_bilinear`] at one point: its value and the
/// plate's own gradient and Hessian block.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlateTerm {
    pub value: f64,
    pub gradient: Vec3,
    pub hessian: Mat3,
}

/// The body held by a cup: where the hold puts it, its equilibrium in world
/// frames, and each holding cup.
#[derive(Clone, Debug, PartialEq)]
pub struct Held3 {
    /// The hold.
    pub hold: Hold3,
    /// The body placed where the hold puts it (its roots and driving unit in
    /// the world; [`Body3::points`] of it gives world points).
    pub body: Body3,
    /// The equilibrium: world frames; the weld's position multipliers (N)
    /// in world axes.
    pub equilibrium: Equilibrium3,
    /// The rear cup, when it holds.
    pub rear: Option<CupState3>,
    /// The front cup, when it holds.
    pub front: Option<CupState3>,
    /// On a free front joint: how far the plate turned about the face's
    /// normal from where the swing started (rad, right-handed about it).
    pub pivot_turn_rad: Option<f64>,
}

/// A force (N, world frame) and a moment (N m, world frame) about a stated point.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Wrench {
    /// Force (N).
    pub force_n: Vec3,
    /// Moment (N m).
    pub moment_nm: Vec3,
}

/// A holding cup in 3D: its face, the surface's normal, the reaction the
/// surface exerts on the robot there, and the verdict.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CupState3 {
    /// Centre of the cup's face (m).
    pub centre_m: Vec3,
    /// The surface's outward unit normal (from the surface into free space).
    pub normal: Vec3,
    /// The reaction on the robot: force (N) and moment about the centre (N m).
    pub reaction: Wrench,
    /// Whether the cup holds, and by what margin ([`crate::cup`]).
    pub verdict: CupVerdict,
}

/// A holding cup at `centre` (m) with the surface's normal `normal` under
/// `reaction`, judged against `robot`'s cup.
fn cup_state(robot: &Robot, centre: Vec3, normal: Vec3, reaction: Wrench) -> Result<CupState3, InputError> {
    let verdict = verdict3(&robot.cup, reaction.force_n, reaction.moment_nm, normal)?;
    Ok(CupState3 { centre_m: centre, normal, reaction, verdict })
}

/// The verdict of [`crate::cup::verdict`] for a 3D reaction: `force_n`
/// (N) and `moment_nm` (N m, about the cup's centre) the surface exerts on
/// the robot, `normal` its outward unit normal. The twist about the normal
/// is added to the shear as `|M . n| / R` (module doc). Errors (never
/// panics) for non-finite loads or a normal that is not a unit vector.
pub fn verdict3(cup: &Cup, force_n: Vec3, moment_nm: Vec3, normal: Vec3) -> Result<CupVerdict, InputError> {
    let finite = |v: Vec3| v.iter().all(|x| x.is_finite());
    let show = |v: Vec3| format!("({}, {}, {})", Num(v[0]), Num(v[1]), Num(v[2]));
    for (field, v) in [("cup force (N)", force_n), ("cup moment (N m)", moment_nm)] {
        if !finite(v) {
            return Err(InputError::Invalid {
                field: field.into(),
                value: show(v),
                allowed: "finite components".into(),
            });
        }
    }
    let length = dot(normal, normal).sqrt();
    if !((length - 1.0).abs() <= crate::cup::UNIT_TOLERANCE) {
        return Err(InputError::Invalid {
            field: "surface normal".into(),
            value: show(normal),
            allowed: format!("a unit vector (length 1 within {})", crate::cup::UNIT_TOLERANCE),
        });
    }
    let unit = scale(1.0 / length, normal);
    let along = dot(force_n, unit);
    let twist = dot(moment_nm, unit);
    let tangential = axpy(-along, unit, force_n);
    let peel = axpy(-twist, unit, moment_nm);
    let shear = dot(tangential, tangential).sqrt() + twist.abs() / (0.5 * cup.diameter_m);
    // The same loads in the plane of the normal and the shear: the planar
    // verdict's pull, push, shear and peel are then exactly these.
    crate::cup::verdict(cup, [shear, along], dot(peel, peel).sqrt(), [0.0, 1.0])
}

impl Body3 {
    /// The unit's right normal `nu = -R0 e_y` (towards tubes 2 and 3).
    fn right_normal(&self) -> Vec3 {
        apply(&self.base_frame(), [0.0, -1.0, 0.0])
    }

    /// The centre of the rear cup's face (m) for `robot` (the robot the body
    /// was built from: its spacing `b`, the cup's offset and where the cup
    /// sits on the unit): `b + rear_offset` from tube 1's root along the
    /// unit's right normal and `rear_cup_behind` behind it, along `-R0 e_x`,
    /// as in the plane.
    pub fn rear_cup_centre(&self, robot: &Robot) -> Vec3 {
        let d = robot.body.base_spacing_m + robot.cup.rear_offset_m;
        let behind = apply(&self.base_frame(), [-robot.driving_unit.rear_cup_behind_m, 0.0, 0.0]);
        axpy(d, self.right_normal(), axpy(1.0, behind, self.tube(0).root()))
    }

    /// Where the driving unit's mass sits (m): the midpoint of tube 1's root
    /// and the midpoint of tubes 2 and 3's roots, as in the planar model.
    pub fn unit_centre(&self) -> Vec3 {
        let pair = scale(0.5, axpy(1.0, self.tube(1).root(), self.tube(2).root()));
        scale(0.5, axpy(1.0, self.tube(0).root(), pair))
    }

    /// The reaction the rear hold's surface exerts on the robot, about
    /// `about` (m), from the forces and spring moments at the tubes' roots
    /// of the equilibrium `eq` (module doc), with the driving unit's mass
    /// `unit_mass_kg` (kg).
    pub fn rear_reaction(&self, eq: &Equilibrium3, unit_mass_kg: f64, about: Vec3) -> Wrench {
        let g = self.gravity();
        let lambda = &eq.multipliers;
        let welds = [[lambda[0], lambda[1], lambda[2]], [lambda[6], lambda[7], lambda[8]]];
        // Both cups holding, the front hold pulls on tube 1's tip too.
        let tip = eq.front_hold.map_or([0.0; 3], |mu| [mu[0], mu[1], mu[2]]);
        let weld = [axpy(-1.0, axpy(1.0, welds[0], welds[1]), tip), welds[0], welds[1]];
        let unit_weight = [0.0, g * unit_mass_kg, 0.0];
        let mut force = unit_weight;
        let mut moment = cross(axpy(-1.0, about, self.unit_centre()), unit_weight);
        for (i, w) in weld.iter().enumerate() {
            let tube = self.tube(i);
            // Contacts on the tube push it as the weld does: the root carries the rest.
            let pushed = eq.contacts.iter().filter(|c| c.row.tube == i);
            let w = pushed.fold(*w, |w, c| axpy(c.force_n, c.row.plane.normal, w));
            let f = axpy(-1.0, w, [0.0, g * tube.total_mass(), 0.0]);
            let first = self.frame(&eq.frames, i, 0);
            let theta = log(&mul_tn(&self.base_frame(), &first));
            let k = tube.stiffness(0);
            let spring = apply(&transpose(&jr_inv(theta)), [k[0] * theta[0], k[1] * theta[1], k[2] * theta[2]]);
            moment = axpy(-1.0, apply(&first, spring), moment);
            moment = axpy(1.0, cross(axpy(-1.0, about, tube.root()), f), moment);
            force = axpy(1.0, f, force);
        }
        Wrench { force_n: force, moment_nm: moment }
    }

    /// The rear cup holding the body at `eq`: its face, the surface's
    /// normal, the reaction about the face's centre and the verdict against
    /// `robot`'s cup (with the mass the driving unit carries,
    /// [`Robot::unit_mass_kg`]: its own and the tubes' tails).
    pub fn rear_cup(&self, robot: &Robot, eq: &Equilibrium3) -> Result<CupState3, InputError> {
        let centre = self.rear_cup_centre(robot);
        let normal = scale(-1.0, self.right_normal());
        let reaction = self.rear_reaction(eq, robot.unit_mass_kg(self.tube_lengths()), centre);
        cup_state(robot, centre, normal, reaction)
    }
}

/// `body` (built from `robot`: its driving unit's mass and cups) held by
/// `hold`, on the hold's path (module doc), with each holding cup's
/// reaction and verdict: the three-tube body's [`crate::stance::solve`]. A
/// plate frame that is not a rotation or a tip that is not finite is
/// refused, naming the field.
pub fn solve(robot: &Robot, body: &Body3, hold: Hold3, solver: &Solver) -> Result<Held3, StanceError> {
    held(robot, body, hold, solver, None)
}

/// `body` of `robot` held by `hold` among `scene`'s solids, with the
/// holding cup's reaction (the contacts' forces taken off it) and verdict:
/// the rear hold, the front hold (the scene turning with the plate in the
/// solver's picture, module doc), both cups and the free front joint (each
/// turn of the swing solved among the solids). The tubes keep their radius
/// from the solids. Bad input is refused as [`solve`] refuses it; so is a
/// hold that puts a cup, the plate or the unit inside a solid.
pub fn solve_in(
    robot: &Robot,
    body: &Body3,
    hold: Hold3,
    scene: &Scene3,
    solver: &Solver,
) -> Result<Held3, StanceError> {
    held(robot, body, hold, solver, Some((scene, 0.5 * robot.tube.outer_diameter_m)))
}

/// [`solve`], among `scene`'s solids with the tubes' centre
/// lines `clearance` (m) from them when `scene` is `Some((scene,
/// clearance))` ([`crate::contact::space`]).
fn held(
    robot: &Robot,
    body: &Body3,
    hold: Hold3,
    solver: &Solver,
    scene: Option<(&Scene3, f64)>,
) -> Result<Held3, StanceError> {
    let md = robot.unit_mass_kg(body.tube_lengths());
    hold.checked()?;
    crate::hold::check_front_joint(robot, matches!(hold, Hold3::FrontPivot(_)))?;
    if let Some((solids, _)) = scene {
        // A cup or the plate inside a solid has no equilibrium to find.
        if let Some(p) = first_inside(solids, &hold_points(robot, body, &hold)) {
            let [x, y, z] = p.point_m.map(|c| Num(c).to_string());
            return Err(InputError::Invalid {
                field: "hold".into(),
                value: format!("{} at ({x}, {y}, {z}) m", p.what),
                allowed:
                    "a hold that leaves the driving unit, the plate and the holding cups in free space or on a surface"
                        .into(),
            }
            .into());
        }
    }
    match hold {
        Hold3::Rear(AsBuilt) => {
            let equilibrium = body.picture(solver, None, scene)?;
            let rear = Some(body.rear_cup(robot, &equilibrium)?);
            Ok(Held3 { hold, body: body.clone(), equilibrium, rear, front: None, pivot_turn_rad: None })
        }
        Hold3::Front(Pose3 { point_m: tip_m, frame: plate }) => {
            let held = FrontHold { tip: tip_m, plate, unit_mass_kg: md };
            let picture = body.picture(solver, Some(&held), scene)?;
            let (hung, equilibrium) = body.hung(&picture, &held);
            let front = Some(hung.front_cup(robot, &equilibrium, md)?);
            Ok(Held3 { hold, body: hung, equilibrium, rear: None, front, pivot_turn_rad: None })
        }
        Hold3::Both { rear: AsBuilt, front: Pose3 { point_m: tip_m, frame: plate } } => {
            let equilibrium = body
                .solve_both_on(solver, FrontTarget { tip: tip_m, plate, compliance: [0.0; 2] }, scene)
                .map_err(|source| body.beyond_reach(source, tip_m))?;
            let rear = Some(body.rear_cup(robot, &equilibrium)?);
            let (centre, normal) = body.front_face(robot, &equilibrium.frames);
            let reaction = body.front_hold_reaction(&equilibrium, &plate, centre);
            let front = Some(cup_state(robot, centre, normal, reaction)?);
            Ok(Held3 { hold, body: body.clone(), equilibrium, rear, front, pivot_turn_rad: None })
        }
        Hold3::FrontPivot(Pose3 { point_m: tip_m, frame: plate }) => {
            body.swing(robot, hold, tip_m, &plate, solver, scene)
        }
    }
}

impl Body3 {
    /// The hanging gravity of [`Hanging`] at `param` into `ev` (module doc):
    /// `g` times the bilinear term of [`Body3::plate_bilinear`] with `u` up
    /// in the held plate's frame, `K` and `c_ij` the masses' first moments.
    pub(crate) fn add_hanging(&self, frames: &[Mat3], hang: &Hanging, param: Param, ev: &mut Evaluation) {
        let g = param.load * self.gravity();
        let p = self.links() - 1;
        let tubes = [0, 1, 2].map(|i| self.tube(i));
        let mass = hang.unit_mass_kg + tubes.iter().map(|t| t.total_mass()).sum::<f64>();
        let mut constant = axpy(-mass, tubes[0].root(), scale(hang.unit_mass_kg, self.unit_centre()));
        for tube in &tubes {
            constant = axpy(tube.total_mass(), tube.root(), constant);
        }
        let coefficient = |i: usize, j: usize| {
            let tube = tubes[i];
            param.scale[i] * (tube.levers()[j] - if i == 0 { mass * tube.lengths()[j] } else { 0.0 })
        };
        let plate = self.plate_bilinear(frames, hang.up, constant, coefficient, |u, grad, hess, cross| {
            ev.add_gradient(u, grad, g);
            ev.add_hessian(u, u, &scale_mat(g, &hess));
            ev.add_hessian(p, u, &scale_mat(g, &cross));
        });
        ev.energy += g * plate.value;
        ev.add_gradient(p, plate.gradient, g);
        ev.add_hessian(p, p, &scale_mat(g, &plate.hessian));
    }

    /// The terms of `f = (R_P u) . (K + sum_ij c_ij R_ij e_x)` (module doc:
    /// the hanging gravity over `g`, and a contact's gap under the front
    /// hold, [`crate::contact::space`]), `R_P` the plate's frame, `u` a vector in
    /// it, `K` a constant vector and `c_ij = coefficient(i, j)` (m, or kg m
    /// for gravity). Calls `link(u, df/ddelta_u, d2f/ddelta_u^2,
    /// d2f/ddelta_P ddelta_u)` for every link but the plate with `c_ij != 0`
    /// (the last block's rows the plate's coordinates, its columns the
    /// link's), and returns `f` with the plate's own gradient and Hessian
    /// block. No allocation.
    pub(crate) fn plate_bilinear(
        &self,
        frames: &[Mat3],
        up: Vec3,
        constant: Vec3,
        coefficient: impl Fn(usize, usize) -> f64,
        mut link: impl FnMut(usize, Vec3, Mat3, Mat3),
    ) -> PlateTerm {
        let f = frames;
        let p = self.links() - 1;
        let plate = f[p];
        let s = apply(&plate, up);
        let mut w = constant;
        let mut own = 0.0;
        for i in 0..3 {
            for j in 0..self.tube(i).len() {
                let c = coefficient(i, j);
                let u = self.index(i, j);
                if c == 0.0 {
                    continue;
                }
                if u == p {
                    // (R_P u) . (R_P e_x) = u . e_x: a constant.
                    own = c * up[0];
                    continue;
                }
                let r = &f[u];
                w = axpy(c, [r[0][0], r[1][0], r[2][0]], w);
                let (grad, hess) = linear_terms(r, scale(c, s), E_X);
                let cross_block = mul(&mul(&hat(up), &mul_tn(&plate, r)), &hat(E_X));
                link(u, grad, hess, scale_mat(-c, &cross_block));
            }
        }
        let (gradient, hessian) = linear_terms(&plate, w, up);
        PlateTerm { value: dot(s, w) + own, gradient, hessian }
    }

    /// The Lagrangian's derivatives of the body hanging as `hang` says
    /// ([`Body3::derivatives`] with the front hold's gravity), for checks.
    pub fn hanging_derivatives(&self, frames: &[Mat3], lambda: &[f64; PLATE_ROWS], hang: Hanging) -> Derivatives {
        self.derivatives_at(frames, lambda, Param { hang: Some(hang), ..Param::FULL })
    }

    /// The equilibrium on the hold's path in the solver's picture: the rear
    /// hold's (`front` none) or the front hold's, among the solids of
    /// `scene` when there is one.
    fn picture(
        &self,
        solver: &Solver,
        front: Option<&FrontHold>,
        scene: Option<(&Scene3, f64)>,
    ) -> Result<Equilibrium3, crate::statics::SolveError> {
        match scene {
            None => self.solve_on(solver, front.map(FrontHold::hanging)),
            Some((scene, clearance)) => self.solve_among_on(solver, scene, clearance, front),
        }
    }

    /// The swing about a free front joint: the front hold's path at the
    /// start, then the plate turned about the face's normal `n` (the tip,
    /// on that axis, stays) in steps of [`SWING_STEP`] the way the moment of
    /// gravity about `n` turns it, each a warm start from the last, until
    /// that moment changes sign; then regula falsi (Illinois) on the turn to
    /// a moment below [`PIVOT_TOLERANCE`] times `W L1`. Moving downhill in
    /// the energy, the first change of sign is a minimum in the turn.
    fn swing(
        &self,
        robot: &Robot,
        hold: Hold3,
        tip: Vec3,
        plate: &Mat3,
        solver: &Solver,
        scene: Option<(&Scene3, f64)>,
    ) -> Result<Held3, StanceError> {
        let md = robot.unit_mass_kg(self.tube_lengths());
        let normal = column(plate, 1);
        let front = |turn: f64| FrontHold { tip, plate: mul(&exp(scale(turn, normal)), plate), unit_mass_kg: md };
        // The surface's moment about n on the plate turned by `turn`, from a
        // picture converged there.
        let moment = |picture: &Equilibrium3, turn: f64| -> Result<(f64, Held3), StanceError> {
            let (body, equilibrium) = self.hung(picture, &front(turn));
            let front = body.front_cup(robot, &equilibrium, md)?;
            let m = dot(front.reaction.moment_nm, normal);
            Ok((m, Held3 { hold, body, equilibrium, rear: None, front: Some(front), pivot_turn_rad: Some(turn) }))
        };
        // A warm start from the last turn's picture and, among solids, its
        // contact rows (their world planes: the scene stays in the world).
        let settle = |from: &Equilibrium3, last: &Held3, turn: f64| match scene {
            None => self.solve_from_on(solver, &from.frames, Some(front(turn).hanging())),
            Some((scene, clearance)) => {
                let rows: Vec<ContactRow3> = last.equilibrium.contacts.iter().map(|c| c.row).collect();
                self.solve_among_from(solver, &from.frames, &rows, scene, clearance, &front(turn))
            }
        };
        let mut picture = self.picture(solver, Some(&front(0.0)), scene)?;
        let (mut m, mut held) = moment(&picture, 0.0)?;
        let scale_nm = held.front.as_ref().map_or(0.0, |f| f.reaction.force_n[1]) * self.tube(0).tube_length();
        let tolerance = PIVOT_TOLERANCE * scale_nm.max(f64::MIN_POSITIVE);
        let mut events = std::mem::take(&mut picture.summary.events);
        // The surface's moment `m` about n is what gravity's moment needs:
        // gravity turns the body by -m.
        let direction = -m.signum();
        let (mut turn, mut iterations) = (0.0, picture.iterations);
        let mut bracket = None;
        for _ in 0..SWING_STEPS {
            if m.abs() <= tolerance {
                break;
            }
            let next = turn + direction * SWING_STEP;
            let ahead = settle(&picture, &held, next)?;
            iterations += ahead.iterations;
            events.extend_from_slice(&ahead.events);
            let (m_next, held_next) = moment(&ahead, next)?;
            if m_next.signum() != m.signum() {
                bracket = Some(((turn, m), (next, m_next)));
            }
            (turn, m, picture, held) = (next, m_next, ahead, held_next);
            if bracket.is_some() {
                break;
            }
        }
        if let Some((a, b)) = bracket {
            let mut bracket = crate::root::Bracket::new(a, b);
            for _ in 0..PIVOT_ITERATIONS {
                if m.abs() <= tolerance || bracket.width() <= 1e-13 {
                    break;
                }
                let c = bracket.next();
                let here = settle(&picture, &held, c)?;
                iterations += here.iterations;
                events.extend_from_slice(&here.events);
                let (mc, held_c) = moment(&here, c)?;
                bracket.narrow(c, mc);
                (turn, m, picture, held) = (c, mc, here, held_c);
            }
        }
        if !(m.abs() <= tolerance) {
            return Err(StanceError::Solve(crate::statics::SolveError::NotConverged {
                stage: crate::statics::Stage::Load,
                iterations,
                residual: m.abs() / scale_nm.max(f64::MIN_POSITIVE),
                reason: crate::statics::StopReason::IterationLimit,
            }));
        }
        held.pivot_turn_rad = Some(turn);
        held.equilibrium.summary.iterations = iterations;
        held.equilibrium.summary.events = events;
        Ok(held)
    }

    /// The hanging equilibrium `picture` (the unit fixed) turned into the
    /// world of the front hold `held`: `G = R_f R'_P^T`, `x = G (x' -
    /// x'_tip) + P_f`; the contacts' planes and points with it.
    fn hung(&self, picture: &Equilibrium3, held: &FrontHold) -> (Body3, Equilibrium3) {
        let turn = mul(&held.plate, &transpose(&self.plate_frame(&picture.frames)));
        let shift = axpy(-1.0, apply(&turn, self.endpoint(&picture.frames)), held.tip);
        let body = self.placed(&turn, shift);
        let mut equilibrium = picture.clone();
        equilibrium.frames = Frames(picture.frames.as_slice().iter().map(|r| mul(&turn, r)).collect());
        equilibrium.summary.q = equilibrium.frames.as_slice().iter().flat_map(log).collect();
        for side in 0..2 {
            let rows = &mut equilibrium.summary.multipliers[6 * side..6 * side + 3];
            let force = apply(&turn, [rows[0], rows[1], rows[2]]);
            rows.copy_from_slice(&force);
        }
        for contact in &mut equilibrium.contacts {
            contact.row.plane = held.plane_world(&contact.row.plane);
            contact.point_m = body.link_tip(&equilibrium.frames, contact.row.tube, contact.row.link);
        }
        (body, equilibrium)
    }

    /// The whole robot's mass (kg) and first moment `sum m x` (kg m) at
    /// `frames`, with the driving unit's mass `unit_mass_kg`.
    pub fn first_moment(&self, frames: &[Mat3], unit_mass_kg: f64) -> (f64, Vec3) {
        let (mut mass, mut first) = (unit_mass_kg, scale(unit_mass_kg, self.unit_centre()));
        for i in 0..3 {
            let tube = self.tube(i);
            mass += tube.total_mass();
            first = axpy(tube.total_mass(), tube.root(), first);
            for (j, w) in tube.levers().iter().enumerate() {
                let r = self.frame(frames, i, j);
                first = axpy(*w, [r[0][0], r[1][0], r[2][0]], first);
            }
        }
        (mass, first)
    }

    /// The front cup holding the body at `eq` (world frames): its face
    /// (`c + front_offset` from tube 1's tip along the plate's right normal
    /// `-R_P e_y`), the surface's normal `R_P e_y`, and the reaction by the
    /// whole robot's balance: it carries what the contacts with a scene's
    /// solids (forces `f_c = mu_c n_c` at `p_c`) do not,
    /// `F = (0, g M, 0) - sum_c f_c`,
    /// `M = (X - M c) x (0, g, 0) - sum_c (p_c - c) x f_c`.
    fn front_cup(&self, robot: &Robot, eq: &Equilibrium3, unit_mass_kg: f64) -> Result<CupState3, InputError> {
        let (centre, normal) = self.front_face(robot, &eq.frames);
        let (mass, first) = self.first_moment(&eq.frames, unit_mass_kg);
        let up = [0.0, self.gravity(), 0.0];
        let mut reaction = Wrench { force_n: scale(mass, up), moment_nm: cross(axpy(-mass, centre, first), up) };
        for c in &eq.contacts {
            let f = scale(c.force_n, c.row.plane.normal);
            reaction.force_n = axpy(-1.0, f, reaction.force_n);
            reaction.moment_nm = axpy(-1.0, cross(axpy(-1.0, centre, c.point_m), f), reaction.moment_nm);
        }
        cup_state(robot, centre, normal, reaction)
    }

    /// The front cup's face at `frames` for `robot`: its centre (m), `c +
    /// front_offset` from tube 1's tip along the plate's right normal
    /// `-R_P e_y`, and the surface's outward normal `R_P e_y`.
    pub fn front_face(&self, robot: &Robot, frames: &[Mat3]) -> (Vec3, Vec3) {
        let plate = self.plate_frame(frames);
        (front_cup_centre(robot, self.endpoint(frames), &plate), column(&plate, 1))
    }

    /// The reaction the front hold exerts on the robot when both cups hold
    /// (`eq` solved with [`Hold3::Both`] whose plate frame is `plate`),
    /// about `about` (m), from its six multipliers (module doc): the force
    /// `mu_tip` at tube 1's tip and the moment `R_P Jr^-1(theta)^T mu_ori`.
    /// Zero when the front does not hold in `eq`.
    pub fn front_hold_reaction(&self, eq: &Equilibrium3, plate: &Mat3, about: Vec3) -> Wrench {
        let Some(mu) = eq.front_hold else {
            return Wrench { force_n: [0.0; 3], moment_nm: [0.0; 3] };
        };
        let force = [mu[0], mu[1], mu[2]];
        let frame = self.plate_frame(&eq.frames);
        let theta = log(&mul_tn(plate, &frame));
        let moment = apply(&frame, apply(&transpose(&jr_inv(theta)), [mu[3], mu[4], mu[5]]));
        let arm = axpy(-1.0, about, self.endpoint(&eq.frames));
        Wrench { force_n: force, moment_nm: axpy(1.0, cross(arm, force), moment) }
    }

    /// A both-hold solve's failure `source`, as [`StanceError::OutOfReach`]
    /// when the tip's target lies farther from tube 1's root than the tube
    /// is long.
    fn beyond_reach(&self, source: crate::statics::SolveError, tip: Vec3) -> StanceError {
        let arm = axpy(-1.0, self.tube(0).root(), tip);
        let (distance_m, reach_m) = (dot(arm, arm).sqrt(), self.tube(0).tube_length());
        if distance_m > reach_m {
            StanceError::OutOfReach { distance_m, reach_m, source }
        } else {
            StanceError::Solve(source)
        }
    }

    /// The front hold's six rows at `frames` for `target` (module doc),
    /// with the multipliers `mu` (N, then N m): values (the tip's offset,
    /// m, and the plate's rotation, rad), compliance and Jacobian into rows
    /// 12 to 17 of `ev`, with `HESSIAN` their Hessian blocks; row `r`
    /// holds `C_r + c mu_r = 0` ([`Evaluation::row_value`]).
    pub(crate) fn add_front_rows<const HESSIAN: bool>(
        &self,
        frames: &[Mat3],
        target: &FrontTarget,
        mu: &[f64],
        ev: &mut Evaluation,
    ) {
        let m = ev.rows();
        let last = self.tube(0).len() - 1;
        let gap = axpy(-1.0, target.tip, self.link_tip(frames, 0, last));
        for c in 0..3 {
            let mut normal = [0.0; 3];
            normal[c] = 1.0;
            ev.constraints[PLATE_ROWS + c] = gap[c];
            ev.compliance[PLATE_ROWS + c] = target.compliance[0];
            let mut sink = row_sink::<HESSIAN>(ev, PLATE_ROWS + c, self.links() - 1);
            self.point_terms(frames, 0, last, normal, mu[c], |u, grad, hess| sink(u, grad, hess, None));
        }
        let p = self.links() - 1;
        let w = [-mu[3], -mu[4], -mu[5]];
        let terms = pair_terms(&mul_tn(&target.plate, &frames[p]), |_| w, [0.0; 3], HESSIAN);
        for c in 0..3 {
            let r = PLATE_ROWS + 3 + c;
            ev.constraints[r] = terms.theta[c];
            ev.compliance[r] = target.compliance[1];
            for (k, j) in terms.jacobian_b[c].iter().enumerate() {
                ev.jacobian[(3 * p + k) * m + r] = *j;
            }
        }
        if HESSIAN {
            ev.add_hessian(p, p, &terms.h_bb);
        }
    }

    /// Declares the front hold's rows' reach in `pattern` (border rows
    /// `3 + 12` to `3 + 17`): the tip rows every link of tube 1's chain and
    /// none of tubes 2 and 3, the rotation rows no chain (the plate only).
    pub(crate) fn front_rows_reach(&self, pattern: &mut crate::linalg::Pattern) {
        for (c, len) in self.chain_blocks().into_iter().enumerate() {
            for r in 0..FRONT_ROWS {
                let first = if c == 0 && r < 3 { 0 } else { len };
                pattern.set_border_start(c, 3 + PLATE_ROWS + r, first);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body3::body3::retract;

    /// A bent, twisted state of an uneven body, a target off it and multipliers.
    fn case() -> (Body3, Frames, FrontTarget, [f64; FRONT_ROWS]) {
        let body = Body3::from_robot(&Robot::builtin(), [0.25, 0.28, 0.22]).unwrap();
        let frames = (0..body.links()).map(|u| {
            let t = u as f64;
            exp([0.3 * (0.7 * t).sin(), 0.2 + 0.05 * t, -0.4 * (0.3 * t).cos()])
        });
        let frames = body.frames_from(frames.collect()).unwrap();
        let target = FrontTarget { tip: [0.1, 0.2, -0.05], plate: exp([0.4, -0.9, 0.3]), compliance: [0.0; 2] };
        (body, frames, target, [1.5, -0.7, 2.2, 0.03, -0.05, 0.02])
    }

    /// The rows' values, Jacobian (`(3 u + c) * 6 + r`) and Hessian blocks
    /// alone: the rows of an evaluation with the weld's left zero.
    fn rows(body: &Body3, frames: &Frames, target: &FrontTarget, mu: &[f64]) -> (Rows, Evaluation) {
        let mut ev = body.evaluation(PLATE_ROWS + FRONT_ROWS);
        body.add_front_rows::<true>(frames, target, mu, &mut ev);
        let m = ev.rows();
        let jacobian = ev.jacobian.chunks_exact(m).flat_map(|j| j[PLATE_ROWS..].to_vec()).collect();
        (Rows { gaps: ev.constraints[PLATE_ROWS..].to_vec(), jacobian }, ev)
    }

    /// The front hold's rows' values and Jacobian (`(3 u + c) * 6 + r`).
    struct Rows {
        gaps: Vec<f64>,
        jacobian: Vec<f64>,
    }

    /// `frames` with local steps `(coordinate, h)` (summed per link, one retraction each).
    fn moved(frames: &Frames, moves: &[(usize, f64)]) -> Frames {
        let mut steps = vec![[0.0; 3]; frames.as_slice().len()];
        for (c, h) in moves {
            steps[c / 3][c % 3] += h;
        }
        Frames(frames.as_slice().iter().zip(steps).map(|(f, v)| retract(f, v)).collect())
    }

    #[test]
    fn rows_are_the_tip_and_the_plate_frame() {
        let (body, frames, target, mu) = case();
        let (cev, _) = rows(&body, &frames, &target, &mu);
        let tip = body.endpoint(&frames);
        let theta = log(&mul_tn(&target.plate, &body.plate_frame(&frames)));
        for c in 0..3 {
            assert!((cev.gaps[c] - (tip[c] - target.tip[c])).abs() < 1e-15);
            assert_eq!(cev.gaps[3 + c], theta[c]);
        }
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let (body, frames, target, mu) = case();
        let (cev, _) = rows(&body, &frames, &target, &mu);
        let h = 1e-6;
        let mut nonzero = 0;
        for c in 0..3 * body.links() {
            let plus = rows(&body, &moved(&frames, &[(c, h)]), &target, &mu).0.gaps;
            let minus = rows(&body, &moved(&frames, &[(c, -h)]), &target, &mu).0.gaps;
            for r in 0..FRONT_ROWS {
                let fd = (plus[r] - minus[r]) / (2.0 * h);
                let j = cev.jacobian[c * FRONT_ROWS + r];
                assert!((fd - j).abs() < 1e-8, "coordinate {c}, row {r}: {j} against {fd}");
                nonzero += usize::from(fd.abs() > 1e-6);
            }
        }
        // Tube 1's links move the tip (two of three rows at least each); the plate turns the frame.
        assert!(nonzero >= 2 * 3 * body.tube(0).len() + 9, "{nonzero}");
    }

    #[test]
    fn hessian_matches_second_differences() {
        let (body, frames, target, mu) = case();
        let (_, ev) = rows(&body, &frames, &target, &mu);
        let lagrangian = |f: &Frames| -> f64 {
            let gaps = rows(&body, f, &target, &mu).0.gaps;
            -gaps.iter().zip(mu).map(|(g, m)| g * m).sum::<f64>()
        };
        let second = |a: usize, b: usize| {
            let h = 1e-4;
            (lagrangian(&moved(&frames, &[(a, h), (b, h)]))
                - lagrangian(&moved(&frames, &[(a, h), (b, -h)]))
                - lagrangian(&moved(&frames, &[(a, -h), (b, h)]))
                + lagrangian(&moved(&frames, &[(a, -h), (b, -h)])))
                / (4e-8)
        };
        let p = body.links() - 1;
        for j in 0..body.tube(0).len() {
            let u = body.index(0, j);
            for a in 0..3 {
                for b in 0..3 {
                    let exact = if u == p { ev.hessian_corner[3 * a + b] } else { ev.hessian_diag[9 * u + 3 * a + b] };
                    let fd = second(3 * u + a, 3 * u + b);
                    assert!((fd - exact).abs() < 1e-6, "link {u} ({a}, {b}): {exact} against {fd}");
                }
            }
        }
        // No second derivative couples two links, nor a link with the plate;
        // tubes 2 and 3 do not enter.
        let (u, v) = (body.index(0, 1), body.index(0, 4));
        assert!(second(3 * u + 1, 3 * v + 2).abs() < 1e-6 && second(3 * u, 3 * p + 1).abs() < 1e-6);
        let side = body.index(1, 3);
        assert!((0..9).all(|k| ev.hessian_diag[9 * side + k] == 0.0) && second(3 * side, 3 * side + 1).abs() < 1e-9);
    }

    /// The reach declared to the factorization holds: nothing before a
    /// row's declared start on a chain.
    #[test]
    fn rows_reach_no_further_than_declared() {
        let (body, frames, target, mu) = case();
        let (cev, _) = rows(&body, &frames, &target, &mu);
        let mut pattern = body.pattern(false, FRONT_ROWS);
        body.front_rows_reach(&mut pattern);
        let mut declared = 0;
        for c in 0..pattern.chains() {
            for (t, u) in pattern.chain_blocks(c).enumerate() {
                for r in 0..FRONT_ROWS {
                    let entries = (0..3).map(|a| cev.jacobian[(3 * u + a) * FRONT_ROWS + r]);
                    if t < pattern.border_start(c, 3 + PLATE_ROWS + r) {
                        assert!(entries.into_iter().all(|x| x == 0.0), "chain {c}, block {t}, row {r}");
                    } else {
                        declared += 1;
                    }
                }
            }
        }
        // Only the tip rows on tube 1's chain are declared.
        assert_eq!(declared, 3 * (body.tube(0).len() - 1));
    }
}
