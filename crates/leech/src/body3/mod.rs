//! The three-tube body in 3D and its static solver (docs/model3d.md).
//!
//! World x horizontal, y up, `z = x cross y`; gravity `(0, -g, 0)`. The
//! driving unit has the pose `(p0, R0)`, `R0` turning `+x` to the clamp
//! direction `phi0` in the x-y plane. Tubes 1, 2, 3 leave it at the
//! vertices of an equilateral triangle in the unit's local y-z plane,
//! `(0, r_b, 0)` and `(0, -r_b/2, +-r_b sqrt(3)/2)` with `r_b = b / 1.5`;
//! each is a chain of rigid links with frames `R_j` (local x the tangent),
//! a point mass at each link's tip and, at joint `j`, the energy
//!
//! ```text
//! E_j = (kt_j theta_x^2 + k_j (theta_y^2 + theta_z^2)) / 2,     theta_j = Log(R_{j-1}^T R_j)   (J, rad)
//! ```
//!
//! The endpoint plate is rigid with tube 1's last link; tubes 2 and 3 are
//! welded to it at the vertices of the triangle of radius `r_t = c / 1.5`
//! (12 rows: [`body3::PLATE_ROWS`]); the payload sits at the midpoint of
//! tubes 2 and 3's tips. With `L2 = L3`, `b = c` and gravity in the
//! symmetry plane this is exactly the planar [`crate::body::Body`].
//!
//! # One solver
//!
//! The body is solved by [`crate::statics`], the planar body's solver,
//! through [`system3::System3`]: the contract's blocks of 3 (the Hessian
//! block tridiagonal with 3 x 3 blocks along each tube, the plate's 3
//! coordinates free border rows of [`crate::linalg::BorderedLdl`]), its
//! retraction `R <- R Exp(delta)` on SO(3) (the gradient and Hessian are
//! those of the pullback at `delta = 0`) and a Hessian that holds the
//! weld's curvature times its multipliers (a weld of two frames is bilinear
//! in them, so its Hessian is not diagonal). [`solve`] keeps only the
//! body's paths (feeding, loading, the front hold's target) and the contact
//! rows' active set among solids; Newton, continuation and the escapes from
//! unstable points are the solver's, with its options and tuning.
//!
//! # Holds
//!
//! The body as built has its driving unit fixed: the rear cup holds.
//! [`Body3::solve_held`] solves it held by the rear cup, by the front cup
//! (the driving unit hanging: gravity turns with the plate, no unknown
//! added), by both cups (a closed loop: six rows on tube 1's tip and the
//! plate) or by the front cup on a free joint about its face's normal (the
//! swing of the sideways maneuver), and gives each holding cup's reaction
//! as a 6-vector (force and moment about the cup's centre, world frame) and
//! its verdict ([`held3`]):
//!
//! ```
//! use leech::body3::Body3;
//! use leech::hold::{AsBuilt, Hold3, Pose3};
//! use leech::geom3::rot_z;
//! use leech::prelude::*;
//! let robot = Robot::builtin();
//! let body = Body3::from_robot(&robot, [0.25, 0.28, 0.22]).unwrap();
//! let solver = Solver::default();
//! let rear = body.solve_held(&robot, Hold3::Rear(AsBuilt), &solver).unwrap();
//! assert!(rear.rear.unwrap().verdict.holds);
//! // Held at the front, the plate along +y (up a wall), the unit below.
//! let hold = Hold3::Front(Pose3 { point_m: [0.0, 0.5, 0.0], frame: rot_z(std::f64::consts::FRAC_PI_2) });
//! let front = body.solve_held(&robot, hold, &solver).unwrap();
//! assert!(front.body.tube(0).root()[1] < 0.5);
//! ```
//!
//! # Contacts
//!
//! Among a [`crate::scene::Scene3`]'s solids (planes, boxes, planar scenes
//! as prisms) the link tips keep the tube's radius from the solids:
//! unilateral rows, one more border row each, with an active set
//! ([`contact3`]); [`Body3::solve_held_among`] solves the rear hold among
//! them (the front holds and both cups holding are not yet among solids).

//! # Layout
//!
//! The rotations it is written in (`Exp`, `Log`, `Jr^-1`, the local
//! derivatives of linear and relative terms, whether a matrix is a rotation)
//! are [`crate::geom3`], in the numbers layer. The files, each importing
//! only the ones before it: [`tube3`] (one tube's links); [`body3`] (the body, its Lagrangian's
//! derivatives); [`contact3`] (contact rows with scene solids);
//! [`equilibrium3`] (the solved body: frames, summary, contacts);
//! [`system3`] (the body as a static system of [`crate::statics`]);
//! [`solve`] (the paths and the contacts' active set); [`place3`] (placing the body for a
//! hold: the plate's frame from angles, the cups, the points a scene must
//! leave free); [`held3`] (the body held: the holds' equations and solves,
//! among solids too, each cup's reaction and verdict); [`planar`] (the
//! comparison with the planar model); [`constant_curvature3`] (the
//! tri-tube constant-curvature model in the same conventions, and its
//! difference from the body).

#[allow(clippy::module_inception)]
pub mod body3;
pub mod constant_curvature3;
pub mod contact3;
pub mod equilibrium3;
pub mod held3;
pub mod place3;
pub mod planar;
pub mod solve;
pub mod system3;
pub mod tube3;

pub use body3::{Body3, Derivatives, Frames, PLATE_ROWS};
pub use constant_curvature3::ConstantCurvature3;
pub use contact3::{Contact3, ContactRow3};
pub use equilibrium3::Equilibrium3;
pub use held3::{verdict3, CupState3, Held3, Wrench};
pub use tube3::Tube3;
