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
//!
//! `W_j` holds only the border rows present at block `j` or before it in its
//! chain ([`Pattern::set_border_start`]): a row zero on a chain's blocks
//! before `j0` has `W_j = 0` there, since the recurrence only carries
//! entries forward. Ordered by first block, the rows present form a prefix
//! of the chain's rows, `m_j` of them; each chain adds its
//! `sum_j W_j^T D_j^-1 W_j` (`3 m_j (m_j + 1) / 2` products per block
//! instead of `3 k (k + 1) / 2`) to a scratch in its own row order, then to
//! `S`. Runs of blocks with the same `m_j` are computed at a width fixed at
//! compile time (the next of [`WIDTHS`], the extra columns zero).

use std::ops::Range;

use nalgebra::{Matrix3, Vector3};

use super::bordered_ldl::{SchurFactors, SparseFactors, SparseInput};
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
    // Reciprocals once: they are D^-1, and products replace the divisions
    // on the recurrence's critical path.
    let p1 = 1.0 / a11;
    let (l21, l31) = (a21 * p1, a31 * p1);
    let (d2, b32) = (a22 - l21 * a21, a32 - l31 * a21);
    if !accepted(d2, b32.abs()) {
        return None;
    }
    let p2 = 1.0 / d2;
    let l32 = b32 * p2;
    let d3 = a33 - l31 * a31 - l32 * b32;
    if !accepted(d3, 0.0) {
        return None;
    }
    let p3 = 1.0 / d3;
    // A^-1 = L^-T D^-1 L^-1 entry by entry, with the unit lower triangular
    // L^-1 = [1 0 0; x 1 0; y z 1] in closed form.
    let (x, y, z) = (-l21, l21 * l32 - l31, -l32);
    let (i21, i31, i32) = (x * p2 + y * z * p3, y * p3, z * p3);
    let inverse = Matrix3::new(p1 + x * x * p2 + y * y * p3, i21, i31, i21, p2 + z * z * p3, i32, i31, i32, p3);
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

/// Which border rows each chain carries, from the pattern's
/// [`Pattern::set_border_start`]: per chain its rows in the order of their
/// first block, so that the rows present at any block are a prefix.
#[derive(Clone, Debug)]
pub(super) struct Layout {
    /// Chain `c`'s rows at `c * MAX_BORDER ..`, ordered by first block.
    rows: Vec<usize>,
    /// Each of those rows' first block (numbered over all chains).
    starts: Vec<usize>,
    /// Rows per chain (those nonzero somewhere on it).
    counts: Vec<usize>,
}

/// The layout and the scratch of one chain's part of `W^T D^-1 W`.
#[derive(Clone, Debug)]
pub(super) struct Profile {
    layout: Layout,
    /// In the chain's row order, lower triangle, rows of `stride` entries.
    local: Vec<f64>,
    stride: usize,
}

/// The run widths the kernels are compiled for: a run carrying `m` rows is
/// computed `padded(m)` wide, the extra columns zero.
const WIDTHS: [usize; 10] = [0, 3, 6, 9, 12, 16, 24, 32, 48, MAX_BORDER];

fn padded(m: usize) -> usize {
    WIDTHS.into_iter().find(|w| *w >= m).unwrap_or(MAX_BORDER)
}

impl Profile {
    /// The layout of `pattern` (chains of 3 x 3 blocks) and scratch for up to
    /// `capacity` border rows; empty for scalar blocks, which do not use it.
    pub fn new(pattern: &Pattern, capacity: usize) -> Profile {
        let (chains, capacity) = if pattern.block_size() == 3 { (pattern.chains(), capacity) } else { (0, 0) };
        let stride = padded(capacity);
        let layout = Layout {
            rows: vec![0; chains * MAX_BORDER],
            starts: vec![0; chains * MAX_BORDER],
            counts: vec![0; chains],
        };
        let mut profile = Profile { layout, local: vec![0.0; stride * stride], stride };
        profile.update(pattern);
        profile
    }

    /// Reads the pattern's border starts again, for its current number of
    /// border rows (after [`Pattern::set_border_rows`]).
    pub fn update(&mut self, pattern: &Pattern) {
        if pattern.block_size() == 3 {
            self.layout.update(pattern);
        }
    }
}

impl Layout {
    /// Reads the pattern's border starts (for its current number of rows).
    fn update(&mut self, pattern: &Pattern) {
        for c in 0..pattern.chains() {
            let blocks = pattern.chain_blocks(c);
            let (rows, starts) = (&mut self.rows[c * MAX_BORDER..], &mut self.starts[c * MAX_BORDER..]);
            let mut count = 0;
            for r in 0..pattern.border_rows() {
                let first = pattern.border_start(c, r);
                if first < blocks.len() {
                    // Insertion in order of first block, ties by row.
                    let at = starts[..count].partition_point(|s| *s <= blocks.start + first);
                    rows.copy_within(at..count, at + 1);
                    starts.copy_within(at..count, at + 1);
                    (rows[at], starts[at]) = (r, blocks.start + first);
                    count += 1;
                }
            }
            self.counts[c] = count;
        }
    }

    /// Chain `c`'s rows in their order.
    fn rows(&self, c: usize) -> &[usize] {
        &self.rows[c * MAX_BORDER..c * MAX_BORDER + self.counts[c]]
    }

    /// Chain `c`'s blocks cut into runs that carry the same rows: each run's
    /// blocks and how many of [`Layout::rows`] (a prefix) they carry.
    fn runs(&self, c: usize, blocks: Range<usize>) -> impl Iterator<Item = (Range<usize>, usize)> + '_ {
        let starts = &self.starts[c * MAX_BORDER..c * MAX_BORDER + self.counts[c]];
        let (mut at, end) = (blocks.start, blocks.end);
        std::iter::from_fn(move || {
            if at >= end {
                return None;
            }
            let present = starts.partition_point(|s| *s <= at);
            let next = starts.get(present).map_or(end, |s| (*s).min(end));
            let run = at..next;
            at = next;
            Some((run, present))
        })
    }
}

/// The factorization of one chain, run by run.
struct ChainFactor<'a> {
    input: &'a SparseInput<'a>,
    k: usize,
    factors: &'a mut SparseFactors,
    rows: &'a [usize],
    local: &'a mut [f64],
    stride: usize,
    /// `D^-1` of the previous block; `None` at the chain's first.
    inv: Option<Matrix3<f64>>,
    /// Rows carried by the previous block.
    width: usize,
    inertia: InertiaCount,
}

impl ChainFactor<'_> {
    /// Blocks `blocks` carrying the first `m` of the chain's rows, computed
    /// `M >= m` wide (the columns past `m` stay zero): pivots, multipliers,
    /// `W_j` (3 x m, row `a` at `3 k j + k a`) and `W_j^T D_j^-1 W_j` added
    /// to `local`. A width known to the compiler keeps `W_j` in registers.
    fn run<const M: usize>(&mut self, blocks: Range<usize>, m: usize) {
        let (input, k, stride) = (self.input, self.k, self.stride);
        let rows = 3 * k;
        let mut previous = [[0.0; M]; 3];
        if self.inv.is_some() {
            let w = &self.factors.w[(blocks.start - 1) * rows..];
            for (a, p) in previous.iter_mut().enumerate() {
                p[..self.width].copy_from_slice(&w[a * k..a * k + self.width]);
            }
        }
        for j in blocks {
            let a = load(input.diag, j) + Matrix3::from_diagonal_element(input.shift);
            let (l, d) = match self.inv {
                None => (Matrix3::zeros(), a),
                Some(inv) => {
                    let e = load(input.off, j - 1);
                    let l = e.transpose() * inv;
                    (l, a - l * e)
                }
            };
            let (inv, inertia) = invert_pivot(&d, input.tiny);
            store(&mut self.factors.inv_pivots, j, &inv);
            store(&mut self.factors.multipliers, j, &l);
            // W_j = B_j - L_j W_{j-1} and V_j = D_j^-1 W_j on the rows present.
            let border = &input.border[j * rows..(j + 1) * rows];
            let w: [[f64; M]; 3] = std::array::from_fn(|a| {
                std::array::from_fn(|c| {
                    let b = if c < m { border[a * k + self.rows[c]] } else { 0.0 };
                    b - (l[(a, 0)] * previous[0][c] + l[(a, 1)] * previous[1][c] + l[(a, 2)] * previous[2][c])
                })
            });
            let v: [[f64; M]; 3] = std::array::from_fn(|a| {
                std::array::from_fn(|c| inv[(a, 0)] * w[0][c] + inv[(a, 1)] * w[1][c] + inv[(a, 2)] * w[2][c])
            });
            for c1 in 0..M {
                let target = &mut self.local[c1 * stride..c1 * stride + c1 + 1];
                for (c2, x) in target.iter_mut().enumerate() {
                    *x += w[0][c1] * v[0][c2] + w[1][c1] * v[1][c2] + w[2][c1] * v[2][c2];
                }
            }
            let out = &mut self.factors.w[j * rows..(j + 1) * rows];
            for (a, row) in w.iter().enumerate() {
                out[a * k..a * k + m].copy_from_slice(&row[..m]);
            }
            previous = w;
            self.inv = Some(inv);
            self.inertia += inertia;
        }
        self.width = m;
    }
}

/// Factors chains of 3 x 3 blocks and subtracts `W^T D^-1 W` from `schur`,
/// chain by chain, on the border rows each chain carries.
pub(super) fn factor(
    pattern: &Pattern,
    input: &SparseInput,
    factors: &mut SparseFactors,
    profile: &mut Profile,
    schur: &mut [f64],
) -> InertiaCount {
    let k = pattern.border_rows();
    let Profile { layout, local, stride } = profile;
    let stride = *stride;
    let mut inertia = InertiaCount::default();
    for c in 0..pattern.chains() {
        let rows = layout.rows(c);
        local[..padded(rows.len()) * stride].fill(0.0);
        let mut chain = ChainFactor {
            input,
            k,
            factors: &mut *factors,
            rows,
            local: &mut local[..],
            stride,
            inv: None,
            width: 0,
            inertia: InertiaCount::default(),
        };
        for (blocks, m) in layout.runs(c, pattern.chain_blocks(c)) {
            match padded(m) {
                0 => chain.run::<0>(blocks, m),
                3 => chain.run::<3>(blocks, m),
                6 => chain.run::<6>(blocks, m),
                9 => chain.run::<9>(blocks, m),
                12 => chain.run::<12>(blocks, m),
                16 => chain.run::<16>(blocks, m),
                24 => chain.run::<24>(blocks, m),
                32 => chain.run::<32>(blocks, m),
                48 => chain.run::<48>(blocks, m),
                _ => chain.run::<MAX_BORDER>(blocks, m),
            }
        }
        inertia += chain.inertia;
        // S -= the chain's part, from its row order to S's (lower triangle by columns).
        for (c1, &r1) in rows.iter().enumerate() {
            for (c2, &r2) in rows[..=c1].iter().enumerate() {
                schur[r1.min(r2) * k + r1.max(r2)] -= local[c1 * stride + c2];
            }
        }
    }
    inertia
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

/// Back substitution `x = L^-T D^-1 h` over `h = t - W y` held in `x`.
struct Backward<'a> {
    factors: &'a SparseFactors,
    x: &'a mut [f64],
}

impl Sweep for Backward<'_> {
    type Lane = Vector3<f64>;

    #[inline(always)]
    fn step<const FRESH: bool>(&mut self, next: &mut Vector3<f64>, j: usize) {
        let f = self.factors;
        *next = load(&f.inv_pivots, j) * block_of(self.x, j) - load(&f.multipliers, j + 1).tr_mul(next);
        set_block(self.x, j, next);
    }
}

/// Solves with the factors of [`factor`], on the border rows each chain
/// carries (`profile` as the factorization left it).
#[allow(clippy::too_many_arguments)]
pub(super) fn solve(
    pattern: &Pattern,
    factors: &SparseFactors,
    profile: &Profile,
    schur: &SchurFactors,
    r: &[f64],
    c: &[f64],
    x: &mut [f64],
    y: &mut [f64],
) {
    let k = c.len();
    let layout = &profile.layout;
    let (mut t0, mut t1) = (Vector3::zeros(), Vector3::zeros());
    pattern.forward(&mut Forward { r, multipliers: &factors.multipliers, x }, &mut t0, &mut t1);
    // y = c - W^T D^-1 t, block by block.
    y.copy_from_slice(c);
    for chain in 0..pattern.chains() {
        let rows = layout.rows(chain);
        for (blocks, m) in layout.runs(chain, pattern.chain_blocks(chain)) {
            for j in blocks {
                let u = load(&factors.inv_pivots, j) * block_of(x, j);
                let w = &factors.w[3 * k * j..];
                for (c, &row) in rows[..m].iter().enumerate() {
                    y[row] -= w[c] * u[0] + w[k + c] * u[1] + w[2 * k + c] * u[2];
                }
            }
        }
    }
    schur.solve(y);
    // h = t - W y, then the backward pass.
    for chain in 0..pattern.chains() {
        let rows = layout.rows(chain);
        for (blocks, m) in layout.runs(chain, pattern.chain_blocks(chain)) {
            for j in blocks {
                let w = &factors.w[3 * k * j..];
                for a in 0..3 {
                    let dot: f64 = rows[..m].iter().zip(&w[a * k..a * k + m]).map(|(&row, w)| w * y[row]).sum();
                    x[3 * j + a] -= dot;
                }
            }
        }
    }
    let (mut next0, mut next1) = (Vector3::zeros(), Vector3::zeros());
    pattern.backward(&mut Backward { factors, x }, &mut next0, &mut next1);
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
