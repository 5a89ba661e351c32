//! The hose's stop: the stripwound hose around the tubes bends no tighter
//! than its minimum radius `R_min` (m, `[tube] min_bend_radius_m`). There it
//! locks and carries the bending moment itself.
//!
//! # Rows
//!
//! A joint `j` of a chain turns by `beta_j = phi_j - phi_(j-1)` (rad; the
//! clamp's direction, the driving unit's angle `phi0`, stands before the
//! first link). A joint stands for one element of length `l` (m) bent to
//! radius `l / |beta_j|` ([`Chain::min_bend_radius`](crate::chain::Chain::min_bend_radius)),
//! so the stop is a unilateral row local to two coordinates:
//!
//! ```text
//! C(q) = beta_max - s beta_j(q),          beta_max = l / R_min          (rad)
//! C + c lambda >= 0,  lambda >= 0,  lambda (C + c lambda) = 0            (N m)
//! ```
//!
//! with `s = +-1` the side the joint turns to and `c = 1 / k_stop` the
//! locked hose's compliance (rad/(N m); `[tube] stop_stiffness_nm_per_rad`,
//! an estimate of 100 `k` by default). The row is linear in `q` (no
//! curvature), its Jacobian has two entries, `-s` at `phi_j` and `+s` at
//! `phi_(j-1)`, and its multiplier `lambda` is the moment the locked hose
//! carries at that joint, on top of the joint's spring: a one-sided spring
//! of stiffness `k_stop` past the stop, `lambda = k_stop (s beta - beta_max)`.
//!
//! The compliance is physical (no hose is rigid) and it is what keeps the
//! rows solvable: a joint locked next to a held clamp makes the link beyond
//! it part of the driving unit, and a contact on that link would otherwise
//! be a combination of the hold's rows and the stop's (a singular
//! Jacobian); with it the stop shares that load as a spring does.
//!
//! # Candidates
//!
//! Like contacts ([`crate::contact`]), rows are found from the geometry at
//! each solved shape: every joint turned past [`CANDIDATE_FRACTION`] of its
//! stop gets a row on its side. A joint at or past its stop in the shape a
//! solve starts from starts locked ([`StopRow::reached`]); the active set
//! lets it go where its moment would pull. A settle is done when no joint is
//! turned past its stop by more than its moment takes up ([`overturn`]).
//!
//! # Limits
//!
//! The stop acts on each joint separately, as a linear spring past it; the
//! hose turns freely up to it (its own bending stiffness is in `k`). Every
//! joint takes the limit of a whole element `l`, the short last element of
//! a tube that is not a whole number of elements too (as
//! [`Chain::min_bend_radius`](crate::chain::Chain::min_bend_radius) measures it). It acts
//! in the two-tube body's solves among solids (the staged feeds of
//! [`crate::stance`], the planner; not the single clamped tube of
//! [`crate::stance::tube_in`], which is one tube without its hose); the clamped body in free space (`leech shape` without a scene,
//! the paper's Fig. 12 sweep) marks shapes past it infeasible instead.
//! `R_min = 0` leaves the stop out.

use crate::contact::planar::Touching;

/// A joint gets a stop row once it has turned this fraction of the way to
/// its stop: far enough below it that one Newton run on the rows it has
/// rarely turns a joint from free past its stop, near enough that a
/// straight body carries no rows.
pub const CANDIDATE_FRACTION: f64 = 0.8;

/// How far past its stop (a fraction of `beta_max`) a locked joint may give
/// in a shape the planner takes ([`crate::stance::Held::within_stop`]):
/// under the robot's weight a joint locks within about 3 % of its stop;
/// one that gives more is a hose crushed by lengths that ask the body for
/// more turn than its locked joints allow, or a shape solved in free space
/// that bends past the stop.
pub const GIVE_FRACTION: f64 = 0.05;

/// Turns closer to the stop than this (rad) count as at it, or short of it:
/// rounding.
pub const AT_STOP_RAD: f64 = 1e-9;

/// The stop of one chain's joints.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop {
    /// `beta_max = l / R_min` (rad).
    pub limit_rad: f64,
    /// `c = 1 / k_stop` (rad/(N m)).
    pub compliance: f64,
}

impl Stop {
    /// The stop of joints of elements `element_length` (m) for the hose's
    /// `min_bend_radius` (m) and locked stiffness `stiffness` (N m/rad);
    /// `None` without a stop (`min_bend_radius` 0).
    pub fn new(element_length: f64, min_bend_radius: f64, stiffness: f64) -> Option<Stop> {
        (min_bend_radius > 0.0)
            .then(|| Stop { limit_rad: element_length / min_bend_radius, compliance: 1.0 / stiffness })
    }
}

/// One stop row: joint `joint` of chain `chain` held at or short of its stop
/// on the side `sign`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StopRow {
    /// The chain: 0 for A, 1 for B.
    pub chain: usize,
    /// The joint (0 at the clamp: between the clamp's direction and link 0).
    pub joint: usize,
    /// The side the joint turns to: `+1` counter-clockwise, `-1` clockwise.
    pub sign: f64,
    /// The chain's stop.
    pub stop: Stop,
}

impl StopRow {
    /// The row's value `C = beta_max - s beta` (rad) for the joint's turn `beta`.
    pub fn value(&self, turn: f64) -> f64 {
        self.stop.limit_rad - self.sign * turn
    }

    /// Whether a joint turned by `turn` is at its stop or past it: a row a
    /// solve starts with locked.
    pub fn reached(&self, turn: f64) -> bool {
        self.value(turn) <= AT_STOP_RAD
    }

    /// Whether `other` holds the same joint on the same side.
    pub fn same_joint(&self, other: &StopRow) -> bool {
        self.chain == other.chain && self.joint == other.joint && self.sign == other.sign
    }
}

/// The stop rows of `system` at `q` into `out` (cleared first): every joint
/// turned past [`CANDIDATE_FRACTION`] of its stop.
pub fn detect<S: Touching>(system: &S, q: &[f64], out: &mut Vec<StopRow>) {
    out.clear();
    let mut turned = Vec::new();
    for chain in 0..system.chain_count() {
        let Some(stop) = system.stop(chain) else { continue };
        system.joint_turns(q, chain, &mut turned);
        for (joint, beta) in turned.iter().enumerate() {
            if beta.abs() >= CANDIDATE_FRACTION * stop.limit_rad {
                out.push(StopRow { chain, joint, sign: beta.signum(), stop });
            }
        }
    }
}

/// The largest amount (rad) by which a joint of `system` at `q` is turned
/// past its stop with no moment to hold it there: beyond what the locked
/// joints' moments (N m; among `multipliers`, all of the system's) take
/// up in the hose's compliance. 0 where none is.
pub fn overturn<S: Touching>(system: &S, q: &[f64], multipliers: &[f64]) -> f64 {
    let mut deepest: f64 = 0.0;
    let mut turned = Vec::new();
    for chain in 0..system.chain_count() {
        let Some(stop) = system.stop(chain) else { continue };
        system.joint_turns(q, chain, &mut turned);
        for (joint, beta) in turned.iter().enumerate() {
            let mut held = locked(system, multipliers);
            let held = held.find(|(s, _)| s.chain == chain && s.joint == joint && s.sign == beta.signum());
            let give = held.map_or(0.0, |(s, moment)| s.stop.compliance * moment);
            deepest = deepest.max(beta.abs() - stop.limit_rad - give);
        }
    }
    deepest
}

/// The stop rows of `system` that hold at `multipliers` (all of the
/// system's, in row order), with their moments (N m): the joints locked.
pub fn locked<'s, S: Touching>(system: &'s S, multipliers: &'s [f64]) -> impl Iterator<Item = (&'s StopRow, f64)> {
    let moments = &multipliers[system.stop_row()..system.contact_row()];
    system.stops().iter().zip(moments).filter(|(_, moment)| **moment > 0.0).map(|(stop, moment)| (stop, *moment))
}

/// A locked joint as reported: where the hose carries a moment.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StopMoment {
    /// `"a"` or `"b"`.
    pub chain: &'static str,
    /// The joint, 0 at the clamp.
    pub joint: usize,
    /// Where the joint is (m).
    pub point_m: [f64; 2],
    /// The side it turns to: `+1` counter-clockwise, `-1` clockwise.
    pub sign: f64,
    /// The moment the locked hose carries (N m, `>= 0`).
    pub moment_nm: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_is_zero_at_its_stop_and_positive_short_of_it() {
        let made = Stop::new(0.01, 0.025, 50.0).unwrap();
        assert!((made.limit_rad - 0.4).abs() < 1e-15 && made.compliance == 0.02, "{made:?}");
        assert_eq!(Stop::new(0.01, 0.0, 50.0), None);
        let stop = Stop { limit_rad: 0.4, compliance: 0.02 };
        let row = StopRow { chain: 0, joint: 3, sign: -1.0, stop };
        assert_eq!(row.value(-0.4), 0.0);
        assert!(row.reached(-0.4 + 0.5 * AT_STOP_RAD) && row.reached(-0.5) && !row.reached(-0.39));
        assert!(row.value(-0.1) > 0.0 && row.value(-0.5) < 0.0);
        // The other side's turn is far from this side's stop.
        assert!((row.value(0.4) - 0.8).abs() < 1e-15);
    }
}
