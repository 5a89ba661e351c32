//! The single clamped tube (a [`Cantilever`], clamped at the origin) resting
//! on a scene's solids.
//!
//! # Equations
//!
//! The unknowns are the links' absolute angles `phi` (rad); the potential is
//! the cantilever's (springs and gravity, J). Each contact adds a
//! frictionless one-sided row on a material point `x` of the tube (a link's
//! tip, or a point a fraction `s` along a link where a corner pokes between
//! nodes), as for the two-tube body ([`super::detect`] finds them):
//!
//! ```text
//! C(phi) = n . x(phi) - h >= 0,   h = n . c + r                       (m)
//! x = p_1 + sum_{j < i} l_j e(phi_j) + s l_i e(phi_i)
//! dC/dphi_j   = lever_j n . e'(phi_j)                                 (m/rad)
//! d2C/dphi_j2 = -lever_j n . e(phi_j)       (diagonal)                (m/rad^2)
//! ```
//!
//! with `p_1` the first joint (the clamp, or the end of the rigid root piece
//! of the `midpoint` cut), `lever_j = l_j` before the contact's link and
//! `s l_i` on it, `n` the surface's outward unit normal and `r` the tube's
//! radius (m). The clamp is fixed: there are no free coordinates and no
//! weld; the rows' multipliers are the normal forces `f_k >= 0` (N), with
//! `f_k C_k = 0`.
//!
//! # The clamp's reaction
//!
//! The clamp carries what the contacts do not: its force (N) from the
//! tube's force balance, `F = (0, W) - sum_k f_k n_k` with `W = g (m_tube +
//! P + m_root)` the weight, and its moment (N m, counter-clockwise, about
//! the clamp) from the first spring and the rigid root piece's balance,
//!
//! ```text
//! M = k_1 (phi_c - phi_1) + r e(phi_c) x (W_links (0, 1) - sum_k f_k n_k)
//!     + m_root g (r/2) cos(phi_c)                                      (N m)
//! ```
//!
//! (`r` here the root piece's length, 0 for the `paper` cut; `W_links` the
//! weight beyond it). The moment is found from the springs, not from the
//! moments of the weight and contacts, so that the balance of moments
//! about the clamp checks the equilibrium.
//!
//! # Path
//!
//! The tube's own: fed from [`TUBE_FEED_START_M`] (or its full length if
//! shorter), solved under gravity without the scene there, then fed to its
//! length in the adaptive steps of the two-tube body's feed, the contact
//! rows refreshed at every step.

use super::feeding::{Fed, Feeding};
use super::scene_solve;
use super::{ContactForce, Reaction, StanceError};
use crate::cantilever::{Cantilever, CantileverSpec};
use crate::contact::planar::{chain_terms, penetration, ContactRow, Touching};
use crate::error::{positive, InputError};
use crate::geom::{cross, dot, Vec2};
use crate::scene::Scene;
use crate::statics::{
    Constraints, Equilibrium, Evaluation, Path, PathTerms, Potential, Row, RowKind, Solver, Stage, StaticSystem,
};

/// Length (m) a single tube is fed from: the built-in robot's `[limits]
/// tube_length_min_m` (a bare cantilever has no limits of its own).
pub const TUBE_FEED_START_M: f64 = 0.05;

/// The clamped tube with contact rows: a [`StaticSystem`] on the links'
/// angles (see the [module doc](self)).
#[derive(Clone, Debug)]
pub struct Tube<'a> {
    tube: &'a Cantilever,
    contacts: Vec<ContactRow>,
}

impl<'a> Tube<'a> {
    /// The tube without contacts.
    pub fn new(tube: &'a Cantilever) -> Tube<'a> {
        Tube { tube, contacts: Vec::new() }
    }

    /// The cantilever underneath.
    pub fn cantilever(&self) -> &Cantilever {
        self.tube
    }

    /// Contact row `row`: its value and its terms in the angles.
    fn contact_terms(&self, row: usize, contact: &ContactRow, ev: &mut Evaluation) {
        let chain = self.tube.chain();
        let x = chain_terms(chain, 0, chain.first_joint(), row, contact, ev);
        ev.constraints[row] = dot(contact.normal, x) - contact.offset;
    }
}

impl Potential for Tube<'_> {
    fn dim(&self) -> usize {
        self.tube.dim()
    }

    fn moment_scale(&self) -> f64 {
        self.tube.moment_scale()
    }

    fn potential(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        self.tube.potential(q, t, ev);
    }
}

impl Constraints for Tube<'_> {
    fn rows(&self) -> usize {
        self.contacts.len()
    }

    /// Positions in element lengths, as the body's contact rows.
    fn row(&self, _r: usize) -> Row {
        Row { kind: RowKind::Inequality, scale: self.tube.chain().lengths()[0] }
    }

    fn constraints(&self, _q: &[f64], _t: f64, ev: &mut Evaluation) {
        for (row, contact) in self.contacts.iter().enumerate() {
            self.contact_terms(row, contact, ev);
        }
    }
}

impl StaticSystem for Tube<'_> {
    fn side_measure(&self, q: &[f64], dq: &[f64]) -> f64 {
        self.tube.side_measure(q, dq)
    }
}

/// Gravity raised from 0 to `g`; the contact rows do not move with it.
impl Path for Tube<'_> {
    fn path(&self, q: &[f64], t: f64, ev: &Evaluation, out: &mut PathTerms) {
        self.tube.path(q, t, ev, out);
    }

    fn discrete_stiffness(&self) -> f64 {
        self.tube.discrete_stiffness()
    }
}

impl Touching for Tube<'_> {
    fn chain_count(&self) -> usize {
        1
    }

    fn chain_points(&self, q: &[f64], _c: usize) -> Vec<Vec2> {
        self.tube.chain().points(q)
    }

    fn chain_len(&self, _c: usize) -> usize {
        self.tube.chain().len()
    }

    fn contacts(&self) -> &[ContactRow] {
        &self.contacts
    }

    fn with_contacts(mut self, contacts: Vec<ContactRow>) -> Self {
        self.contacts = contacts;
        self
    }

    /// At full gravity.
    fn stage(&self) -> Stage {
        Stage::Load
    }
}

/// The tube resting on a scene: its equilibrium, where it touches and what
/// the clamp carries.
#[derive(Clone, Debug, PartialEq)]
pub struct TubeHeld {
    /// The tube at its full length.
    pub tube: Cantilever,
    /// Its equilibrium: `q` the links' angles (rad), the multipliers the
    /// contact rows' normal forces (N).
    pub equilibrium: Equilibrium,
    /// The centre line (m): the clamp, the first joint when there is a
    /// rigid root piece, then every link's tip.
    pub points_m: Vec<Vec2>,
    /// The contacts that push (normal force above zero); `chain` is empty.
    pub contacts: Vec<ContactForce>,
    /// What the clamp exerts on the tube: force (N) and moment (N m,
    /// counter-clockwise) about the clamp.
    pub clamp: Reaction,
    /// The tube's weight (N), root piece and tip mass included.
    pub weight_n: f64,
    /// The deepest penetration into the scene (m; 0 when clear).
    pub penetration_m: f64,
}

/// The tube of `spec` (clamped at the origin) fed among `scene`'s solids,
/// tube radius `radius` (m), to its full length (see the module's "Path").
///
/// ```
/// use leech::prelude::*;
/// use leech::cantilever::CantileverSpec;
/// use leech::scene::Scene;
/// let spec = CantileverSpec {
///     elements: 20, element_length_m: 0.01, element_mass_kg: 0.001, joint_stiffness_nm_per_rad: 0.05,
///     tip_mass_kg: 0.0, base_angle_deg: 0.0, gravity_m_per_s2: 9.81, discretization: Discretization::Paper,
/// };
/// let floor = Scene::from_toml_str("name = \"low floor\"\n[[half_plane]]\npoint_m = [0.0, -0.05]\nnormal = [0.0, 1.0]\n", "floor").unwrap();
/// let held = leech::stance::tube_in(&spec, &floor, 0.005, &Solver::default()).unwrap();
/// // The soft tube sags onto the floor, which carries part of its weight.
/// let carried: f64 = held.contacts.iter().map(|c| c.force_n * c.normal[1]).sum();
/// assert!(carried > 0.0 && (carried + held.clamp.force_n[1] - held.weight_n).abs() < 1e-9 * held.weight_n);
/// ```
pub fn tube_in(spec: &CantileverSpec, scene: &Scene, radius: f64, solver: &Solver) -> Result<TubeHeld, StanceError> {
    let radius = positive("radius (m)", radius)?;
    let full = spec.build()?.chain().tube_length();
    let short = TUBE_FEED_START_M.min(full);
    let start = spec.fed_to(short)?;
    let q = start.solve(solver)?.q;
    let fed = TubeFeed { spec, from: short, to: full };
    let end = Feeding { fed, scene, radius, solver }.run(start, q)?;
    let system = Tube::new(&end.shape).with_contacts(end.contacts);
    Ok(TubeHeld::new(&system, end.equilibrium, scene, radius))
}

/// The tube of `spec` fed from `from` to `to` (m).
struct TubeFeed<'a> {
    spec: &'a CantileverSpec,
    from: f64,
    to: f64,
}

impl Fed for TubeFeed<'_> {
    type Shape = Cantilever;
    type System<'s> = Tube<'s>;

    fn span(&self) -> f64 {
        self.to - self.from
    }

    fn shape_at(&self, fraction: f64) -> Result<Cantilever, InputError> {
        // Never past the full length by rounding.
        self.spec.fed_to((self.from + fraction * (self.to - self.from)).min(self.to))
    }

    fn system<'s>(&self, tube: &'s Cantilever) -> Tube<'s> {
        Tube::new(tube)
    }

    fn carried(&self, next: &Cantilever, _tube: &Cantilever, q: &[f64]) -> Vec<f64> {
        next.chain().carry_over(q)
    }
}

impl TubeHeld {
    fn new(system: &Tube<'_>, equilibrium: Equilibrium, scene: &Scene, radius: f64) -> TubeHeld {
        let tube = system.cantilever();
        let contacts = scene_solve::contact_forces(system, &equilibrium, |_| "");
        let chain = tube.chain();
        let g = tube.gravity();
        let (links, root_mass, root) = (g * chain.total_mass(), chain.root_mass(), chain.root_length());
        let weight_n = links + g * root_mass;
        let pushed = contacts
            .iter()
            .fold([0.0, 0.0], |sum, c| [sum[0] + c.force_n * c.normal[0], sum[1] + c.force_n * c.normal[1]]);
        let (phi_c, phi_1) = (chain.clamp_angle(), equilibrium.q[0]);
        // The first joint carries the links' weight less what the contacts push.
        let arm = [root * phi_c.cos(), root * phi_c.sin()];
        let moment_nm = chain.stiffness()[0] * (phi_c - phi_1)
            + cross(arm, [-pushed[0], links - pushed[1]])
            + g * root_mass * 0.5 * arm[0];
        TubeHeld {
            tube: tube.clone(),
            points_m: chain.points(&equilibrium.q),
            penetration_m: penetration(system, &equilibrium.q, scene, radius).max(0.0),
            clamp: Reaction { force_n: [-pushed[0], weight_n - pushed[1]], moment_nm },
            contacts,
            weight_n,
            equilibrium,
        }
    }

    /// The moment (N m, counter-clockwise) about the clamp of everything on
    /// the tube: the clamp's reaction, the contacts and the weight. Zero at
    /// equilibrium, to rounding (see the module's "The clamp's reaction").
    pub fn moment_about_clamp(&self) -> f64 {
        let chain = self.tube.chain();
        let g = self.tube.gravity();
        let clamp = chain.clamp_point();
        let at = |p: Vec2| [p[0] - clamp[0], p[1] - clamp[1]];
        let contacts: f64 = self
            .contacts
            .iter()
            .map(|c| cross(at(c.point_m), [c.force_n * c.normal[0], c.force_n * c.normal[1]]))
            .sum();
        // The links' and tip mass's first moment, and the root piece's at its middle.
        let links_x = chain.mass_moment(&self.equilibrium.q)[0] - chain.total_mass() * clamp[0];
        let root_x = 0.5 * chain.root_length() * chain.clamp_angle().cos();
        self.clamp.moment_nm + contacts - g * (links_x + chain.root_mass() * root_x)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_feed_starts_at_the_builtin_robots_shortest_tube() {
        let robot = crate::robot::Robot::builtin();
        assert_eq!(super::TUBE_FEED_START_M, robot.limits.tube_length_min_m);
    }
}
