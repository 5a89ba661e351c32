//! # leech: exact statics of extensible soft climbing robots
//!
//! A LEeCH-type robot pushes three flexible tubes through a driving unit; their
//! free lengths `L1, L2, L3` set the body's shape, and gravity bends it. In the
//! plane of a climb the body is two chains of rigid links (docs/model.md section 3): chain A,
//! the centre tube, and chain B, the two side tubes lumped (twice the stiffness
//! and mass), clamped `b` apart at the driving unit and welded `c` apart at the
//! endpoint plate, which carries the payload `ms`.
//!
//! ## The maths in one page
//!
//! With absolute link angles `q = (phi^A, phi^B)` (rad) the potential is
//!
//! ```text
//! V(q) = sum_j k_j/2 (phi_j - phi_{j-1})^2  +  g sum_i m_i y_i(q)        (J)
//! ```
//!
//! and the endpoint plate imposes three constraints `C(q) = 0` (two position
//! rows and one angle row). An equilibrium solves the KKT system
//! `grad V = J^T lambda, C = 0`; it is stable when the Hessian of
//! `V - lambda . C` is positive definite on the null space of `J = dC/dq`.
//!
//! Three facts make it fast: the spring Hessian is tridiagonal, gravity's
//! Hessian is diagonal (`-g W_j sin phi_j`, [`chain`]), and each constraint's
//! Hessian is diagonal too ([`body`]). Newton's step is then a tridiagonal
//! factorization bordered by three dense rows: O(n) per step ([`linalg`]).
//!
//! Equilibria are not unique (folds, pitchforks, several unloaded shapes), so
//! [`statics`] follows the robot's history: tubes fed from equal lengths with no
//! gravity, then gravity raised to `g`, and it says when the body snapped or
//! buckled on the way.
//!
//! ## Quick start
//!
//! ```
//! use leech::prelude::*;
//!
//! let robot = Robot::builtin();                 // estimated LEeCH parameters
//! let body = robot.body(0.30, 0.28).unwrap();   // LA, LB in m
//! let eq = body.solve(&Solver::default()).unwrap();
//! let [x, y] = body.endpoint(&eq.q);
//! println!("endpoint at ({:.1}, {:.1}) mm, stable: {}", x * 1e3, y * 1e3, eq.stable);
//! assert!(eq.stable && eq.residual < 1e-10);
//! ```
//!
//! ## Modules
//!
//! * [`geom`]: plane vectors, unit vectors and normals.
//! * [`chain`]: one tube as a chain of links; discretizations, kinematics, energy.
//! * [`cantilever`]: a single clamped tube under gravity.
//! * [`batch`]: many clamped bodies at once (lengths and base angles as arrays), on all cores.
//! * [`body`]: the two-chain body and its endpoint weld.
//! * [`body3`]: the three-tube body in 3D (twist, turning) and its static solver; the
//!   robot's tri-tube constant-curvature model in the same conventions.
//! * [`calibration`]: fitting `k` (and `m`) to measured tubes and bodies; model comparison.
//! * [`constant_curvature`]: the kinematic constant-curvature model, planar and tri-tube.
//! * [`cup`]: whether a suction cup holds under a hold's reaction: pull-off, peel, slip.
//! * [`hold`]: which cups hold a body and where (rear, front, both, a free front joint), planar and 3D.
//! * [`hose`]: the hose's stop, a joint limit at its minimum bend radius, composed onto a body among solids.
//! * [`contact`]: contact rows between a body and a scene's solids, planar and 3D.
//! * [`stance3`]: the three-tube body held by its cups and among solids; each cup's reaction and verdict.
//! * [`stance`]: the body held by its rear cup, its front cup or both; the reactions on the cups.
//! * [`statics`]: the Newton-KKT solver, continuation, stability, inequality rows.
//! * [`dynamics`]: constrained forward dynamics and integrators.
//! * [`least_squares`]: bounded Levenberg-Marquardt for small fits and inverse problems.
//! * [`linalg`]: bordered block-tridiagonal LDL^T with inertia (any number of chains and
//!   border rows); O(n) quasiseparable mass matrices.
//! * [`inverse_statics`]: tube lengths that put the endpoint on a target.
//! * [`sweep`]: sweeps over tube lengths along the actuation path, reach metrics.
//! * [`robot`]: robot files (TOML) and the built-in robot.
//! * [`root`]: bracketed root finding (regula falsi with the Illinois rule).
//! * [`scene`]: floors, walls, steps and thin walls (TOML) and the geometric queries of contact.
//! * [`report`]: serializable results (what the command line prints and writes).
//! * [`error`]: input errors.
//! * [`budget`]: deadlines and cancel flags every long computation checks; what a stopped job did.

#![warn(missing_docs)]

pub mod batch;
pub mod body;
pub mod body3;
pub mod budget;
pub mod calibration;
pub mod cantilever;
pub mod chain;
pub mod constant_curvature;
pub mod contact;
pub mod cup;
pub mod dynamics;
pub mod error;
pub mod files;
pub mod geom;
pub mod geom3;
pub mod hold;
pub mod hose;
pub mod inverse_statics;
pub mod least_squares;
pub mod linalg;
pub mod report;
pub mod robot;
pub mod root;
pub mod scene;
pub mod stance;
pub mod stance3;
pub mod statics;
pub mod stride;
pub mod sweep;

/// The types most programs need.
pub mod prelude {
    pub use crate::body::Body;
    pub use crate::cantilever::{Cantilever, CantileverSpec};
    pub use crate::chain::{Chain, ChainSpec, Discretization};
    pub use crate::constant_curvature::{PlanarBody, TriTube};
    pub use crate::error::InputError;
    pub use crate::robot::Robot;
    pub use crate::statics::{
        Constraints, Equilibrium, Event, Path, Potential, Scratch, SolveError, Solver, SolverOptions, StaticSystem,
    };
}
