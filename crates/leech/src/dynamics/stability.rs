//! The explicit integrator's stability limit, by power iteration.

use super::{Multibody, Simulator, StepError};

/// Vectors of the power iterations, kept between calls.
#[derive(Clone, Debug, Default)]
pub(super) struct PowerScratch {
    /// The tridiagonal operator's diagonal (n) and off-diagonal (n - 1).
    diag: Vec<f64>,
    off: Vec<f64>,
    /// The iterate and its image.
    x: Vec<f64>,
    y: Vec<f64>,
}

impl PowerScratch {
    pub(super) fn new(n: usize) -> PowerScratch {
        PowerScratch { diag: vec![0.0; n], off: vec![0.0; n.saturating_sub(1)], x: vec![0.0; n], y: vec![0.0; n] }
    }
}

impl<S: Multibody> Simulator<'_, S> {
    /// A step within the stability limit of RK4 (s): `2.5 / omega_max` with
    /// `omega_max^2` the largest eigenvalue of `M^-1 K`, and `2.5 / rho` with
    /// `rho` the largest of `M^-1 D` (stiff dampers on light links make the
    /// fast modes overdamped, which limits an explicit step as much as the
    /// springs do). Both by power iteration at `q`.
    pub fn stable_step(&mut self, q: &[f64]) -> Result<f64, StepError> {
        self.evaluate(q);
        self.factor_mass()?;
        let mut sc = std::mem::take(&mut self.power);
        // The stiffness: the potential's Hessian with its diagonal taken
        // positive, so that a destabilizing gravity term cannot hide a stiff mode.
        for (d, h) in sc.diag.iter_mut().zip(&self.ev.hessian_diag) {
            *d = h.abs();
        }
        sc.off.copy_from_slice(&self.ev.hessian_off);
        let springs = self.largest_eigenvalue(&mut sc);
        self.iteration_matrix(1.0, false, &mut sc.diag, &mut sc.off);
        let dampers = self.largest_eigenvalue(&mut sc);
        self.power = sc;
        Ok((2.5 / springs.sqrt().max(1e-9)).min(2.5 / dampers.max(1e-9)))
    }

    /// Largest eigenvalue of `M^-1 A` (factored `M`), `A` the tridiagonal
    /// matrix in `sc.diag` and `sc.off`.
    fn largest_eigenvalue(&self, sc: &mut PowerScratch) -> f64 {
        let n = self.n;
        for (i, x) in sc.x.iter_mut().enumerate() {
            *x = if i % 2 == 0 { 1.0 } else { -1.0 };
        }
        let mut lambda = 0.0;
        for _ in 0..100 {
            for i in 0..n {
                let mut y = sc.diag[i] * sc.x[i];
                if i > 0 {
                    y += sc.off[i - 1] * sc.x[i - 1];
                }
                if i + 1 < n {
                    y += sc.off[i] * sc.x[i + 1];
                }
                sc.y[i] = y;
            }
            self.solve(&mut sc.y);
            let norm = sc.y.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if norm == 0.0 {
                break;
            }
            lambda = norm;
            sc.x.iter_mut().zip(&sc.y).for_each(|(a, b)| *a = b / norm);
        }
        lambda
    }
}
