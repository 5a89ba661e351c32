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
//! from 0 to `g`; a vertical tube above its buckling load
//! (`beta = rho g L^3 / EI > 7.84`) is a pitchfork, left on the right of the
//! clamp direction.

use crate::chain::{right_normal, Block, Chain};
use crate::kkt::MAX_CONSTRAINTS;
use crate::statics::{Equilibrium, Evaluation, SolveError, Solver, State, StaticSystem, Workspace};

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
        let mut ws = Workspace::for_system(self);
        let mut state = State::new(self.chain.straight());
        let residual = solver.continuation(self, &mut state, 0.0, "load", &mut ws)?;
        Ok(solver.finish(self, state, residual, &mut ws))
    }

    /// The equilibrium reached from `q0` with gravity on (warm start).
    pub fn solve_from(&self, solver: &Solver, q0: &[f64], ws: &mut Workspace) -> Result<Equilibrium, SolveError> {
        Solver::check_start(self, q0)?;
        let mut state = State::new(q0.to_vec());
        let residual = solver.minimize(self, &mut state, 1.0, "warm start", ws)?;
        Ok(solver.finish(self, state, residual, ws))
    }
}

impl StaticSystem for Cantilever {
    fn dim(&self) -> usize {
        self.chain.len()
    }

    fn constraint_count(&self) -> usize {
        0
    }

    fn moment_scale(&self) -> f64 {
        self.chain.stiffness().iter().fold(0.0, |a, k| a.max(*k))
    }

    fn constraint_scales(&self) -> [f64; MAX_CONSTRAINTS] {
        [1.0; MAX_CONSTRAINTS]
    }

    /// `t` is the fraction of gravity applied.
    fn evaluate(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        ev.energy = self.chain.evaluate_block(
            q,
            self.gravity,
            t,
            1.0,
            Block {
                cos: &mut ev.cos,
                sin: &mut ev.sin,
                grad: &mut ev.gradient,
                param_grad: &mut ev.param_gradient,
                diag: &mut ev.hessian_diag,
                off: &mut ev.hessian_off,
            },
        );
    }

    fn lateral_displacement(&self, q: &[f64], dq: &[f64]) -> f64 {
        let nu = right_normal(self.chain.clamp_angle());
        self.chain.tip_jacobian(q).iter().zip(dq).map(|(col, d)| (col[0] * nu[0] + col[1] * nu[1]) * d).sum()
    }
}
