//! Robot descriptions: the TOML file format and the built-in LEeCH robot.
//!
//! A robot file gives one tube's element (`l` in m, `m` in kg, `k` in N m/rad,
//! `d` in N m s/rad, or the continuum `EI` in N m^2 and `rho` in kg/m, with
//! `k = EI / l` and `m = rho l`), the body's spacings `b`, `c` (m) and payload
//! `ms` (kg), gravity (m/s^2), the clamp angle (deg) and the discretization.
//! Every key is SI and checked; unknown keys are errors. The shape parameter
//! of the tube is `Pi = k / (m g l)` (docs/model.md section 8).
//!
//! Keys the statics do not need are optional, and the sections
//! `[driving_unit]`, `[cup]`, `[limits]` and `[drive]` may be left out whole: a missing
//! key takes the built-in robot's value, so robot files written before these
//! keys existed stay valid. They are the tube's outer diameter
//! ([`DEFAULT_TUBE_OUTER_DIAMETER_M`]), its torsional stiffness for the 3D
//! body (`torsion_stiffness_nm_per_rad`, `k / 1.3` until measured), the driving unit's mass
//! ([`DrivingUnit`]), both suction cups ([`Cup`], judged by [`crate::cup`]) and
//! the tube lengths planners may use ([`Limits`]). One key differs:
//! `tube.full_length_m`, each tube's whole length, is the built-in's 0.40 m
//! only in the built-in file; a file without it leaves the tubes' tails out
//! (the driving unit carries its own `mass_kg` alone, [`Robot::unit_mass_kg`])
//! and its answers are those it had before the key existed.
//!
//! ```
//! use leech::robot::Robot;
//! let robot = Robot::from_toml_str(r#"
//! name = "my hose"
//! [tube]
//! element_length_m = 0.01
//! mass_per_length_kg_per_m = 0.1
//! bending_stiffness_nm2 = 0.005
//! joint_damping_nms_per_rad = 0.005
//! min_bend_radius_m = 0.025
//! [body]
//! base_spacing_m = 0.017
//! tip_spacing_m = 0.012
//! payload_kg = 0.021
//! [world]
//! gravity_m_per_s2 = 9.81
//! base_angle_deg = 90
//! [model]
//! discretization = "midpoint"
//! "#).unwrap();
//! assert!((robot.tube.joint_stiffness_nm_per_rad - 0.5).abs() < 1e-12);
//! assert!((robot.shape_parameter() - 5096.8).abs() < 0.1);
//! ```

use serde::{Deserialize, Serialize};

use crate::body::Body;
use crate::cantilever::Cantilever;
pub use crate::chain::MAX_LINKS;
use crate::chain::{check_element_length, check_element_mass, Chain, ChainSpec, Discretization};
use crate::error::{non_negative, positive, within, InputError, Num};
use crate::geom::right_normal;

/// The built-in robot's file, comments included.
pub const BUILTIN_TOML: &str = include_str!("../robots/leech.toml");

/// One tube's element.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Tube {
    /// Element length `l` (m).
    pub element_length_m: f64,
    /// Element mass `m` (kg).
    pub element_mass_kg: f64,
    /// Joint stiffness `k` (N m/rad).
    pub joint_stiffness_nm_per_rad: f64,
    /// Joint damping `d` (N m s/rad).
    pub joint_damping_nms_per_rad: f64,
    /// Tightest bend the real tube takes (m): the hose's stop, where joints
    /// lock among solids ([`crate::hose`]); free-space sweeps mark tighter
    /// shapes infeasible. 0: no stop.
    pub min_bend_radius_m: f64,
    /// The tube's outer diameter (m): contacts with a surface keep a tube's
    /// axis at least its radius away.
    pub outer_diameter_m: f64,
    /// Torsional stiffness of one joint `kt` (N m/rad), twist about the
    /// tube's own axis (the 3D body, [`crate::body3`]); `None`: not measured,
    /// estimated as `k / 1.3` ([`Tube::torsion_stiffness`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub torsion_stiffness_nm_per_rad: Option<f64>,
    /// Stiffness of one joint locked at the hose's stop (N m/rad,
    /// [`crate::hose`]); `None`: not measured, estimated as
    /// [`STOP_PER_JOINT_STIFFNESS`] times `k` ([`Tube::stop_stiffness`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stop_stiffness_nm_per_rad: Option<f64>,
    /// Each tube's whole length (m). What of it is not ahead of its clamp,
    /// `full - L`, trails behind the driving unit and loads it
    /// ([`Robot::unit_mass_kg`]), so the robot weighs the same at every
    /// extension; no tube length may exceed it. `None`: the tails are not
    /// modelled (`driving_unit.mass_kg` is all the unit carries) and tube
    /// lengths are bounded only by [`MAX_LINKS`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub full_length_m: Option<f64>,
}

/// `k / kt` assumed while a tube's torsional stiffness is not measured
/// (a thin tube's `GJ / EI = 1 / (1 + nu)` with Poisson's ratio 0.3).
pub const BENDING_PER_TORSION: f64 = 1.3;

/// The tubes each chain of the planar body stands for: chain A the centre
/// tube, chain B the side pair lumped (twice the stiffness and mass).
pub const TUBES_PER_CHAIN: [f64; 2] = [1.0, 2.0];

/// The locked hose's stiffness per joint over the free tube's `k`, assumed
/// while it is not measured (an ESTIMATE: a stripwound hose at its stop is
/// a chain of interlocked steel strip, far stiffer than the free tubes; two
/// orders of magnitude keep a locked joint within about 3 % of its stop
/// under the robot's own weight).
pub const STOP_PER_JOINT_STIFFNESS: f64 = 100.0;

impl Tube {
    /// Torsional stiffness of one joint `kt` (N m/rad): the file's value, else `k / 1.3`.
    pub fn torsion_stiffness(&self) -> f64 {
        self.torsion_stiffness_nm_per_rad.unwrap_or(self.joint_stiffness_nm_per_rad / BENDING_PER_TORSION)
    }

    /// The stiffness of a joint locked at the hose's stop (N m/rad): as
    /// given, or [`STOP_PER_JOINT_STIFFNESS`] times `k`.
    pub fn stop_stiffness(&self) -> f64 {
        self.stop_stiffness_nm_per_rad.unwrap_or(self.joint_stiffness_nm_per_rad * STOP_PER_JOINT_STIFFNESS)
    }
}

/// The paper's stripwound hose: 25 mm minimum bending radius.
pub const DEFAULT_MIN_BEND_RADIUS_M: f64 = 0.025;

/// The paper's stripwound hose: 10 mm outer diameter.
pub const DEFAULT_TUBE_OUTER_DIAMETER_M: f64 = 0.010;

/// Tube outer diameters (m): 0.1 mm to 1 m, the range of tubes a soft
/// robot is made of; the cups' offsets are checked against its radius.
pub const OUTER_DIAMETER_M: (f64, f64) = (1e-4, 1.0);

/// Longest spacing (m) of the tubes at the driving unit or the tip: a
/// driving unit is a hand's width, ten metres is already none.
pub const MAX_SPACING_M: f64 = 10.0;

/// Checks a tube spacing: above 0 and at most [`MAX_SPACING_M`].
fn spacing(field: &str, value: f64) -> Result<f64, InputError> {
    if value > 0.0 && value <= MAX_SPACING_M {
        Ok(value)
    } else {
        Err(InputError::invalid(field, value, format!("a finite number > 0 and at most {} m", Num(MAX_SPACING_M))))
    }
}

/// The body's geometry and payload.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodyGeometry {
    /// Chain distance at the driving unit `b` (m).
    pub base_spacing_m: f64,
    /// Chain distance at the endpoint `c` (m).
    pub tip_spacing_m: f64,
    /// Payload at chain B's tip `ms` (kg).
    pub payload_kg: f64,
}

/// Gravity and the clamp.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct World {
    /// Gravity (m/s^2), acting along -y.
    pub gravity_m_per_s2: f64,
    /// Clamp direction of the driving unit (deg from +x).
    pub base_angle_deg: f64,
}

/// Modelling choices.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Model {
    /// How tubes are cut into links.
    #[serde(default, deserialize_with = "discretization")]
    pub discretization: Discretization,
}

/// A discretization's name; anything else (a number, a table) answered
/// with the names allowed, not the parser's "wanted string or table".
fn discretization<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Discretization, D::Error> {
    use serde::de::Error as _;
    use serde::Deserialize as _;
    let value = toml::Value::deserialize(d)?;
    match value.as_str() {
        Some("paper") => Ok(Discretization::Paper),
        Some("midpoint") => Ok(Discretization::Midpoint),
        _ => Err(D::Error::custom(format!(
            "model.discretization: got {}, expected \"paper\" or \"midpoint\"",
            crate::error::quoted(&value.to_string())
        ))),
    }
}

/// The driving unit: its motors, frame and the rear cup, a rigid body
/// ([`crate::stance::Unit`]). Lengths are in the unit's frame: from chain
/// A's clamp, "along" the clamp direction `e(phi0)` and "across" along
/// `nu(phi0)`, towards chain B and the rear cup.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DrivingUnit {
    /// Mass (kg). The statics hold the unit as a fixed clamp and leave it
    /// out; it loads the body and the front cup when the front cup holds and
    /// the unit hangs.
    pub mass_kg: f64,
    /// Where the mass sits, `[along, across]` from chain A's clamp (m).
    /// Absent: the clamps' midpoint, `[0, b/2]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub centre_of_mass_m: Option<[f64; 2]>,
    /// The outline's length along the clamp direction (m). 0 together with
    /// `height_m`: no outline, nothing of the unit touches a solid.
    pub length_m: f64,
    /// The outline's height across (m).
    pub height_m: f64,
    /// How far the outline's back lies behind chain A's clamp (m, at most `length_m`).
    pub back_m: f64,
    /// How far the outline's top (the side away from the cups) lies from chain A's axis (m).
    pub top_m: f64,
    /// How far the rear cup's face centre lies behind chain A's clamp (m;
    /// negative: ahead of it). Across, it sits `cup.rear_offset_m` beyond chain B.
    pub rear_cup_behind_m: f64,
}

impl Default for DrivingUnit {
    /// The built-in robot's estimate (see [`BUILTIN_TOML`]).
    fn default() -> Self {
        DrivingUnit {
            mass_kg: 0.099,
            centre_of_mass_m: None,
            length_m: 0.05,
            height_m: 0.036,
            back_m: 0.035,
            top_m: 0.012,
            rear_cup_behind_m: 0.0,
        }
    }
}

impl DrivingUnit {
    /// Whether the unit has an outline.
    pub fn has_outline(&self) -> bool {
        self.length_m > 0.0 || self.height_m > 0.0
    }

    /// The outline's corners in the unit's frame, `[along, across]` (m):
    /// back top, front top, front bottom, back bottom ([`crate::stance::Unit`]).
    pub fn outline_m(&self) -> Option<[[f64; 2]; 4]> {
        let (front, bottom) = (self.length_m - self.back_m, self.height_m - self.top_m);
        self.has_outline().then_some([
            [-self.back_m, -self.top_m],
            [front, -self.top_m],
            [front, bottom],
            [-self.back_m, bottom],
        ])
    }

    /// Checks the unit against the body it carries: spacing `b` (m), tube
    /// radius `r` (m) and the rear cup's face `face` across from chain A (m).
    fn validate(&self, b: f64, r: f64, face: f64) -> Result<(), InputError> {
        non_negative("driving_unit.mass_kg", self.mass_kg)?;
        for (field, value) in [
            ("driving_unit.length_m", self.length_m),
            ("driving_unit.height_m", self.height_m),
            ("driving_unit.back_m", self.back_m),
            ("driving_unit.top_m", self.top_m),
        ] {
            within(field, value, 0.0, MAX_CUP_LENGTH_M)?;
        }
        within("driving_unit.rear_cup_behind_m", self.rear_cup_behind_m, -MAX_CUP_LENGTH_M, MAX_CUP_LENGTH_M)?;
        if let Some(centre) = self.centre_of_mass_m {
            for (axis, value) in ["along", "across"].iter().zip(centre) {
                within(&format!("driving_unit.centre_of_mass_m ({axis})"), value, -MAX_CUP_LENGTH_M, MAX_CUP_LENGTH_M)?;
            }
        }
        if !self.has_outline() {
            return Ok(());
        }
        let invalid = |field: &str, value: f64, allowed: String| Err(InputError::invalid(field, value, allowed));
        if !(self.length_m > 0.0) {
            return invalid(
                "driving_unit.length_m",
                self.length_m,
                "a number > 0 where height_m is (both 0: no outline)".into(),
            );
        }
        if !(self.back_m <= self.length_m) {
            return invalid(
                "driving_unit.back_m",
                self.back_m,
                format!("at most length_m ({} m): the clamps lie inside the outline", Num(self.length_m)),
            );
        }
        if !(self.top_m >= r) {
            return invalid(
                "driving_unit.top_m",
                self.top_m,
                format!("at least the tube's radius ({} m): chain A's clamp lies inside the outline", Num(r)),
            );
        }
        let (inside, beyond) = (self.top_m + b + r, self.top_m + face);
        if !(self.height_m >= inside && self.height_m <= beyond) {
            return invalid(
                "driving_unit.height_m",
                self.height_m,
                format!(
                    "from top_m + b + r = {} m (chain B's clamp inside the outline) to top_m + b + cup.rear_offset_m = {} m (the rear cup's face on or beyond its bottom)",
                    Num(inside),
                    Num(beyond)
                ),
            );
        }
        Ok(())
    }
}

/// Both suction cups (the rear one on the driving unit, the front one on the
/// endpoint plate), alike. Both sit on chain B's side: the surfaces the robot
/// holds lie to the right of the body (`nu`, docs/model.md section 2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Cup {
    /// Diameter of the cup's lip (m).
    pub diameter_m: f64,
    /// Force that pulls one cup straight off a smooth surface (N).
    pub pull_off_force_n: f64,
    /// Friction coefficient between the lip and the surface.
    pub friction_coefficient: f64,
    /// Smallest safety factor a hold should keep (at least 1).
    pub min_safety_factor: f64,
    /// A cup attaches when its face is at most this far from the surface (m).
    pub attach_distance_tolerance_m: f64,
    /// ... and faces the surface within this angle (deg).
    pub attach_angle_tolerance_deg: f64,
    /// The rear cup's face: this far from chain B's clamp along `nu(phi_0)` (m).
    pub rear_offset_m: f64,
    /// The front cup's face: this far from chain B's tip along `nu` of the plate angle (m).
    pub front_offset_m: f64,
    /// How far a cup is pushed on past touchdown to seal (m).
    pub preload_m: f64,
    /// Whether the front cup turns freely on the endpoint plate about its
    /// face's normal (the paper's robot: released by the rear cup, the body
    /// swings back under gravity, the sideways maneuver, [`crate::hold`]).
    /// In the plane that axis lies in the plane, nothing turns about it and
    /// a planar body is held alike either way; without the joint the 3D
    /// front pivot hold is bad input and the sideways maneuver has no plan.
    pub front_free_joint: bool,
}

impl Default for Cup {
    /// The built-in robot's cups (see [`BUILTIN_TOML`] for the sources).
    fn default() -> Self {
        Cup {
            diameter_m: 0.05,
            pull_off_force_n: 33.4,
            friction_coefficient: 0.5,
            min_safety_factor: 1.5,
            attach_distance_tolerance_m: 0.002,
            attach_angle_tolerance_deg: 5.0,
            rear_offset_m: 0.015,
            front_offset_m: 0.016,
            preload_m: 0.0,
            front_free_joint: true,
        }
    }
}

impl Cup {
    /// Checks the cup's own values (the robot also checks the offsets
    /// against the tube's radius).
    pub fn validate(&self) -> Result<(), InputError> {
        // Lengths of a cup for a robot of tubes a few tenths of a metre
        // long: a metre bounds any real one (and keeps the geometry finite).
        for (field, value) in [
            ("cup.diameter_m", self.diameter_m),
            ("cup.rear_offset_m", self.rear_offset_m),
            ("cup.front_offset_m", self.front_offset_m),
            ("cup.attach_distance_tolerance_m", self.attach_distance_tolerance_m),
        ] {
            if !(value <= MAX_CUP_LENGTH_M) {
                return Err(InputError::invalid(field, value, format!("at most {MAX_CUP_LENGTH_M} m")));
            }
        }
        positive("cup.diameter_m", self.diameter_m)?;
        positive("cup.pull_off_force_n", self.pull_off_force_n)?;
        positive("cup.friction_coefficient", self.friction_coefficient)?;
        // Below 1 a hold would be accepted that the model predicts to fail.
        let factor = self.min_safety_factor;
        if !(factor.is_finite() && factor >= 1.0) {
            return Err(InputError::invalid("cup.min_safety_factor", factor, "a finite number >= 1"));
        }
        positive("cup.attach_distance_tolerance_m", self.attach_distance_tolerance_m)?;
        let angle = self.attach_angle_tolerance_deg;
        if !(angle.is_finite() && angle > 0.0 && angle <= 90.0) {
            return Err(InputError::invalid("cup.attach_angle_tolerance_deg", angle, "a finite number in (0, 90]"));
        }
        non_negative("cup.rear_offset_m", self.rear_offset_m)?;
        non_negative("cup.front_offset_m", self.front_offset_m)?;
        // A push of a few millimetres past touchdown seals the lip; more
        // would drive the face into the surface.
        within("cup.preload_m", self.preload_m, 0.0, MAX_PRELOAD_M)?;
        Ok(())
    }
}

/// Largest cup length (diameter, offsets, attach distance) a robot file may give (m).
pub const MAX_CUP_LENGTH_M: f64 = 1.0;

/// Largest `[cup] preload_m` (m).
pub const MAX_PRELOAD_M: f64 = 0.01;

/// The tube lengths planners may command (m): the body model itself takes
/// any length from one element up (see [`Robot::check_tube_length`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Limits {
    /// Shortest free tube length (m).
    pub tube_length_min_m: f64,
    /// Longest free tube length (m).
    pub tube_length_max_m: f64,
}

impl Default for Limits {
    /// The range of the paper's reachability study (Fig. 12): 0.05 to 0.30 m.
    fn default() -> Self {
        Limits { tube_length_min_m: 0.05, tube_length_max_m: 0.30 }
    }
}

/// How the controller drives the tubes: the calibration from encoder counts
/// to tube length and the position loop's settings, sent to the device
/// before it moves (`leech drive`; docs/protocol.md, `ConfigureTube`). One
/// set for the three tubes (L1 centre, L2 and L3 the side pair).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Drive {
    /// Encoder counts per mm of tube (12 CPR x 75:1 gear = 900 counts per
    /// output turn, on a roller feeding 20 mm a turn: 45).
    pub counts_per_mm: f64,
    /// Each tube's free length at encoder count zero (m): where it stands
    /// when the controller powers up.
    pub zero_lengths_m: [f64; 3],
    /// Fastest tube speed the position loop commands (m/s; the paper's 20 mm/s).
    pub max_speed_m_per_s: f64,
    /// Position loop gains: duty (per mille) per um of error, per um s, per um/s.
    pub gains: [f64; 3],
}

impl Default for Drive {
    /// The simulated robot's drive (and an estimate for the paper's).
    fn default() -> Self {
        Drive { counts_per_mm: 45.0, zero_lengths_m: [0.2; 3], max_speed_m_per_s: 0.02, gains: [0.3, 0.5, 0.003] }
    }
}

impl Drive {
    fn validate(&self) -> Result<(), InputError> {
        within("drive.counts_per_mm", self.counts_per_mm, 1e-3, 1e6)?;
        for (i, l) in self.zero_lengths_m.iter().enumerate() {
            within(&format!("drive.zero_lengths_m[{i}]"), *l, 0.0, 10.0)?;
        }
        within("drive.max_speed_m_per_s", self.max_speed_m_per_s, 1e-4, 1.0)?;
        for (name, g) in ["kp", "ki", "kd"].iter().zip(self.gains) {
            // Sent as Q16.16: at most 32767.
            within(&format!("drive.gains ({name})"), g, 0.0, 3e4)?;
        }
        Ok(())
    }
}

/// A validated robot description.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Robot {
    /// Display name.
    pub name: String,
    /// The tube's element.
    pub tube: Tube,
    /// Spacings and payload.
    pub body: BodyGeometry,
    /// Gravity and clamp.
    pub world: World,
    /// Discretization.
    pub model: Model,
    /// The driving unit: its mass, outline and rear cup.
    pub driving_unit: DrivingUnit,
    /// Both suction cups.
    pub cup: Cup,
    /// Tube lengths for planners.
    pub limits: Limits,
    /// The controller's drive: encoder calibration and position loop.
    pub drive: Drive,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTube {
    element_length_m: f64,
    element_mass_kg: Option<f64>,
    mass_per_length_kg_per_m: Option<f64>,
    joint_stiffness_nm_per_rad: Option<f64>,
    bending_stiffness_nm2: Option<f64>,
    joint_damping_nms_per_rad: f64,
    min_bend_radius_m: Option<f64>,
    outer_diameter_m: Option<f64>,
    torsion_stiffness_nm_per_rad: Option<f64>,
    stop_stiffness_nm_per_rad: Option<f64>,
    full_length_m: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRobot {
    name: String,
    tube: RawTube,
    body: BodyGeometry,
    world: World,
    #[serde(default)]
    model: Model,
    #[serde(default)]
    driving_unit: DrivingUnit,
    #[serde(default)]
    cup: Cup,
    #[serde(default)]
    limits: Limits,
    #[serde(default)]
    drive: Drive,
}

/// One of two alternative keys, exactly one present.
fn either(
    section: &str,
    (a, va): (&str, Option<f64>),
    (b, vb): (&str, Option<f64>),
) -> Result<(bool, f64), InputError> {
    match (va, vb) {
        (Some(x), None) => Ok((true, positive(&format!("{section}.{a}"), x)?)),
        (None, Some(x)) => Ok((false, positive(&format!("{section}.{b}"), x)?)),
        (Some(_), Some(_)) => Err(InputError::Invalid {
            field: format!("{section}.{a}"),
            value: format!("given together with {section}.{b}"),
            allowed: "exactly one of the two".into(),
        }),
        (None, None) => Err(InputError::Invalid {
            field: format!("{section}.{a}"),
            value: "missing".into(),
            allowed: format!("{a} or {b}"),
        }),
    }
}

impl Robot {
    /// The built-in LEeCH robot (estimated parameters, see [`BUILTIN_TOML`]).
    pub fn builtin() -> Robot {
        Robot::from_toml_str(BUILTIN_TOML).expect("the built-in robot file is valid")
    }

    /// Parses and validates a robot file.
    pub fn from_toml_str(text: &str) -> Result<Robot, InputError> {
        let raw: RawRobot =
            toml::from_str(text).map_err(|e| InputError::Toml { message: crate::error::one_line(text, &e) })?;
        // First: every other length is checked against it.
        let l = check_element_length("tube.element_length_m", raw.tube.element_length_m)?;
        let (per_element, mass) = either(
            "tube",
            ("element_mass_kg", raw.tube.element_mass_kg),
            ("mass_per_length_kg_per_m", raw.tube.mass_per_length_kg_per_m),
        )?;
        let (joint, stiffness) = either(
            "tube",
            ("joint_stiffness_nm_per_rad", raw.tube.joint_stiffness_nm_per_rad),
            ("bending_stiffness_nm2", raw.tube.bending_stiffness_nm2),
        )?;
        let robot = Robot {
            name: raw.name,
            tube: Tube {
                element_length_m: l,
                element_mass_kg: if per_element { mass } else { mass * l },
                joint_stiffness_nm_per_rad: if joint { stiffness } else { stiffness / l },
                joint_damping_nms_per_rad: raw.tube.joint_damping_nms_per_rad,
                min_bend_radius_m: raw.tube.min_bend_radius_m.unwrap_or(DEFAULT_MIN_BEND_RADIUS_M),
                outer_diameter_m: raw.tube.outer_diameter_m.unwrap_or(DEFAULT_TUBE_OUTER_DIAMETER_M),
                torsion_stiffness_nm_per_rad: raw.tube.torsion_stiffness_nm_per_rad,
                stop_stiffness_nm_per_rad: raw.tube.stop_stiffness_nm_per_rad,
                full_length_m: raw.tube.full_length_m,
            },
            body: raw.body,
            world: raw.world,
            model: raw.model,
            driving_unit: raw.driving_unit,
            cup: raw.cup,
            limits: raw.limits,
            drive: raw.drive,
        };
        robot.validate()?;
        Ok(robot)
    }

    /// Checks every value; call it again after changing fields by hand.
    pub fn validate(&self) -> Result<(), InputError> {
        crate::error::printable("name", &self.name)?;
        check_element_length("tube.element_length_m", self.tube.element_length_m)?;
        check_element_mass("tube.element_mass_kg", self.tube.element_mass_kg)?;
        positive("tube.joint_stiffness_nm_per_rad", self.tube.joint_stiffness_nm_per_rad)?;
        non_negative("tube.joint_damping_nms_per_rad", self.tube.joint_damping_nms_per_rad)?;
        non_negative("tube.min_bend_radius_m", self.tube.min_bend_radius_m)?;
        spacing("body.base_spacing_m", self.body.base_spacing_m)?;
        spacing("body.tip_spacing_m", self.body.tip_spacing_m)?;
        non_negative("body.payload_kg", self.body.payload_kg)?;
        within("world.gravity_m_per_s2", self.world.gravity_m_per_s2, 0.0, 1e3)?;
        within("world.base_angle_deg", self.world.base_angle_deg, -360.0, 360.0)?;
        within("tube.outer_diameter_m", self.tube.outer_diameter_m, OUTER_DIAMETER_M.0, OUTER_DIAMETER_M.1)?;
        // A stop the robot cannot have or reach: tighter than the hose's own
        // radius, or than the l / pi of a joint turned right back on itself.
        let tightest = (0.5 * self.tube.outer_diameter_m).max(self.tube.element_length_m / std::f64::consts::PI);
        let stop = self.tube.min_bend_radius_m;
        if stop != 0.0 && stop < tightest {
            return Err(InputError::invalid(
                "tube.min_bend_radius_m",
                stop,
                format!(
                    "0 (no stop) or at least {} m: no hose bends tighter than its own radius, and no joint tighter than l / pi",
                    Num(tightest)
                ),
            ));
        }
        if let Some(kt) = self.tube.torsion_stiffness_nm_per_rad {
            positive("tube.torsion_stiffness_nm_per_rad", kt)?;
        }
        if let Some(ks) = self.tube.stop_stiffness_nm_per_rad {
            positive("tube.stop_stiffness_nm_per_rad", ks)?;
        }
        self.cup.validate()?;
        self.validate_cup_offsets()?;
        let (b, r) = (self.body.base_spacing_m, 0.5 * self.tube.outer_diameter_m);
        self.driving_unit.validate(b, r, b + self.cup.rear_offset_m)?;
        self.drive.validate()?;
        // Planners build the body at the shortest lengths: both tubes there
        // must give it the four elements a body needs (see `body`).
        let l = self.tube.element_length_m;
        let min = self.limits.tube_length_min_m;
        if !(min.is_finite() && min >= 2.0 * l * (1.0 - 1e-12)) {
            return Err(InputError::invalid(
                "limits.tube_length_min_m",
                min,
                format!(
                    "at least two elements (2 x tube.element_length_m = {} m): the body needs four in all",
                    Num(2.0 * l)
                ),
            ));
        }
        let max = self.limits.tube_length_max_m;
        if !(max.is_finite() && max > min && max <= l * MAX_LINKS as f64) {
            return Err(InputError::invalid(
                "limits.tube_length_max_m",
                max,
                format!(
                    "a number > limits.tube_length_min_m ({}) and at most {MAX_LINKS} elements ({} m)",
                    Num(min),
                    Num(l * MAX_LINKS as f64)
                ),
            ));
        }
        if let Some(full) = self.tube.full_length_m {
            if !(full >= max && full <= l * MAX_LINKS as f64 * (1.0 + 1e-12)) {
                return Err(InputError::invalid(
                    "tube.full_length_m",
                    full,
                    format!(
                        "a length at least limits.tube_length_max_m ({} m, a planner cannot feed more tube than there is) and at most {MAX_LINKS} elements ({} m)",
                        Num(max),
                        Num(l * MAX_LINKS as f64)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// A cup face closer to chain B's axis than the tube's radius would put
    /// the tube into the surface the cup holds.
    fn validate_cup_offsets(&self) -> Result<(), InputError> {
        let radius = 0.5 * self.tube.outer_diameter_m;
        for (field, offset) in
            [("cup.rear_offset_m", self.cup.rear_offset_m), ("cup.front_offset_m", self.cup.front_offset_m)]
        {
            if !(offset >= radius) {
                return Err(InputError::invalid(
                    field,
                    offset,
                    format!("a number >= the tube's radius ({} m, half of tube.outer_diameter_m)", Num(radius)),
                ));
            }
        }
        Ok(())
    }

    /// The robot file for this description (values only, no comments).
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).expect("a robot always serializes")
    }

    /// Shape parameter `Pi = k / (m g l)` of one tube (dimensionless; infinite at `g = 0`).
    pub fn shape_parameter(&self) -> f64 {
        self.tube.joint_stiffness_nm_per_rad
            / (self.tube.element_mass_kg * self.world.gravity_m_per_s2 * self.tube.element_length_m)
    }

    /// The same robot with the driving unit's clamp at `degrees` from +x.
    pub fn with_base_angle(&self, degrees: f64) -> Result<Robot, InputError> {
        self.with(|r| r.world.base_angle_deg = degrees)
    }

    /// The same robot under gravity `g` (m/s^2, along -y; 0 for none).
    pub fn with_gravity(&self, g: f64) -> Result<Robot, InputError> {
        self.with(|r| r.world.gravity_m_per_s2 = g)
    }

    /// The same robot cut into links by another scheme.
    pub fn with_discretization(&self, discretization: Discretization) -> Robot {
        let mut robot = self.clone();
        robot.model.discretization = discretization;
        robot
    }

    /// The same robot with other tube properties: joint stiffness `k` (N m/rad)
    /// and element mass `m` (kg), as a calibration fits them.
    pub fn with_tube(&self, stiffness: f64, element_mass: f64) -> Result<Robot, InputError> {
        self.with(|r| {
            r.tube.joint_stiffness_nm_per_rad = stiffness;
            r.tube.element_mass_kg = element_mass;
        })
    }

    /// The same robot with joint damping `d` (N m s/rad).
    pub fn with_damping(&self, damping: f64) -> Result<Robot, InputError> {
        self.with(|r| r.tube.joint_damping_nms_per_rad = damping)
    }

    /// The same tube cut into elements of length `l` (m): bending stiffness
    /// `EI = k l`, mass per length `m / l` and the dampers' `d l` kept, so the
    /// physical robot is unchanged and only the discretization is finer or
    /// coarser (docs/model.md section 9).
    pub fn with_element_length(&self, l: f64) -> Result<Robot, InputError> {
        let l = positive("element length (m)", l)?;
        let ratio = l / self.tube.element_length_m;
        self.with(|r| {
            r.tube.element_length_m = l;
            r.tube.element_mass_kg *= ratio;
            r.tube.joint_stiffness_nm_per_rad /= ratio;
            r.tube.joint_damping_nms_per_rad /= ratio;
        })
    }

    /// The same robot with other suction cups.
    pub fn with_cup(&self, cup: Cup) -> Result<Robot, InputError> {
        self.with(|r| r.cup = cup)
    }

    /// The same robot under another name.
    pub fn with_name(&self, name: impl Into<String>) -> Robot {
        Robot { name: name.into(), ..self.clone() }
    }

    /// A changed copy, validated: every builder goes through here so that no
    /// invalid robot escapes.
    fn with(&self, change: impl FnOnce(&mut Robot)) -> Result<Robot, InputError> {
        let mut robot = self.clone();
        change(&mut robot);
        robot.validate()?;
        Ok(robot)
    }

    /// The same robot with shape parameter `pi`, set by scaling the joint
    /// stiffness: `k = Pi m g l` (masses and geometry unchanged).
    pub fn with_shape_parameter(&self, pi: f64) -> Result<Robot, InputError> {
        let pi = positive("shape parameter", pi)?;
        let g = positive("world.gravity_m_per_s2 (the shape parameter needs gravity)", self.world.gravity_m_per_s2)?;
        let k = pi * self.tube.element_mass_kg * g * self.tube.element_length_m;
        self.with(|r| r.tube.joint_stiffness_nm_per_rad = k)
    }

    /// The robot scaled in size by `factor` with the same shape parameter and
    /// payload ratio (docs/model.md section 8): lengths `l, b, c` times `s`, the
    /// tube's mass per length kept (`m` and `ms` times `s`), so `k` times `s^2`
    /// keeps `Pi = k/(m g l)`; damping times `s^2.5` keeps the damping ratio.
    /// Tube lengths must be scaled by `s` too for the same shape: the angles
    /// are then unchanged and every position is multiplied by `s`.
    ///
    /// The rest follows the same rule: every length (tube diameter, cup
    /// geometry and tolerances, tube length limits) times `s`, the driving
    /// unit's mass times `s` like the payload, and the cups' pull-off force
    /// times `s`: the loads on a cup grow as `s` and a moment over the cup's
    /// radius too, so every cup keeps its safety factor ([`crate::cup`]).
    pub fn scaled(&self, factor: f64) -> Result<Robot, InputError> {
        let s = positive("scale factor", factor)?;
        self.with(|robot| {
            robot.tube.element_length_m *= s;
            robot.tube.element_mass_kg *= s;
            robot.tube.joint_stiffness_nm_per_rad *= s * s;
            let stiffnesses = [&mut robot.tube.torsion_stiffness_nm_per_rad, &mut robot.tube.stop_stiffness_nm_per_rad];
            for k in stiffnesses.into_iter().flatten() {
                *k *= s * s;
            }
            robot.tube.joint_damping_nms_per_rad *= s * s * s.sqrt();
            robot.tube.min_bend_radius_m *= s;
            robot.body.base_spacing_m *= s;
            robot.body.tip_spacing_m *= s;
            robot.body.payload_kg *= s;
            robot.tube.outer_diameter_m *= s;
            let unit = &mut robot.driving_unit;
            unit.mass_kg *= s;
            if let Some(centre) = &mut unit.centre_of_mass_m {
                centre.iter_mut().for_each(|x| *x *= s);
            }
            let cup = &mut robot.cup;
            for length in [
                &mut unit.length_m,
                &mut unit.height_m,
                &mut unit.back_m,
                &mut unit.top_m,
                &mut unit.rear_cup_behind_m,
                &mut cup.diameter_m,
                &mut cup.attach_distance_tolerance_m,
                &mut cup.rear_offset_m,
                &mut cup.front_offset_m,
                &mut cup.preload_m,
                &mut robot.limits.tube_length_min_m,
                &mut robot.limits.tube_length_max_m,
            ] {
                *length *= s;
            }
            if let Some(full) = &mut robot.tube.full_length_m {
                *full *= s;
            }
            cup.pull_off_force_n *= s;
        })
    }

    /// Bending stiffness `EI = k l` (N m^2).
    pub fn bending_stiffness(&self) -> f64 {
        self.tube.joint_stiffness_nm_per_rad * self.tube.element_length_m
    }

    /// Mass per length `rho = m / l` (kg/m).
    pub fn mass_per_length(&self) -> f64 {
        self.tube.element_mass_kg / self.tube.element_length_m
    }

    /// Checks a tube length: at least one element, at most the tube's whole
    /// length (`tube.full_length_m`) or, where that is not given, [`MAX_LINKS`].
    pub fn check_tube_length(&self, field: &str, length: f64) -> Result<f64, InputError> {
        let l = self.tube.element_length_m;
        let (most, allowed) = match self.tube.full_length_m {
            Some(full) => (full, format!("the tube's whole length (tube.full_length_m = {} m)", Num(full))),
            None => (l * MAX_LINKS as f64, format!("{MAX_LINKS} elements")),
        };
        // A relative slack keeps exactly MAX_LINKS elements inside despite rounding.
        within(field, length, l * (1.0 - 1e-12), most * (1.0 + 1e-12)).map_err(|_| {
            InputError::invalid(field, length, format!("a tube length in m from one element ({}) to {allowed}", Num(l)))
        })
    }

    /// What the driving unit carries (kg) with the three tubes fed to
    /// `tube_lengths_m` (m, each checked by [`Robot::check_tube_length`]):
    /// its own `mass_kg` and the tubes' tails behind the clamps,
    /// `rho sum_i (full - L_i)`, lumped at its centre of mass (docs/model.md
    /// section 13). With no `tube.full_length_m`, `mass_kg` alone.
    pub fn unit_mass_kg(&self, tube_lengths_m: [f64; 3]) -> f64 {
        let tails = self.tube.full_length_m.map_or(0.0, |full| tube_lengths_m.iter().map(|length| full - length).sum());
        self.driving_unit.mass_kg + self.mass_per_length() * tails
    }

    /// What the driving unit carries (kg) under the planar body of tube
    /// lengths `la` (chain A, the centre tube) and `lb` (chain B, the side
    /// pair): [`Robot::unit_mass_kg`] of `[la, lb, lb]`.
    pub fn planar_unit_mass_kg(&self, la: f64, lb: f64) -> f64 {
        self.unit_mass_kg([la, lb, lb])
    }

    pub(crate) fn spec(&self, tube_length: f64, tubes: f64, tip_mass: f64, clamp_point: [f64; 2]) -> ChainSpec {
        ChainSpec {
            tube_length,
            element_length: self.tube.element_length_m,
            element_mass: tubes * self.tube.element_mass_kg,
            stiffness: tubes * self.tube.joint_stiffness_nm_per_rad,
            damping: tubes * self.tube.joint_damping_nms_per_rad,
            tip_mass,
            clamp_point,
            clamp_angle: self.world.base_angle_deg.to_radians(),
            discretization: self.model.discretization,
        }
    }

    /// The two-chain body for tube lengths `la` (centre tube, chain A) and
    /// `lb` (side pair, chain B), in m.
    pub fn body(&self, la: f64, lb: f64) -> Result<Body, InputError> {
        self.validate()?;
        self.valid_body(la, lb)
    }

    /// [`Robot::body`] of a robot validated already: a sweep checks its
    /// robots once, not at each of its tens of thousands of bodies (the
    /// whole robot's checks were 1 % of the Fig. 12 sweep).
    pub(crate) fn valid_body(&self, la: f64, lb: f64) -> Result<Body, InputError> {
        let la = self.check_tube_length("lengths[0] (LA)", la)?;
        let lb = self.check_tube_length("lengths[1] (LB)", lb)?;
        // The plate takes three constraints: with fewer than four links the
        // body has no freedom left (and is over-determined unless b = c).
        let d = self.model.discretization;
        let l = self.tube.element_length_m;
        let links = d.link_count(la, l) + d.link_count(lb, l);
        if links < 4 {
            return Err(InputError::Invalid {
                field: "lengths (LA, LB)".into(),
                value: format!("{la}, {lb} ({links} elements in all)"),
                allowed: format!("at least 4 elements in all, e.g. both tubes at least {} m", Num(2.0 * l)),
            });
        }
        let nu = right_normal(self.world.base_angle_deg.to_radians());
        let b = self.body.base_spacing_m;
        let [one, two] = TUBES_PER_CHAIN;
        let a = Chain::new(&self.spec(la, one, 0.0, [0.0, 0.0]));
        let chain_b = Chain::new(&self.spec(lb, two, self.body.payload_kg, [b * nu[0], b * nu[1]]));
        Ok(Body::new(a, chain_b, self.body.tip_spacing_m, self.world.gravity_m_per_s2))
    }

    /// One of the robot's tubes alone, clamped at the origin, with `tip_mass` (kg).
    pub fn cantilever(&self, length: f64, tip_mass: f64) -> Result<Cantilever, InputError> {
        self.validate()?;
        let length = self.check_tube_length("tube length", length)?;
        let tip_mass = non_negative("tip mass", tip_mass)?;
        Ok(Cantilever::new(Chain::new(&self.spec(length, 1.0, tip_mass, [0.0, 0.0])), self.world.gravity_m_per_s2))
    }
}
