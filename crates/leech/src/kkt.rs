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
    /// Factors of the Schur complement `S = J H^-1 J^T`.
    schur: Schur,
    negative_pivots: usize,
    /// Where the second independent block starts (`n` for one block).
    split: usize,
}

impl Kkt {
    /// Scratch for `n` unknowns and `m` constraints whose tridiagonal block
    /// splits into two independent blocks at `split` (the off-diagonal entry
    /// `split - 1` is zero); with `split = n` (or 0) it is one block. A split
    /// whose coupling entry is not zero at factor time is ignored.
    pub fn with_blocks(n: usize, m: usize, split: usize) -> Kkt {
        let mut kkt = Kkt::new(n, m);
        kkt.split = if split == 0 { n } else { split.min(n) };
        kkt
    }

    fn split_for(&mut self, off: &[f64]) -> usize {
        if self.split < self.n && off[self.split - 1] != 0.0 {
            self.split = self.n;
        }
        self.split
    }

    /// Scratch for `n` unknowns and `m` constraints.
    pub fn new(n: usize, m: usize) -> Kkt {
        assert!(m <= MAX_CONSTRAINTS, "at most {MAX_CONSTRAINTS} constraints");
        Kkt {
            n,
            m,
            pivots: vec![0.0; n],
            multipliers: vec![0.0; n],
            hinv_jt: vec![0.0; n * MAX_CONSTRAINTS],
            split: n,
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
        let split = self.split_for(off);
        let mut singular = false;
        // The factorization and the forward substitution of the border
        // columns share one pass. The columns are interleaved and the two
        // independent blocks walked side by side, so that their serial
        // recurrences overlap in the pipeline.
        let z = &mut self.hinv_jt[..n * M];
        let (pivots, multipliers) = (&mut self.pivots[..n], &mut self.multipliers[..n]);
        let mut lanes = [Forward::default(), Forward::default()];
        let (first, second) = (split, n - split);
        for i in 0..first.max(second) {
            // Two separately named lanes stay in registers; indexing one array
            // by lane would serialize them through memory.
            let [lane0, lane1] = &mut lanes;
            if i < first {
                let ok = lane0.step(i, diag[i] + shift, off, &jac[i * M..i * M + M], tiny, pivots, multipliers, z);
                singular |= !ok;
            }
            if i < second {
                let j = split + i;
                let ok = lane1.step(j, diag[j] + shift, off, &jac[j * M..j * M + M], tiny, pivots, multipliers, z);
                singular |= !ok;
            }
        }
        let negative = lanes[0].negative + lanes[1].negative;
        self.negative_pivots = negative;
        if singular {
            return Inertia::Singular;
        }
        if m == 0 {
            return if negative == 0 { Inertia::Minimum } else { Inertia::Indefinite { negative } };
        }
        // Back substitution, accumulating S = J H^-1 J^T on the way.
        let (mut back0, mut back1) = (Backward::default(), Backward::default());
        let (first, second) = (split, n - split);
        for i in 0..first.max(second) {
            if i < first {
                let j = split - 1 - i;
                back0.step(pivots[j], multipliers[j], &jac[j * M..j * M + M], &mut z[j * M..j * M + M]);
            }
            if i < second {
                let j = n - 1 - i;
                back1.step(pivots[j], multipliers[j], &jac[j * M..j * M + M], &mut z[j * M..j * M + M]);
            }
        }
        let mut s = back0.schur;
        for a in 0..M {
            for b in 0..M {
                s[a][b] += back1.schur[a][b];
            }
        }
        for a in 0..m {
            for b in 0..a {
                let v = 0.5 * (s[a][b] + s[b][a]);
                s[a][b] = v;
                s[b][a] = v;
            }
        }
        self.schur = Schur::factor(s, m);
        let Some(positive) = self.schur.positive(m) else {
            return Inertia::Singular;
        };
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
        let split = self.split.min(self.n);
        tridiagonal_solve_in_place(&self.pivots, &self.multipliers, split, x);
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
        let yy = self.schur.solve(rhs, m);
        y[..m].copy_from_slice(&yy[..m]);
        for (xi, zi) in x.iter_mut().zip(self.hinv_jt.chunks_exact(M)) {
            *xi -= zi[0] * yy[0] + zi[1] * yy[1] + zi[2] * yy[2];
        }
    }
}

/// Solves `L D L^T x = b` in place for the tridiagonal factors (reciprocal
/// pivots), walking the blocks `[0, split)` and `[split, n)` side by side.
fn tridiagonal_solve_in_place(inv_pivots: &[f64], multipliers: &[f64], split: usize, x: &mut [f64]) {
    let n = x.len();
    let (first, second) = (split, n - split);
    let (mut carry0, mut carry1) = (0.0, 0.0);
    for i in 0..first.max(second) {
        if i < first {
            x[i] -= carry0;
            carry0 = multipliers[i] * x[i];
        }
        if i < second {
            let j = split + i;
            x[j] -= carry1;
            carry1 = multipliers[j] * x[j];
        }
    }
    let (mut next0, mut next1) = (0.0, 0.0);
    for i in 0..first.max(second) {
        if i < first {
            let j = split - 1 - i;
            x[j] = x[j] * inv_pivots[j] - multipliers[j] * next0;
            next0 = x[j];
        }
        if i < second {
            let j = n - 1 - i;
            x[j] = x[j] * inv_pivots[j] - multipliers[j] * next1;
            next1 = x[j];
        }
    }
}

/// One lane of the forward pass: the LDL^T recurrence and the forward
/// substitution of the border columns.
#[derive(Clone, Copy, Default)]
struct Forward {
    prev: [f64; MAX_CONSTRAINTS],
    mult: f64,
    off: f64,
    negative: usize,
}

impl Forward {
    /// Processes row `i` with shifted diagonal `a`; false on a tiny pivot.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        i: usize,
        a: f64,
        off: &[f64],
        jac: &[f64],
        tiny: f64,
        pivots: &mut [f64],
        multipliers: &mut [f64],
        z: &mut [f64],
    ) -> bool {
        const M: usize = MAX_CONSTRAINTS;
        let d0 = a - self.mult * self.off;
        let ok = d0.abs() > tiny;
        // Keep the factors finite on a tiny pivot; the caller does not step with them.
        let d = if ok {
            d0
        } else if d0 < 0.0 {
            -tiny
        } else {
            tiny
        };
        self.negative += usize::from(d < 0.0);
        let inv = 1.0 / d;
        pivots[i] = inv;
        for r in 0..M {
            self.prev[r] = jac[r] - self.mult * self.prev[r];
            z[i * M + r] = self.prev[r];
        }
        self.off = if i < off.len() { off[i] } else { 0.0 };
        self.mult = self.off * inv;
        multipliers[i] = self.mult;
        ok
    }
}

/// One lane of the back substitution, accumulating its share of `J H^-1 J^T`.
#[derive(Clone, Copy, Default)]
struct Backward {
    next: [f64; MAX_CONSTRAINTS],
    schur: [[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS],
}

impl Backward {
    #[inline(always)]
    fn step(&mut self, inv_pivot: f64, multiplier: f64, jac: &[f64], z: &mut [f64]) {
        for r in 0..MAX_CONSTRAINTS {
            self.next[r] = z[r] * inv_pivot - multiplier * self.next[r];
            z[r] = self.next[r];
        }
        for a in 0..MAX_CONSTRAINTS {
            for b in 0..MAX_CONSTRAINTS {
                self.schur[a][b] += jac[a] * self.next[b];
            }
        }
    }
}

/// Factors of the small Schur complement: `L D L^T` without pivoting when
/// its pivots are safely away from zero (the usual case, a few flops), an
/// eigen-decomposition otherwise (robust when `S` is indefinite or nearly
/// singular). Both give the inertia by Sylvester's law.
#[derive(Clone, Copy, Debug)]
enum Schur {
    Ldl { l: [[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS], d: [f64; MAX_CONSTRAINTS] },
    Eigen { w: [f64; MAX_CONSTRAINTS], v: [[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS] },
}

impl Default for Schur {
    fn default() -> Self {
        Schur::Eigen { w: [1.0; MAX_CONSTRAINTS], v: [[0.0; MAX_CONSTRAINTS]; MAX_CONSTRAINTS] }
    }
}

impl Schur {
    fn factor(s: [[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS], m: usize) -> Schur {
        let mut l = [[0.0; MAX_CONSTRAINTS]; MAX_CONSTRAINTS];
        let mut d = [0.0; MAX_CONSTRAINTS];
        let mut safe = true;
        for j in 0..m {
            let mut dj = s[j][j];
            for k in 0..j {
                dj -= l[j][k] * l[j][k] * d[k];
            }
            // A pivot that lost most of its diagonal to cancellation is not trusted.
            safe &= dj.abs() > 1e-8 * s[j][j].abs() && dj != 0.0;
            d[j] = dj;
            for i in j + 1..m {
                let mut v = s[i][j];
                for k in 0..j {
                    v -= l[i][k] * l[j][k] * d[k];
                }
                l[i][j] = v / dj;
            }
        }
        if safe {
            Schur::Ldl { l, d }
        } else {
            let (w, v) = symmetric_eigen(s, m);
            Schur::Eigen { w, v }
        }
    }

    /// Number of positive eigenvalues, or `None` when `S` is numerically singular.
    fn positive(&self, m: usize) -> Option<usize> {
        let values = match self {
            Schur::Ldl { d, .. } => d,
            Schur::Eigen { w, .. } => w,
        };
        let scale = values[..m].iter().fold(0.0f64, |acc, x| acc.max(x.abs()));
        if scale == 0.0 || values[..m].iter().any(|x| x.abs() <= 1e-13 * scale) {
            return None;
        }
        Some(values[..m].iter().filter(|x| **x > 0.0).count())
    }

    fn solve(&self, rhs: [f64; MAX_CONSTRAINTS], m: usize) -> [f64; MAX_CONSTRAINTS] {
        let mut y = [0.0; MAX_CONSTRAINTS];
        match self {
            Schur::Ldl { l, d } => {
                for i in 0..m {
                    y[i] = rhs[i] - (0..i).map(|k| l[i][k] * y[k]).sum::<f64>();
                }
                for i in 0..m {
                    y[i] /= d[i];
                }
                for i in (0..m).rev() {
                    y[i] -= (i + 1..m).map(|k| l[k][i] * y[k]).sum::<f64>();
                }
            }
            Schur::Eigen { w, v } => {
                // y = V diag(1/w) V^T rhs
                for k in 0..m {
                    let t = (0..m).map(|row| v[row][k] * rhs[row]).sum::<f64>() / w[k];
                    for row in 0..m {
                        y[row] += v[row][k] * t;
                    }
                }
            }
        }
        y
    }
}

/// Solves the small symmetric system `S x = b` (leading `m x m` block) with
/// the same factorization the KKT solve uses for its Schur complement.
pub(crate) fn solve_small_symmetric(
    s: &[[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS],
    b: [f64; MAX_CONSTRAINTS],
    m: usize,
) -> [f64; MAX_CONSTRAINTS] {
    Schur::factor(*s, m).solve(b, m)
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
    fn two_block_solve_matches_dense_elimination() {
        let n = 9;
        let diag: Vec<f64> = (0..n).map(|i| 2.5 + (i as f64 * 1.3).cos()).collect();
        let mut off: Vec<f64> = (0..n - 1).map(|i| -0.8 + 0.2 * (i as f64).sin()).collect();
        for split in [4, 5, 1, 8] {
            off[split - 1] = 0.0;
            let jac: Vec<f64> = (0..n * 3).map(|i| ((i * 5 % 13) as f64 - 6.0) / 4.0).collect();
            let r: Vec<f64> = (0..n).map(|i| (i as f64 * 0.4).sin()).collect();
            let c = [0.1, 0.7, -0.4];
            let mut kkt = Kkt::with_blocks(n, 3, split);
            kkt.factor(&diag, &off, 0.0, &jac, 1e-300);
            let (mut x, mut y) = (vec![0.0; n], [0.0; 3]);
            kkt.solve(&jac, &r, &c, &mut x, &mut y);
            let reference = dense_solve(&diag, &off, &jac, 3, &r, &c);
            for i in 0..n {
                assert!((x[i] - reference[i]).abs() < 1e-12, "split {split}, x[{i}]");
            }
            for row in 0..3 {
                assert!((y[row] - reference[n + row]).abs() < 1e-12, "split {split}, y[{row}]");
            }
            off[split - 1] = -0.5;
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
