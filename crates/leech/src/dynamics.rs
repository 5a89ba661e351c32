//! Constrained forward dynamics of a tube or of the body, and integrators.
//!
//! # Equations
//!
//! With the chains' mass matrix `M(q)` (block diagonal, kg m^2, [`crate::chain`]),
//! velocity terms `h(q, v)`, potential `V(q)` (springs and gravity), dampers
//! `D` (tridiagonal, on relative rates) and the plate constraints `C(q) = 0`
//! with Jacobian `J` (the weld of [`crate::body`]; none for a single tube):
//!
//! ```text
//! M a = Q + J^T lambda,      Q = -grad V - D v - h        (N m)
//! J a = -gamma,              gamma_r = sum_j (d2 C_r / dq_j^2) v_j^2
//! ```
//!
//! (every constraint Hessian is diagonal, so `gamma` is a sum of squares).
//! By Gauss' principle `lambda = -(J M^-1 J^T)^-1 (J M^-1 Q + gamma)`; each
//! chain's block of `M` is factored by Cholesky. Drift is removed after every
//! step by projecting onto the constraint manifold (positions by Newton with
//! the least-norm correction `-J^T (J J^T)^-1 C`, then velocities onto
//! `J v = 0`), so the constraints hold to rounding throughout.
//!
//! # Integrators
//!
//! * [`Integrator::Explicit`]: classical RK4, stable for `dt` below about
//!   `2.8 / omega_max`; [`Simulator::stable_step`] estimates `omega_max` by
//!   power iteration on `M^-1 K`.
//! * [`Integrator::Implicit`]: backward Euler, `M(q1)(v1 - v0) = dt (Q(q1, v1) + J^T lambda)`,
//!   `q1 = q0 + dt v1`, solved by Newton with the iteration matrix
//!   `M + dt D + dt^2 H`, `H` the statics' Lagrangian Hessian (tridiagonal
//!   plus diagonal). Stable at steps far beyond the explicit limit; it damps
//!   the fast modes (first order).
//! * [`Integrator::Midpoint`]: the implicit midpoint rule, solved by
//!   fixed-point iteration on the midpoint velocity. Symmetric: with the
//!   dampers off it keeps the energy to `O(dt^2)` without drift. Needs
//!   `dt omega_max < 1` for the iteration to converge.
//!
//! Energies are in J, times in s.

use crate::body::Body;
use crate::cantilever::Cantilever;
use crate::chain::Chain;
use crate::kkt::{solve_small_symmetric, MAX_CONSTRAINTS};
use crate::statics::{Evaluation, StaticSystem};

/// A system of chains that the simulator can move.
pub trait Multibody: StaticSystem {
    /// The chains with the offset of each one's coordinates in `q`.
    fn chains(&self) -> Vec<(&Chain, usize)>;
}

impl Multibody for Body {
    fn chains(&self) -> Vec<(&Chain, usize)> {
        vec![(self.chain_a(), 0), (self.chain_b(), self.chain_a().len())]
    }
}

impl Multibody for Cantilever {
    fn chains(&self) -> Vec<(&Chain, usize)> {
        vec![(self.chain(), 0)]
    }
}

/// Most links per chain a simulation takes: the mass matrix is dense.
pub const MAX_SIMULATED_LINKS: usize = 500;
/// Most steps one simulation takes.
pub const MAX_STEPS: usize = 10_000_000;

/// Time-stepping scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Integrator {
    /// RK4 with projection.
    Explicit,
    /// Backward Euler with Newton iterations on the statics Hessian.
    Implicit,
    /// Implicit midpoint (fixed-point iterations), energy-conserving.
    Midpoint,
}

/// Position and velocity.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Angles (rad).
    pub q: Vec<f64>,
    /// Angular rates (rad/s).
    pub v: Vec<f64>,
}

/// Why a step failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepError {
    /// The mass matrix lost positive definiteness (it cannot; a NaN got in).
    #[error("mass matrix not positive definite at link {index}")]
    NonPositivePivot {
        /// The failing row.
        index: usize,
    },
    /// The implicit solve did not converge within its iterations.
    #[error("{integrator:?} step of {dt} s did not converge (residual {residual:.3e}); use a smaller --dt")]
    NotConverged {
        /// The scheme.
        integrator: Integrator,
        /// The step tried (s).
        dt: f64,
        /// What was left.
        residual: f64,
    },
    /// The projection onto the constraints did not converge.
    #[error("projection onto the constraints failed (violation {violation:.3e})")]
    Projection {
        /// The remaining violation.
        violation: f64,
    },
    /// An initial state that does not satisfy the constraints.
    #[error("initial state violates the constraints by {violation:.3e} (m or rad); start from a static solution")]
    Inconsistent {
        /// The violation.
        violation: f64,
    },
}

/// The simulator: a system, its scratch space, and the dynamics.
pub struct Simulator<'a, S: Multibody> {
    sys: &'a S,
    chains: Vec<(&'a Chain, usize)>,
    n: usize,
    m: usize,
    ev: Evaluation,
    mass: Vec<Vec<f64>>,
    raw: Vec<Vec<f64>>,
    rhs: Vec<f64>,
    y: Vec<f64>,
    work: Vec<f64>,
    scratch: Scratch,
    /// Fraction of gravity applied (1 unless a scenario ramps it).
    pub load: f64,
}

/// Vectors of one implicit step, kept between steps.
#[derive(Clone, Debug, Default)]
struct Scratch {
    v1: Vec<f64>,
    q1: Vec<f64>,
    f: Vec<f64>,
    g: Vec<f64>,
    dv: Vec<f64>,
    diag: Vec<f64>,
    off: Vec<f64>,
}

impl Scratch {
    fn resize(&mut self, n: usize) {
        for v in [&mut self.v1, &mut self.q1, &mut self.f, &mut self.g, &mut self.dv, &mut self.diag] {
            v.resize(n, 0.0);
        }
        self.off.resize(n.saturating_sub(1), 0.0);
    }
}

impl<'a, S: Multibody> Simulator<'a, S> {
    /// A simulator for `sys`.
    pub fn new(sys: &'a S) -> Simulator<'a, S> {
        let chains = sys.chains();
        let (n, m) = (sys.dim(), sys.rows());
        Simulator {
            sys,
            mass: chains.iter().map(|(c, _)| vec![0.0; c.len() * c.len()]).collect(),
            raw: chains.iter().map(|(c, _)| vec![0.0; c.len() * c.len()]).collect(),
            chains,
            n,
            m,
            ev: Evaluation::new(n, m),
            rhs: vec![0.0; n],
            y: vec![0.0; n * MAX_CONSTRAINTS],
            work: vec![0.0; n],
            scratch: Scratch::default(),
            load: 1.0,
        }
    }

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.n
    }

    fn evaluate(&mut self, q: &[f64]) {
        self.ev.clear();
        self.sys.evaluate(q, self.load, &mut self.ev);
    }

    /// Factors each chain's block of `M(q)` in place (Cholesky, lower
    /// triangle), `q` being the point last evaluated (its trigonometry is reused).
    fn factor_mass(&mut self, q: &[f64]) -> Result<(), StepError> {
        debug_assert_eq!(q.len(), self.n);
        for (b, (chain, offset)) in self.chains.iter().enumerate() {
            let k = chain.len();
            let block = &mut self.mass[b];
            let range = *offset..*offset + k;
            chain.mass_matrix_from_trig(&self.ev.cos[range.clone()], &self.ev.sin[range], block);
            cholesky(block, k).map_err(|i| StepError::NonPositivePivot { index: offset + i })?;
        }
        Ok(())
    }

    /// Solves the factored block-diagonal system in place.
    fn solve_mass(&self, x: &mut [f64]) {
        for (b, (chain, offset)) in self.chains.iter().enumerate() {
            let k = chain.len();
            cholesky_solve(&self.mass[b], k, &mut x[*offset..*offset + k]);
        }
    }

    /// `Y = M^-1 J^T` (interleaved like the Jacobian) and `S = J Y`.
    fn schur(&mut self) -> [[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS] {
        let (n, m) = (self.n, self.m);
        let mut s = [[0.0; MAX_CONSTRAINTS]; MAX_CONSTRAINTS];
        for r in 0..m {
            for i in 0..n {
                self.work[i] = self.ev.jacobian[i * MAX_CONSTRAINTS + r];
            }
            let mut col = std::mem::take(&mut self.work);
            self.solve_mass(&mut col);
            for i in 0..n {
                self.y[i * MAX_CONSTRAINTS + r] = col[i];
            }
            self.work = col;
        }
        for a in 0..m {
            for b in 0..m {
                s[a][b] =
                    (0..n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + a] * self.y[i * MAX_CONSTRAINTS + b]).sum();
            }
        }
        s
    }

    /// Corrects `x` (already `M^-1 f`) by `Y lambda` so that `J x = target`.
    fn enforce(
        &mut self,
        x: &mut [f64],
        target: [f64; MAX_CONSTRAINTS],
        s: &[[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS],
    ) {
        let (n, m) = (self.n, self.m);
        if m == 0 {
            return;
        }
        let mut rhs = [0.0; MAX_CONSTRAINTS];
        for r in 0..m {
            let jx: f64 = (0..n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + r] * x[i]).sum();
            rhs[r] = target[r] - jx;
        }
        let lambda = solve_small_symmetric(s, rhs, m);
        for i in 0..n {
            for r in 0..m {
                x[i] += self.y[i * MAX_CONSTRAINTS + r] * lambda[r];
            }
        }
    }

    /// Generalized forces `Q = -grad V - D v - h` at the last evaluated `q`.
    fn forces(&mut self, v: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = -self.ev.gradient[i];
        }
        for (chain, offset) in &self.chains {
            let k = chain.len();
            let vs = &v[*offset..*offset + k];
            chain.damping_forces(vs, &mut self.work[..k]);
            for i in 0..k {
                out[offset + i] += self.work[i];
            }
            chain.velocity_terms_from_trig(
                &self.ev.cos[*offset..*offset + k],
                &self.ev.sin[*offset..*offset + k],
                vs,
                &mut self.work[..k],
            );
            for i in 0..k {
                out[offset + i] -= self.work[i];
            }
        }
    }

    /// Constrained accelerations `a(q, v)` (rad/s^2) into `a`.
    pub fn accelerations(&mut self, q: &[f64], v: &[f64], a: &mut [f64]) -> Result<(), StepError> {
        self.evaluate(q);
        self.factor_mass(q)?;
        let mut f = std::mem::take(&mut self.rhs);
        self.forces(v, &mut f);
        a.copy_from_slice(&f);
        self.rhs = f;
        self.solve_mass(a);
        let s = self.schur();
        let mut gamma = [0.0; MAX_CONSTRAINTS];
        for r in 0..self.m {
            gamma[r] = -(0..self.n).map(|i| self.ev.curvature[i * MAX_CONSTRAINTS + r] * v[i] * v[i]).sum::<f64>();
        }
        self.enforce(a, gamma, &s);
        Ok(())
    }

    /// Largest constraint violation at `q` (m or rad).
    pub fn violation(&mut self, q: &[f64]) -> f64 {
        self.evaluate(q);
        self.ev.constraints[..self.m].iter().fold(0.0f64, |a, c| a.max(c.abs()))
    }

    /// Projects positions onto `C = 0` and velocities onto `J v = 0` by the
    /// least (Euclidean) change, `dx = -J^T (J J^T)^-1 r`: the corrections
    /// are at the level of the integrator's drift, so the metric does not
    /// matter and this one needs no factorization. Returns the position
    /// violation left (m or rad).
    pub fn project(&mut self, state: &mut State) -> Result<f64, StepError> {
        if self.m == 0 {
            return Ok(0.0);
        }
        let mut violation = f64::INFINITY;
        let mut current = false;
        for _ in 0..20 {
            violation = self.violation(&state.q);
            current = true;
            if violation < 1e-13 {
                break;
            }
            let mut target = [0.0; MAX_CONSTRAINTS];
            target[..self.m].copy_from_slice(&self.ev.constraints);
            self.least_change(&mut state.q, target);
            current = false;
        }
        if violation >= 1e-10 {
            return Err(StepError::Projection { violation });
        }
        // The loop usually ends having just evaluated at the projected point.
        if !current {
            violation = self.violation(&state.q);
        }
        let mut jv = [0.0; MAX_CONSTRAINTS];
        for r in 0..self.m {
            jv[r] = (0..self.n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + r] * state.v[i]).sum::<f64>();
        }
        self.least_change(&mut state.v, jv);
        Ok(violation)
    }

    /// `x -= J^T (J J^T)^-1 r` with the evaluated Jacobian.
    fn least_change(&self, x: &mut [f64], r: [f64; MAX_CONSTRAINTS]) {
        let (n, m) = (self.n, self.m);
        let jac = &self.ev.jacobian;
        let mut jjt = [[0.0; MAX_CONSTRAINTS]; MAX_CONSTRAINTS];
        for a in 0..m {
            for b in 0..m {
                jjt[a][b] = (0..n).map(|i| jac[i * MAX_CONSTRAINTS + a] * jac[i * MAX_CONSTRAINTS + b]).sum();
            }
        }
        let mu = solve_small_symmetric(&jjt, r, m);
        for i in 0..n {
            for a in 0..m {
                x[i] -= jac[i * MAX_CONSTRAINTS + a] * mu[a];
            }
        }
    }

    /// Checks that `state` satisfies the constraints in position and velocity
    /// (to 1e-9 m, rad and rad/s): the initial state of a run must.
    pub fn check(&mut self, state: &State) -> Result<(), StepError> {
        let position = self.violation(&state.q);
        let velocity = (0..self.m)
            .map(|r| (0..self.n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + r] * state.v[i]).sum::<f64>().abs())
            .fold(0.0f64, f64::max);
        let violation = position.max(velocity);
        if !(violation <= 1e-9) || state.q.len() != self.n || state.v.len() != self.n {
            return Err(StepError::Inconsistent { violation });
        }
        Ok(())
    }

    /// Kinetic plus potential energy (J).
    pub fn energy(&mut self, state: &State) -> (f64, f64) {
        self.evaluate(&state.q);
        let potential = self.ev.energy;
        let kinetic = self
            .chains
            .iter()
            .map(|(c, o)| c.kinetic_energy(&state.q[*o..*o + c.len()], &state.v[*o..*o + c.len()]))
            .sum();
        (kinetic, potential)
    }

    /// A step within the stability limit of RK4 (s): `2.5 / omega_max` with
    /// `omega_max^2` the largest eigenvalue of `M^-1 K`, and `2.5 / rho` with
    /// `rho` the largest of `M^-1 D` (stiff dampers on light links make the
    /// fast modes overdamped, which limits an explicit step as much as the
    /// springs do). Both by power iteration at `q`.
    pub fn stable_step(&mut self, q: &[f64]) -> Result<f64, StepError> {
        self.evaluate(q);
        self.factor_mass(q)?;
        let n = self.n;
        let (diag, off) = (self.ev.hessian_diag.clone(), self.ev.hessian_off.clone());
        let (mut ddiag, mut doff) = (vec![0.0; n], vec![0.0; n.saturating_sub(1)]);
        self.iteration_matrix(1.0, false, &mut ddiag, &mut doff);
        let springs = self.largest_eigenvalue(|i, x| {
            let mut y = diag[i].abs() * x[i];
            if i > 0 {
                y += off[i - 1] * x[i - 1];
            }
            if i + 1 < n {
                y += off[i] * x[i + 1];
            }
            y
        });
        let dampers = self.largest_eigenvalue(|i, x| {
            let mut y = ddiag[i] * x[i];
            if i > 0 {
                y += doff[i - 1] * x[i - 1];
            }
            if i + 1 < n {
                y += doff[i] * x[i + 1];
            }
            y
        });
        Ok((2.5 / springs.sqrt().max(1e-9)).min(2.5 / dampers.max(1e-9)))
    }

    /// Largest eigenvalue of `M^-1 A` (factored `M`), `A x` given row by row.
    fn largest_eigenvalue(&self, apply: impl Fn(usize, &[f64]) -> f64) -> f64 {
        let n = self.n;
        let mut x: Vec<f64> = (0..n).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
        let mut lambda = 0.0;
        for _ in 0..100 {
            let mut y: Vec<f64> = (0..n).map(|i| apply(i, &x)).collect();
            self.solve_mass(&mut y);
            let norm = y.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if norm == 0.0 {
                break;
            }
            lambda = norm;
            x.iter_mut().zip(&y).for_each(|(a, b)| *a = b / norm);
        }
        lambda
    }

    /// Whether the body is at rest: every rate below `rate` (rad/s) and every
    /// constrained acceleration below `100 rate` (rad/s^2), so it stays there.
    pub fn at_rest(&mut self, state: &State, rate: f64) -> Result<bool, StepError> {
        if state.v.iter().any(|v| v.abs() > rate) {
            return Ok(false);
        }
        let mut a = vec![0.0; self.n];
        self.accelerations(&state.q, &state.v, &mut a)?;
        Ok(a.iter().all(|x| x.abs() < 100.0 * rate))
    }

    /// Integrates until [`Simulator::at_rest`] (rates below 1e-9 rad/s) or
    /// `max_time` (s), with
    /// gravity raised linearly over the first `ramp` seconds (0: all at once,
    /// as the paper; a slow ramp follows the quasi-static loading path of the
    /// static solver where a sudden load would overshoot into another
    /// equilibrium). Returns the time (s) and steps to rest, or `None`.
    pub fn run_to_rest(
        &mut self,
        state: &mut State,
        dt: f64,
        integrator: Integrator,
        ramp: f64,
        max_time: f64,
    ) -> Result<Option<(f64, usize)>, StepError> {
        let mut t = 0.0;
        let mut steps = 0;
        while t < max_time {
            self.load = if ramp > 0.0 { ((t + dt) / ramp).min(1.0) } else { 1.0 };
            self.step(state, dt, integrator)?;
            t += dt;
            steps += 1;
            if self.load == 1.0 && self.at_rest(state, 1e-9)? {
                return Ok(Some((t, steps)));
            }
        }
        Ok(None)
    }

    /// One step of `dt` (s), projected onto the constraints.
    /// Returns the constraint violation left (m or rad).
    pub fn step(&mut self, state: &mut State, dt: f64, integrator: Integrator) -> Result<f64, StepError> {
        match integrator {
            Integrator::Explicit => self.rk4(state, dt)?,
            Integrator::Implicit => self.backward_euler(state, dt)?,
            Integrator::Midpoint => self.midpoint(state, dt)?,
        }
        self.project(state)
    }

    fn rk4(&mut self, state: &mut State, dt: f64) -> Result<(), StepError> {
        let n = self.n;
        let (q0, v0) = (state.q.clone(), state.v.clone());
        let mut ka = vec![vec![0.0; n]; 4];
        let mut kv = vec![vec![0.0; n]; 4];
        let mut q = q0.clone();
        let mut v = v0.clone();
        for stage in 0..4 {
            if stage > 0 {
                let c = if stage == 3 { dt } else { 0.5 * dt };
                for i in 0..n {
                    q[i] = q0[i] + c * kv[stage - 1][i];
                    v[i] = v0[i] + c * ka[stage - 1][i];
                }
            }
            kv[stage].copy_from_slice(&v);
            self.accelerations(&q, &v, &mut ka[stage])?;
        }
        for i in 0..n {
            state.q[i] = q0[i] + dt / 6.0 * (kv[0][i] + 2.0 * kv[1][i] + 2.0 * kv[2][i] + kv[3][i]);
            state.v[i] = v0[i] + dt / 6.0 * (ka[0][i] + 2.0 * ka[1][i] + 2.0 * ka[2][i] + ka[3][i]);
        }
        Ok(())
    }

    fn midpoint(&mut self, state: &mut State, dt: f64) -> Result<(), StepError> {
        let n = self.n;
        let (q0, v0) = (state.q.clone(), state.v.clone());
        let mut a = vec![0.0; n];
        self.accelerations(&q0, &v0, &mut a)?;
        // Midpoint velocity, first guessed by an explicit half step.
        let mut vm: Vec<f64> = (0..n).map(|i| v0[i] + 0.5 * dt * a[i]).collect();
        let mut residual = f64::INFINITY;
        for _ in 0..50 {
            let qm: Vec<f64> = (0..n).map(|i| q0[i] + 0.5 * dt * vm[i]).collect();
            self.accelerations(&qm, &vm, &mut a)?;
            let next: Vec<f64> = (0..n).map(|i| v0[i] + 0.5 * dt * a[i]).collect();
            let change = next.iter().zip(&vm).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            vm = next;
            let scale = 1.0 + vm.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            // Converged, or stalled at rounding (no longer contracting).
            let done = change < 1e-13 * scale || (change < 1e-10 * scale && change >= 0.5 * residual);
            residual = change;
            if done {
                for i in 0..n {
                    state.q[i] = q0[i] + dt * vm[i];
                    state.v[i] = 2.0 * vm[i] - v0[i];
                }
                return Ok(());
            }
        }
        Err(StepError::NotConverged { integrator: Integrator::Midpoint, dt, residual })
    }

    fn backward_euler(&mut self, state: &mut State, dt: f64) -> Result<(), StepError> {
        // The step's vectors live in the simulator: no allocation per step.
        let mut sc = std::mem::take(&mut self.scratch);
        sc.resize(self.n);
        let result = self.backward_euler_with(state, dt, &mut sc);
        self.scratch = sc;
        result
    }

    fn backward_euler_with(&mut self, state: &mut State, dt: f64, sc: &mut Scratch) -> Result<(), StepError> {
        let n = self.n;
        sc.v1.copy_from_slice(&state.v);
        let mut residual = f64::INFINITY;
        let mut s = [[0.0; MAX_CONSTRAINTS]; MAX_CONSTRAINTS];
        // Simplified Newton: the matrix M + dt D + dt^2 H is factored at the
        // first iterate only and reused; the iterations converge linearly
        // at a rate of order dt, for a fraction of the cost.
        for iteration in 0..40 {
            for i in 0..n {
                sc.q1[i] = state.q[i] + dt * sc.v1[i];
            }
            self.evaluate(&sc.q1);
            // G = M(q1)(v1 - v0) - dt Q(q1, v1).
            self.forces(&sc.v1, &mut sc.f);
            if iteration == 0 {
                self.iteration_matrix(dt, true, &mut sc.diag, &mut sc.off);
            }
            for (b, (chain, offset)) in self.chains.iter().enumerate() {
                let k = chain.len();
                let raw = &mut self.raw[b];
                let range = *offset..*offset + k;
                chain.mass_matrix_from_trig(&self.ev.cos[range.clone()], &self.ev.sin[range.clone()], raw);
                for i in 0..k {
                    let row = &raw[i * k..(i + 1) * k];
                    sc.g[offset + i] = row
                        .iter()
                        .zip(&sc.v1[range.clone()])
                        .zip(&state.v[range.clone()])
                        .map(|((m, a), b)| m * (a - b))
                        .sum::<f64>();
                }
                if iteration == 0 {
                    let block = &mut self.mass[b];
                    block.copy_from_slice(raw);
                    for i in 0..k {
                        block[i * k + i] += sc.diag[offset + i];
                        if i + 1 < k {
                            block[i * k + i + 1] += sc.off[offset + i];
                            block[(i + 1) * k + i] += sc.off[offset + i];
                        }
                    }
                    if cholesky(block, k).is_err() {
                        return Err(StepError::NotConverged { integrator: Integrator::Implicit, dt, residual });
                    }
                }
            }
            if iteration == 0 {
                s = self.schur();
            }
            // Step with the velocity constraint J(q1) v1 = 0.
            for i in 0..n {
                sc.dv[i] = dt * sc.f[i] - sc.g[i];
            }
            self.solve_mass(&mut sc.dv);
            let mut target = [0.0; MAX_CONSTRAINTS];
            for r in 0..self.m {
                target[r] = -(0..n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + r] * sc.v1[i]).sum::<f64>();
            }
            self.enforce(&mut sc.dv, target, &s);
            sc.v1.iter_mut().zip(&sc.dv).for_each(|(v, d)| *v += d);
            let scale = 1.0 + sc.v1.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            residual = sc.dv.iter().fold(0.0f64, |m, x| m.max(x.abs())) / scale;
            if residual < 1e-10 {
                for i in 0..n {
                    state.q[i] += dt * sc.v1[i];
                    state.v[i] = sc.v1[i];
                }
                return Ok(());
            }
        }
        Err(StepError::NotConverged { integrator: Integrator::Implicit, dt, residual })
    }

    /// The tridiagonal part `dt D + dt^2 H` of the backward-Euler matrix
    /// (`dt D` alone without `springs`), with `H` the potential's Hessian at
    /// the evaluated point less its destabilizing gravity curvature (which
    /// only slows Newton where gravity destabilizes), into `diag` (n) and
    /// `off` (n - 1).
    fn iteration_matrix(&self, dt: f64, springs: bool, diag: &mut [f64], off: &mut [f64]) {
        let w = if springs { dt * dt } else { 0.0 };
        for (o, h) in off.iter_mut().zip(&self.ev.hessian_off) {
            *o = w * h;
        }
        for (chain, offset) in &self.chains {
            // The springs' diagonal is kept whole; of the gravity curvature
            // only the stabilizing part, so that the matrix stays positive
            // definite (the tridiagonal spring part is itself semidefinite).
            let k = chain.stiffness();
            for j in 0..chain.len() {
                let spring = k[j] + if j + 1 < chain.len() { k[j + 1] } else { 0.0 };
                let gravity = self.ev.hessian_diag[offset + j] - spring;
                diag[offset + j] = w * (spring + gravity.max(0.0));
            }
            let d = chain.damping();
            for j in 0..chain.len() {
                diag[offset + j] += dt * d[j];
                if j + 1 < chain.len() {
                    diag[offset + j] += dt * d[j + 1];
                    off[offset + j] -= dt * d[j + 1];
                }
            }
        }
    }
}

/// In-place Cholesky `A = L L^T` of a dense `k x k` row-major matrix (lower
/// triangle); the failing row on a non-positive pivot.
fn cholesky(a: &mut [f64], k: usize) -> Result<(), usize> {
    for j in 0..k {
        let mut d = a[j * k + j];
        for p in 0..j {
            d -= a[j * k + p] * a[j * k + p];
        }
        if !(d > 0.0) {
            return Err(j);
        }
        let d = d.sqrt();
        a[j * k + j] = d;
        for i in j + 1..k {
            let mut s = a[i * k + j];
            for p in 0..j {
                s -= a[i * k + p] * a[j * k + p];
            }
            a[i * k + j] = s / d;
        }
    }
    Ok(())
}

fn cholesky_solve(l: &[f64], k: usize, x: &mut [f64]) {
    for i in 0..k {
        let row = &l[i * k..i * k + i];
        let s: f64 = row.iter().zip(&x[..i]).map(|(a, b)| a * b).sum();
        x[i] = (x[i] - s) / l[i * k + i];
    }
    // L^T x = y by rows of L (contiguous), eliminating each solved unknown.
    for p in (0..k).rev() {
        x[p] /= l[p * k + p];
        let xp = x[p];
        for (xi, lpi) in x[..p].iter_mut().zip(&l[p * k..p * k + p]) {
            *xi -= lpi * xp;
        }
    }
}

/// How the tubes move during a simulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Actuation {
    /// Lengths held.
    Hold,
    /// Lengths switched at once to `to` (m) at the start.
    Step {
        /// New lengths LA, LB (m).
        to: [f64; 2],
    },
    /// Both tubes fed towards `to` (m) at `speed` (m/s) each, as the motors do.
    Feed {
        /// Final lengths LA, LB (m).
        to: [f64; 2],
        /// Feeding speed (m/s).
        speed: f64,
    },
}

/// Where a simulation starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// The unloaded (g = 0) equilibrium at rest, gravity then switched on (the paper's method).
    Unloaded,
    /// The static equilibrium with gravity, at rest.
    Static,
}

/// Settings of [`simulate`].
#[derive(Clone, Debug, PartialEq)]
pub struct SimulationOptions {
    /// Time-stepping scheme.
    pub integrator: Integrator,
    /// Time step (s); `None` picks 2 ms for the implicit scheme and
    /// [`Simulator::stable_step`] for the others.
    pub dt: Option<f64>,
    /// Simulated time (s); the longest run when stopping at rest.
    pub duration: f64,
    /// Stop when at rest (after the actuation and the gravity ramp end).
    pub until_rest: bool,
    /// Gravity raised linearly over this time (s); 0 for all at once.
    pub gravity_ramp: f64,
    /// Interval between recorded samples (s).
    pub sample_interval: f64,
    /// At rest when every rate is below this (rad/s), see [`Simulator::at_rest`].
    pub rest_rate: f64,
}

/// A recorded instant.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Sample {
    /// Time (s).
    pub time_s: f64,
    /// Tube lengths (m).
    pub lengths_m: [f64; 2],
    /// Chain A's angles (rad).
    pub angles_a_rad: Vec<f64>,
    /// Chain B's angles (rad).
    pub angles_b_rad: Vec<f64>,
    /// Chain A's centre line (m).
    pub points_a_m: Vec<[f64; 2]>,
    /// Chain B's centre line (m).
    pub points_b_m: Vec<[f64; 2]>,
    /// Endpoint (m).
    pub endpoint_m: [f64; 2],
    /// Kinetic energy (J).
    pub kinetic_j: f64,
    /// Potential energy (J).
    pub potential_j: f64,
    /// Largest constraint violation (m or rad).
    pub violation: f64,
}

/// A finished simulation.
#[derive(Clone, Debug, PartialEq)]
pub struct Simulation {
    /// Recorded samples, first at t = 0, last at the end.
    pub samples: Vec<Sample>,
    /// Time when the body came to rest (s), if it did.
    pub time_to_rest: Option<f64>,
    /// Steps taken.
    pub steps: usize,
    /// The step used (s).
    pub dt: f64,
    /// Largest constraint violation over the run (m or rad).
    pub max_violation: f64,
}

/// Why a simulation failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SimulationError {
    /// Bad settings or lengths.
    #[error(transparent)]
    Input(#[from] crate::error::InputError),
    /// The starting equilibrium could not be solved.
    #[error("starting shape: {0}")]
    Start(#[from] crate::statics::SolveError),
    /// A step failed.
    #[error("at t = {time:.4} s: {source}")]
    Step {
        /// When (s).
        time: f64,
        /// What failed.
        source: StepError,
    },
}

fn sample(sim: &mut Simulator<'_, Body>, body: &Body, state: &State, time: f64) -> Sample {
    let (qa, qb) = body.split(&state.q);
    let (kinetic, potential) = sim.energy(state);
    Sample {
        time_s: time,
        lengths_m: [body.chain_a().tube_length(), body.chain_b().tube_length()],
        angles_a_rad: qa.to_vec(),
        angles_b_rad: qb.to_vec(),
        points_a_m: body.chain_a().points(qa),
        points_b_m: body.chain_b().points(qb),
        endpoint_m: body.endpoint(&state.q),
        kinetic_j: kinetic,
        potential_j: potential,
        violation: sim.violation(&state.q),
    }
}

/// Simulates the body of `robot` starting at tube lengths `lengths` (m).
/// `progress` receives the simulated time (s) now and then.
pub fn simulate(
    robot: &crate::robot::Robot,
    lengths: [f64; 2],
    start: Start,
    actuation: Actuation,
    options: &SimulationOptions,
    progress: &dyn Fn(f64),
) -> Result<Simulation, SimulationError> {
    use crate::error::positive;
    use crate::statics::Solver;
    positive("duration (s)", options.duration)?;
    positive("sample interval (s)", options.sample_interval)?;
    positive("rest rate (rad/s)", options.rest_rate)?;
    crate::error::non_negative("gravity ramp (s)", options.gravity_ramp)?;
    let target = match actuation {
        Actuation::Hold => lengths,
        Actuation::Step { to } | Actuation::Feed { to, .. } => {
            robot.body(to[0], to[1])?;
            to
        }
    };
    if let Actuation::Feed { speed, .. } = actuation {
        positive("speed (m/s)", speed)?;
    }
    let mut body = robot.body(lengths[0], lengths[1])?;
    let largest = body.chain_a().len().max(body.chain_b().len()).max(match actuation {
        Actuation::Hold => 0,
        Actuation::Step { to } | Actuation::Feed { to, .. } => {
            let d = robot.model.discretization;
            d.link_count(to[0], robot.tube.element_length_m).max(d.link_count(to[1], robot.tube.element_length_m))
        }
    });
    if largest > MAX_SIMULATED_LINKS {
        return Err(crate::error::InputError::invalid(
            "links per chain",
            largest as f64,
            format!("at most {MAX_SIMULATED_LINKS} for dynamics (dense mass matrices)"),
        )
        .into());
    }
    let q0 = match start {
        Start::Unloaded => {
            let mut unloaded = robot.clone();
            unloaded.world.gravity_m_per_s2 = 0.0;
            unloaded.body(lengths[0], lengths[1])?.solve(&Solver::default())?.q
        }
        Start::Static => body.solve(&Solver::default())?.q,
    };
    let mut state = State { v: vec![0.0; q0.len()], q: q0 };
    let dt = match (options.dt, options.integrator) {
        (Some(dt), _) => positive("dt (s)", dt)?,
        (None, Integrator::Implicit) => 2e-3,
        (None, integrator) => {
            let limit = Simulator::new(&body)
                .stable_step(&state.q)
                .map_err(|source| SimulationError::Step { time: 0.0, source })?;
            // The midpoint's fixed-point iteration needs dt omega < 1, RK4 dt omega < 2.8.
            if integrator == Integrator::Midpoint {
                0.3 * limit
            } else {
                limit
            }
        }
    };
    let steps_needed = options.duration / dt;
    if steps_needed > MAX_STEPS as f64 {
        return Err(crate::error::InputError::invalid(
            "duration / dt",
            steps_needed,
            format!("at most {MAX_STEPS} steps (a shorter duration or a larger dt)"),
        )
        .into());
    }
    if let Actuation::Step { to } = actuation {
        let next = robot.body(to[0], to[1])?;
        state = State { q: next.carry_over(&body, &state.q), v: next.carry_over(&body, &state.v) };
        body = next;
        Simulator::new(&body).project(&mut state).map_err(|source| SimulationError::Step { time: 0.0, source })?;
    }
    let ramp_load = |t: f64| if options.gravity_ramp > 0.0 { (t / options.gravity_ramp).min(1.0) } else { 1.0 };
    let mut sim = Simulator::new(&body);
    sim.check(&state).map_err(|source| SimulationError::Step { time: 0.0, source })?;
    sim.load = ramp_load(0.0);
    let mut samples = vec![sample(&mut sim, &body, &state, 0.0)];
    let mut max_violation = samples[0].violation;
    let (mut t, mut steps, mut next_sample) = (0.0, 0usize, options.sample_interval);
    let mut current = [body.chain_a().tube_length(), body.chain_b().tube_length()];
    let mut time_to_rest = None;
    let max_steps = (options.duration / dt).ceil() as usize;
    while steps < max_steps {
        let fail = |time: f64| move |source| SimulationError::Step { time, source };
        if let Actuation::Feed { speed, .. } = actuation {
            let mut next = current;
            for k in 0..2 {
                let d = target[k] - current[k];
                next[k] = current[k] + d.signum() * d.abs().min(speed * dt);
            }
            if next != current {
                let fed = robot.body(next[0], next[1])?;
                state = State { q: fed.carry_over(&body, &state.q), v: fed.carry_over(&body, &state.v) };
                body = fed;
                current = next;
                sim = Simulator::new(&body);
            }
        }
        sim.load = ramp_load(t + dt);
        let violation = sim.step(&mut state, dt, options.integrator).map_err(fail(t))?;
        t += dt;
        steps += 1;
        max_violation = max_violation.max(violation);
        let settled_inputs = current == target && sim.load == 1.0;
        let at_rest =
            options.until_rest && settled_inputs && sim.at_rest(&state, options.rest_rate).map_err(fail(t))?;
        if t + 1e-12 >= next_sample || at_rest || steps == max_steps {
            samples.push(sample(&mut sim, &body, &state, t));
            next_sample += options.sample_interval;
            progress(t);
        }
        if at_rest {
            time_to_rest = Some(t);
            break;
        }
    }
    Ok(Simulation { samples, time_to_rest, steps, dt, max_violation })
}
