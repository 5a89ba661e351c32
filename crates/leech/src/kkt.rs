//! The equilibrium (KKT) linear system, solved in O(n) by bordering.
//!
//! Every Newton step of [`crate::statics`] solves
//!
//! ```text
//! [ H + delta I   J^T ] [ x ]   [ r ]
//! [ J             0   ] [ y ] = [ c ]
//! ```
//!
//! `J` is stored interleaved by coordinate (`dC_r/dq_i` at `i * 3 + r`), so
//! that one pass over the coordinates touches every border column.
//!
//! where `H` (n x n) is tridiagonal (springs, plus the diagonal gravity and
//! constraint-curvature terms), `J` has `m <= 3` dense rows and `delta >= 0` is
//! an inertia-correcting shift. With the LDL^T factorization of the tridiagonal
//! block and the Schur complement `S = J H^-1 J^T` (m x m),
//!
//! ```text
//! S y = J H^-1 r - c,      x = H^-1 r - (H^-1 J^T) y,
//! ```
//!
//! which costs `O(n m)`. By Sylvester's law of inertia the KKT matrix has
//! `neg(H) + pos(S)` negative eigenvalues; the equilibrium is a constrained
//! minimum (the reduced Hessian is positive definite on the null space of `J`)
//! exactly when that count is `m` and nothing is singular.

/// Largest number of constraint rows the bordered solver carries.
pub const MAX_CONSTRAINTS: usize = 3;

/// What the factorization found about the KKT matrix.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inertia {
    /// Reduced Hessian positive definite: a step towards a constrained minimum.
    Minimum,
    /// Reduced Hessian indefinite, with this many negative directions.
    Indefinite {
        /// Number of negative eigenvalues of the reduced Hessian.
        negative: usize,
    },
    /// A zero pivot in the tridiagonal block or a rank-deficient Schur complement.
    Singular,
}

/// Scratch space and factors for the bordered solve of one problem size.
#[derive(Clone, Debug, Default)]
pub struct Kkt {
    n: usize,
    m: usize,
    /// Reciprocals of the LDL^T pivots.
    pivots: Vec<f64>,
    multipliers: Vec<f64>,
    /// `H^-1 J^T`, interleaved: entry `(i, r)` at `i * MAX_CONSTRAINTS + r`.
    hinv_jt: Vec<f64>,
    /// Eigen-decomposition of the Schur complement `S = V diag(w) V^T`.
    schur_values: [f64; MAX_CONSTRAINTS],
    schur_vectors: [[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS],
    negative_pivots: usize,
}

impl Kkt {
    /// Scratch for `n` unknowns and `m` constraints.
    pub fn new(n: usize, m: usize) -> Kkt {
        assert!(m <= MAX_CONSTRAINTS, "at most {MAX_CONSTRAINTS} constraints");
        Kkt {
            n,
            m,
            pivots: vec![0.0; n],
            multipliers: vec![0.0; n],
            hinv_jt: vec![0.0; n * MAX_CONSTRAINTS],
            ..Kkt::default()
        }
    }

    /// Number of negative pivots of the tridiagonal block.
    pub fn negative_pivots(&self) -> usize {
        self.negative_pivots
    }

    /// Factors `H + shift I` (diagonal `diag`, off-diagonal `off`, `n - 1`
    /// entries) bordered by the constraint Jacobian `jac` (interleaved:
    /// `dC_r/dq_i` at `i * MAX_CONSTRAINTS + r`, rows `r >= m` zero) and reports
    /// the inertia. `tiny` is the pivot size under which the matrix counts as
    /// singular.
    pub fn factor(&mut self, diag: &[f64], off: &[f64], shift: f64, jac: &[f64], tiny: f64) -> Inertia {
        const M: usize = MAX_CONSTRAINTS;
        let (n, m) = (self.n, self.m);
        let mut negative = 0;
        let mut singular = false;
        // The factorization and the forward substitution of the border
        // columns share one pass; the columns are interleaved so that their
        // independent recurrences overlap in the pipeline.
        let z = &mut self.hinv_jt[..n * M];
        let (pivots, multipliers) = (&mut self.pivots[..n], &mut self.multipliers[..n]);
        let mut prev = [0.0; M];
        let mut mult_prev = 0.0;
        let mut off_prev = 0.0;
        for (i, (zi, ji)) in z.chunks_exact_mut(M).zip(jac.chunks_exact(M)).enumerate() {
            let d0 = diag[i] + shift - mult_prev * off_prev;
            let d = if d0.abs() > tiny {
                d0
            } else {
                // Keep the factors finite; the caller does not step with them.
                singular = true;
                if d0 < 0.0 {
                    -tiny
                } else {
                    tiny
                }
            };
            negative += usize::from(d < 0.0);
            let inv = 1.0 / d;
            pivots[i] = inv;
            for r in 0..M {
                prev[r] = ji[r] - mult_prev * prev[r];
                zi[r] = prev[r];
            }
            off_prev = if i + 1 < n { off[i] } else { 0.0 };
            mult_prev = off_prev * inv;
            multipliers[i] = mult_prev;
        }
        self.negative_pivots = negative;
        if singular {
            return Inertia::Singular;
        }
        if m == 0 {
            return if negative == 0 { Inertia::Minimum } else { Inertia::Indefinite { negative } };
        }
        // Back substitution, accumulating S = J H^-1 J^T on the way.
        let mut next = [0.0; M];
        let mut s = [[0.0; M]; M];
        for i in (0..n).rev() {
            let (zi, ji) = (&mut z[i * M..i * M + M], &jac[i * M..i * M + M]);
            for r in 0..M {
                next[r] = zi[r] * pivots[i] - multipliers[i] * next[r];
                zi[r] = next[r];
            }
            for a in 0..M {
                for b in 0..M {
                    s[a][b] += ji[a] * next[b];
                }
            }
        }
        for a in 0..m {
            for b in 0..a {
                let v = 0.5 * (s[a][b] + s[b][a]);
                s[a][b] = v;
                s[b][a] = v;
            }
        }
        let (w, v) = symmetric_eigen(s, m);
        self.schur_values = w;
        self.schur_vectors = v;
        let scale = w[..m].iter().fold(0.0f64, |acc, x| acc.max(x.abs()));
        if scale == 0.0 || w[..m].iter().any(|x| x.abs() <= 1e-13 * scale) {
            return Inertia::Singular;
        }
        let positive = w[..m].iter().filter(|x| **x > 0.0).count();
        let total_negative = negative + positive;
        if total_negative == m {
            Inertia::Minimum
        } else if total_negative > m {
            Inertia::Indefinite { negative: total_negative - m }
        } else {
            // Fewer negative eigenvalues than constraints cannot happen for a
            // full-rank J; treat it as numerically singular.
            Inertia::Singular
        }
    }

    /// Solves the factored system for right-hand sides `r` (n) and `c` (m),
    /// writing `x` (n) and `y` (m).
    pub fn solve(&self, jac: &[f64], r: &[f64], c: &[f64], x: &mut [f64], y: &mut [f64]) {
        const M: usize = MAX_CONSTRAINTS;
        let m = self.m;
        x.copy_from_slice(r);
        tridiagonal_solve_in_place(&self.pivots, &self.multipliers, x);
        if m == 0 {
            return;
        }
        let mut rhs = [0.0; M];
        for (xi, ji) in x.iter().zip(jac.chunks_exact(M)) {
            for row in 0..M {
                rhs[row] += ji[row] * xi;
            }
        }
        for row in 0..m {
            rhs[row] -= c[row];
        }
        // y = V diag(1/w) V^T rhs
        let mut t = [0.0; M];
        for k in 0..m {
            let mut acc = 0.0;
            for row in 0..m {
                acc += self.schur_vectors[row][k] * rhs[row];
            }
            t[k] = acc / self.schur_values[k];
        }
        let mut yy = [0.0; M];
        for row in 0..m {
            for k in 0..m {
                yy[row] += self.schur_vectors[row][k] * t[k];
            }
        }
        y[..m].copy_from_slice(&yy[..m]);
        for (xi, zi) in x.iter_mut().zip(self.hinv_jt.chunks_exact(M)) {
            *xi -= zi[0] * yy[0] + zi[1] * yy[1] + zi[2] * yy[2];
        }
    }
}

/// Solves `L D L^T x = b` in place for the tridiagonal factors (reciprocal pivots).
fn tridiagonal_solve_in_place(inv_pivots: &[f64], multipliers: &[f64], x: &mut [f64]) {
    let n = x.len();
    for i in 1..n {
        x[i] -= multipliers[i - 1] * x[i - 1];
    }
    for i in 0..n {
        x[i] *= inv_pivots[i];
    }
    for i in (0..n.saturating_sub(1)).rev() {
        x[i] -= multipliers[i] * x[i + 1];
    }
}

/// Eigenvalues and eigenvectors (columns) of the leading `m x m` block of a
/// symmetric matrix, by cyclic Jacobi rotations: robust for indefinite and
/// nearly singular matrices, and cheap for `m <= 3`.
fn symmetric_eigen(
    mut a: [[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS],
    m: usize,
) -> ([f64; MAX_CONSTRAINTS], [[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS]) {
    let mut v = [[0.0; MAX_CONSTRAINTS]; MAX_CONSTRAINTS];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _sweep in 0..50 {
        let mut off = 0.0;
        let mut diag = 0.0;
        for p in 0..m {
            diag += a[p][p] * a[p][p];
            for q in p + 1..m {
                off += a[p][q] * a[p][q];
            }
        }
        if off <= 1e-32 * diag || off == 0.0 {
            break;
        }
        for p in 0..m {
            for q in p + 1..m {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..m {
                    let (akp, akq) = (a[k][p], a[k][q]);
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..m {
                    let (apk, aqk) = (a[p][k], a[q][k]);
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for row in v.iter_mut().take(m) {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    let mut w = [0.0; MAX_CONSTRAINTS];
    for (i, wi) in w.iter_mut().enumerate().take(m) {
        *wi = a[i][i];
    }
    (w, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dense reference: builds the full KKT matrix and solves by Gaussian elimination.
    fn dense_solve(diag: &[f64], off: &[f64], jac: &[f64], m: usize, r: &[f64], c: &[f64]) -> Vec<f64> {
        let n = diag.len();
        let size = n + m;
        let mut a = vec![vec![0.0; size + 1]; size];
        for i in 0..n {
            a[i][i] = diag[i];
            if i + 1 < n {
                a[i][i + 1] = off[i];
                a[i + 1][i] = off[i];
            }
            a[i][size] = r[i];
        }
        for row in 0..m {
            for i in 0..n {
                a[n + row][i] = jac[i * MAX_CONSTRAINTS + row];
                a[i][n + row] = jac[i * MAX_CONSTRAINTS + row];
            }
            a[n + row][size] = c[row];
        }
        for col in 0..size {
            let piv = (col..size).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs())).unwrap();
            a.swap(col, piv);
            for row in 0..size {
                if row != col {
                    let f = a[row][col] / a[col][col];
                    for k in col..=size {
                        a[row][k] -= f * a[col][k];
                    }
                }
            }
        }
        (0..size).map(|i| a[i][size] / a[i][i]).collect()
    }

    #[test]
    fn bordered_solve_matches_dense_elimination() {
        let n = 7;
        let diag: Vec<f64> = (0..n).map(|i| 3.0 + (i as f64 * 0.7).sin()).collect();
        let off: Vec<f64> = (0..n - 1).map(|i| -1.0 + 0.3 * (i as f64).cos()).collect();
        let m = 3;
        let jac: Vec<f64> = (0..n * m).map(|i| ((i * 7 % 11) as f64 - 5.0) / 3.0).collect();
        assert_eq!(m, MAX_CONSTRAINTS);
        let r: Vec<f64> = (0..n).map(|i| (i as f64).cos()).collect();
        let c = [0.3, -0.2, 0.9];
        let mut kkt = Kkt::new(n, m);
        let inertia = kkt.factor(&diag, &off, 0.0, &jac, 1e-300);
        assert_eq!(inertia, Inertia::Minimum);
        let (mut x, mut y) = (vec![0.0; n], [0.0; 3]);
        kkt.solve(&jac, &r, &c, &mut x, &mut y);
        let reference = dense_solve(&diag, &off, &jac, m, &r, &c);
        for i in 0..n {
            assert!((x[i] - reference[i]).abs() < 1e-12, "x[{i}]");
        }
        for row in 0..m {
            assert!((y[row] - reference[n + row]).abs() < 1e-12, "y[{row}]");
        }
    }

    #[test]
    fn inertia_counts_negative_reduced_curvature() {
        // H = diag(1, -1, 1) with one constraint on the first coordinate:
        // the null space {x1 = 0} still contains the negative direction.
        let diag = [1.0, -1.0, 1.0];
        let off = [0.0, 0.0];
        let jac = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut kkt = Kkt::new(3, 1);
        assert_eq!(kkt.factor(&diag, &off, 0.0, &jac, 1e-300), Inertia::Indefinite { negative: 1 });
        // Constraining the negative coordinate instead leaves a minimum.
        let jac = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(kkt.factor(&diag, &off, 0.0, &jac, 1e-300), Inertia::Minimum);
        // Without constraints the shift restores positive definiteness.
        let mut free = Kkt::new(3, 0);
        let none = [0.0; 9];
        assert_eq!(free.factor(&diag, &off, 0.0, &none, 1e-300), Inertia::Indefinite { negative: 1 });
        assert_eq!(free.factor(&diag, &off, 2.0, &none, 1e-300), Inertia::Minimum);
    }

    #[test]
    fn jacobi_eigen_reconstructs_matrix() {
        let s = [[2.0, -1.0, 0.5], [-1.0, -3.0, 0.25], [0.5, 0.25, 1e-3]];
        let (w, v) = symmetric_eigen(s, 3);
        for i in 0..3 {
            for j in 0..3 {
                let rec: f64 = (0..3).map(|k| v[i][k] * w[k] * v[j][k]).sum();
                assert!((rec - s[i][j]).abs() < 1e-13);
            }
        }
    }
}
