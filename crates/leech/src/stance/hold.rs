//! Which cups hold the body, and where.

use crate::geom::Vec2;

/// A pose in the plane: a point (m) and a direction (rad, counter-clockwise from +x).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Pose {
    /// The point (m).
    pub point_m: Vec2,
    /// The direction (rad).
    pub angle_rad: f64,
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

/// Which cups hold, where: the rear hold fixes the driving unit (chain A's
/// clamp `p0` and the clamp direction `phi0`), the front hold the endpoint
/// (chain A's tip) and the plate's angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hold {
    /// The rear cup holds; the front end is free (today's clamped body).
    Rear(Pose),
    /// The front cup holds; the driving unit hangs from it.
    Front(Pose),
    /// Both cups hold: a closed, statically indeterminate loop.
    Both {
        /// The driving unit's pose.
        rear: Pose,
        /// The endpoint's pose.
        front: Pose,
    },
}

impl Hold {
    /// The rear hold's pose, if the rear cup holds.
    pub fn rear(&self) -> Option<Pose> {
        match self {
            Hold::Rear(p) | Hold::Both { rear: p, .. } => Some(*p),
            Hold::Front(_) => None,
        }
    }

    /// The front hold's pose, if the front cup holds.
    pub fn front(&self) -> Option<Pose> {
        match self {
            Hold::Front(p) | Hold::Both { front: p, .. } => Some(*p),
            Hold::Rear(_) => None,
        }
    }

    /// The name used on the command line and in results.
    pub fn name(&self) -> &'static str {
        match self {
            Hold::Rear(_) => "rear",
            Hold::Front(_) => "front",
            Hold::Both { .. } => "both",
        }
    }
}
