//! Classical RK4 on the constrained accelerations.

use super::{Motion, Multibody, Simulator, StepError};

impl<S: Multibody> Simulator<'_, S> {
    pub(super) fn rk4(&mut self, motion: &mut Motion, dt: f64) -> Result<(), StepError> {
        let n = self.n;
        let (q0, v0) = (motion.q.clone(), motion.v.clone());
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
            motion.q[i] = q0[i] + dt / 6.0 * (kv[0][i] + 2.0 * kv[1][i] + 2.0 * kv[2][i] + kv[3][i]);
            motion.v[i] = v0[i] + dt / 6.0 * (ka[0][i] + 2.0 * ka[1][i] + 2.0 * ka[2][i] + ka[3][i]);
        }
        Ok(())
    }
}
