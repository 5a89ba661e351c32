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
        for ((chain, offset), ldl) in chains.iter().zip(&mut self.mass) {
            let range = *offset..offset + chain.len();
            ldl.factor(chain.mass_generators(&cos[range.clone()], &sin[range])).map_err(at(*offset))?;
        }
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
        for ((chain, offset), ldl) in chains.iter().zip(&mut self.iteration) {
            let (k, o) = (chain.len(), *offset);
            let range = o..o + k;
            let rows = chain.mass_generators(&cos[range.clone()], &sin[range]).enumerate().map(|(j, m)| {
                let coupling = if j + 1 < k { off[o + j] } else { 0.0 };
                Generators {
                    diagonal: m.diagonal + diag[o + j],
                    p: [m.p[0], m.p[1], 1.0],
                    q: [m.q[0], m.q[1], coupling],
                    a: [1.0, 1.0, 0.0],
                }
            });
            ldl.factor(rows).map_err(at(o))?;
        }
        self.held = Held::Iteration;
        Ok(())
    }

    /// Solves the factored block-diagonal system in place.
    pub(super) fn solve(&self, chains: &[Placed<'_>], x: &mut [f64]) {
        for (b, (chain, offset)) in chains.iter().enumerate() {
            let block = &mut x[*offset..offset + chain.len()];
            match self.held {
                Held::Mass => self.mass[b].solve(block),
                Held::Iteration => self.iteration[b].solve(block),
                Held::Nothing => unreachable!("solve before a successful factorization"),
            }
        }
    }
}

/// The system's row of a chain's failing pivot.
fn at(offset: usize) -> impl Fn(NotPositiveDefinite) -> usize {
    move |e| offset + e.row
}

/// `y = M x` at the point whose cosines and sines are given.
pub(super) fn multiply(chains: &[Placed<'_>], cos: &[f64], sin: &[f64], x: &[f64], y: &mut [f64]) {
    for (chain, offset) in chains {
        let range = *offset..offset + chain.len();
        quasiseparable::multiply(
            chain.mass_generators(&cos[range.clone()], &sin[range.clone()]),
            &x[range.clone()],
            &mut y[range],
        );
    }
}
