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
//! # Energy
//!
//! With `E = T + V`, `T = v^T M v / 2`, the exact motion loses energy at the
//! rate `dE/dt = -v^T D v <= 0` (the constraint forces do no work since
//! `J v = 0`). What each scheme keeps of that, for one step `q0 -> q1 =
//! q0 + dt v1` (backward Euler), multiplying its velocity equation by `v1`
//! and using `J(q1) v1 = 0`:
//!
//! ```text
//! E1 - E0 = -dt v1^T D v1 - |v1 - v0|^2_M / 2 - B + R,
//! B = V(q0) - V(q1) - grad V(q1) . (q0 - q1)   (= dt^2 v1^T H v1 / 2 + O(dt^3))
//! ```
//!
//! where `R` collects what a constant mass matrix would not have (`M(q1)`
//! against `M(q0)`, the velocity terms `h`) and the projection's
//! correction. The springs' energy is convex (`B >= 0` from them), gravity's
//! is not: where it destabilizes, `B` and `R` may be negative, of order
//! `dt^2 |v|^2`, and a long step on a fast, gravity-driven motion can gain
//! energy. The numerical damping `|v1 - v0|^2_M / 2` and the dampers
//! oppose it and dominate near rest; [`Simulation::max_energy_gain_j`]
//! measures the largest gain between samples while the inputs are
//! settled, and the tests hold it to round-off on soft and stiff bodies at
//! the default step. The implicit midpoint rule with the dampers on
//! satisfies the same balance with the midpoint velocity and without the
//! numerical damping; RK4 keeps energy to `O(dt^4)` per unit time at its
//! stability limit and otherwise promises nothing about its sign. While
//! the tubes are fed or gravity ramps up, the inputs do work and the energy
//! may rise.
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

pub use scenario::{
    energy_gain, simulate, Actuation, Sample, Simulation, SimulationError, SimulationOptions, Start, IMPLICIT_STEP_S,
    MAX_STEPS,
};
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

/// Why a step failed. Each message names the iterations the step's solve
/// used and the residual it had reached (the simulation adds the time), so
/// that a failure says how far the solve got.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepError {
    /// The mass matrix lost positive definiteness: it cannot at finite
    /// angles, and the integrators stop non-finite values at their source
    /// ([`StepError::NonFinite`]), so only a degenerate chain gets here.
    #[error("mass matrix not positive definite at link {index} (0 iterations, no residual: a degenerate chain)")]
    NonPositivePivot {
        /// The failing row.
        index: usize,
    },
    /// A quantity of the step overflowed to infinity or NaN: the step is
    /// far too long for the motion (an iteration that diverges, or RK4
    /// beyond its stability limit).
    #[error(
        "{integrator:?} step of {dt:e} s: the {what} went non-finite in iteration {iterations} ({}); use a smaller --dt",
        residual_phrase(*.residual)
    )]
    NonFinite {
        /// The scheme.
        integrator: Integrator,
        /// The step tried (s).
        dt: f64,
        /// What went non-finite.
        what: &'static str,
        /// The iteration (RK4: the stage) where it did.
        iterations: usize,
        /// The iteration's last finite residual (relative), infinite where
        /// there was none (RK4 does not iterate).
        residual: f64,
    },
    /// The implicit solve did not converge within its iterations.
    #[error("{integrator:?} step of {dt:e} s did not converge in {iterations} iterations (residual {residual:.3e}); use a smaller --dt")]
    NotConverged {
        /// The scheme.
        integrator: Integrator,
        /// The step tried (s).
        dt: f64,
        /// Iterations used.
        iterations: usize,
        /// What was left.
        residual: f64,
    },
    /// The projection onto the constraints did not converge.
    #[error(
        "projection onto the constraints failed after {iterations} iterations (residual: violation {violation:.3e} m or rad): the step left them too far; use a smaller --dt"
    )]
    Projection {
        /// Newton iterations used.
        iterations: usize,
        /// The remaining violation.
        violation: f64,
    },
    /// An initial state that does not satisfy the constraints.
    #[error("initial state violates the constraints (0 iterations, residual: violation {violation:.3e} m or rad); start from a static solution")]
    Inconsistent {
        /// The violation.
        violation: f64,
    },
}

/// The residual of [`StepError::NonFinite`] in words.
fn residual_phrase(residual: f64) -> String {
    if residual.is_finite() {
        format!("last finite residual {residual:.3e}")
    } else {
        "no residual: the scheme does not iterate".into()
    }
}

/// Whether every entry of `x` is finite.
pub(super) fn all_finite(x: &[f64]) -> bool {
    x.iter().all(|v| v.is_finite())
}
