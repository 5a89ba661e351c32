//! Batch solves: the clamped two-chain body at many tube lengths (and
//! optionally base angles) at once, on all cores, each entry with its own
//! status, in memory bounded by the batch's own outputs.
//!
//! # What an entry is
//!
//! Entry `i` is the body of `robot` with tube lengths `LA = la_m[i]`,
//! `LB = lb_m[i]` (m), clamped at the base angle `base_angle_deg[i]` (deg)
//! when angles are given, at the robot's own otherwise. Its result is the
//! equilibrium the command line's `leech shape` reports (endpoint in m,
//! endpoint plate angle in rad, stability), or why there is none:
//!
//! * [`Status::Invalid`]: the entry is not a body (a NaN, a length outside
//!   one element to [`crate::robot::MAX_LINKS`] elements, a base angle
//!   outside [-360, 360] deg); its reason is the [`InputError`]'s line.
//! * [`Status::NotConverged`]: the solver failed; its reason is the solver's.
//!
//! Neither stops the batch: the other entries are solved as if it were not
//! there (a warm start skips it, see below). Only a batch that cannot be
//! read at all (arrays of different lengths, a robot that does not
//! validate) is an error.
//!
//! # Warm starts
//!
//! A cold solve follows the robot's history from straight, equal tubes
//! ([`Body::solve`](crate::body::Body::solve)); it is what `leech shape`
//! prints, bit for bit. When consecutive
//! entries lie within `warm_step_m` of each other in both lengths (and share
//! the base angle), the batch reads them as an actuation path, as the
//! workspace sweep does ([`crate::sweep`]): the entry is warm-started from
//! its predecessor's equilibrium carried over ([`Body::carry_over`](crate::body::Body::carry_over)), one or
//! two Newton steps instead of a whole continuation, and flagged `warm`; a
//! warm start moving some angle by more than [`crate::sweep::SNAP_RAD`] is
//! flagged `snapped` (a snap on the path), and a failed one is retried cold.
//! Farther entries, or `warm_step_m = 0`, are solved cold.
//!
//! The batch is cut into chunks of [`CHUNK`] entries counted from its start,
//! solved in parallel (rayon); warm starts never cross a chunk's start. So a
//! batch solved in pieces whose lengths are multiples of [`CHUNK`] (a
//! distributed study's tasks, a binding's blocks) gives exactly the results
//! of the batch solved whole, and the memory a solve holds beyond the
//! outputs is one body per thread.

use rayon::prelude::*;

use crate::error::InputError;
use crate::robot::Robot;
use crate::statics::{Scratch, Solver};
use crate::sweep::{solve_body, Seed};

/// Entries per chunk: the unit of parallel work and the span of warm starts.
pub const CHUNK: usize = 256;

/// The default largest step between entries read as an actuation path (m):
/// the workspace sweep's usual grid step.
pub const WARM_STEP_M: f64 = 0.005;

/// The tube lengths (m) and optional base angles (deg) of a batch.
#[derive(Clone, Copy, Debug)]
pub struct Query<'a> {
    /// Length LA of the centre tube (m), one per entry.
    pub la_m: &'a [f64],
    /// Length LB of the side tubes (m), one per entry.
    pub lb_m: &'a [f64],
    /// Base angle of the driving unit (deg), one per entry; the robot's own when `None`.
    pub base_angle_deg: Option<&'a [f64]>,
}

impl Query<'_> {
    /// Entries in the batch, once the arrays are checked to agree.
    pub fn len(&self) -> Result<usize, InputError> {
        let n = self.la_m.len();
        let mismatch = |field: &str, got: usize| InputError::Invalid {
            field: field.into(),
            value: format!("{got} entries"),
            allowed: format!("as many entries as la_m ({n})"),
        };
        if self.lb_m.len() != n {
            return Err(mismatch("lb_m", self.lb_m.len()));
        }
        match self.base_angle_deg {
            Some(a) if a.len() != n => Err(mismatch("base_angle_deg", a.len())),
            _ => Ok(n),
        }
    }

    /// Whether the batch has no entries.
    pub fn is_empty(&self) -> bool {
        self.la_m.is_empty()
    }
}

/// How a batch is solved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatchOptions {
    /// Largest change of either length between consecutive entries for a
    /// warm start (m); 0 solves every entry cold.
    pub warm_step_m: f64,
}

impl Default for BatchOptions {
    fn default() -> Self {
        BatchOptions { warm_step_m: WARM_STEP_M }
    }
}

/// What became of an entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[repr(u8)]
pub enum Status {
    /// Solved: the outcome's numbers are the equilibrium's.
    Converged = 0,
    /// The solver failed (its reason in [`Failure`]); the numbers are NaN.
    NotConverged = 1,
    /// The entry is not a body (its reason in [`Failure`]); the numbers are NaN.
    #[default]
    Invalid = 2,
}

impl Status {
    /// Every status, in code order.
    pub const ALL: [Status; 3] = [Status::Converged, Status::NotConverged, Status::Invalid];

    /// The name used in JSON (`converged`, `not_converged`, `invalid`).
    pub fn name(self) -> &'static str {
        match self {
            Status::Converged => "converged",
            Status::NotConverged => "not_converged",
            Status::Invalid => "invalid",
        }
    }
}

/// One entry's result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    /// Converged, not converged or invalid.
    pub status: Status,
    /// Stable equilibrium (false unless converged).
    pub stable: bool,
    /// Warm-started from the previous entry.
    pub warm: bool,
    /// The warm start landed far from the previous entry's shape (a snap).
    pub snapped: bool,
    /// Endpoint: chain A's tip (m); NaN unless converged.
    pub endpoint_m: [f64; 2],
    /// Endpoint plate angle (rad); NaN unless converged.
    pub endpoint_angle_rad: f64,
    /// Smallest bending radius of the tubes (m); NaN unless converged.
    pub min_bend_radius_m: f64,
}

impl Default for Outcome {
    /// An entry not solved: invalid, NaN numbers.
    fn default() -> Self {
        Outcome {
            status: Status::Invalid,
            stable: false,
            warm: false,
            snapped: false,
            endpoint_m: [f64::NAN; 2],
            endpoint_angle_rad: f64::NAN,
            min_bend_radius_m: f64::NAN,
        }
    }
}

/// Why an entry has no equilibrium.
#[derive(Clone, Debug, PartialEq)]
pub struct Failure {
    /// The entry's index in the batch.
    pub index: usize,
    /// Its status ([`Status::Invalid`] or [`Status::NotConverged`]).
    pub status: Status,
    /// One line: the input error or the solver's message.
    pub reason: String,
}

/// Solves every entry of `query` into `out` (one outcome per entry, in
/// order) and returns the failed entries' reasons, in index order.
///
/// # Errors
/// Arrays of different lengths (`out` included), an invalid `robot` or a
/// negative or NaN `warm_step_m`; entries never fail the batch.
pub fn solve(
    robot: &Robot,
    query: &Query,
    options: &BatchOptions,
    out: &mut [Outcome],
) -> Result<Vec<Failure>, InputError> {
    let n = query.len()?;
    if out.len() != n {
        return Err(InputError::Invalid {
            field: "outcomes".into(),
            value: format!("{} entries", out.len()),
            allowed: format!("as many entries as la_m ({n})"),
        });
    }
    robot.validate()?;
    let step = options.warm_step_m;
    if !(step >= 0.0) {
        return Err(InputError::invalid("warm_step_m", step, "a step in m, at least 0 (0: every entry cold)"));
    }
    let failures: Vec<Vec<Failure>> = out
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(c, chunk)| solve_chunk(robot, query, c * CHUNK, step, chunk))
        .collect();
    Ok(failures.into_iter().flatten().collect())
}

/// The robot an entry is solved with: `robot` at the entry's base angle.
struct Variant {
    angle_deg: Option<f64>,
    robot: Result<Robot, InputError>,
}

/// Solves entries `start..start + out.len()`, warm-starting along them.
fn solve_chunk(robot: &Robot, query: &Query, start: usize, step: f64, out: &mut [Outcome]) -> Vec<Failure> {
    let mut failures = Vec::new();
    let mut ws: Option<Scratch> = None;
    // A batch has no deadline of its own: each entry is bounded by the solver's iteration limit.
    let solver = Solver::default();
    let mut variant = Variant { angle_deg: None, robot: Ok(robot.clone()) };
    // The last converged entry: its lengths, base angle and state.
    let mut previous: Option<([f64; 2], Option<f64>, Seed)> = None;
    for (k, slot) in out.iter_mut().enumerate() {
        let i = start + k;
        let (la, lb) = (query.la_m[i], query.lb_m[i]);
        let angle = query.base_angle_deg.map(|a| a[i]);
        if angle.map(f64::to_bits) != variant.angle_deg.map(f64::to_bits) {
            let r = match angle {
                Some(a) => robot
                    .with_base_angle(a)
                    .map_err(|_| InputError::invalid("base_angle_deg", a, "an angle in deg from -360 to 360")),
                None => Ok(robot.clone()),
            };
            variant = Variant { angle_deg: angle, robot: r };
        }
        let built = match &variant.robot {
            Ok(r) => r.body(la, lb).map(|b| (r, b)),
            Err(e) => Err(e.clone()),
        };
        let (robot, body) = match built {
            Ok(pair) => pair,
            Err(e) => {
                *slot = Outcome::default();
                failures.push(Failure { index: i, status: Status::Invalid, reason: e.to_string() });
                continue;
            }
        };
        let seed = previous.as_ref().filter(|(lengths, a, _)| {
            step > 0.0
                && a.map(f64::to_bits) == angle.map(f64::to_bits)
                && (lengths[0] - la).abs() <= step
                && (lengths[1] - lb).abs() <= step
        });
        let warm = seed.is_some();
        let solved = solve_body(robot, body, seed.map(|(_, _, s)| s), &solver, &mut ws);
        let p = solved.point;
        match p.failure {
            None => {
                *slot = Outcome {
                    status: Status::Converged,
                    stable: p.stable,
                    warm,
                    snapped: p.snapped,
                    endpoint_m: p.endpoint_m,
                    endpoint_angle_rad: p.endpoint_angle_rad,
                    min_bend_radius_m: p.min_bend_radius_m,
                };
                previous = solved.body.map(|s| ([la, lb], angle, s));
            }
            Some(reason) => {
                *slot = Outcome { status: Status::NotConverged, warm, ..Outcome::default() };
                failures.push(Failure { index: i, status: Status::NotConverged, reason });
            }
        }
    }
    failures
}

/// Solves a whole batch into a new vector of outcomes (see [`solve`]).
pub fn solve_vec(
    robot: &Robot,
    query: &Query,
    options: &BatchOptions,
) -> Result<(Vec<Outcome>, Vec<Failure>), InputError> {
    let mut out = vec![Outcome::default(); query.len()?];
    let failures = solve(robot, query, options, &mut out)?;
    Ok((out, failures))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_codes_follow_their_order() {
        for (code, s) in Status::ALL.iter().enumerate() {
            assert_eq!(*s as usize, code);
        }
    }
}
