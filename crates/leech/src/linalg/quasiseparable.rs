//! Symmetric quasiseparable matrices: `O(n r^2)` LDL^T factorization, `O(n r)`
//! solves, products and quadratic forms, for a small fixed order `r`.
//!
//! # Representation
//!
//! A symmetric `n x n` matrix `A` has quasiseparable order `r` when every
//! block strictly below its diagonal has rank at most `r`. It is then given
//! by the [`Generators`] of its rows: the diagonal `A_jj = d_j`, row
//! generators `p_j`, column generators `q_k` and transitions `a_k` (vectors
//! of `r`, the transitions being diagonal matrices), as
//!
//! ```text
//! A_jk = p_j^T a_{j-1} a_{j-2} ... a_{k+1} q_k      (j > k; A_{k+1,k} = p_{k+1}^T q_k)
//! A_kj = A_jk
//! ```
//!
//! Diagonal transitions cover the uses here: a semiseparable block has
//! `a = 1` (the chains' mass matrices, `r = 2`: `cos(phi_j - phi_k)` splits
//! into `c_j c_k + s_j s_k`); a component with `a = 0` reaches the first
//! subdiagonal only (adding a tridiagonal matrix: `p = (u, 1)`, `q = (v, t)`,
//! `a = (1, 1, 0)`, `r = 3`). Only `a_1 .. a_{n-2}` matter.
//!
//! # Factorization
//!
//! `A = L D L^T` with `L` unit lower triangular. Guess that `L` has the form
//! of `A` with `q` replaced by unknown `g`, `L_jk = p_j^T a_{j-1}..a_{k+1} g_k`,
//! and let `D = diag(delta)`. For `j > k` the entry of `L D L^T` is
//!
//! ```text
//! sum_{i <= k} L_ji delta_i L_ki = p_j^T a_{j-1}..a_{k+1} (g_k delta_k + a_k F_k p_k),
//! F_k = sum_{i < k} (a_{k-1}..a_{i+1}) g_i delta_i g_i^T (a_{k-1}..a_{i+1})^T   (r x r),
//! ```
//!
//! using `a_{j-1}..a_{i+1} = (a_{j-1}..a_{k+1}) a_k (a_{k-1}..a_{i+1})` for
//! `i < k < j`. Matching `A_jk` for every `j > k` at once, and the diagonal
//! `A_kk = delta_k + p_k^T F_k p_k`, gives the recurrences (`F_0 = 0`)
//!
//! ```text
//! delta_k = d_k - p_k^T F_k p_k                    (pivot; > 0 iff A is SPD)
//! h_k     = q_k - a_k F_k p_k,    g_k = h_k / delta_k
//! F_{k+1} = a_k F_k a_k^T + g_k delta_k g_k^T = a_k F_k a_k + h_k g_k^T
//! ```
//!
//! at `O(r^2)` per row. It is Gaussian elimination without pivoting, as
//! stable as the dense Cholesky factorization for a symmetric positive
//! definite `A`, and it stops at the first pivot that is not positive.
//!
//! # Solve, product, quadratic form
//!
//! With `z_j = sum_{k<j} (a_{j-1}..a_{k+1}) g_k y_k` and
//! `w_k = sum_{j>k} (a_{j-1}..a_{k+1})^T p_j x_j`, each a running sum,
//!
//! ```text
//! L y = b:     y_j = b_j - p_j^T z_j,        z_{j+1} = a_j z_j + g_j y_j
//! D:           y_j <- y_j / delta_j
//! L^T x = y:   x_k = y_k - g_k^T w_k,        w_{k-1} = a_k w_k + p_k x_k   (from k = n-1 down)
//! ```
//!
//! (several right-hand sides share one sweep, and the blocks of a block
//! diagonal matrix can share one too: [`Ldl::solve_together`]). Each sweep
//! is a chain of dependent operations, row after row; independent chains
//! (columns, blocks) run in lockstep and overlap, which hides that latency
//! at no extra arithmetic. The same sums with `q`
//! in place of `g` give `(A x)_j = d_j x_j +
//! p_j^T z_j + q_j^T w_j` and `x^T A x = sum_j x_j (d_j x_j + 2 p_j^T z_j)`,
//! all `O(n r)`.

/// The generators of one row `j` of a symmetric quasiseparable matrix of
/// order `R` (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Generators<const R: usize> {
    /// The diagonal entry `A_jj`.
    pub diagonal: f64,
    /// Row generator `p_j`: how row `j` reads the rows above it.
    pub p: [f64; R],
    /// Column generator `q_j`: how column `j` reaches the rows below it.
    pub q: [f64; R],
    /// Diagonal of the transition `a_j`, applied when passing row `j`.
    pub a: [f64; R],
}

/// A pivot that is not positive: the matrix is not positive definite (or
/// holds a NaN).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("matrix not positive definite: pivot {pivot:e} at row {row}")]
pub struct NotPositiveDefinite {
    /// The row whose pivot failed (from 0).
    pub row: usize,
    /// The pivot found there.
    pub pivot: f64,
}

/// One row of the factors: `L`'s generators `p_j`, `g_j`, the transition
/// `a_j` and the pivot.
#[derive(Clone, Copy, Debug)]
struct FactorRow<const R: usize> {
    p: [f64; R],
    g: [f64; R],
    a: [f64; R],
    pivot: f64,
}

/// The factorization `A = L D L^T` of a symmetric positive definite
/// quasiseparable matrix of order `R`. Its storage is reused from one
/// factorization to the next: refactoring a matrix of no more rows than
/// before does not allocate.
#[derive(Clone, Debug, Default)]
pub struct Ldl<const R: usize> {
    rows: Vec<FactorRow<R>>,
}

impl<const R: usize> Ldl<R> {
    /// Empty factors with room for `n` rows.
    pub fn with_capacity(n: usize) -> Ldl<R> {
        Ldl { rows: Vec::with_capacity(n) }
    }

    /// Number of rows factored.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether nothing is factored.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The pivot `delta_j` of row `j`.
    pub fn pivot(&self, j: usize) -> f64 {
        self.rows[j].pivot
    }

    /// Factors the matrix whose rows' generators `rows` yields, in order.
    /// On a pivot that is not positive the factors are left incomplete.
    pub fn factor(&mut self, rows: impl IntoIterator<Item = Generators<R>>) -> Result<(), NotPositiveDefinite> {
        Ldl::factor_together([self], [rows.into_iter()]).map_err(|(_, e)| e)
    }

    /// [`Ldl::factor`] of `K` matrices at once (the blocks of a block
    /// diagonal matrix), `rows[k]` yielding the generators of `factors[k]`.
    /// Their rows are factored in lockstep: each recurrence waits on its own
    /// previous row (a division among others), and independent ones overlap.
    /// A block whose pivot fails stops there and the others go on; the error
    /// is the first failing block's, with its index.
    pub fn factor_together<const K: usize, I>(
        mut factors: [&mut Ldl<R>; K],
        rows: [I; K],
    ) -> Result<(), (usize, NotPositiveDefinite)>
    where
        I: Iterator<Item = Generators<R>>,
    {
        let mut rows = rows.map(|r| r.enumerate());
        let mut f = [[[0.0; R]; R]; K];
        let mut failed: [Option<NotPositiveDefinite>; K] = [None; K];
        factors.iter_mut().for_each(|ldl| ldl.rows.clear());
        loop {
            let mut more = false;
            for (((ldl, rows), f), failed) in factors.iter_mut().zip(&mut rows).zip(&mut f).zip(&mut failed) {
                if failed.is_some() {
                    continue;
                }
                let Some((row, generators)) = rows.next() else { continue };
                more = true;
                match FactorRow::next(f, generators) {
                    Ok(factored) => ldl.rows.push(factored),
                    Err(pivot) => *failed = Some(NotPositiveDefinite { row, pivot }),
                }
            }
            if !more {
                break;
            }
        }
        match failed.iter().enumerate().find_map(|(k, e)| e.map(|e| (k, e))) {
            Some(error) => Err(error),
            None => Ok(()),
        }
    }

    /// Solves `A x = b` in place (`x` holds `b` on entry).
    pub fn solve(&self, x: &mut [f64]) {
        Ldl::solve_together([self], [x], 1);
    }

    /// Solves `A X = B` in place for up to [`MAX_COLUMNS`] right-hand sides
    /// at once, `x` holding `B` row by row (entry `(j, c)` at
    /// `j * columns + c`). One sweep serves every column: their recurrences
    /// are independent, so they overlap instead of waiting on each other.
    pub fn solve_columns(&self, x: &mut [f64], columns: usize) {
        Ldl::solve_together([self], [x], columns);
    }

    /// [`Ldl::solve_columns`] for `K` factored matrices at once, `xs[k]`
    /// holding the right-hand sides of `factors[k]` (the blocks of a block
    /// diagonal matrix). The sweeps step through the matrices' rows in
    /// lockstep: each is a chain of dependent operations, and independent
    /// chains overlap instead of waiting each on its own previous row.
    pub fn solve_together<const K: usize>(factors: [&Ldl<R>; K], xs: [&mut [f64]; K], columns: usize) {
        assert!(columns <= MAX_COLUMNS, "at most {MAX_COLUMNS} columns");
        for (f, x) in factors.iter().zip(&xs) {
            assert_eq!(x.len(), f.rows.len() * columns, "right-hand sides of another size");
        }
        // A column count known at compile time keeps the recurrences in registers.
        match columns {
            0 => {}
            1 => Ldl::sweep::<K, 1>(factors, xs),
            2 => Ldl::sweep::<K, 2>(factors, xs),
            3 => Ldl::sweep::<K, 3>(factors, xs),
            _ => Ldl::sweep::<K, MAX_COLUMNS>(factors, xs),
        }
    }

    /// The forward and backward sweeps of [`Ldl::solve_together`] for `C` columns.
    fn sweep<const K: usize, const C: usize>(factors: [&Ldl<R>; K], mut xs: [&mut [f64]; K]) {
        let n = factors.iter().map(|f| f.rows.len()).max().unwrap_or(0);
        let mut z = [[[0.0; R]; C]; K];
        for j in 0..n {
            for ((f, x), z) in factors.iter().zip(&mut xs).zip(&mut z) {
                let Some(r) = f.rows.get(j) else { continue };
                for (xc, zc) in x[j * C..(j + 1) * C].iter_mut().zip(z) {
                    let y = *xc - dot(&r.p, zc);
                    r.forward(zc, y);
                    *xc = y / r.pivot;
                }
            }
        }
        // Backwards, each matrix from its own last row.
        let mut w = [[[0.0; R]; C]; K];
        for t in 0..n {
            for ((f, x), w) in factors.iter().zip(&mut xs).zip(&mut w) {
                let Some(k) = f.rows.len().checked_sub(t + 1) else { continue };
                let r = &f.rows[k];
                for (xc, wc) in x[k * C..(k + 1) * C].iter_mut().zip(w) {
                    *xc -= dot(&r.g, wc);
                    r.backward(wc, *xc);
                }
            }
        }
    }
}

impl<const R: usize> FactorRow<R> {
    /// The factors' row for the generators `generators` and the running
    /// `f` (`F_k`, advanced to `F_(k+1)`), or the pivot if not positive.
    #[inline]
    fn next(f: &mut [[f64; R]; R], generators: Generators<R>) -> Result<FactorRow<R>, f64> {
        let Generators { diagonal, p, q, a } = generators;
        let mut fp = [0.0; R];
        for i in 0..R {
            fp[i] = (0..R).map(|k| f[i][k] * p[k]).sum();
        }
        let pivot = diagonal - (0..R).map(|i| p[i] * fp[i]).sum::<f64>();
        if !(pivot > 0.0) {
            return Err(pivot);
        }
        let mut h = [0.0; R];
        let mut g = [0.0; R];
        for i in 0..R {
            h[i] = q[i] - a[i] * fp[i];
            g[i] = h[i] / pivot;
        }
        for i in 0..R {
            for k in 0..R {
                f[i][k] = a[i] * f[i][k] * a[k] + h[i] * g[k];
            }
        }
        Ok(FactorRow { p, g, a, pivot })
    }

    /// `z_{j+1} = a_j z_j + g_j y_j`.
    #[inline]
    fn forward(&self, z: &mut [f64; R], y: f64) {
        for i in 0..R {
            z[i] = self.a[i] * z[i] + self.g[i] * y;
        }
    }

    /// `w_{k-1} = a_k w_k + p_k x_k`.
    #[inline]
    fn backward(&self, w: &mut [f64; R], x: f64) {
        for i in 0..R {
            w[i] = self.a[i] * w[i] + self.p[i] * x;
        }
    }
}

/// Most right-hand sides [`Ldl::solve_columns`] takes in one sweep.
pub const MAX_COLUMNS: usize = 4;

#[inline]
fn dot<const R: usize>(a: &[f64; R], b: &[f64; R]) -> f64 {
    (0..R).map(|i| a[i] * b[i]).sum()
}

/// `y = A x` for the matrix whose rows' generators `rows` yields (twice:
/// forwards and backwards, hence `Clone` and double-ended).
pub fn multiply<const R: usize, I>(rows: I, x: &[f64], y: &mut [f64])
where
    I: DoubleEndedIterator<Item = Generators<R>> + ExactSizeIterator + Clone,
{
    multiply_together([rows], [x], [y]);
}

/// [`multiply`] for `K` matrices at once (the blocks of a block diagonal
/// matrix), `ys[k] = A_k xs[k]`: their running sums are independent
/// recurrences, advanced in lockstep so that they overlap.
pub fn multiply_together<const K: usize, const R: usize, I>(rows: [I; K], xs: [&[f64]; K], mut ys: [&mut [f64]; K])
where
    I: DoubleEndedIterator<Item = Generators<R>> + ExactSizeIterator + Clone,
{
    let lengths = rows.each_ref().map(|r| r.len());
    for ((n, x), y) in lengths.iter().zip(&xs).zip(&ys) {
        assert!(x.len() == *n && y.len() == *n, "vectors of another size");
    }
    let n = lengths.iter().copied().max().unwrap_or(0);
    let mut forward = rows.each_ref().map(|r| r.clone());
    let mut z = [[0.0; R]; K];
    for j in 0..n {
        for (((rows, x), y), z) in forward.iter_mut().zip(&xs).zip(&mut ys).zip(&mut z) {
            let Some(r) = rows.next() else { continue };
            let xj = x[j];
            y[j] = r.diagonal * xj + dot(&r.p, z);
            for i in 0..R {
                z[i] = r.a[i] * z[i] + r.q[i] * xj;
            }
        }
    }
    let mut backward = rows.map(|r| r.rev());
    let mut w = [[0.0; R]; K];
    for t in 0..n {
        for ((((rows, n), x), y), w) in backward.iter_mut().zip(&lengths).zip(&xs).zip(&mut ys).zip(&mut w) {
            let Some(r) = rows.next() else { continue };
            let k = n - 1 - t;
            let xk = x[k];
            y[k] += dot(&r.q, w);
            for i in 0..R {
                w[i] = r.a[i] * w[i] + r.p[i] * xk;
            }
        }
    }
}

/// `x^T A x` for the matrix whose rows' generators `rows` yields, in one
/// forward pass.
pub fn quadratic_form<const R: usize>(rows: impl ExactSizeIterator<Item = Generators<R>>, x: &[f64]) -> f64 {
    assert_eq!(rows.len(), x.len(), "vector of another size");
    let mut z = [0.0; R];
    let mut sum = 0.0;
    for (r, xj) in rows.zip(x) {
        sum += xj * (r.diagonal * xj + 2.0 * dot(&r.p, &z));
        for i in 0..R {
            z[i] = r.a[i] * z[i] + r.q[i] * xj;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A small deterministic generator of uniform numbers in `[lo, hi)`.
    struct Rng(u64);

    impl Rng {
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            lo + (hi - lo) * (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The dense matrix (row-major) of the generators, from the definition.
    fn dense<const R: usize>(rows: &[Generators<R>]) -> Vec<f64> {
        let n = rows.len();
        let mut a = vec![0.0; n * n];
        for k in 0..n {
            a[k * n + k] = rows[k].diagonal;
            let mut t = rows[k].q;
            for j in k + 1..n {
                let v = dot(&rows[j].p, &t);
                a[j * n + k] = v;
                a[k * n + j] = v;
                for i in 0..R {
                    t[i] *= rows[j].a[i];
                }
            }
        }
        a
    }

    fn dense_product(a: &[f64], x: &[f64]) -> Vec<f64> {
        let n = x.len();
        (0..n).map(|j| (0..n).map(|k| a[j * n + k] * x[k]).sum()).collect()
    }

    /// Random generators of order `R` with transitions in `[-1, 1]` (some
    /// exactly 0 or 1), made positive definite by a dominant diagonal.
    fn random_spd<const R: usize>(n: usize, rng: &mut Rng) -> Vec<Generators<R>> {
        let mut rows: Vec<Generators<R>> = (0..n)
            .map(|_| {
                let mut r = Generators { diagonal: 0.0, p: [0.0; R], q: [0.0; R], a: [0.0; R] };
                for i in 0..R {
                    r.p[i] = rng.uniform(-1.0, 1.0);
                    r.q[i] = rng.uniform(-1.0, 1.0);
                    let a = rng.uniform(-1.5, 1.5);
                    r.a[i] = if a > 1.0 {
                        1.0
                    } else if a < -1.0 {
                        0.0
                    } else {
                        a
                    };
                }
                r
            })
            .collect();
        let a = dense(&rows);
        for (j, r) in rows.iter_mut().enumerate() {
            let off: f64 = (0..n).filter(|k| *k != j).map(|k| a[j * n + k].abs()).sum();
            r.diagonal = off + rng.uniform(0.01, 2.0);
        }
        rows
    }

    fn sup(x: &[f64]) -> f64 {
        x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    }

    fn check<const R: usize>(rows: &[Generators<R>], rng: &mut Rng) -> Result<(), TestCaseError> {
        let n = rows.len();
        let a = dense(rows);
        let x: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let expected = dense_product(&a, &x);
        let mut y = vec![0.0; n];
        multiply(rows.iter().copied(), &x, &mut y);
        let scale = sup(&a) * n as f64;
        for j in 0..n {
            prop_assert!((y[j] - expected[j]).abs() <= 1e-13 * scale, "product row {j}");
        }
        let form: f64 = x.iter().zip(&expected).map(|(a, b)| a * b).sum();
        prop_assert!((quadratic_form(rows.iter().copied(), &x) - form).abs() <= 1e-13 * scale * n as f64);
        let mut ldl = Ldl::with_capacity(n);
        ldl.factor(rows.iter().copied()).unwrap();
        let mut solved = expected.clone();
        ldl.solve(&mut solved);
        for j in 0..n {
            prop_assert!((solved[j] - x[j]).abs() < 1e-10, "solve row {j}: {} vs {}", solved[j], x[j]);
        }
        // Several right-hand sides at once give each column's single solve, bit for bit.
        for columns in 0..=MAX_COLUMNS {
            let b: Vec<f64> = (0..n * columns).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let mut together = b.clone();
            ldl.solve_columns(&mut together, columns);
            for c in 0..columns {
                let mut alone: Vec<f64> = (0..n).map(|j| b[j * columns + c]).collect();
                ldl.solve(&mut alone);
                for j in 0..n {
                    prop_assert_eq!(together[j * columns + c], alone[j]);
                }
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Product, quadratic form and solve against the dense matrix, for
        /// orders 1 to 4.
        #[test]
        fn agrees_with_the_dense_matrix(n in 1usize..200, seed in 1u64..u64::MAX) {
            let mut rng = Rng(seed);
            check(&random_spd::<1>(n, &mut rng), &mut rng)?;
            check(&random_spd::<2>(n, &mut rng), &mut rng)?;
            check(&random_spd::<3>(n, &mut rng), &mut rng)?;
            check(&random_spd::<4>(n, &mut rng), &mut rng)?;
        }

        /// The factors reproduce the pivots of the dense LDL^T (Schur
        /// complements), and a refactorization of fewer rows reuses them.
        #[test]
        fn pivots_are_the_dense_ones(n in 1usize..60, seed in 1u64..u64::MAX) {
            let mut rng = Rng(seed);
            let rows = random_spd::<3>(n, &mut rng);
            let mut a = dense(&rows);
            let mut ldl = Ldl::with_capacity(n);
            ldl.factor(rows.iter().copied()).unwrap();
            prop_assert_eq!(ldl.len(), n);
            for k in 0..n {
                let d = a[k * n + k];
                prop_assert!((ldl.pivot(k) - d).abs() < 1e-12 * d.abs().max(1.0), "pivot {k}");
                for i in k + 1..n {
                    let f = a[i * n + k] / d;
                    for j in k + 1..n {
                        a[i * n + j] -= f * a[k * n + j];
                    }
                }
            }
            ldl.factor(rows[..n / 2].iter().copied()).unwrap();
            prop_assert_eq!(ldl.len(), n / 2);
        }
    }

    /// An indefinite matrix fails at the row of its first non-positive pivot.
    #[test]
    fn an_indefinite_matrix_reports_its_row() {
        // [[2, 1, 0], [1, 2, 3], [0, 3, 1]]: pivots 2, 1.5, 1 - 9/1.5 = -5.
        let row = |diagonal: f64, p: f64, q: f64| Generators { diagonal, p: [p], q: [q], a: [0.0] };
        let rows = [row(2.0, 0.0, 1.0), row(2.0, 1.0, 3.0), row(1.0, 1.0, 0.0)];
        let mut ldl = Ldl::<1>::default();
        let err = ldl.factor(rows).unwrap_err();
        assert_eq!(err.row, 2);
        assert!((err.pivot + 5.0).abs() < 1e-12);
        let nan = [row(f64::NAN, 0.0, 0.0)];
        assert_eq!(ldl.factor(nan).unwrap_err().row, 0);
    }
}
