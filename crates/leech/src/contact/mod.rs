//! Contact between a body and a scene's solids, planar ([`planar`]: the
//! two-tube body and the single tube among [`crate::scene::Scene`]'s
//! polygons and half-planes) and in 3D ([`space`]: the three-tube body among
//! [`crate::scene::Scene3`]'s solids): rows composed onto a body's system,
//! not part of the body.
//!
//! # The rule every contact follows
//!
//! A contact holds a material point `x(q)` of the body on the free side of
//! a surface, the tube's radius `r` of clearance kept by its centre line:
//!
//! ```text
//! g(q) = n . x(q) - h >= 0        h = n . c + r          (m)   the point stays out
//! mu >= 0                                                 (N)   the surface only pushes
//! mu g = 0                                                       force only where the gap is closed
//! ```
//!
//! with `n` the surface's outward unit normal and `c` its point nearest
//! `x`, both frozen while Newton runs and refreshed from the new geometry
//! at each solved shape; at the fixed point `n` is the true contact normal,
//! so the frozen rows are the exact frictionless conditions. The Lagrangian
//! gets `-mu g`; `mu`, the row's multiplier, is the normal force. A row's
//! Jacobian is dense along its chain up to the point (one border row of the
//! bordered factorization) and its Hessian is diagonal in the planar angles
//! and block diagonal in the 3D frames: contacts add no coupling to the
//! body's band. Candidates are the points within a margin of a surface;
//! rows that do not touch stay inactive and cost nothing in the
//! factorization. Which rows act is decided by the callers' active sets
//! ([`crate::stance`], [`crate::stance3`]; docs/model.md section 7.3.1,
//! docs/model3d.md section 12).
//!
//! The robot's rigid faces that rest on the solids with no clearance (a
//! free cup's face, the free driving unit's outline) are [`planar::Face`]s:
//! rows at their corners and where a solid's convex corner touches an edge.
//! A new kind of contact (a cup's lip, friction) is a new file here beside
//! these two.

pub mod planar;
pub mod space;
