//! What `leech climb` prints: a planned climb (or why there is none), one
//! entry per phase's end, and the rows of its CSV.
//!
//! Every pose is written with all its digits (serde_json writes the shortest
//! text that reads back to the same `f64`), so that each step can be
//! replayed with `leech shape --scene S --hold H --rear X,Y,DEG --front
//! X,Y,DEG --lengths LA,LB --free-cups rest`.

use serde::Serialize;

use super::decimal;
use crate::geom::Vec2;
use crate::robot::Robot;
use crate::stance::Pose;
use crate::stride::{Plan, Rejection, Status, Step};

/// A planned climb: the plan's steps and totals, with what was asked.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClimbReport {
    /// The scenario's name (or the scene's, for a climb given by flags).
    pub scenario: String,
    /// The robot's name.
    pub robot: String,
    /// `reached` or `impossible`.
    pub status: Status,
    /// For an impossible climb, what blocked it; `null` when reached.
    pub reason: Option<Rejection>,
    /// Strides in the plan (to the farthest stance, for an impossible climb).
    pub strides: usize,
    /// Every phase's end, from the start.
    pub steps: Vec<ClimbStep>,
    /// Total tube travel, both tubes (m).
    pub tube_travel_m: f64,
    /// Time the motors run (s).
    pub duration_s: f64,
    /// The smallest safety factor of any holding cup; `null` when no cup was loaded.
    pub min_safety_factor: Option<f64>,
    /// Statics solves the search made.
    pub solves: usize,
    /// Where the rear cup's face centre should land (m).
    pub goal_m: Vec2,
    /// How close it must land (m).
    pub tolerance_m: f64,
}

/// One phase's end.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClimbStep {
    /// The phase that ended here (`start`, `push`, `attach_front`, ...).
    pub phase: &'static str,
    /// The stride it belongs to (0 for the start).
    pub stride: usize,
    /// Tube lengths [LA, LB] (m).
    pub lengths_m: [f64; 2],
    /// Which cups hold: `rear`, `front` or `both`.
    pub hold: &'static str,
    /// The rear hold: the driving unit's point (m) and clamp direction (deg),
    /// as `--rear X,Y,DEG` takes it; `null` when the rear cup is released.
    pub rear: Option<[f64; 3]>,
    /// The front hold: the endpoint (m) and the plate's angle (deg), as
    /// `--front X,Y,DEG` takes it; `null` when the front cup is released.
    pub front: Option<[f64; 3]>,
    /// Centre of the rear cup's face (m).
    pub rear_cup_m: Vec2,
    /// Centre of the front cup's face (m).
    pub front_cup_m: Vec2,
    /// Chain A's tip (m).
    pub endpoint_m: Vec2,
    /// The driving unit's point (m).
    pub driving_unit_m: Vec2,
    /// The holding cups' safety factors.
    pub safety_factor: SafetyFactors,
    /// For a push or a pull, the holding cup's smallest safety factor on the
    /// way (the tubes sampled every 10 mm); `null` for other phases.
    pub path_safety_factor: Option<f64>,
    /// Whether the solve met a fold and snapped.
    pub snapped: bool,
}

/// The cups' safety factors at a step: `null` for a cup that does not hold
/// (or holds unloaded).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SafetyFactors {
    /// The rear cup's.
    pub rear: Option<f64>,
    /// The front cup's.
    pub front: Option<f64>,
}

/// A finite number, else `None` (JSON has no infinity).
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// A pose as `[x, y, deg]`.
fn pose_deg(p: Pose) -> [f64; 3] {
    [p.point_m[0], p.point_m[1], p.angle_rad.to_degrees()]
}

impl ClimbStep {
    /// The report of one of a plan's steps for `robot`.
    pub fn new(robot: &Robot, step: &Step) -> ClimbStep {
        let held = &step.held;
        ClimbStep {
            phase: step.phase.name(),
            stride: step.stride,
            lengths_m: step.lengths_m,
            hold: held.hold.name(),
            rear: held.hold.rear().map(pose_deg),
            front: held.hold.front().map(pose_deg),
            rear_cup_m: held.rear_cup_m(robot),
            front_cup_m: held.front_cup_m(robot),
            endpoint_m: held.endpoint_m,
            driving_unit_m: held.unit.point_m,
            safety_factor: SafetyFactors {
                rear: step.rear_safety_factor.and_then(finite),
                front: step.front_safety_factor.and_then(finite),
            },
            path_safety_factor: step.path_safety_factor.and_then(finite),
            snapped: step.snapped(),
        }
    }
}

impl ClimbReport {
    /// The report of `plan` of `robot` in the climb called `scenario`, to `goal_m` within `tolerance_m`.
    pub fn new(scenario: &str, robot: &Robot, plan: &Plan, goal_m: Vec2, tolerance_m: f64) -> ClimbReport {
        ClimbReport {
            scenario: scenario.into(),
            robot: robot.name.clone(),
            status: plan.status,
            reason: plan.reason.clone(),
            strides: plan.strides,
            steps: plan.steps.iter().map(|s| ClimbStep::new(robot, s)).collect(),
            // `+ 0.0` turns the empty sum's -0 (a plan of the start alone) into 0.
            tube_travel_m: plan.tube_travel_m() + 0.0,
            duration_s: plan.duration_s() + 0.0,
            min_safety_factor: finite(plan.min_safety_factor()),
            solves: plan.solves,
            goal_m,
            tolerance_m,
        }
    }
}

/// One row of the climb CSV (`leech climb --csv`): a step, with units in
/// the column names. Numbers are written in Rust's plain decimal notation
/// with every digit (as the sweep's CSV); a released cup's pose and a safety
/// factor that does not apply are empty fields.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClimbRow {
    /// The phase.
    pub phase: &'static str,
    /// The stride.
    pub stride: usize,
    /// Tube length LA (m).
    #[serde(serialize_with = "decimal")]
    pub la_m: f64,
    /// Tube length LB (m).
    #[serde(serialize_with = "decimal")]
    pub lb_m: f64,
    /// `rear`, `front` or `both`.
    pub hold: &'static str,
    /// The rear hold's x (m).
    #[serde(serialize_with = "optional")]
    pub rear_x_m: Option<f64>,
    /// The rear hold's y (m).
    #[serde(serialize_with = "optional")]
    pub rear_y_m: Option<f64>,
    /// The rear hold's clamp direction (deg).
    #[serde(serialize_with = "optional")]
    pub rear_angle_deg: Option<f64>,
    /// The front hold's x (m).
    #[serde(serialize_with = "optional")]
    pub front_x_m: Option<f64>,
    /// The front hold's y (m).
    #[serde(serialize_with = "optional")]
    pub front_y_m: Option<f64>,
    /// The front hold's plate angle (deg).
    #[serde(serialize_with = "optional")]
    pub front_angle_deg: Option<f64>,
    /// The rear cup's face centre x (m).
    #[serde(serialize_with = "decimal")]
    pub rear_cup_x_m: f64,
    /// The rear cup's face centre y (m).
    #[serde(serialize_with = "decimal")]
    pub rear_cup_y_m: f64,
    /// The front cup's face centre x (m).
    #[serde(serialize_with = "decimal")]
    pub front_cup_x_m: f64,
    /// The front cup's face centre y (m).
    #[serde(serialize_with = "decimal")]
    pub front_cup_y_m: f64,
    /// The endpoint's x (m).
    #[serde(serialize_with = "decimal")]
    pub endpoint_x_m: f64,
    /// The endpoint's y (m).
    #[serde(serialize_with = "decimal")]
    pub endpoint_y_m: f64,
    /// The driving unit's x (m).
    #[serde(serialize_with = "decimal")]
    pub driving_unit_x_m: f64,
    /// The driving unit's y (m).
    #[serde(serialize_with = "decimal")]
    pub driving_unit_y_m: f64,
    /// The rear cup's safety factor.
    #[serde(serialize_with = "optional")]
    pub rear_safety_factor: Option<f64>,
    /// The front cup's safety factor.
    #[serde(serialize_with = "optional")]
    pub front_safety_factor: Option<f64>,
    /// The holding cup's smallest safety factor on the way (push, pull).
    #[serde(serialize_with = "optional")]
    pub path_safety_factor: Option<f64>,
    /// Whether the solve snapped.
    pub snapped: bool,
}

impl From<&ClimbStep> for ClimbRow {
    fn from(s: &ClimbStep) -> ClimbRow {
        ClimbRow {
            phase: s.phase,
            stride: s.stride,
            la_m: s.lengths_m[0],
            lb_m: s.lengths_m[1],
            hold: s.hold,
            rear_x_m: s.rear.map(|p| p[0]),
            rear_y_m: s.rear.map(|p| p[1]),
            rear_angle_deg: s.rear.map(|p| p[2]),
            front_x_m: s.front.map(|p| p[0]),
            front_y_m: s.front.map(|p| p[1]),
            front_angle_deg: s.front.map(|p| p[2]),
            rear_cup_x_m: s.rear_cup_m[0],
            rear_cup_y_m: s.rear_cup_m[1],
            front_cup_x_m: s.front_cup_m[0],
            front_cup_y_m: s.front_cup_m[1],
            endpoint_x_m: s.endpoint_m[0],
            endpoint_y_m: s.endpoint_m[1],
            driving_unit_x_m: s.driving_unit_m[0],
            driving_unit_y_m: s.driving_unit_m[1],
            rear_safety_factor: s.safety_factor.rear,
            front_safety_factor: s.safety_factor.front,
            path_safety_factor: s.path_safety_factor,
            snapped: s.snapped,
        }
    }
}

/// Writes the climb CSV of `report` to `writer`: a header, then one row per step.
pub fn write_climb_csv<W: std::io::Write>(writer: W, report: &ClimbReport) -> csv::Result<()> {
    let mut w = csv::Writer::from_writer(writer);
    for step in &report.steps {
        w.serialize(ClimbRow::from(step))?;
    }
    w.flush()?;
    Ok(())
}

fn optional<S: serde::Serializer>(x: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    super::optional_decimal(x, s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_leave_released_cups_empty_and_keep_every_digit() {
        let step = ClimbStep {
            phase: "release_rear",
            stride: 1,
            lengths_m: [0.2, 0.15],
            hold: "front",
            rear: None,
            front: Some([0.1, 0.30000000000000004, -90.0]),
            rear_cup_m: [0.0, 0.0],
            front_cup_m: [0.2, 0.0],
            endpoint_m: [0.1, 0.3],
            driving_unit_m: [0.0, 0.05],
            safety_factor: SafetyFactors { rear: None, front: Some(2.5) },
            path_safety_factor: Some(3.0),
            snapped: false,
        };
        let report = ClimbReport {
            scenario: "s".into(),
            robot: "r".into(),
            status: Status::Reached,
            reason: None,
            strides: 1,
            steps: vec![step],
            tube_travel_m: 0.0,
            duration_s: 0.0,
            min_safety_factor: Some(2.5),
            solves: 1,
            goal_m: [0.0, 0.0],
            tolerance_m: 0.03,
        };
        let mut out = Vec::new();
        write_climb_csv(&mut out, &report).unwrap();
        let text = String::from_utf8(out).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap();
        assert!(header.starts_with("phase,stride,la_m,lb_m,hold,rear_x_m,"), "{header}");
        assert_eq!(header.split(',').count(), 23);
        assert_eq!(
            lines.next().unwrap(),
            "release_rear,1,0.2,0.15,front,,,,0.1,0.30000000000000004,-90,0,0,0.2,0,0.1,0.3,0,0.05,,2.5,3,false"
        );
        let json = serde_json::to_value(&report).unwrap();
        assert_eq!(json["steps"][0]["safety_factor"]["rear"], serde_json::Value::Null);
        assert_eq!(json["status"], "reached");
        assert_eq!(json["reason"], serde_json::Value::Null);
    }
}
