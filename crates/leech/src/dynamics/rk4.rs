//! Classical RK4 on the constrained accelerations.

use super::{Integrator, Motion, Multibody, Simulator, StepError};

/// The stages of one RK4 step, kept between steps.
#[derive(Clone, Debug, Default)]
pub(super) struct Rk4Scratch {
    q0: Vec<f64>,
    v0: Vec<f64>,
    q: Vec<f64>,
    v: Vec<f64>,
    /// Stage velocities (the position slopes).
    kv: [Vec<f64>; 4],
    /// Stage accelerations (the velocity slopes).
    ka: [Vec<f64>; 4],
}

impl Rk4Scratch {
    pub(super) fn new(n: usize) -> Rk4Scratch {
        let stages = || std::array::from_fn(|_| vec![0.0; n]);
        Rk4Scratch { q0: vec![0.0; n], v0: vec![0.0; n], q: vec![0.0; n], v: vec![0.0; n], kv: stages(), ka: stages() }
    }
}

impl<S: Multibody> Simulator<'_, S> {
    pub(super) fn rk4(&mut self, motion: &mut Motion, dt: f64) -> Result<(), StepError> {
        // Borrowed out of the simulator so that the stages can be passed to
        // its methods; put back whatever the outcome.
        let mut sc = std::mem::take(&mut self.rk4);
        let result = self.rk4_with(motion, dt, &mut sc);
        self.rk4 = sc;
        result
    }

    fn rk4_with(&mut self, motion: &mut Motion, dt: f64, sc: &mut Rk4Scratch) -> Result<(), StepError> {
        let n = self.n;
        sc.q0.copy_from_slice(&motion.q);
        sc.v0.copy_from_slice(&motion.v);
        sc.q.copy_from_slice(&motion.q);
        sc.v.copy_from_slice(&motion.v);
        for stage in 0..4 {
            if stage > 0 {
                let c = if stage == 3 { dt } else { 0.5 * dt };
                for i in 0..n {
                    sc.q[i] = sc.q0[i] + c * sc.kv[stage - 1][i];
                    sc.v[i] = sc.v0[i] + c * sc.ka[stage - 1][i];
                }
            }
            sc.kv[stage].copy_from_slice(&sc.v);
            self.accelerations(&sc.q, &sc.v, &mut sc.ka[stage])?;
            // Beyond the stability limit the motion grows until it
            // overflows: stop at the stage where it does, before the next
            // stage evaluates at non-finite angles.
            if !super::all_finite(&sc.ka[stage]) {
                let (what, iterations, residual) = ("acceleration", stage + 1, f64::INFINITY);
                return Err(StepError::NonFinite { integrator: Integrator::Explicit, dt, what, iterations, residual });
            }
        }
        let (kv, ka) = (&sc.kv, &sc.ka);
        for i in 0..n {
            motion.q[i] = sc.q0[i] + dt / 6.0 * (kv[0][i] + 2.0 * kv[1][i] + 2.0 * kv[2][i] + kv[3][i]);
            motion.v[i] = sc.v0[i] + dt / 6.0 * (ka[0][i] + 2.0 * ka[1][i] + 2.0 * ka[2][i] + ka[3][i]);
        }
        Ok(())
    }
}
