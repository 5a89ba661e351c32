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
//! The body is solved, held and put among solids by [`crate::stance3`]
//! (holds from [`crate::hold`], contact rows from [`crate::contact`]):
//! this module is the body alone, its energy, weld and derivatives.
//!
//! # Layout
//!
//! The rotations it is written in (`Exp`, `Log`, `Jr^-1`, the local
//! derivatives of linear and relative terms, whether a matrix is a rotation)
//! are [`crate::geom3`], in the numbers layer. The files, each importing
//! only the ones before it: [`tube3`] (one tube's links); [`body3`] (the
//! body, its Lagrangian's derivatives); [`constant_curvature3`] (the
//! tri-tube constant-curvature model in the same conventions, and its
//! difference from the body).

#[allow(clippy::module_inception)]
pub mod body3;
pub mod constant_curvature3;
pub mod tube3;

pub use body3::{Body3, Derivatives, Frames, PLATE_ROWS};
pub use constant_curvature3::ConstantCurvature3;
pub use tube3::Tube3;
