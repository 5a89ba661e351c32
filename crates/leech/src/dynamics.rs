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
//! the `M`-weighted least-norm correction, then velocities onto `J v = 0`), so
//! the constraints hold to rounding throughout.
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
use crate::kkt::MAX_CONSTRAINTS;
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
    rhs: Vec<f64>,
    y: Vec<f64>,
    work: Vec<f64>,
    /// Fraction of gravity applied (1 unless a scenario ramps it).
    pub load: f64,
}

impl<'a, S: Multibody> Simulator<'a, S> {
    /// A simulator for `sys`.
    pub fn new(sys: &'a S) -> Simulator<'a, S> {
        let chains = sys.chains();
        let (n, m) = (sys.dim(), sys.constraint_count());
        Simulator {
            sys,
            mass: chains.iter().map(|(c, _)| vec![0.0; c.len() * c.len()]).collect(),
            chains,
            n,
            m,
            ev: Evaluation::new(n, m),
            rhs: vec![0.0; n],
            y: vec![0.0; n * MAX_CONSTRAINTS],
            work: vec![0.0; n],
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

    /// Factors each chain's block of `M(q) + shift_v D + shift_q H_blocks`
    /// in place (Cholesky, lower triangle). `extra` adds a tridiagonal part
    /// given by `(diag, off)` scaled by `scale`.
    fn factor_mass(&mut self, q: &[f64], extra: Option<(&[f64], &[f64], f64)>) -> Result<(), StepError> {
        for (b, (chain, offset)) in self.chains.iter().enumerate() {
            let k = chain.len();
            let block = &mut self.mass[b];
            chain.mass_matrix(&q[*offset..*offset + k], block);
            if let Some((diag, off, scale)) = extra {
                for i in 0..k {
                    block[i * k + i] += scale * diag[offset + i];
                    if i + 1 < k {
                        block[i * k + i + 1] += scale * off[offset + i];
                        block[(i + 1) * k + i] += scale * off[offset + i];
                    }
                }
            }
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
                s[a][b] = (0..n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + a] * self.y[i * MAX_CONSTRAINTS + b]).sum();
            }
        }
        s
    }

    /// Corrects `x` (already `M^-1 f`) by `Y lambda` so that `J x = target`.
    fn enforce(&mut self, x: &mut [f64], target: [f64; MAX_CONSTRAINTS], s: &[[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS]) {
        let (n, m) = (self.n, self.m);
        if m == 0 {
            return;
        }
        let mut rhs = [0.0; MAX_CONSTRAINTS];
        for r in 0..m {
            let jx: f64 = (0..n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + r] * x[i]).sum();
            rhs[r] = target[r] - jx;
        }
        let lambda = solve_small(s, rhs, m);
        for i in 0..n {
            for r in 0..m {
                x[i] += self.y[i * MAX_CONSTRAINTS + r] * lambda[r];
            }
        }
    }

    /// Generalized forces `Q = -grad V - D v - h` at the evaluated `q`.
    fn forces(&mut self, q: &[f64], v: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = -self.ev.gradient[i];
        }
        for (chain, offset) in &self.chains {
            let k = chain.len();
            let (qs, vs) = (&q[*offset..*offset + k], &v[*offset..*offset + k]);
            chain.damping_forces(vs, &mut self.work[..k]);
            for i in 0..k {
                out[offset + i] += self.work[i];
            }
            chain.velocity_terms(qs, vs, &mut self.work[..k]);
            for i in 0..k {
                out[offset + i] -= self.work[i];
            }
        }
    }

    /// Constrained accelerations `a(q, v)` (rad/s^2) into `a`.
    pub fn accelerations(&mut self, q: &[f64], v: &[f64], a: &mut [f64]) -> Result<(), StepError> {
        self.evaluate(q);
        self.factor_mass(q, None)?;
        let mut f = std::mem::take(&mut self.rhs);
        self.forces(q, v, &mut f);
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

    /// Projects positions onto `C = 0` (M-weighted least change) and
    /// velocities onto `J v = 0`.
    pub fn project(&mut self, state: &mut State) -> Result<(), StepError> {
        if self.m == 0 {
            return Ok(());
        }
        let mut violation = f64::INFINITY;
        for _ in 0..20 {
            violation = self.violation(&state.q);
            if violation < 1e-13 {
                break;
            }
            self.factor_mass(&state.q, None)?;
            let s = self.schur();
            let mut dq = vec![0.0; self.n];
            let mut target = [0.0; MAX_CONSTRAINTS];
            for r in 0..self.m {
                target[r] = -self.ev.constraints[r];
            }
            self.enforce(&mut dq, target, &s);
            state.q.iter_mut().zip(&dq).for_each(|(q, d)| *q += d);
        }
        if violation >= 1e-10 {
            return Err(StepError::Projection { violation });
        }
        self.evaluate(&state.q);
        self.factor_mass(&state.q, None)?;
        let s = self.schur();
        let mut dv = vec![0.0; self.n];
        let mut target = [0.0; MAX_CONSTRAINTS];
        for r in 0..self.m {
            target[r] = -(0..self.n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + r] * state.v[i]).sum::<f64>();
        }
        self.enforce(&mut dv, target, &s);
        state.v.iter_mut().zip(&dv).for_each(|(v, d)| *v += d);
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
        self.factor_mass(q, None)?;
        let n = self.n;
        let (diag, off) = (self.ev.hessian_diag.clone(), self.ev.hessian_off.clone());
        let (ddiag, doff) = self.iteration_matrix(1.0, false);
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

    /// Whether the body is at rest: every rate below `1e-9` rad/s and every
    /// constrained acceleration below `1e-7` rad/s^2 (so it stays there).
    pub fn at_rest(&mut self, state: &State) -> Result<bool, StepError> {
        if state.v.iter().any(|v| v.abs() > 1e-9) {
            return Ok(false);
        }
        let mut a = vec![0.0; self.n];
        self.accelerations(&state.q, &state.v, &mut a)?;
        Ok(a.iter().all(|x| x.abs() < 1e-7))
    }

    /// Integrates until [`Simulator::at_rest`] or `max_time` (s), with
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
            if self.load == 1.0 && self.at_rest(state)? {
                return Ok(Some((t, steps)));
            }
        }
        Ok(None)
    }

    /// One step of `dt` (s), projected onto the constraints.
    pub fn step(&mut self, state: &mut State, dt: f64, integrator: Integrator) -> Result<(), StepError> {
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
        let n = self.n;
        let (q0, v0) = (state.q.clone(), state.v.clone());
        let mut v1 = v0.clone();
        let mut residual = f64::INFINITY;
        for _ in 0..30 {
            let q1: Vec<f64> = (0..n).map(|i| q0[i] + dt * v1[i]).collect();
            self.evaluate(&q1);
            // G = M(q1)(v1 - v0) - dt Q(q1, v1); Newton matrix M + dt D + dt^2 H.
            let mut f = vec![0.0; n];
            self.forces(&q1, &v1, &mut f);
            let mut g = vec![0.0; n];
            for (b, (chain, offset)) in self.chains.iter().enumerate() {
                let k = chain.len();
                let block = &mut self.mass[b];
                chain.mass_matrix(&q1[*offset..*offset + k], block);
                for i in 0..k {
                    g[offset + i] = (0..k).map(|j| block[i * k + j] * (v1[offset + j] - v0[offset + j])).sum::<f64>();
                }
            }
            for i in 0..n {
                g[i] -= dt * f[i];
            }
            let (diag, off) = self.iteration_matrix(dt, true);
            self.factor_mass(&q1, Some((&diag, &off, 1.0)))?;
            // Newton step with the velocity constraint J(q1) v1 = 0.
            let mut dv: Vec<f64> = g.iter().map(|x| -x).collect();
            self.solve_mass(&mut dv);
            let s = self.schur();
            let mut target = [0.0; MAX_CONSTRAINTS];
            for r in 0..self.m {
                target[r] = -(0..n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + r] * v1[i]).sum::<f64>();
            }
            self.enforce(&mut dv, target, &s);
            v1.iter_mut().zip(&dv).for_each(|(v, d)| *v += d);
            let scale = 1.0 + v1.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            residual = dv.iter().fold(0.0f64, |m, x| m.max(x.abs())) / scale;
            if residual < 1e-11 {
                for i in 0..n {
                    state.q[i] = q0[i] + dt * v1[i];
                    state.v[i] = v1[i];
                }
                return Ok(());
            }
        }
        Err(StepError::NotConverged { integrator: Integrator::Implicit, dt, residual })
    }

    /// The tridiagonal part `dt D + dt^2 H` of the backward-Euler matrix
    /// (`dt D` alone without `springs`),
    /// with `H` the potential's Hessian at the evaluated point (its negative
    /// gravity curvature dropped, which keeps the matrix positive definite
    /// and only slows Newton where gravity destabilizes).
    fn iteration_matrix(&self, dt: f64, springs: bool) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        let w = if springs { dt * dt } else { 0.0 };
        let mut diag: Vec<f64> = self.ev.hessian_diag.iter().map(|h| w * h.max(0.0)).collect();
        let mut off: Vec<f64> = self.ev.hessian_off.iter().map(|h| w * h).collect();
        for (chain, offset) in &self.chains {
            let d = chain.damping();
            for j in 0..chain.len() {
                diag[offset + j] += dt * d[j];
                if j + 1 < chain.len() {
                    diag[offset + j] += dt * d[j + 1];
                    off[offset + j] -= dt * d[j + 1];
                }
            }
        }
        debug_assert_eq!(diag.len(), n);
        (diag, off)
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
        let mut s = x[i];
        for p in 0..i {
            s -= l[i * k + p] * x[p];
        }
        x[i] = s / l[i * k + i];
    }
    for i in (0..k).rev() {
        let mut s = x[i];
        for p in i + 1..k {
            s -= l[p * k + i] * x[p];
        }
        x[i] = s / l[i * k + i];
    }
}

/// Solves the small symmetric system `S x = b` (Gaussian elimination with pivoting).
fn solve_small(s: &[[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS], b: [f64; MAX_CONSTRAINTS], m: usize) -> [f64; MAX_CONSTRAINTS] {
    let mut a = *s;
    let mut x = b;
    for c in 0..m {
        let p = (c..m).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs())).unwrap_or(c);
        a.swap(c, p);
        x.swap(c, p);
        if a[c][c] == 0.0 {
            continue;
        }
        for r in c + 1..m {
            let f = a[r][c] / a[c][c];
            for k in c..m {
                a[r][k] -= f * a[c][k];
            }
            x[r] -= f * x[c];
        }
    }
    for c in (0..m).rev() {
        let mut v = x[c];
        for k in c + 1..m {
            v -= a[c][k] * x[k];
        }
        x[c] = if a[c][c] != 0.0 { v / a[c][c] } else { 0.0 };
    }
    x
}
