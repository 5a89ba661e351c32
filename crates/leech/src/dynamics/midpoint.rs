//! The implicit midpoint rule by fixed-point iteration.

use super::{Integrator, Motion, Multibody, Simulator, StepError};

/// Vectors of one midpoint step, kept between steps.
#[derive(Clone, Debug, Default)]
pub(super) struct MidpointScratch {
    q0: Vec<f64>,
    v0: Vec<f64>,
    a: Vec<f64>,
    /// The midpoint velocity iterate.
    vm: Vec<f64>,
    /// The midpoint position.
    qm: Vec<f64>,
}

impl MidpointScratch {
    pub(super) fn new(n: usize) -> MidpointScratch {
        MidpointScratch { q0: vec![0.0; n], v0: vec![0.0; n], a: vec![0.0; n], vm: vec![0.0; n], qm: vec![0.0; n] }
    }
}

/// Most fixed-point iterations of one step.
const MAX_ITERATIONS: usize = 50;

impl<S: Multibody> Simulator<'_, S> {
    pub(super) fn midpoint(&mut self, motion: &mut Motion, dt: f64) -> Result<(), StepError> {
        let mut sc = std::mem::take(&mut self.midpoint);
        let result = self.midpoint_with(motion, dt, &mut sc);
        self.midpoint = sc;
        result
    }

    fn midpoint_with(&mut self, motion: &mut Motion, dt: f64, sc: &mut MidpointScratch) -> Result<(), StepError> {
        let n = self.n;
        sc.q0.copy_from_slice(&motion.q);
        sc.v0.copy_from_slice(&motion.v);
        self.accelerations(&sc.q0, &sc.v0, &mut sc.a)?;
        // Midpoint velocity, first guessed by an explicit half step.
        for i in 0..n {
            sc.vm[i] = sc.v0[i] + 0.5 * dt * sc.a[i];
        }
        let mut residual = f64::INFINITY;
        for iteration in 0..MAX_ITERATIONS {
            // A diverging iteration overflows in the velocity first (the
            // guess counts as iteration 0): stop it before the evaluation
            // meets non-finite angles.
            if !super::all_finite(&sc.vm) {
                let what = "midpoint velocity";
                return Err(StepError::NonFinite {
                    integrator: Integrator::Midpoint,
                    dt,
                    what,
                    iterations: iteration,
                    residual,
                });
            }
            for i in 0..n {
                sc.qm[i] = sc.q0[i] + 0.5 * dt * sc.vm[i];
            }
            self.accelerations(&sc.qm, &sc.vm, &mut sc.a)?;
            let mut change = 0.0f64;
            let mut largest = 0.0f64;
            for i in 0..n {
                let next = sc.v0[i] + 0.5 * dt * sc.a[i];
                change = change.max((next - sc.vm[i]).abs());
                largest = largest.max(next.abs());
                sc.vm[i] = next;
            }
            let scale = 1.0 + largest;
            // Converged, or stalled at rounding (no longer contracting, nor
            // growing: a diverging iteration is small relative to its own
            // growing iterates, and must run on to its overflow or limit).
            let stalled = change >= 0.5 * residual && change <= 2.0 * residual;
            // `f64::max` drops a NaN from `change`: the next iteration's
            // check stops it, with the last finite residual.
            let finite = super::all_finite(&sc.vm);
            let done = finite && (change < 1e-13 * scale || (change < 1e-10 * scale && stalled));
            if finite {
                residual = change;
            }
            if done {
                for i in 0..n {
                    motion.q[i] = sc.q0[i] + dt * sc.vm[i];
                    motion.v[i] = 2.0 * sc.vm[i] - sc.v0[i];
                }
                return Ok(());
            }
        }
        Err(StepError::NotConverged { integrator: Integrator::Midpoint, dt, iterations: MAX_ITERATIONS, residual })
    }
}
