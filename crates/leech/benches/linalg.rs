//! Benchmarks of the bordered factorization (divan): `linalg::BorderedLdl`
//! on two chains of `chain` unknowns each, factor and solve, for 3 border rows
//! (the statics' weld; the fast path) and more. Run with
//! `cargo bench -p leech --bench linalg`. (The `kkt::Kkt` it replaced measured
//! 651 ns, 5.98 us, 58.8 us for factor and solve at 29, 300, 3000 per chain
//! on the same machine: see BENCHMARKS.md.)

use divan::{black_box, Bencher};
use leech::linalg::{BorderedLdl, Pattern};

fn main() {
    divan::main();
}

/// Unknowns per chain: the built-in robot's size, and ten and a hundred times it.
const CHAIN: [usize; 3] = [29, 300, 3000];

/// A positive definite tridiagonal part split into two chains, `k` border
/// rows, zero corner: the statics solver's problem shape.
struct Problem {
    pattern: Pattern,
    diag: Vec<f64>,
    off: Vec<f64>,
    border: Vec<f64>,
    corner: Vec<f64>,
    r: Vec<f64>,
    c: Vec<f64>,
}

impl Problem {
    fn new(block: usize, chain: usize, k: usize) -> Problem {
        let blocks = 2 * chain;
        let n = blocks * block;
        let diag = (0..blocks * block * block)
            .map(|e| if (e % (block * block)).is_multiple_of(block + 1) { 3.0 + (e as f64 * 0.7).sin() } else { 0.1 })
            .collect();
        let mut off: Vec<f64> = (0..(blocks - 1) * block * block).map(|e| -0.5 + 0.3 * (e as f64).cos()).collect();
        off[(chain - 1) * block * block..chain * block * block].fill(0.0);
        Problem {
            pattern: Pattern::new(block, &[chain, chain], k, 0),
            diag,
            off,
            border: (0..n * k).map(|e| ((e * 7 % 11) as f64 - 5.0) / 3.0).collect(),
            corner: vec![0.0; k * k],
            r: (0..n).map(|i| (i as f64 * 0.4).sin()).collect(),
            c: (0..k).map(|r| 0.1 * r as f64).collect(),
        }
    }

    fn bench(&self, bencher: Bencher, solve: bool) {
        let mut ldl = BorderedLdl::new(&self.pattern);
        let (mut x, mut y) = (vec![0.0; self.r.len()], vec![0.0; self.c.len()]);
        bencher.bench_local(|| {
            let inertia = ldl.factor(black_box(&self.diag), &self.off, &self.border, &self.corner, 0.0, 1e-13);
            if solve {
                ldl.solve(&self.r, &self.c, &mut x, &mut y);
            }
            inertia
        });
    }
}

/// New solver, k = 3 (the fast path): factor and solve.
#[divan::bench(args = CHAIN)]
fn linalg_k3(bencher: Bencher, chain: usize) {
    Problem::new(1, chain, 3).bench(bencher, true);
}

/// New solver, k = 3: factor only.
#[divan::bench(args = CHAIN)]
fn linalg_k3_factor(bencher: Bencher, chain: usize) {
    Problem::new(1, chain, 3).bench(bencher, false);
}

/// New solver, more border rows (the general path): factor and solve.
#[divan::bench(consts = [6, 24, 64], args = CHAIN)]
fn linalg_wide<const K: usize>(bencher: Bencher, chain: usize) {
    Problem::new(1, chain, K).bench(bencher, true);
}

/// New solver, chains of 3 x 3 blocks (`chain` blocks each), k = 6: factor and solve.
#[divan::bench(args = CHAIN)]
fn linalg_block3_k6(bencher: Bencher, chain: usize) {
    Problem::new(3, chain, 6).bench(bencher, true);
}
