//! The solver's contract: what a static problem provides.
//!
//! A problem is split the way its mathematics is:
//!
//! * a [`Potential`] `V(q, t)` (J) with gradient `dV/dq` (N m) and a Hessian that
//!   is tridiagonal within each of a few independent chains (springs) plus
//!   diagonal (gravity);
//! * a set of [`Constraints`], `m` rows whose number and [`RowKind`] are known
//!   at run time: equalities `C_r(q) = 0` and inequalities `C_r(q) >= 0`, each
//!   with its Jacobian row `dC_r/dq` and a diagonal Hessian ("curvature");
//! * optionally a [`Path`]: the derivatives along the continuation parameter
//!   `t` that the predictor of [`Solver::continuation`](super::Solver::continuation)
//!   needs.
//!
//! The multipliers `lambda` enter as `grad V - J^T lambda = 0`: for an
//! inequality `C_r >= 0`, `lambda_r >= 0` is the force that holds the system
//! on the feasible side.

use super::evaluation::{Evaluation, PathTerms};

/// Whether a constraint row is an equality or a one-sided bound.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowKind {
    /// `C_r(q) = 0`, any multiplier.
    Equality,
    /// `C_r(q) >= 0` with `lambda_r >= 0` and `lambda_r C_r = 0` (complementarity).
    Inequality,
}

/// One constraint row as the solver sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// Equality or inequality.
    pub kind: RowKind,
    /// Scale of the row's value (m for positions, rad for angles): residuals
    /// are divided by it, so that rows of different units compare.
    pub scale: f64,
}

/// A potential with a chain-banded Hessian.
pub trait Potential {
    /// Number of generalized coordinates `n`.
    fn dim(&self) -> usize;
    /// Sizes of the independent blocks (chains) the banded Hessian splits
    /// into (their sum is `dim() - free()`): no Hessian entry couples two chains.
    fn blocks(&self) -> Vec<usize> {
        vec![self.dim() - self.free()]
    }
    /// Number of free coordinates, the last ones of `q`, whose Hessian
    /// couples densely (a floating base's pose); 0 by default.
    fn free(&self) -> usize {
        0
    }
    /// Moment scale for residuals (N m): the largest joint stiffness.
    fn moment_scale(&self) -> f64;
    /// Adds `V`, its gradient and Hessian at `q` and parameter `t` to `ev`
    /// (cleared by the caller) and fills `ev.cos`, `ev.sin` with the
    /// coordinates' trigonometry for [`Constraints::constraints`].
    fn potential(&self, q: &[f64], t: f64, ev: &mut Evaluation);
}

/// Constraint rows, known at run time.
pub trait Constraints {
    /// Number of rows `m`.
    fn rows(&self) -> usize;
    /// Kind and scale of row `r`.
    fn row(&self, r: usize) -> Row;
    /// Writes the values, the Jacobian (stride `m`: `dC_r/dq_i` at `i m + r`)
    /// and the diagonal constraint Hessians (same layout) into `ev`, after
    /// [`Potential::potential`] at the same `q` and `t` (its trigonometry may
    /// be reused).
    fn constraints(&self, q: &[f64], t: f64, ev: &mut Evaluation);
}

/// A potential under constraints: what [`Solver::minimize`](super::Solver::minimize) solves.
pub trait StaticSystem: Potential + Constraints {
    /// A linear measure of a displacement `dq` at `q` whose sign names the
    /// side a symmetric bifurcation is left to (positive: [`Side::Right`]);
    /// the [`BranchRule`] option picks the side. For the robot: the
    /// endpoint's displacement along the right normal of the clamp direction.
    ///
    /// [`Side::Right`]: super::Side::Right
    /// [`BranchRule`]: super::BranchRule
    fn side_measure(&self, q: &[f64], dq: &[f64]) -> f64;

    /// Evaluates the potential and the constraints into `ev` (cleared here;
    /// a system whose potential and constraints write every entry instead
    /// of adding to it may leave the clear out).
    fn evaluate(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        ev.clear();
        self.potential(q, t, ev);
        self.constraints(q, t, ev);
    }
}

/// The derivatives along the continuation parameter `t`: what
/// [`Solver::continuation`](super::Solver::continuation) follows.
pub trait Path: StaticSystem {
    /// Writes `d(dV/dq)/dt`, `d(dC/dq)/dt` and `dC/dt` at fixed `q` into `out`,
    /// after [`StaticSystem::evaluate`] at the same `q` and `t` into `ev`.
    fn path(&self, q: &[f64], t: f64, ev: &Evaluation, out: &mut PathTerms);
    /// Largest first continuation step along `t` worth trying (the solver
    /// may take a shorter one, see [`Tuning::first_step_angle`]).
    ///
    /// [`Tuning::first_step_angle`]: super::Tuning::first_step_angle
    fn first_step(&self) -> f64 {
        1.0
    }
    /// How stiff the discrete path is: for chains under gravity the largest
    /// `k / (m g l)` of a link (dimensionless; 0 when it does not apply). A
    /// fine chain's stiff high modes shrink the corrector's basin, so above
    /// [`Tuning::stiff_path`] the first step is sized from the tangent.
    ///
    /// [`Tuning::stiff_path`]: super::Tuning::stiff_path
    fn discrete_stiffness(&self) -> f64 {
        0.0
    }
}
