//! Static equilibrium: Newton's method on the constrained stationarity (KKT)
//! conditions, with load continuation, inequality rows handled by an active
//! set, and honest reporting of folds and bifurcations.
//!
//! # Equations
//!
//! An equilibrium of a potential `V(q)` (J) under constraints `C(q)`, rows of
//! which are equalities `C_r = 0` and the others inequalities `C_r >= 0`, solves
//!
//! ```text
//! grad V(q) - J(q)^T lambda = 0,      J = dC/dq
//! C_r(q) = 0                           (equality rows)
//! C_r(q) >= 0, lambda_r >= 0, lambda_r C_r(q) = 0   (inequality rows)
//! ```
//!
//! The *working set* `A` holds the equality rows and the inequality rows at
//! their bound. Newton's step on it solves `[H  J_A^T; J_A  0] [dq; y] = -[r; C_A]`
//! with the Lagrangian Hessian `H = hess V - sum_r lambda_r hess C_r` and
//! updates `lambda_A <- lambda_A - y`. After Newton converges on a working
//! set, rows whose multiplier pulls (`lambda_r < 0`) leave it and violated
//! rows (`C_r < 0`) join it, and Newton runs again (a primal-dual active set,
//! bounded by [`Tuning::active_set_changes_per_row`]). For the LEeCH body
//! `hess V` is tridiagonal within each chain (springs) plus diagonal
//! (gravity), every `hess C_r` is diagonal, and the rows are few and dense,
//! so each step costs O(n m) ([`crate::linalg`]).
//!
//! *Globalization.* When the reduced Hessian is not positive definite, `H` is
//! shifted by `delta I` until it is (inertia correction), so the step always
//! points towards a *stable* equilibrium. A rejected step raises a
//! Levenberg shift (shorter steps turning towards steepest descent) instead of
//! backtracking; where the curvature was corrected steps are also kept within
//! a trust radius, and so are all steps of a system with inequality rows: there,
//! where the curvature is right, the Newton step is cut to the radius along its
//! direction (no new factorization). A step is accepted when it decreases the exact-penalty
//! merit `V/k + rho |C_A|_1` measurably (Armijo, above rounding) or, where the
//! curvature needed no correction, the norm of the scaled residual.
//!
//! *Rounding floor.* Near a fold the system is ill-conditioned and rounding
//! can keep the residual above the tolerance. A solve counts as converged
//! there only if no step can improve it and the residual is within
//! [`SolverOptions::rounding_slack`] times the tolerance; the residual is
//! reported as it is.
//!
//! *Stability.* An equilibrium is stable when `H` is positive definite on the
//! null space of `J_A`; the factorization reports it for free (Sylvester's
//! law of inertia).
//!
//! *Continuation.* [`Solver::continuation`] follows a one-parameter family of
//! problems `t in [0, 1]` (gravity raised from 0 to g; tubes fed from equal
//! lengths) with a tangent predictor ([`Path`] gives `dF/dt`; one extra
//! solve with the converged factors) and a Newton corrector, doubling the
//! step after a success and halving it when the corrector fails or jumps. The
//! first step is sized from the tangent ([`Tuning::first_step_angle`]). A jump
//! that persists at the smallest step is a *fold*: the body snaps through, and
//! the solver minimizes from the last stable state at the new load, which is
//! the equilibrium that damped dynamics reach (an [`Event::Snap`]). A converged
//! but unstable point on the path is a *bifurcation* (a straight vertical body
//! past its buckling load): the solver leaves it along the direction of most
//! negative curvature, to the side the [`BranchRule`] picks, and reports an
//! [`Event::Bifurcation`].
//!
//! Everything is bounded by iteration counts (and an optional
//! [`Deadline`](crate::budget::Deadline)): the solver never hangs, and a failure is an error carrying the
//! residual, the iteration count and a [`StopReason`], never a silent wrong
//! shape.
//!
//! Residuals are dimensionless: moments divided by the largest joint
//! stiffness, constraint rows by their [`Row::scale`].
//!
//! *Bodies it solves.* The planar body and its stances (link angles,
//! tridiagonal Hessian, diagonal row curvature, `q + dq`), the single tube,
//! and the three-tube body in 3D ([`crate::body3`]: frames on SO(3), 3 x 3
//! blocks, the weld's Hessian coupling frames): the contract's block size,
//! retraction `q (+) dq` and Lagrangian Hessian ([`system`]) cover both, and
//! everything above is written in the tangent space. Where the Hessian holds
//! the multipliers, a Newton run without any starts from their
//! least-squares estimate `(J_A J_A^T)^-1 J_A grad V`.
//!
//! *Escapes.* An unstable landing is kicked along its most negative
//! curvature to the branch rule's side, and a settle where no step descends
//! (a fold's ghost; systems without inequality rows only, since a kick could
//! cross a surface) along its softest mode to the side of lower merit; then
//! it minimizes again, the kick growing by [`Tuning::escape_kick_growth`],
//! at most [`Tuning::escapes`] times (`escape.rs`).
//!
//! # Layout
//!
//! [`system`] (the contract: [`Potential`], [`Constraints`], [`Path`]),
//! [`Evaluation`], [`SolverOptions`] and [`Tuning`], [`Iterate`] and
//! [`Scratch`] (the in-place API), Newton (`newton.rs`), continuation
//! (`continuation.rs`), leaving unstable equilibria (`escape.rs`).

mod continuation;
mod escape;
mod evaluation;
mod iterate;
mod newton;
mod options;
mod outcome;
mod scratch;
pub mod system;

pub use evaluation::{Evaluation, PathTerms};
pub use iterate::Iterate;
pub use options::{BranchRule, SolverOptions, Tuning};
pub use outcome::{Equilibrium, Event, Side, SolveError, Stage, StopReason};
pub use scratch::Scratch;
pub use system::{Border, Constraints, Path, Potential, Row, RowKind, StaticSystem};

/// The solver: options plus the algorithms that use them.
#[derive(Clone, Debug, Default)]
pub struct Solver {
    /// Bounds and tolerances.
    pub options: SolverOptions,
}

impl Solver {
    /// A solver with the given options.
    pub fn new(options: SolverOptions) -> Solver {
        Solver { options }
    }

    /// The error for a Newton run that stopped for `reason`.
    pub(crate) fn fail(&self, stage: Stage, it: &Iterate, residual: f64, reason: StopReason) -> SolveError {
        match self.options.deadline.check() {
            Some(halt) if reason == StopReason::TimeLimit => {
                SolveError::Stopped { halt, iterations: it.iterations, residual }
            }
            _ => SolveError::NotConverged { stage, iterations: it.iterations, residual, reason },
        }
    }

    /// Minimizes from `it` at parameter `t` (no continuation) and leaves an
    /// unstable result along its most negative curvature. The in-place form
    /// of a warm-started solve; returns the scaled residual.
    pub fn minimize<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        stage: Stage,
        ws: &mut Scratch,
    ) -> Result<f64, SolveError> {
        assert!(ws.fits(sys), "scratch sized for another system");
        ws.q_saved.copy_from_slice(&it.q);
        let (residual, escaped) = self.settle(sys, it, t, stage, ws)?;
        if let Some(side) = escaped {
            let jump_rad = sys.distance(&it.q, &ws.q_saved);
            it.events.push(Event::Bifurcation { stage, at: t, side, jump_rad });
        }
        Ok(residual)
    }

    /// At most [`SolverOptions::max_minimization_iterations`] Newton
    /// iterations from `it` at parameter `t`, with no escape from an
    /// unstable point: one leg of a descent that its caller cuts into legs
    /// (to refresh what the rows are between them). Returns the scaled
    /// residual and, where Newton converged, whether the point is stable;
    /// `None` where the leg's iterations ran out (`it` holds the last
    /// accepted point).
    pub fn descend<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        stage: Stage,
        ws: &mut Scratch,
    ) -> Result<(f64, Option<bool>), SolveError> {
        assert!(ws.fits(sys), "scratch sized for another system");
        let out = self.newton(sys, it, t, self.free_budget(), ws);
        match out.result {
            Ok(stable) => Ok((out.residual, Some(stable))),
            Err(StopReason::IterationLimit) if it.iterations < self.options.max_iterations => Ok((out.residual, None)),
            Err(reason) => Err(self.fail(stage, it, out.residual, reason)),
        }
    }

    /// Packs a finished iterate as an [`Equilibrium`] at `t = 1`. The last
    /// converged Newton run already knows energy and stability when it ended
    /// there; otherwise `sys` is evaluated and factored once.
    pub fn finish<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        mut it: Iterate,
        residual: f64,
        ws: &mut Scratch,
    ) -> Equilibrium {
        it.fit_rows(&ws.rows);
        let verdict = match it.verdict {
            Some(v) if v.t == 1.0 && v.fingerprint == it.fingerprint() => v,
            _ => {
                sys.evaluate_at(&it.q, &it.lambda, 1.0, &mut ws.current);
                // More active rows than the factorization holds: no verdict
                // can be had, so the point is not reported stable.
                let fits = it.active.iter().filter(|a| **a).count() <= ws.kkt.active_capacity();
                let stable = fits && self.factor(sys.moment_scale(), &it, ws).0 == scratch::Inertia::Minimum;
                iterate::Verdict { fingerprint: 0, t: 1.0, stable, energy: ws.current.energy }
            }
        };
        Equilibrium {
            energy: verdict.energy,
            q: it.q,
            multipliers: it.lambda,
            residual,
            stable: verdict.stable,
            iterations: it.iterations,
            steps: it.steps,
            events: it.events,
        }
    }

    /// The equilibrium reached from `q0` at `t = 1` without continuation (a
    /// warm start), with the same stability handling as every other stage.
    pub fn warm_start<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        q0: &[f64],
        ws: &mut Scratch,
    ) -> Result<Equilibrium, SolveError> {
        self.warm_start_from(sys, Iterate::new(q0.to_vec()), ws)
    }

    /// [`Solver::warm_start`] from an iterate whose multipliers may be
    /// known already. The Lagrangian's Hessian holds the multipliers times
    /// the rows' curvature: started from zero multipliers, a soft body whose
    /// weld carries large forces can look unstable to the inertia test, which
    /// then only accepts energy descent, and there is none at a point that
    /// is already an equilibrium.
    pub fn warm_start_from<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        mut it: Iterate,
        ws: &mut Scratch,
    ) -> Result<Equilibrium, SolveError> {
        Solver::check_start(sys, &it.q)?;
        let residual = self.minimize(sys, &mut it, 1.0, Stage::WarmStart, ws)?;
        Ok(self.finish(sys, it, residual, ws))
    }

    /// Checks a warm start's size and finiteness.
    pub fn check_start<S: StaticSystem + ?Sized>(sys: &S, q: &[f64]) -> Result<(), SolveError> {
        let got = q.iter().filter(|x| x.is_finite()).count();
        if q.len() != sys.point_dim() || got != q.len() {
            return Err(SolveError::BadStart { expected: sys.point_dim(), got });
        }
        Ok(())
    }
}
