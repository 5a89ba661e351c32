//! Whether a suction cup holds: its verdict under the reaction of a hold.
//!
//! A hold is judged from what the surface exerts on the robot at the cup: a
//! force `F` (N, world frame) and a moment `M` (N m, counter-clockwise) about
//! the cup's centre. `n` is the surface's outward unit normal (from the
//! surface into free space), `F_v` the cup's pull-off force on a smooth
//! surface, `mu` the friction coefficient and `R` the radius of the lip
//! (robot file section `[cup]`, [`Cup`]):
//!
//! ```text
//! P  = max(-F.n, 0)            pull: the surface pulling the cup off
//! N  = max( F.n, 0)            push: the robot pressed onto the surface
//! S  = |F - (F.n) n|           shear, along the surface
//! Q  = P + 2 |M| / R           rim pull: the pull plus the peel equivalent of M
//! C  = F_v + N                 what presses the lip on: vacuum and push
//! SF_normal = C / Q            the lip opens (pull-off, peel)
//! SF_shear  = mu C / S         the cup slides
//! SF = min(SF_normal, SF_shear), infinite for a mode without load
//! holds          when SF >= 1
//! meets_minimum  when SF >= min_safety_factor
//! ```
//!
//! The load cases are those of vacuum-gripper design practice (Schmalz's
//! vacuum technology handbook): a pull along the normal is held by the
//! vacuum force, a shear only through friction, and a safety factor of at
//! least 1.5 is kept on smooth, dense surfaces. A push is no load on the
//! seal: it presses the lip on like the vacuum does, so it adds to both
//! capacities.
//!
//! **Peel.** A moment about the cup's centre tilts the cup and lifts one side
//! of the lip; the cup lets go where the lip's contact pressure first falls to
//! zero, the failure criterion of Mantriota's models of suction-cup grasps
//! (Mechanism and Machine Theory, 2007). leech takes the lip as a thin ring
//! of radius `R` whose contact load varies linearly across it. The clamping
//! force `C` less the pull `P` spreads evenly, `(C - P) / (2 pi R)` per unit
//! length, and the moment adds `M cos(theta) / (pi R^2)` (which integrates back
//! to `M`). The ring opens at `theta = 0` when `C = P + 2 |M| / R`: a moment
//! counts as an extra pull of `2 |M| / R`. That lies between a rigid cup
//! tipping about its rim (`|M| / R`) and a full disc in contact (`4 |M| / R`,
//! the disc's section modulus). The lip is a ring, so the ring's value is used.
//!
//! Without a push, `SF` is also the factor by which the whole reaction can
//! grow before the cup fails. An infinite factor is written as `null` in JSON.
//!
//! ```
//! use leech::cup::verdict;
//! use leech::robot::Robot;
//! let cup = Robot::builtin().cup;
//! // A 1 kg robot under a ceiling: the surface holds it up, pulling the cup.
//! let v = verdict(&cup, [0.0, 9.81], 0.0, [0.0, -1.0]).unwrap();
//! assert!((v.normal_pull_n - 9.81).abs() < 1e-12 && v.shear_n.abs() < 1e-12);
//! assert!((v.safety_factor - cup.pull_off_force_n / 9.81).abs() < 1e-12);
//! assert!(v.holds && v.meets_minimum);
//! ```

use serde::Serialize;

use crate::error::{InputError, Num};
use crate::geom::{cross, dot, Vec2};
pub use crate::robot::Cup;

/// How far a surface normal may be from unit length: rounding, not a wrong
/// vector.
pub(crate) const UNIT_TOLERANCE: f64 = 1e-6;

/// Which failure a cup is closest to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CupMode {
    /// The lip opens: the pull and the peel at the rim exceed what presses it on.
    Normal,
    /// The cup slides along the surface: the shear exceeds the friction.
    Shear,
}

/// A cup under a hold's reaction: its loads, capacities and safety factors.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CupVerdict {
    /// Pull-off load `P`: the surface pulling the cup along `-n` (N, >= 0).
    pub normal_pull_n: f64,
    /// Push `N`: the robot pressed onto the surface (N, >= 0; zero when pulled).
    pub normal_push_n: f64,
    /// Shear `S` along the surface (N, >= 0).
    pub shear_n: f64,
    /// Peel moment `|M|` about the cup's centre (N m).
    pub peel_moment_nm: f64,
    /// Rim pull `Q = P + 2 |M| / R` (N).
    pub rim_pull_n: f64,
    /// What presses the lip on, `C = F_v + N` (N): the capacity against the rim pull.
    pub capacity_normal_n: f64,
    /// Friction capacity `mu C` (N).
    pub capacity_shear_n: f64,
    /// `C / Q`; infinite without rim pull.
    pub safety_factor_normal: f64,
    /// `mu C / S`; infinite without shear.
    pub safety_factor_shear: f64,
    /// The smaller of the two; infinite when the cup is unloaded.
    pub safety_factor: f64,
    /// The mode with the smaller factor (`normal` on a tie); none when unloaded.
    pub limited_by: Option<CupMode>,
    /// The model predicts the cup holds: `safety_factor >= 1`.
    pub holds: bool,
    /// The hold keeps the cup's margin: `safety_factor >= min_safety_factor`.
    pub meets_minimum: bool,
}

/// The verdict on `cup` when the surface, with outward unit normal
/// `outward_normal`, exerts `force_n` (N, world frame) on the robot at the
/// cup and `moment_nm` (N m, counter-clockwise) about the cup's centre.
///
/// Errors (never panics) for a non-finite force or moment, a normal that is
/// not a finite unit vector, or an invalid cup.
pub fn verdict(cup: &Cup, force_n: Vec2, moment_nm: f64, outward_normal: Vec2) -> Result<CupVerdict, InputError> {
    cup.validate()?;
    if !force_n.iter().all(|f| f.is_finite()) {
        return Err(InputError::Invalid {
            field: "cup force (N)".into(),
            value: format!("({}, {})", Num(force_n[0]), Num(force_n[1])),
            allowed: "finite components".into(),
        });
    }
    if !moment_nm.is_finite() {
        return Err(InputError::invalid("cup moment (N m)", moment_nm, "a finite number"));
    }
    let n = outward_normal;
    let length = n[0].hypot(n[1]);
    if !((length - 1.0).abs() <= UNIT_TOLERANCE) {
        return Err(InputError::Invalid {
            field: "surface normal".into(),
            value: format!("({}, {})", Num(n[0]), Num(n[1])),
            allowed: format!("a unit vector (length 1 within {UNIT_TOLERANCE})"),
        });
    }

    // Split without max(): it keeps a zero component +0.0 rather than -0.0.
    let along = dot(force_n, n);
    let (normal_pull_n, normal_push_n) = if along < 0.0 { (-along, 0.0) } else { (0.0, along) };
    let shear_n = cross(n, force_n).abs();
    let peel_moment_nm = moment_nm.abs();
    let rim_pull_n = normal_pull_n + 2.0 * peel_moment_nm / (0.5 * cup.diameter_m);
    let capacity_normal_n = cup.pull_off_force_n + normal_push_n;
    let capacity_shear_n = cup.friction_coefficient * capacity_normal_n;
    let safety_factor_normal = factor(capacity_normal_n, rim_pull_n);
    let safety_factor_shear = factor(capacity_shear_n, shear_n);
    let safety_factor = safety_factor_normal.min(safety_factor_shear);
    let limited_by = if safety_factor.is_infinite() {
        None
    } else if safety_factor_normal <= safety_factor_shear {
        Some(CupMode::Normal)
    } else {
        Some(CupMode::Shear)
    };
    Ok(CupVerdict {
        normal_pull_n,
        normal_push_n,
        shear_n,
        peel_moment_nm,
        rim_pull_n,
        capacity_normal_n,
        capacity_shear_n,
        safety_factor_normal,
        safety_factor_shear,
        safety_factor,
        limited_by,
        holds: safety_factor >= 1.0,
        meets_minimum: safety_factor >= cup.min_safety_factor,
    })
}

/// Capacity over load; a mode without load cannot fail.
fn factor(capacity: f64, load: f64) -> f64 {
    if load > 0.0 {
        capacity / load
    } else {
        f64::INFINITY
    }
}
