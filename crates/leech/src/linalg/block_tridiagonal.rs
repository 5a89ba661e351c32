//! Chains of 3 x 3 blocks: the block-tridiagonal `L D L^T` bordered by `k`
//! rows, and its solve.
//!
//! Per block `j` of a chain, with `E = A_{j-1, j}` the coupling block above
//! the diagonal,
//!
//! ```text
//! L_j = E^T D_{j-1}^-1,   D_j = A_jj + shift I - L_j E,   W_j = B_j - L_j W_{j-1}.
//! ```
//!
//! A pivot block `D_j` may be indefinite, so its inertia comes from its own
//! Bunch-Kaufman factorization ([`super::dense_ldl`]), which also gives the
//! inverse (with the directions of zero pivots dropped). The 3 x 3 arithmetic
//! uses nalgebra's static matrices: unrolled, in registers, no allocation.

use nalgebra::{Matrix3, Vector3};

use super::bordered_ldl::{subtract_outer, SchurFactors, SparseFactors, SparseInput};
use super::dense_ldl::{self, Pivot, ALPHA};
use super::pattern::Sweep;
use super::{InertiaCount, Pattern, MAX_BORDER};

/// Entries per block.
const BLOCK: usize = 9;

// Element-wise copies: these 9 or 3 entries are too few for a call to memcpy.
fn load(values: &[f64], j: usize) -> Matrix3<f64> {
    let b = &values[j * BLOCK..][..BLOCK];
    Matrix3::new(b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7], b[8])
}

fn store(values: &mut [f64], j: usize, m: &Matrix3<f64>) {
    // Row-major, like the inputs.
    for (e, value) in values[j * BLOCK..][..BLOCK].iter_mut().enumerate() {
        *value = m[(e / 3, e % 3)];
    }
}

/// Inertia and (generalized) inverse of a symmetric pivot block, from its
/// Bunch-Kaufman factorization; only the lower triangle of `d` is read.
fn invert_pivot(d: &Matrix3<f64>, tiny: f64) -> (Matrix3<f64>, InertiaCount) {
    diagonal_pivots(d, tiny).unwrap_or_else(|| bunch_kaufman(d, tiny))
}

/// The factorization written out for the usual case of a dominant block, when
/// Bunch-Kaufman's rule takes the three diagonal pivots in order, without an
/// interchange; `None` otherwise.
fn diagonal_pivots(d: &Matrix3<f64>, tiny: f64) -> Option<(Matrix3<f64>, InertiaCount)> {
    let (a11, a21, a31, a22, a32, a33) = (d[(0, 0)], d[(1, 0)], d[(2, 0)], d[(1, 1)], d[(2, 1)], d[(2, 2)]);
    let accepted = |pivot: f64, below: f64| pivot.abs() > tiny && pivot.abs() >= ALPHA * below;
    if !accepted(a11, a21.abs().max(a31.abs())) {
        return None;
    }
    let (l21, l31) = (a21 / a11, a31 / a11);
    let (d2, b32) = (a22 - l21 * a21, a32 - l31 * a21);
    if !accepted(d2, b32.abs()) {
        return None;
    }
    let l32 = b32 / d2;
    let d3 = a33 - l31 * a31 - l32 * b32;
    if !accepted(d3, 0.0) {
        return None;
    }
    // A^-1 = L^-T D^-1 L^-1, with L^-1 of the unit lower triangular L in closed form.
    let l_inv = Matrix3::new(1.0, 0.0, 0.0, -l21, 1.0, 0.0, l21 * l32 - l31, -l32, 1.0);
    let inverse = l_inv.transpose() * Matrix3::from_diagonal(&Vector3::new(1.0 / a11, 1.0 / d2, 1.0 / d3)) * l_inv;
    let negative = [a11, d2, d3].iter().filter(|p| **p < 0.0).count();
    Some((inverse, InertiaCount { positive: 3 - negative, negative, zero: 0 }))
}

/// The general case: interchanges, 2 x 2 pivots or zero pivots.
fn bunch_kaufman(d: &Matrix3<f64>, tiny: f64) -> (Matrix3<f64>, InertiaCount) {
    // nalgebra stores by columns: entry (i, j) at j * 3 + i, the dense layout.
    let mut factors = [0.0; BLOCK];
    factors.copy_from_slice(d.as_slice());
    let mut pivots = [Pivot::default(); 3];
    let inertia = dense_ldl::factor_in_place(&mut factors, 3, &mut pivots, tiny);
    let mut inverse = Matrix3::identity();
    for mut column in inverse.column_iter_mut() {
        dense_ldl::solve_in_place(&factors, 3, &pivots, column.as_mut_slice());
    }
    (inverse, inertia)
}

/// The factorization pass: pivot blocks in the lanes, `W` three rows at a time.
struct Factor<'a> {
    input: &'a SparseInput<'a>,
    k: usize,
    factors: &'a mut SparseFactors,
}

#[derive(Clone, Copy, Default)]
struct FactorLane {
    /// `D^-1` of the lane's previous block.
    inv: Matrix3<f64>,
    inertia: InertiaCount,
}

impl Sweep for Factor<'_> {
    type Lane = FactorLane;

    #[inline(always)]
    fn step<const FRESH: bool>(&mut self, lane: &mut FactorLane, j: usize) {
        let input = self.input;
        let a = load(input.diag, j) + Matrix3::from_diagonal_element(input.shift);
        let (l, d) = if FRESH {
            (Matrix3::zeros(), a)
        } else {
            let e = load(input.off, j - 1);
            let l = e.transpose() * lane.inv;
            (l, a - l * e)
        };
        let (inv, inertia) = invert_pivot(&d, input.tiny);
        lane.inv = inv;
        lane.inertia += inertia;
        store(&mut self.factors.inv_pivots, j, &inv);
        store(&mut self.factors.multipliers, j, &l);
        let k = self.k;
        let rows = 3 * k;
        let border = &input.border[j * rows..(j + 1) * rows];
        if FRESH {
            self.factors.w[j * rows..(j + 1) * rows].copy_from_slice(border);
            return;
        }
        let (done, rest) = self.factors.w.split_at_mut(j * rows);
        let previous = &done[(j - 1) * rows..];
        for r in 0..k {
            let p = Vector3::new(previous[r], previous[k + r], previous[2 * k + r]);
            let w = l * p;
            for a in 0..3 {
                rest[a * k + r] = border[a * k + r] - w[a];
            }
        }
    }
}

/// Factors chains of 3 x 3 blocks and subtracts `W^T D^-1 W` from `schur`.
pub(super) fn factor(
    pattern: &Pattern,
    input: &SparseInput,
    factors: &mut SparseFactors,
    schur: &mut [f64],
) -> InertiaCount {
    let k = pattern.border_rows();
    let (mut lane0, mut lane1) = (FactorLane::default(), FactorLane::default());
    pattern.forward(&mut Factor { input, k, factors }, &mut lane0, &mut lane1);
    // S -= W_j^T V_j with V_j = D_j^-1 W_j, block by block.
    let mut v = [[0.0; MAX_BORDER]; 3];
    for j in 0..pattern.blocks() {
        let inv = load(&factors.inv_pivots, j);
        let rows: [&[f64]; 3] = std::array::from_fn(|a| &factors.w[(3 * j + a) * k..(3 * j + a + 1) * k]);
        for r in 0..k {
            let vr = inv * Vector3::new(rows[0][r], rows[1][r], rows[2][r]);
            for a in 0..3 {
                v[a][r] = vr[a];
            }
        }
        subtract_outer::<3>(schur, k, rows, &v);
    }
    lane0.inertia + lane1.inertia
}

fn block_of(values: &[f64], j: usize) -> Vector3<f64> {
    let b = &values[3 * j..][..3];
    Vector3::new(b[0], b[1], b[2])
}

fn set_block(values: &mut [f64], j: usize, v: &Vector3<f64>) {
    let b = &mut values[3 * j..][..3];
    (b[0], b[1], b[2]) = (v[0], v[1], v[2]);
}

/// Forward substitution `t = L^-1 r` into `x`.
struct Forward<'a> {
    r: &'a [f64],
    multipliers: &'a [f64],
    x: &'a mut [f64],
}

impl Sweep for Forward<'_> {
    type Lane = Vector3<f64>;

    #[inline(always)]
    fn step<const FRESH: bool>(&mut self, t: &mut Vector3<f64>, j: usize) {
        let r = block_of(self.r, j);
        *t = if FRESH { r } else { r - load(self.multipliers, j) * *t };
        set_block(self.x, j, t);
    }
}

/// Back substitution `x = L^-T D^-1 (t - W y)` over `t` held in `x`.
struct Backward<'a> {
    y: &'a [f64],
    factors: &'a SparseFactors,
    x: &'a mut [f64],
}

impl Sweep for Backward<'_> {
    type Lane = Vector3<f64>;

    #[inline(always)]
    fn step<const FRESH: bool>(&mut self, next: &mut Vector3<f64>, j: usize) {
        let (f, k) = (self.factors, self.y.len());
        let h = Vector3::from_fn(|a, _| {
            let row = &f.w[(3 * j + a) * k..(3 * j + a + 1) * k];
            self.x[3 * j + a] - row.iter().zip(self.y).map(|(w, y)| w * y).sum::<f64>()
        });
        *next = load(&f.inv_pivots, j) * h - load(&f.multipliers, j + 1).tr_mul(next);
        set_block(self.x, j, next);
    }
}

/// Solves with the factors of [`factor`].
pub(super) fn solve(
    pattern: &Pattern,
    factors: &SparseFactors,
    schur: &SchurFactors,
    r: &[f64],
    c: &[f64],
    x: &mut [f64],
    y: &mut [f64],
) {
    let k = c.len();
    let (mut t0, mut t1) = (Vector3::zeros(), Vector3::zeros());
    pattern.forward(&mut Forward { r, multipliers: &factors.multipliers, x }, &mut t0, &mut t1);
    // y = c - W^T D^-1 t, block by block.
    y.copy_from_slice(c);
    for j in 0..pattern.blocks() {
        let u = load(&factors.inv_pivots, j) * block_of(x, j);
        for a in 0..3 {
            for (yr, w) in y.iter_mut().zip(&factors.w[(3 * j + a) * k..(3 * j + a + 1) * k]) {
                *yr -= w * u[a];
            }
        }
    }
    schur.solve(y);
    let (mut next0, mut next1) = (Vector3::zeros(), Vector3::zeros());
    pattern.backward(&mut Backward { y, factors, x }, &mut next0, &mut next1);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pivot_blocks_inverted_with_their_inertia() {
        let cases = [
            // Dominant and indefinite: diagonal pivots in order.
            (Matrix3::new(4.0, 0.5, -0.3, 0.5, -5.0, 0.2, -0.3, 0.2, 3.0), (2, 1)),
            // Off-diagonal dominant: needs an interchange or a 2 x 2 pivot.
            (Matrix3::new(1e-3, 2.0, 0.0, 2.0, 1e-3, 1.0, 0.0, 1.0, -1.0), (1, 2)),
            (Matrix3::new(0.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 0.0), (1, 2)),
        ];
        for (d, (positive, negative)) in cases {
            let (inverse, inertia) = invert_pivot(&d, 1e-12);
            assert_eq!(inertia, InertiaCount { positive, negative, zero: 0 }, "{d}");
            assert!((inverse * d - Matrix3::identity()).amax() < 1e-12, "{d}");
            let (general, general_inertia) = bunch_kaufman(&d, 1e-12);
            assert_eq!(general_inertia, inertia);
            assert!((general - inverse).amax() < 1e-12);
        }
    }
}
