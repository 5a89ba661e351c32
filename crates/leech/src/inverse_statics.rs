//! Inverse statics: the tube lengths whose equilibrium puts the endpoint on a
//! target, the problem the paper left to the operator.
//!
//! With `e(L)` the equilibrium endpoint (m) and `phi(L)` the plate angle (rad)
//! for tube lengths `L = (LA, LB)` in the allowed box, [`Reacher::reach`]
//! minimizes
//!
//! ```text
//! |e(L) - target|^2  (+ (w (phi(L) - angle))^2 when an angle is asked, w = 0.05 m/rad)
//! ```
//!
//! by Levenberg-Marquardt on the two lengths, projected on the box (angles
//! compared modulo 2 pi). Each evaluation is a warm-started static solve from
//! the previous iterate's state (the tubes fed by the step), and the Jacobian
//! `de/dL` is taken by central differences of warm solves (`h = 1e-6` m;
//! solves converge to 1e-11). It starts
//! from the nearest points of a map of the workspace computed once with
//! default solves (in parallel).
//!
//! The answer is checked with the default cold solve at the lengths found
//! (the equilibrium a fresh `leech shape` gives): the target counts as
//! reached only if that endpoint is within `tolerance_m` (and the angle
//! within `angle_tolerance_rad`); otherwise it is unreachable and the nearest
//! endpoint found is reported with its lengths. A false "reached" is not
//! possible.

use crate::body::Body;
use crate::error::InputError;
use crate::robot::Robot;
use crate::statics::{Scratch, Solver};
use crate::sweep::{Grid, Seed};
use rayon::prelude::*;

/// Weight of the angle error in the cost (m/rad).
pub const ANGLE_WEIGHT_M_PER_RAD: f64 = 0.05;
const FD_STEP_M: f64 = 1e-6;
const MAX_ITERATIONS: usize = 100;
const STARTS: usize = 32;
/// Largest map the reacher builds (a 10 mm grid over 0.05..0.3 m has 676).
pub const MAX_MAP_POINTS: usize = 40_000;

/// Whether the target was hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ReachStatus {
    /// The equilibrium endpoint is on the target (and angle).
    Reached,
    /// No allowed lengths put it there; the nearest point found is given.
    Unreachable,
}

/// The answer of an inverse solve.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Reach {
    /// Reached or unreachable.
    pub status: ReachStatus,
    /// Tube lengths LA, LB (m): the solution, or the nearest point's.
    pub lengths_m: [f64; 2],
    /// Equilibrium endpoint at those lengths, from a default cold solve (m).
    pub endpoint_m: [f64; 2],
    /// Plate angle there (rad).
    pub endpoint_angle_rad: f64,
    /// Distance from the target (m).
    pub error_m: f64,
    /// Angle error (rad), when an angle was asked.
    pub angle_error_rad: Option<f64>,
    /// Static solves spent.
    pub solves: usize,
}

/// Tolerances of [`Reacher::reach`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReachTolerance {
    /// Largest endpoint error that counts as reached (m).
    pub tolerance_m: f64,
    /// Largest angle error that counts as reached (rad).
    pub angle_tolerance_rad: f64,
}

impl Default for ReachTolerance {
    fn default() -> Self {
        ReachTolerance { tolerance_m: 1e-6, angle_tolerance_rad: 1e-4 }
    }
}

/// An inverse-statics solver for one robot: the workspace map and scratch.
pub struct Reacher {
    robot: Robot,
    range: [f64; 2],
    map: Vec<(Seed, [f64; 2], f64)>,
    tolerance: ReachTolerance,
}

/// One evaluated iterate.
#[derive(Clone)]
struct Iterate {
    lengths: [f64; 2],
    state: Seed,
    endpoint: [f64; 2],
    angle: f64,
}

impl Reacher {
    /// Maps the workspace of `robot` over `grid` (both tubes) with default
    /// solves. Lengths stay within the grid's range.
    ///
    /// ```
    /// use leech::prelude::*;
    /// use leech::inverse_statics::{Reacher, ReachStatus};
    /// use leech::sweep::Grid;
    /// let reacher = Reacher::new(&Robot::builtin(), Grid::new(0.05, 0.3, 0.025).unwrap()).unwrap();
    /// let answer = reacher.reach([0.12, 0.15], None);
    /// assert_eq!(answer.status, ReachStatus::Reached);
    /// assert!(answer.error_m < 1e-6);
    /// ```
    pub fn new(robot: &Robot, grid: Grid) -> Result<Reacher, InputError> {
        robot.validate()?;
        let values = grid.values();
        robot.check_tube_length("lengths range min", grid.min)?;
        robot.check_tube_length("lengths range max", grid.max)?;
        if values.len() * values.len() > MAX_MAP_POINTS {
            return Err(InputError::invalid(
                "lengths range step",
                grid.step,
                format!("a step giving at most {MAX_MAP_POINTS} map points"),
            ));
        }
        // Fresh (default-path) solves, the same equilibria the answer is
        // checked against: where equilibria are not unique the starts then lie
        // on the right branch.
        let pairs: Vec<(f64, f64)> = values.iter().flat_map(|&a| values.iter().map(move |&b| (a, b))).collect();
        let map = pairs
            .par_iter()
            .filter_map(|&(la, lb)| {
                let body = robot.body(la, lb).ok()?;
                let eq = body.solve(&Solver::default()).ok()?;
                let (e, a) = (body.endpoint(&eq.q), body.endpoint_angle(&eq.q));
                Some(((body, eq.q), e, a))
            })
            .collect::<Vec<_>>();
        if map.is_empty() {
            return Err(InputError::invalid("lengths range", grid.min, "a range where the body can be solved"));
        }
        Ok(Reacher { robot: robot.clone(), range: [grid.min, grid.max], map, tolerance: ReachTolerance::default() })
    }

    /// Changes the tolerances.
    pub fn with_tolerance(mut self, tolerance: ReachTolerance) -> Reacher {
        self.tolerance = tolerance;
        self
    }

    /// The allowed range of tube lengths (m).
    pub fn range(&self) -> [f64; 2] {
        self.range
    }

    fn residual(&self, endpoint: [f64; 2], angle: f64, target: [f64; 2], target_angle: Option<f64>) -> [f64; 3] {
        [
            endpoint[0] - target[0],
            endpoint[1] - target[1],
            target_angle.map_or(0.0, |a| ANGLE_WEIGHT_M_PER_RAD * angle_difference(angle, a)),
        ]
    }

    /// The equilibrium at `lengths`: warm-started from `from` (the tubes fed
    /// from the previous iterate), or the default cold solve when `cold`.
    fn evaluate(&self, lengths: [f64; 2], from: &Seed, cold: bool, solves: &mut usize) -> Option<Iterate> {
        *solves += 1;
        let body: Body = self.robot.body(lengths[0], lengths[1]).ok()?;
        let eq = if cold {
            body.solve(&Solver::default()).ok()?
        } else {
            let start = body.carry_over(&from.0, &from.1);
            let mut ws = Scratch::for_system(&body);
            body.solve_from(&Solver::default(), &start, &mut ws).ok()?
        };
        Some(Iterate {
            lengths,
            endpoint: body.endpoint(&eq.q),
            angle: body.endpoint_angle(&eq.q),
            state: (body, eq.q),
        })
    }

    /// Whether a fresh default solve at the iterate's lengths lands on its endpoint.
    fn fresh_agrees(&self, it: &Iterate, solves: &mut usize) -> bool {
        self.evaluate(it.lengths, &it.state, true, solves)
            .is_some_and(|fresh| (fresh.endpoint[0] - it.endpoint[0]).hypot(fresh.endpoint[1] - it.endpoint[1]) < 1e-9)
    }

    fn clamp(&self, x: f64) -> f64 {
        x.clamp(self.range[0], self.range[1])
    }

    /// Levenberg-Marquardt from one start; returns the best iterate.
    fn descend(&self, start: Iterate, target: [f64; 2], angle: Option<f64>, cold: bool, solves: &mut usize) -> Iterate {
        let cost = |it: &Iterate| {
            let r = self.residual(it.endpoint, it.angle, target, angle);
            r.iter().map(|x| x * x).sum::<f64>()
        };
        let mut best = start;
        let mut mu = 1e-6;
        for _ in 0..MAX_ITERATIONS {
            let r = self.residual(best.endpoint, best.angle, target, angle);
            if r.iter().map(|x| x * x).sum::<f64>().sqrt() < 1e-3 * self.tolerance.tolerance_m.min(1e-6) {
                break;
            }
            // Central differences (one-sided at the box): near-singular maps
            // have long shallow valleys where a forward difference's error
            // would steer the step.
            let mut jac = [[0.0; 2]; 3];
            for k in 0..2 {
                let (mut up, mut down) = (best.lengths, best.lengths);
                up[k] = (up[k] + FD_STEP_M).min(self.range[1]);
                down[k] = (down[k] - FD_STEP_M).max(self.range[0]);
                let Some(a) = self.evaluate(up, &best.state, cold, solves) else { return best };
                let Some(b) = self.evaluate(down, &best.state, cold, solves) else { return best };
                let (ra, rb) = (
                    self.residual(a.endpoint, a.angle, target, angle),
                    self.residual(b.endpoint, b.angle, target, angle),
                );
                for row in 0..3 {
                    jac[row][k] = (ra[row] - rb[row]) / (up[k] - down[k]);
                }
            }
            let mut jtj = [[0.0; 2]; 2];
            let mut jtr = [0.0; 2];
            for row in 0..3 {
                for a in 0..2 {
                    jtr[a] += jac[row][a] * r[row];
                    for b in 0..2 {
                        jtj[a][b] += jac[row][a] * jac[row][b];
                    }
                }
            }
            let scale = jtj[0][0].max(jtj[1][1]).max(1e-300);
            let mut improved = false;
            for _ in 0..12 {
                let (a, b, c) = (jtj[0][0] + mu * scale, jtj[0][1], jtj[1][1] + mu * scale);
                let det = a * c - b * b;
                let step = [-(c * jtr[0] - b * jtr[1]) / det, -(a * jtr[1] - b * jtr[0]) / det];
                let lengths = [self.clamp(best.lengths[0] + step[0]), self.clamp(best.lengths[1] + step[1])];
                if lengths == best.lengths {
                    break;
                }
                if let Some(it) = self.evaluate(lengths, &best.state, cold, solves) {
                    if cost(&it) < cost(&best) {
                        best = it;
                        mu = (mu * 0.2).max(1e-12);
                        improved = true;
                        break;
                    }
                }
                mu *= 10.0;
            }
            if !improved {
                break;
            }
        }
        best
    }

    /// Tube lengths putting the endpoint on `target` (m), and the plate at
    /// `angle` (rad) if given. Never a false "reached": see the module doc.
    pub fn reach(&self, target: [f64; 2], angle: Option<f64>) -> Reach {
        let mut solves = 0;
        let map_cost = |e: [f64; 2], a: f64| {
            let r = self.residual(e, a, target, angle);
            r.iter().map(|x| x * x).sum::<f64>()
        };
        let mut order: Vec<usize> = (0..self.map.len()).collect();
        order.sort_by(|&i, &j| {
            let (a, b) = (&self.map[i], &self.map[j]);
            map_cost(a.1, a.2).total_cmp(&map_cost(b.1, b.2))
        });
        let mut best: Option<Iterate> = None;
        // With an angle the weighted cost can have local minima off the
        // solution; the position alone has none nearby, so its solutions
        // (one per branch of the map) are tried as well, judged by the full cost.
        let modes: &[Option<f64>] = if angle.is_some() { &[angle, None] } else { &[None] };
        'search: for mode in modes {
            for &i in order.iter().take(STARTS) {
                let (state, endpoint, a) = &self.map[i];
                let start = Iterate {
                    lengths: [state.0.chain_a().tube_length(), state.0.chain_b().tube_length()],
                    state: state.clone(),
                    endpoint: *endpoint,
                    angle: *a,
                };
                let found = self.descend(start, target, *mode, false, &mut solves);
                let better =
                    best.as_ref().is_none_or(|b| map_cost(found.endpoint, found.angle) < map_cost(b.endpoint, b.angle));
                if better {
                    best = Some(found);
                }
                let hit = best
                    .as_ref()
                    .is_some_and(|b| map_cost(b.endpoint, b.angle).sqrt() < 1e-3 * self.tolerance.tolerance_m);
                if hit {
                    break 'search;
                }
            }
        }
        let mut best = best.expect("the map is not empty");
        // Where equilibria are not unique the fed (warm) path and a fresh solve
        // can disagree; the answer must hold for a fresh solve, so finish
        // with fresh solves from the best point when the warm one missed.
        let fresh_cost = |it: &Iterate| map_cost(it.endpoint, it.angle);
        if fresh_cost(&best).sqrt() >= 1e-3 * self.tolerance.tolerance_m || !self.fresh_agrees(&best, &mut solves) {
            if let Some(start) = self.evaluate(best.lengths, &best.state, true, &mut solves) {
                let found = self.descend(start, target, angle, true, &mut solves);
                if angle.is_some() && fresh_cost(&found).sqrt() >= 1e-3 * self.tolerance.tolerance_m {
                    let position = self.descend(found.clone(), target, None, true, &mut solves);
                    best = if fresh_cost(&position) < fresh_cost(&found) { position } else { found };
                } else {
                    best = found;
                }
            }
        }
        // The check: a fresh default solve at the lengths found.
        solves += 1;
        let checked = self
            .robot
            .body(best.lengths[0], best.lengths[1])
            .ok()
            .and_then(|b| b.solve(&Solver::default()).ok().map(|eq| (b.endpoint(&eq.q), b.endpoint_angle(&eq.q))));
        // Without the check there is no answer to vouch for: unreachable.
        let verified = checked.is_some();
        let (endpoint, endpoint_angle) = checked.unwrap_or((best.endpoint, best.angle));
        let error_m = (endpoint[0] - target[0]).hypot(endpoint[1] - target[1]);
        let angle_error_rad = angle.map(|a| angle_difference(endpoint_angle, a).abs());
        let reached = verified
            && error_m <= self.tolerance.tolerance_m
            && angle_error_rad.is_none_or(|e| e <= self.tolerance.angle_tolerance_rad);
        Reach {
            status: if reached { ReachStatus::Reached } else { ReachStatus::Unreachable },
            lengths_m: best.lengths,
            endpoint_m: endpoint,
            endpoint_angle_rad: endpoint_angle,
            error_m,
            angle_error_rad,
            solves,
        }
    }
}

/// `a - b` wrapped to `(-pi, pi]`: plate angles are compared as directions.
fn angle_difference(a: f64, b: f64) -> f64 {
    let tau = 2.0 * std::f64::consts::PI;
    let d = (a - b).rem_euclid(tau);
    if d > std::f64::consts::PI {
        d - tau
    } else {
        d
    }
}

/// Checks a target coordinate.
pub fn check_target(field: &str, value: f64) -> Result<f64, InputError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(InputError::invalid(field, value, "a finite number in m"))
    }
}
