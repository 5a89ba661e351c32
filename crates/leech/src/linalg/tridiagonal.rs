//! Chains of scalar unknowns (block size 1): the tridiagonal `L D L^T`
//! bordered by `k` rows, and its solve.
//!
//! Two versions of each pass: for `k <= 3` ("small", monomorphized over `K`)
//! the border rows of the current unknown, its share of `W^T D^-1 W` and of
//! the solve's `W^T D^-1 t` stay in registers of each lane; for larger `k`
//! ("wide") the lanes only carry the pivot recurrence and the border work
//! runs over rows of memory, `W^T D^-1 W` in a separate cache-friendly pass.

use super::bordered_ldl::{subtract_outer, SchurFactors, SparseFactors, SparseInput};
use super::pattern::Sweep;
use super::{InertiaCount, Pattern, MAX_BORDER};

/// Unknowns per group in the wide Schur update.
const GROUP: usize = 4;

/// The pivot recurrence of unknown `i`: its multiplier `l_i = off_{i-1} /
/// d_{i-1}` and reciprocal pivot `1 / d_i`, `d_i = a_i - off_{i-1}^2 / d_{i-1}`
/// (0 when `|d_i| <= tiny`, which drops the direction and restarts the
/// recurrence). `off_{i-1}^2` does not depend on the previous pivot, so the
/// serial chain from one pivot to the next is a multiply, a subtract and a
/// divide.
#[inline(always)]
fn pivot<const FRESH: bool>(input: &SparseInput, i: usize, inv_prev: f64) -> (f64, f64) {
    let a = input.diag[i] + input.shift;
    let (l, d) = if FRESH {
        (0.0, a)
    } else {
        let o = input.off[i - 1];
        (o * inv_prev, a - (o * o) * inv_prev)
    };
    (l, if d.abs() > input.tiny { 1.0 / d } else { 0.0 })
}

/// Inertia of `D` from the stored reciprocal pivots (0 for a zero pivot):
/// counted after the pass, which keeps the counters out of the lanes.
fn pivot_inertia(inv_pivots: &[f64]) -> InertiaCount {
    let (mut negative, mut zero) = (0, 0);
    for inv in inv_pivots {
        negative += usize::from(*inv < 0.0);
        zero += usize::from(*inv == 0.0);
    }
    InertiaCount { positive: inv_pivots.len() - negative - zero, negative, zero }
}

/// The factorization pass with everything of one lane in registers.
struct SmallFactor<'a, const K: usize> {
    input: &'a SparseInput<'a>,
    inv_pivots: &'a mut [f64],
    multipliers: &'a mut [f64],
    w: &'a mut [f64],
}

#[derive(Clone, Copy)]
struct SmallFactorLane<const K: usize> {
    inv: f64,
    w: [f64; K],
    /// Lower triangle of the lane's share of `W^T D^-1 W`.
    s: [[f64; K]; K],
}

impl<const K: usize> Sweep for SmallFactor<'_, K> {
    type Lane = SmallFactorLane<K>;

    #[inline(always)]
    fn step<const FRESH: bool>(&mut self, lane: &mut Self::Lane, i: usize) {
        let (l, inv) = pivot::<FRESH>(self.input, i, lane.inv);
        lane.inv = inv;
        self.inv_pivots[i] = inv;
        self.multipliers[i] = l;
        let border = &self.input.border[i * K..i * K + K];
        let w = &mut self.w[i * K..i * K + K];
        for r in 0..K {
            lane.w[r] = if FRESH { border[r] } else { border[r] - l * lane.w[r] };
            w[r] = lane.w[r];
        }
        for a in 0..K {
            let v = lane.w[a] * inv;
            for b in 0..=a {
                lane.s[a][b] += v * lane.w[b];
            }
        }
    }
}

/// Factors the chains of a pattern with `K = k <= 3` border rows and
/// subtracts `W^T D^-1 W` from `schur` (`k x k`, lower triangle by columns).
pub(super) fn factor_small<const K: usize>(
    pattern: &Pattern,
    input: &SparseInput,
    factors: &mut SparseFactors,
    schur: &mut [f64],
) -> InertiaCount {
    let n = pattern.unknowns();
    let mut sweep = SmallFactor::<K> {
        input,
        inv_pivots: &mut factors.inv_pivots[..n],
        multipliers: &mut factors.multipliers[..n],
        w: &mut factors.w[..n * K],
    };
    let fresh = SmallFactorLane { inv: 0.0, w: [0.0; K], s: [[0.0; K]; K] };
    let (mut lane0, mut lane1) = (fresh, fresh);
    pattern.forward(&mut sweep, &mut lane0, &mut lane1);
    for a in 0..K {
        for b in 0..=a {
            schur[b * K + a] -= lane0.s[a][b] + lane1.s[a][b];
        }
    }
    pivot_inertia(&factors.inv_pivots[..n])
}

/// Forward substitution `t = L^-1 r` into `x`, accumulating `W^T D^-1 t`.
struct SmallForward<'a, const K: usize> {
    r: &'a [f64],
    factors: &'a SparseFactors,
    x: &'a mut [f64],
}

#[derive(Clone, Copy)]
struct SmallForwardLane<const K: usize> {
    t: f64,
    g: [f64; K],
}

impl<const K: usize> Sweep for SmallForward<'_, K> {
    type Lane = SmallForwardLane<K>;

    #[inline(always)]
    fn step<const FRESH: bool>(&mut self, lane: &mut Self::Lane, i: usize) {
        let f = self.factors;
        lane.t = if FRESH { self.r[i] } else { self.r[i] - f.multipliers[i] * lane.t };
        self.x[i] = lane.t;
        let u = lane.t * f.inv_pivots[i];
        let w = &f.w[i * K..i * K + K];
        for r in 0..K {
            lane.g[r] += w[r] * u;
        }
    }
}

/// Back substitution `x = L^-T D^-1 (t - W y)` over `t` held in `x`.
struct SmallBackward<'a, const K: usize> {
    y: [f64; K],
    factors: &'a SparseFactors,
    x: &'a mut [f64],
}

impl<const K: usize> Sweep for SmallBackward<'_, K> {
    /// `x` of the block after the current one in the lane's order.
    type Lane = f64;

    #[inline(always)]
    fn step<const FRESH: bool>(&mut self, next: &mut f64, i: usize) {
        let f = self.factors;
        let w = &f.w[i * K..i * K + K];
        let mut h = self.x[i];
        for r in 0..K {
            h -= w[r] * self.y[r];
        }
        *next = h * f.inv_pivots[i] - f.multipliers[i + 1] * *next;
        self.x[i] = *next;
    }
}

/// Solves with the factors of [`factor_small`].
pub(super) fn solve_small<const K: usize>(
    pattern: &Pattern,
    factors: &SparseFactors,
    schur: &SchurFactors,
    r: &[f64],
    c: &[f64],
    x: &mut [f64],
    y: &mut [f64],
) {
    let fresh = SmallForwardLane { t: 0.0, g: [0.0; K] };
    let (mut lane0, mut lane1) = (fresh, fresh);
    pattern.forward(&mut SmallForward::<K> { r, factors, x }, &mut lane0, &mut lane1);
    for row in 0..K {
        y[row] = c[row] - lane0.g[row] - lane1.g[row];
    }
    schur.solve(&mut y[..K]);
    let mut backward = SmallBackward::<K> { y: std::array::from_fn(|row| y[row]), factors, x };
    pattern.backward(&mut backward, &mut 0.0, &mut 0.0);
}

/// The factorization pass for any `k`: pivots in the lanes, `W` row by row.
struct WideFactor<'a> {
    input: &'a SparseInput<'a>,
    k: usize,
    inv_pivots: &'a mut [f64],
    multipliers: &'a mut [f64],
    w: &'a mut [f64],
}

impl Sweep for WideFactor<'_> {
    /// The previous reciprocal pivot.
    type Lane = f64;

    #[inline(always)]
    fn step<const FRESH: bool>(&mut self, inv_prev: &mut f64, i: usize) {
        let (l, inv) = pivot::<FRESH>(self.input, i, *inv_prev);
        *inv_prev = inv;
        self.inv_pivots[i] = inv;
        self.multipliers[i] = l;
        let k = self.k;
        let border = &self.input.border[i * k..i * k + k];
        if FRESH {
            self.w[i * k..i * k + k].copy_from_slice(border);
        } else {
            let (done, rest) = self.w.split_at_mut(i * k);
            for ((w, b), p) in rest[..k].iter_mut().zip(border).zip(&done[(i - 1) * k..]) {
                *w = b - l * p;
            }
        }
    }
}

/// Factors the chains of a pattern with any number of border rows and
/// subtracts `W^T D^-1 W` from `schur`.
pub(super) fn factor_wide(
    pattern: &Pattern,
    input: &SparseInput,
    factors: &mut SparseFactors,
    schur: &mut [f64],
) -> InertiaCount {
    let (n, k) = (pattern.unknowns(), pattern.border_rows());
    let mut sweep = WideFactor {
        input,
        k,
        inv_pivots: &mut factors.inv_pivots[..n],
        multipliers: &mut factors.multipliers[..n],
        w: &mut factors.w[..n * k],
    };
    pattern.forward(&mut sweep, &mut 0.0, &mut 0.0);
    let mut v = [[0.0; MAX_BORDER]; GROUP];
    let (w, inv) = (&factors.w, &factors.inv_pivots);
    let grouped = n - n % GROUP;
    for start in (0..grouped).step_by(GROUP) {
        let rows: [&[f64]; GROUP] = std::array::from_fn(|u| &w[(start + u) * k..(start + u + 1) * k]);
        for u in 0..GROUP {
            for (vr, wr) in v[u].iter_mut().zip(rows[u]) {
                *vr = wr * inv[start + u];
            }
        }
        subtract_outer::<GROUP>(schur, k, rows, &v);
    }
    for i in grouped..n {
        let row = &w[i * k..(i + 1) * k];
        for (vr, wr) in v[0].iter_mut().zip(row) {
            *vr = wr * inv[i];
        }
        subtract_outer::<1>(schur, k, [row], std::array::from_ref(&v[0]));
    }
    pivot_inertia(&factors.inv_pivots[..n])
}

/// Forward substitution `t = L^-1 r` into `x`, for any `k`.
struct WideForward<'a> {
    r: &'a [f64],
    multipliers: &'a [f64],
    x: &'a mut [f64],
}

impl Sweep for WideForward<'_> {
    type Lane = f64;

    #[inline(always)]
    fn step<const FRESH: bool>(&mut self, t: &mut f64, i: usize) {
        *t = if FRESH { self.r[i] } else { self.r[i] - self.multipliers[i] * *t };
        self.x[i] = *t;
    }
}

/// Back substitution `x = L^-T D^-1 (t - W y)`, for any `k`.
struct WideBackward<'a> {
    y: &'a [f64],
    factors: &'a SparseFactors,
    x: &'a mut [f64],
}

impl Sweep for WideBackward<'_> {
    type Lane = f64;

    #[inline(always)]
    fn step<const FRESH: bool>(&mut self, next: &mut f64, i: usize) {
        let (f, k) = (self.factors, self.y.len());
        let dot: f64 = f.w[i * k..i * k + k].iter().zip(self.y).map(|(w, y)| w * y).sum();
        *next = (self.x[i] - dot) * f.inv_pivots[i] - f.multipliers[i + 1] * *next;
        self.x[i] = *next;
    }
}

/// Solves with the factors of [`factor_wide`].
pub(super) fn solve_wide(
    pattern: &Pattern,
    factors: &SparseFactors,
    schur: &SchurFactors,
    r: &[f64],
    c: &[f64],
    x: &mut [f64],
    y: &mut [f64],
) {
    let k = c.len();
    pattern.forward(&mut WideForward { r, multipliers: &factors.multipliers, x }, &mut 0.0, &mut 0.0);
    // y = c - W^T D^-1 t, one row of W at a time.
    y.copy_from_slice(c);
    for (i, t) in x.iter().enumerate() {
        let u = t * factors.inv_pivots[i];
        for (yr, w) in y.iter_mut().zip(&factors.w[i * k..i * k + k]) {
            *yr -= w * u;
        }
    }
    schur.solve(y);
    pattern.backward(&mut WideBackward { y, factors, x }, &mut 0.0, &mut 0.0);
}
