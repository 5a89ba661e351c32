//! Robot descriptions: the TOML file format and the built-in LEeCH robot.
//!
//! A robot file gives one tube's element (`l` in m, `m` in kg, `k` in N m/rad,
//! `d` in N m s/rad, or the continuum `EI` in N m^2 and `rho` in kg/m, with
//! `k = EI / l` and `m = rho l`), the body's spacings `b`, `c` (m) and payload
//! `ms` (kg), gravity (m/s^2), the clamp angle (deg) and the discretization.
//! Every key is SI and checked; unknown keys are errors. The shape parameter
//! of the tube is `Pi = k / (m g l)` (docs/model.md section 8).
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
use crate::chain::{Chain, ChainSpec, Discretization};
use crate::error::{non_negative, positive, within, InputError};
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
    /// Tightest bend the real tube takes (m); sweeps mark tighter shapes infeasible.
    pub min_bend_radius_m: f64,
}

/// The paper's stripwound hose: 25 mm minimum bending radius.
pub const DEFAULT_MIN_BEND_RADIUS_M: f64 = 0.025;

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
    #[serde(default)]
    pub discretization: Discretization,
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
        let raw: RawRobot = toml::from_str(text).map_err(|e| InputError::Toml {
            message: e.to_string().split_whitespace().collect::<Vec<_>>().join(" "),
        })?;
        let l = positive("tube.element_length_m", raw.tube.element_length_m)?;
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
            },
            body: raw.body,
            world: raw.world,
            model: raw.model,
        };
        robot.validate()?;
        Ok(robot)
    }

    /// Checks every value; call it again after changing fields by hand.
    pub fn validate(&self) -> Result<(), InputError> {
        positive("tube.element_length_m", self.tube.element_length_m)?;
        positive("tube.element_mass_kg", self.tube.element_mass_kg)?;
        positive("tube.joint_stiffness_nm_per_rad", self.tube.joint_stiffness_nm_per_rad)?;
        non_negative("tube.joint_damping_nms_per_rad", self.tube.joint_damping_nms_per_rad)?;
        non_negative("tube.min_bend_radius_m", self.tube.min_bend_radius_m)?;
        positive("body.base_spacing_m", self.body.base_spacing_m)?;
        positive("body.tip_spacing_m", self.body.tip_spacing_m)?;
        non_negative("body.payload_kg", self.body.payload_kg)?;
        within("world.gravity_m_per_s2", self.world.gravity_m_per_s2, 0.0, 1e3)?;
        within("world.base_angle_deg", self.world.base_angle_deg, -360.0, 360.0)?;
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
    pub fn scaled(&self, factor: f64) -> Result<Robot, InputError> {
        let s = positive("scale factor", factor)?;
        self.with(|robot| {
            robot.tube.element_length_m *= s;
            robot.tube.element_mass_kg *= s;
            robot.tube.joint_stiffness_nm_per_rad *= s * s;
            robot.tube.joint_damping_nms_per_rad *= s * s * s.sqrt();
            robot.tube.min_bend_radius_m *= s;
            robot.body.base_spacing_m *= s;
            robot.body.tip_spacing_m *= s;
            robot.body.payload_kg *= s;
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

    /// Checks a tube length: at least one element, at most [`MAX_LINKS`].
    pub fn check_tube_length(&self, field: &str, length: f64) -> Result<f64, InputError> {
        let l = self.tube.element_length_m;
        // A relative slack keeps exactly MAX_LINKS elements inside despite rounding.
        within(field, length, l * (1.0 - 1e-12), l * MAX_LINKS as f64 * (1.0 + 1e-12)).map_err(|_| {
            InputError::invalid(
                field,
                length,
                format!("a tube length in m from one element ({l}) to {MAX_LINKS} elements"),
            )
        })
    }

    fn spec(&self, tube_length: f64, tubes: f64, tip_mass: f64, clamp_point: [f64; 2]) -> ChainSpec {
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
                allowed: format!("at least 4 elements in all, e.g. both tubes at least {} m", 2.0 * l),
            });
        }
        let nu = right_normal(self.world.base_angle_deg.to_radians());
        let b = self.body.base_spacing_m;
        let a = Chain::new(&self.spec(la, 1.0, 0.0, [0.0, 0.0]));
        let chain_b = Chain::new(&self.spec(lb, 2.0, self.body.payload_kg, [b * nu[0], b * nu[1]]));
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
