//! The three-tube body's solves (docs/model3d.md section 6): the default
//! path, both cups, among solids and warm starts, each a sequence of
//! stages of the one static solver ([`crate::statics::Solver`]) on the body
//! as a [`System3`] (blocks of 3, frames on SO(3)).
//!
//! * The default path: the tubes fed from the shortest length at `g = 0`
//!   (each tube's links scaled from `L_min / L_i` up to 1), then gravity
//!   raised from 0 to `g`, both by continuation.
//! * Both cups: the rear-held equilibrium, then the front hold's target
//!   moved from where the endpoint is to the hold, its rows compliant, then
//!   their compliance taken to 0 ([`Body3::solve_both_on`]).
//! * Among solids: gravity raised in [`LOAD_STAGES`] stages, each settled
//!   with the contact rows' active set ([`Body3::settle_among`]): a row whose
//!   force pulls leaves (the one pulling hardest first), then every tube's
//!   deepest link tip inside a solid gets a row against that solid's plane,
//!   until neither happens; at most [`Tuning::active_set_changes_per_row`]
//!   changes per link.
//!
//! [`Tuning::active_set_changes_per_row`]: crate::statics::Tuning::active_set_changes_per_row

use super::equilibrium3::Equilibrium3;
use super::system3::System3;
use crate::body3::body3::{Body3, Frames, Param, PLATE_ROWS};
use crate::cantilever::start_compliance;
use crate::contact::space::{Contact3, ContactRow3, HeldAt};
use crate::error::{InputError, StanceError};
use crate::geom3::dot;
use crate::hold::front3::{FrontHold, FrontTarget, Hanging, FRONT_ROWS};
use crate::linalg::MAX_BORDER;
use crate::scene::Scene3;
use crate::statics::{Iterate, Scratch, SolveError, Solver, Stage, StopReason};

/// Stages gravity is raised in among a scene's solids, each settled with
/// the contact rows' active set.
pub const LOAD_STAGES: usize = 8;

/// Two contact planes at one tip whose normals' cosine is above this
/// (within 1e-3 rad) face the same way: only the one the tip is inside keeps
/// a row.
const PARALLEL: f64 = 0.9999995;

/// A solve among a scene's solids: the scene, the clearance (m) the tubes'
/// centre lines keep, which cups hold the body, and the active set's
/// changes so far (a bound stops a cycling set).
struct Among<'a> {
    scene: &'a Scene3,
    clearance: f64,
    held: HeldAt<'a>,
    changes: usize,
}

/// What a solve carries from stage to stage: the iterate (the frames as a
/// point of [`System3`], the rows' multipliers: the weld's 12, the front
/// hold's, the contacts'), the contact rows and the solver's scratch.
struct State {
    it: Iterate,
    contacts: Vec<ContactRow3>,
    ws: Option<Scratch>,
}

impl State {
    /// A start at `frames` with the weld's rows and `contacts`, zero multipliers.
    fn new(frames: &[crate::geom3::Mat3], contacts: Vec<ContactRow3>) -> State {
        let mut it = Iterate::new(System3::point(frames));
        it.lambda = vec![0.0; PLATE_ROWS + contacts.len()];
        State { it, contacts, ws: None }
    }

    /// Runs `run` on the body along `path` with this state's contact rows,
    /// its iterate and its scratch sized for that system; every row in the
    /// working set (all are equalities: the contacts' active set is kept
    /// here, not by the solver).
    fn on<R>(
        &mut self,
        body: &Body3,
        path: &dyn Fn(f64) -> Param,
        run: impl FnOnce(&System3, &mut Iterate, &mut Scratch) -> R,
    ) -> R {
        let State { it, contacts, ws } = self;
        let sys = System3::new(body, path, contacts);
        it.active.clear();
        it.active.resize(it.lambda.len(), true);
        run(&sys, it, Scratch::fitted(ws, &sys))
    }

    fn frames(&self) -> &[crate::geom3::Mat3] {
        System3::frames(&self.it.q)
    }
}

impl Body3 {
    /// The equilibrium on the default path (module doc). The solver's
    /// options (tolerances, bounds, time limit) are `solver`'s.
    pub fn solve(&self, solver: &Solver) -> Result<Equilibrium3, SolveError> {
        self.solve_on(solver, None)
    }

    /// [`Body3::solve`], hanging from the front cup when `hang` says so
    /// ([`crate::hold::front3`]: gravity raised on the hanging body).
    pub(crate) fn solve_on(&self, solver: &Solver, hang: Option<Hanging>) -> Result<Equilibrium3, SolveError> {
        let (state, residual) = self.loaded(solver, hang)?;
        Ok(self.finish(solver, state, residual, Param { hang, ..Param::FULL }))
    }

    /// The default path's end (hanging when `hang` says so): the state and the residual.
    fn loaded(&self, solver: &Solver, hang: Option<Hanging>) -> Result<(State, f64), SolveError> {
        let mut state = State::new(&self.straight(), Vec::new());
        let mut residual = self.feed(solver, &mut state)?;
        if self.gravity() != 0.0 {
            residual = self.continuation(solver, &mut state, &load_path(hang), Stage::Load)?;
        }
        Ok((state, residual))
    }

    /// Both cups holding (docs/model3d.md section 8): the rear-held
    /// equilibrium on the default path, then the front hold's target moved
    /// by continuation from where the endpoint is (tube 1's tip and the
    /// plate's frame) to `to`: the tip along the segment, the frame along
    /// the geodesic ([`FrontTarget::toward`]), under full gravity, with the
    /// rows compliant ([`Body3::start_compliance`]); then their compliance
    /// taken from there to 0 by continuation, the target held. Among the
    /// solids of `scene` (with the tubes' `clearance`, m) when there is one:
    /// the rear-held equilibrium among them, then each path in
    /// [`LOAD_STAGES`] stages, the contact rows' active set updated at the
    /// end of each ([`Body3::settle_among`]).
    pub(crate) fn solve_both_on(
        &self,
        solver: &Solver,
        to: FrontTarget,
        scene: Option<(&Scene3, f64)>,
    ) -> Result<Equilibrium3, SolveError> {
        let (mut state, _) = match scene {
            None => self.loaded(solver, None)?,
            Some((scene, clearance)) => self.loaded_among(solver, scene, clearance, None)?,
        };
        let soft = self.start_compliance();
        let frames = state.frames();
        let from = FrontTarget { tip: self.endpoint(frames), plate: self.plate_frame(frames), compliance: soft };
        // The rows hold where the endpoint is: zero multipliers to start.
        state.it.lambda.splice(PLATE_ROWS..PLATE_ROWS, [0.0; FRONT_ROWS]);
        let to_soft = FrontTarget { compliance: soft, ..to };
        let approach = |t: f64| Param { front: Some(from.toward(&to_soft, t)), ..Param::FULL };
        let stiffen = |t: f64| Param {
            front: Some(FrontTarget { compliance: soft.map(|c| (1.0 - t) * c), ..to }),
            ..Param::FULL
        };
        // Among solids in stages, the active set updated at each end.
        let stages = if scene.is_some() { LOAD_STAGES } else { 1 };
        let mut among = scene.map(|(scene, clearance)| Among { scene, clearance, held: HeldAt::Both, changes: 0 });
        let mut residual = 0.0;
        for path in [&approach as &dyn Fn(f64) -> Param, &stiffen] {
            for stage in 0..stages {
                let [t0, t1] = [stage, stage + 1].map(|t| t as f64 / stages as f64);
                let part = |tau: f64| path(t0 + tau * (t1 - t0));
                residual = self.continuation(solver, &mut state, &part, Stage::Load)?;
                if let Some(among) = &mut among {
                    residual = self.settle_among(solver, &mut state, path(t1), Stage::Load, among)?;
                }
            }
        }
        Ok(self.finish(solver, state, residual, stiffen(1.0)))
    }

    /// The front hold's compliance on the both cups' path's start: tube 1
    /// as a cantilever ([`start_compliance`]).
    fn start_compliance(&self) -> [f64; 2] {
        start_compliance(self.tube(0).tube_length(), self.moment_scale() * self.element_length())
    }

    /// The tubes fed from the shortest length at `g = 0` (each tube's links
    /// scaled from `L_min / L_i` up to 1); the residual at the end.
    fn feed(&self, solver: &Solver, state: &mut State) -> Result<f64, SolveError> {
        let lengths = [0, 1, 2].map(|i| self.tube(i).tube_length());
        let feed = self.feed_path();
        if lengths.iter().all(|l| *l == lengths[0]) {
            self.settle(solver, state, feed(1.0), 1.0, Stage::Feed)
        } else {
            self.continuation(solver, state, &feed, Stage::Feed)
        }
    }

    /// The feeding path: at `g = 0`, each tube's links scaled from
    /// `L_min / L_i` (`tau = 0`) to 1 (`tau = 1`), affine in `tau`.
    fn feed_path(&self) -> impl Fn(f64) -> Param {
        let lengths = [0, 1, 2].map(|i| self.tube(i).tube_length());
        let shortest = lengths.iter().copied().fold(f64::INFINITY, f64::min);
        move |tau| Param { load: 0.0, scale: lengths.map(|l| (shortest + tau * (l - shortest)) / l), ..Param::FULL }
    }

    /// The equilibrium among `scene`'s solids, the driving unit fixed (the
    /// rear hold): the tubes fed at `g = 0`, then gravity raised in
    /// [`LOAD_STAGES`] stages, each settled with the contact
    /// rows' active set ([`crate::contact::space`]). Its `contacts` are the rows that push
    /// at the end, with their forces (N).
    /// The tubes' centre lines keep `clearance` (m, their radius) from the solids.
    /// A clearance that is not a finite length of at least 0 is refused.
    pub fn solve_among(&self, solver: &Solver, scene: &Scene3, clearance: f64) -> Result<Equilibrium3, StanceError> {
        if !(clearance.is_finite() && clearance >= 0.0) {
            return Err(InputError::invalid("clearance (m)", clearance, "a finite length of at least 0").into());
        }
        Ok(self.solve_among_on(solver, scene, clearance, None)?)
    }

    /// The equilibrium among `scene`'s solids on the default path: the
    /// tubes fed at `g = 0` as [`Body3::solve`] does, then gravity raised
    /// in [`LOAD_STAGES`] stages, each settled with the contact rows'
    /// active set ([`Body3::settle_among`]); held at the front when `front`
    /// says so (the picture of [`crate::hold::front3`]).
    pub(crate) fn solve_among_on(
        &self,
        solver: &Solver,
        scene: &Scene3,
        clearance: f64,
        front: Option<&FrontHold>,
    ) -> Result<Equilibrium3, SolveError> {
        let (state, residual) = self.loaded_among(solver, scene, clearance, front)?;
        let param = Param { hang: front.map(FrontHold::hanging), ..Param::FULL };
        Ok(self.finish(solver, state, residual, param))
    }

    /// [`Body3::solve_among_on`]'s end: the state and the residual.
    fn loaded_among(
        &self,
        solver: &Solver,
        scene: &Scene3,
        clearance: f64,
        front: Option<&FrontHold>,
    ) -> Result<(State, f64), SolveError> {
        let hang = front.map(FrontHold::hanging);
        let mut state = State::new(&self.straight(), Vec::new());
        let mut residual = self.feed(solver, &mut state)?;
        let held = front.map_or(HeldAt::Rear, HeldAt::Front);
        let mut among = Among { scene, clearance, held, changes: 0 };
        for stage in 1..=LOAD_STAGES {
            let load = stage as f64 / LOAD_STAGES as f64;
            let param = Param { load, hang, ..Param::FULL };
            residual = self.settle_among(solver, &mut state, param, Stage::Load, &mut among)?;
        }
        Ok((state, residual))
    }

    /// The equilibrium held at the front by `front` among `scene`'s solids
    /// reached from `frames` (the solver's picture) with gravity on, the
    /// active set starting from `rows` (their planes in the world): a warm
    /// start, as the swing on a free front joint takes from one turn to the
    /// next.
    pub(crate) fn solve_among_from(
        &self,
        solver: &Solver,
        frames: &Frames,
        rows: &[ContactRow3],
        scene: &Scene3,
        clearance: f64,
        front: &FrontHold,
    ) -> Result<Equilibrium3, SolveError> {
        let hang = Some(front.hanging());
        let local = rows.iter().map(|r| ContactRow3 { plane: front.plane_local(&r.plane), ..*r }).collect();
        let mut state = State::new(frames, local);
        let mut among = Among { scene, clearance, held: HeldAt::Front(front), changes: 0 };
        let param = Param { hang, ..Param::FULL };
        let residual = self.settle_among(solver, &mut state, param, Stage::WarmStart, &mut among)?;
        Ok(self.finish(solver, state, residual, param))
    }

    /// Settles at `param` with the contact rows' active set updated until
    /// it stands (module doc, docs/model3d.md section 12). The residual at the end.
    fn settle_among(
        &self,
        solver: &Solver,
        state: &mut State,
        param: Param,
        stage: Stage,
        among: &mut Among,
    ) -> Result<f64, SolveError> {
        let k = self.moment_scale();
        // A gap within the tolerance is closed; a force within it is zero.
        let gap_tolerance = solver.options.tolerance * self.row_scale(0);
        let force_tolerance = solver.options.tolerance * k / self.row_scale(0);
        let changes_allowed = solver.options.tuning.active_set_changes_per_row * self.links();
        let mut candidates = Vec::new();
        loop {
            let residual = self.settle(solver, state, param, param.load, stage)?;
            // The contacts' forces follow the weld's and the front hold's rows.
            let first = PLATE_ROWS + if param.front.is_some() { FRONT_ROWS } else { 0 };
            let forces = &state.it.lambda[first..];
            let pulling = (0..forces.len()).filter(|r| forces[*r] < -force_tolerance);
            if let Some(r) = pulling.min_by(|a, b| forces[*a].total_cmp(&forces[*b])) {
                state.contacts.remove(r);
                state.it.lambda.remove(first + r);
            } else {
                // Each tube's deepest point inside, one at a time: a body
                // sagging through a floor would otherwise bring all its
                // points at once, where a few rows lift the rest.
                let (scene, clearance, held) = (among.scene, among.clearance, among.held);
                let frames = state.frames();
                self.contact_rows_in(frames, scene, clearance, -gap_tolerance, held, &mut candidates);
                let mut changed = false;
                for tube in 0..3 {
                    let rows = &state.contacts;
                    let new = candidates.iter().filter(|c| c.tube == tube);
                    let same_tip = |r: &ContactRow3, c: &ContactRow3| (r.tube, r.link) == (c.tube, c.link);
                    // A tip has at most one row per solid (two in a corner).
                    let new = new.filter(|c| !rows.iter().any(|r| same_tip(r, c) && r.solid == c.solid));
                    let hanging = matches!(held, HeldAt::Front(_));
                    let gap = |c: &&ContactRow3| self.row_gap(System3::frames(&state.it.q), c, hanging);
                    let Some(c) = new.min_by(|a, b| gap(a).total_cmp(&gap(b))) else { continue };
                    let c = *c;
                    changed = true;
                    // Two rows of one tip facing the same way would be
                    // dependent: the plane it is inside replaces the other.
                    let parallel = |r: &ContactRow3| same_tip(r, &c) && dot(r.plane.normal, c.plane.normal) > PARALLEL;
                    match rows.iter().position(parallel) {
                        Some(r) => state.contacts[r] = c,
                        None => {
                            state.contacts.push(c);
                            state.it.lambda.push(0.0);
                        }
                    }
                }
                if !changed {
                    return Ok(residual);
                }
                if 3 + first + state.contacts.len() > MAX_BORDER {
                    return Err(solver.fail(stage, &state.it, residual, StopReason::TooManyActiveRows));
                }
            }
            among.changes += 1;
            if among.changes > changes_allowed {
                return Err(solver.fail(stage, &state.it, residual, StopReason::ActiveSetCycling));
            }
        }
    }

    /// The equilibrium reached from `frames` with gravity on, without
    /// continuation (a warm start, as planners following an actuation
    /// history use it); an unstable landing is left as on the paths.
    pub fn solve_from(&self, solver: &Solver, frames: &Frames) -> Result<Equilibrium3, SolveError> {
        self.solve_from_on(solver, frames, None)
    }

    /// [`Body3::solve_from`], hanging from the front cup when `hang` says so.
    pub(crate) fn solve_from_on(
        &self,
        solver: &Solver,
        frames: &Frames,
        hang: Option<Hanging>,
    ) -> Result<Equilibrium3, SolveError> {
        let mut state = State::new(frames, Vec::new());
        let full = Param { hang, ..Param::FULL };
        let residual = self.settle(solver, &mut state, full, 1.0, Stage::WarmStart)?;
        Ok(self.finish(solver, state, residual, full))
    }

    /// A free minimization at `param` (reported at the path parameter
    /// `at`), which ends stable ([`Solver::minimize`]).
    fn settle(
        &self,
        solver: &Solver,
        state: &mut State,
        param: Param,
        at: f64,
        stage: Stage,
    ) -> Result<f64, SolveError> {
        state.on(self, &move |_| param, |sys, it, ws| solver.minimize(sys, it, at, stage, ws))
    }

    /// Follows `path(tau)`, `tau` from 0 to 1 ([`Solver::continuation`]),
    /// from a start that is minimized at `tau = 0` first; ends at a stable
    /// equilibrium at 1.
    fn continuation(
        &self,
        solver: &Solver,
        state: &mut State,
        path: &dyn Fn(f64) -> Param,
        stage: Stage,
    ) -> Result<f64, SolveError> {
        state.on(self, path, |sys, it, ws| solver.continuation(sys, it, 0.0, stage, ws))
    }

    /// Packs a state converged at the full load, `param`.
    fn finish(&self, solver: &Solver, mut state: State, residual: f64, param: Param) -> Equilibrium3 {
        let mut summary = state.on(self, &move |_| param, |sys, it, ws| {
            solver.finish(sys, std::mem::replace(it, Iterate::new(Vec::new())), residual, ws)
        });
        let contacts = state.contacts;
        let frames = Frames(System3::frames(&summary.q).to_vec());
        summary.q = frames.iter().flat_map(crate::geom3::log).collect();
        let front_hold = param.front.map(|_| std::array::from_fn(|r| summary.multipliers[PLATE_ROWS + r]));
        let first = PLATE_ROWS + if param.front.is_some() { FRONT_ROWS } else { 0 };
        let contacts = (contacts.iter().zip(&summary.multipliers[first..]))
            .map(|(row, f)| Contact3 { row: *row, point_m: self.link_tip(&frames, row.tube, row.link), force_n: *f })
            .collect();
        Equilibrium3 { frames, summary, contacts, front_hold }
    }
}

/// The gravity path at the body's lengths: the load fraction `t` from 0
/// to 1, hanging from the front cup when `hang` says so.
fn load_path(hang: Option<Hanging>) -> impl Fn(f64) -> Param {
    move |t| Param { load: t, hang, ..Param::FULL }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body3::body3::tests::bent_and_hanging;
    use crate::body3::body3::Terms3;
    use crate::robot::Robot;
    use crate::scene::Plane3;

    /// [`System3`]'s tangent's premise: along the feeding and gravity paths
    /// (hanging or not, with a contact row) the residual is affine in the
    /// path parameter, so `F(tau + 1) - F(tau)` is its derivative, here
    /// against a central difference of step 1e-5 at a bent, twisted state
    /// with nonzero multipliers.
    #[test]
    fn residual_is_affine_along_the_paths() {
        let body = Body3::from_robot(&Robot::builtin(), [0.09, 0.12, 0.07]).unwrap();
        let (frames, hang) = bent_and_hanging(&body);
        let lambda: Vec<f64> = (0..PLATE_ROWS + 1).map(|r| 0.3 - 0.07 * r as f64).collect();
        let plane = Plane3 { point_m: [0.0, -0.01, 0.0], normal: [0.0, 1.0, 0.0] };
        let contact = [ContactRow3 { tube: 1, link: 3, solid: 0, plane }];
        let residual = |param: Param| {
            let mut ev = body.evaluation(PLATE_ROWS + 1);
            body.evaluate_rows::<false>(&frames, &lambda, param, &contact, &mut ev);
            let mut r = vec![0.0; 3 * body.links()];
            ev.stationarity(&lambda, &mut r);
            r.extend(ev.constraints);
            r
        };
        let feed = body.feed_path();
        let paths: [&dyn Fn(f64) -> Param; 3] = [&feed, &load_path(None), &load_path(Some(hang))];
        const H: f64 = 1e-5;
        let sup = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for (p, path) in paths.iter().enumerate() {
            for tau in [0.0, 0.4, 0.9] {
                let difference = |a: f64, b: f64, over: f64| -> Vec<f64> {
                    residual(path(a)).iter().zip(residual(path(b))).map(|(x, y)| (x - y) / over).collect()
                };
                let (unit, central) = (difference(tau + 1.0, tau, 1.0), difference(tau + H, tau - H, 2.0 * H));
                let size = sup(&unit);
                assert!(size > 1e-3, "path {p}: the residual moves along it");
                for (i, (a, b)) in unit.iter().zip(central).enumerate() {
                    assert!((a - b).abs() <= 1e-8 * size, "path {p}, tau {tau}, entry {i}: {a} against {b}");
                }
            }
        }
    }
}
