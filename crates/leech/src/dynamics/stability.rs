//! The explicit integrator's stability limit, by power iteration.

use super::{Multibody, Simulator, StepError};

impl<S: Multibody> Simulator<'_, S> {
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
}
