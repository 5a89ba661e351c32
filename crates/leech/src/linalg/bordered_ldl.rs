//! The numeric factorization of a bordered block-tridiagonal matrix and its
//! solve (equations in the [module doc](super)).

use super::dense_ldl::{self, Pivot};
use super::{block_tridiagonal, tridiagonal, InertiaCount, Pattern, MAX_BORDER};

/// Below this a pivot of the equilibrated Schur complement (every row's
/// largest entry scaled to 1) counts as zero: the border is rank deficient
/// to rounding. Per row, since the border mixes units (primal rows shifted by
/// a large inertia correction beside constraint rows in metres): a threshold
/// relative to the largest entry of `S` would drop the constraint rows.
const SCHUR_RELATIVE_ZERO: f64 = 1e-12;

/// Factors of one bordered block-tridiagonal matrix, with all the scratch its
/// factorization and solves need, allocated once from a [`Pattern`]:
/// [`BorderedLdl::factor`] and [`BorderedLdl::solve`] allocate nothing.
#[derive(Clone, Debug)]
pub struct BorderedLdl {
    pattern: Pattern,
    /// Border rows the buffers hold: the pattern's when made.
    capacity: usize,
    factors: SparseFactors,
    /// The border rows each chain carries (3 x 3 blocks), and scratch.
    profile: block_tridiagonal::Profile,
    /// `S`, then its Bunch-Kaufman factors (lower triangle by columns).
    schur: Vec<f64>,
    schur_pivots: Vec<Pivot>,
    /// The equilibration `D` of `S` (factored as `D S D`).
    schur_scale: Vec<f64>,
    sparse_inertia: InertiaCount,
    schur_inertia: InertiaCount,
}

/// The numbers of the sparse part and border for one factorization.
pub(super) struct SparseInput<'a> {
    pub diag: &'a [f64],
    pub off: &'a [f64],
    pub border: &'a [f64],
    pub shift: f64,
    pub tiny: f64,
}

/// Factors of the chains: `L D L^T` of `A + shift I` and `W = L^-1 B`.
#[derive(Clone, Debug)]
pub(super) struct SparseFactors {
    /// `D^+` of each block: the reciprocal pivot (B = 1) or the 3 x 3 inverse
    /// of the pivot block (B = 3, row-major), 0 in dropped directions.
    pub inv_pivots: Vec<f64>,
    /// `L_{j, j-1}` of each block (row-major); zero at the first block of a
    /// chain, and one zero block past the end, so that backward recurrences
    /// cross chain ends without a test.
    pub multipliers: Vec<f64>,
    /// `W = L^-1 B`, laid out like the border (`i * k + r`).
    pub w: Vec<f64>,
}

/// The factored Schur complement, as the chain kernels see it.
pub(super) struct SchurFactors<'a> {
    factors: &'a [f64],
    pivots: &'a [Pivot],
    scale: &'a [f64],
}

impl SchurFactors<'_> {
    /// Overwrites `y` (all k entries, no more) with `S^-1 y` (directions of
    /// zero pivots dropped). Inlined, so that a constant length unrolls it.
    #[inline(always)]
    pub fn solve(&self, y: &mut [f64]) {
        let k = y.len();
        // S^-1 = D (D S D)^-1 D.
        y.iter_mut().zip(self.scale).for_each(|(v, d)| *v *= d);
        dense_ldl::solve_in_place(&self.factors[..k * k], k, &self.pivots[..k], y);
        y.iter_mut().zip(self.scale).for_each(|(v, d)| *v *= d);
    }
}

impl BorderedLdl {
    /// Scratch and factors for matrices of the given structure.
    pub fn new(pattern: &Pattern) -> BorderedLdl {
        let (blocks, b, k) = (pattern.blocks(), pattern.block_size(), pattern.border_rows());
        BorderedLdl {
            pattern: pattern.clone(),
            capacity: k,
            factors: SparseFactors {
                inv_pivots: vec![0.0; blocks * b * b],
                multipliers: vec![0.0; (blocks + 1) * b * b],
                w: vec![0.0; blocks * b * k],
            },
            profile: block_tridiagonal::Profile::new(pattern, k),
            schur: vec![0.0; k * k],
            schur_pivots: vec![Pivot::default(); k],
            schur_scale: vec![1.0; k],
            sparse_inertia: InertiaCount::default(),
            schur_inertia: InertiaCount::default(),
        }
    }

    /// The structure this factorization was made for.
    pub fn pattern(&self) -> &Pattern {
        &self.pattern
    }

    /// Sets the number of border rows of the next factorizations to `rows`,
    /// at most the pattern's when this was made (the buffers are reused, so
    /// nothing is allocated) and at least its primal rows: a working set of
    /// constraints that changes size keeps one factorization.
    ///
    /// # Panics
    /// If `rows` is out of that range.
    pub fn set_border_rows(&mut self, rows: usize) {
        assert!(rows <= self.capacity, "{rows} border rows: this factorization holds {}", self.capacity);
        self.pattern.set_border_rows(rows);
        self.profile.update(&self.pattern);
    }

    /// Declares that border row `row` is zero on chain `c`'s blocks before
    /// `first` ([`Pattern::set_border_start`]), read by the next
    /// [`BorderedLdl::set_border_rows`].
    pub fn set_border_start(&mut self, c: usize, row: usize, first: usize) {
        self.pattern.set_border_start(c, row, first);
    }

    /// Factors the matrix and returns its inertia (Sylvester's law: that of
    /// the chains' pivots plus that of the Schur complement).
    ///
    /// * `diag`: the diagonal blocks, `B * B` row-major entries per block (for
    ///   B = 1 the `n` diagonal entries).
    /// * `off`: for each block `j` but the last, the block coupling it (rows)
    ///   with block `j + 1` (columns), `B * B` row-major entries; the block
    ///   below the diagonal is its transpose. Entries between chains are
    ///   ignored. For B = 1, `off[i]` couples unknowns `i` and `i + 1`.
    /// * `border`: `B` (n x k), entry (unknown `i`, border row `r`) at `i * k + r`.
    /// * `corner`: `C` (k x k, row-major, symmetric; the lower triangle is read).
    /// * `shift`: added to the chains' diagonal and to the first `k_primal`
    ///   diagonal entries of the corner.
    /// * `tiny`: a chain pivot with `|d| <= tiny` counts as zero. A Schur
    ///   pivot counts as zero below `1e-12` once each row of `S` is scaled
    ///   to a largest entry of 1.
    ///
    /// # Panics
    /// If a slice's length does not fit the pattern.
    pub fn factor(
        &mut self,
        diag: &[f64],
        off: &[f64],
        border: &[f64],
        corner: &[f64],
        shift: f64,
        tiny: f64,
    ) -> InertiaCount {
        self.check_factor_inputs(diag, off, border, corner);
        let k = self.pattern.border_rows();
        self.load_corner(corner, shift);
        let input = SparseInput { diag, off, border, shift, tiny };
        let (pattern, factors, profile) = (&self.pattern, &mut self.factors, &mut self.profile);
        let (schur, pivots) = (&mut self.schur[..], (&mut self.schur_pivots[..], &mut self.schur_scale[..]));
        (self.sparse_inertia, self.schur_inertia) = match (pattern.block_size(), k) {
            (1, 0) => factor_fused::<0>(pattern, &input, factors, schur, pivots),
            (1, 1) => factor_fused::<1>(pattern, &input, factors, schur, pivots),
            (1, 2) => factor_fused::<2>(pattern, &input, factors, schur, pivots),
            (1, 3) => factor_fused::<3>(pattern, &input, factors, schur, pivots),
            (1, _) => {
                let sparse = tridiagonal::factor_wide(pattern, &input, factors, schur);
                (sparse, factor_schur(schur, k, pivots))
            }
            _ => {
                let sparse = block_tridiagonal::factor(pattern, &input, factors, profile, schur);
                (sparse, factor_schur(schur, k, pivots))
            }
        };
        self.sparse_inertia + self.schur_inertia
    }

    /// Solves the factored system for right-hand sides `r` (n) and `c` (k),
    /// writing `x` (n) and `y` (k). Meaningful when the last factorization
    /// counted no zero eigenvalue; otherwise the dropped directions are zero.
    ///
    /// # Panics
    /// If a slice's length does not fit the pattern.
    pub fn solve(&self, r: &[f64], c: &[f64], x: &mut [f64], y: &mut [f64]) {
        let (n, k) = (self.pattern.unknowns(), self.pattern.border_rows());
        assert!(r.len() == n && x.len() == n, "solve: r and x need {n} entries");
        assert!(c.len() == k && y.len() == k, "solve: c and y need {k} entries");
        let schur = SchurFactors { factors: &self.schur, pivots: &self.schur_pivots, scale: &self.schur_scale };
        let (pattern, factors) = (&self.pattern, &self.factors);
        match (pattern.block_size(), k) {
            (1, 0) => tridiagonal::solve_small::<0>(pattern, factors, &schur, r, c, x, y),
            (1, 1) => tridiagonal::solve_small::<1>(pattern, factors, &schur, r, c, x, y),
            (1, 2) => tridiagonal::solve_small::<2>(pattern, factors, &schur, r, c, x, y),
            (1, 3) => tridiagonal::solve_small::<3>(pattern, factors, &schur, r, c, x, y),
            (1, _) => tridiagonal::solve_wide(pattern, factors, &schur, r, c, x, y),
            _ => block_tridiagonal::solve(pattern, factors, &self.profile, &schur, r, c, x, y),
        }
    }

    /// Inertia of the chains' part `A + shift I` found by the last factorization.
    pub fn sparse_inertia(&self) -> InertiaCount {
        self.sparse_inertia
    }

    /// Inertia of the Schur complement `S` found by the last factorization.
    pub fn schur_inertia(&self) -> InertiaCount {
        self.schur_inertia
    }

    fn check_factor_inputs(&self, diag: &[f64], off: &[f64], border: &[f64], corner: &[f64]) {
        let (blocks, b, k) = (self.pattern.blocks(), self.pattern.block_size(), self.pattern.border_rows());
        assert_eq!(diag.len(), blocks * b * b, "factor: diagonal blocks");
        assert!(off.len() >= blocks.saturating_sub(1) * b * b, "factor: {} off-diagonal entries too few", off.len());
        assert_eq!(border.len(), blocks * b * k, "factor: border");
        assert_eq!(corner.len(), k * k, "factor: corner");
    }

    /// `S` starts as the shifted corner; the kernels subtract `W^T D^-1 W`.
    fn load_corner(&mut self, corner: &[f64], shift: f64) {
        let (k, primal) = (self.pattern.border_rows(), self.pattern.primal_rows());
        for j in 0..k {
            for i in j..k {
                self.schur[j * k + i] = corner[i * k + j];
            }
        }
        for i in 0..primal {
            self.schur[i * k + i] += shift;
        }
    }
}

/// The fast path: chains with `K <= 3` border rows, and `S` factored with
/// its size known to the compiler.
fn factor_fused<const K: usize>(
    pattern: &Pattern,
    input: &SparseInput,
    factors: &mut SparseFactors,
    schur: &mut [f64],
    pivots: (&mut [Pivot], &mut [f64]),
) -> (InertiaCount, InertiaCount) {
    let sparse = tridiagonal::factor_small::<K>(pattern, input, factors, schur);
    (sparse, factor_schur(schur, K, pivots))
}

/// Factors `S` (k x k, lower triangle by columns) in place as `D S D`, `D`
/// scaling each row's largest entry to 1; zero pivots are judged on that.
#[inline(always)]
fn factor_schur(schur: &mut [f64], k: usize, (pivots, scale): (&mut [Pivot], &mut [f64])) -> InertiaCount {
    let s = &mut schur[..k * k];
    for i in 0..k {
        // Row i of the symmetric S: (i, j <= i) at j k + i, (i, j > i) at i k + j.
        let row = (0..k).map(|j| if j <= i { s[j * k + i] } else { s[i * k + j] }.abs()).fold(0.0f64, f64::max);
        scale[i] = if row > 0.0 { 1.0 / row.sqrt() } else { 1.0 };
    }
    for j in 0..k {
        for i in j..k {
            s[j * k + i] *= scale[i] * scale[j];
        }
    }
    dense_ldl::factor_in_place(s, k, &mut pivots[..k], SCHUR_RELATIVE_ZERO)
}

/// `S(i, j) -= sum_u v_u[j] w_u[i]` on the lower triangle (`S` by columns),
/// for a group of `R` unknowns with border rows `w_u` and `v_u = (D^-1 W)_u`:
/// taking several unknowns per sweep over `S` divides its memory traffic.
///
/// The border's rows are mostly zero on a chain (a contact on one chain,
/// a hold's rows on the driving unit's pose alone), and `W = L^-1 B` keeps
/// those zeros: the rows of `S` past the group's last nonzero border row,
/// and its columns where every `v_u` is zero, receive exact zeros and are
/// left out (the sums that remain are the same, in the same order).
#[inline(always)]
pub(super) fn subtract_outer<const R: usize>(s: &mut [f64], k: usize, w: [&[f64]; R], v: &[[f64; MAX_BORDER]; R]) {
    let top = (0..k).rev().find(|&i| w.iter().any(|row| row[i] != 0.0)).map_or(0, |i| i + 1);
    for j in 0..top {
        let coefficients: [f64; R] = std::array::from_fn(|u| v[u][j]);
        if coefficients.iter().all(|c| *c == 0.0) {
            continue;
        }
        let target = &mut s[j * k + j..j * k + top];
        for (offset, x) in target.iter_mut().enumerate() {
            let i = j + offset;
            let mut sum = 0.0;
            for u in 0..R {
                sum += coefficients[u] * w[u][i];
            }
            *x -= sum;
        }
    }
}
