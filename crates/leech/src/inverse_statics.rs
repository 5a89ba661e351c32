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
//! by Levenberg-Marquardt on the two lengths within the box
//! ([`crate::least_squares`]; angles compared modulo 2 pi). Each evaluation
//! is a warm-started static solve from the current iterate's state (the tubes
//! fed by the step), and the Jacobian `de/dL` is taken by central differences
//! of warm solves (`h = 1e-6` m; solves converge to 1e-11). It starts
//! from the nearest points of a map of the workspace computed once with
//! default solves (in parallel).
//!
//! The answer is checked with the default cold solve at the lengths found
//! (the equilibrium a fresh `leech shape` gives): the target counts as
//! reached only if that endpoint is within `tolerance_m` (and the angle
//! within `angle_tolerance_rad`); otherwise it is unreachable and the nearest
//! endpoint found is reported with its lengths. A false "reached" is not
//! possible.
//!
//! Every answer is reproducible: its endpoint is the fresh solve's at its
//! lengths, never a fed one. Where the fresh solve at the best lengths fails,
//! or lands farther from the target than the nearest map point (itself a
//! fresh solve), the nearest map point is the answer.
//!
//! The [`Deadline`] given to [`Reacher::new`] bounds the map and every
//! [`Reacher::reach`]: both check it at each solve and return [`Stopped`]
//! (how many map points or descents were done) when it runs out.

use std::sync::atomic::{AtomicUsize, Ordering};

use crate::body::Body;
use crate::budget::{Deadline, Stopped};
use crate::error::{InputError, JobError};
use crate::geom::angle_difference;
use crate::least_squares::{central_differences, levenberg_marquardt, LeastSquares, Options, Scaling};
use crate::robot::Robot;
use crate::statics::{Scratch, Solver, SolverOptions};
use crate::sweep::{Grid, Seed};
use rayon::prelude::*;

/// Weight of the angle error in the cost (m/rad).
pub const ANGLE_WEIGHT_M_PER_RAD: f64 = 0.05;
const FD_STEP_M: f64 = 1e-6;
const MAX_ITERATIONS: usize = 100;
const STARTS: usize = 32;
/// Largest map the reacher builds (a 10 mm grid over 0.05..0.3 m has 676).
pub const MAX_MAP_POINTS: usize = 40_000;

/// Why there is no reacher: bad robot or range, or stopped by its deadline.
pub type ReachError = JobError;

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
    /// The default solver bounded by the reacher's deadline: every solve,
    /// warm or fresh, is `leech shape`'s.
    solver: Solver,
}

/// One evaluated iterate.
#[derive(Clone)]
struct Iterate {
    lengths: [f64; 2],
    state: Seed,
    endpoint: [f64; 2],
    angle: f64,
}

/// One descent as a least-squares problem: every evaluation is a warm solve
/// fed from the current iterate, which moves with each accepted step.
struct Descent<'a> {
    reacher: &'a Reacher,
    target: [f64; 2],
    angle: Option<f64>,
    cold: bool,
    solves: &'a mut usize,
    current: Iterate,
    /// The last trial evaluated, kept until the minimizer accepts or rejects it.
    trial: Option<Iterate>,
}

impl Descent<'_> {
    fn solve(&mut self, x: &[f64]) -> Option<Iterate> {
        self.reacher.evaluate([x[0], x[1]], &self.current.state, self.cold, self.solves)
    }

    /// The residual rows of an iterate: the angle row only when an angle is asked.
    fn residual_of(&self, it: &Iterate, r: &mut [f64]) {
        let full = self.reacher.residual(it.endpoint, it.angle, self.target, self.angle);
        r.copy_from_slice(&full[..r.len()]);
    }
}

impl LeastSquares for Descent<'_> {
    /// A static solve failed: the descent needs to know that, not why.
    type Error = ();

    fn rows(&self) -> usize {
        2 + usize::from(self.angle.is_some())
    }

    /// The start is already solved: a map point or a cold solve.
    fn start(&mut self, _: &[f64], r: &mut [f64]) -> Result<(), ()> {
        self.residual_of(&self.current, r);
        Ok(())
    }

    fn residual(&mut self, x: &[f64], r: &mut [f64]) -> Result<(), ()> {
        let it = self.solve(x).ok_or(())?;
        self.residual_of(&it, r);
        self.trial = Some(it);
        Ok(())
    }

    /// Central differences (one-sided at the box): near-singular maps have
    /// long shallow valleys where a forward difference's error would steer
    /// the step.
    fn jacobian(&mut self, x: &[f64], r: &[f64], jac: &mut [f64]) -> Result<(), ()> {
        let mut scratch = [0.0; 3];
        let bounds = [self.reacher.range; 2];
        central_differences(x, FD_STEP_M, &bounds, jac, &mut scratch[..r.len()], |y, out| {
            let it = self.solve(y).ok_or(())?;
            self.residual_of(&it, out);
            Ok(())
        })
    }

    fn accept(&mut self) {
        if let Some(it) = self.trial.take() {
            self.current = it;
        }
    }
}

impl Reacher {
    /// Maps the workspace of `robot` over `grid` (both tubes) with default
    /// solves, within `deadline` (which also bounds every later
    /// [`reach`](Self::reach)). Lengths stay within the grid's range.
    ///
    /// ```
    /// use leech::budget::Deadline;
    /// use leech::prelude::*;
    /// use leech::inverse_statics::{Reacher, ReachStatus};
    /// use leech::sweep::Grid;
    /// let grid = Grid::new(0.05, 0.3, 0.025).unwrap();
    /// let reacher = Reacher::new(&Robot::builtin(), grid, Deadline::none()).unwrap();
    /// let answer = reacher.reach([0.12, 0.15], None).unwrap();
    /// assert_eq!(answer.status, ReachStatus::Reached);
    /// assert!(answer.error_m < 1e-6);
    /// ```
    pub fn new(robot: &Robot, grid: Grid, deadline: Deadline) -> Result<Reacher, ReachError> {
        robot.validate()?;
        let values = grid.values();
        robot.check_tube_length("lengths range min", grid.min)?;
        robot.check_tube_length("lengths range max", grid.max)?;
        if values.len() * values.len() > MAX_MAP_POINTS {
            return Err(InputError::invalid(
                "lengths range step",
                grid.step,
                format!("a step giving at most {MAX_MAP_POINTS} map points"),
            )
            .into());
        }
        let solver = Solver::new(SolverOptions { deadline: deadline.clone(), ..SolverOptions::default() });
        // Fresh (default-path) solves, the same equilibria the answer is
        // checked against: where equilibria are not unique the starts then lie
        // on the right branch.
        let pairs: Vec<(f64, f64)> = values.iter().flat_map(|&a| values.iter().map(move |&b| (a, b))).collect();
        let done = AtomicUsize::new(0);
        let map = pairs
            .par_iter()
            .filter_map(|&(la, lb)| {
                if deadline.expired() {
                    return None;
                }
                let body = robot.body(la, lb).ok()?;
                let eq = body.solve(&solver).ok();
                done.fetch_add(1, Ordering::Relaxed);
                let eq = eq?;
                let (e, a) = (body.endpoint(&eq.q), body.endpoint_angle(&eq.q));
                Some(((body, eq.q), e, a))
            })
            .collect::<Vec<_>>();
        // A solve the deadline stopped is missing from the map: not trusted.
        deadline.guard(done.load(Ordering::Relaxed), pairs.len(), "map points")?;
        if map.is_empty() {
            return Err(InputError::invalid("lengths range", grid.min, "a range where the body can be solved").into());
        }
        Ok(Reacher {
            robot: robot.clone(),
            range: [grid.min, grid.max],
            map,
            tolerance: ReachTolerance::default(),
            solver,
        })
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
            body.solve(&self.solver).ok()?
        } else {
            let start = body.carry_over(&from.0, &from.1);
            let mut ws = Scratch::for_system(&body);
            body.solve_from(&self.solver, &start, &mut ws).ok()?
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

    /// The Levenberg-Marquardt settings of a descent: both unknowns are
    /// lengths (m), so one damping scale serves both; map starts are close,
    /// so the damping starts mild. A descent stops only when the endpoint is
    /// on the target far below the tolerance or when no step helps: the
    /// callers judge the result, and try other starts.
    fn options(&self) -> Options {
        let close = 1e-3 * self.tolerance.tolerance_m.min(1e-6);
        Options {
            initial_damping: 1e-6,
            damping_decrease: 0.2,
            damping_increase: 10.0,
            min_damping: 1e-12,
            max_damping: 1e16,
            scaling: Scaling::Uniform,
            max_iterations: MAX_ITERATIONS,
            max_trials: 12,
            min_gain_ratio: 0.0,
            cost_tolerance: 0.5 * close * close,
            relative_decrease_tolerance: 0.0,
            step_tolerance: 0.0,
            gradient_tolerance: 0.0,
            jacobian_at_solution: false,
        }
    }

    /// Levenberg-Marquardt from one start; returns the best iterate.
    fn descend(&self, start: Iterate, target: [f64; 2], angle: Option<f64>, cold: bool, solves: &mut usize) -> Iterate {
        let x0 = start.lengths;
        let mut descent = Descent { reacher: self, target, angle, cold, solves, current: start, trial: None };
        // Whatever the stop (on target, no descent, a failed solve), the
        // current iterate is the best one reached.
        levenberg_marquardt(&mut descent, &x0, &[self.range; 2], &self.options());
        descent.current
    }

    /// Tube lengths putting the endpoint on `target` (m), and the plate at
    /// `angle` (rad) if given. Never a false "reached", and reproducible by a
    /// fresh solve: see the module doc.
    pub fn reach(&self, target: [f64; 2], angle: Option<f64>) -> Result<Reach, Stopped> {
        let deadline = &self.solver.options.deadline;
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
        let map_point = |i: usize| {
            let (state, endpoint, a) = &self.map[i];
            Iterate {
                lengths: [state.0.chain_a().tube_length(), state.0.chain_b().tube_length()],
                state: state.clone(),
                endpoint: *endpoint,
                angle: *a,
            }
        };
        let mut best: Option<Iterate> = None;
        // With an angle the weighted cost can have local minima off the
        // solution; the position alone has none nearby, so its solutions
        // (one per branch of the map) are tried as well, judged by the full cost.
        let modes: &[Option<f64>] = if angle.is_some() { &[angle, None] } else { &[None] };
        let (mut descents, most) = (0, modes.len() * STARTS.min(order.len()));
        'search: for mode in modes {
            for &i in order.iter().take(STARTS) {
                deadline.guard(descents, most, "descents")?;
                let found = self.descend(map_point(i), target, *mode, false, &mut solves);
                descents += 1;
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
        let cost = |it: &Iterate| map_cost(it.endpoint, it.angle);
        if cost(&best).sqrt() >= 1e-3 * self.tolerance.tolerance_m || !self.fresh_agrees(&best, &mut solves) {
            if let Some(start) = self.evaluate(best.lengths, &best.state, true, &mut solves) {
                let found = self.descend(start, target, angle, true, &mut solves);
                if angle.is_some() && cost(&found).sqrt() >= 1e-3 * self.tolerance.tolerance_m {
                    let position = self.descend(found.clone(), target, None, true, &mut solves);
                    best = if cost(&position) < cost(&found) { position } else { found };
                } else {
                    best = found;
                }
            }
        }
        // The answer is a fresh default solve: at the lengths found, or the
        // nearest map point's (a fresh solve too) when that one fails or
        // lands farther away.
        let fresh = self.evaluate(best.lengths, &best.state, true, &mut solves);
        // A solve the deadline stopped is no verdict.
        deadline.guard(descents, most, "descents")?;
        let nearest = map_point(order[0]);
        let answer = match fresh {
            Some(fresh) if cost(&fresh) <= cost(&nearest) => fresh,
            _ => nearest,
        };
        let error_m = (answer.endpoint[0] - target[0]).hypot(answer.endpoint[1] - target[1]);
        let angle_error_rad = angle.map(|a| angle_difference(answer.angle, a).abs());
        let reached = error_m <= self.tolerance.tolerance_m
            && angle_error_rad.is_none_or(|e| e <= self.tolerance.angle_tolerance_rad);
        Ok(Reach {
            status: if reached { ReachStatus::Reached } else { ReachStatus::Unreachable },
            lengths_m: answer.lengths,
            endpoint_m: answer.endpoint,
            endpoint_angle_rad: answer.angle,
            error_m,
            angle_error_rad,
            solves,
        })
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
