//! Backward Euler by simplified Newton iterations.

use super::mass::cholesky;
use super::{Integrator, Motion, Multibody, Simulator, StepError};
use crate::kkt::MAX_CONSTRAINTS;

/// Vectors of one implicit step, kept between steps.
#[derive(Clone, Debug, Default)]
pub(super) struct Scratch {
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

impl<S: Multibody> Simulator<'_, S> {
    pub(super) fn backward_euler(&mut self, motion: &mut Motion, dt: f64) -> Result<(), StepError> {
        // The step's vectors live in the simulator: no allocation per step.
        let mut sc = std::mem::take(&mut self.scratch);
        sc.resize(self.n);
        let result = self.backward_euler_with(motion, dt, &mut sc);
        self.scratch = sc;
        result
    }

    fn backward_euler_with(&mut self, motion: &mut Motion, dt: f64, sc: &mut Scratch) -> Result<(), StepError> {
        let n = self.n;
        sc.v1.copy_from_slice(&motion.v);
        let mut residual = f64::INFINITY;
        let mut s = [[0.0; MAX_CONSTRAINTS]; MAX_CONSTRAINTS];
        // Simplified Newton: the matrix M + dt D + dt^2 H is factored at the
        // first iterate only and reused; the iterations converge linearly
        // at a rate of order dt, for a fraction of the cost.
        for iteration in 0..40 {
            for i in 0..n {
                sc.q1[i] = motion.q[i] + dt * sc.v1[i];
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
                        .zip(&motion.v[range.clone()])
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
                    motion.q[i] += dt * sc.v1[i];
                    motion.v[i] = sc.v1[i];
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
