//! Backward Euler by simplified Newton iterations.

use super::{Integrator, Motion, Multibody, Simulator, StepError};

/// Vectors of one implicit step, kept between steps.
#[derive(Clone, Debug, Default)]
pub(super) struct EulerScratch {
    v1: Vec<f64>,
    q1: Vec<f64>,
    /// The forces `Q(q1, v1)`.
    f: Vec<f64>,
    /// `M(q1) (v1 - v0)`.
    g: Vec<f64>,
    /// The Newton correction of `v1`.
    dv: Vec<f64>,
    /// The tridiagonal `dt D + dt^2 H`: diagonal (n) and off-diagonal (n - 1).
    diag: Vec<f64>,
    off: Vec<f64>,
}

impl EulerScratch {
    pub(super) fn new(n: usize) -> EulerScratch {
        let zeros = || vec![0.0; n];
        EulerScratch {
            v1: zeros(),
            q1: zeros(),
            f: zeros(),
            g: zeros(),
            dv: zeros(),
            diag: zeros(),
            off: vec![0.0; n.saturating_sub(1)],
        }
    }
}

/// Most simplified-Newton iterations of one step.
const MAX_ITERATIONS: usize = 40;

/// Relative size of the velocity error at which a step is converged.
const TOLERANCE: f64 = 1e-10;

/// The stopping rule of Hairer and Wanner (Solving ODEs II, IV.8): with the
/// observed contraction `theta = |dv_k| / |dv_(k-1)|` the error left after
/// the correction `dv_k` is about `theta / (1 - theta) |dv_k|`, which saves
/// the iteration that would only confirm convergence.
struct Convergence {
    previous: f64,
}

impl Convergence {
    fn new() -> Convergence {
        Convergence { previous: f64::NAN }
    }

    /// Whether the iteration has converged after a correction of relative
    /// size `residual`. A correction below the tolerance has converged
    /// whatever the rate (at the rounding floor `theta` is noise and may
    /// exceed 1); above it, the estimate counts only while the iteration
    /// contracts (`theta < 1`): a simplified Newton iteration may grow for a
    /// step or two before it contracts, so growth alone is no failure (the
    /// iteration count bounds it).
    fn converged(&mut self, residual: f64) -> bool {
        let theta = residual / self.previous;
        self.previous = residual;
        residual < TOLERANCE || (theta < 1.0 && theta / (1.0 - theta) * residual < TOLERANCE)
    }
}

impl<S: Multibody> Simulator<'_, S> {
    pub(super) fn backward_euler(&mut self, motion: &mut Motion, dt: f64) -> Result<(), StepError> {
        let mut sc = std::mem::take(&mut self.euler);
        let result = self.backward_euler_with(motion, dt, &mut sc);
        self.euler = sc;
        result
    }

    fn backward_euler_with(&mut self, motion: &mut Motion, dt: f64, sc: &mut EulerScratch) -> Result<(), StepError> {
        let n = self.n;
        sc.v1.copy_from_slice(&motion.v);
        let mut residual = f64::INFINITY;
        let mut stop = Convergence::new();
        // Simplified Newton: the matrix M + dt D + dt^2 H is factored at the
        // first iterate only and reused; the iterations converge linearly
        // at a rate of order dt, for a fraction of the cost.
        for iteration in 0..MAX_ITERATIONS {
            for i in 0..n {
                sc.q1[i] = motion.q[i] + dt * sc.v1[i];
            }
            self.evaluate(&sc.q1);
            // G = M(q1)(v1 - v0) - dt Q(q1, v1); the first iterate is v1 = v0.
            self.forces(&sc.v1, &mut sc.f);
            if iteration > 0 {
                for i in 0..n {
                    sc.dv[i] = sc.v1[i] - motion.v[i];
                }
                self.mass_product(&sc.dv, &mut sc.g);
            } else {
                sc.g.fill(0.0);
                self.iteration_matrix(dt, true, &mut sc.diag, &mut sc.off);
                let (cos, sin) = (&self.ev.cos, &self.ev.sin);
                if self.factors.factor_iteration(&self.chains, cos, sin, &sc.diag, &sc.off).is_err() {
                    let iterations = 0;
                    return Err(StepError::NotConverged { integrator: Integrator::Implicit, dt, iterations, residual });
                }
                self.schur();
            }
            // Step with the velocity constraint J(q1) v1 = 0.
            for i in 0..n {
                sc.dv[i] = dt * sc.f[i] - sc.g[i];
            }
            self.solve(&mut sc.dv);
            self.target_opposite_of(&sc.v1);
            self.enforce(&mut sc.dv);
            sc.v1.iter_mut().zip(&sc.dv).for_each(|(v, d)| *v += d);
            let scale = 1.0 + sc.v1.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let next = sc.dv.iter().fold(0.0f64, |m, x| m.max(x.abs())) / scale;
            // `fold` with `max` drops NaN: check the vectors themselves,
            // before the next evaluation meets non-finite angles.
            if !(next.is_finite() && super::all_finite(&sc.v1)) {
                let what = "velocity correction";
                let iterations = iteration + 1;
                return Err(StepError::NonFinite { integrator: Integrator::Implicit, dt, what, iterations, residual });
            }
            residual = next;
            if stop.converged(residual) {
                // q1 from the corrected v1, not the point last evaluated:
                // dt times the last correction there, in the stiff
                // springs, would move the next steps beyond the tolerance.
                for i in 0..n {
                    motion.q[i] += dt * sc.v1[i];
                    motion.v[i] = sc.v1[i];
                    sc.dv[i] = motion.q[i] - sc.q1[i];
                }
                self.least_change_from(&mut motion.q, &sc.dv);
                return Ok(());
            }
        }
        Err(StepError::NotConverged { integrator: Integrator::Implicit, dt, iterations: MAX_ITERATIONS, residual })
    }

    /// The tridiagonal part `dt D + dt^2 H` of the backward-Euler matrix
    /// (`dt D` alone without `springs`), with `H` the potential's Hessian at
    /// the evaluated point less its destabilizing gravity curvature (which
    /// only slows Newton where gravity destabilizes), into `diag` (n) and
    /// `off` (n - 1).
    pub(super) fn iteration_matrix(&self, dt: f64, springs: bool, diag: &mut [f64], off: &mut [f64]) {
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
