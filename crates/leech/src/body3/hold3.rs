//! What holds the three-tube body: the hold ([`Hold3`]: the rear cup, the
//! front cup, both, a free front joint) and what a hold puts on the body's
//! evaluation: gravity turning with the plate under a front hold
//! ([`Hanging`]), the front target's six rows when both cups hold
//! ([`FRONT_ROWS`], `FrontTarget`), the solver's picture of a front hold
//! (`FrontHold`). The equations are [`super::held3`]'s, which solves the
//! holds.

use crate::error::InputError;
use crate::geom3::{apply, axpy, exp, is_rotation, log, mul, mul_tn, scale, transpose, Mat3, Vec3};
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

/// A hold's point (named `point_field`) must be finite and its frame (named
/// `frame_field`) a rotation.
pub(crate) fn check_hold(point_field: &str, point: Vec3, frame_field: &str, frame: &Mat3) -> Result<(), InputError> {
    if !point.iter().all(|x| x.is_finite()) {
        return Err(InputError::Invalid {
            field: point_field.into(),
            value: format!("{point:?}"),
            allowed: "finite coordinates".into(),
        });
    }
    if !is_rotation(frame) {
        return Err(InputError::Invalid {
            field: frame_field.into(),
            value: format!("{frame:?}"),
            allowed: "a rotation matrix (orthonormal to 1e-9, determinant +1)".into(),
        });
    }
    Ok(())
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

/// Which cup holds the 3D body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hold3 {
    /// The rear cup: the driving unit where [`Body3::from_robot`](super::Body3::from_robot) put it.
    Rear,
    /// The front cup: tube 1's tip at `tip_m` (m), the plate's frame
    /// `plate` (a rotation, columns the plate's axes); the driving unit
    /// hangs from it.
    Front {
        /// Where tube 1's tip is held (m).
        tip_m: Vec3,
        /// The plate's frame.
        plate: Mat3,
    },
    /// Both cups: the driving unit where [`Body3::from_robot`](super::Body3::from_robot) put it (as
    /// [`Hold3::Rear`]) and tube 1's tip at `tip_m` (m) with the plate's
    /// frame `plate` (as [`Hold3::Front`]): a closed loop, statically
    /// indeterminate, the tubes' elasticity sharing the load between the
    /// cups (module doc).
    Both {
        /// Where tube 1's tip is held (m).
        tip_m: Vec3,
        /// The plate's frame.
        plate: Mat3,
    },
    /// The front cup on a free rotation joint about its face's normal
    /// (the sideways maneuver, paper Fig. 11): the face's centre `centre_m`
    /// (m) and normal `plate e_y` fixed, the plate free to turn about that
    /// normal. The body swings from the plate's frame `plate` the way gravity
    /// turns it until the moment about the normal vanishes (module doc).
    FrontPivot {
        /// The front cup's face centre (m).
        centre_m: Vec3,
        /// The plate's frame where the swing starts.
        plate: Mat3,
    },
}
