//! Which cups hold a body, and where: one vocabulary for the planar body
//! ([`crate::stance`]) and the three-tube body ([`crate::body3`]).
//!
//! # The holds
//!
//! | hold | fixed | free |
//! | --- | --- | --- |
//! | [`Hold::Rear`] | the driving unit (its clamp point and direction) | the endpoint plate |
//! | [`Hold::Front`] | the endpoint plate (tube A's / tube 1's tip and the plate's frame) | the driving unit, hanging |
//! | [`Hold::Both`] | both: a closed loop, statically indeterminate | nothing rigid: the tubes share the load |
//! | [`Hold::FrontPivot`] | the front cup's face (centre and normal) | the plate's turn about that normal |
//!
//! A hold is generic in what places each end: in the plane a [`Pose`]
//! (point, m; direction, rad) for both ends; in 3D the rear is the body
//! where it was built ([`AsBuilt`]: the body carries its placement) and the
//! front a [`Pose3`] (point, m; frame, a rotation). [`Hold3`] names the 3D
//! form.
//!
//! # A free front joint in the plane
//!
//! The front cup's free joint turns about the face's normal, which lies in
//! the plane of a planar body. A planar body's loads are forces in the plane
//! at points of the plane, whose moments are all normal to it: the moment
//! about the face's normal is zero at every shape, so the joint never turns
//! and [`Hold::FrontPivot`] holds a planar body exactly as [`Hold::Front`]
//! does. In 3D the swing it allows is solved ([`crate::stance3::held3`]).
//! Whether the robot has the joint is its file's `cup.front_free_joint`
//! (the paper's robot has it): without it a front pivot hold is bad input
//! ([`check_front_joint`]), in the plane as in 3D.
//!
//! The 3D front hold's equations (gravity turning with the plate, the front
//! target's rows) are in [`front3`].

pub mod front3;

use crate::error::InputError;
use crate::geom::Vec2;
use crate::geom3::{is_rotation, Mat3, Vec3};

/// A pose in the plane: a point (m) and a direction (rad, counter-clockwise from +x).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Pose {
    /// The point (m).
    pub point_m: Vec2,
    /// The direction (rad).
    pub angle_rad: f64,
}

/// Refuses a front pivot hold for a robot whose front cup has no free joint
/// (`cup.front_free_joint = false`): `pivot` says whether the hold is one.
pub fn check_front_joint(robot: &crate::robot::Robot, pivot: bool) -> Result<(), InputError> {
    if pivot && !robot.cup.front_free_joint {
        return Err(InputError::Invalid {
            field: "hold".into(),
            value: "front pivot".into(),
            allowed: "rear, front or both: the robot's front cup has no free joint (cup.front_free_joint = false)"
                .into(),
        });
    }
    Ok(())
}

impl Pose {
    /// A pose from a point (m) and an angle in degrees, as the command line takes it.
    pub fn from_deg(point: Vec2, degrees: f64) -> Pose {
        Pose { point_m: point, angle_rad: degrees.to_radians() }
    }

    /// The pose a fraction `t` of the way from `self` to `to` (both linearly).
    pub fn lerp(&self, to: &Pose, t: f64) -> Pose {
        let p = |a: f64, b: f64| a + t * (b - a);
        Pose {
            point_m: [p(self.point_m[0], to.point_m[0]), p(self.point_m[1], to.point_m[1])],
            angle_rad: p(self.angle_rad, to.angle_rad),
        }
    }
}

/// A pose in space: a point (m) and a frame (a rotation, columns its axes).
/// A front hold's: tube 1's tip and the endpoint plate's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose3 {
    /// The point (m).
    pub point_m: Vec3,
    /// The frame.
    pub frame: Mat3,
}

impl Pose3 {
    /// The pose, checked: the point finite, the frame a rotation; `what`
    /// names the hold in the error (`"front hold"`).
    pub fn checked(&self, what: &str) -> Result<(), InputError> {
        if !self.point_m.iter().all(|x| x.is_finite()) {
            return Err(InputError::Invalid {
                field: format!("{what} tip (m)"),
                value: format!("{:?}", self.point_m),
                allowed: "finite coordinates".into(),
            });
        }
        if !is_rotation(&self.frame) {
            return Err(InputError::Invalid {
                field: format!("{what} plate frame"),
                value: format!("{:?}", self.frame),
                allowed: "a rotation matrix (orthonormal to 1e-9, determinant +1)".into(),
            });
        }
        Ok(())
    }
}

/// The 3D body's rear hold: the driving unit where the body was built and
/// placed ([`crate::body3::Body3::from_robot`], a scene's start).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct AsBuilt;

/// Which cups hold, where: `R` places the driving unit, `F` the endpoint
/// plate (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hold<R = Pose, F = R> {
    /// The rear cup holds; the front end is free.
    Rear(R),
    /// The front cup holds; the driving unit hangs from it.
    Front(F),
    /// Both cups hold: a closed, statically indeterminate loop.
    Both {
        /// The driving unit's pose.
        rear: R,
        /// The endpoint's pose.
        front: F,
    },
    /// The front cup on a free rotation joint about its face's normal (the
    /// sideways maneuver, paper Fig. 11): the face fixed, the plate free to
    /// turn about the normal, starting from the pose given; the body swings
    /// the way gravity turns it until the moment about the normal vanishes.
    FrontPivot(F),
}

/// The three-tube body's hold.
pub type Hold3 = Hold<AsBuilt, Pose3>;

impl<R: Copy, F: Copy> Hold<R, F> {
    /// The rear hold's pose, if the rear cup holds.
    pub fn rear(&self) -> Option<R> {
        match self {
            Hold::Rear(p) | Hold::Both { rear: p, .. } => Some(*p),
            Hold::Front(_) | Hold::FrontPivot(_) => None,
        }
    }

    /// The front hold's pose, if the front cup holds (on a free joint, where
    /// its swing starts).
    pub fn front(&self) -> Option<F> {
        match self {
            Hold::Front(p) | Hold::FrontPivot(p) | Hold::Both { front: p, .. } => Some(*p),
            Hold::Rear(_) => None,
        }
    }

    /// The name used on the command line and in results: `rear`, `front`,
    /// `both` or `front_pivot`.
    pub fn name(&self) -> &'static str {
        match self {
            Hold::Rear(_) => "rear",
            Hold::Front(_) => "front",
            Hold::Both { .. } => "both",
            Hold::FrontPivot(_) => "front_pivot",
        }
    }
}

impl Hold3 {
    /// The 3D hold checked: every front pose's point finite and its frame a
    /// rotation.
    pub fn checked(&self) -> Result<(), InputError> {
        let what = match self {
            Hold::Rear(_) => return Ok(()),
            Hold::Front(_) => "front hold",
            Hold::Both { .. } => "both holds: front",
            Hold::FrontPivot(_) => "front pivot",
        };
        self.front().map_or(Ok(()), |pose| pose.checked(what))
    }
}
