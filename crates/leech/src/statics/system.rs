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
//! The coordinates live on a manifold given by a *retraction*
//! `q (+) dq` ([`StaticSystem::retract`]): additive by default (link
//! angles), `R_u Exp(dq_u)` for frames in SO(3) (the three-tube body,
//! [`crate::body3`]). The solver works in the tangent space: gradients,
//! Hessians, Jacobians and steps have [`Potential::dim`] entries, while a
//! point `q` has [`StaticSystem::point_dim`] (9 per frame for rotation
//! matrices). The Hessian is banded in blocks of [`Potential::block_size`]
//! (1 for angles, 3 for frames). A system whose rows' Hessians are not
//! diagonal adds `-sum_r lambda_r hess C_r` to its Hessian itself, given the
//! multipliers ([`StaticSystem::evaluate_at`],
//! [`StaticSystem::multipliers_in_hessian`]).
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
    /// Size of the Hessian's blocks along a chain: 1 (one angle per link,
    /// tridiagonal) or 3 (a rotation per link, block tridiagonal with 3 x 3
    /// blocks, [`Evaluation`]'s layout per block row-major). A system of
    /// blocks of 3 must include its rows' Hessians itself
    /// ([`StaticSystem::multipliers_in_hessian`]).
    fn block_size(&self) -> usize {
        1
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

    /// What the solver calls: [`StaticSystem::evaluate`] at multipliers
    /// `lambda` (one per row). A system whose Hessian holds the rows'
    /// curvature times the multipliers
    /// ([`StaticSystem::multipliers_in_hessian`]) evaluates it here.
    fn evaluate_at(&self, q: &[f64], _lambda: &[f64], t: f64, ev: &mut Evaluation) {
        self.evaluate(q, t, ev);
    }

    /// Whether [`StaticSystem::evaluate_at`] writes the Lagrangian's Hessian
    /// `hess V - sum_r lambda_r hess C_r` (its [`Evaluation::curvature`] left
    /// unused), instead of `hess V` with the rows' diagonal curvature beside it.
    fn multipliers_in_hessian(&self) -> bool {
        false
    }

    /// Number of entries of a point `q`: [`Potential::dim`] unless the
    /// coordinates are not a vector space (9 per rotation matrix).
    fn point_dim(&self) -> usize {
        self.dim()
    }

    /// The retraction `out = q (+) alpha dq` of a tangent step `dq`
    /// ([`Potential::dim`] entries): `q + alpha dq` by default.
    fn retract(&self, q: &[f64], dq: &[f64], alpha: f64, out: &mut [f64]) {
        for ((o, x), d) in out.iter_mut().zip(q).zip(dq) {
            *o = x + alpha * d;
        }
    }

    /// The distance between two points (rad, sup norm over the
    /// coordinates, or over the frames' angles): how far a step, a jump or
    /// a snap went.
    fn distance(&self, a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).fold(0.0f64, |acc, (x, y)| acc.max((x - y).abs()))
    }

    /// Whether [`StaticSystem::distance`]`(a, b) <= limit`, which a system
    /// may answer more cheaply (frames: by the trace, without a logarithm).
    fn within(&self, a: &[f64], b: &[f64], limit: f64) -> bool {
        self.distance(a, b) <= limit
    }

    /// Longest step (rad, sup norm) the retraction is good for: a plain
    /// Newton step is cut to it. Unbounded by default; the exponential map
    /// of a rotation is one to one within `pi`.
    fn step_limit(&self) -> f64 {
        f64::INFINITY
    }

    /// Whether [`StaticSystem::border_start`] says more than "everywhere":
    /// the factorization then skips the blocks before each border row's start.
    fn sparse_border(&self) -> bool {
        false
    }

    /// The first block of chain `chain` (counted from the chain's start)
    /// where border entry `border` may be nonzero: free coordinate `a`
    /// ([`Border::Free`]) or row `r` ([`Border::Row`]); the chain's length
    /// or more where it is zero on the whole chain. Read only when
    /// [`StaticSystem::sparse_border`].
    fn border_start(&self, _chain: usize, _border: Border) -> usize {
        0
    }
}

/// An entry of the KKT matrix's dense border ([`StaticSystem::border_start`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Border {
    /// Free coordinate `a` (of [`Potential::free`]).
    Free(usize),
    /// Constraint row `r`.
    Row(usize),
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
    /// Most the first predictor may turn a coordinate (rad) where the first
    /// step is sized from the tangent: [`Tuning::first_step_angle`] for link
    /// angles by default.
    ///
    /// [`Tuning::first_step_angle`]: super::Tuning::first_step_angle
    fn first_turn(&self, tuning: &super::Tuning) -> f64 {
        tuning.first_step_angle
    }
}
