//! Symmetric indefinite `P A P^T = L D L^T` of a small dense matrix
//! (Bunch-Kaufman pivoting), with its inertia.
//!
//! `D` is block diagonal with 1 x 1 and 2 x 2 blocks, `L` unit lower
//! triangular, `P` a product of symmetric interchanges. Bunch and Kaufman's
//! partial pivoting (`alpha = (1 + sqrt 17) / 8`) bounds the growth of the
//! entries, so the factorization is stable for indefinite and nearly singular
//! matrices, and by Sylvester's law `inertia(A) = inertia(D)`. Every 2 x 2
//! pivot this rule picks has a negative determinant (one positive and one
//! negative eigenvalue).
//!
//! Storage: a `k x k` array whose entry `(i, j)`, `i >= j`, is at `j * k + i`
//! (the lower triangle by columns; for a symmetric matrix stored row- or
//! column-major that is all of it). The other triangle is neither read nor
//! written. Factoring overwrites the lower triangle with `L` (below the
//! diagonal) and `D`'s diagonal; [`Pivot`] records keep the interchanges and
//! `D^+`. Nothing is allocated.
//!
//! A pivot with `|d| <= tiny` counts as a zero eigenvalue; its reciprocal is
//! taken as 0, so the solve drops that direction instead of dividing by it.

use super::InertiaCount;

/// Bunch-Kaufman's threshold, which minimizes the bound on element growth.
pub(super) const ALPHA: f64 = 0.640_388_203_202_207_6;

/// Per row of the factorization: the interchange made before its step and its
/// row of `D^+` (block diagonal, so tridiagonal).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pivot {
    /// Row exchanged with this one (itself when none).
    swap: usize,
    /// Diagonal entry of `D^+`.
    inv_diag: f64,
    /// Entry of `D^+` coupling this row and the next (inside a 2 x 2 pivot).
    inv_next: f64,
}

/// Index of entry `(i, j)`, `i >= j`, of the lower triangle stored by columns.
#[inline(always)]
fn at(k: usize, i: usize, j: usize) -> usize {
    j * k + i
}

/// Factors the symmetric `k x k` matrix `a` in place (layout in the module
/// doc) and returns its inertia; `pivots` (at least `k`) receives the
/// interchanges and `D^+`. Pivots with `|d| <= tiny` count as zero.
///
/// # Panics
/// If `a` has fewer than `k * k` entries or `pivots` fewer than `k`.
#[inline]
pub fn factor_in_place(a: &mut [f64], k: usize, pivots: &mut [Pivot], tiny: f64) -> InertiaCount {
    assert!(a.len() >= k * k && pivots.len() >= k, "dense LDL^T: storage for {k} rows expected");
    let mut inertia = InertiaCount::default();
    let mut p = 0;
    while p < k {
        if choose_pivot(a, k, p, tiny, pivots) == 2 {
            inertia += eliminate_pair(a, k, p, tiny, pivots);
            p += 2;
        } else {
            inertia += eliminate_single(a, k, p, tiny, pivots);
            p += 1;
        }
    }
    inertia
}

/// Solves `A x = b` in place with the factors of [`factor_in_place`].
///
/// # Panics
/// If the slices are shorter than `k` rows need.
#[inline]
pub fn solve_in_place(factors: &[f64], k: usize, pivots: &[Pivot], b: &mut [f64]) {
    let b = &mut b[..k];
    for (p, pivot) in pivots[..k].iter().enumerate() {
        b.swap(p, pivot.swap);
    }
    for j in 0..k {
        let bj = b[j];
        let column = &factors[at(k, j + 1, j)..at(k, k, j)];
        for (bi, l) in b[j + 1..].iter_mut().zip(column) {
            *bi -= l * bj;
        }
    }
    // D^+ is symmetric tridiagonal: inv_next couples the two rows of a 2 x 2 pivot.
    let (mut previous, mut coupling) = (0.0, 0.0);
    for i in 0..k {
        let (bi, next) = (b[i], if i + 1 < k { b[i + 1] } else { 0.0 });
        b[i] = pivots[i].inv_diag * bi + pivots[i].inv_next * next + coupling * previous;
        (previous, coupling) = (bi, pivots[i].inv_next);
    }
    for j in (0..k).rev() {
        let column = &factors[at(k, j + 1, j)..at(k, k, j)];
        let dot: f64 = column.iter().zip(&b[j + 1..]).map(|(l, x)| l * x).sum();
        b[j] -= dot;
    }
    for (p, pivot) in pivots[..k].iter().enumerate().rev() {
        b.swap(p, pivot.swap);
    }
}

/// Reusable storage for factoring and solving small symmetric systems of up
/// to a fixed number of rows without allocating.
#[derive(Clone, Debug, Default)]
pub struct DenseLdl {
    factors: Vec<f64>,
    pivots: Vec<Pivot>,
    rows: usize,
}

impl DenseLdl {
    /// Storage for matrices of up to `max_rows` rows.
    pub fn new(max_rows: usize) -> DenseLdl {
        DenseLdl { factors: vec![0.0; max_rows * max_rows], pivots: vec![Pivot::default(); max_rows], rows: 0 }
    }

    /// Rows of the matrix last factored.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Factors the symmetric `k x k` matrix `a` (entry `(i, j)`, `i >= j`, at
    /// `j * k + i`, the rest ignored) and returns its inertia.
    ///
    /// # Panics
    /// If `k` exceeds the capacity or `a` has fewer than `k * k` entries.
    pub fn factor(&mut self, a: &[f64], k: usize, tiny: f64) -> InertiaCount {
        assert!(k <= self.pivots.len(), "dense LDL^T: {k} rows exceed the capacity {}", self.pivots.len());
        self.factors[..k * k].copy_from_slice(&a[..k * k]);
        self.rows = k;
        factor_in_place(&mut self.factors[..k * k], k, &mut self.pivots, tiny)
    }

    /// Solves with the last factors: `b` (at least `rows()` entries) is
    /// overwritten by the solution.
    pub fn solve_in_place(&self, b: &mut [f64]) {
        let k = self.rows;
        solve_in_place(&self.factors[..k * k], k, &self.pivots, b);
    }
}

/// Solves the small symmetric system `S x = b` (`s` is `k x k`, layout as in
/// [`DenseLdl::factor`]) in place in `b`, with caller-provided scratch, and
/// returns the inertia of `S`. Pivots with `|d| <= tiny` count as zero and the
/// solve drops their directions.
pub fn solve_symmetric(s: &[f64], k: usize, b: &mut [f64], scratch: &mut DenseLdl, tiny: f64) -> InertiaCount {
    let inertia = scratch.factor(s, k, tiny);
    scratch.solve_in_place(b);
    inertia
}

/// Picks the pivot for step `p` by Bunch-Kaufman's rule, makes the symmetric
/// interchange it needs, and returns the pivot's size (1 or 2).
#[inline]
fn choose_pivot(a: &mut [f64], k: usize, p: usize, tiny: f64, pivots: &mut [Pivot]) -> usize {
    pivots[p].swap = p;
    // Largest entry below the diagonal in column p, and its row.
    let (mut lambda, mut r) = (0.0, p);
    for i in p + 1..k {
        if a[at(k, i, p)].abs() > lambda {
            (lambda, r) = (a[at(k, i, p)].abs(), i);
        }
    }
    let app = a[at(k, p, p)].abs();
    // A column that is zero to within tiny needs no interchange: it is dropped.
    if app.max(lambda) <= tiny || app >= ALPHA * lambda {
        return 1;
    }
    // Largest off-diagonal entry in row/column r of the active part.
    let mut sigma = 0.0f64;
    for i in p..k {
        if i != r {
            let index = if i < r { at(k, r, i) } else { at(k, i, r) };
            sigma = sigma.max(a[index].abs());
        }
    }
    if app * sigma >= ALPHA * lambda * lambda {
        1
    } else if a[at(k, r, r)].abs() >= ALPHA * sigma {
        swap_symmetric(a, k, p, r);
        pivots[p].swap = r;
        1
    } else {
        swap_symmetric(a, k, p + 1, r);
        pivots[p + 1].swap = r;
        2
    }
}

/// Exchanges rows and columns `i < j` of the lower triangle, including the
/// rows of `L` already computed (columns before `i`).
#[inline]
fn swap_symmetric(a: &mut [f64], k: usize, i: usize, j: usize) {
    if i == j {
        return;
    }
    for c in 0..i {
        a.swap(at(k, i, c), at(k, j, c));
    }
    a.swap(at(k, i, i), at(k, j, j));
    for c in i + 1..j {
        a.swap(at(k, c, i), at(k, j, c));
    }
    for row in j + 1..k {
        a.swap(at(k, row, i), at(k, row, j));
    }
}

/// Sign of one pivot (or eigenvalue of a 2 x 2 pivot) and its reciprocal, 0
/// when it counts as zero. NaN counts as zero.
#[inline]
fn classify(d: f64, tiny: f64) -> (InertiaCount, f64) {
    if !(d.abs() > tiny) {
        (InertiaCount { zero: 1, ..InertiaCount::default() }, 0.0)
    } else if d > 0.0 {
        (InertiaCount { positive: 1, ..InertiaCount::default() }, 1.0 / d)
    } else {
        (InertiaCount { negative: 1, ..InertiaCount::default() }, 1.0 / d)
    }
}

/// Eliminates with the 1 x 1 pivot at `p`: multipliers into column `p`,
/// rank-one update of the trailing lower triangle, column by column.
#[inline]
fn eliminate_single(a: &mut [f64], k: usize, p: usize, tiny: f64, pivots: &mut [Pivot]) -> InertiaCount {
    let (count, inv) = classify(a[at(k, p, p)], tiny);
    pivots[p].inv_diag = inv;
    pivots[p].inv_next = 0.0;
    let (left, right) = a.split_at_mut(at(k, 0, p + 1));
    let column = &mut left[at(k, p + 1, p)..];
    if inv == 0.0 {
        // The pivot rule only lets a zero pivot through when its whole
        // column is within tiny of zero: dropping it is that small a change.
        column.fill(0.0);
        return count;
    }
    for j in p + 1..k {
        let factor = column[j - p - 1] * inv;
        let target = &mut right[at(k, j, j - p - 1)..at(k, k, j - p - 1)];
        for (x, s) in target.iter_mut().zip(&column[j - p - 1..]) {
            *x -= factor * s;
        }
    }
    for x in column {
        *x *= inv;
    }
    count
}

/// Eliminates with the 2 x 2 pivot at rows `p, p + 1`: multipliers into
/// columns `p` and `p + 1`, rank-two update of the trailing lower triangle.
#[inline]
fn eliminate_pair(a: &mut [f64], k: usize, p: usize, tiny: f64, pivots: &mut [Pivot]) -> InertiaCount {
    let (d11, d21, d22) = (a[at(k, p, p)], a[at(k, p + 1, p)], a[at(k, p + 1, p + 1)]);
    // The rule guarantees det <= -(1 - ALPHA^2) d21^2 < 0: the inverse is safe.
    let det = d11 * d22 - d21 * d21;
    let (e11, e21, e22) = (d22 / det, -d21 / det, d11 / det);
    pivots[p].inv_diag = e11;
    pivots[p].inv_next = e21;
    pivots[p + 1].inv_diag = e22;
    pivots[p + 1].inv_next = 0.0;
    let mean = 0.5 * (d11 + d22);
    let radius = (0.5 * (d11 - d22)).hypot(d21);
    let count = classify(mean + radius, tiny).0 + classify(mean - radius, tiny).0;
    a[at(k, p + 1, p)] = 0.0;
    let (left, right) = a.split_at_mut(at(k, 0, p + 2));
    let (first, second) = left[at(k, 0, p)..].split_at_mut(k);
    let (first, second) = (&mut first[p + 2..], &mut second[p + 2..]);
    for j in p + 2..k {
        let (u, v) = (first[j - p - 2], second[j - p - 2]);
        let (lu, lv) = (u * e11 + v * e21, u * e21 + v * e22);
        let target = &mut right[at(k, j, j - p - 2)..at(k, k, j - p - 2)];
        for ((x, s), t) in target.iter_mut().zip(&first[j - p - 2..]).zip(&second[j - p - 2..]) {
            *x -= lu * s + lv * t;
        }
    }
    for (u, v) in first.iter_mut().zip(second.iter_mut()) {
        (*u, *v) = (*u * e11 + *v * e21, *u * e21 + *v * e22);
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inertia(positive: usize, negative: usize, zero: usize) -> InertiaCount {
        InertiaCount { positive, negative, zero }
    }

    #[test]
    fn zero_diagonal_takes_a_two_by_two_pivot() {
        // [[0, 2], [2, 0]]: no usable 1 x 1 pivot; eigenvalues +-2.
        let mut a = [0.0, 2.0, 2.0, 0.0];
        let mut pivots = [Pivot::default(); 2];
        assert_eq!(factor_in_place(&mut a, 2, &mut pivots, 0.0), inertia(1, 1, 0));
        let mut b = [4.0, 6.0];
        solve_in_place(&a, 2, &pivots, &mut b);
        assert_eq!(b, [3.0, 2.0]);
    }

    #[test]
    fn interchange_brings_the_large_diagonal_forward() {
        // Column 0 is dominated by a21 = 1, and a22 = 10 is a safe 1 x 1 pivot.
        let s = [1e-3, 1.0, 0.0, 1.0, 10.0, 0.5, 0.0, 0.5, -2.0];
        let mut scratch = DenseLdl::new(3);
        let mut b = [1.0, 2.0, 3.0];
        assert_eq!(solve_symmetric(&s, 3, &mut b, &mut scratch, 0.0), inertia(1, 2, 0));
        for i in 0..3 {
            let row: f64 = (0..3).map(|j| s[i * 3 + j] * b[j]).sum();
            assert!((row - [1.0, 2.0, 3.0][i]).abs() < 1e-13, "row {i}: {row}");
        }
    }

    #[test]
    fn singular_matrices_count_zeros_and_solve_finitely() {
        let mut scratch = DenseLdl::new(4);
        assert_eq!(scratch.factor(&[0.0; 9], 3, 0.0), inertia(0, 0, 3));
        // Rank one: v v^T with v = (1, 2, -1).
        let v = [1.0, 2.0, -1.0];
        let a: Vec<f64> = (0..9).map(|e| v[e / 3] * v[e % 3]).collect();
        assert_eq!(scratch.factor(&a, 3, 1e-12), inertia(1, 0, 2));
        let mut b = [1.0, 2.0, -1.0];
        scratch.solve_in_place(&mut b);
        assert!(b.iter().all(|x| x.is_finite()));
        assert_eq!(scratch.rows(), 3);
    }
}
