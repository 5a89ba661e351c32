//! Constrained forward dynamics of a tube or of the body, and integrators.
//!
//! # Equations
//!
//! With the chains' mass matrix `M(q)` (block diagonal, kg m^2, [`crate::chain`]),
//! velocity terms `h(q, v)`, potential `V(q)` (springs and gravity), dampers
//! `D` (tridiagonal, on relative rates) and the plate constraints `C(q) = 0`
//! with Jacobian `J` (the weld of [`crate::body`]; none for a single tube):
//!
//! ```text
//! M a = Q + J^T lambda,      Q = -grad V - D v - h        (N m)
//! J a = -gamma,              gamma_r = sum_j (d2 C_r / dq_j^2) v_j^2
//! ```
//!
//! (every constraint Hessian is diagonal, so `gamma` is a sum of squares).
//! By Gauss' principle `lambda = -(J M^-1 J^T)^-1 (J M^-1 Q + gamma)`:
//! with `Y = M^-1 J^T` (`m` solves, `m <= 3` constraint rows) and the
//! `m x m` Schur complement `S = J Y`,
//!
//! ```text
//! a = M^-1 Q + Y lambda,     S lambda = -gamma - J M^-1 Q.
//! ```
//!
//! Drift is removed after every step by projecting onto the constraint
//! manifold (positions by Newton with the least-norm correction
//! `-J^T (J J^T)^-1 C`, then velocities onto `J v = 0`), so the constraints
//! hold to rounding throughout.
//!
//! # O(n) mass algebra
//!
//! A chain's mass matrix is dense but structured: with `e_j = (cos phi_j,
//! sin phi_j)`, `cos(phi_j - phi_k) = e_j . e_k` splits it into
//!
//! ```text
//! M_jj = C_jj + I_j,     M_jk = (W_j e_j) . (l_k e_k)   (j > k),
//! ```
//!
//! semiseparable plus diagonal: a symmetric quasiseparable matrix of order
//! 2 ([`crate::linalg::quasiseparable`], [`Chain::mass_generators`](crate::chain::Chain::mass_generators)). The
//! iteration matrices of the implicit scheme add a tridiagonal `T`, carried
//! by a third generator component (`p = (u, 1)`, `q = (v, t)`, transition
//! `(1, 1, 0)`: it reaches the first subdiagonal only). Both are factored
//! `L D L^T` in `O(n)`, solved and multiplied in `O(n)`, so that a step
//! costs `O(n)` (with `m` solves for `Y`): no dense matrix is formed.
//!
//! Every vector a step needs is allocated with the [`Simulator`], once.
//!
//! # Integrators
//!
//! * [`Integrator::Explicit`]: classical RK4, stable for `dt` below about
//!   `2.8 / omega_max`; [`Simulator::stable_step`] estimates `omega_max` by
//!   power iteration on `M^-1 K`.
//! * [`Integrator::Implicit`]: backward Euler, `M(q1)(v1 - v0) = dt (Q(q1, v1) + J^T lambda)`,
//!   `q1 = q0 + dt v1`, solved by Newton with the iteration matrix
//!   `M + dt D + dt^2 H`, `H` the statics' Lagrangian Hessian (tridiagonal
//!   plus diagonal), factored once per step (simplified Newton). The
//!   iterations stop when the error left, estimated from the observed
//!   contraction `theta` of the corrections as `theta / (1 - theta)` times
//!   the last one, is below `1e-10 (1 + max |v1|)` (Hairer and Wanner;
//!   the estimate counts while `theta < 1`, and a correction below that
//!   bound converges by itself); 40 iterations fail the step. Stable at
//!   steps far beyond the explicit limit; it damps the fast modes (first
//!   order).
//! * [`Integrator::Midpoint`]: the implicit midpoint rule, solved by
//!   fixed-point iteration on the midpoint velocity. Symmetric: with the
//!   dampers off it keeps the energy to `O(dt^2)` without drift. Needs
//!   `dt omega_max < 1` for the iteration to converge.
//!
//! Energies are in J, times in s.

mod backward_euler;
mod mass;
mod midpoint;
mod rk4;
mod rows;
mod scenario;
mod simulator;
mod stability;

pub use scenario::{simulate, Actuation, Sample, Simulation, SimulationError, SimulationOptions, Start, MAX_STEPS};
pub use simulator::{Multibody, Simulator};

/// Time-stepping scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Integrator {
    /// RK4 with projection.
    Explicit,
    /// Backward Euler with Newton iterations on the statics Hessian.
    Implicit,
    /// Implicit midpoint (fixed-point iterations), energy-conserving.
    Midpoint,
}

/// Where the system is and how it moves: the state that the integrators advance.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// Angles (rad).
    pub q: Vec<f64>,
    /// Angular rates (rad/s).
    pub v: Vec<f64>,
}

/// Why a step failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepError {
    /// The mass matrix lost positive definiteness (it cannot; a NaN got in).
    #[error("mass matrix not positive definite at link {index}")]
    NonPositivePivot {
        /// The failing row.
        index: usize,
    },
    /// The implicit solve did not converge within its iterations.
    #[error("{integrator:?} step of {dt} s did not converge (residual {residual:.3e}); use a smaller --dt")]
    NotConverged {
        /// The scheme.
        integrator: Integrator,
        /// The step tried (s).
        dt: f64,
        /// What was left.
        residual: f64,
    },
    /// The projection onto the constraints did not converge.
    #[error("projection onto the constraints failed (violation {violation:.3e})")]
    Projection {
        /// The remaining violation.
        violation: f64,
    },
    /// An initial state that does not satisfy the constraints.
    #[error("initial state violates the constraints by {violation:.3e} (m or rad); start from a static solution")]
    Inconsistent {
        /// The violation.
        violation: f64,
    },
}
