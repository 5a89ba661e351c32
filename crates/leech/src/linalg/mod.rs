//! Sparse symmetric indefinite factorization of bordered block-tridiagonal
//! matrices, with the inertia, in O(n k^2).
//!
//! The matrices solved here are
//!
//! ```text
//!     [ A + shift I   B           ] [x]   [r]
//! K = [ B^T           C + shift P ] [y] = [c]
//! ```
//!
//! where `A` (n x n) is a direct sum of independent block-tridiagonal chains
//! (blocks of size 1 or 3, coupling only between consecutive blocks of one
//! chain), `B` (n x k) is a dense border of `k <= 64` rows, `C` (k x k) is a
//! dense symmetric corner, and `P` selects the first `k_primal` border rows:
//! extra primal unknowns (a floating base's pose) that are shifted like the
//! sparse unknowns, while the remaining constraint rows are not.
//! [`Pattern`] holds that structure, [`BorderedLdl`] the numbers.
//!
//! ## Bordered solve
//!
//! Each chain of `A + shift I` is factored as `L D L^T` (block bidiagonal unit
//! `L`, block diagonal `D`) without pivoting. With `W = L^-1 B` the Schur
//! complement of the sparse block is
//!
//! ```text
//! S = C + shift P - B^T A^-1 B = C + shift P - W^T D^-1 W        (k x k),
//! ```
//!
//! symmetric by construction and computed from `W` and `D` alone (inside the
//! forward pass that produces `W` on the fast path, right after it
//! otherwise): unlike `kkt`'s `B^T A^-1 B`, no backward pass over the border
//! columns is needed. The solve is then
//!
//! ```text
//! t = L^-1 r,   S y = c - W^T D^-1 t,   x = L^-T D^-1 (t - W y),
//! ```
//!
//! two passes over the chains and one small dense solve.
//!
//! ## Inertia (Sylvester's law)
//!
//! `K` is congruent to `diag(A, S)`, so by Sylvester's law of inertia
//!
//! ```text
//! inertia(K) = inertia(A) + inertia(S) = inertia(D) + inertia(S).
//! ```
//!
//! The pivots of `D` are counted directly (a 3 x 3 pivot block through its own
//! symmetric indefinite factorization, since it may be indefinite). `S` is
//! factored by the Bunch-Kaufman `P S P^T = L D L^T` with 1 x 1 and 2 x 2
//! pivots in [`dense_ldl`]: written here rather than taken from a library
//! because it must work in place, allocate nothing, and report the inertia.
//! Pivoting makes this robust where an unpivoted `L D L^T` of `S` would need
//! an eigen-decomposition as a fallback: a tiny diagonal is passed over for a
//! larger one or for a 2 x 2 pivot.
//!
//! A chain pivot with `|d| <= tiny` counts as zero; `S` is first scaled so
//! that each row's largest entry is 1 (its rows mix units: shifted primal
//! rows beside constraint rows), and its pivots below `1e-12` count as zero;
//! direction is dropped from the solve (its reciprocal is taken as 0), which
//! keeps every factor finite. A count with `zero > 0` means the matrix is
//! numerically singular, or (a zero in a chain) that it cannot be factored
//! without pivoting across the border; either way the solve is then a finite
//! guess, not a solution, and the caller should change the shift.
//!
//! ## Speed
//!
//! The chains' recurrences are serial, so two chains are walked side by side
//! in two lanes whose instructions overlap in the pipeline; with one scalar
//! unknown per block and at most three border rows, the border columns and
//! the Schur complement live in registers (a monomorphized fast path).
//!
//! A border row that is zero on a chain, or on its first blocks, can be
//! declared so ([`Pattern::set_border_start`]): `W = L^-1 B` keeps those
//! zeros (the recurrence only carries entries forward), and the 3 x 3 block
//! path computes `W` and `W^T D^-1 W` only on the rows present at each
//! block, `O(sum_j m_j^2)` with `m_j` the rows present at block `j` instead
//! of `O(n k^2)`, in kernels of a width fixed at compile time. The scalar
//! path for `k > 3` finds such zeros itself: its update of `S` by a group of
//! unknowns stops at the group's last nonzero border row and skips the
//! columns whose coefficients are all zero (a contact row on the other
//! chain, a hold's rows on the pose alone), which leaves every remaining sum
//! as it was, term for term.

//!
//! ## Quasiseparable matrices
//!
//! The chains' mass matrices are semiseparable plus diagonal, and the
//! implicit integrators add a tridiagonal term: both are symmetric
//! quasiseparable matrices of small order, factored and solved in `O(n)`
//! ([`quasiseparable`]).

mod block_tridiagonal;
mod bordered_ldl;
pub mod dense_ldl;
mod pattern;
pub mod quasiseparable;
mod tridiagonal;

use std::ops::{Add, AddAssign};

pub use bordered_ldl::BorderedLdl;
pub use dense_ldl::{solve_symmetric, DenseLdl, Pivot};
pub use pattern::Pattern;

/// Largest number of border rows a [`Pattern`] carries.
pub const MAX_BORDER: usize = 64;

/// Numbers of positive, negative and zero eigenvalues of a symmetric matrix,
/// as counted from the pivots of a factorization (Sylvester's law).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct InertiaCount {
    /// Positive eigenvalues.
    pub positive: usize,
    /// Negative eigenvalues.
    pub negative: usize,
    /// Eigenvalues counted as zero: pivots with `|d| <= tiny`.
    pub zero: usize,
}

impl InertiaCount {
    /// Order of the matrix counted.
    pub fn dimension(&self) -> usize {
        self.positive + self.negative + self.zero
    }
}

impl Add for InertiaCount {
    type Output = InertiaCount;

    fn add(self, other: InertiaCount) -> InertiaCount {
        InertiaCount {
            positive: self.positive + other.positive,
            negative: self.negative + other.negative,
            zero: self.zero + other.zero,
        }
    }
}

impl AddAssign for InertiaCount {
    fn add_assign(&mut self, other: InertiaCount) {
        *self = *self + other;
    }
}
