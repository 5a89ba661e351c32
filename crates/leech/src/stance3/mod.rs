//! The three-tube body of [`crate::body3`] held and among solids: the
//! holds of [`crate::hold`] and the contact rows of [`crate::contact`]
//! composed onto the body and solved by [`crate::statics`]
//! (docs/model3d.md sections 6 to 8 and 12), as [`crate::stance`] does for
//! the planar body.
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
//! [`solve`](fn@solve) solves it held by the rear cup, by the front cup
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
//! use leech::stance3;
//! let robot = Robot::builtin();
//! let body = Body3::from_robot(&robot, [0.25, 0.28, 0.22]).unwrap();
//! let solver = Solver::default();
//! let rear = stance3::solve(&robot, &body, Hold3::Rear(AsBuilt), &solver).unwrap();
//! assert!(rear.rear.unwrap().verdict.holds);
//! // Held at the front, the plate along +y (up a wall), the unit below.
//! let hold = Hold3::Front(Pose3 { point_m: [0.0, 0.5, 0.0], frame: rot_z(std::f64::consts::FRAC_PI_2) });
//! let front = stance3::solve(&robot, &body, hold, &solver).unwrap();
//! assert!(front.body.tube(0).root()[1] < 0.5);
//! ```
//!
//! # Contacts
//!
//! Among a [`crate::scene::Scene3`]'s solids (planes, boxes, planar scenes
//! as prisms) the link tips keep the tube's radius from the solids:
//! unilateral rows, one more border row each, with an active set
//! ([`crate::contact::space`]); [`solve_in`] solves every hold among them.

//! # Layout
//!
//! The files, each importing only the ones before it: [`equilibrium3`] (the
//! solved body: frames, summary, contacts); [`system3`] (the body as a
//! static system of [`crate::statics`]); [`solve`] (the paths and the
//! contacts' active set); [`place3`] (placing the body for a hold: the
//! plate's frame from angles, the cups, the points a scene must leave free);
//! [`held3`] (the body held: the holds' equations and solves, among solids
//! too, each cup's reaction and verdict); [`planar`] (the comparison with
//! the planar model).

pub mod equilibrium3;
pub mod held3;
pub mod place3;
pub mod planar;
pub mod solve;
pub mod system3;

pub use equilibrium3::Equilibrium3;
pub use held3::{solve, solve_in, verdict3, CupState3, Held3, Wrench};
