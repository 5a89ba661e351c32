//! The constant-curvature model: kinematics only, no mass, no gravity
//! (docs/model.md section 10).
//!
//! # Planar, two tubes
//!
//! Chain A (length `LA`, m) and chain B (`LB`) are concentric arcs a width `w`
//! apart (m); with different spacings at the base and the tip `w = (b + c)/2`
//! (docs/model.md section 10). The bending angle (rad, counter-clockwise positive,
//! towards chain A) and chain A's curvature (1/m) are
//!
//! ```text
//! theta = (LB - LA) / w,      kappa_A = theta / LA
//! ```
//!
//! and an arc of length `s` leaving `p` along `phi` ends at
//! `p + s sinc(theta/2) e(phi + theta/2)`, `sinc x = sin x / x`: the chord is
//! `s sinc(theta/2)` long and points half-way through the turn. This form is
//! exact and smooth through `theta = 0` (a series is used for tiny angles).
//! The endpoint is chain A's tip, at angle `phi_0 + theta`.
//!
//! Inverse: an endpoint at axial `u` and lateral `v` (m) from chain A's clamp
//! gives `theta = 2 atan2(v, u)`, `LA = sqrt(u^2 + v^2) / sinc(theta/2)`,
//! `LB = LA + w theta` (unique for `|theta| < 2 pi`).
//!
//! # Spatial, three tubes
//!
//! Three tubes at radius `r` (m) and angles `sigma_i = sigma_0 + 2 pi i/3`
//! around the backbone, bent by `theta` in the plane at angle `phi` (rad):
//!
//! ```text
//! L_i = ell - theta r cos(phi - sigma_i)        (Webster and Jones, 2010)
//! ell = mean(L_i),  theta r (3/2) (cos phi, sin phi) = -sum_i L_i (cos sigma_i, sin sigma_i)
//! ```
//!
//! The backbone tip is `ell (sin(theta/2) sinc(theta/2) cos phi,
//! sin(theta/2) sinc(theta/2) sin phi, sinc theta)` in the base frame (z along
//! the clamp) and its orientation is `Rz(phi) Ry(theta) Rz(-phi)`. With
//! `L2 = L3` the tri-tube body bends in the plane of tube 1 and is the planar
//! model with `w = 3r/2`.

use crate::error::{positive, InputError};
use crate::geom::{right_normal, unit};
use crate::robot::Robot;

/// `sin x / x`, exact through 0.
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        1.0 - x * x / 6.0 + x * x * x * x / 120.0
    } else {
        x.sin() / x
    }
}

/// The end of an arc of length `s` (m) leaving `p` along `phi` (rad) and
/// turning by `theta` (rad).
pub fn arc_end(p: [f64; 2], phi: f64, s: f64, theta: f64) -> [f64; 2] {
    let chord = s * sinc(0.5 * theta);
    let u = unit(phi + 0.5 * theta);
    [p[0] + chord * u[0], p[1] + chord * u[1]]
}

/// `samples + 1` points along that arc, from `p` to its end.
pub fn arc_points(p: [f64; 2], phi: f64, s: f64, theta: f64, samples: usize) -> Vec<[f64; 2]> {
    (0..=samples)
        .map(|i| {
            let f = i as f64 / samples as f64;
            arc_end(p, phi, f * s, f * theta)
        })
        .collect()
}

/// The planar two-tube constant-curvature body of a robot.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarBody {
    /// Clamp point of chain A (m).
    pub clamp_point: [f64; 2],
    /// Clamp angle (rad).
    pub clamp_angle: f64,
    /// Chain spacing at the base `b` (m).
    pub base_spacing: f64,
    /// Chain spacing at the tip `c` (m).
    pub tip_spacing: f64,
}

/// Where a planar constant-curvature body ends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarPose {
    /// Chain A's tip (m).
    pub endpoint: [f64; 2],
    /// Endpoint plate angle `phi_0 + theta` (rad).
    pub endpoint_angle: f64,
    /// Bending angle `theta` (rad).
    pub bend: f64,
    /// Chain A's curvature `theta / LA` (1/m).
    pub curvature_a: f64,
}

impl PlanarBody {
    /// The body of `robot`, clamped at the origin along its base angle.
    pub fn of(robot: &Robot) -> PlanarBody {
        PlanarBody {
            clamp_point: [0.0, 0.0],
            clamp_angle: robot.world.base_angle_deg.to_radians(),
            base_spacing: robot.body.base_spacing_m,
            tip_spacing: robot.body.tip_spacing_m,
        }
    }

    /// The arcs' spacing `w = (b + c)/2` (m).
    pub fn width(&self) -> f64 {
        0.5 * (self.base_spacing + self.tip_spacing)
    }

    /// Bending angle `(LB - LA)/w` (rad).
    pub fn bend(&self, la: f64, lb: f64) -> f64 {
        (lb - la) / self.width()
    }

    /// Forward kinematics: tube lengths (m) to the endpoint.
    ///
    /// ```
    /// use leech::constant_curvature::PlanarBody;
    /// let cc = PlanarBody { clamp_point: [0.0, 0.0], clamp_angle: 0.0, base_spacing: 0.015, tip_spacing: 0.015 };
    /// let pose = cc.pose(0.2, 0.2);
    /// assert_eq!(pose.endpoint, [0.2, 0.0]); // equal tubes: straight
    /// ```
    pub fn pose(&self, la: f64, lb: f64) -> PlanarPose {
        let theta = self.bend(la, lb);
        PlanarPose {
            endpoint: arc_end(self.clamp_point, self.clamp_angle, la, theta),
            endpoint_angle: self.clamp_angle + theta,
            bend: theta,
            curvature_a: theta / la,
        }
    }

    /// Chain B's clamp point (m).
    pub fn clamp_point_b(&self) -> [f64; 2] {
        let nu = right_normal(self.clamp_angle);
        [self.clamp_point[0] + self.base_spacing * nu[0], self.clamp_point[1] + self.base_spacing * nu[1]]
    }

    /// Points along chains A and B (m), `samples + 1` each.
    pub fn chain_points(&self, la: f64, lb: f64, samples: usize) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
        let theta = self.bend(la, lb);
        (
            arc_points(self.clamp_point, self.clamp_angle, la, theta, samples),
            arc_points(self.clamp_point_b(), self.clamp_angle, lb, theta, samples),
        )
    }

    /// Inverse kinematics: the tube lengths `(LA, LB)` (m) that put the
    /// endpoint at `target` (m). Errors when no arc reaches it (behind the
    /// clamp beyond a full turn or at the clamp itself).
    pub fn lengths_for(&self, target: [f64; 2]) -> Result<[f64; 2], InputError> {
        let d = [target[0] - self.clamp_point[0], target[1] - self.clamp_point[1]];
        let (e, n) = (unit(self.clamp_angle), unit(self.clamp_angle + std::f64::consts::FRAC_PI_2));
        let (u, v) = (d[0] * e[0] + d[1] * e[1], d[0] * n[0] + d[1] * n[1]);
        let chord = positive("target distance from the clamp", u.hypot(v))?;
        let theta = 2.0 * v.atan2(u);
        let la = chord / sinc(0.5 * theta);
        Ok([la, la + self.width() * theta])
    }
}

/// Arc parameters of a spatial constant-curvature segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arc {
    /// Backbone length `ell` (m).
    pub length: f64,
    /// Bending angle `theta >= 0` (rad).
    pub bend: f64,
    /// Bending plane angle `phi` (rad), from the base frame's x axis.
    pub plane: f64,
}

/// Position (m) and orientation of the backbone tip in the base frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose3 {
    /// Position (m), z along the clamp direction.
    pub position: [f64; 3],
    /// Rotation matrix, rows are base-frame components.
    pub rotation: [[f64; 3]; 3],
}

/// Three tubes at equal spacing on a circle, the spatial LEeCH body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriTube {
    /// Radius of the circle through the tubes (m).
    pub radius: f64,
    /// Angle of tube 1 around the backbone (rad); tubes 2 and 3 follow at +-120 deg.
    pub first_angle: f64,
}

impl TriTube {
    /// Angles `sigma_i` of the three tubes (rad).
    pub fn angles(&self) -> [f64; 3] {
        let step = 2.0 * std::f64::consts::PI / 3.0;
        [self.first_angle, self.first_angle + step, self.first_angle + 2.0 * step]
    }

    /// Tube lengths (m) to the arc.
    ///
    /// ```
    /// use leech::constant_curvature::TriTube;
    /// let body = TriTube { radius: 0.01, first_angle: 0.0 };
    /// let arc = body.arc([0.2, 0.21, 0.21]);
    /// assert!((arc.plane - 0.0).abs() < 1e-12);           // bends towards the short tube 1
    /// assert!((arc.bend - 0.01 / (1.5 * 0.01)).abs() < 1e-12);
    /// ```
    pub fn arc(&self, lengths: [f64; 3]) -> Arc {
        let sigma = self.angles();
        let ell = (lengths[0] + lengths[1] + lengths[2]) / 3.0;
        let (mut cx, mut cy) = (0.0, 0.0);
        for (l, s) in lengths.iter().zip(sigma) {
            cx -= l * s.cos();
            cy -= l * s.sin();
        }
        let bend = 2.0 / (3.0 * self.radius) * cx.hypot(cy);
        let plane = if bend == 0.0 { 0.0 } else { cy.atan2(cx) };
        Arc { length: ell, bend, plane }
    }

    /// The arc to tube lengths (m).
    pub fn lengths(&self, arc: Arc) -> [f64; 3] {
        self.angles().map(|s| arc.length - arc.bend * self.radius * (arc.plane - s).cos())
    }

    /// Forward kinematics of the backbone tip.
    pub fn pose(&self, arc: Arc) -> Pose3 {
        let (theta, phi) = (arc.bend, arc.plane);
        let radial = arc.length * (0.5 * theta).sin() * sinc(0.5 * theta);
        let position = [radial * phi.cos(), radial * phi.sin(), arc.length * sinc(theta)];
        let (ct, st, cp, sp) = (theta.cos(), theta.sin(), phi.cos(), phi.sin());
        // Rz(phi) Ry(theta) Rz(-phi)
        let rotation = [
            [cp * cp * ct + sp * sp, cp * sp * (ct - 1.0), cp * st],
            [cp * sp * (ct - 1.0), sp * sp * ct + cp * cp, sp * st],
            [-cp * st, -sp * st, ct],
        ];
        Pose3 { position, rotation }
    }

    /// Inverse kinematics: the arc whose backbone tip is at `position` (m).
    /// A constant-curvature arc is fixed by its tip position as long as it
    /// bends by less than a full turn; this returns that arc.
    pub fn arc_for(&self, position: [f64; 3]) -> Result<Arc, InputError> {
        let distance = positive("target distance from the base", position.iter().map(|x| x * x).sum::<f64>().sqrt())?;
        let radial = position[0].hypot(position[1]);
        let bend = 2.0 * radial.atan2(position[2]);
        let plane = if radial == 0.0 { 0.0 } else { position[1].atan2(position[0]) };
        Ok(Arc { length: distance / sinc(0.5 * bend), bend, plane })
    }

    /// Tips of the three tubes (m): the backbone tip plus each tube's offset
    /// turned with the cross-section.
    pub fn tube_tips(&self, arc: Arc) -> [[f64; 3]; 3] {
        let pose = self.pose(arc);
        self.angles().map(|s| {
            let offset = [self.radius * s.cos(), self.radius * s.sin(), 0.0];
            let mut tip = pose.position;
            for (row, t) in tip.iter_mut().enumerate() {
                *t += (0..3).map(|k| pose.rotation[row][k] * offset[k]).sum::<f64>();
            }
            tip
        })
    }
}
