//! The implicit midpoint rule by fixed-point iteration.

use super::{Integrator, Motion, Multibody, Simulator, StepError};

impl<S: Multibody> Simulator<'_, S> {
    pub(super) fn midpoint(&mut self, motion: &mut Motion, dt: f64) -> Result<(), StepError> {
        let n = self.n;
        let (q0, v0) = (motion.q.clone(), motion.v.clone());
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
                    motion.q[i] = q0[i] + dt * vm[i];
                    motion.v[i] = 2.0 * vm[i] - v0[i];
                }
                return Ok(());
            }
        }
        Err(StepError::NotConverged { integrator: Integrator::Midpoint, dt, residual })
    }
}
