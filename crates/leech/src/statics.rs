//! Static equilibrium: Newton's method on the constrained stationarity (KKT)
//! conditions, with load continuation and honest reporting of folds and
//! bifurcations.
//!
//! # Equations
//!
//! An equilibrium of a potential `V(q)` (J) under constraints `C(q) = 0` solves
//!
//! ```text
//! F(q, lambda) = [ grad V(q) - J(q)^T lambda ]  =  0,     J = dC/dq
//!                [ C(q)                       ]
//! ```
//!
//! Newton's step solves `[H  J^T; J  0] [dq; y] = -[r; C]` with the Lagrangian
//! Hessian `H = hess V - sum_i lambda_i hess C_i` and updates `lambda <- lambda - y`.
//! For the LEeCH body `hess V` is tridiagonal (springs) plus diagonal (gravity),
//! every `hess C_i` is diagonal and there are three constraint rows, so each step
//! costs O(n) ([`crate::kkt`]).
//!
//! *Globalization.* When the reduced Hessian is not positive definite, `H` is
//! shifted by `delta I` until it is (inertia correction), so the step always
//! points towards a *stable* equilibrium. A rejected step raises a
//! Levenberg shift (shorter steps turning towards steepest descent) instead of
//! backtracking; where the curvature was corrected steps are also kept within
//! a trust radius. A step is accepted when it decreases the exact-penalty
//! merit `V/k + rho |C|_1` measurably (Armijo, above rounding) or, where the
//! curvature needed no correction, the norm of the scaled residual `F`.
//!
//! *Rounding floor.* Near a fold the system is ill-conditioned and rounding
//! can keep the residual above the tolerance. A solve counts as converged
//! there only if no step can improve it and the residual is within
//! `SolverOptions::rounding_slack` times the tolerance; the residual is
//! reported as it is.
//!
//! *Stability.* An equilibrium is stable when `H` is positive definite on the
//! null space of `J`; the factorization reports it for free (Sylvester's law of
//! inertia).
//!
//! *Continuation.* [`Solver::continuation`] follows a one-parameter family of
//! problems `t in [0, 1]` (gravity raised from 0 to g; tubes fed from equal
//! lengths) with a tangent predictor (`dF/dt` from the system, one extra
//! solve with the converged factors) and a Newton corrector, doubling the
//! step after a success and halving it when the corrector fails or jumps. A jump
//! that persists at the smallest step is a *fold*: the body snaps through, and
//! the solver minimizes from the last stable state at the new load, which is
//! the equilibrium that damped dynamics reach (a [`Event::Snap`]). A converged
//! but unstable point on the path is a *bifurcation* (a straight vertical body
//! past its buckling load): the solver leaves it along the direction of most
//! negative curvature, on the side where the endpoint moves to the right of
//! the clamp direction (towards chain B), and reports a [`Event::Bifurcation`].
//!
//! Everything is bounded by iteration counts (and an optional wall-clock
//! limit): the solver never hangs, and a failure is an error carrying the
//! residual and iteration count, never a silent wrong shape.
//!
//! Residuals are dimensionless: moments divided by the largest joint
//! stiffness, lengths by the element length, angles in radians.

use std::time::{Duration, Instant};

use crate::kkt::{Inertia, Kkt, MAX_CONSTRAINTS};

/// Values and derivatives of a [`StaticSystem`] at one configuration.
#[derive(Clone, Debug, Default)]
pub struct Evaluation {
    /// Potential `V` (J).
    pub energy: f64,
    /// `dV/dq` (N m).
    pub gradient: Vec<f64>,
    /// Diagonal of `d2V/dq2` (N m/rad).
    pub hessian_diag: Vec<f64>,
    /// Off-diagonal of the tridiagonal `d2V/dq2`; entry `i` couples `i` and `i + 1`.
    pub hessian_off: Vec<f64>,
    /// Constraint values `C` (m for positions, rad for angles).
    pub constraints: [f64; MAX_CONSTRAINTS],
    /// Constraint Jacobian, interleaved by coordinate: `dC_r/dq_i` at
    /// `i * MAX_CONSTRAINTS + r` (rows `r >= m` stay zero).
    pub jacobian: Vec<f64>,
    /// Diagonals of the constraint Hessians `d2C_r/dq_i2`, laid out as `jacobian`.
    pub curvature: Vec<f64>,
    /// `d(dV/dq)/dt` at fixed `q`: how the gradient moves along the path (N m).
    pub param_gradient: Vec<f64>,
    /// `d(dC/dq)/dt` at fixed `q`, laid out as `jacobian`.
    pub param_jacobian: Vec<f64>,
    /// `dC/dt` at fixed `q`.
    pub param_constraints: [f64; MAX_CONSTRAINTS],
    /// Cosines of the coordinates (scratch for systems of link angles).
    pub cos: Vec<f64>,
    /// Sines of the coordinates.
    pub sin: Vec<f64>,
}

impl Evaluation {
    /// Zeroed storage for `n` coordinates and `m` constraints.
    pub fn new(n: usize, _m: usize) -> Evaluation {
        Evaluation {
            energy: 0.0,
            gradient: vec![0.0; n],
            hessian_diag: vec![0.0; n],
            hessian_off: vec![0.0; n.saturating_sub(1)],
            constraints: [0.0; MAX_CONSTRAINTS],
            jacobian: vec![0.0; n * MAX_CONSTRAINTS],
            curvature: vec![0.0; n * MAX_CONSTRAINTS],
            param_gradient: vec![0.0; n],
            param_jacobian: vec![0.0; n * MAX_CONSTRAINTS],
            param_constraints: [0.0; MAX_CONSTRAINTS],
            cos: vec![0.0; n],
            sin: vec![0.0; n],
        }
    }

    /// Sets every accumulated quantity to zero before an evaluation.
    pub fn clear(&mut self) {
        self.energy = 0.0;
        for v in [
            &mut self.gradient,
            &mut self.hessian_diag,
            &mut self.hessian_off,
            &mut self.jacobian,
            &mut self.curvature,
            &mut self.param_gradient,
            &mut self.param_jacobian,
        ] {
            v.iter_mut().for_each(|x| *x = 0.0);
        }
        self.constraints = [0.0; MAX_CONSTRAINTS];
        self.param_constraints = [0.0; MAX_CONSTRAINTS];
    }
}

/// A potential with a tridiagonal Hessian under at most three constraints
/// whose Hessians are diagonal, depending on a continuation parameter `t`.
pub trait StaticSystem {
    /// Number of generalized coordinates.
    fn dim(&self) -> usize;
    /// Number of constraint rows (0 to 3).
    fn constraint_count(&self) -> usize;
    /// Moment scale for residuals (N m): the largest joint stiffness.
    fn moment_scale(&self) -> f64;
    /// Scale of each constraint row (m or rad).
    fn constraint_scales(&self) -> [f64; MAX_CONSTRAINTS];
    /// Fills `ev` at configuration `q` and parameter `t` (cleared by the
    /// caller), including the `param_*` derivatives along `t`.
    fn evaluate(&self, q: &[f64], t: f64, ev: &mut Evaluation);
    /// First-order displacement (m) of the endpoint along the right normal of
    /// the clamp direction for a change `dq`: decides the side of a bifurcation.
    fn lateral_displacement(&self, q: &[f64], dq: &[f64]) -> f64;
    /// Where the Hessian splits into two independent tridiagonal blocks (the
    /// first coordinate of the second block); `dim()` for one block.
    fn block_split(&self) -> usize {
        self.dim()
    }
    /// The first continuation step to try along `t` (the whole path by default).
    fn first_step(&self) -> f64 {
        1.0
    }
}

/// Bounds and tolerances of the static solver.
#[derive(Clone, Debug, PartialEq)]
pub struct SolverOptions {
    /// Converged when the scaled residual's sup norm is below this.
    pub tolerance: f64,
    /// Looser tolerance for the intermediate points of a continuation path,
    /// which only seed the next step.
    pub path_tolerance: f64,
    /// Newton iterations allowed for one whole solve, all stages together.
    pub max_iterations: usize,
    /// Newton iterations allowed for one continuation corrector.
    pub max_corrector_iterations: usize,
    /// Newton iterations allowed for a free minimization (snap, escape, warm start).
    pub max_minimization_iterations: usize,
    /// Continuation steps allowed for one path.
    pub max_steps: usize,
    /// Smallest continuation step before a persisting jump counts as a fold.
    pub min_step: f64,
    /// Largest distance (rad, sup norm) between predictor and corrector
    /// that still counts as following the same branch.
    pub jump_tolerance: f64,
    /// Longest step (rad, sup norm) taken where the curvature is corrected.
    pub trust_radius: f64,
    /// A residual that no step can reduce counts as converged up to this
    /// multiple of the tolerance (the rounding floor near folds).
    pub rounding_slack: f64,
    /// A settle after a failed step moving some angle by more than this
    /// (rad) is reported as a snap.
    pub snap_threshold: f64,
    /// Optional wall-clock limit for one solve.
    pub time_limit: Option<Duration>,
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            tolerance: 1e-11,
            path_tolerance: 1e-6,
            max_iterations: 20000,
            max_corrector_iterations: 8,
            max_minimization_iterations: 5000,
            max_steps: 500,
            min_step: 1e-4,
            jump_tolerance: 0.5,
            trust_radius: 0.1,
            rounding_slack: 1e3,
            snap_threshold: 0.05,
            time_limit: None,
        }
    }
}

/// Something that happened on the way to an equilibrium.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Event {
    /// The path met a fold and the body snapped through to another branch.
    Snap {
        /// Which path (`"load"` or `"feed"`).
        stage: &'static str,
        /// Path parameter at the fold (0..1; the fraction of g on the load path).
        #[serde(rename = "at_path_fraction")]
        at: f64,
        /// Largest angle change across the snap (rad).
        jump_rad: f64,
    },
    /// The path crossed a symmetric bifurcation and left the unstable branch.
    Bifurcation {
        /// Which path (`"load"` or `"feed"`).
        stage: &'static str,
        /// Path parameter where the branch was found unstable.
        #[serde(rename = "at_path_fraction")]
        at: f64,
        /// The side chosen: `"right"` of the clamp direction (towards chain B).
        side: &'static str,
        /// Largest angle change from the last stable state (rad): small for a
        /// supercritical pitchfork, large when the body falls far.
        jump_rad: f64,
    },
}

/// Why a solve failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// Newton's method did not reach the tolerance within its bounds.
    #[error("{stage}: not converged after {iterations} iterations (residual {residual:.3e}): {reason}")]
    NotConverged {
        /// Stage of the solve that failed.
        stage: &'static str,
        /// Iterations spent in the whole solve.
        iterations: usize,
        /// Scaled residual when it stopped.
        residual: f64,
        /// What stopped it.
        reason: &'static str,
    },
    /// The wall-clock limit ran out.
    #[error("time limit of {limit:?} exceeded after {iterations} iterations (residual {residual:.3e})")]
    TimeLimit {
        /// The limit that was set.
        limit: Duration,
        /// Iterations spent.
        iterations: usize,
        /// Scaled residual when it stopped.
        residual: f64,
    },
    /// A starting state of the wrong size or with non-finite entries.
    #[error("starting state has {got} finite angles, expected {expected}")]
    BadStart {
        /// Expected number of coordinates.
        expected: usize,
        /// Number of finite coordinates given.
        got: usize,
    },
}

/// A converged equilibrium and how it was reached.
#[derive(Clone, Debug, PartialEq)]
pub struct Equilibrium {
    /// Generalized coordinates (absolute link angles, rad).
    pub q: Vec<f64>,
    /// Lagrange multipliers of the constraints (N and N m).
    pub multipliers: Vec<f64>,
    /// Potential energy (J).
    pub energy: f64,
    /// Scaled residual sup norm at the solution.
    pub residual: f64,
    /// Whether the reduced Hessian is positive definite (a stable equilibrium).
    pub stable: bool,
    /// Newton iterations spent, all stages together.
    pub iterations: usize,
    /// Continuation steps accepted, all paths together.
    pub steps: usize,
    /// Folds and bifurcations met on the way.
    pub events: Vec<Event>,
}

/// Reusable scratch space for one problem size: the in-place API.
#[derive(Clone, Debug)]
pub struct Scratch {
    n: usize,
    m: usize,
    split: usize,
    current: Evaluation,
    trial: Evaluation,
    kkt: Kkt,
    residual: Vec<f64>,
    lagrangian_diag: Vec<f64>,
    step: Vec<f64>,
    q_trial: Vec<f64>,
    tangent: Vec<f64>,
    q_saved: Vec<f64>,
    q_predicted: Vec<f64>,
    dual_step: [f64; MAX_CONSTRAINTS],
    lambda_tangent: [f64; MAX_CONSTRAINTS],
}

impl Scratch {
    /// Scratch for a system of `n` coordinates and `m` constraints.
    pub fn new(n: usize, m: usize) -> Scratch {
        Scratch::with_blocks(n, m, n)
    }

    /// Scratch for a system whose Hessian splits into two blocks at `split`.
    pub fn with_blocks(n: usize, m: usize, split: usize) -> Scratch {
        Scratch {
            n,
            m,
            split,
            current: Evaluation::new(n, m),
            trial: Evaluation::new(n, m),
            kkt: Kkt::with_blocks(n, m, split),
            residual: vec![0.0; n],
            lagrangian_diag: vec![0.0; n],
            step: vec![0.0; n],
            q_trial: vec![0.0; n],
            tangent: vec![0.0; n],
            q_saved: vec![0.0; n],
            q_predicted: vec![0.0; n],
            dual_step: [0.0; MAX_CONSTRAINTS],
            lambda_tangent: [0.0; MAX_CONSTRAINTS],
        }
    }

    /// Scratch sized for `system`.
    pub fn for_system<S: StaticSystem + ?Sized>(system: &S) -> Scratch {
        Scratch::with_blocks(system.dim(), system.constraint_count(), system.block_split())
    }

    /// Whether this scratch is sized for `system`.
    pub fn fits<S: StaticSystem + ?Sized>(&self, system: &S) -> bool {
        self.n == system.dim() && self.m == system.constraint_count() && self.split == system.block_split()
    }
}

/// The state the solver carries: coordinates, multipliers and counters.
#[derive(Clone, Debug)]
pub struct Iterate {
    /// Coordinates (rad).
    pub q: Vec<f64>,
    /// Multipliers.
    pub lambda: [f64; MAX_CONSTRAINTS],
    /// Iterations spent so far.
    pub iterations: usize,
    /// Continuation steps accepted so far.
    pub steps: usize,
    /// Events met so far.
    pub events: Vec<Event>,
    started: Instant,
}

impl Iterate {
    /// A state at `q` with zero multipliers.
    pub fn new(q: Vec<f64>) -> Iterate {
        Iterate {
            q,
            lambda: [0.0; MAX_CONSTRAINTS],
            iterations: 0,
            steps: 0,
            events: Vec::new(),
            started: Instant::now(),
        }
    }
}

/// Outcome of one Newton run.
#[derive(Clone, Copy, Debug)]
struct Newton {
    converged: bool,
    residual: f64,
    stable: bool,
    reason: &'static str,
}

/// Iterations without halving the residual, with steps at the rounding level,
/// after which a residual within `rounding_slack` of the tolerance counts as
/// stalled at rounding.
const STALL_ITERATIONS: usize = 20;

/// Limits of one Newton run: iterations, tolerance, and how far (rad, sup
/// norm) the iterates may wander from the starting point.
#[derive(Clone, Copy, Debug)]
struct Budget {
    max_iter: usize,
    tolerance: f64,
    leash: f64,
}

/// The solver: options plus the algorithms that use them.
#[derive(Clone, Debug, Default)]
pub struct Solver {
    /// Bounds and tolerances.
    pub options: SolverOptions,
}

fn sup_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |a, x| a.max(x.abs()))
}

/// `out = base - J^T lambda` for an interleaved Jacobian (unused rows are zero).
fn transposed_product(base: &[f64], jac: &[f64], lambda: &[f64; MAX_CONSTRAINTS], out: &mut [f64]) {
    for ((o, b), j) in out.iter_mut().zip(base).zip(jac.chunks_exact(MAX_CONSTRAINTS)) {
        *o = b - j[0] * lambda[0] - j[1] * lambda[1] - j[2] * lambda[2];
    }
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0f64, |acc, (x, y)| acc.max((x - y).abs()))
}

impl Solver {
    fn free_budget(&self) -> Budget {
        Budget {
            max_iter: self.options.max_minimization_iterations,
            tolerance: self.options.tolerance,
            leash: f64::INFINITY,
        }
    }

    /// A solver with the given options.
    pub fn new(options: SolverOptions) -> Solver {
        Solver { options }
    }

    /// Writes `r = grad V - J^T lambda` into `ws.residual` and returns the
    /// scaled sup norm of `(r, C)` for the evaluation in `ws.current`.
    fn residual<S: StaticSystem + ?Sized>(&self, sys: &S, lambda: &[f64; 3], ev: &Evaluation, r: &mut [f64]) -> f64 {
        let (n, m) = (sys.dim(), sys.constraint_count());
        transposed_product(&ev.gradient, &ev.jacobian, lambda, r);
        let _ = n;
        let scales = sys.constraint_scales();
        let mut norm = sup_norm(r) / sys.moment_scale();
        for row in 0..m {
            norm = norm.max((ev.constraints[row] / scales[row]).abs());
        }
        norm
    }

    /// Scaled Euclidean norm of the residual, for step acceptance.
    fn residual_l2<S: StaticSystem + ?Sized>(sys: &S, r: &[f64], ev: &Evaluation) -> f64 {
        let k = sys.moment_scale();
        let scales = sys.constraint_scales();
        let mut s: f64 = r.iter().map(|x| (x / k) * (x / k)).sum();
        for row in 0..sys.constraint_count() {
            s += (ev.constraints[row] / scales[row]).powi(2);
        }
        s.sqrt()
    }

    fn merit<S: StaticSystem + ?Sized>(sys: &S, ev: &Evaluation, rho: f64) -> f64 {
        let scales = sys.constraint_scales();
        let penalty: f64 = (0..sys.constraint_count()).map(|i| (ev.constraints[i] / scales[i]).abs()).sum();
        ev.energy / sys.moment_scale() + rho * penalty
    }

    /// Factors the Lagrangian Hessian of `ws.current` with multipliers
    /// `lambda`, adding the smallest shift (from a geometric sequence) that
    /// makes the reduced Hessian positive definite. Returns the unshifted
    /// inertia and the shift used.
    fn factor<S: StaticSystem + ?Sized>(&self, sys: &S, lambda: &[f64; 3], ws: &mut Scratch) -> (Inertia, f64) {
        let (n, m) = (ws.n, ws.m);
        transposed_product(&ws.current.hessian_diag, &ws.current.curvature, lambda, &mut ws.lagrangian_diag);
        let _ = (n, m);
        let k = sys.moment_scale();
        let tiny = 1e-13 * k;
        let first = ws.kkt.factor(&ws.lagrangian_diag, &ws.current.hessian_off, 0.0, &ws.current.jacobian, tiny);
        if first == Inertia::Minimum {
            return (first, 0.0);
        }
        let mut shift = 1e-6 * k;
        for _ in 0..40 {
            if ws.kkt.factor(&ws.lagrangian_diag, &ws.current.hessian_off, shift, &ws.current.jacobian, tiny)
                == Inertia::Minimum
            {
                return (first, shift);
            }
            shift *= 8.0;
        }
        (first, f64::INFINITY)
    }

    fn out_of_time(&self, state: &Iterate) -> bool {
        self.options.time_limit.is_some_and(|limit| state.started.elapsed() > limit)
    }

    /// Newton's method from `state` at parameter `t`, at most `max_iter`
    /// iterations. Leaves `ws.current` evaluated at the final point and the
    /// KKT factors of its unshifted Lagrangian Hessian when converged.
    fn newton<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        state: &mut Iterate,
        t: f64,
        budget: Budget,
        ws: &mut Scratch,
    ) -> Newton {
        let Budget { max_iter, tolerance, leash } = budget;
        let (n, m) = (ws.n, ws.m);
        ws.q_predicted.copy_from_slice(&state.q);
        ws.current.clear();
        sys.evaluate(&state.q, t, &mut ws.current);
        let mut rho: f64 = 0.0;
        let mut damping: f64 = 0.0;
        let mut iter = 0;
        let (mut best, mut best_at) = (f64::INFINITY, 0);
        // After a tiny unshifted step from a minimum, the last factors still
        // give the stability verdict and a tangent good enough for a predictor.
        let mut factors_fresh = false;
        loop {
            let res = self.residual(sys, &state.lambda, &ws.current, &mut ws.residual);
            if !res.is_finite() {
                return Newton { converged: false, residual: res, stable: false, reason: "non-finite residual" };
            }
            // A residual that stalls within a few orders of the tolerance is at
            // the rounding floor of an ill-conditioned point (near a fold):
            // converged, with the residual reported as is.
            if res < 0.5 * best {
                best = res;
                best_at = iter;
            }
            let stalled = iter >= best_at + STALL_ITERATIONS
                && res <= self.options.rounding_slack * tolerance
                && sup_norm(&ws.step) < 1e-10;
            if res <= tolerance || stalled {
                let stable = factors_fresh || self.factor(sys, &state.lambda, ws).0 == Inertia::Minimum;
                return Newton { converged: true, residual: res, stable, reason: "" };
            }
            if iter >= max_iter || state.iterations >= self.options.max_iterations {
                return Newton { converged: false, residual: res, stable: false, reason: "iteration limit reached" };
            }
            if self.out_of_time(state) {
                return Newton { converged: false, residual: res, stable: false, reason: "time limit reached" };
            }
            iter += 1;
            state.iterations += 1;
            let (inertia, min_shift) = self.factor(sys, &state.lambda, ws);
            if !min_shift.is_finite() {
                return Newton {
                    converged: false,
                    residual: res,
                    stable: false,
                    reason: "singular constraint Jacobian",
                };
            }
            // Levenberg-style damping on top of the inertia correction: a
            // rejected full step raises the shift (shorter steps turning towards
            // steepest descent), an accepted one lets it relax. In negative
            // curvature this walks downhill much faster than backtracking along
            // a fixed direction.
            let k = sys.moment_scale();
            let scales = sys.constraint_scales();
            let r0 = Self::residual_l2(sys, &ws.residual, &ws.current);
            // Where the curvature is right, try the plain Newton step first:
            // that keeps quadratic convergence; the memory is for the rest.
            let mut shift = if min_shift == 0.0 { 0.0 } else { min_shift.max(damping) };
            let mut accepted = false;
            for attempt in 0..80 {
                if attempt > 0 || shift != min_shift {
                    let tiny = 1e-13 * k;
                    let diag = &ws.lagrangian_diag;
                    ws.kkt.factor(diag, &ws.current.hessian_off, shift, &ws.current.jacobian, tiny);
                }
                // The step solves (H + shift I) dq + J^T y = -r, J dq = -C.
                ws.residual.iter_mut().for_each(|x| *x = -*x);
                let mut neg_c = [0.0; MAX_CONSTRAINTS];
                for row in 0..m {
                    neg_c[row] = -ws.current.constraints[row];
                }
                ws.kkt.solve(&ws.current.jacobian, &ws.residual, &neg_c[..m], &mut ws.step, &mut ws.dual_step[..m]);
                ws.residual.iter_mut().for_each(|x| *x = -*x);
                // Where the curvature is corrected the quadratic model is not
                // the energy: keep such steps short, so that the descent follows
                // the valley a damped motion would and cannot hop into a
                // distant basin.
                if min_shift > 0.0 && sup_norm(&ws.step) > self.options.trust_radius {
                    shift = (4.0 * shift).max(1e-8 * k);
                    continue;
                }
                let mut lam_trial = state.lambda;
                for row in 0..m {
                    lam_trial[row] -= ws.dual_step[row];
                    rho = rho.max(2.0 * (lam_trial[row] * scales[row] / k).abs() + 1e-3);
                }
                let phi0 = Self::merit(sys, &ws.current, rho);
                let slope = {
                    let g: f64 = ws.current.gradient.iter().zip(&ws.step).map(|(g, d)| g * d).sum::<f64>() / k;
                    let p: f64 = (0..m).map(|i| (ws.current.constraints[i] / scales[i]).abs()).sum();
                    g - rho * p
                };
                for i in 0..n {
                    ws.q_trial[i] = state.q[i] + ws.step[i];
                }
                ws.trial.clear();
                sys.evaluate(&ws.q_trial, t, &mut ws.trial);
                let phi = Self::merit(sys, &ws.trial, rho);
                let r_trial = {
                    let mut s = 0.0;
                    for (g, j) in ws.trial.gradient.iter().zip(ws.trial.jacobian.chunks_exact(MAX_CONSTRAINTS)) {
                        let ri = g - j[0] * lam_trial[0] - j[1] * lam_trial[1] - j[2] * lam_trial[2];
                        s += (ri / k) * (ri / k);
                    }
                    for row in 0..m {
                        s += (ws.trial.constraints[row] / scales[row]).powi(2);
                    }
                    s.sqrt()
                };
                // A decrease lost in rounding is no progress: accepting it would
                // spend the iteration budget on null steps.
                let measurable = phi0 - phi > 1e-14 * phi0.abs().max(1.0);
                let armijo = slope < 0.0 && phi <= phi0 + 1e-4 * slope && measurable;
                // Where the curvature needed correcting, only energy descent
                // counts: a falling residual may be heading for a saddle.
                let decrease = min_shift == 0.0 && r_trial <= (1.0 - 1e-4) * r0;
                if phi.is_finite() && (armijo || decrease) {
                    factors_fresh = inertia == Inertia::Minimum && shift == 0.0 && sup_norm(&ws.step) < 1e-5;
                    damping = if shift > min_shift { 0.25 * shift } else { 0.0 };
                    state.q.copy_from_slice(&ws.q_trial);
                    state.lambda = lam_trial;
                    std::mem::swap(&mut ws.current, &mut ws.trial);
                    accepted = true;
                    break;
                }
                shift = (4.0 * shift).max(1e-8 * k);
            }
            if !accepted {
                // Within a few orders of the tolerance no step can improve on
                // rounding: that is convergence, with the residual reported as is.
                if res <= self.options.rounding_slack * tolerance {
                    let stable = self.factor(sys, &state.lambda, ws).0 == Inertia::Minimum;
                    return Newton { converged: true, residual: res, stable, reason: "" };
                }
                return Newton { converged: false, residual: res, stable: false, reason: "no descent step found" };
            }
            if leash.is_finite() && distance(&state.q, &ws.q_predicted) > leash {
                return Newton { converged: false, residual: res, stable: false, reason: "left the branch" };
            }
        }
    }

    /// Tangent of the solution path `(dq/dt, dlambda/dt)` at a converged
    /// point: `ws.current` evaluated there and its unshifted factors in `ws.kkt`.
    fn tangent(&self, state: &Iterate, ws: &mut Scratch) {
        let (n, m) = (ws.n, ws.m);
        let ev = &ws.current;
        transposed_product(&ev.param_gradient, &ev.param_jacobian, &state.lambda, &mut ws.tangent);
        ws.tangent.iter_mut().for_each(|x| *x = -*x);
        let _ = n;
        let mut dc = [0.0; MAX_CONSTRAINTS];
        for row in 0..m {
            dc[row] = -ev.param_constraints[row];
        }
        // H q' + J^T y = -dr/dt, J q' = -dC/dt, lambda' = -y.
        ws.kkt.solve(&ev.jacobian, &ws.tangent, &dc[..m], &mut ws.step, &mut ws.lambda_tangent[..m]);
        ws.tangent.copy_from_slice(&ws.step);
        for row in 0..m {
            ws.lambda_tangent[row] = -ws.lambda_tangent[row];
        }
    }

    fn fail(&self, stage: &'static str, state: &Iterate, out: Newton) -> SolveError {
        match self.options.time_limit {
            Some(limit) if out.reason == "time limit reached" => {
                SolveError::TimeLimit { limit, iterations: state.iterations, residual: out.residual }
            }
            _ => SolveError::NotConverged {
                stage,
                iterations: state.iterations,
                residual: out.residual,
                reason: out.reason,
            },
        }
    }

    /// Minimizes from `state` at parameter `t` (no continuation) and leaves an
    /// unstable result along its most negative curvature. The in-place form of
    /// a warm-started solve.
    pub fn minimize<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        state: &mut Iterate,
        t: f64,
        stage: &'static str,
        ws: &mut Scratch,
    ) -> Result<f64, SolveError> {
        assert!(ws.fits(sys), "workspace sized for another system");
        let (residual, escaped) = self.settle(sys, state, t, stage, ws)?;
        if escaped {
            state.events.push(Event::Bifurcation { stage, at: t, side: "right", jump_rad: 0.0 });
        }
        Ok(residual)
    }

    /// Newton's method to a stable equilibrium at `t`, leaving an unstable one
    /// if it lands there. Returns the residual and whether it had to leave one.
    fn settle<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        state: &mut Iterate,
        t: f64,
        stage: &'static str,
        ws: &mut Scratch,
    ) -> Result<(f64, bool), SolveError> {
        let out = self.newton(sys, state, t, self.free_budget(), ws);
        if !out.converged {
            return Err(self.fail(stage, state, out));
        }
        if out.stable {
            return Ok((out.residual, false));
        }
        Ok((self.escape(sys, state, t, stage, ws)?, true))
    }

    /// Leaves an unstable equilibrium along the most negative curvature of the
    /// reduced Hessian (shifted inverse iteration on the KKT system) and
    /// minimizes from there.
    fn escape<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        state: &mut Iterate,
        t: f64,
        stage: &'static str,
        ws: &mut Scratch,
    ) -> Result<f64, SolveError> {
        let (n, m) = (ws.n, ws.m);
        // A shift below every eigenvalue (Gershgorin) makes H - sigma I positive
        // definite; inverse iteration then converges to the lowest mode.
        let mut lower = f64::INFINITY;
        for i in 0..n {
            let mut radius = 0.0;
            if i > 0 {
                radius += ws.current.hessian_off[i - 1].abs();
            }
            if i + 1 < n {
                radius += ws.current.hessian_off[i].abs();
            }
            lower = lower.min(ws.lagrangian_diag[i] - radius);
        }
        let sigma = lower - 1e-3 * sys.moment_scale();
        let tiny = 1e-13 * sys.moment_scale();
        ws.kkt.factor(&ws.lagrangian_diag, &ws.current.hessian_off, -sigma, &ws.current.jacobian, tiny);
        let mut v: Vec<f64> = (0..n).map(|i| 1.0 + 0.1 * (i as f64).sin()).collect();
        let zero = [0.0; MAX_CONSTRAINTS];
        let mut y = [0.0; MAX_CONSTRAINTS];
        for _ in 0..200 {
            ws.kkt.solve(&ws.current.jacobian, &v, &zero[..m], &mut ws.step, &mut y[..m]);
            let norm = sup_norm(&ws.step);
            v.iter_mut().zip(&ws.step).for_each(|(vi, si)| *vi = si / norm);
        }
        if sys.lateral_displacement(&state.q, &v) < 0.0 {
            v.iter_mut().for_each(|x| *x = -*x);
        }
        let kick = 0.01;
        for i in 0..n {
            state.q[i] += kick * v[i];
        }
        let out = self.newton(sys, state, t, self.free_budget(), ws);
        if !out.converged {
            return Err(self.fail(stage, state, out));
        }
        if !out.stable {
            return Err(SolveError::NotConverged {
                stage,
                iterations: state.iterations,
                residual: out.residual,
                reason: "could not leave an unstable equilibrium",
            });
        }
        Ok(out.residual)
    }

    /// Follows the family `t in [from, 1]` from a converged, stable `state` at
    /// `t = from`, ending at a stable equilibrium at `t = 1`. Returns the
    /// final scaled residual.
    pub fn continuation<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        state: &mut Iterate,
        from: f64,
        stage: &'static str,
        ws: &mut Scratch,
    ) -> Result<f64, SolveError> {
        assert!(ws.fits(sys), "workspace sized for another system");
        let n = ws.n;
        let m = ws.m;
        // Converge at the start and get factors for the first tangent.
        let mut residual = self.minimize(sys, state, from, stage, ws)?;
        let mut t = from;
        let mut dt = sys.first_step().min(1.0 - from);
        let mut steps = 0;
        self.tangent(state, ws);
        let mut lambda_saved = state.lambda;
        while t < 1.0 {
            steps += 1;
            if steps > self.options.max_steps {
                return Err(SolveError::NotConverged {
                    stage,
                    iterations: state.iterations,
                    residual,
                    reason: "continuation step limit reached",
                });
            }
            dt = dt.min(1.0 - t);
            ws.q_saved.copy_from_slice(&state.q);
            lambda_saved.copy_from_slice(&state.lambda);
            for i in 0..n {
                state.q[i] += dt * ws.tangent[i];
            }
            for row in 0..m {
                state.lambda[row] += dt * ws.lambda_tangent[row];
            }
            ws.q_predicted.copy_from_slice(&state.q);
            let tolerance = if t + dt >= 1.0 { self.options.tolerance } else { self.options.path_tolerance };
            let budget = Budget {
                max_iter: self.options.max_corrector_iterations,
                tolerance,
                leash: self.options.jump_tolerance,
            };
            let out = self.newton(sys, state, t + dt, budget, ws);
            // An unstable landing counts as a failure too: halving the step
            // then brackets the fold or bifurcation to within `min_step`.
            if out.converged && out.stable && distance(&state.q, &ws.q_predicted) <= self.options.jump_tolerance {
                t = if dt >= 1.0 - t { 1.0 } else { t + dt };
                state.steps += 1;
                residual = out.residual;
                if t < 1.0 {
                    self.tangent(state, ws);
                }
                dt *= 2.0;
                continue;
            }
            if let Some(limit) = self.options.time_limit {
                if state.started.elapsed() > limit {
                    return Err(SolveError::TimeLimit { limit, iterations: state.iterations, residual: out.residual });
                }
            }
            state.q.copy_from_slice(&ws.q_saved);
            state.lambda.copy_from_slice(&lambda_saved);
            if dt > self.options.min_step {
                dt *= 0.5;
                // Re-evaluate and re-factor at the saved point for the tangent.
                let refactor = Budget { max_iter: 0, tolerance: f64::INFINITY, leash: f64::INFINITY };
                let again = self.newton(sys, state, t, refactor, ws);
                if !again.converged {
                    return Err(self.fail(stage, state, again));
                }
                self.tangent(state, ws);
                continue;
            }
            // Still failing at the smallest step: the stable branch ends or turns
            // unstable here. Settle from the last stable state at the new
            // parameter, as damped dynamics would: leaving an unstable
            // symmetric state is a pitchfork, anything else a snap at a fold.
            let at = t;
            t = (t + dt).min(1.0);
            let (settled, escaped) = self.settle(sys, state, t, stage, ws)?;
            residual = settled;
            let jump_rad = distance(&state.q, &ws.q_saved);
            // A settle that stays close was a hard step, not a snap.
            if escaped {
                state.events.push(Event::Bifurcation { stage, at, side: "right", jump_rad });
            } else if jump_rad > self.options.snap_threshold {
                state.events.push(Event::Snap { stage, at, jump_rad });
            }
            state.steps += 1;
            dt = 1e-3;
            if t < 1.0 {
                self.tangent(state, ws);
            }
        }
        Ok(residual)
    }

    /// Packs a finished state as an [`Equilibrium`], evaluating the energy at `t = 1`.
    pub fn finish<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        state: Iterate,
        residual: f64,
        ws: &mut Scratch,
    ) -> Equilibrium {
        ws.current.clear();
        sys.evaluate(&state.q, 1.0, &mut ws.current);
        let (inertia, _) = self.factor(sys, &state.lambda, ws);
        let m = sys.constraint_count();
        Equilibrium {
            energy: ws.current.energy,
            q: state.q,
            multipliers: state.lambda[..m].to_vec(),
            residual,
            stable: inertia == Inertia::Minimum,
            iterations: state.iterations,
            steps: state.steps,
            events: state.events,
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
        Solver::check_start(sys, q0)?;
        let mut state = Iterate::new(q0.to_vec());
        let residual = self.minimize(sys, &mut state, 1.0, "warm start", ws)?;
        Ok(self.finish(sys, state, residual, ws))
    }

    /// Checks a warm start's size and finiteness.
    pub fn check_start<S: StaticSystem + ?Sized>(sys: &S, q: &[f64]) -> Result<(), SolveError> {
        let got = q.iter().filter(|x| x.is_finite()).count();
        if q.len() != sys.dim() || got != q.len() {
            return Err(SolveError::BadStart { expected: sys.dim(), got });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;

    /// The predictor's tangent agrees with a finite difference of converged solutions.
    #[test]
    fn tangent_matches_finite_difference_of_solutions() {
        let robot = Robot::builtin();
        let body = robot.body(0.30, 0.28).unwrap();
        let solver = Solver::default();
        let mut ws = Scratch::for_system(&body);
        let base = body.solve(&solver).unwrap();
        for t in [0.3, 0.7] {
            let mut state = Iterate::new(base.q.clone());
            solver.minimize(&body, &mut state, t, "test", &mut ws).unwrap();
            solver.tangent(&state, &mut ws);
            let tangent = ws.tangent.clone();
            let h = 1e-6;
            let mut ahead = state.clone();
            solver.minimize(&body, &mut ahead, t + h, "test", &mut ws).unwrap();
            for i in 0..tangent.len() {
                let fd = (ahead.q[i] - state.q[i]) / h;
                assert!(
                    (fd - tangent[i]).abs() < 1e-4 * (1.0 + fd.abs()),
                    "t {t} i {i}: fd {fd} tangent {}",
                    tangent[i]
                );
            }
        }
    }
}
