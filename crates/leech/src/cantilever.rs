//! A single clamped tube under gravity: the paper's Fig. 3a experiment.
//!
//! The potential is the chain's `V = V_s + V_g` ([`crate::chain`]); there are no
//! constraints, so an equilibrium solves `dV/dphi = 0`:
//!
//! ```text
//! k_j (phi_j - phi_{j-1}) - k_{j+1} (phi_{j+1} - phi_j) + g W_j cos(phi_j) = 0   (N m)
//! ```
//!
//! The default path starts from the straight unloaded tube and raises gravity
//! from 0 to `g`; a vertical tube above its buckling load is a pitchfork,
//! left on the right of the clamp direction. The continuous column buckles at
//! `beta = rho g L^3 / EI = 7.837`; the discrete chains buckle near it
//! (`midpoint` within 0.1 % at 40 elements, `paper` lower, about 7.2 at 35
//! elements, as its masses sit at the element tips).

use crate::chain::{Block, Chain};
use crate::geom::right_normal;
use crate::statics::{
    Constraints, Equilibrium, Evaluation, Iterate, Path, PathTerms, Potential, Row, Scratch, SolveError, Solver, Stage,
    StaticSystem,
};

/// The both cups' path starts with the front hold's rows this compliant,
/// relative to tube 1 (chain A) as a cantilever ([`start_compliance`]):
/// stiff enough that a straight body buckles under the tip rows' force well
/// before the target has moved far, soft enough that the rows' Jacobian
/// along a straight tube (zero along it) leaves the KKT matrix regular.
pub const START_SOFTNESS: f64 = 1e-3;

/// The front hold's compliance at the start of the both cups' path: a tube
/// of `length` (m) and bending stiffness `bending` (N m^2: a joint's
/// stiffness times the element length) as a cantilever, `L^3 / EI` (m/N)
/// for the tip's position and `L / EI` (rad/(N m)) for the plate's angle,
/// times [`START_SOFTNESS`].
pub fn start_compliance(length: f64, bending: f64) -> [f64; 2] {
    [START_SOFTNESS * length.powi(3) / bending, START_SOFTNESS * length / bending]
}

/// One clamped chain under gravity (m/s^2).
#[derive(Clone, Debug, PartialEq)]
pub struct Cantilever {
    chain: Chain,
    gravity: f64,
}

impl Cantilever {
    /// A clamped chain under `gravity` (m/s^2).
    pub fn new(chain: Chain, gravity: f64) -> Cantilever {
        Cantilever { chain, gravity }
    }

    /// The chain.
    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    /// Gravity (m/s^2).
    pub fn gravity(&self) -> f64 {
        self.gravity
    }

    /// Potential energy (J).
    pub fn energy(&self, q: &[f64]) -> f64 {
        self.chain.energy(q, self.gravity)
    }

    /// The equilibrium reached by raising gravity from 0 on the straight tube.
    ///
    /// ```
    /// use leech::prelude::*;
    /// let spec = ChainSpec {
    ///     tube_length: 0.2, element_length: 0.01, element_mass: 0.001, stiffness: 0.5,
    ///     damping: 0.0, tip_mass: 0.0, clamp_point: [0.0, 0.0], clamp_angle: 0.0,
    ///     discretization: Discretization::Paper,
    /// };
    /// let tube = Cantilever::new(Chain::new(&spec), 9.81);
    /// let eq = tube.solve(&Solver::default()).unwrap();
    /// let tip = tube.chain().tip(&eq.q);
    /// assert!(tip[1] < 0.0 && tip[0] > 0.19); // a stiff horizontal tube sags a little
    /// ```
    pub fn solve(&self, solver: &Solver) -> Result<Equilibrium, SolveError> {
        Scratch::with_spare(self, |ws| {
            let mut state = Iterate::new(self.chain.straight());
            let residual = solver.continuation(self, &mut state, 0.0, Stage::Load, ws)?;
            Ok(solver.finish(self, state, residual, ws))
        })
    }

    /// The equilibrium reached from `q0` with gravity on (warm start).
    pub fn solve_from(&self, solver: &Solver, q0: &[f64], ws: &mut Scratch) -> Result<Equilibrium, SolveError> {
        solver.warm_start(self, q0, ws)
    }
}

impl Potential for Cantilever {
    fn dim(&self) -> usize {
        self.chain.len()
    }

    fn moment_scale(&self) -> f64 {
        self.chain.nominal_stiffness()
    }

    /// `t` is the fraction of gravity applied.
    fn potential(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        let n = q.len();
        ev.energy = self.chain.evaluate_block(q, self.gravity, t, 1.0, Block::of(ev, 0..n));
    }
}

/// A clamped tube alone has no constraint rows.
impl Constraints for Cantilever {
    fn rows(&self) -> usize {
        0
    }

    fn row(&self, r: usize) -> Row {
        unreachable!("a cantilever has no constraint rows (asked for row {r})")
    }

    fn constraints(&self, _q: &[f64], _t: f64, _ev: &mut Evaluation) {}
}

impl StaticSystem for Cantilever {
    fn side_measure(&self, q: &[f64], dq: &[f64]) -> f64 {
        let nu = right_normal(self.chain.clamp_angle());
        self.chain.tip_jacobian(q).iter().zip(dq).map(|(col, d)| (col[0] * nu[0] + col[1] * nu[1]) * d).sum()
    }
}

/// The load path: gravity raised from 0 to `g`.
impl Path for Cantilever {
    fn path(&self, _q: &[f64], _t: f64, ev: &Evaluation, out: &mut PathTerms) {
        self.chain.load_gradient(&ev.cos, self.gravity, &mut out.gradient);
    }
    fn discrete_stiffness(&self) -> f64 {
        self.chain.discrete_stiffness(self.gravity)
    }
}

/// A single tube described element by element, as on `leech chain`'s
/// command line. [`CantileverSpec::build`] checks every value.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CantileverSpec {
    /// Number of elements `n` (1 to [`crate::chain::MAX_LINKS`]).
    pub elements: usize,
    /// Element length `l` (m); the tube, `n l`, at most [`crate::chain::MAX_TUBE_LENGTH_M`].
    pub element_length_m: f64,
    /// Element mass `m` (kg).
    pub element_mass_kg: f64,
    /// Joint stiffness `k` (N m/rad).
    pub joint_stiffness_nm_per_rad: f64,
    /// Point mass at the tip (kg).
    pub tip_mass_kg: f64,
    /// Clamp direction (deg from +x).
    pub base_angle_deg: f64,
    /// Gravity (m/s^2).
    pub gravity_m_per_s2: f64,
    /// How the tube is cut into links.
    pub discretization: crate::chain::Discretization,
}

impl CantileverSpec {
    /// Validates the values and builds the tube (length `n l`).
    pub fn build(&self) -> Result<Cantilever, crate::error::InputError> {
        self.built(None)
    }

    /// The tube fed out to `length` (m, above 0 and at most `n l`), the last
    /// element cut short where the length is not a whole number of them: the
    /// tube on its way to its full length.
    ///
    /// ```
    /// use leech::cantilever::CantileverSpec;
    /// use leech::chain::Discretization;
    /// let spec = CantileverSpec {
    ///     elements: 10, element_length_m: 0.01, element_mass_kg: 0.001, joint_stiffness_nm_per_rad: 0.5,
    ///     tip_mass_kg: 0.0, base_angle_deg: 0.0, gravity_m_per_s2: 9.81, discretization: Discretization::Paper,
    /// };
    /// assert_eq!(spec.fed_to(0.045).unwrap().chain().len(), 5);
    /// assert!(spec.fed_to(0.2).is_err());
    /// ```
    pub fn fed_to(&self, length: f64) -> Result<Cantilever, crate::error::InputError> {
        self.built(Some(length))
    }

    /// The full length `n l` (m).
    pub fn length_m(&self) -> f64 {
        self.elements as f64 * self.element_length_m
    }

    /// Builds the tube at `length` (m; `n l` when `None`), checking every value.
    fn built(&self, length: Option<f64>) -> Result<Cantilever, crate::error::InputError> {
        use crate::error::{non_negative, positive, within, InputError, Num};
        if self.elements == 0 || self.elements > crate::chain::MAX_LINKS {
            return Err(InputError::invalid(
                "elements",
                self.elements as f64,
                format!("a whole number from 1 to {}", crate::chain::MAX_LINKS),
            ));
        }
        let l = crate::chain::check_element_length("element_length_m", self.element_length_m)?;
        // The derived length, not only its factors: 20 elements of 1e308 m
        // are each finite but together overflow.
        let full = self.elements as f64 * l;
        if !(full.is_finite() && full <= crate::chain::MAX_TUBE_LENGTH_M) {
            return Err(InputError::Invalid {
                field: "tube length (elements x element_length_m)".into(),
                value: format!("{} x {} m = {} m", self.elements, Num(l), Num(full)),
                allowed: format!("a finite length of at most {} m", Num(crate::chain::MAX_TUBE_LENGTH_M)),
            });
        }
        let tube_length = match length {
            Some(length) => within("tube_length_m", positive("tube_length_m", length)?, 0.0, full)?,
            None => full,
        };
        let spec = crate::chain::ChainSpec {
            tube_length,
            element_length: l,
            element_mass: crate::chain::check_element_mass("element_mass_kg", self.element_mass_kg)?,
            stiffness: positive("joint_stiffness_nm_per_rad", self.joint_stiffness_nm_per_rad)?,
            damping: 0.0,
            tip_mass: non_negative("tip_mass_kg", self.tip_mass_kg)?,
            clamp_point: [0.0, 0.0],
            clamp_angle: within("base_angle_deg", self.base_angle_deg, -360.0, 360.0)?.to_radians(),
            discretization: self.discretization,
        };
        let gravity = within("gravity_m_per_s2", self.gravity_m_per_s2, 0.0, 1e3)?;
        Ok(Cantilever::new(Chain::new(&spec), gravity))
    }

    /// Shape parameter `Pi = k / (m g l)`.
    pub fn shape_parameter(&self) -> f64 {
        self.joint_stiffness_nm_per_rad / (self.element_mass_kg * self.gravity_m_per_s2 * self.element_length_m)
    }
}
