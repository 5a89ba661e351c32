//! Placing the 3D body for a hold: the front plate's frame from angles, the
//! rear cup on a point, and the points a hold must keep out of a scene's
//! solids (docs/model3d.md section 10).
//!
//! # The plate's frame from angles
//!
//! ```text
//! R_f = Rz(angle) Ry(yaw) Rx(roll)                                   (rad)
//! ```
//!
//! `angle` is the plate's tangent (tube 1's, the frame's first column) in
//! the x-y plane, counter-clockwise from +x: the planar `--front` angle, so
//! that with `yaw = roll = 0` the 3D plate is the planar one (`Rz(angle)`,
//! the front cup's face normal `R_f e_y` in the plane). `yaw` then turns the
//! plate about its own y axis, the front cup's face normal (the cup turning
//! on its surface, as the free front joint does), and `roll` about its own
//! x axis, the tangent (tilting the face's normal out of the x-y plane).
//!
//! # The cups
//!
//! The rear cup's face centre is `b + rear_offset` from tube 1's root along
//! `-R0 e_y`; the front cup's `c + front_offset` from tube 1's tip along
//! `-R_f e_y` (docs/model3d.md section 8).

use crate::body3::body3::{triangle, Body3};
use crate::geom3::{apply, axpy, column, exp, mul, rot_z, Mat3, Vec3};
use crate::hold::{Hold3, Pose3};
use crate::robot::Robot;
use crate::scene::{Scene3, ON_SURFACE_M};

/// The plate's frame `Rz(angle) Ry(yaw) Rx(roll)` (module doc; rad).
pub fn plate_frame_from_angles(angle: f64, yaw: f64, roll: f64) -> Mat3 {
    mul(&rot_z(angle), &mul(&exp([0.0, yaw, 0.0]), &exp([roll, 0.0, 0.0])))
}

/// The front cup's face centre (m) for tube 1's tip at `tip_m` and the
/// plate's frame `plate`, on `robot`'s body.
pub fn front_cup_centre(robot: &Robot, tip_m: Vec3, plate: &Mat3) -> Vec3 {
    let d = robot.body.tip_spacing_m + robot.cup.front_offset_m;
    axpy(-d, column(plate, 1), tip_m)
}

/// Tube 1's tip (m) for the front cup's face centre at `centre_m` and the
/// plate's frame `plate`: the inverse of [`front_cup_centre`].
pub fn front_tip(robot: &Robot, centre_m: Vec3, plate: &Mat3) -> Vec3 {
    let d = robot.body.tip_spacing_m + robot.cup.front_offset_m;
    axpy(d, column(plate, 1), centre_m)
}

impl Body3 {
    /// The same body shifted (not turned) so that the rear cup's face centre
    /// is at `centre_m` (m); `robot` is the robot it was built from.
    pub fn with_rear_cup_at(&self, robot: &Robot, centre_m: Vec3) -> Body3 {
        let shift = axpy(-1.0, self.rear_cup_centre(robot), centre_m);
        self.placed(&exp([0.0; 3]), shift)
    }
}

/// A point a hold places, which a scene's solid must not hold inside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HoldPoint {
    /// What it is (`"the rear cup's centre"`).
    pub what: &'static str,
    /// Where (m).
    pub point_m: Vec3,
    /// How deep inside a solid it may lie (m): [`ON_SURFACE_M`] for the
    /// body, that plus the cup's preload for a cup's centre (a cup is
    /// pressed into its surface by it).
    pub depth_m: f64,
}

/// The points `hold` fixes before any solve: held at the rear, the tubes'
/// roots on the driving unit and the rear cup's centre (for `body` as
/// placed); at the front (a free joint alike), the plate's triangle (the
/// tubes' tips) and the front cup's centre; both cups, all of these.
pub fn hold_points(robot: &Robot, body: &Body3, hold: &Hold3) -> Vec<HoldPoint> {
    let pressed = ON_SURFACE_M + robot.cup.preload_m;
    let on = |what, point_m| HoldPoint { what, point_m, depth_m: ON_SURFACE_M };
    let mut points = Vec::new();
    if hold.rear().is_some() {
        points.extend((0..3).map(|i| on("the driving unit", body.tube(i).root())));
        points.push(HoldPoint { depth_m: pressed, ..on("the rear cup's centre", body.rear_cup_centre(robot)) });
    }
    let Some(Pose3 { point_m: tip, frame: plate }) = hold.front() else { return points };
    let corners = triangle(robot.body.tip_spacing_m / 1.5);
    points.extend(
        corners.iter().map(|v| on("the endpoint plate", axpy(1.0, apply(&plate, axpy(-1.0, corners[0], *v)), tip))),
    );
    let centre = front_cup_centre(robot, tip, &plate);
    points.push(HoldPoint { depth_m: pressed, ..on("the front cup's centre", centre) });
    points
}

/// The first of `points` inside a solid of `scene` deeper than it may lie.
pub fn first_inside(scene: &Scene3, points: &[HoldPoint]) -> Option<HoldPoint> {
    points.iter().copied().find(|p| scene.nearest(p.point_m).is_some_and(|(_, _, d)| d < -p.depth_m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom3::{dot, scale};
    use crate::scene::Solid3;

    /// `v` scaled to unit length (a direction for checks).
    fn unit(v: Vec3) -> Vec3 {
        scale(1.0 / dot(v, v).sqrt(), v)
    }

    #[test]
    fn in_plane_angles_are_the_planar_plate_and_turns_are_about_its_axes() {
        let (a, yaw, roll) = (0.7, 0.3, -0.4);
        assert_eq!(plate_frame_from_angles(a, 0.0, 0.0), mul(&rot_z(a), &exp([0.0; 3])));
        let r = plate_frame_from_angles(a, yaw, roll);
        let col = |m: &Mat3, k: usize| [m[0][k], m[1][k], m[2][k]];
        // Yaw keeps the face normal (the plate's y axis) where the in-plane plate had it.
        let turned = plate_frame_from_angles(a, yaw, 0.0);
        let normal = col(&rot_z(a), 1);
        assert!((dot(col(&turned, 1), normal) - 1.0).abs() < 1e-15);
        // and turns the tangent out of the plane by yaw.
        assert!((col(&turned, 0)[2] + yaw.sin()).abs() < 1e-15);
        // Roll keeps the tangent.
        assert!((dot(col(&r, 0), col(&turned, 0)) - 1.0).abs() < 1e-15);
        assert!((dot(unit(col(&r, 1)), col(&turned, 1)) - roll.cos()).abs() < 1e-15);
    }

    #[test]
    fn cups_and_placement_invert_and_points_inside_are_found() {
        let robot = Robot::builtin();
        let plate = plate_frame_from_angles(1.1, 0.2, 0.3);
        let tip = [0.1, 0.2, -0.05];
        let centre = front_cup_centre(&robot, tip, &plate);
        let back = front_tip(&robot, centre, &plate);
        assert!(dot(axpy(-1.0, tip, back), axpy(-1.0, tip, back)).sqrt() < 1e-15);
        let body = Body3::from_robot(&robot, [0.2, 0.2, 0.2]).unwrap().with_rear_cup_at(&robot, [0.3, 0.0, 0.1]);
        let at = body.rear_cup_centre(&robot);
        assert!(dot(axpy(-1.0, [0.3, 0.0, 0.1], at), axpy(-1.0, [0.3, 0.0, 0.1], at)).sqrt() < 1e-15);
        // A solid 1 cm over tube 1's root, its face towards the unit's y axis.
        let base = body.base_frame();
        let up = column(&base, 1);
        let over = Solid3::HalfSpace { point_m: axpy(0.01, up, body.tube(0).root()), normal: up };
        let held = hold_points(&robot, &body, &Hold3::Rear(crate::hold::AsBuilt));
        assert_eq!(held.len(), 4);
        let inside = first_inside(&Scene3::new("s", vec![over]).unwrap(), &held).map(|p| p.what);
        assert_eq!(inside, Some("the driving unit"));
        let low = Scene3::new("f", vec![Solid3::HalfSpace { point_m: [0.0, -1.0, 0.0], normal: [0.0, 1.0, 0.0] }]);
        assert_eq!(first_inside(&low.unwrap(), &held), None);
        let front = hold_points(&robot, &body, &Hold3::Front(Pose3 { point_m: tip, frame: plate }));
        assert_eq!(front[0].point_m, tip);
        assert_eq!(front[3].point_m, centre);
    }
}
