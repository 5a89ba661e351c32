//! The chains' mass matrices and the implicit integrators' iteration
//! matrices, factored, solved and multiplied in O(n).
//!
//! Each chain's `M` is semiseparable plus diagonal (order 2,
//! [`Chain::mass_generators`]); the iteration matrix `M + T` of backward
//! Euler adds a tridiagonal `T`, which a third generator component with
//! transition 0 carries to the first subdiagonal only (order 3, see
//! [`crate::linalg::quasiseparable`]). The matrices of the whole system are
//! block diagonal, one block per chain.

use crate::chain::Chain;
use crate::linalg::quasiseparable::{self, Generators, Ldl, NotPositiveDefinite};

/// Which matrix the factors hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Held {
    /// Nothing factored yet.
    Nothing,
    /// The mass matrix `M`.
    Mass,
    /// An iteration matrix `M + T`.
    Iteration,
}

/// Each chain's factored `M` or `M + T`, whichever was factored last;
/// [`Factors::solve`] solves with it. Storage is kept between
/// factorizations.
#[derive(Clone, Debug)]
pub(super) struct Factors {
    mass: Vec<Ldl<2>>,
    iteration: Vec<Ldl<3>>,
    held: Held,
}

/// A chain with the offset of its coordinates in the system's.
pub(super) type Placed<'a> = (&'a Chain, usize);

impl Factors {
    /// Storage for `chains`.
    pub(super) fn new(chains: &[Placed<'_>]) -> Factors {
        Factors {
            mass: chains.iter().map(|(c, _)| Ldl::with_capacity(c.len())).collect(),
            iteration: chains.iter().map(|(c, _)| Ldl::with_capacity(c.len())).collect(),
            held: Held::Nothing,
        }
    }

    /// Factors `M` at the point whose cosines and sines are given (all the
    /// system's coordinates). Fails with the system's row of a pivot that is
    /// not positive.
    pub(super) fn factor_mass(&mut self, chains: &[Placed<'_>], cos: &[f64], sin: &[f64]) -> Result<(), usize> {
        self.held = Held::Nothing;
        factor_blocks(&mut self.mass, chains, |(chain, offset)| {
            let range = *offset..offset + chain.len();
            chain.mass_generators(&cos[range.clone()], &sin[range])
        })?;
        self.held = Held::Mass;
        Ok(())
    }

    /// Factors `M + T`, `T` tridiagonal with diagonal `diag` and
    /// off-diagonal `off` (`off[i]` couples `i` and `i + 1`; entries that
    /// couple two chains are ignored).
    pub(super) fn factor_iteration(
        &mut self,
        chains: &[Placed<'_>],
        cos: &[f64],
        sin: &[f64],
        diag: &[f64],
        off: &[f64],
    ) -> Result<(), usize> {
        self.held = Held::Nothing;
        factor_blocks(&mut self.iteration, chains, |&(chain, o)| {
            let k = chain.len();
            let range = o..o + k;
            chain.mass_generators(&cos[range.clone()], &sin[range]).enumerate().map(move |(j, m)| {
                let coupling = if j + 1 < k { off[o + j] } else { 0.0 };
                Generators {
                    diagonal: m.diagonal + diag[o + j],
                    p: [m.p[0], m.p[1], 1.0],
                    q: [m.q[0], m.q[1], coupling],
                    a: [1.0, 1.0, 0.0],
                }
            })
        })?;
        self.held = Held::Iteration;
        Ok(())
    }

    /// Solves the factored block-diagonal system in place.
    pub(super) fn solve(&self, chains: &[Placed<'_>], x: &mut [f64]) {
        self.solve_columns(chains, x, 1);
    }

    /// Solves for `columns` right-hand sides at once, in place, laid out
    /// row by row (entry `(i, c)` at `i * columns + c`).
    pub(super) fn solve_columns(&self, chains: &[Placed<'_>], x: &mut [f64], columns: usize) {
        match self.held {
            Held::Mass => solve_blocks(&self.mass, chains, x, columns),
            Held::Iteration => solve_blocks(&self.iteration, chains, x, columns),
            Held::Nothing => unreachable!("solve before a successful factorization"),
        }
    }
}

/// Factors each chain's block with the generators `rows` makes for it.
/// The body's two chains are factored together, in lockstep
/// ([`Ldl::factor_together`]). Fails with the system's row of the first
/// pivot that is not positive.
fn factor_blocks<'c, const R: usize, I>(
    ldl: &mut [Ldl<R>],
    chains: &'c [Placed<'c>],
    rows: impl Fn(&'c Placed<'c>) -> I,
) -> Result<(), usize>
where
    I: Iterator<Item = Generators<R>>,
{
    if let ([a, b], [first, second]) = (&mut *ldl, chains) {
        return Ldl::factor_together([a, b], [rows(first), rows(second)]).map_err(|(k, e)| chains[k].1 + e.row);
    }
    for (ldl, placed) in ldl.iter_mut().zip(chains) {
        ldl.factor(rows(placed)).map_err(at(placed.1))?;
    }
    Ok(())
}

/// Solves with each chain's factors `ldl` its block of `x` (`columns`
/// right-hand sides). The body's two chains are solved together, their
/// sweeps interleaved ([`Ldl::solve_together`]).
fn solve_blocks<const R: usize>(ldl: &[Ldl<R>], chains: &[Placed<'_>], x: &mut [f64], columns: usize) {
    let block = |(chain, offset): &Placed<'_>| offset * columns..(offset + chain.len()) * columns;
    if let ([a, b], [first, second]) = (ldl, chains) {
        let (ra, rb) = (block(first), block(second));
        if ra.end <= rb.start {
            let (head, tail) = x.split_at_mut(rb.start);
            Ldl::solve_together([a, b], [&mut head[ra], &mut tail[..rb.end - rb.start]], columns);
            return;
        }
    }
    for (ldl, placed) in ldl.iter().zip(chains) {
        ldl.solve_columns(&mut x[block(placed)], columns);
    }
}

/// The system's row of a chain's failing pivot.
fn at(offset: usize) -> impl Fn(NotPositiveDefinite) -> usize {
    move |e| offset + e.row
}

/// `y = M x` at the point whose cosines and sines are given. The body's
/// two chains are multiplied together ([`quasiseparable::multiply_together`]).
pub(super) fn multiply(chains: &[Placed<'_>], cos: &[f64], sin: &[f64], x: &[f64], y: &mut [f64]) {
    let range = |(chain, offset): &Placed<'_>| *offset..offset + chain.len();
    if let [first, second] = chains {
        let (ra, rb) = (range(first), range(second));
        if ra.end <= rb.start {
            let (head, tail) = y.split_at_mut(rb.start);
            let ys = [&mut head[ra.clone()], &mut tail[..rb.end - rb.start]];
            quasiseparable::multiply_together(
                [chain_rows(first, cos, sin), chain_rows(second, cos, sin)],
                [&x[ra], &x[rb]],
                ys,
            );
            return;
        }
    }
    for placed in chains {
        quasiseparable::multiply(chain_rows(placed, cos, sin), &x[range(placed)], &mut y[range(placed)]);
    }
}

/// The mass generators of a placed chain from the system's trigonometry.
fn chain_rows<'a>(
    &(chain, offset): &Placed<'a>,
    cos: &'a [f64],
    sin: &'a [f64],
) -> impl DoubleEndedIterator<Item = Generators<2>> + ExactSizeIterator + Clone + 'a {
    let range = offset..offset + chain.len();
    chain.mass_generators(&cos[range.clone()], &sin[range])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::Multibody;
    use crate::robot::Robot;

    /// Dense `M + T` of the whole system (block diagonal), row-major.
    fn dense(chains: &[Placed<'_>], cos: &[f64], sin: &[f64], diag: &[f64], off: &[f64]) -> Vec<f64> {
        let n = cos.len();
        let mut a = vec![0.0; n * n];
        for (chain, o) in chains {
            let rows: Vec<_> = chain.mass_generators(&cos[*o..], &sin[*o..]).collect();
            for (j, rj) in rows.iter().enumerate() {
                a[(o + j) * n + o + j] = rj.diagonal + diag[o + j];
                for (k, rk) in rows[..j].iter().enumerate() {
                    let mut v = rj.p[0] * rk.q[0] + rj.p[1] * rk.q[1];
                    if k + 1 == j {
                        v += off[o + k];
                    }
                    a[(o + j) * n + o + k] = v;
                    a[(o + k) * n + o + j] = v;
                }
            }
        }
        a
    }

    /// The iteration matrix's factors solve like the dense matrix, one
    /// right-hand side or several, and the product is the dense one.
    #[test]
    fn iteration_matrix_solves_like_the_dense_matrix() {
        let body = Robot::builtin().body(0.12, 0.10).unwrap();
        let chains = body.chains();
        let n = body.chain_a().len() + body.chain_b().len();
        let q: Vec<f64> = (0..n).map(|i| 1.5 + 0.3 * (i as f64).sin()).collect();
        let (sin, cos): (Vec<f64>, Vec<f64>) = q.iter().map(|phi| phi.sin_cos()).unzip();
        // A positive semidefinite tridiagonal dt D + dt^2 K, coupling the chains too (ignored).
        let t: Vec<f64> = (0..n).map(|i| 1e-5 * (1.0 + (i % 3) as f64)).collect();
        let diag: Vec<f64> = (0..n).map(|i| t[i] + if i > 0 { t[i - 1] } else { 0.0 }).collect();
        let off: Vec<f64> = t[..n - 1].iter().map(|x| -x).collect();
        let mut factors = Factors::new(&chains);
        factors.factor_iteration(&chains, &cos, &sin, &diag, &off).unwrap();
        let mut off_within = off.clone();
        off_within[body.chain_a().len() - 1] = 0.0;
        let a = dense(&chains, &cos, &sin, &diag, &off_within);
        let x: Vec<f64> = (0..3 * n).map(|i| (0.7 * i as f64).cos()).collect();
        let mut b = vec![0.0; 3 * n];
        for i in 0..n {
            for c in 0..3 {
                b[i * 3 + c] = (0..n).map(|k| a[i * n + k] * x[k * 3 + c]).sum();
            }
        }
        let mut columns = b.clone();
        factors.solve_columns(&chains, &mut columns, 3);
        let mut single: Vec<f64> = (0..n).map(|i| b[i * 3 + 1]).collect();
        factors.solve(&chains, &mut single);
        for i in 0..n {
            for c in 0..3 {
                assert!((columns[i * 3 + c] - x[i * 3 + c]).abs() < 1e-8, "row {i} column {c}");
            }
            assert_eq!(single[i], columns[i * 3 + 1]);
        }
        let mut y = vec![0.0; n];
        let first: Vec<f64> = (0..n).map(|i| x[i * 3]).collect();
        multiply(&chains, &cos, &sin, &first, &mut y);
        let mass = dense(&chains, &cos, &sin, &vec![0.0; n], &vec![0.0; n]);
        for i in 0..n {
            let expected: f64 = (0..n).map(|k| mass[i * n + k] * first[k]).sum();
            assert!((y[i] - expected).abs() < 1e-15, "product row {i}");
        }
    }

    /// A pivot that fails in chain B is reported at its row of the system.
    #[test]
    fn a_failing_pivot_names_the_system_row() {
        let body = Robot::builtin().body(0.06, 0.05).unwrap();
        let chains = body.chains();
        let n = body.chain_a().len() + body.chain_b().len();
        let (mut sin, cos) = (vec![0.0; n], vec![1.0; n]);
        let row = body.chain_a().len() + 2;
        sin[row] = f64::NAN;
        let mut factors = Factors::new(&chains);
        assert_eq!(factors.factor_mass(&chains, &cos, &sin), Err(row));
    }
}
