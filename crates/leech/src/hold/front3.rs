//! The 3D front hold's equations: gravity turning with the plate while the
//! driving unit hangs from the front cup ([`Hanging`]), the front target's
//! six rows when both cups hold ([`FRONT_ROWS`], `FrontTarget`, held through
//! a compliance that starts the both cups' path), and the solver's picture
//! of a front hold (`FrontHold`: the driving unit kept fixed, the world
//! turning with the plate). The equations of the picture are
//! [`crate::stance3::held3`]'s, which solves the holds.

use crate::geom3::{apply, axpy, exp, log, mul, mul_tn, scale, transpose, Mat3, Vec3};
use crate::scene::Plane3;

/// The front hold's rows when both cups hold: tube 1's tip (3, m), then
/// the plate's frame (3, rad).
pub const FRONT_ROWS: usize = 6;

/// The front hold's target when both cups hold: tube 1's tip (m) and the
/// plate's frame, held through a compliance (m/N for the tip rows, rad/(N
/// m) for the frame's; zero: rigidly) that starts the path (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FrontTarget {
    pub tip: Vec3,
    pub plate: Mat3,
    pub compliance: [f64; 2],
}

impl FrontTarget {
    /// The target a fraction `t` of the way to `to`: the tip along the
    /// segment, the frame along the geodesic `R Exp(t Log(R^T R_to))`.
    pub(crate) fn toward(&self, to: &FrontTarget, t: f64) -> FrontTarget {
        let turn = log(&mul_tn(&self.plate, &to.plate));
        FrontTarget {
            tip: axpy(t, axpy(-1.0, self.tip, to.tip), self.tip),
            plate: mul(&self.plate, &exp(scale(t, turn))),
            compliance: self.compliance,
        }
    }
}

/// The front hold as the solver sees it: tube 1's tip held at `tip` (m),
/// the plate's frame `plate`, the driving unit's mass (kg). The world is
/// `x = plate R'_P^T (x' - x'_tip) + tip` in the solver's picture (module
/// doc); planes of the scene are kept in the held plate's frame, origin at
/// tube 1's tip, where they stay put while the picture's plate turns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FrontHold {
    pub tip: Vec3,
    pub plate: Mat3,
    pub unit_mass_kg: f64,
}

impl FrontHold {
    /// Gravity turning with the plate: up in the held plate's frame.
    pub fn hanging(&self) -> Hanging {
        Hanging { up: apply(&transpose(&self.plate), [0.0, 1.0, 0.0]), unit_mass_kg: self.unit_mass_kg }
    }

    /// A world plane in the held plate's frame.
    pub fn plane_local(&self, plane: &Plane3) -> Plane3 {
        let back = transpose(&self.plate);
        Plane3 { point_m: apply(&back, axpy(-1.0, self.tip, plane.point_m)), normal: apply(&back, plane.normal) }
    }

    /// A plane of the held plate's frame in the world.
    pub fn plane_world(&self, plane: &Plane3) -> Plane3 {
        Plane3 {
            point_m: axpy(1.0, self.tip, apply(&self.plate, plane.point_m)),
            normal: apply(&self.plate, plane.normal),
        }
    }
}

/// Gravity on the body hanging from the front cup, in the fixed unit's
/// picture (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hanging {
    /// `u = R_f^T e_y`: up, in the held plate's frame (unit vector).
    pub up: Vec3,
    /// The driving unit's mass `Md` (kg).
    pub unit_mass_kg: f64,
}
