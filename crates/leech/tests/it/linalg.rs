//! The bordered block-tridiagonal LDL^T (`leech::linalg`) against a dense
//! reference: solutions by their residual, inertia against nalgebra's
//! symmetric eigenvalues, and the old `kkt` solver on its own problems.

use leech::linalg::{solve_symmetric, BorderedLdl, DenseLdl, InertiaCount, Pattern};
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use proptest::prelude::*;

/// SplitMix64: reproducible entries from one seed that proptest varies.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }

    fn sign(&mut self) -> f64 {
        if self.next() < 0.5 {
            -1.0
        } else {
            1.0
        }
    }
}

/// One bordered matrix's numbers, laid out as `BorderedLdl::factor` takes them.
struct Problem {
    pattern: Pattern,
    diag: Vec<f64>,
    off: Vec<f64>,
    border: Vec<f64>,
    corner: Vec<f64>,
    shift: f64,
}

impl Problem {
    /// Random entries of both signs. The chains are made block diagonally
    /// dominant (so `L D L^T` without pivoting is stable) but indefinite; the
    /// border and corner are arbitrary, so `S` is indefinite too.
    fn random(pattern: Pattern, shift: f64, zero_constraint_corner: bool, rng: &mut Rng) -> Problem {
        let (blocks, b, k) = (pattern.blocks(), pattern.block_size(), pattern.border_rows());
        let mut diag = vec![0.0; blocks * b * b];
        for block in diag.chunks_exact_mut(b * b) {
            for i in 0..b {
                block[i * b + i] = rng.sign() * rng.uniform(5.0, 7.0);
                for j in 0..i {
                    let v = rng.uniform(-0.5, 0.5);
                    (block[i * b + j], block[j * b + i]) = (v, v);
                }
            }
        }
        // Couplings between chains are ignored by the solver: fill them anyway.
        let off = (0..blocks.saturating_sub(1) * b * b).map(|_| rng.uniform(-1.0, 1.0) / b as f64).collect();
        let border = (0..blocks * b * k).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let mut corner = vec![0.0; k * k];
        let primal = pattern.primal_rows();
        for i in 0..k {
            for j in 0..=i {
                let constraint = i >= primal && j >= primal;
                let v = if constraint && zero_constraint_corner { 0.0 } else { rng.uniform(-1.0, 1.0) };
                (corner[i * k + j], corner[j * k + i]) = (v, v);
            }
        }
        Problem { pattern, diag, off, border, corner, shift }
    }

    /// The whole matrix `K`, shifts included, couplings between chains left out.
    fn dense(&self) -> DMatrix<f64> {
        let p = &self.pattern;
        let (n, b, k) = (p.unknowns(), p.block_size(), p.border_rows());
        let mut m = DMatrix::zeros(n + k, n + k);
        for j in 0..p.blocks() {
            for (a, c) in (0..b).flat_map(|a| (0..b).map(move |c| (a, c))) {
                m[(b * j + a, b * j + c)] = self.diag[j * b * b + a * b + c];
            }
        }
        for c in 0..p.chains() {
            for j in p.chain_blocks(c).skip(1) {
                for (a, e) in (0..b).flat_map(|a| (0..b).map(move |e| (a, e))) {
                    let v = self.off[(j - 1) * b * b + a * b + e];
                    m[(b * (j - 1) + a, b * j + e)] = v;
                    m[(b * j + e, b * (j - 1) + a)] = v;
                }
            }
        }
        for i in 0..n {
            m[(i, i)] += self.shift;
            for r in 0..k {
                m[(i, n + r)] = self.border[i * k + r];
                m[(n + r, i)] = self.border[i * k + r];
            }
        }
        for r in 0..k {
            for s in 0..k {
                m[(n + r, n + s)] = self.corner[r * k + s];
            }
        }
        for r in 0..p.primal_rows() {
            m[(n + r, n + r)] += self.shift;
        }
        m
    }

    fn factor(&self, ldl: &mut BorderedLdl, tiny: f64) -> InertiaCount {
        ldl.factor(&self.diag, &self.off, &self.border, &self.corner, self.shift, tiny)
    }
}

/// Eigenvalue signs of a dense symmetric matrix, or `None` when the smallest
/// eigenvalue is too close to zero for the count to be well defined.
fn reference_inertia(m: &DMatrix<f64>) -> Option<InertiaCount> {
    if m.nrows() == 0 {
        return Some(InertiaCount::default());
    }
    let eigenvalues = SymmetricEigen::new(m.clone()).eigenvalues;
    let largest = eigenvalues.amax();
    if eigenvalues.iter().any(|e| e.abs() < 1e-8 * largest) {
        return None;
    }
    let negative = eigenvalues.iter().filter(|e| **e < 0.0).count();
    Some(InertiaCount { positive: m.nrows() - negative, negative, zero: 0 })
}

/// Solves `K z = rhs` with the factors and checks the dense residual.
fn check_solve(problem: &Problem, ldl: &BorderedLdl, rng: &mut Rng) -> Result<(), TestCaseError> {
    let (n, k) = (problem.pattern.unknowns(), problem.pattern.border_rows());
    let rhs = DVector::from_fn(n + k, |_, _| rng.uniform(-1.0, 1.0));
    let (mut x, mut y) = (vec![0.0; n], vec![0.0; k]);
    ldl.solve(&rhs.as_slice()[..n], &rhs.as_slice()[n..], &mut x, &mut y);
    let z = DVector::from_iterator(n + k, x.into_iter().chain(y));
    let m = problem.dense();
    let residual = (&m * &z - &rhs).amax();
    let scale = m.amax() * z.amax() + rhs.amax();
    prop_assert!(residual <= 1e-9 * scale, "residual {residual:e} against scale {scale:e}");
    Ok(())
}

/// A random problem's description: structure, shift, and the seed of its entries.
#[derive(Clone, Debug)]
struct Case {
    block: usize,
    lengths: Vec<usize>,
    border_rows: usize,
    primal_rows: usize,
    shift: f64,
    zero_constraint_corner: bool,
    /// Whether border rows start late on some chains (zero before), declared.
    profile: bool,
    seed: u64,
}

impl Case {
    fn problem(&self) -> Problem {
        let mut pattern = Pattern::new(self.block, &self.lengths, self.border_rows, self.primal_rows);
        let mut rng = Rng(self.seed);
        let mut starts = Vec::new();
        if self.profile {
            for (c, len) in self.lengths.iter().enumerate() {
                for row in 0..self.border_rows {
                    // Anywhere from the chain's start to past its end (absent).
                    let first = (rng.next() * (len + 2) as f64) as usize;
                    pattern.set_border_start(c, row, first);
                    starts.push((pattern.chain_blocks(c), row, first));
                }
            }
        }
        let mut problem = Problem::random(pattern, self.shift, self.zero_constraint_corner, &mut rng);
        let (b, k) = (self.block, self.border_rows);
        for (blocks, row, first) in starts {
            for j in blocks.start..(blocks.start + first).min(blocks.end) {
                (0..b).for_each(|a| problem.border[(b * j + a) * k + row] = 0.0);
            }
        }
        problem
    }
}

fn cases() -> impl Strategy<Value = Case> {
    let shape = (prop_oneof![Just(1usize), Just(3usize)], prop::collection::vec(1usize..40, 1..4), 0usize..24);
    let shift = prop_oneof![Just(0.0), 0.0..1.0f64];
    (shape, 0.0..=1.0f64, shift, any::<bool>(), any::<bool>(), any::<u64>()).prop_map(
        |((block, lengths, border_rows), primal_fraction, shift, zero_constraint_corner, profile, seed)| Case {
            block,
            lengths,
            border_rows,
            primal_rows: (primal_fraction * border_rows as f64).floor() as usize,
            shift,
            zero_constraint_corner,
            profile,
            seed,
        },
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn solve_and_inertia_match_the_dense_reference(case in cases()) {
        let (problem, seed) = (case.problem(), case.seed);
        let reference = reference_inertia(&problem.dense());
        prop_assume!(reference.is_some());
        let mut ldl = BorderedLdl::new(&problem.pattern);
        let inertia = problem.factor(&mut ldl, 1e-12);
        prop_assert_eq!(Some(inertia), reference);
        check_solve(&problem, &ldl, &mut Rng(seed ^ 0x5eed))?;
        // A second factorization reuses the scratch and gives the same answer.
        prop_assert_eq!(problem.factor(&mut ldl, 1e-12), inertia);
        check_solve(&problem, &ldl, &mut Rng(seed ^ 0x5eed))?;
    }

    #[test]
    fn small_symmetric_solve_matches_eigenvalues(k in 1usize..12, seed in any::<u64>()) {
        let mut rng = Rng(seed);
        let s = DMatrix::from_fn(k, k, |_, _| rng.uniform(-1.0, 1.0));
        let s = &s + s.transpose();
        let reference = reference_inertia(&s);
        prop_assume!(reference.is_some());
        let mut b: Vec<f64> = (0..k).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let rhs = DVector::from_column_slice(&b);
        let mut scratch = DenseLdl::new(16);
        let inertia = solve_symmetric(s.as_slice(), k, &mut b, &mut scratch, 0.0);
        prop_assert_eq!(Some(inertia), reference);
        let residual = (&s * DVector::from_column_slice(&b) - &rhs).amax();
        prop_assert!(residual <= 1e-12 * (s.amax() * DVector::from_column_slice(&b).amax() + 1.0));
    }
}

#[test]
fn zero_pivot_counts_as_zero() {
    // Unknown 3 has a zero diagonal and no coupling to unknown 2: its pivot is 0.
    let pattern = Pattern::new(1, &[3, 4], 2, 0);
    let mut ldl = BorderedLdl::new(&pattern);
    let diag = [2.0, 3.0, 2.0, 0.0, 2.0, 2.0, 2.0];
    let off = [0.5, 0.5, 9.0, 0.0, 0.5, 0.5];
    let border: Vec<f64> = (0..14).map(|i| (i as f64 * 0.7).sin()).collect();
    let inertia = ldl.factor(&diag, &off, &border, &[0.0; 4], 0.0, 1e-12);
    assert!(inertia.zero >= 1, "{inertia:?}");
    assert_eq!(inertia.dimension(), 9);
    // The solve stays finite: the dropped direction comes out as zero.
    let (mut x, mut y) = (vec![0.0; 7], vec![0.0; 2]);
    ldl.solve(&[1.0; 7], &[1.0; 2], &mut x, &mut y);
    assert!(x.iter().chain(&y).all(|v| v.is_finite()));
}

#[test]
fn singular_pivot_block_counts_as_zero() {
    // The first 3 x 3 block is diag(4, -3, 0): one zero eigenvalue.
    let pattern = Pattern::new(3, &[2], 1, 0);
    let mut ldl = BorderedLdl::new(&pattern);
    let mut diag = vec![0.0; 18];
    (diag[0], diag[4], diag[8]) = (4.0, -3.0, 0.0);
    (diag[9], diag[13], diag[17]) = (5.0, 5.0, 5.0);
    let off = vec![0.0; 9];
    let border = [1.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    let inertia = ldl.factor(&diag, &off, &border, &[0.0], 0.0, 1e-12);
    assert_eq!(ldl.sparse_inertia(), InertiaCount { positive: 4, negative: 1, zero: 1 });
    assert!(inertia.zero >= 1);
}

#[test]
fn rank_deficient_border_counts_as_zero() {
    // Border rows 0 and 2 are equal and the corner is zero: S = -B^T A^-1 B
    // is negative semidefinite of rank 2.
    let n = 20;
    let pattern = Pattern::new(1, &[12, 8], 3, 0);
    let mut ldl = BorderedLdl::new(&pattern);
    let diag = vec![4.0; n];
    let off = vec![-1.0; n - 1];
    let mut border = vec![0.0; 3 * n];
    for i in 0..n {
        border[3 * i] = (i as f64).cos();
        border[3 * i + 1] = (i as f64 * 0.3).sin();
        border[3 * i + 2] = border[3 * i];
    }
    let inertia = ldl.factor(&diag, &off, &border, &[0.0; 9], 0.0, 1e-12);
    assert_eq!(inertia, InertiaCount { positive: n, negative: 2, zero: 1 });
    // The same through the wide path, with the border repeated to 6 rows of rank 2.
    let pattern = Pattern::new(1, &[12, 8], 6, 0);
    let mut ldl = BorderedLdl::new(&pattern);
    let wide: Vec<f64> = border.chunks_exact(3).flat_map(|row| [row, row].concat()).collect();
    let inertia = ldl.factor(&diag, &off, &wide, &[0.0; 36], 0.0, 1e-12);
    assert_eq!(inertia, InertiaCount { positive: n, negative: 2, zero: 4 });
    let (mut x, mut y) = (vec![0.0; n], vec![0.0; 6]);
    ldl.solve(&vec![1.0; n], &[0.0; 6], &mut x, &mut y);
    assert!(x.iter().chain(&y).all(|v| v.is_finite()));
}

#[test]
fn primal_border_rows_are_shifted_constraint_rows_are_not() {
    // No chains: K is the corner, diag(-1, 0) shifted on the primal row only.
    let pattern = Pattern::new(1, &[], 2, 1);
    let mut ldl = BorderedLdl::new(&pattern);
    let inertia = ldl.factor(&[], &[], &[], &[-1.0, 0.0, 0.0, 0.0], 3.0, 1e-12);
    assert_eq!(inertia, InertiaCount { positive: 1, negative: 0, zero: 1 });
}
