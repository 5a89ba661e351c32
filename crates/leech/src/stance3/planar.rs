//! The 3D body against the planar model (docs/model3d.md section 7).
//!
//! With `L2 = L3`, gravity in the symmetry plane and `b = c` the 3D body is
//! the planar one: chain A is tube 1, chain B the midpoint of tubes 2 and 3
//! (their frames equal), and the planar clamp `p0 = 0` is tube 1's root.
//! With `b != c` the side tubes also converge sideways from the wider
//! triangle to the narrower one (an out-of-plane S-bend with a little
//! twist), which the planar model leaves out: [`PlanarDifference`] measures
//! what that changes, point by point (m) and link frame by link frame (rad).

use super::equilibrium3::Equilibrium3;
use crate::body::Body;
use crate::body3::body3::{angle_between, Body3};
use crate::geom::Vec2;
use crate::geom3::{axpy, dot, rot_z, scale, Vec3};
use crate::statics::{Equilibrium, SolveError, Solver};

/// How far the 3D body is from the planar model of the same robot.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PlanarDifference {
    /// Distance between the endpoints, tube 1's tip and chain A's (m).
    pub endpoint_m: f64,
    /// Largest distance between corresponding points: tube 1 against chain
    /// A, the midpoint of tubes 2 and 3 against chain B (m).
    pub max_point_m: f64,
    /// Largest angle between a 3D link frame and the planar link's (a
    /// rotation by its angle about z); tubes 2 and 3 against chain B (rad).
    pub max_angle_rad: f64,
    /// Largest distance of tube 1 or of the side tubes' midpoints from the
    /// symmetry plane `z = 0` (m).
    pub out_of_plane_m: f64,
    /// Largest twist of any joint (rad).
    pub max_twist_rad: f64,
}

/// Compares solved bodies of one robot: `body3` at `(L1, L2, L2)` against the
/// planar `body` at `(L1, L2)`, its clamp placed on tube 1's root.
pub fn compare(body3: &Body3, eq3: &Equilibrium3, body: &Body, eq: &Equilibrium) -> PlanarDifference {
    let (qa, qb) = body.split(&eq.q);
    let chains = [body.chain_a().points(qa), body.chain_b().points(qb)];
    compare_points(body3, eq3, &chains, body3.tube(0).root())
}

/// Compares `body3` with a planar body given by its chains' points (m,
/// chain A then chain B, each from its root), the planar origin placed at
/// `origin` (m) in the 3D world and the plane at `z = origin z`: a held
/// planar body ([`crate::stance::Held::chain_points`], world points) with
/// `origin = 0` against the 3D body held the same way. Each planar link's
/// angle is its chord's, `atan2` of consecutive points.
pub fn compare_points(body3: &Body3, eq3: &Equilibrium3, chains: &[Vec<Vec2>; 2], origin: Vec3) -> PlanarDifference {
    let tube1 = body3.points(&eq3.frames, 0);
    let (tube2, tube3) = (body3.points(&eq3.frames, 1), body3.points(&eq3.frames, 2));
    let mid: Vec<_> = tube2.iter().zip(&tube3).map(|(a, b)| scale(0.5, axpy(1.0, *a, *b))).collect();
    let mut out = PlanarDifference {
        endpoint_m: 0.0,
        max_point_m: 0.0,
        max_angle_rad: 0.0,
        out_of_plane_m: 0.0,
        max_twist_rad: body3.max_twist(&eq3.frames),
    };
    for (points, flat) in [(&tube1, &chains[0]), (&mid, &chains[1])] {
        for (p, f) in points.iter().zip(flat) {
            let d = axpy(-1.0, [f[0], f[1], 0.0], axpy(-1.0, origin, *p));
            out.max_point_m = out.max_point_m.max(dot(d, d).sqrt());
            out.out_of_plane_m = out.out_of_plane_m.max((p[2] - origin[2]).abs());
        }
    }
    let tip = |points: &[[f64; 3]]| points.last().copied().unwrap_or(origin);
    let (t1, ta) = (tip(&tube1), chains[0].last().copied().unwrap_or([0.0; 2]));
    let d = axpy(-1.0, [ta[0], ta[1], 0.0], axpy(-1.0, origin, t1));
    out.endpoint_m = dot(d, d).sqrt();
    for (tube, chain) in [(0, &chains[0]), (1, &chains[1]), (2, &chains[1])] {
        for (j, link) in chain.windows(2).enumerate() {
            let phi = (link[1][1] - link[0][1]).atan2(link[1][0] - link[0][0]);
            let frame = body3.frame(&eq3.frames, tube, j);
            out.max_angle_rad = out.max_angle_rad.max(angle_between(&frame, &rot_z(phi)));
        }
    }
    out
}

/// Solves `body3` (a robot at `(L1, L2, L2)`, [`Body3::from_robot`]) and the
/// planar `body` of the same robot at `(L1, L2)` ([`Robot::body`]) on their
/// default paths and compares them.
///
/// [`Robot::body`]: crate::robot::Robot::body
pub fn planar_difference(body3: &Body3, body: &Body, solver: &Solver) -> Result<PlanarDifference, SolveError> {
    let eq3 = body3.solve(solver)?;
    let eq = body.solve(solver)?;
    Ok(compare(body3, &eq3, body, &eq))
}
