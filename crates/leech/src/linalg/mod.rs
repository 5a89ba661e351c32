//! Structured linear algebra: factorizations and solves that exploit the
//! structure of the matrices met here instead of storing them densely. The
//! chains' mass matrices are semiseparable plus diagonal, and the implicit
//! integrators add a tridiagonal term: both are symmetric quasiseparable
//! matrices of small order, factored and solved in `O(n)`
//! ([`quasiseparable`]).

pub mod quasiseparable;
