//! Bounded Levenberg-Marquardt for small nonlinear least-squares problems:
//! a few unknowns (at most [`MAX_UNKNOWNS`]), any number of residual rows.
//!
//! The caller supplies the residual `r(x)` and its Jacobian `J = dr/dx`
//! through [`LeastSquares`]; either may fail (a static solve that does not
//! converge), which is a rejected trial step or, for the Jacobian, the end of
//! the run. [`levenberg_marquardt`] then minimizes
//!
//! ```text
//! cost        F(x) = |r(x)|^2 / 2                       (units of r, squared)
//! gradient    g = J^T r                                 (units of F per unit of x)
//! held set    unknown i sits on a bound and -g_i points out of the box
//! step        (J^T J + mu D) dx = -g  over the free unknowns; dx_i = 0 if held
//!             D = diag(J^T J)                 Scaling::Marquardt
//!             D = max_i (J^T J)_ii  I         Scaling::Uniform
//! projection  x' = P(x + dx),  P(y)_i = min(max(y_i, lo_i), hi_i),  h = x' - x
//! gain ratio  rho = (F(x) - F(x')) / (L(0) - L(h)),
//!             L(0) - L(h) = -g.h - h^T (J^T J) h / 2   (the decrease the linear model predicts)
//! accept      F(x') < F(x) and rho >= rho_min:  x <- x',  mu <- max(mu * down, mu_min)
//! reject      otherwise, or r(x') failed:               mu <- min(mu * up, mu_max), retry from x
//! ```
//!
//! The held set is renewed with each Jacobian. A run stops when the cost is
//! at most its tolerance (checked before each Jacobian, so a solved start
//! costs nothing), when an accepted step lowered the cost by a small fraction
//! or moved no unknown much, when no free unknown has gradient left, after
//! the iteration budget, after `max_trials` rejections in a row, or when the
//! start or a Jacobian cannot be evaluated ([`Stop`]).
//!
//! `x`, `h`, the bounds and the step tolerance are in the caller's units, `r`
//! in its own; the damping `mu`, its factors and `rho` are dimensionless,
//! because `D` carries the curvature's units. Holding the unknowns that press
//! on their bounds before solving, rather than only projecting the full step,
//! lets the free ones take their own Gauss-Newton step along the boundary
//! instead of one bent by the blocked direction.
//!
//! The normal equations are solved by an `L D L^T` factorization on
//! fixed-size arrays: with `p <= 8` a dense solve costs less than any
//! residual evaluation, and nothing is allocated inside the loop.

use std::ops::Index;

/// Largest number of unknowns [`levenberg_marquardt`] accepts.
pub const MAX_UNKNOWNS: usize = 8;

/// Bounds `[lower, upper]` of an unknown without any.
pub const UNBOUNDED: [f64; 2] = [f64::NEG_INFINITY, f64::INFINITY];

/// Storage of the small square matrices.
type Square = [[f64; MAX_UNKNOWNS]; MAX_UNKNOWNS];

/// A least-squares problem: residuals and their Jacobian at trial points.
///
/// The problem may be stateful: the minimizer evaluates trials with
/// [`residual`](Self::residual) and, when one is kept, calls
/// [`accept`](Self::accept) before anything else, so a problem that warm-starts
/// each evaluation from the current point can move its state there.
pub trait LeastSquares {
    /// Why an evaluation failed.
    type Error;

    /// Number of residual rows (fixed for the whole run).
    fn rows(&self) -> usize;

    /// The residual at the starting point. By default a plain evaluation;
    /// override it when the caller already has the residual there.
    fn start(&mut self, x: &[f64], r: &mut [f64]) -> Result<(), Self::Error> {
        self.residual(x, r)
    }

    /// The residual at a trial point `x` (within the bounds), into `r`.
    fn residual(&mut self, x: &[f64], r: &mut [f64]) -> Result<(), Self::Error>;

    /// The Jacobian at the current point `x` (residual `r`), column-major into
    /// `jac`: `jac[k * rows + i] = dr_i / dx_k`.
    fn jacobian(&mut self, x: &[f64], r: &[f64], jac: &mut [f64]) -> Result<(), Self::Error>;

    /// The last trial evaluated by [`residual`](Self::residual) became the
    /// current point.
    fn accept(&mut self) {}
}

/// How the damping term is scaled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scaling {
    /// `D = diag(J^T J)`: each unknown damped by its own curvature, so the
    /// step does not depend on the units of the unknowns.
    Marquardt,
    /// `D = max_i (J^T J)_ii I`: the same damping for all unknowns, which
    /// share a unit; an unknown with little curvature is still damped.
    Uniform,
}

/// The damping strategy and the stopping rules of [`levenberg_marquardt`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Damping `mu` at the start (dimensionless).
    pub initial_damping: f64,
    /// Factor on `mu` after an accepted step (below 1).
    pub damping_decrease: f64,
    /// Factor on `mu` after a rejected step (above 1).
    pub damping_increase: f64,
    /// Smallest `mu` (keeps the damped matrix away from singular).
    pub min_damping: f64,
    /// Largest `mu`.
    pub max_damping: f64,
    /// Scaling `D` of the damping.
    pub scaling: Scaling,
    /// Jacobians evaluated at most (one per iteration).
    pub max_iterations: usize,
    /// Rejected steps in a row that end the run with [`Stop::NoDescent`].
    pub max_trials: usize,
    /// Smallest gain ratio `rho` of an accepted step (0: any decrease).
    pub min_gain_ratio: f64,
    /// Stop when the cost `|r|^2 / 2` is at most this (units of `r`, squared).
    pub cost_tolerance: f64,
    /// Stop when an accepted step lowered the cost by at most this fraction.
    pub relative_decrease_tolerance: f64,
    /// Stop when an accepted step moved no unknown by more than this (units of `x`).
    pub step_tolerance: f64,
    /// Stop when no free unknown's gradient component exceeds this in
    /// magnitude (units of the cost per unit of `x`).
    pub gradient_tolerance: f64,
    /// Evaluate the Jacobian once more at the solution when the last one was
    /// taken before the final step, so that [`Report::jtj`] is the curvature
    /// there (for a covariance). Costs one Jacobian.
    pub jacobian_at_solution: bool,
}

impl Default for Options {
    /// Settings for fits whose unknowns are of order one (logarithms of
    /// parameters, say): Marquardt scaling, moderate damping.
    fn default() -> Self {
        Options {
            initial_damping: 1e-3,
            damping_decrease: 0.3,
            damping_increase: 10.0,
            min_damping: 1e-12,
            max_damping: 1e16,
            scaling: Scaling::Marquardt,
            max_iterations: 100,
            max_trials: 20,
            min_gain_ratio: 0.0,
            cost_tolerance: 0.0,
            relative_decrease_tolerance: 1e-14,
            step_tolerance: 1e-10,
            gradient_tolerance: 0.0,
            jacobian_at_solution: false,
        }
    }
}

/// Why [`levenberg_marquardt`] stopped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Stop<E> {
    /// The cost fell to [`Options::cost_tolerance`].
    Cost,
    /// An accepted step lowered the cost by at most
    /// [`Options::relative_decrease_tolerance`] of itself.
    CostDecrease,
    /// An accepted step was within [`Options::step_tolerance`].
    Step,
    /// The gradient of the free unknowns was within [`Options::gradient_tolerance`].
    Gradient,
    /// [`Options::max_iterations`] Jacobians were spent.
    IterationLimit,
    /// [`Options::max_trials`] steps in a row were rejected.
    NoDescent,
    /// The residual at the start or a Jacobian could not be evaluated; the
    /// report holds the last point reached.
    EvaluationFailed(E),
}

/// The outcome of [`levenberg_marquardt`].
#[derive(Clone, Debug, PartialEq)]
pub struct Report<E> {
    /// The best point reached (within the bounds).
    pub x: Vec<f64>,
    /// The residual there.
    pub residual: Vec<f64>,
    /// The cost `|r|^2 / 2` there (infinite if the start could not be evaluated).
    pub cost: f64,
    /// Iterations (Jacobians taken before the stop).
    pub iterations: usize,
    /// Residual evaluations, the start and failed trials included.
    pub evaluations: usize,
    /// Jacobian evaluations, the one at the solution included.
    pub jacobians: usize,
    /// `J^T J` at `x` when the Jacobian was taken there (always, with
    /// [`Options::jacobian_at_solution`], unless an evaluation failed).
    pub jtj: Option<SymmetricMatrix>,
    /// Why the run stopped.
    pub stop: Stop<E>,
}

/// A small dense symmetric matrix (at most [`MAX_UNKNOWNS`] square).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SymmetricMatrix {
    dim: usize,
    a: Square,
}

impl Index<(usize, usize)> for SymmetricMatrix {
    type Output = f64;
    fn index(&self, (i, j): (usize, usize)) -> &f64 {
        assert!(i < self.dim && j < self.dim, "index ({i}, {j}) outside a {0}x{0} matrix", self.dim);
        &self.a[i][j]
    }
}

impl SymmetricMatrix {
    fn zeros(dim: usize) -> SymmetricMatrix {
        SymmetricMatrix { dim, a: [[0.0; MAX_UNKNOWNS]; MAX_UNKNOWNS] }
    }

    /// Number of rows (and columns).
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The inverse, or `None` when the matrix is not numerically positive
    /// definite: an `L D L^T` pivot at most `1e-14` of its diagonal entry
    /// (for `2 x 2`, `1 - correlation^2 <= 1e-14`).
    pub fn inverse(&self) -> Option<SymmetricMatrix> {
        let factors = factor(&self.a, self.dim, 1e-14)?;
        let mut inverse = SymmetricMatrix::zeros(self.dim);
        for j in 0..self.dim {
            let mut column = [0.0; MAX_UNKNOWNS];
            column[j] = 1.0;
            let x = substitute(&factors, self.dim, column);
            for i in 0..self.dim {
                inverse.a[i][j] = x[i];
            }
        }
        Some(inverse)
    }
}

/// `L D L^T` of the leading `n x n` block (unit `L` below the diagonal, `D`
/// on it), or `None` if a pivot is not above `tolerance` times its diagonal
/// entry. No pivoting: the matrices are symmetric positive definite or
/// rejected.
fn factor(a: &Square, n: usize, tolerance: f64) -> Option<Square> {
    let mut f = [[0.0; MAX_UNKNOWNS]; MAX_UNKNOWNS];
    for j in 0..n {
        let d = a[j][j] - (0..j).map(|k| f[j][k] * f[j][k] * f[k][k]).sum::<f64>();
        if !(d > tolerance * a[j][j]) || !d.is_finite() {
            return None;
        }
        f[j][j] = d;
        for i in j + 1..n {
            f[i][j] = (a[i][j] - (0..j).map(|k| f[i][k] * f[j][k] * f[k][k]).sum::<f64>()) / d;
        }
    }
    Some(f)
}

/// Solves `L D L^T x = b` with the factors of [`factor`].
fn substitute(f: &Square, n: usize, mut b: [f64; MAX_UNKNOWNS]) -> [f64; MAX_UNKNOWNS] {
    for i in 0..n {
        b[i] -= (0..i).map(|k| f[i][k] * b[k]).sum::<f64>();
    }
    for i in 0..n {
        b[i] /= f[i][i];
    }
    for i in (0..n).rev() {
        b[i] -= (i + 1..n).map(|k| f[k][i] * b[k]).sum::<f64>();
    }
    b
}

/// A central-difference Jacobian with step `h` (units of `x`), one-sided
/// where a bound is closer than `h`, into `jac` (column-major, as
/// [`LeastSquares::jacobian`]); `scratch` has one entry per residual row. An
/// unknown whose bounds coincide has a zero column.
pub fn central_differences<E>(
    x: &[f64],
    h: f64,
    bounds: &[[f64; 2]],
    jac: &mut [f64],
    scratch: &mut [f64],
    mut residual: impl FnMut(&[f64], &mut [f64]) -> Result<(), E>,
) -> Result<(), E> {
    let (p, m) = (x.len(), scratch.len());
    assert!(m > 0 && p <= MAX_UNKNOWNS && bounds.len() == p && jac.len() == m * p, "Jacobian shapes disagree");
    let mut y = [0.0; MAX_UNKNOWNS];
    y[..p].copy_from_slice(x);
    for (k, column) in jac.chunks_exact_mut(m).enumerate() {
        let (up, down) = ((x[k] + h).min(bounds[k][1]), (x[k] - h).max(bounds[k][0]));
        if up == down {
            column.fill(0.0);
            continue;
        }
        y[k] = up;
        residual(&y[..p], column)?;
        y[k] = down;
        residual(&y[..p], scratch)?;
        y[k] = x[k];
        for (c, s) in column.iter_mut().zip(scratch.iter()) {
            *c = (*c - s) / (up - down);
        }
    }
    Ok(())
}

/// Minimizes `|r(x)|^2 / 2` over the box `bounds` (one `[lower, upper]` per
/// unknown, [`UNBOUNDED`] for none) from `x0` projected onto the box, by the
/// rules of the module doc.
///
/// # Panics
///
/// If there are no unknowns or more than [`MAX_UNKNOWNS`], or if `bounds`
/// does not hold one ordered pair per unknown.
pub fn levenberg_marquardt<P: LeastSquares>(
    problem: &mut P,
    x0: &[f64],
    bounds: &[[f64; 2]],
    options: &Options,
) -> Report<P::Error> {
    let p = x0.len();
    assert!((1..=MAX_UNKNOWNS).contains(&p), "{p} unknowns: 1 to {MAX_UNKNOWNS} are supported");
    assert_eq!(bounds.len(), p, "one [lower, upper] per unknown");
    assert!(bounds.iter().all(|[lo, hi]| lo <= hi), "bounds {bounds:?} are not ordered pairs");
    let mut run = Run::new(problem.rows(), x0, bounds, options);
    run.evaluations += 1;
    let stop = match problem.start(&run.x[..p], &mut run.r) {
        Ok(()) => {
            run.cost = half_squared_norm(&run.r);
            run.iterate(problem)
        }
        Err(e) => Stop::EvaluationFailed(e),
    };
    run.finish(problem, stop)
}

fn half_squared_norm(r: &[f64]) -> f64 {
    0.5 * r.iter().map(|v| v * v).sum::<f64>()
}

/// The largest magnitude, NaN if any value is NaN (a NaN gradient or step
/// must not pass for a small one).
fn largest_magnitude(values: impl Iterator<Item = f64>) -> f64 {
    let mut largest = 0.0f64;
    for v in values {
        if v.is_nan() {
            return f64::NAN;
        }
        largest = largest.max(v.abs());
    }
    largest
}

/// The state of one run: the current point, its residual and Jacobian, and
/// the scratch of the trials (allocated once).
struct Run<'o> {
    options: &'o Options,
    p: usize,
    bounds: [[f64; 2]; MAX_UNKNOWNS],
    x: [f64; MAX_UNKNOWNS],
    r: Vec<f64>,
    r_trial: Vec<f64>,
    jac: Vec<f64>,
    cost: f64,
    mu: f64,
    jtj: SymmetricMatrix,
    gradient: [f64; MAX_UNKNOWNS],
    /// Whether `jac`, `jtj` and `gradient` belong to `x`.
    jacobian_at_x: bool,
    iterations: usize,
    evaluations: usize,
    jacobians: usize,
}

impl<'o> Run<'o> {
    fn new(rows: usize, x0: &[f64], bounds: &[[f64; 2]], options: &'o Options) -> Run<'o> {
        let p = x0.len();
        let mut run = Run {
            options,
            p,
            bounds: [UNBOUNDED; MAX_UNKNOWNS],
            x: [0.0; MAX_UNKNOWNS],
            r: vec![0.0; rows],
            r_trial: vec![0.0; rows],
            jac: vec![0.0; rows * p],
            cost: f64::INFINITY,
            mu: options.initial_damping,
            jtj: SymmetricMatrix::zeros(p),
            gradient: [0.0; MAX_UNKNOWNS],
            jacobian_at_x: false,
            iterations: 0,
            evaluations: 0,
            jacobians: 0,
        };
        run.bounds[..p].copy_from_slice(bounds);
        for i in 0..p {
            run.x[i] = x0[i].clamp(bounds[i][0], bounds[i][1]);
        }
        run
    }

    /// Iterations until a stopping rule holds.
    fn iterate<P: LeastSquares>(&mut self, problem: &mut P) -> Stop<P::Error> {
        let o = self.options;
        loop {
            // Checked before the Jacobian: a problem already solved costs nothing more.
            if self.cost <= o.cost_tolerance {
                return Stop::Cost;
            }
            if self.iterations == o.max_iterations {
                return Stop::IterationLimit;
            }
            if let Err(e) = self.evaluate_jacobian(problem) {
                return Stop::EvaluationFailed(e);
            }
            self.iterations += 1;
            let free = self.free_unknowns();
            let slope = largest_magnitude((0..self.p).filter(|&i| free[i]).map(|i| self.gradient[i]));
            if slope <= o.gradient_tolerance {
                return Stop::Gradient;
            }
            let Some((decrease, step)) = self.descend(problem, &free) else {
                return Stop::NoDescent;
            };
            if decrease <= o.relative_decrease_tolerance {
                return Stop::CostDecrease;
            }
            if step <= o.step_tolerance {
                return Stop::Step;
            }
        }
    }

    fn evaluate_jacobian<P: LeastSquares>(&mut self, problem: &mut P) -> Result<(), P::Error> {
        let (p, m) = (self.p, self.r.len());
        problem.jacobian(&self.x[..p], &self.r, &mut self.jac)?;
        self.jacobians += 1;
        let column = |k: usize| &self.jac[k * m..(k + 1) * m];
        for a in 0..p {
            self.gradient[a] = column(a).iter().zip(&self.r).map(|(j, r)| j * r).sum();
            for b in 0..=a {
                let entry = column(a).iter().zip(column(b)).map(|(u, v)| u * v).sum();
                self.jtj.a[a][b] = entry;
                self.jtj.a[b][a] = entry;
            }
        }
        self.jacobian_at_x = true;
        Ok(())
    }

    /// The unknowns not held at a bound: held where the box blocks the
    /// steepest-descent direction `-g`.
    fn free_unknowns(&self) -> [bool; MAX_UNKNOWNS] {
        let mut free = [false; MAX_UNKNOWNS];
        for i in 0..self.p {
            let [lo, hi] = self.bounds[i];
            let g = self.gradient[i];
            free[i] = !((self.x[i] <= lo && g > 0.0) || (self.x[i] >= hi && g < 0.0));
        }
        free
    }

    /// Damped trial steps from `x` until one is accepted: the cost's relative
    /// decrease and the largest change of an unknown, or `None` after
    /// `max_trials` rejections.
    fn descend<P: LeastSquares>(&mut self, problem: &mut P, free: &[bool; MAX_UNKNOWNS]) -> Option<(f64, f64)> {
        let o = self.options;
        let p = self.p;
        for _ in 0..o.max_trials {
            if let Some((trial, h)) = self.trial_point(free) {
                self.evaluations += 1;
                if problem.residual(&trial[..p], &mut self.r_trial).is_ok() {
                    let cost = half_squared_norm(&self.r_trial);
                    let actual = self.cost - cost;
                    if actual > 0.0 && actual >= o.min_gain_ratio * self.predicted_decrease(&h) {
                        problem.accept();
                        let relative = actual / self.cost.max(f64::MIN_POSITIVE);
                        self.x = trial;
                        std::mem::swap(&mut self.r, &mut self.r_trial);
                        self.cost = cost;
                        self.jacobian_at_x = false;
                        self.mu = (self.mu * o.damping_decrease).max(o.min_damping);
                        return Some((relative, largest_magnitude(h[..p].iter().copied())));
                    }
                }
            }
            self.mu = (self.mu * o.damping_increase).min(o.max_damping);
        }
        None
    }

    /// The projected point of the damped step and the step `h` to it, or
    /// `None` when the damped matrix cannot be factored or the projection
    /// leaves `x` where it is (more damping turns the step towards `-g`).
    fn trial_point(&self, free: &[bool; MAX_UNKNOWNS]) -> Option<([f64; MAX_UNKNOWNS], [f64; MAX_UNKNOWNS])> {
        let p = self.p;
        let mut index = [0; MAX_UNKNOWNS];
        let mut n = 0;
        for i in (0..p).filter(|&i| free[i]) {
            index[n] = i;
            n += 1;
        }
        let diagonal = |i: usize| self.jtj.a[i][i].max(f64::MIN_POSITIVE);
        let uniform = (0..n).map(|k| diagonal(index[k])).fold(0.0, f64::max);
        let mut a = [[0.0; MAX_UNKNOWNS]; MAX_UNKNOWNS];
        let mut rhs = [0.0; MAX_UNKNOWNS];
        for k in 0..n {
            for l in 0..n {
                a[k][l] = self.jtj.a[index[k]][index[l]];
            }
            let scale = match self.options.scaling {
                Scaling::Marquardt => diagonal(index[k]),
                Scaling::Uniform => uniform,
            };
            a[k][k] += self.mu * scale;
            rhs[k] = -self.gradient[index[k]];
        }
        let dx = substitute(&factor(&a, n, 0.0)?, n, rhs);
        if !dx[..n].iter().all(|s| s.is_finite()) {
            return None;
        }
        let (mut trial, mut h) = (self.x, [0.0; MAX_UNKNOWNS]);
        for k in 0..n {
            let i = index[k];
            trial[i] = (self.x[i] + dx[k]).clamp(self.bounds[i][0], self.bounds[i][1]);
            h[i] = trial[i] - self.x[i];
        }
        h[..p].iter().any(|&s| s != 0.0).then_some((trial, h))
    }

    /// `L(0) - L(h) = -g.h - h^T (J^T J) h / 2`.
    fn predicted_decrease(&self, h: &[f64; MAX_UNKNOWNS]) -> f64 {
        let p = self.p;
        let mut decrease = 0.0;
        for a in 0..p {
            let curvature: f64 = (0..p).map(|b| self.jtj.a[a][b] * h[b]).sum();
            decrease -= h[a] * (self.gradient[a] + 0.5 * curvature);
        }
        decrease
    }

    fn finish<P: LeastSquares>(mut self, problem: &mut P, mut stop: Stop<P::Error>) -> Report<P::Error> {
        let wanted = self.options.jacobian_at_solution && !self.jacobian_at_x;
        if wanted && !matches!(stop, Stop::EvaluationFailed(_)) {
            if let Err(e) = self.evaluate_jacobian(problem) {
                stop = Stop::EvaluationFailed(e);
            }
        }
        Report {
            x: self.x[..self.p].to_vec(),
            residual: self.r,
            cost: self.cost,
            iterations: self.iterations,
            evaluations: self.evaluations,
            jacobians: self.jacobians,
            jtj: self.jacobian_at_x.then_some(self.jtj),
            stop,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A problem from plain functions: residual and analytic Jacobian.
    struct Analytic<const M: usize, const P: usize> {
        residual: fn(&[f64]) -> Option<[f64; M]>,
        jacobian: fn(&[f64]) -> Option<[[f64; M]; P]>,
    }

    impl<const M: usize, const P: usize> LeastSquares for Analytic<M, P> {
        type Error = &'static str;
        fn rows(&self) -> usize {
            M
        }
        fn residual(&mut self, x: &[f64], r: &mut [f64]) -> Result<(), &'static str> {
            r.copy_from_slice(&(self.residual)(x).ok_or("no residual")?);
            Ok(())
        }
        fn jacobian(&mut self, x: &[f64], _: &[f64], jac: &mut [f64]) -> Result<(), &'static str> {
            let columns = (self.jacobian)(x).ok_or("no Jacobian")?;
            jac.copy_from_slice(columns.as_flattened());
            Ok(())
        }
    }

    #[test]
    fn rosenbrock_converges_to_one_one() {
        // F = ((10 (y - x^2))^2 + (1 - x)^2) / 2: a curved valley.
        let mut problem = Analytic::<2, 2> {
            residual: |x| Some([10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]),
            jacobian: |x| Some([[-20.0 * x[0], -1.0], [10.0, 0.0]]),
        };
        let options = Options {
            cost_tolerance: 1e-24,
            relative_decrease_tolerance: 0.0,
            step_tolerance: 0.0,
            ..Options::default()
        };
        let fit = levenberg_marquardt(&mut problem, &[-1.2, 1.0], &[UNBOUNDED; 2], &options);
        assert_eq!(fit.stop, Stop::Cost, "{fit:?}");
        assert!((fit.x[0] - 1.0).abs() < 1e-10 && (fit.x[1] - 1.0).abs() < 1e-10, "{fit:?}");
        assert!(fit.iterations < 40 && fit.evaluations > fit.iterations, "{fit:?}");
    }

    #[test]
    fn bounds_hold_and_the_free_unknown_finishes_on_the_boundary() {
        // r = (x - 2, y - 1, x - y) with x <= 0.5: the optimum (5/3, 4/3) is
        // outside; on x = 0.5 the best y is 0.75.
        let mut problem = Analytic::<3, 2> {
            residual: |x| Some([x[0] - 2.0, x[1] - 1.0, x[0] - x[1]]),
            jacobian: |_| Some([[1.0, 0.0, 1.0], [0.0, 1.0, -1.0]]),
        };
        let options = Options {
            gradient_tolerance: 1e-12,
            relative_decrease_tolerance: 0.0,
            step_tolerance: 0.0,
            ..Options::default()
        };
        let fit = levenberg_marquardt(&mut problem, &[0.0, 0.0], &[[-1.0, 0.5], UNBOUNDED], &options);
        assert_eq!(fit.stop, Stop::Gradient, "{fit:?}");
        assert_eq!(fit.x[0], 0.5);
        assert!((fit.x[1] - 0.75).abs() < 1e-12, "{fit:?}");
        // At a corner where both unknowns press outwards nothing moves.
        let fit = levenberg_marquardt(&mut problem, &[0.5, 0.5], &[[-1.0, 0.5], [0.0, 0.5]], &options);
        assert_eq!((fit.stop, fit.x, fit.evaluations), (Stop::Gradient, vec![0.5, 0.5], 1));
    }

    #[test]
    fn linear_least_squares_takes_one_step() {
        // The line a + b t through (0, 1), (1, 3), (2, 2), (3, 5): a = b = 1.1.
        let mut problem = Analytic::<4, 2> {
            residual: |x| Some([(0.0, 1.0), (1.0, 3.0), (2.0, 2.0), (3.0, 5.0)].map(|(t, y)| x[0] + x[1] * t - y)),
            jacobian: |_| Some([[1.0; 4], [0.0, 1.0, 2.0, 3.0]]),
        };
        let options =
            Options { initial_damping: 1e-12, max_iterations: 1, jacobian_at_solution: true, ..Options::default() };
        let fit = levenberg_marquardt(&mut problem, &[0.0, 0.0], &[UNBOUNDED; 2], &options);
        assert_eq!((&fit.stop, fit.iterations, fit.evaluations), (&Stop::IterationLimit, 1, 2));
        assert!((fit.x[0] - 1.1).abs() < 1e-10 && (fit.x[1] - 1.1).abs() < 1e-10, "{fit:?}");
        // Residuals 0.1, -0.8, 1.3, -0.6: cost 1.35.
        assert!((fit.cost - 1.35).abs() < 1e-10);
        let jtj = fit.jtj.expect("Jacobian at the solution");
        assert_eq!((jtj.dim(), jtj[(0, 0)], jtj[(0, 1)], jtj[(1, 0)], jtj[(1, 1)]), (2, 4.0, 6.0, 6.0, 14.0));
        // (J^T J)^-1 = [[14, -6], [-6, 4]] / 20.
        let inverse = jtj.inverse().unwrap();
        for (i, j, v) in [(0, 0, 0.7), (0, 1, -0.3), (1, 0, -0.3), (1, 1, 0.2)] {
            assert!((inverse[(i, j)] - v).abs() < 1e-14, "({i}, {j}): {}", inverse[(i, j)]);
        }
        // A second run from the solution stops on the gradient at once.
        let again = levenberg_marquardt(
            &mut problem,
            &fit.x,
            &[UNBOUNDED; 2],
            &Options { gradient_tolerance: 1e-9, ..options },
        );
        assert_eq!((again.stop, again.evaluations), (Stop::Gradient, 1));
    }

    #[test]
    fn failed_evaluations_are_reported_not_panics() {
        // The residual exists for x < 1 only; the minimum (x = 2) lies beyond.
        let residual: fn(&[f64]) -> Option<[f64; 1]> = |x| (x[0] < 1.0).then(|| [x[0] - 2.0]);
        let mut problem = Analytic::<1, 1> { residual, jacobian: |_| Some([[1.0]]) };
        let one = [UNBOUNDED];
        let fit = levenberg_marquardt(&mut problem, &[0.0], &one, &Options::default());
        // Every full step fails; damping shrinks the steps until one lands.
        assert!(fit.x[0] > 0.0 && fit.x[0] < 1.0, "{fit:?}");
        let fit = levenberg_marquardt(&mut problem, &[5.0], &one, &Options::default());
        assert_eq!((fit.stop, fit.cost, fit.iterations), (Stop::EvaluationFailed("no residual"), f64::INFINITY, 0));
        let mut broken = Analytic::<1, 1> { residual, jacobian: |_| None };
        let fit = levenberg_marquardt(&mut broken, &[0.5], &one, &Options::default());
        assert_eq!((&fit.stop, &fit.x), (&Stop::EvaluationFailed("no Jacobian"), &vec![0.5]));
        assert_eq!(fit.residual, vec![-1.5]);
        // A residual that fails everywhere but the start: no descent.
        let mut stuck = Analytic::<1, 1> { residual: |x| (x[0] == 0.0).then_some([1.0]), jacobian: |_| Some([[1.0]]) };
        let fit = levenberg_marquardt(&mut stuck, &[0.0], &one, &Options { max_trials: 5, ..Options::default() });
        assert_eq!((fit.stop, fit.evaluations, fit.x), (Stop::NoDescent, 6, vec![0.0]));
    }

    #[test]
    fn central_differences_stay_inside_the_bounds() {
        let mut jac = [0.0; 6];
        let mut scratch = [0.0; 2];
        let mut seen = Vec::new();
        let result: Result<(), ()> = central_differences(
            &[1.0, 0.0, 3.0],
            1e-3,
            &[[0.0, 1.0], UNBOUNDED, [3.0, 3.0]],
            &mut jac,
            &mut scratch,
            |x, r| {
                seen.push(x.to_vec());
                r.copy_from_slice(&[x[0] * x[0], x[0] + 2.0 * x[1]]);
                Ok(())
            },
        );
        result.unwrap();
        assert!(seen.iter().all(|x| x[0] <= 1.0 && x[2] == 3.0), "{seen:?}");
        let expected = [2.0, 1.0, 0.0, 2.0, 0.0, 0.0];
        assert!(jac.iter().zip(expected).all(|(a, b)| (a - b).abs() < 2e-3), "{jac:?}");
    }
}
