//! The tri-tube constant-curvature model of the robot in 3D: kinematics
//! only, no mass, no stiffness (docs/model3d.md section 9). It stands beside
//! the 3D body ([`Body3`]) as [`crate::constant_curvature::PlanarBody`]
//! stands beside the planar one, in the same world conventions.
//!
//! # Geometry
//!
//! The driving unit's frame is `R0 = Rz(phi0)` at `p0 = 0` (columns: the
//! clamp direction `e_x`, then `e_y`, `e_z`; docs/model3d.md section 2). In
//! its local y-z plane the tubes leave the unit in the directions
//!
//! ```text
//! u_i = (0, cos sigma_i, sin sigma_i),   sigma_1 = 0, sigma_2 = 2 pi/3, sigma_3 = 4 pi/3
//! root_i = p0 + R0 r_b u_i,              r_b = b / 1.5                         (m)
//! ```
//!
//! (tube 1 at `(0, r_b, 0)`, tube 2 towards `+z`). The *arc* is the
//! backbone through the centre of the triangle: its length `ell` (m), its
//! bend `theta >= 0` (rad, the turn from the unit to the plate) and its
//! plane angle `phi` (rad, from tube 1's direction towards tube 2's). The
//! backbone bends towards `d` about `a`, with curvature `kappa`:
//!
//! ```text
//! d = (0, cos phi, sin phi),   a = e_x x d = (0, -sin phi, cos phi),   kappa = theta / ell   (1/m)
//! ```
//!
//! # Lengths from the arc
//!
//! The cross-sections stay rigid and normal to the backbone (Webster and
//! Jones, 2010). At backbone arc length `t` the section has turned by
//! `kappa t` about `a`; a tube at offset `r u_i` runs on a circle of
//! radius `1/kappa - r (d . u_i)`, so over the whole arc it is
//!
//! ```text
//! L_i = ell - theta r (d . u_i) = ell - theta r cos(phi - sigma_i)             (m)
//! ```
//!
//! long: tubes on the inside of the bend are shorter, and the body bends
//! towards its shortest tube. A circle of one radius cannot start at `r_b`
//! and end at `r_t = c / 1.5`, so, as the planar model takes the mean
//! spacing `w = (b + c)/2` (docs/model.md section 10), this model takes the
//! mean radius
//!
//! ```text
//! r = (r_b + r_t) / 2 = (b + c) / 3                                            (m)
//! ```
//!
//! (`1.5 r = w`) in the relation between lengths and the arc, and starts
//! every tube at its true root.
//!
//! # The arc from the lengths
//!
//! Since `sum_i u_i = 0` and `sum_i (d . u_i) u_i = (3/2) d` (the sums of
//! `cos`, `sin`, `cos sin` over the three directions vanish, those of
//! `cos^2` and `sin^2` are 3/2), summing the lengths, and summing them
//! weighted by `u_i`, gives
//!
//! ```text
//! ell     = (L1 + L2 + L3) / 3                                                  (m)
//! theta d = -(2 / (3 r)) sum_i L_i u_i = (0, L2 + L3 - 2 L1, sqrt(3) (L3 - L2)) / (3 r)   (rad)
//! theta   = (2 / (3 r)) sqrt(L1^2 + L2^2 + L3^2 - L1 L2 - L2 L3 - L3 L1)
//! phi     = atan2(sqrt(3) (L3 - L2), L2 + L3 - 2 L1)          (0 for a straight body)
//! ```
//!
//! The plate's rotation vector `theta a = e_x x (theta d)` is *linear* in
//! the lengths; `theta` and `phi` are not, and `phi` is undefined where the
//! body is straight (`theta = 0`, equal lengths). With `L2 = L3` the bend
//! is in the plane of tube 1 (`phi = 0` towards it when it is the shortest,
//! `phi = pi` away from it) and `theta = |L2 - L1| / (1.5 r)`: the planar
//! model's `(LB - LA) / w`. Swapping `L2` and `L3` changes the sign of `phi`:
//! the mirror image in the unit's x-y plane.
//!
//! # Where the tubes and the plate are
//!
//! Each tube is a circular arc of its own length `L_i` that turns by the
//! same `theta` about the same axis: at its own arc length `s` it has turned
//! by `tau = theta s / L_i`, and (the planar chord formula, axial and
//! lateral parts)
//!
//! ```text
//! p_i(s) = root_i + R0 (s sinc(tau) e_x + s sin(tau/2) sinc(tau/2) d)     (m),   sinc x = sin x / x
//! R_i(s) = R0 Exp(tau a)                                                   (columns the tube's axes)
//! ```
//!
//! exact and smooth through `theta = 0`. The **endpoint** is tube 1's tip
//! `p_1(L1)` and the **plate frame** `R_P = R0 Exp(theta a)`, every tube's
//! tip frame, as [`Body3::endpoint`] and [`Body3::plate_frame`] give them.
//! With `b = c` the tubes are the backbone's parallel curves and their tips
//! sit exactly on the plate's triangle: `p_i(L_i) - p_1(L1) = R_P r (u_i - u_1)`.
//! With `b != c` they miss it by
//!
//! ```text
//! (r_b - r_t) [ (u_i - u_1) - ((d . (u_i - u_1)) / 2) ((1 - cos theta) d + sin theta e_x) ]   (in the unit's frame, m)
//! ```
//!
//! (`b - c` apart at the roots' spacing when straight), as the planar model's
//! chain B ends `b`, not `c`, from chain A when straight.
//!
//! # Against the 3D body
//!
//! The elastic body is not constant-curvature even without gravity: the
//! weld makes the tubes push and pull on one another along their axes
//! (tube 1 against tubes 2 and 3), and those forces keep their direction in
//! the world while the tubes curve, so each tube's bending moment varies
//! along it. To first order in the bend (`g = 0`, `b = c`) the two agree:
//! the plate's rotation vector with the arcs' `theta a` exactly, since
//! `L_i - L_1 = -theta r d . (u_i - u_1)` is the axial balance of any shape
//! to first order; the endpoint up to the `paper` scheme's offset, its
//! lateral part times `1 + sum_j e_j^2 / L1^2` (docs/model3d.md section 9).
//! [`ConstantCurvature3::difference`] measures the rest.

use super::body3::{angle_between, Body3, Frames};
use crate::constant_curvature::{sinc, Arc};
use crate::error::{InputError, Num};
use crate::geom3::{apply, axpy, cross, dot, exp, mul, rot_z, scale, Mat3, Vec3};
use crate::robot::Robot;

/// `sqrt(3)`.
const SQRT_3: f64 = 1.732_050_807_568_877_2;

/// The tubes' directions `u_i` in the unit's local frame (module doc).
const DIRECTIONS: [Vec3; 3] = [[0.0, 1.0, 0.0], [0.0, -0.5, 0.5 * SQRT_3], [0.0, -0.5, -0.5 * SQRT_3]];

/// The robot's three tubes as constant-curvature arcs (module doc).
///
/// ```
/// use leech::body3::constant_curvature3::ConstantCurvature3;
/// use leech::prelude::*;
/// let robot = Robot::builtin().with_base_angle(90.0).unwrap();
/// // The side tubes longer than tube 1: the body bends towards tube 1, to the left (-x).
/// let cc = ConstantCurvature3::new(&robot, [0.20, 0.22, 0.22]).unwrap();
/// let arc = cc.arc();
/// assert!(arc.plane.abs() < 1e-15 && arc.bend > 0.0);
/// let [x, y, z] = cc.endpoint();
/// assert!(x < -robot.body.base_spacing_m / 1.5 && y > 0.1 && z.abs() < 1e-15);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct ConstantCurvature3 {
    lengths: [f64; 3],
    base: Mat3,
    roots: [Vec3; 3],
    base_radius: f64,
    tip_radius: f64,
    /// `theta d` in the unit's frame (rad): `(0, (L2 + L3 - 2 L1), sqrt 3 (L3 - L2)) / (3 r)`.
    bend_vector: Vec3,
}

/// How far a solved [`Body3`] is from the constant-curvature body of the
/// same robot and lengths.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ArcDifference {
    /// Distance between the endpoints, tube 1's tips (m).
    pub endpoint_m: f64,
    /// Angle between the plate frames (rad).
    pub plate_angle_rad: f64,
    /// Largest distance between a point of the body (a root or a link's
    /// tip) and the arc's point at the same arc length along the same tube (m).
    pub max_point_m: f64,
}

impl ConstantCurvature3 {
    /// The constant-curvature body of `robot` at tube lengths
    /// `[L1, L2, L3]` (m), the driving unit at the origin turned by the
    /// clamp angle about z. Lengths are checked as [`Body3::from_robot`]
    /// checks them.
    pub fn new(robot: &Robot, lengths: [f64; 3]) -> Result<ConstantCurvature3, InputError> {
        robot.validate()?;
        let mut checked = [0.0; 3];
        for (i, (out, length)) in checked.iter_mut().zip(lengths).enumerate() {
            *out = robot.check_tube_length(&format!("lengths[{i}] (L{})", i + 1), length)?;
        }
        let [l1, l2, l3] = checked;
        let (base_radius, tip_radius) = (robot.body.base_spacing_m / 1.5, robot.body.tip_spacing_m / 1.5);
        let r = 0.5 * (base_radius + tip_radius);
        let base = rot_z(robot.world.base_angle_deg.to_radians());
        Ok(ConstantCurvature3 {
            lengths: checked,
            base,
            roots: DIRECTIONS.map(|u| apply(&base, scale(base_radius, u))),
            base_radius,
            tip_radius,
            bend_vector: [0.0, (l2 + l3 - 2.0 * l1) / (3.0 * r), SQRT_3 * (l3 - l2) / (3.0 * r)],
        })
    }

    /// The tube lengths `[L1, L2, L3]` (m) of the arc `arc` on `robot`: the
    /// inverse of [`ConstantCurvature3::arc`],
    /// `L_i = ell - theta r cos(phi - sigma_i)`. Errors name the arc's field
    /// that is not a finite number (or a negative bend), or the tube whose
    /// length leaves the robot's range.
    ///
    /// ```
    /// use leech::body3::constant_curvature3::ConstantCurvature3;
    /// use leech::constant_curvature::Arc;
    /// use leech::prelude::*;
    /// let robot = Robot::builtin();
    /// let lengths = ConstantCurvature3::lengths_for(&robot, Arc { length: 0.2, bend: 0.5, plane: 1.0 }).unwrap();
    /// let arc = ConstantCurvature3::new(&robot, lengths).unwrap().arc();
    /// assert!((arc.length - 0.2).abs() < 1e-15 && (arc.bend - 0.5).abs() < 1e-13 && (arc.plane - 1.0).abs() < 1e-13);
    /// ```
    pub fn lengths_for(robot: &Robot, arc: Arc) -> Result<[f64; 3], InputError> {
        robot.validate()?;
        for (field, value) in [("arc.length", arc.length), ("arc.plane", arc.plane)] {
            if !value.is_finite() {
                return Err(InputError::invalid(field, value, "a finite number"));
            }
        }
        if !(arc.bend.is_finite() && arc.bend >= 0.0) {
            return Err(InputError::invalid("arc.bend", arc.bend, "a finite number >= 0 (rad)"));
        }
        let r = (robot.body.base_spacing_m + robot.body.tip_spacing_m) / 3.0;
        let d = [0.0, arc.plane.cos(), arc.plane.sin()];
        let mut lengths = [0.0; 3];
        for (i, (out, u)) in lengths.iter_mut().zip(DIRECTIONS).enumerate() {
            let length = arc.length - arc.bend * r * dot(d, u);
            *out = robot.check_tube_length(&format!("lengths[{i}] (L{}) of the arc", i + 1), length)?;
        }
        Ok(lengths)
    }

    /// The tube lengths `[L1, L2, L3]` (m).
    pub fn lengths(&self) -> [f64; 3] {
        self.lengths
    }

    /// The radius `r = (r_b + r_t)/2` (m) of the relation between lengths and arc.
    pub fn radius(&self) -> f64 {
        0.5 * (self.base_radius + self.tip_radius)
    }

    /// The arc: backbone length `ell` (m), bend `theta >= 0` (rad) and plane
    /// angle `phi` (rad, from tube 1's direction towards tube 2's; 0 when straight).
    pub fn arc(&self) -> Arc {
        let [_, y, z] = self.bend_vector;
        Arc { length: self.lengths.iter().sum::<f64>() / 3.0, bend: y.hypot(z), plane: z.atan2(y) }
    }

    /// The backbone's curvature `kappa = theta / ell` (1/m).
    pub fn curvature(&self) -> f64 {
        let arc = self.arc();
        arc.bend / arc.length
    }

    /// The plate's rotation vector `theta a` in the world (rad): the axis the
    /// body bends about, as long as the bend.
    pub fn rotation_vector(&self) -> Vec3 {
        apply(&self.base, cross([1.0, 0.0, 0.0], self.bend_vector))
    }

    /// The driving unit's frame `R0` (columns its axes).
    pub fn base_frame(&self) -> Mat3 {
        self.base
    }

    /// Where tube `tube` (0, 1, 2 for tubes 1, 2, 3) leaves the unit (m).
    pub fn root(&self, tube: usize) -> Result<Vec3, InputError> {
        self.check_tube(tube).map(|i| self.roots[i])
    }

    /// The plate's frame `R0 Exp(theta a)` (columns the plate's axes, x
    /// along the tubes' tips).
    pub fn plate_frame(&self) -> Mat3 {
        mul(&self.base, &exp(cross([1.0, 0.0, 0.0], self.bend_vector)))
    }

    /// The endpoint: tube 1's tip (m).
    pub fn endpoint(&self) -> Vec3 {
        self.point_unchecked(0, self.lengths[0])
    }

    /// The point of tube `tube` (0, 1, 2) at arc length `s` (m) from its root,
    /// `0 <= s <= L_i`.
    pub fn point(&self, tube: usize, s: f64) -> Result<Vec3, InputError> {
        let i = self.check_arc_length(tube, s)?;
        Ok(self.point_unchecked(i, s))
    }

    /// The frame of tube `tube` (0, 1, 2) at arc length `s` (m) from its
    /// root: `R0 Exp(tau a)`, `tau = theta s / L_i`; `0 <= s <= L_i`.
    pub fn frame(&self, tube: usize, s: f64) -> Result<Mat3, InputError> {
        let i = self.check_arc_length(tube, s)?;
        Ok(mul(&self.base, &exp(scale(s / self.lengths[i], cross([1.0, 0.0, 0.0], self.bend_vector)))))
    }

    /// `samples + 1` points of tube `tube` (0, 1, 2) from its root to its tip,
    /// evenly spaced in arc length (m); `samples >= 1`.
    pub fn points(&self, tube: usize, samples: usize) -> Result<Vec<Vec3>, InputError> {
        let i = self.check_tube(tube)?;
        if samples == 0 {
            return Err(InputError::invalid("samples", 0.0, "at least 1 (points along each tube)"));
        }
        let length = self.lengths[i];
        Ok((0..=samples).map(|k| self.point_unchecked(i, length * k as f64 / samples as f64)).collect())
    }

    /// How far the solved 3D body `body` (its `frames`) is from this one:
    /// endpoints, plate frames, and every root and link tip against the
    /// arc's point at the same arc length. `body` must be of the same robot
    /// and lengths (roots and tube lengths to 1e-12 m).
    pub fn difference(&self, body: &Body3, frames: &Frames) -> Result<ArcDifference, InputError> {
        for i in 0..3 {
            let tube = body.tube(i);
            let root_gap = axpy(-1.0, self.roots[i], tube.root());
            if (tube.tube_length() - self.lengths[i]).abs() > 1e-12 || dot(root_gap, root_gap).sqrt() > 1e-12 {
                return Err(InputError::invalid(
                    format!("body3 tube {} length", i + 1),
                    tube.tube_length(),
                    format!("a body of the same robot and lengths ({} m)", Num(self.lengths[i])),
                ));
            }
        }
        let gap = |a: Vec3, b: Vec3| {
            let d = axpy(-1.0, a, b);
            dot(d, d).sqrt()
        };
        let mut max_point_m = 0.0f64;
        for i in 0..3 {
            let mut s = 0.0;
            let arc_lengths = std::iter::once(0.0).chain(body.tube(i).lengths().iter().map(|l| {
                s += l;
                s.min(self.lengths[i])
            }));
            for (p, s) in body.points(frames, i).into_iter().zip(arc_lengths) {
                max_point_m = max_point_m.max(gap(p, self.point_unchecked(i, s)));
            }
        }
        Ok(ArcDifference {
            endpoint_m: gap(body.endpoint(frames), self.endpoint()),
            plate_angle_rad: angle_between(&body.plate_frame(frames), &self.plate_frame()),
            max_point_m,
        })
    }

    /// `p_i(s)` (module doc), `s` within `[0, L_i]`.
    fn point_unchecked(&self, i: usize, s: f64) -> Vec3 {
        let arc = self.arc();
        let tau = arc.bend * s / self.lengths[i];
        let d = [0.0, arc.plane.cos(), arc.plane.sin()];
        let local = axpy(s * (0.5 * tau).sin() * sinc(0.5 * tau), d, [s * sinc(tau), 0.0, 0.0]);
        axpy(1.0, self.roots[i], apply(&self.base, local))
    }

    /// `tube` if `0 <= s <= L_tube`.
    fn check_arc_length(&self, tube: usize, s: f64) -> Result<usize, InputError> {
        let i = self.check_tube(tube)?;
        let length = self.lengths[i];
        if (0.0..=length).contains(&s) {
            Ok(i)
        } else {
            Err(InputError::invalid(
                "arc length along the tube",
                s,
                format!("a number from 0 to the tube's length ({} m)", Num(length)),
            ))
        }
    }

    fn check_tube(&self, tube: usize) -> Result<usize, InputError> {
        if tube < 3 {
            Ok(tube)
        } else {
            Err(InputError::invalid("tube", tube as f64, "0, 1 or 2 (tubes 1, 2, 3)"))
        }
    }
}
