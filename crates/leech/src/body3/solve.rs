//! The static solver of the 3D body: Newton on the KKT system in local
//! rotation coordinates, re-based on SO(3) after every step, and continuation
//! along the documented path (docs/model3d.md section 6).
//!
//! Each Newton step solves
//!
//! ```text
//! [ H + shift I   J^T ] [ delta ]     [ grad V - J^T lambda ]
//! [ J             0   ] [ y     ] = - [ C                   ],     R_u <- R_u Exp(delta_u),  lambda <- lambda - y
//! ```
//!
//! with the Lagrangian Hessian `H` of [`Body3`] (3 x 3 blocks, tridiagonal
//! along each tube, the plate's 3 coordinates dense) on
//! [`BorderedLdl`] with 3 x 3 blocks and a border of 15 rows (the plate's
//! coordinates and the 12 weld rows) and the run-time rows after them (the
//! front hold's six when both cups hold, then the contacts'): O(n) per step. As in
//! [`crate::statics`]: the shift is the smallest of a geometric sequence
//! that makes the reduced Hessian positive definite (Sylvester's inertia:
//! one negative eigenvalue per row), so steps head for stable equilibria
//! (searched from the last shift's place in the sequence, down or up);
//! shifted steps stay within the trust radius and are accepted on the
//! merit `V/k + rho |C/s|_1`, plain Newton steps also on the residual; a
//! rejected step raises a Levenberg shift. Continuation uses a tangent
//! predictor (the path derivative of the residual `F(tau + 1) - F(tau)`,
//! exact since `F` is affine in the path parameter, and one solve with the
//! converged factors) and a Newton corrector, the first step sized so that the predictor turns no
//! link by more than 0.5 rad, doubling on success, halving on failure; a
//! persisting jump at the smallest step is a fold, reported as
//! [`Event::Snap`].

use super::body3::{distance, retract, within, Body3, Eval3, Frames, Param, PLATE_ROWS};
use super::contact3::{Contact3, ContactEval, ContactRow3, HeldAt};
use super::equilibrium3::Equilibrium3;
use super::hold3::{FrontHold, FrontTarget, Hanging, FRONT_ROWS};
use crate::cantilever::start_compliance;
use crate::geom3::{apply, axpy, column, cross, dot};
use crate::linalg::{BorderedLdl, MAX_BORDER};
use crate::scene::Scene3;
use crate::statics::{BranchRule, Equilibrium, Event, Side, SolveError, Solver, Stage, StopReason, Tuning};

/// Unstable landings left in one settle before it gives up.
const ESCAPES: usize = 4;

/// Growth of the kick between escapes from one settle (0.01, 0.03, 0.09, ... rad).
const ESCAPE_KICK_GROWTH: f64 = 3.0;

/// Bisections of the shift that brackets the most negative curvature.
const ESCAPE_BISECTIONS: usize = 30;

/// Most a continuation's first predictor turns a link (rad, sup norm): the
/// first step is `min(1, FIRST_TURN / |d delta/dtau|)`. The whole path at
/// once (as before) failed on most feeding paths and was halved down to
/// about this, each failed try costing its corrector's iterations and the
/// shifts of a search far from the path. Measured on 400 random bodies
/// (lengths 0.05 to 0.30 m, any clamp angle): 0.3 to 0.7 rad need the same
/// iterations to 1 %, 0.64 times those of the whole path first, and a
/// third of its factorizations (0.3 to 0.5 rad within 5 % of each other).
const FIRST_TURN: f64 = 0.5;

/// Stages gravity is raised in among a scene's solids, each settled with
/// the contact rows' active set.
pub const LOAD_STAGES: usize = 8;

/// Two contact planes at one tip whose normals' cosine is above this
/// (within 1e-3 rad) face the same way: only the one the tip is inside keeps
/// a row.
const PARALLEL: f64 = 0.9999995;

/// Active-set changes allowed per link before the solve among solids gives
/// up ([`StopReason::ActiveSetCycling`]).
const ACTIVE_SET_CHANGES: usize = 4;

/// A solve among a scene's solids: the scene, the clearance (m) the tubes'
/// centre lines keep, which cups hold the body, and the active set's
/// changes so far (a bound stops a cycling set).
struct Among<'a> {
    scene: &'a Scene3,
    clearance: f64,
    held: HeldAt<'a>,
    changes: usize,
}

/// The solver's state: frames, multipliers, counters.
#[derive(Clone, Debug)]
struct State {
    frames: Frames,
    /// The weld's 12 multipliers, then the contact rows' forces.
    lambda: Vec<f64>,
    iterations: usize,
    steps: usize,
    events: Vec<Event>,
}

impl State {
    fn new(frames: Frames) -> State {
        State { frames, lambda: vec![0.0; PLATE_ROWS], iterations: 0, steps: 0, events: Vec::new() }
    }
}

/// Limits of one Newton run.
#[derive(Clone, Copy, Debug)]
struct Budget {
    max_iter: usize,
    tolerance: f64,
    leash: f64,
}

/// Scratch for one body: evaluations, the factorization and vectors.
#[derive(Clone, Debug)]
struct Work {
    ev: Eval3,
    trial: Eval3,
    /// Whether the body hangs from the front cup (its factorization's pattern).
    hanging: bool,
    /// The front hold's rows when both cups hold ([`FRONT_ROWS`], else 0):
    /// the first of the run-time rows, before the contacts'.
    front_rows: usize,
    /// The contact rows (docs/model3d.md section 12) and their values.
    contacts: Vec<ContactRow3>,
    cev: ContactEval,
    cev_trial: ContactEval,
    /// The weld's and contact rows' right-hand side of a solve.
    cons: Vec<f64>,
    lambda_trial: Vec<f64>,
    lambda_start: Vec<f64>,
    ldl: BorderedLdl,
    border: Vec<f64>,
    corner: Vec<f64>,
    residual: Vec<f64>,
    residual_trial: Vec<f64>,
    rhs_c: Vec<f64>,
    x: Vec<f64>,
    y: Vec<f64>,
    step: Vec<f64>,
    dual: Vec<f64>,
    tangent: Vec<f64>,
    /// `dF/dtau` of the residual's moments (the tangent's right-hand side).
    path_residual: Vec<f64>,
    lambda_tangent: Vec<f64>,
    frames_trial: Frames,
    /// Where the last Newton run started (its leash) and the continuation step's start.
    frames_saved: Frames,
    frames_start: Frames,
    damping: f64,
    rho: f64,
    /// The shift whose factors of `ev`'s KKT matrix `ldl` holds, and what
    /// [`Work::factor`] said of them; `None` once `ev` changed.
    factored: Option<(f64, (bool, bool))>,
    /// Whether `border` and `corner` hold `ev`'s entries.
    border_loaded: bool,
    /// Where in the sequence `first_shift k growth^i` the last
    /// inertia-correcting shift was: the next search starts there.
    shift_index: usize,
}

impl Work {
    fn new(body: &Body3, hang: Option<Hanging>) -> Work {
        let n = body.links();
        let chain = 3 * (n - 1);
        let mut work = Work {
            ev: Eval3::new(body),
            trial: Eval3::new(body),
            contacts: Vec::new(),
            cev: ContactEval::default(),
            cev_trial: ContactEval::default(),
            cons: Vec::new(),
            lambda_trial: Vec::new(),
            lambda_start: Vec::new(),
            ldl: BorderedLdl::new(&body.pattern(hang.is_some(), 0)),
            hanging: hang.is_some(),
            front_rows: 0,
            border: Vec::new(),
            corner: Vec::new(),
            residual: vec![0.0; 3 * n],
            residual_trial: vec![0.0; 3 * n],
            rhs_c: Vec::new(),
            x: vec![0.0; chain],
            y: Vec::new(),
            step: vec![0.0; 3 * n],
            dual: Vec::new(),
            tangent: vec![0.0; 3 * n],
            path_residual: vec![0.0; 3 * n],
            lambda_tangent: Vec::new(),
            frames_trial: body.straight(),
            frames_saved: body.straight(),
            frames_start: body.straight(),
            damping: 0.0,
            rho: 0.0,
            factored: None,
            border_loaded: false,
            shift_index: 0,
        };
        work.set_contacts(body, &[]);
        work
    }

    /// The weld's and run-time rows' count.
    fn rows(&self) -> usize {
        PLATE_ROWS + self.front_rows + self.contacts.len()
    }

    /// Adds the front hold's rows (both cups holding) before any contact rows.
    fn hold_front(&mut self, body: &Body3) {
        self.front_rows = FRONT_ROWS;
        let contacts = std::mem::take(&mut self.contacts);
        self.set_contacts(body, &contacts);
    }

    /// Takes `contacts` as the contact rows: the border (the plate's 3
    /// coordinates, the weld's 12 rows and one per contact) sized to match.
    fn set_contacts(&mut self, body: &Body3, contacts: &[ContactRow3]) {
        self.contacts.clear();
        self.contacts.extend_from_slice(contacts);
        let (rows, chain) = (self.rows(), self.x.len());
        let border = 3 + rows;
        let mut pattern = body.pattern(self.hanging, self.front_rows + contacts.len());
        if self.front_rows > 0 {
            body.front_rows_reach(&mut pattern);
        }
        self.ldl = BorderedLdl::new(&pattern);
        self.border.resize(chain * border, 0.0);
        self.corner.resize(border * border, 0.0);
        for v in [&mut self.rhs_c, &mut self.y] {
            v.resize(border, 0.0);
        }
        for v in [&mut self.cons, &mut self.dual, &mut self.lambda_tangent, &mut self.lambda_trial] {
            v.resize(rows, 0.0);
        }
        self.changed();
    }

    /// `ev` (or the rows) changed: its factors and border are out of date.
    fn changed(&mut self) {
        self.factored = None;
        self.border_loaded = false;
    }

    /// Evaluates `body` at `frames`, `lambda` on `param` into `ev`, `cev`
    /// and `residual`, with the Hessian.
    fn evaluate(&mut self, body: &Body3, frames: &Frames, lambda: &[f64], param: Param) {
        let (ev, cev, residual) = (&mut self.ev, &mut self.cev, &mut self.residual);
        body.evaluate_with::<true>(frames, lambda, param, &self.contacts, ev, cev, residual);
        self.changed();
    }

    /// The trial point's evaluation becomes the current one (`ev`, `cev`, `residual`).
    fn accept_trial(&mut self) {
        std::mem::swap(&mut self.ev, &mut self.trial);
        std::mem::swap(&mut self.cev, &mut self.cev_trial);
        std::mem::swap(&mut self.residual, &mut self.residual_trial);
        self.changed();
    }

    /// The weld's and run-time rows' values of the current point into `cons`.
    fn gather_constraints(&mut self) {
        self.cons[..PLATE_ROWS].copy_from_slice(&self.ev.constraints);
        self.cons[PLATE_ROWS..].copy_from_slice(&self.cev.gaps);
    }

    /// Factors the KKT matrix of `ev` shifted by `shift`; whether the reduced
    /// Hessian is positive definite, and whether the count was singular.
    /// Factors already held for `ev` at `shift` are kept, not made again.
    fn factor(&mut self, shift: f64, tiny: f64) -> (bool, bool) {
        match self.factored {
            Some((at, verdict)) if at == shift => return verdict,
            _ => {}
        }
        if !self.border_loaded {
            self.load_border();
        }
        let rows = self.rows();
        let count = self.ldl.factor(&self.ev.diag, &self.ev.off, &self.border, &self.corner, shift, tiny);
        let verdict = (count.zero == 0 && count.negative == rows, count.zero > 0);
        self.factored = Some((shift, verdict));
        verdict
    }

    /// The border and corner of `ev`'s KKT matrix in [`BorderedLdl`]'s layout.
    fn load_border(&mut self) {
        let (ev, cev) = (&self.ev, &self.cev);
        let chain = ev.diag.len() / 3;
        let m = self.rows() - PLATE_ROWS;
        let border = 3 + PLATE_ROWS + m;
        // Unknown `i`'s entries of the rows: the weld's 12, then the run-time
        // rows' (the front hold's, then the contacts').
        let weld = |i: usize| &ev.jacobian[i * PLATE_ROWS..(i + 1) * PLATE_ROWS];
        let contacts = |i: usize| &cev.jacobian[i * m..(i + 1) * m];
        for (i, row) in self.border.chunks_exact_mut(border).enumerate() {
            row[..3].copy_from_slice(&ev.plate_border[3 * i..3 * i + 3]);
            row[3..3 + PLATE_ROWS].copy_from_slice(weld(i));
            row[3 + PLATE_ROWS..].copy_from_slice(contacts(i));
        }
        self.corner.fill(0.0);
        for a in 0..3 {
            self.corner[a * border..a * border + 3].copy_from_slice(&ev.plate_corner[a]);
            for (r, j) in weld(chain + a).iter().chain(contacts(chain + a)).enumerate() {
                self.corner[(3 + r) * border + a] = *j;
                self.corner[a * border + 3 + r] = *j;
            }
        }
        // A compliant row `g + c mu`: its unknown is `-mu`, so `-c`.
        for (r, c) in cev.compliance.iter().enumerate() {
            let at = 3 + PLATE_ROWS + r;
            self.corner[at * border + at] = -c;
        }
        self.border_loaded = true;
    }

    /// The smallest shift of `0, first_shift k growth^i` (`i` up to
    /// `max_shift_tries`) that makes the reduced Hessian positive definite,
    /// its factors left in `ldl`; `None` if there is none. The search
    /// starts at the last shift's place in the sequence and walks down
    /// while the next smaller one still does (the reduced Hessian grows
    /// with the shift, so this is the smallest), else up: along a path the
    /// shift needed changes little, and a search from the sequence's start
    /// cost as many factorizations as its place.
    fn inertia_shift(&mut self, tuning: &Tuning, k: f64, tiny: f64) -> Option<f64> {
        if self.factor(0.0, tiny).0 {
            return Some(0.0);
        }
        let shift = |i: usize| tuning.first_shift * k * tuning.shift_growth.powi(i as i32);
        let mut i = self.shift_index.min(tuning.max_shift_tries);
        if self.factor(shift(i), tiny).0 {
            while i > 0 && self.factor(shift(i - 1), tiny).0 {
                i -= 1;
            }
        } else {
            loop {
                i += 1;
                if i > tuning.max_shift_tries {
                    return None;
                }
                if self.factor(shift(i), tiny).0 {
                    break;
                }
            }
        }
        self.shift_index = i;
        // Again after a walk down that ended on a shift too small.
        self.factor(shift(i), tiny);
        Some(shift(i))
    }

    /// Solves the factored system for `-(r, c)`, `c` the rows' values in
    /// `cons`: the primal step into `step` and `-y` (the multipliers'
    /// change) into `dual`.
    fn solve(&mut self, r: &[f64]) {
        let chain = self.x.len();
        for (dst, v) in self.rhs_c[..3].iter_mut().zip(&r[chain..]) {
            *dst = -v;
        }
        for (dst, v) in self.rhs_c[3..].iter_mut().zip(&self.cons) {
            *dst = -v;
        }
        self.step[..chain].iter_mut().zip(&r[..chain]).for_each(|(s, v)| *s = -v);
        self.ldl.solve(&self.step[..chain], &self.rhs_c, &mut self.x, &mut self.y);
        self.step[..chain].copy_from_slice(&self.x);
        self.step[chain..].copy_from_slice(&self.y[..3]);
        for (d, y) in self.dual.iter_mut().zip(&self.y[3..]) {
            *d = -y;
        }
    }
}

/// `frames` moved by `alpha` times the local step `step` (3 per link) into `out`.
fn moved(frames: &Frames, step: &[f64], alpha: f64, out: &mut Frames) {
    for ((o, f), s) in out.0.iter_mut().zip(&frames.0).zip(step.chunks_exact(3)) {
        *o = retract(f, [alpha * s[0], alpha * s[1], alpha * s[2]]);
    }
}

fn sup(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

impl Body3 {
    /// The equilibrium on the default path (docs/model3d.md section 6): the
    /// tubes fed from the shortest length at `g = 0` (each tube's links
    /// scaled from `L_min / L_i` up to 1), then gravity raised from 0 to `g`.
    /// The solver's options (tolerances, bounds, time limit) are `solver`'s.
    pub fn solve(&self, solver: &Solver) -> Result<Equilibrium3, SolveError> {
        self.solve_on(solver, None)
    }

    /// [`Body3::solve`], hanging from the front cup when `hang` says so
    /// ([`super::hold3`]: gravity raised on the hanging body).
    pub(crate) fn solve_on(&self, solver: &Solver, hang: Option<Hanging>) -> Result<Equilibrium3, SolveError> {
        let (state, mut work, residual) = self.loaded(solver, hang)?;
        Ok(self.finish(solver, state, residual, Param { hang, ..Param::FULL }, &mut work))
    }

    /// The default path's end (hanging when `hang` says so): the state, its
    /// scratch and the residual.
    fn loaded(&self, solver: &Solver, hang: Option<Hanging>) -> Result<(State, Work, f64), SolveError> {
        let mut work = Work::new(self, hang);
        let mut state = State::new(self.straight());
        let mut residual = self.feed(solver, &mut state, &mut work)?;
        if self.gravity() != 0.0 {
            residual = self.continuation(solver, &mut state, &load_path(hang), Stage::Load, &mut work)?;
        }
        Ok((state, work, residual))
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
        let (mut state, mut work, _) = match scene {
            None => self.loaded(solver, None)?,
            Some((scene, clearance)) => self.loaded_among(solver, scene, clearance, None)?,
        };
        let soft = self.start_compliance();
        let frames = &state.frames;
        let from = FrontTarget { tip: self.endpoint(frames), plate: self.plate_frame(frames), compliance: soft };
        work.hold_front(self);
        // The rows hold where the endpoint is: zero multipliers to start.
        state.lambda.splice(PLATE_ROWS..PLATE_ROWS, [0.0; FRONT_ROWS]);
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
                residual = self.continuation(solver, &mut state, &part, Stage::Load, &mut work)?;
                if let Some(among) = &mut among {
                    residual = self.settle_among(solver, &mut state, path(t1), Stage::Load, among, &mut work)?;
                }
            }
        }
        Ok(self.finish(solver, state, residual, stiffen(1.0), &mut work))
    }

    /// The front hold's compliance on the both cups' path's start: tube 1
    /// as a cantilever ([`start_compliance`]).
    fn start_compliance(&self) -> [f64; 2] {
        start_compliance(self.tube(0).tube_length(), self.moment_scale() * self.element_length())
    }

    /// The tubes fed from the shortest length at `g = 0` (each tube's links
    /// scaled from `L_min / L_i` up to 1); the residual at the end.
    fn feed(&self, solver: &Solver, state: &mut State, work: &mut Work) -> Result<f64, SolveError> {
        let lengths = [0, 1, 2].map(|i| self.tube(i).tube_length());
        let feed = self.feed_path();
        if lengths.iter().all(|l| *l == lengths[0]) {
            self.settle_reporting(solver, state, feed(1.0), 1.0, Stage::Feed, work)
        } else {
            self.continuation(solver, state, &feed, Stage::Feed, work)
        }
    }

    /// The feeding path: at `g = 0`, each tube's links scaled from
    /// `L_min / L_i` (`tau = 0`) to 1 (`tau = 1`), affine in `tau`.
    fn feed_path(&self) -> impl Fn(f64) -> Param {
        let lengths = [0, 1, 2].map(|i| self.tube(i).tube_length());
        let shortest = lengths.iter().copied().fold(f64::INFINITY, f64::min);
        move |tau| Param { load: 0.0, scale: lengths.map(|l| (shortest + tau * (l - shortest)) / l), ..Param::FULL }
    }

    /// The equilibrium among `scene`'s solids on the default path: the
    /// tubes fed at `g = 0` as [`Body3::solve`] does, then gravity raised
    /// in [`LOAD_STAGES`] stages, each settled with the contact rows'
    /// active set ([`Body3::settle_among`]); held at the front when `front`
    /// says so (the picture of [`super::hold3`]).
    pub(crate) fn solve_among_on(
        &self,
        solver: &Solver,
        scene: &Scene3,
        clearance: f64,
        front: Option<&FrontHold>,
    ) -> Result<Equilibrium3, SolveError> {
        let (state, mut work, residual) = self.loaded_among(solver, scene, clearance, front)?;
        let param = Param { hang: front.map(FrontHold::hanging), ..Param::FULL };
        Ok(self.finish(solver, state, residual, param, &mut work))
    }

    /// [`Body3::solve_among_on`]'s end: the state, its scratch and the residual.
    fn loaded_among(
        &self,
        solver: &Solver,
        scene: &Scene3,
        clearance: f64,
        front: Option<&FrontHold>,
    ) -> Result<(State, Work, f64), SolveError> {
        let hang = front.map(FrontHold::hanging);
        let mut work = Work::new(self, hang);
        let mut state = State::new(self.straight());
        let mut residual = self.feed(solver, &mut state, &mut work)?;
        let held = front.map_or(HeldAt::Rear, HeldAt::Front);
        let mut among = Among { scene, clearance, held, changes: 0 };
        for stage in 1..=LOAD_STAGES {
            let load = stage as f64 / LOAD_STAGES as f64;
            let param = Param { load, hang, ..Param::FULL };
            residual = self.settle_among(solver, &mut state, param, Stage::Load, &mut among, &mut work)?;
        }
        Ok((state, work, residual))
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
        let mut work = Work::new(self, hang);
        let mut state = State::new(frames.clone());
        let local: Vec<ContactRow3> =
            rows.iter().map(|r| ContactRow3 { plane: front.plane_local(&r.plane), ..*r }).collect();
        state.lambda.resize(PLATE_ROWS + local.len(), 0.0);
        work.set_contacts(self, &local);
        let mut among = Among { scene, clearance, held: HeldAt::Front(front), changes: 0 };
        let param = Param { hang, ..Param::FULL };
        let residual = self.settle_among(solver, &mut state, param, Stage::WarmStart, &mut among, &mut work)?;
        Ok(self.finish(solver, state, residual, param, &mut work))
    }

    /// Settles at `param` with the contact rows' active set updated until it
    /// stands (docs/model3d.md section 12): a row whose force pulls is
    /// released (the one pulling hardest first), then every tube's deepest
    /// link tip inside a solid gets a row against that solid's plane, until
    /// neither happens. The residual at the end.
    fn settle_among(
        &self,
        solver: &Solver,
        state: &mut State,
        param: Param,
        stage: Stage,
        among: &mut Among,
        work: &mut Work,
    ) -> Result<f64, SolveError> {
        let k = self.moment_scale();
        // A gap within the tolerance is closed; a force within it is zero.
        let gap_tolerance = solver.options.tolerance * self.row_scale(0);
        let force_tolerance = solver.options.tolerance * k / self.row_scale(0);
        let mut candidates = Vec::new();
        loop {
            let residual = self.settle_reporting(solver, state, param, param.load, stage, work)?;
            // The contacts' forces follow the weld's and the front hold's rows.
            let first = PLATE_ROWS + work.front_rows;
            let forces = &state.lambda[first..];
            let pulling = (0..forces.len()).filter(|r| forces[*r] < -force_tolerance);
            let mut rows = work.contacts.clone();
            if let Some(r) = pulling.min_by(|a, b| forces[*a].total_cmp(&forces[*b])) {
                rows.remove(r);
                state.lambda.remove(first + r);
            } else {
                // Each tube's deepest point inside, one at a time: a body
                // sagging through a floor would otherwise bring all its
                // points at once, where a few rows lift the rest.
                let (scene, clearance, held) = (among.scene, among.clearance, among.held);
                self.contact_rows_in(&state.frames, scene, clearance, -gap_tolerance, held, &mut candidates);
                let mut changed = false;
                for tube in 0..3 {
                    let new = candidates.iter().filter(|c| c.tube == tube);
                    let same_tip = |r: &ContactRow3, c: &ContactRow3| (r.tube, r.link) == (c.tube, c.link);
                    // A tip has at most one row per solid (two in a corner).
                    let new = new.filter(|c| !rows.iter().any(|r| same_tip(r, c) && r.solid == c.solid));
                    let hanging = matches!(held, HeldAt::Front(_));
                    let gap = |c: &&ContactRow3| self.row_gap(&state.frames, c, hanging);
                    let Some(c) = new.min_by(|a, b| gap(a).total_cmp(&gap(b))) else { continue };
                    changed = true;
                    // Two rows of one tip facing the same way would be
                    // dependent: the plane it is inside replaces the other.
                    let parallel = |r: &ContactRow3| same_tip(r, c) && dot(r.plane.normal, c.plane.normal) > PARALLEL;
                    match rows.iter().position(parallel) {
                        Some(r) => rows[r] = *c,
                        None => {
                            rows.push(*c);
                            state.lambda.push(0.0);
                        }
                    }
                }
                if !changed {
                    return Ok(residual);
                }
                if 3 + first + rows.len() > MAX_BORDER {
                    return Err(fail(solver, stage, state, residual, StopReason::TooManyActiveRows));
                }
            }
            among.changes += 1;
            if among.changes > ACTIVE_SET_CHANGES * self.links() {
                return Err(fail(solver, stage, state, residual, StopReason::ActiveSetCycling));
            }
            work.set_contacts(self, &rows);
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
        let mut work = Work::new(self, hang);
        let mut state = State::new(frames.clone());
        let full = Param { hang, ..Param::FULL };
        let residual = self.settle_reporting(solver, &mut state, full, 1.0, Stage::WarmStart, &mut work)?;
        Ok(self.finish(solver, state, residual, full, &mut work))
    }

    /// Packs a state converged at the full load, `param`.
    fn finish(&self, solver: &Solver, state: State, residual: f64, param: Param, work: &mut Work) -> Equilibrium3 {
        work.evaluate(self, &state.frames, &state.lambda, param);
        let tiny = solver.options.tuning.tiny_pivot * self.moment_scale();
        let stable = work.factor(0.0, tiny).0;
        let q = state.frames.0.iter().flat_map(crate::geom3::log).collect();
        let front_hold = param.front.map(|_| std::array::from_fn(|r| state.lambda[PLATE_ROWS + r]));
        let contacts = (work.contacts.iter().zip(&state.lambda[PLATE_ROWS + work.front_rows..]))
            .map(|(row, f)| Contact3 {
                row: *row,
                point_m: self.link_tip(&state.frames, row.tube, row.link),
                force_n: *f,
            })
            .collect();
        Equilibrium3 {
            frames: state.frames,
            summary: Equilibrium {
                q,
                multipliers: state.lambda.clone(),
                energy: work.ev.energy,
                residual,
                stable,
                iterations: state.iterations,
                steps: state.steps,
                events: state.events,
            },
            contacts,
            front_hold,
        }
    }

    /// The weld's and contact rows' scaled values `C_r / s_r`.
    fn scaled_rows<'a>(&'a self, ev: &'a Eval3, cev: &'a ContactEval) -> impl Iterator<Item = f64> + 'a {
        let values = ev.constraints.iter().chain(&cev.gaps);
        values.enumerate().map(|(r, c)| c / self.any_row_scale(cev, r))
    }

    /// The scaled sup norm of `(grad V - J^T lambda, C)`.
    fn residual_norm(&self, ev: &Eval3, cev: &ContactEval, r: &[f64]) -> f64 {
        let moments = sup(r) / self.moment_scale();
        self.scaled_rows(ev, cev).fold(moments, |m, c| m.max(c.abs()))
    }

    /// Squared scaled Euclidean norm of the same.
    fn residual_l2(&self, ev: &Eval3, cev: &ContactEval, r: &[f64]) -> f64 {
        let k = self.moment_scale();
        let moments = r.iter().fold(0.0, |s, x| s + (x / k) * (x / k));
        self.scaled_rows(ev, cev).fold(moments, |s, c| s + c * c)
    }

    /// The exact-penalty merit `V/k + rho |C/s|_1`.
    fn merit(&self, ev: &Eval3, cev: &ContactEval, rho: f64) -> f64 {
        let infeasibility = self.scaled_rows(ev, cev).fold(0.0, |s, c| s + c.abs());
        ev.energy / self.moment_scale() + rho * infeasibility
    }

    /// A free minimization at `param` (no leash), which must end stable: an
    /// unstable landing is left along its most negative curvature
    /// ([`Body3::escape`]), at most [`ESCAPES`] times. Returns the residual
    /// and the side left to, if any.
    fn settle(
        &self,
        solver: &Solver,
        state: &mut State,
        param: Param,
        stage: Stage,
        work: &mut Work,
    ) -> Result<(f64, Option<Side>), SolveError> {
        let o = &solver.options;
        let budget = Budget { max_iter: o.max_minimization_iterations, tolerance: o.tolerance, leash: f64::INFINITY };
        let mut escaped = None;
        for attempt in 0..=ESCAPES {
            // A landing back where it was left is kicked harder each time.
            let kick = solver.options.tuning.escape_kick * ESCAPE_KICK_GROWTH.powi(attempt as i32);
            match self.newton(solver, state, param, budget, work) {
                (residual, Ok(true)) => return Ok((residual, escaped)),
                (residual, Ok(false)) => {
                    let side = self.escape(solver, state, work, kick);
                    escaped = Some(side.map_err(|reason| fail(solver, stage, state, residual, reason))?);
                }
                (residual, Err(StopReason::NoDescent)) if attempt < ESCAPES => {
                    // Past a fold no equilibrium is near: the steps stall
                    // where the gradient is least (the fold's ghost), along
                    // the softest mode. The energy falls along it one way.
                    self.snap(solver, state, param, work, kick)
                        .map_err(|reason| fail(solver, stage, state, residual, reason))?;
                }
                (residual, Err(reason)) => return Err(fail(solver, stage, state, residual, reason)),
            }
        }
        let residual = self.residual_norm(&work.ev, &work.cev, &work.residual);
        Err(fail(solver, stage, state, residual, StopReason::StillUnstable))
    }

    /// Leaves the unstable equilibrium `state` (evaluated in `work.ev`)
    /// along the reduced Hessian's most negative curvature: inverse
    /// iteration on the KKT matrix shifted to just above that curvature
    /// (found by bisection on the inertia), then a kick of `kick` rad
    /// (from [`Tuning::escape_kick`](crate::statics::Tuning::escape_kick)).
    /// The sign follows the branch rule on the endpoint's displacement:
    /// along the right of the clamp direction (towards tubes 2 and 3) for a
    /// mode mostly in the plane of the clamp, along `+z` (towards tube 2)
    /// for one mostly out of it; [`Side::Right`] names the positive side.
    fn escape(&self, solver: &Solver, state: &mut State, work: &mut Work, kick: f64) -> Result<Side, StopReason> {
        let v = self.softest_mode(solver, work)?;
        // The endpoint's displacement along v: sum_j l_j R_j (v_j x e_x) over tube 1.
        let mut d = [0.0; 3];
        for (j, l) in self.tube(0).lengths().iter().enumerate() {
            let u = self.index(0, j);
            let local = cross([v[3 * u], v[3 * u + 1], v[3 * u + 2]], [1.0, 0.0, 0.0]);
            d = axpy(*l, apply(&state.frames.0[u], local), d);
        }
        let right = -dot(column(&self.base_frame(), 1), d);
        let measure = if right.abs() >= d[2].abs() { right } else { d[2] };
        let (side, wanted) = match solver.options.branch {
            BranchRule::Right => (Side::Right, 1.0),
            BranchRule::Left => (Side::Left, -1.0),
            BranchRule::Refuse => return Err(StopReason::UnstableRefused),
        };
        let sign = if measure < 0.0 { -wanted } else { wanted };
        let frames = state.frames.clone();
        moved(&frames, &v, sign * kick, &mut state.frames);
        Ok(side)
    }

    /// Leaves a point past a fold (evaluated in `work.ev`) where no step
    /// descends: a kick of `kick` rad along the reduced Hessian's softest
    /// mode ([`Body3::softest_mode`]), to whichever side has the lower
    /// merit (no branch to choose: the equilibrium left has ended).
    fn snap(
        &self,
        solver: &Solver,
        state: &mut State,
        param: Param,
        work: &mut Work,
        kick: f64,
    ) -> Result<(), StopReason> {
        let v = self.softest_mode(solver, work)?;
        let rho = work.rho;
        let mut best = (f64::INFINITY, 0.0);
        for sign in [1.0, -1.0] {
            moved(&state.frames, &v, sign * kick, &mut work.frames_trial);
            let (ev, cev, residual) = (&mut work.trial, &mut work.cev_trial, &mut work.residual_trial);
            self.evaluate_with::<false>(&work.frames_trial, &state.lambda, param, &work.contacts, ev, cev, residual);
            let merit = self.merit(&work.trial, &work.cev_trial, rho);
            if merit < best.0 {
                best = (merit, sign);
            }
        }
        if !best.0.is_finite() {
            return Err(StopReason::NonFinite);
        }
        moved(&state.frames, &v, best.1 * kick, &mut work.frames_trial);
        std::mem::swap(&mut state.frames, &mut work.frames_trial);
        Ok(())
    }

    /// The reduced Hessian's softest (most negative) mode at the point
    /// evaluated in `work.ev`, as a step (3 per link, largest entry 1):
    /// inverse iteration on the KKT matrix shifted to just above its least
    /// curvature, found by bisection on the inertia.
    fn softest_mode(&self, solver: &Solver, work: &mut Work) -> Result<Vec<f64>, StopReason> {
        let tuning = &solver.options.tuning;
        let k = self.moment_scale();
        let tiny = tuning.tiny_pivot * k;
        let (mut lo, mut hi) = (0.0, tuning.first_shift * k);
        let mut tries = 0;
        while !work.factor(hi, tiny).0 {
            (lo, hi) = (hi, hi * tuning.shift_growth);
            tries += 1;
            if tries > tuning.max_shift_tries {
                return Err(StopReason::SingularJacobian);
            }
        }
        for _ in 0..ESCAPE_BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if work.factor(mid, tiny).0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        work.factor(hi, tiny);
        // A fixed start with every component present, so no mode is missed.
        let n = work.tangent.len();
        let mut v: Vec<f64> = (0..n).map(|i| 1.0 + 0.5 * ((i * 7919) % 13) as f64 / 13.0).collect();
        work.cons.fill(0.0);
        for _ in 0..tuning.escape_iterations {
            work.solve(&v);
            let norm = sup(&work.step);
            if norm == 0.0 || !norm.is_finite() {
                return Err(StopReason::StillUnstable);
            }
            v.iter_mut().zip(&work.step).for_each(|(a, b)| *a = b / norm);
        }
        Ok(v)
    }

    /// [`Body3::settle`] at path parameter `at`, reporting a bifurcation left.
    fn settle_reporting(
        &self,
        solver: &Solver,
        state: &mut State,
        param: Param,
        at: f64,
        stage: Stage,
        work: &mut Work,
    ) -> Result<f64, SolveError> {
        let before = state.frames.clone();
        let (residual, escaped) = self.settle(solver, state, param, stage, work)?;
        if let Some(side) = escaped {
            let jump_rad = distance(&state.frames, &before);
            state.events.push(Event::Bifurcation { stage, at, side, jump_rad });
        }
        Ok(residual)
    }

    /// Newton's method from `state` at `param`; the scaled residual and
    /// whether it converged to a stable point. Leaves `work.ev` evaluated at
    /// the final point and, when converged, its unshifted factors.
    fn newton(
        &self,
        solver: &Solver,
        state: &mut State,
        param: Param,
        budget: Budget,
        work: &mut Work,
    ) -> (f64, Result<bool, StopReason>) {
        let o = &solver.options;
        let tuning = &o.tuning;
        let k = self.moment_scale();
        let tiny = tuning.tiny_pivot * k;
        work.frames_saved.clone_from(&state.frames);
        work.evaluate(self, &state.frames, &state.lambda, param);
        work.damping = 0.0;
        let (mut iter, mut best, mut best_at, mut fresh) = (0, f64::INFINITY, 0, false);
        loop {
            let res = self.residual_norm(&work.ev, &work.cev, &work.residual);
            if !res.is_finite() {
                return (res, Err(StopReason::NonFinite));
            }
            // A residual that stalls within a few orders of the tolerance is
            // at the rounding floor: converged, reported as it is.
            if res < 0.5 * best {
                (best, best_at) = (res, iter);
            }
            let stalled = iter >= best_at + tuning.stall_iterations && res <= o.rounding_slack * budget.tolerance;
            if res <= budget.tolerance || stalled {
                // After a tiny plain step from a minimum the last factors
                // still give the verdict and a tangent good for a predictor.
                return (res, Ok(fresh || work.factor(0.0, tiny).0));
            }
            if iter >= budget.max_iter || state.iterations >= o.max_iterations {
                return (res, Err(StopReason::IterationLimit));
            }
            if o.deadline.expired() {
                return (res, Err(StopReason::TimeLimit));
            }
            iter += 1;
            state.iterations += 1;
            let Some(min_shift) = work.inertia_shift(tuning, k, tiny) else {
                return (res, Err(StopReason::SingularJacobian));
            };
            if !self.take_step(solver, state, param, work, min_shift) {
                // Within a few orders of the tolerance no step improves on rounding.
                if res <= o.rounding_slack * budget.tolerance {
                    return (res, Ok(work.factor(0.0, tiny).0));
                }
                // Damped steps cannot leave a saddle whose unstable mode the
                // gradient does not reach (a straight column compressed past
                // its buckling load, by symmetry): an unstable landing.
                if min_shift > 0.0 {
                    return (res, Ok(false));
                }
                return (res, Err(StopReason::NoDescent));
            }
            // The Lagrangian Hessian holds the multipliers too (the weld's
            // curvature): factors stay good only if neither moved. A warm
            // start begins with zero multipliers, whose Hessian can look
            // stable where the true one is a saddle.
            let moved_multipliers =
                (0..work.rows()).fold(0.0f64, |m, r| m.max(work.dual[r].abs() * self.any_row_scale(&work.cev, r) / k));
            fresh = min_shift == 0.0
                && work.damping == 0.0
                && sup(&work.step) < tuning.reuse_factors_step
                && moved_multipliers < tuning.reuse_factors_step;
            if !within(&state.frames, &work.frames_saved, budget.leash) {
                let res = self.residual_norm(&work.ev, &work.cev, &work.residual);
                return (res, Err(StopReason::LeftBranch));
            }
        }
    }

    /// Tries steps with growing shifts from `min_shift` until one is accepted
    /// (then `state` and `work.ev` hold the new point); false if none was.
    fn take_step(&self, solver: &Solver, state: &mut State, param: Param, work: &mut Work, min_shift: f64) -> bool {
        let o = &solver.options;
        let tuning = &o.tuning;
        let k = self.moment_scale();
        let tiny = tuning.tiny_pivot * k;
        let mut shift = if min_shift == 0.0 { 0.0 } else { min_shift.max(work.damping) };
        let base_l2 = self.residual_l2(&work.ev, &work.cev, &work.residual);
        for _ in 0..tuning.max_trials {
            work.factor(shift, tiny);
            let residual = std::mem::take(&mut work.residual);
            work.gather_constraints();
            work.solve(&residual);
            work.residual = residual;
            // Shifted steps stay within the trust radius; plain Newton steps
            // within the jump tolerance (the exponential map's good range).
            let radius = if shift > 0.0 { o.trust_radius } else { o.jump_tolerance };
            let alpha = (radius / sup(&work.step)).min(1.0);
            moved(&state.frames, &work.step, alpha, &mut work.frames_trial);
            let lambda = &mut work.lambda_trial;
            for ((l, s), d) in lambda.iter_mut().zip(&state.lambda).zip(&work.dual) {
                *l = s + alpha * d;
            }
            let (ev, cev, residual) = (&mut work.trial, &mut work.cev_trial, &mut work.residual_trial);
            self.evaluate_with::<true>(&work.frames_trial, lambda, param, &work.contacts, ev, cev, residual);
            let largest = lambda
                .iter()
                .enumerate()
                .fold(0.0f64, |m, (r, l)| m.max(l.abs() * self.any_row_scale(&work.cev_trial, r) / k));
            work.rho = work.rho.max((1.0 + tuning.penalty_margin) * largest);
            let before = self.merit(&work.ev, &work.cev, work.rho);
            let after = self.merit(&work.trial, &work.cev_trial, work.rho);
            let decreased = after < before - tuning.measurable_decrease * before.abs().max(1.0);
            // A plain Newton step may also be accepted on the residual; so may
            // any step that leaves the merit as it was (to rounding) while
            // the residual falls: at a constrained stationary point with
            // wrong multipliers only they need to move.
            let level = after <= before + tuning.measurable_decrease * before.abs().max(1.0);
            let improved = (shift == 0.0 || level)
                && self.residual_l2(&work.trial, &work.cev_trial, &work.residual_trial)
                    < (1.0 - tuning.residual_decrease) * base_l2;
            if (decreased || improved) && after.is_finite() {
                std::mem::swap(&mut state.frames, &mut work.frames_trial);
                std::mem::swap(&mut state.lambda, &mut work.lambda_trial);
                work.accept_trial();
                work.damping = shift * tuning.damping_memory;
                return true;
            }
            shift = if shift == 0.0 { (tuning.min_damping * k).max(min_shift) } else { shift * tuning.damping_growth };
        }
        false
    }

    /// The path tangent at a converged point, evaluated in `work.ev` with
    /// its unshifted factors in `work.ldl`: `K (delta', -lambda') =
    /// -dF/dtau` for the residual `F = (grad V - J^T lambda, C)` at fixed
    /// frames and multipliers. Along the feeding and loading paths `F` is
    /// affine in `tau` (the feeding scales enter the link lengths, so the
    /// position rows and their Jacobian, linearly, at zero gravity; the load
    /// enters gravity linearly, hanging or not; the contact rows do not
    /// move), so `dF/dtau = F(tau + 1) - F(tau)` exactly: one residual
    /// evaluation (no Hessian), where a central difference took two, and no
    /// difference step's rounding. The both cups' target path turns the
    /// plate's target along a geodesic, not affine: a central difference.
    fn tangent(&self, state: &State, path: &impl Fn(f64) -> Param, tau: f64, work: &mut Work) {
        let mut dr = std::mem::take(&mut work.path_residual);
        if path(tau).front.is_none() {
            let (ev, cev, residual) = (&mut work.trial, &mut work.cev_trial, &mut work.residual_trial);
            self.evaluate_with::<false>(
                &state.frames,
                &state.lambda,
                path(tau + 1.0),
                &work.contacts,
                ev,
                cev,
                residual,
            );
            for ((d, next), now) in dr.iter_mut().zip(&work.residual_trial).zip(&work.residual) {
                *d = next - now;
            }
            let next = work.trial.constraints.iter().chain(&work.cev_trial.gaps);
            let now = work.ev.constraints.iter().chain(&work.cev.gaps);
            for ((d, next), now) in work.cons.iter_mut().zip(next).zip(now) {
                *d = next - now;
            }
        } else {
            // The both cups' target turns along a geodesic: its rows are not
            // affine in `tau`, a central difference takes their derivative.
            const H: f64 = 1e-6;
            dr.fill(0.0);
            work.cons.fill(0.0);
            for (sign, at) in [(1.0, tau + H), (-1.0, tau - H)] {
                let (ev, cev, residual) = (&mut work.trial, &mut work.cev_trial, &mut work.residual_trial);
                self.evaluate_with::<false>(&state.frames, &state.lambda, path(at), &work.contacts, ev, cev, residual);
                for (d, r) in dr.iter_mut().zip(&work.residual_trial) {
                    *d += sign * r / (2.0 * H);
                }
                for (d, c) in work.cons.iter_mut().zip(work.trial.constraints.iter().chain(&work.cev_trial.gaps)) {
                    *d += sign * c / (2.0 * H);
                }
            }
        }
        work.solve(&dr);
        work.path_residual = dr;
        work.tangent.copy_from_slice(&work.step);
        work.lambda_tangent.copy_from_slice(&work.dual);
    }

    /// Follows `path(tau)`, `tau` from 0 to 1, from a start that is
    /// minimized at `tau = 0` first; ends at a stable equilibrium at 1.
    fn continuation(
        &self,
        solver: &Solver,
        state: &mut State,
        path: &impl Fn(f64) -> Param,
        stage: Stage,
        work: &mut Work,
    ) -> Result<f64, SolveError> {
        let o = &solver.options;
        let mut residual = self.settle_reporting(solver, state, path(0.0), 0.0, stage, work)?;
        let mut tau = 0.0;
        self.tangent(state, path, tau, work);
        let mut dtau = (FIRST_TURN / sup(&work.tangent)).min(1.0);
        let mut steps = 0;
        while tau < 1.0 {
            steps += 1;
            if steps > o.max_steps {
                return Err(fail(solver, stage, state, residual, StopReason::StepLimit));
            }
            dtau = dtau.min(1.0 - tau);
            // The step's start, and the prediction (the corrector's start is
            // the newton run's own `frames_saved`): buffers of `work`, no allocation.
            work.frames_start.clone_from(&state.frames);
            work.lambda_start.clone_from(&state.lambda);
            moved(&work.frames_start, &work.tangent, dtau, &mut state.frames);
            for (l, d) in state.lambda.iter_mut().zip(&work.lambda_tangent) {
                *l += dtau * d;
            }
            let last = tau + dtau >= 1.0;
            let tolerance = if last { o.tolerance } else { o.path_tolerance };
            let budget = Budget { max_iter: o.max_corrector_iterations, tolerance, leash: o.jump_tolerance };
            let (res, out) = self.newton(solver, state, path(tau + dtau), budget, work);
            if out == Ok(true) && within(&state.frames, &work.frames_saved, o.jump_tolerance) {
                tau = if last { 1.0 } else { tau + dtau };
                state.steps += 1;
                residual = res;
                if tau < 1.0 {
                    self.tangent(state, path, tau, work);
                }
                dtau *= 2.0;
                continue;
            }
            if o.deadline.expired() {
                return Err(fail(solver, stage, state, res, StopReason::TimeLimit));
            }
            state.frames.clone_from(&work.frames_start);
            state.lambda.clone_from(&work.lambda_start);
            if dtau > o.min_step {
                dtau *= 0.5;
                // Re-evaluate and re-factor at the saved point for the tangent.
                let refactor = Budget { max_iter: 0, tolerance: f64::INFINITY, leash: f64::INFINITY };
                if let (res, Err(reason)) = self.newton(solver, state, path(tau), refactor, work) {
                    return Err(fail(solver, stage, state, res, reason));
                }
                self.tangent(state, path, tau, work);
                continue;
            }
            // Still failing at the smallest step: the branch ends here (a fold).
            let at = tau;
            tau = (tau + dtau).min(1.0);
            let escaped;
            (residual, escaped) = self.settle(solver, state, path(tau), stage, work)?;
            let jump_rad = distance(&state.frames, &work.frames_start);
            if let Some(side) = escaped {
                state.events.push(Event::Bifurcation { stage, at, side, jump_rad });
            } else if jump_rad > o.snap_threshold {
                state.events.push(Event::Snap { stage, at, jump_rad });
            }
            state.steps += 1;
            dtau = o.tuning.step_after_event;
            if tau < 1.0 {
                self.tangent(state, path, tau, work);
            }
        }
        Ok(residual)
    }
}

/// The gravity path at the body's lengths: the load fraction `t` from 0
/// to 1, hanging from the front cup when `hang` says so.
fn load_path(hang: Option<Hanging>) -> impl Fn(f64) -> Param {
    move |t| Param { load: t, hang, ..Param::FULL }
}

/// The error for a Newton run that stopped for `reason`.
fn fail(solver: &Solver, stage: Stage, state: &State, residual: f64, reason: StopReason) -> SolveError {
    match solver.options.deadline.check() {
        Some(halt) if reason == StopReason::TimeLimit => {
            SolveError::Stopped { halt, iterations: state.iterations, residual }
        }
        _ => SolveError::NotConverged { stage, iterations: state.iterations, residual, reason },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body3::body3::tests::bent_and_hanging;
    use crate::robot::Robot;
    use crate::scene::Plane3;

    /// [`Body3::tangent`]'s premise: along the feeding and gravity paths
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
            let (mut ev, mut cev) = (Eval3::new(&body), ContactEval::default());
            let mut r = vec![0.0; 3 * body.links()];
            body.evaluate_with::<false>(&frames, &lambda, param, &contact, &mut ev, &mut cev, &mut r);
            r.extend(ev.constraints);
            r.extend(cev.gaps);
            r
        };
        let feed = body.feed_path();
        let paths: [&dyn Fn(f64) -> Param; 3] = [&feed, &load_path(None), &load_path(Some(hang))];
        const H: f64 = 1e-5;
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
