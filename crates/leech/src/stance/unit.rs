//! The driving unit as a rigid body: its mass, where that mass sits, and
//! its outline, all in the unit's own frame.
//!
//! # The unit's frame
//!
//! The frame's origin is chain A's clamp `p0`, its axes the clamp direction
//! `e(phi0)` ("along") and the right normal `nu(phi0)` ("across", towards
//! chain B and the rear cup). A point `(a, c)` of the unit is in the world at
//!
//! ```text
//! x = p0 + a e(phi0) + c nu(phi0)                                     (m)
//! dx/dphi0   = a e'(phi0) + c e(phi0)         (nu' = e, e' = (-sin, cos))
//! d2x/dphi0^2 = -a e(phi0) + c e'(phi0)
//! ```
//!
//! linear in `p0` and with a diagonal second derivative in `phi0`, so a
//! contact row on the unit keeps the Hessian's pattern (three free
//! coordinates, docs/model.md section 7.1).
//!
//! # The outline
//!
//! A rectangle `length x height` (m) with chain A's clamp `back` from its
//! back and `top` from its top (the side away from the cups): corners
//! `(-back, -top)`, `(length - back, -top)`, `(length - back, height - top)`,
//! `(-back, height - top)`. Both clamps lie inside it with the tube's radius
//! clear, and the rear cup's face lies on or beyond its bottom
//! ([`crate::robot::DrivingUnit`] checks both). Where the unit is free (the
//! rear cup does not hold) its corners and edges are faces of the robot that
//! rest on the scene's solids with no clearance, as a free cup's face does
//! ([`crate::contact::planar`]); where the rear cup holds, the hold fixes it.

use crate::body::Body;
use crate::geom::Vec2;
use crate::robot::Robot;

/// The driving unit's rigid geometry and mass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unit {
    /// Its mass (kg).
    pub mass_kg: f64,
    /// Where the mass sits in the unit's frame, `(along, across)` (m).
    pub centre_m: Vec2,
    /// The outline's corners in the unit's frame (m), or `None` for a unit
    /// that has no extent (nothing of it touches).
    pub outline_m: Option<[Vec2; 4]>,
}

impl Unit {
    /// A point mass `mass_kg` at the clamps' midpoint, `b/2` across, with no outline.
    pub fn point_mass(mass_kg: f64, base_spacing: f64) -> Unit {
        Unit { mass_kg, centre_m: [0.0, 0.5 * base_spacing], outline_m: None }
    }

    /// The unit of `robot`'s `[driving_unit]` under `body`, carrying the
    /// tubes' tails behind its clamps ([`Robot::planar_unit_mass_kg`]).
    pub fn of(robot: &Robot, body: &Body) -> Unit {
        let unit = &robot.driving_unit;
        Unit {
            mass_kg: robot.planar_unit_mass_kg(body.chain_a().tube_length(), body.chain_b().tube_length()),
            centre_m: unit.centre_of_mass_m.unwrap_or([0.0, 0.5 * robot.body.base_spacing_m]),
            outline_m: unit.outline_m(),
        }
    }
}

/// The point `local = (along, across)` of a frame at `origin` turned to
/// `angle` (rad), in the world, with its first two derivatives in `angle`
/// (the module's equations).
pub(crate) fn placed(origin: Vec2, local: Vec2, angle: f64) -> [Vec2; 3] {
    let [a, c] = local;
    let (s, k) = angle.sin_cos();
    // e = (k, s), nu = (s, -k); e' = (-s, k).
    [
        [origin[0] + a * k + c * s, origin[1] + a * s - c * k],
        [-a * s + c * k, a * k + c * s],
        [-a * k - c * s, -a * s + c * k],
    ]
}
