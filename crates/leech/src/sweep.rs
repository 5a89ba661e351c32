//! Workspace sweeps: the endpoint over a grid of tube lengths, for one or
//! several shape parameters and both models, with reach metrics.
//!
//! # Actuation path
//!
//! Equilibria are not unique, so the sweep follows how the robot would get
//! there: the tubes are fed from grid point to grid point with gravity on.
//! The corner `(L0, L0)` is a default cold solve ([`Body::solve`]); the first
//! column `(L_i, L0)` is walked upwards in `LA`, each point warm-started
//! ([`Body::solve_from`]) from its neighbour's state carried over
//! ([`Body::carry_over`]); then every row walks `LB` upwards from its first
//! column, rows in parallel. Each point costs one or two Newton steps. A warm
//! start that lands far from its neighbour (more than `SNAP_RAD` on some
//! angle) is a snap on the actuation path and is flagged `snapped`; if a warm
//! start fails, the point is retried cold and, failing that, listed as a
//! failure (never dropped).
//!
//! # History dependence
//!
//! Where the body has several equilibria, the fed path and a fresh solve
//! (the default cold solve `leech shape --lengths LA,LB` makes) can land on
//! different ones. Every point says so: `fresh_difference_m` is the distance
//! (m) between its endpoint and the fresh solve's, 0 where they agree to
//! [`FRESH_TOLERANCE_M`], infinite where the fresh solve fails, NaN for a
//! failed point. Points solved cold (the corner, cold retries) are fresh by
//! construction; the others are solved fresh again after the walks of every
//! shape parameter, grid points in parallel.
//!
//! A fresh solve has two stages ([`Body::feed_in`], [`Body::load_in`]): the
//! tubes fed from equal lengths at `g = 0`, then gravity raised from 0 to
//! `g`. The shape parameters of one sweep differ only in the joint
//! stiffness `k` (`Pi = k / (m g l)`), and at `g = 0` the potential is
//! `k V(q)`: the fed shape is the same for every `k`, the weld's multipliers
//! (forces) proportional to it. So each grid point is fed once, with the
//! first shape parameter's robot, and that state, its multipliers scaled by
//! the ratio of the stiffnesses ([`crate::body::Fed::for_stiffness`]), is
//! the fed state of each robot.
//!
//! Nor is the load stage repeated: with gravity on, the potential is
//! `k V(q) + g U(q)`, so a robot of stiffness `k` at full gravity has the
//! equilibria of the softest robot (`k_min`) at the gravity fraction
//! `k_min / k`. The softest robot's load is followed once and lands on each
//! of those fractions on its way to full gravity ([`Body::load_through`]);
//! only a robot whose fraction it did not reach (the softest failed first)
//! is loaded by itself. Only the steps' sizes differ from each robot's own
//! default solve: the states agree to the tolerance where the path is
//! smooth, and past a fold each path settles from its own bracket of it. On
//! the paper's Fig. 12 grid (5 mm and 2 mm, Pi 300 to 10000), Pi 100 to 400,
//! Pi 500, 510, 520 and 5097, and Pi 200 and 20000 with `LA >= LB` (about
//! 140 000 points) every flag and count is the same as loading each robot
//! itself, and `fresh_difference_m` moves by at most 3.1e-12 m. The feed
//! costs the same at every Pi; the load grows as Pi falls (on the 5 mm grid,
//! one core: feed 0.16 s, each robot's own load 0.03 s at Pi 10000 to 0.67 s
//! at Pi 300, 1.3 s for the five; the shared load 0.68 s).
//!
//! # Time and size
//!
//! [`SweepOptions::deadline`] bounds the whole sweep: every solve checks it,
//! every worker stops at its next point, and the sweep returns
//! [`SweepError::Stopped`] (how many of its solves were done), never a partial
//! result. A sweep has at most [`MAX_POINTS`] points over all its models and
//! shape parameters (about 280 bytes each in memory).
//!
//! # Metrics (for each model and shape parameter)
//!
//! Over the points that converged and are feasible (no tube bent tighter than
//! `tube.min_bend_radius_m`): the highest and lowest endpoint, the farthest
//! horizontal reach (largest `|x|`), and the reachable area (m^2): neighbouring
//! grid points form triangles in the endpoint plane, which are rasterized onto
//! a grid of `AREA_CELL_M` cells; the area is the number of cells covered times
//! the cell area (overlaps count once). Triangles with a corner that failed,
//! is infeasible or unstable are left out, and so are those whose longest
//! edge exceeds `AREA_EDGE_FACTOR` times the median one (a jump between
//! neighbours, not a region the endpoint sweeps).

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::body::Body;
use crate::budget::Deadline;
use crate::constant_curvature::PlanarBody;
use crate::error::{positive, InputError, JobError};
use crate::robot::{Robot, MAX_LINKS};
use crate::statics::{Potential, Scratch, Solver, SolverOptions};

/// Most points of one sweep over all models and shape parameters: two full
/// grids of 2001 lengths (about 2.3 GB of points).
pub const MAX_POINTS: usize = 2 * 2001 * 2001;
/// A point whose endpoint is within this (m) of a fresh solve's agrees with it.
pub const FRESH_TOLERANCE_M: f64 = 1e-6;
/// A warm start moving some angle by more than this (rad) is a snap.
pub const SNAP_RAD: f64 = 0.5;
/// Raster cell for the reachable area (m).
pub const AREA_CELL_M: f64 = 0.002;
/// Triangles whose longest edge exceeds this multiple of the median one span
/// a jump between neighbours (a snap, or two actuation paths meeting) and are
/// not part of the reachable area.
pub const AREA_EDGE_FACTOR: f64 = 5.0;

/// Tube lengths `min, min + step, ..., max` (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Shortest tube length (m).
    pub min: f64,
    /// Longest tube length (m).
    pub max: f64,
    /// Step (m).
    pub step: f64,
}

impl Grid {
    /// A checked grid: `0 < min <= max`, `step > 0`, at most 2 001 values
    /// (4 million grid points).
    pub fn new(min: f64, max: f64, step: f64) -> Result<Grid, InputError> {
        let min = positive("lengths range min", min)?;
        let max = positive("lengths range max", max)?;
        let step = positive("lengths range step", step)?;
        if max < min {
            return Err(InputError::invalid(
                "lengths range max",
                max,
                format!("at least the min ({})", crate::error::Num(min)),
            ));
        }
        let count = ((max - min) / step).floor() + 1.0;
        if count > 2_001.0 {
            // Both tubes take every value: the grid has count^2 points.
            return Err(InputError::invalid("lengths range step", step, "a step giving at most 2001 lengths per tube"));
        }
        Ok(Grid { min, max, step })
    }

    /// Parses `MIN:MAX:STEP` (m).
    pub fn parse(text: &str) -> Result<Grid, InputError> {
        let parts: Vec<&str> = text.split(':').collect();
        let bad = || InputError::Invalid {
            field: "lengths range".into(),
            value: text.into(),
            allowed: "MIN:MAX:STEP in m, e.g. 0.05:0.3:0.005".into(),
        };
        let [a, b, c] = parts.as_slice() else { return Err(bad()) };
        let num = |s: &str| s.trim().parse::<f64>().map_err(|_| bad());
        Grid::new(num(a)?, num(b)?, num(c)?)
    }

    /// The lengths (m); the last is `max` when the step divides the range.
    pub fn values(&self) -> Vec<f64> {
        let count = ((self.max - self.min) / self.step + 1e-9).floor() as usize + 1;
        (0..count).map(|i| self.min + self.step * i as f64).collect()
    }
}

/// Which model a point belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Model {
    /// The two-chain model with gravity.
    TwoChain,
    /// The kinematic constant-curvature model.
    ConstantCurvature,
}

impl Model {
    /// The name used in CSV and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Model::TwoChain => "two-chain",
            Model::ConstantCurvature => "constant-curvature",
        }
    }
}

/// What to sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepOptions {
    /// The lengths, for both tubes.
    pub grid: Grid,
    /// Shape parameters to sweep (the robot's own when empty).
    pub shape_parameters: Vec<f64>,
    /// Models to evaluate.
    pub models: Vec<Model>,
    /// Only `LA >= LB` (the paper's Fig. 12: left tube longer).
    pub left_longer: bool,
    /// When the sweep stops (never, by default).
    pub deadline: Deadline,
}

/// Why a sweep gave no result: bad input, or stopped by its deadline.
pub type SweepError = JobError;

/// One grid point.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Point {
    /// Model.
    pub model: Model,
    /// Shape parameter (None for the constant-curvature model, which has none).
    pub shape_parameter: Option<f64>,
    /// Tube lengths LA, LB (m).
    pub lengths_m: [f64; 2],
    /// `None` when converged, else why it failed.
    pub failure: Option<String>,
    /// Stable equilibrium (always true for constant curvature).
    pub stable: bool,
    /// The warm start landed far from its neighbour's shape (a snap).
    pub snapped: bool,
    /// Smallest bending radius of the tubes (m).
    pub min_bend_radius_m: f64,
    /// Not bent tighter than the tube allows.
    pub feasible: bool,
    /// Endpoint (m); NaN for a failure.
    pub endpoint_m: [f64; 2],
    /// Endpoint plate angle (rad); NaN for a failure.
    pub endpoint_angle_rad: f64,
    /// Distance (m) from the endpoint a fresh default solve gives at these
    /// lengths: 0 when within [`FRESH_TOLERANCE_M`], infinite when the fresh
    /// solve fails, NaN for a failure (see the module doc).
    pub fresh_difference_m: f64,
}

/// An extreme endpoint and where it comes from.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Extreme {
    /// Endpoint (m).
    pub endpoint_m: [f64; 2],
    /// Tube lengths (m).
    pub lengths_m: [f64; 2],
}

/// A failed point.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Failure {
    /// Tube lengths (m).
    pub lengths_m: [f64; 2],
    /// The solver's message.
    pub reason: String,
}

/// Metrics of one model at one shape parameter.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Summary {
    /// Model.
    pub model: Model,
    /// Shape parameter (None for constant curvature).
    pub shape_parameter: Option<f64>,
    /// Grid points evaluated.
    pub points: usize,
    /// Points that did not converge, each listed.
    pub failures: Vec<Failure>,
    /// Points bent tighter than the tube allows.
    pub infeasible: usize,
    /// Points that converged to an unstable equilibrium.
    pub unstable: usize,
    /// Points where the actuation path snapped.
    pub snapped: usize,
    /// Converged points a fresh solve does not reproduce (history dependence).
    pub differ_from_fresh: usize,
    /// The largest finite `fresh_difference_m` (m).
    pub largest_fresh_difference_m: f64,
    /// Highest endpoint.
    pub highest: Option<Extreme>,
    /// Lowest endpoint.
    pub lowest: Option<Extreme>,
    /// Largest horizontal distance from the driving unit.
    pub farthest: Option<Extreme>,
    /// Reachable area (m^2), see the module doc.
    pub area_m2: f64,
}

/// A finished sweep.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Sweep {
    /// Every grid point of every model and shape parameter.
    pub points: Vec<Point>,
    /// Metrics per model and shape parameter.
    pub summaries: Vec<Summary>,
}

/// Number of grid points a sweep evaluates.
pub fn point_count(options: &SweepOptions) -> usize {
    let (per, pis) = per_model(options);
    options.models.iter().map(|m| if *m == Model::TwoChain { per * pis } else { per }).sum()
}

/// Work units of a sweep (for progress bars): a two-chain point counts twice
/// (its solve along the path and its fresh check), a constant-curvature one once.
pub fn work_count(options: &SweepOptions) -> usize {
    let (per, pis) = per_model(options);
    options.models.iter().map(|m| if *m == Model::TwoChain { 2 * per * pis } else { per }).sum()
}

/// Grid points per model and shape parameter, and the number of shape parameters.
fn per_model(options: &SweepOptions) -> (usize, usize) {
    let n = options.grid.values().len();
    let per = if options.left_longer { n * (n + 1) / 2 } else { n * n };
    (per, options.shape_parameters.len().max(1))
}

/// Runs a sweep. `progress` is called with the number of work units just
/// finished ([`work_count`]; from several threads).
pub fn sweep(robot: &Robot, options: &SweepOptions, progress: &(dyn Fn(usize) + Sync)) -> Result<Sweep, SweepError> {
    robot.validate()?;
    let total = point_count(options);
    if total > MAX_POINTS {
        let (per, _) = per_model(options);
        let most = (MAX_POINTS / per).saturating_sub(usize::from(options.models.contains(&Model::ConstantCurvature)));
        return Err(InputError::invalid(
            "shape parameters (count)",
            options.shape_parameters.len() as f64,
            format!("at most {MAX_POINTS} points in all (about 280 bytes each): {most} shape parameters on this grid"),
        )
        .into());
    }
    let values = options.grid.values();
    robot.check_tube_length("lengths range min", values[0])?;
    robot.check_tube_length("lengths range max", *values.last().expect("a grid has a value"))?;
    if values.last().copied().unwrap_or(0.0) / robot.tube.element_length_m > MAX_LINKS as f64 {
        return Err(InputError::invalid("lengths range max", options.grid.max, "fewer elements").into());
    }
    let pis: Vec<Option<f64>> = if options.shape_parameters.is_empty() {
        vec![None]
    } else {
        options.shape_parameters.iter().map(|p| Some(*p)).collect()
    };
    let solver = Solver::new(SolverOptions { deadline: options.deadline.clone(), ..SolverOptions::default() });
    let (work, done) = (work_count(options), AtomicUsize::new(0));
    let tick = |k: usize| {
        done.fetch_add(k, Ordering::Relaxed);
        progress(k);
    };
    // A solve the deadline stopped is a failed point: a block that ends past
    // the deadline is not trusted.
    let finished = || options.deadline.guard(done.load(Ordering::Relaxed), work, "solves (path and fresh check)");
    let mut points = Vec::new();
    let mut summaries = Vec::new();
    // Every shape parameter's walk, then their fresh checks together (they
    // share the feed, see the module doc).
    let uses = options.models.iter().filter(|m| **m == Model::TwoChain).count();
    let mut two_chain = if uses > 0 {
        let robots = pis
            .iter()
            .map(|pi| match pi {
                Some(p) => robot.with_shape_parameter(*p),
                None => Ok(robot.clone()),
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut walked: Vec<Vec<Point>> =
            robots.par_iter().map(|tuned| walk(tuned, &values, options.left_longer, &solver, &tick)).collect();
        finished()?;
        check_fresh(&robots, &mut walked, &solver, &tick);
        finished()?;
        for (tuned, pts) in robots.iter().zip(&mut walked) {
            pts.iter_mut().for_each(|p| p.shape_parameter = Some(tuned.shape_parameter()));
        }
        walked
    } else {
        Vec::new()
    };
    let mut used = 0;
    for model in &options.models {
        match model {
            Model::TwoChain => {
                used += 1;
                // The last listing takes the points; a model listed twice is reported twice.
                let blocks = if used == uses { std::mem::take(&mut two_chain) } else { two_chain.clone() };
                for pts in blocks {
                    let pi_value = pts.first().and_then(|p| p.shape_parameter);
                    summaries.push(summarize(Model::TwoChain, pi_value, &pts, &values, options.left_longer));
                    points.extend(pts);
                }
            }
            Model::ConstantCurvature => {
                let pts = constant_curvature_points(robot, &values, options.left_longer);
                tick(pts.len());
                summaries.push(summarize(Model::ConstantCurvature, None, &pts, &values, options.left_longer));
                points.extend(pts);
            }
        }
    }
    Ok(Sweep { points, summaries })
}

fn grid_pairs(n: usize, left_longer: bool) -> impl Iterator<Item = (usize, usize)> {
    (0..n).flat_map(move |i| (0..if left_longer { i + 1 } else { n }).map(move |j| (i, j)))
}

fn constant_curvature_points(robot: &Robot, values: &[f64], left_longer: bool) -> Vec<Point> {
    let cc = PlanarBody::of(robot);
    grid_pairs(values.len(), left_longer)
        .map(|(i, j)| {
            let (la, lb) = (values[i], values[j]);
            let pose = cc.pose(la, lb);
            let radius = (la.min(lb) / pose.bend.abs()).max(0.0);
            Point {
                model: Model::ConstantCurvature,
                shape_parameter: None,
                lengths_m: [la, lb],
                failure: None,
                stable: true,
                snapped: false,
                min_bend_radius_m: radius,
                feasible: radius >= robot.tube.min_bend_radius_m,
                endpoint_m: pose.endpoint,
                endpoint_angle_rad: pose.endpoint_angle,
                fresh_difference_m: 0.0,
            }
        })
        .collect()
}

/// A solved point and its state, the seed of its neighbours.
pub(crate) struct Solved {
    /// The point's result.
    pub point: Point,
    /// Its body and angles when it converged.
    pub body: Option<Seed>,
}

/// Solves one point along the path with `robot`, validated (a sweep checks
/// its robots once). A warm-started point's `fresh_difference_m` is NaN
/// until [`check_fresh`] fills it in.
fn solve_point(
    robot: &Robot,
    (la, lb): (f64, f64),
    seed: Option<&Seed>,
    solver: &Solver,
    ws: &mut Option<Scratch>,
) -> Solved {
    match robot.valid_body(la, lb) {
        Ok(body) => solve_body(robot, body, seed, solver, ws),
        Err(e) => failed(la, lb, e.to_string()),
    }
}

/// A grid point that did not converge.
fn failed(la: f64, lb: f64, reason: String) -> Solved {
    Solved {
        point: Point {
            model: Model::TwoChain,
            shape_parameter: None,
            lengths_m: [la, lb],
            failure: Some(reason),
            stable: false,
            snapped: false,
            min_bend_radius_m: f64::NAN,
            feasible: false,
            endpoint_m: [f64::NAN; 2],
            endpoint_angle_rad: f64::NAN,
            fresh_difference_m: f64::NAN,
        },
        body: None,
    }
}

/// Solves `body` (of `robot`), warm-started from `seed` when given (a cold
/// retry if that fails), cold otherwise; `ws` is reused between calls. A
/// warm-started point's `fresh_difference_m` is NaN (not yet checked), a
/// cold one's 0 (it is the fresh solve).
pub(crate) fn solve_body(
    robot: &Robot,
    body: Body,
    seed: Option<&Seed>,
    solver: &Solver,
    ws: &mut Option<Scratch>,
) -> Solved {
    let [la, lb] = [body.chain_a().tube_length(), body.chain_b().tube_length()];
    // A walk's or a thread's points mostly differ in a few links.
    let scratch = Scratch::fitted(ws, &body);
    // (result, snapped, warm): a cold solve is the fresh one.
    let (result, snapped, warm) = match seed {
        Some((previous, q)) => {
            let start = body.carry_over(previous, q);
            match body.solve_from(solver, &start, scratch) {
                Ok(eq) => {
                    let jump = eq.q.iter().zip(&start).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                    (Ok(eq), jump > SNAP_RAD, true)
                }
                Err(_) => (body.solve_in(solver, scratch), false, false),
            }
        }
        None => (body.solve_in(solver, scratch), false, false),
    };
    match result {
        Ok(eq) => {
            let radius = body.min_bend_radius(&eq.q);
            Solved {
                point: Point {
                    model: Model::TwoChain,
                    shape_parameter: None,
                    lengths_m: [la, lb],
                    failure: None,
                    stable: eq.stable,
                    snapped,
                    min_bend_radius_m: radius,
                    feasible: radius >= robot.tube.min_bend_radius_m,
                    endpoint_m: body.endpoint(&eq.q),
                    endpoint_angle_rad: body.endpoint_angle(&eq.q),
                    fresh_difference_m: if warm { f64::NAN } else { 0.0 },
                },
                body: Some((body, eq.q)),
            }
        }
        Err(e) => failed(la, lb, e.to_string()),
    }
}

/// Fills in `fresh_difference_m` of the warm-started points of every shape
/// parameter (`points[k]` walked with `robots[k]`, which differ only in the
/// joint stiffness): at each grid point the tubes are fed at `g = 0` once,
/// with `robots[0]`, and the softest robot's load from that fed state
/// passes through every other robot's loaded state (see the module doc).
/// Grid points in parallel; one progress unit per point (checked or not).
fn check_fresh(robots: &[Robot], points: &mut [Vec<Point>], solver: &Solver, progress: &(dyn Fn(usize) + Sync)) {
    let (models, per) = (points.len(), points.first().map_or(0, Vec::len));
    let mut fresh = vec![f64::NAN; models * per];
    fresh.par_chunks_mut(models).enumerate().for_each_init(
        || None,
        |ws, (g, out)| {
            if solver.options.deadline.expired() {
                return;
            }
            let unchecked = |k: usize| points[k][g].failure.is_none() && points[k][g].fresh_difference_m.is_nan();
            if (0..models).any(unchecked) {
                fresh_differences(robots, points, g, &unchecked, solver, ws, out);
            }
            progress(models);
        },
    );
    for (k, pts) in points.iter_mut().enumerate() {
        for (g, p) in pts.iter_mut().enumerate() {
            if p.fresh_difference_m.is_nan() && p.failure.is_none() {
                p.fresh_difference_m = fresh[g * models + k];
            }
        }
    }
}

/// The distances (m) from grid point `g`'s endpoints to a fresh solve's
/// (see the module doc), into `out[k]` for each robot `k` (validated) it is
/// `unchecked` for.
fn fresh_differences(
    robots: &[Robot],
    points: &[Vec<Point>],
    g: usize,
    unchecked: &dyn Fn(usize) -> bool,
    solver: &Solver,
    ws: &mut Option<Scratch>,
    out: &mut [f64],
) {
    let [la, lb] = points[0][g].lengths_m;
    let Ok(first) = robots[0].valid_body(la, lb) else { return out.fill(f64::INFINITY) };
    let scratch = Scratch::fitted(ws, &first);
    out.fill(f64::INFINITY);
    let Ok(fed) = first.feed_in(solver, scratch) else { return };
    // The robots to check, stiffest first: the softest one's load passes
    // through the others' loaded states ([`Body::load_through`]).
    let mut bodies: Vec<(usize, Body)> = (0..robots.len())
        .filter(|k| unchecked(*k))
        .filter_map(|k| robots[k].valid_body(la, lb).ok().map(|b| (k, b)))
        .collect();
    bodies.sort_by(|x, y| y.1.moment_scale().total_cmp(&x.1.moment_scale()));
    let Some((_, softest)) = bodies.last() else { return };
    let stops: Vec<f64> = bodies.iter().map(|(_, b)| softest.moment_scale() / b.moment_scale()).collect();
    let mut landed: Vec<Option<[f64; 2]>> = vec![None; bodies.len()];
    // Equal stiffnesses give equal stops: one landing serves them all.
    let (distinct, first_of) = distinct_stops(&stops);
    let _ = softest.load_through(solver, fed.for_stiffness(softest.moment_scale()), &distinct, scratch, &mut |i, q| {
        for j in first_of[i]..first_of.get(i + 1).copied().unwrap_or(bodies.len()) {
            landed[j] = Some(softest.endpoint(q));
        }
    });
    // A body whose stop the softest load did not reach (it failed on the
    // way) is loaded by itself.
    for (j, (k, body)) in bodies.iter().enumerate() {
        let endpoint = landed[j].or_else(|| {
            body.load_in(solver, fed.for_stiffness(body.moment_scale()), scratch).ok().map(|eq| body.endpoint(&eq.q))
        });
        let p = &points[*k][g].endpoint_m;
        out[*k] = match endpoint {
            Some(e) => {
                let d = (e[0] - p[0]).hypot(e[1] - p[1]);
                if d <= FRESH_TOLERANCE_M {
                    0.0
                } else {
                    d
                }
            }
            None => f64::INFINITY,
        };
    }
}

/// The distinct values of ascending `stops`, and where each starts in them.
fn distinct_stops(stops: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let (mut distinct, mut first_of) = (Vec::new(), Vec::new());
    for (j, s) in stops.iter().enumerate() {
        if distinct.last() != Some(s) {
            distinct.push(*s);
            first_of.push(j);
        }
    }
    (distinct, first_of)
}

/// A grid point's equilibrium: the body and its angles.
pub(crate) type Seed = (Body, Vec<f64>);

/// Walks the grid along the actuation path (see the module doc), returning
/// every point in row order (`LA` major).
fn walk(
    robot: &Robot,
    values: &[f64],
    left_longer: bool,
    solver: &Solver,
    progress: &(dyn Fn(usize) + Sync),
) -> Vec<Point> {
    let n = values.len();
    // Past the deadline every loop ends at its next point (the caller then
    // discards the partial walk); progress counts the points solved in time.
    let deadline = &solver.options.deadline;
    // The first column, fed upwards in LA from the cold corner.
    let mut column: Vec<Solved> = Vec::with_capacity(n);
    let mut ws = None;
    for &la in values {
        if deadline.expired() {
            break;
        }
        let seed = column.iter().rev().find_map(|s| s.body.as_ref());
        column.push(solve_point(robot, (la, values[0]), seed, solver, &mut ws));
        progress(1);
    }
    // Each row fed in LB from its first column, rows in parallel.
    let rows: Vec<Vec<Point>> = column
        .into_par_iter()
        .enumerate()
        .map(|(i, first)| {
            let mut ws = None;
            let end = if left_longer { i + 1 } else { n };
            let mut row = Vec::with_capacity(end);
            let mut seed = first.body;
            row.push(first.point);
            for &lb in &values[1..end] {
                if deadline.expired() {
                    break;
                }
                let solved = solve_point(robot, (values[i], lb), seed.as_ref(), solver, &mut ws);
                if solved.body.is_some() {
                    seed = solved.body;
                }
                row.push(solved.point);
                progress(1);
            }
            row
        })
        .collect();
    rows.into_iter().flatten().collect()
}

fn extreme(points: &[&Point], key: impl Fn(&Point) -> f64) -> Option<Extreme> {
    points
        .iter()
        .max_by(|a, b| key(a).total_cmp(&key(b)))
        .map(|p| Extreme { endpoint_m: p.endpoint_m, lengths_m: p.lengths_m })
}

fn summarize(model: Model, pi: Option<f64>, points: &[Point], values: &[f64], left_longer: bool) -> Summary {
    let good: Vec<&Point> = points.iter().filter(|p| p.failure.is_none() && p.feasible).collect();
    Summary {
        model,
        shape_parameter: pi,
        points: points.len(),
        failures: points
            .iter()
            .filter_map(|p| p.failure.as_ref().map(|r| Failure { lengths_m: p.lengths_m, reason: r.clone() }))
            .collect(),
        infeasible: points.iter().filter(|p| p.failure.is_none() && !p.feasible).count(),
        unstable: points.iter().filter(|p| p.failure.is_none() && !p.stable).count(),
        snapped: points.iter().filter(|p| p.snapped).count(),
        differ_from_fresh: points.iter().filter(|p| p.fresh_difference_m > 0.0).count(),
        largest_fresh_difference_m: points
            .iter()
            .map(|p| p.fresh_difference_m)
            .filter(|d| d.is_finite())
            .fold(0.0, f64::max),
        highest: extreme(&good, |p| p.endpoint_m[1]),
        lowest: extreme(&good, |p| -p.endpoint_m[1]),
        farthest: extreme(&good, |p| p.endpoint_m[0].abs()),
        area_m2: area(points, values.len(), left_longer),
    }
}

/// Rasterized area covered by the triangles of neighbouring grid points.
fn area(points: &[Point], n: usize, left_longer: bool) -> f64 {
    let index = |i: usize, j: usize| -> Option<&Point> {
        if left_longer {
            (j <= i).then(|| &points[i * (i + 1) / 2 + j])
        } else {
            Some(&points[i * n + j])
        }
    };
    let usable = |p: &Point| p.failure.is_none() && p.feasible && p.stable;
    let mut triangles = Vec::new();
    for i in 0..n.saturating_sub(1) {
        for j in 0..n.saturating_sub(1) {
            let corners = [index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1)];
            for tri in [[0, 1, 2], [0, 2, 3]] {
                let [Some(a), Some(b), Some(c)] = tri.map(|k| corners[k]) else { continue };
                if [a, b, c].iter().all(|p| usable(p)) {
                    triangles.push([a.endpoint_m, b.endpoint_m, c.endpoint_m]);
                }
            }
        }
    }
    let longest = |t: &[[f64; 2]; 3]| {
        let edge = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]);
        edge(t[0], t[1]).max(edge(t[1], t[2])).max(edge(t[2], t[0]))
    };
    let mut edges: Vec<f64> = triangles.iter().map(longest).collect();
    edges.sort_by(f64::total_cmp);
    let limit = edges.get(edges.len() / 2).map_or(0.0, |m| AREA_EDGE_FACTOR * m);
    let mut cells = std::collections::HashSet::new();
    for t in triangles.iter().filter(|t| longest(t) <= limit) {
        rasterize(t[0], t[1], t[2], &mut cells);
    }
    cells.len() as f64 * AREA_CELL_M * AREA_CELL_M
}

/// Marks the cells whose centres lie in the triangle.
fn rasterize(a: [f64; 2], b: [f64; 2], c: [f64; 2], cells: &mut std::collections::HashSet<(i64, i64)>) {
    let h = AREA_CELL_M;
    let lo = |k: usize| (a[k].min(b[k]).min(c[k]) / h).floor() as i64;
    let hi = |k: usize| (a[k].max(b[k]).max(c[k]) / h).ceil() as i64;
    let cross = |o: [f64; 2], p: [f64; 2], q: [f64; 2]| (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0]);
    for x in lo(0)..hi(0) {
        for y in lo(1)..hi(1) {
            let p = [(x as f64 + 0.5) * h, (y as f64 + 0.5) * h];
            let (d1, d2, d3) = (cross(a, b, p), cross(b, c, p), cross(c, a, p));
            let negative = d1 < 0.0 || d2 < 0.0 || d3 < 0.0;
            let positive = d1 > 0.0 || d2 > 0.0 || d3 > 0.0;
            if !(negative && positive) {
                cells.insert((x, y));
            }
        }
    }
}
