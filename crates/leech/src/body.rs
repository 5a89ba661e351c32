//! The LEeCH body: two chains joined at the endpoint plate.
//!
//! Chain A is the centre tube (stiffness `k`, mass `m` per element); chain B
//! lumps the two side tubes (`2k`, `2m`, `2d`). Chain A is clamped at `p0`,
//! chain B at `p0 + b nu(phi_0)`, both along `phi_0`. The payload `ms` hangs at
//! chain B's tip. The coordinates are `q = (phi^A_1..phi^A_nA, phi^B_1..phi^B_nB)`.
//!
//! The endpoint plate is a weld (docs/model.md section 6: an equivalent, better conditioned
//! form of the paper's parallel, distance and perpendicular constraints):
//!
//! ```text
//! C_xy = p_B - p_A - c nu(phi^A_nA) = 0        (m)
//! C_phi = phi^A_nA - phi^B_nB = 0              (rad)
//! ```
//!
//! with `p_A`, `p_B` the chains' tips and `c` the tip spacing (m). It selects the
//! branch `Delta . nu(phi^A_nA) = +c` (chain B on the right of chain A). Its
//! Jacobian is dense in `q` but its Hessians are diagonal:
//!
//! ```text
//! dC_xy/dphi^A_j = -l_j e'(phi^A_j) - [j = nA] c e(phi^A_nA)
//! dC_xy/dphi^B_j =  l_j e'(phi^B_j)
//! d2C_xy/dphi^A_j^2 = l_j e(phi^A_j) - [j = nA] c e'(phi^A_nA)
//! d2C_xy/dphi^B_j^2 = -l_j e(phi^B_j)
//! ```
//!
//! # Default solve path
//!
//! The real robot feeds its tubes from equal lengths. [`Body::solve`] does the
//! same at `g = 0`: it starts from the body with both tubes at the shorter
//! length (the longer chain's links scaled down), where the unloaded shape is
//! unique (straight for `b = c`, an S for `b != c`), and follows the family as
//! the longer tube is fed to its length; then it raises gravity from 0 to `g`
//! (load continuation). Folds and bifurcations on both paths are reported as
//! [`Event`](crate::statics::Event)s. The two stages are also callable one
//! by one ([`Body::feed_in`], [`Body::load_in`]): the fed state does not
//! depend on the joint stiffness but through its multipliers ([`Fed`]), so
//! a sweep over shape parameters feeds each pair of lengths once.

use crate::chain::{Block, Chain};
use crate::geom::right_normal;
use crate::statics::{
    Constraints, Equilibrium, Evaluation, Iterate, Path, PathTerms, Potential, Row, RowKind, Scratch, SolveError,
    Solver, Stage, StaticSystem,
};

/// Two chains welded at the endpoint plate, under gravity.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    a: Chain,
    b: Chain,
    tip_spacing: f64,
    gravity: f64,
    moment_scale: f64,
}

impl Body {
    /// Joins chain `a` (centre tube) and chain `b` (side pair, carrying the
    /// payload as its tip mass) with an endpoint plate of width `tip_spacing`
    /// (m), under `gravity` (m/s^2).
    pub fn new(a: Chain, b: Chain, tip_spacing: f64, gravity: f64) -> Body {
        let moment_scale = a.nominal_stiffness().max(b.nominal_stiffness());
        Body { a, b, tip_spacing, gravity, moment_scale }
    }

    /// The centre tube.
    pub fn chain_a(&self) -> &Chain {
        &self.a
    }

    /// The lumped side tubes.
    pub fn chain_b(&self) -> &Chain {
        &self.b
    }

    /// Gravity (m/s^2).
    pub fn gravity(&self) -> f64 {
        self.gravity
    }

    /// Tip spacing `c` (m).
    pub fn tip_spacing(&self) -> f64 {
        self.tip_spacing
    }

    /// Splits `q` into chain A's and chain B's angles.
    pub fn split<'q>(&self, q: &'q [f64]) -> (&'q [f64], &'q [f64]) {
        q.split_at(self.a.len())
    }

    /// The endpoint: chain A's tip (m).
    pub fn endpoint(&self, q: &[f64]) -> [f64; 2] {
        self.a.tip(self.split(q).0)
    }

    /// The endpoint plate's angle: chain A's last link (rad).
    pub fn endpoint_angle(&self, q: &[f64]) -> f64 {
        q[self.a.len() - 1]
    }

    /// Constraint values `(C_x, C_y, C_phi)` (m, m, rad).
    pub fn constraints(&self, q: &[f64]) -> [f64; 3] {
        let (qa, qb) = self.split(q);
        let (pa, pb) = (self.a.tip(qa), self.b.tip(qb));
        let nu = right_normal(qa[qa.len() - 1]);
        [
            pb[0] - pa[0] - self.tip_spacing * nu[0],
            pb[1] - pa[1] - self.tip_spacing * nu[1],
            qa[qa.len() - 1] - qb[qb.len() - 1],
        ]
    }

    /// Potential energy, springs and gravity (J).
    pub fn energy(&self, q: &[f64]) -> f64 {
        let (qa, qb) = self.split(q);
        self.a.energy(qa, self.gravity) + self.b.energy(qb, self.gravity)
    }

    /// Smallest bending radius of either chain (m), see [`Chain::min_bend_radius`].
    pub fn min_bend_radius(&self, q: &[f64]) -> f64 {
        let (qa, qb) = self.split(q);
        self.a.min_bend_radius(qa).min(self.b.min_bend_radius(qb))
    }

    /// A state of `other` (the same robot with other tube lengths) carried
    /// over to this body chain by chain ([`Chain::carry_over`]): the start of
    /// a warm solve after feeding the tubes.
    pub fn carry_over(&self, other: &Body, q: &[f64]) -> Vec<f64> {
        let (qa, qb) = other.split(q);
        let mut out = self.a.carry_over(qa);
        out.extend(self.b.carry_over(qb));
        out
    }

    /// The straight configuration (both chains along the clamp).
    pub fn straight(&self) -> Vec<f64> {
        let mut q = self.a.straight();
        q.extend(self.b.straight());
        q
    }

    /// Writes the potential at gravity `load * gravity` with link lengths
    /// scaled by `scale` (A, B) over the chains' entries of `ev` (energy,
    /// gradient, banded Hessian), with the links' trigonometry.
    pub(crate) fn potential_with(&self, q: &[f64], gravity: f64, load: f64, scale: [f64; 2], ev: &mut Evaluation) {
        let (na, n) = (self.a.len(), q.len());
        let (qa, qb) = self.split(q);
        let ea = self.a.evaluate_block(qa, gravity, load, scale[0], Block::of(ev, 0..na));
        let eb = self.b.evaluate_block(qb, gravity, load, scale[1], Block::of(ev, na..n));
        // No spring couples A's last link and B's first (if B has links).
        if let Some(between) = ev.hessian_off.get_mut(na - 1) {
            *between = 0.0;
        }
        ev.energy = ea + eb;
    }

    /// The weld's rows (the first three of `ev`), Jacobian and curvature
    /// with link lengths scaled by `scale` (A, B), from the trigonometry in
    /// `ev`, for the chains' coordinates `q`: every entry of these rows in
    /// the chains' columns is written.
    pub(crate) fn weld_with(&self, q: &[f64], scale: [f64; 2], ev: &mut Evaluation) {
        let na = self.a.len();
        let n = q.len();
        let (ca, sa) = (ev.cos[na - 1], ev.sin[na - 1]);
        let c = self.tip_spacing;
        let m = ev.rows();
        // The columns' pass sums the links too: p_B - p_A without a second
        // pass over each chain for its tip.
        let links = self.weld_columns(scale, &ev.cos, &ev.sin, m, &mut ev.jacobian, Some(&mut ev.curvature));
        let (ja, jb) = (self.a.first_joint(), self.b.first_joint());
        ev.constraints[..WELD_ROWS].copy_from_slice(&[
            jb[0] - ja[0] + links[0] - c * sa,
            jb[1] - ja[1] + links[1] + c * ca,
            q[na - 1] - q[n - 1],
        ]);
        let last_a = (na - 1) * m;
        ev.jacobian[last_a] -= c * ca;
        ev.jacobian[last_a + 1] -= c * sa;
        ev.curvature[last_a] += c * sa;
        ev.curvature[last_a + 1] -= c * ca;
        ev.jacobian[last_a + 2] = 1.0;
        ev.jacobian[(n - 1) * m + 2] = -1.0;
    }

    /// The position rows' Jacobian columns `-+ l_j s e'(phi_j)` for link
    /// lengths times `s` (A, B) and, if asked, their curvature `-+ l_j s e(phi_j)`
    /// (the tip spacing's terms left out), the angle row's zero Jacobian
    /// (but at its two ends) and curvature with them; returns `sum -+ l_j s e(phi_j)`.
    fn weld_columns(
        &self,
        s: [f64; 2],
        cos: &[f64],
        sin: &[f64],
        m: usize,
        jac: &mut [f64],
        curvature: Option<&mut [f64]>,
    ) -> [f64; 2] {
        let na = self.a.len();
        let mut sum = [0.0; 2];
        // Per chain, and the curvature's test out of the loops.
        let (jac_a, jac_b) = jac.split_at_mut(na * m);
        let (trig_a, trig_b) = ((&cos[..na], &sin[..na]), (&cos[na..], &sin[na..]));
        match curvature {
            Some(curvature) => {
                let (curvature_a, curvature_b) = curvature.split_at_mut(na * m);
                chain_columns(self.a.lengths(), -s[0], trig_a, m, jac_a, Some(curvature_a), &mut sum);
                chain_columns(self.b.lengths(), s[1], trig_b, m, jac_b, Some(curvature_b), &mut sum);
            }
            None => {
                chain_columns(self.a.lengths(), -s[0], trig_a, m, jac_a, None, &mut sum);
                chain_columns(self.b.lengths(), s[1], trig_b, m, jac_b, None, &mut sum);
            }
        }
        sum
    }

    /// The equilibrium on the default path: tubes fed from equal lengths at
    /// `g = 0`, then gravity raised to `g` (see the module doc). Scratch
    /// space comes from the thread's spare ([`Scratch::with_spare`]).
    ///
    /// ```
    /// use leech::prelude::*;
    /// let robot = Robot::builtin();
    /// let body = robot.body(0.20, 0.18).unwrap();
    /// let eq = body.solve(&Solver::default()).unwrap();
    /// assert!(eq.stable);
    /// assert!(body.constraints(&eq.q).iter().all(|c| c.abs() < 1e-12));
    /// ```
    pub fn solve(&self, solver: &Solver) -> Result<Equilibrium, SolveError> {
        Scratch::with_spare(self, |ws| self.solve_in(solver, ws))
    }

    /// [`Body::solve`] with caller-provided scratch space.
    pub fn solve_in(&self, solver: &Solver, ws: &mut Scratch) -> Result<Equilibrium, SolveError> {
        let fed = self.feed_in(solver, ws)?;
        self.load_in(solver, fed, ws)
    }

    /// The first stage of [`Body::solve_in`]: the tubes fed from equal
    /// lengths at `g = 0`. No gravity acts, so the potential is the springs'
    /// alone and scales with the joint stiffness `k`: the same shape is the
    /// fed state of every body that differs only in `k`
    /// ([`Fed::for_stiffness`]).
    pub fn feed_in(&self, solver: &Solver, ws: &mut Scratch) -> Result<Fed, SolveError> {
        let mut state = Iterate::new(self.straight());
        let (la, lb) = (self.a.tube_length(), self.b.tube_length());
        let feed = Feeding::new(self, la, lb);
        let residual = if la == lb {
            solver.minimize(&feed, &mut state, 1.0, Stage::Feed, ws)?
        } else {
            solver.continuation(&feed, &mut state, 0.0, Stage::Feed, ws)?
        };
        Ok(Fed { state, residual, moment_scale: self.moment_scale })
    }

    /// The second stage of [`Body::solve_in`]: gravity raised from 0 to `g`
    /// from the fed state (of this body, or of one differing only in `k`,
    /// carried over by [`Fed::for_stiffness`]).
    pub fn load_in(&self, solver: &Solver, fed: Fed, ws: &mut Scratch) -> Result<Equilibrium, SolveError> {
        self.load_through(solver, fed, &[], ws, &mut |_, _| {})
    }

    /// [`Body::load_in`] that also hands over, on the way, the loaded states
    /// of bodies differing from this one only in `k`: a body whose joint
    /// stiffnesses are `1 / s` times this one's (`s <= 1`, so stiffer) has the
    /// potential `(k / s) V + g U = (1 / s) (k V + s g U)`, the same
    /// equilibria as this body at the gravity fraction `s`, its multipliers
    /// `1 / s` times larger. Each fraction in `stops` (ascending, in `(0, 1]`)
    /// is landed on and passed to `at_stop(index, angles)`; then this body's
    /// own loaded equilibrium is returned. Only the step sizes differ from
    /// loading each body itself, so the states agree where the load path is
    /// smooth (to the tolerance). Past a fold each path settles from its own
    /// bracket of it, as close as `SolverOptions::min_step`; the sweep's
    /// fresh check measures how little that moves the states
    /// ([`crate::sweep`]).
    pub fn load_through(
        &self,
        solver: &Solver,
        fed: Fed,
        stops: &[f64],
        ws: &mut Scratch,
        at_stop: &mut dyn FnMut(usize, &[f64]),
    ) -> Result<Equilibrium, SolveError> {
        let Fed { mut state, mut residual, .. } = fed;
        if self.gravity == 0.0 {
            (0..stops.len()).for_each(|i| at_stop(i, &state.q));
        } else {
            let mut hand = |i: usize, it: &Iterate, _: f64| at_stop(i, &it.q);
            residual = solver.continuation_through(self, &mut state, 0.0, stops, Stage::Load, ws, &mut hand)?;
        }
        Ok(solver.finish(self, state, residual, ws))
    }

    /// The equilibrium reached from a given state (warm start) with gravity on,
    /// as sweeps and planners that follow the actuation history use it.
    pub fn solve_from(&self, solver: &Solver, q0: &[f64], ws: &mut Scratch) -> Result<Equilibrium, SolveError> {
        solver.warm_start(self, q0, ws)
    }
}

/// One chain's part of [`Body::weld_columns`], for links of `lengths` times
/// `factor` (the scale, negative for chain A), adding to `sum`.
#[inline(always)]
fn chain_columns(
    lengths: &[f64],
    factor: f64,
    (cos, sin): (&[f64], &[f64]),
    m: usize,
    jac: &mut [f64],
    curvature: Option<&mut [f64]>,
    sum: &mut [f64; 2],
) {
    // By the links' rows of `m` entries (the weld's three rows first): no
    // index to check in the loop.
    let links = lengths.iter().zip(cos).zip(sin).map(|((l, co), si)| (l * factor, *co, *si));
    match curvature {
        Some(curvature) => {
            for ((ls, co, si), (j, c)) in links.zip(jac.chunks_exact_mut(m).zip(curvature.chunks_exact_mut(m))) {
                j[..3].copy_from_slice(&[-ls * si, ls * co, 0.0]);
                c[..3].copy_from_slice(&[-ls * co, -ls * si, 0.0]);
                sum[0] += ls * co;
                sum[1] += ls * si;
            }
        }
        None => {
            for ((ls, co, si), j) in links.zip(jac.chunks_exact_mut(m)) {
                j[..2].copy_from_slice(&[-ls * si, ls * co]);
                sum[0] += ls * co;
                sum[1] += ls * si;
            }
        }
    }
}

/// Rows of the endpoint weld: `C_x`, `C_y` (m) and `C_phi` (rad).
pub(crate) const WELD_ROWS: usize = 3;

impl Potential for Body {
    fn dim(&self) -> usize {
        self.a.len() + self.b.len()
    }

    fn blocks(&self) -> Vec<usize> {
        vec![self.a.len(), self.b.len()]
    }

    fn moment_scale(&self) -> f64 {
        self.moment_scale
    }

    /// `t` is the fraction of gravity applied.
    fn potential(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        self.potential_with(q, self.gravity, t, [1.0; 2], ev);
    }
}

impl Constraints for Body {
    fn rows(&self) -> usize {
        WELD_ROWS
    }

    fn row(&self, r: usize) -> Row {
        // Positions in element lengths, the angle in radians.
        let scale = if r < 2 { self.a.lengths()[0] } else { 1.0 };
        Row { kind: RowKind::Equality, scale }
    }

    fn constraints(&self, q: &[f64], _t: f64, ev: &mut Evaluation) {
        self.weld_with(q, [1.0; 2], ev);
    }
}

impl StaticSystem for Body {
    /// Potential and weld write every entry of `ev` (no free coordinates,
    /// the weld's rows only, all rigid): the clear, a pass over the
    /// Jacobian and curvature per evaluation, is left out.
    fn evaluate(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        self.potential(q, t, ev);
        Constraints::constraints(self, q, t, ev);
        // Rigid rows (a scratch may come from a system with compliant ones).
        ev.compliance.fill(0.0);
    }

    fn side_measure(&self, q: &[f64], dq: &[f64]) -> f64 {
        let (qa, _) = self.split(q);
        let nu = right_normal(self.a.clamp_angle());
        self.a.tip_jacobian(qa).iter().zip(dq).map(|(col, d)| (col[0] * nu[0] + col[1] * nu[1]) * d).sum()
    }
}

/// The load path: gravity raised from 0 (`t = 0`) to `g` (`t = 1`).
impl Path for Body {
    fn path(&self, _q: &[f64], _t: f64, ev: &Evaluation, out: &mut PathTerms) {
        let na = self.a.len();
        let (out_a, out_b) = out.gradient.split_at_mut(na);
        self.a.load_gradient(&ev.cos[..na], self.gravity, out_a);
        self.b.load_gradient(&ev.cos[na..], self.gravity, out_b);
    }
    fn discrete_stiffness(&self) -> f64 {
        self.a.discrete_stiffness(self.gravity).max(self.b.discrete_stiffness(self.gravity))
    }
}

/// A body's fed state at `g = 0` ([`Body::feed_in`]), before gravity.
#[derive(Clone, Debug)]
pub struct Fed {
    state: Iterate,
    residual: f64,
    /// The largest joint stiffness (N m/rad) of the body that was fed.
    moment_scale: f64,
}

impl Fed {
    /// The fed state of a body differing from the fed one only in its joint
    /// stiffnesses, all in one ratio (the same robot at another shape
    /// parameter), whose largest is `moment_scale` (N m/rad). At `g = 0` the
    /// potential is `k V(q)` and the weld's multipliers are forces, so the
    /// same `q` is the equilibrium with the multipliers scaled by the ratio
    /// of the stiffnesses; the scaled residual does not change. Only the
    /// rounding differs from feeding that body itself (about 1e-15 rad).
    pub fn for_stiffness(&self, moment_scale: f64) -> Fed {
        let mut state = self.state.clone();
        state.scale_potential(moment_scale / self.moment_scale);
        Fed { state, residual: self.residual, moment_scale }
    }
}

/// The feeding homotopy at `g = 0`: the longer chain's links are scaled so
/// that its tube length goes from the shorter tube's length (`t = 0`) to its
/// own (`t = 1`).
struct Feeding<'a> {
    body: &'a Body,
    start_a: f64,
    start_b: f64,
    first_step: f64,
}

impl<'a> Feeding<'a> {
    /// The link scale factors (A, B) at `t`.
    fn scale(&self, t: f64) -> [f64; 2] {
        let rate = self.rate();
        [self.start_a + t * rate[0], self.start_b + t * rate[1]]
    }

    /// `d scale / dt` (A, B).
    fn rate(&self) -> [f64; 2] {
        [1.0 - self.start_a, 1.0 - self.start_b]
    }

    fn new(body: &'a Body, la: f64, lb: f64) -> Feeding<'a> {
        let short = la.min(lb);
        let flexible = |chain: &Chain, length: f64| {
            let links = chain.lengths().iter().sum::<f64>();
            let root = length - links;
            (short - root) / links
        };
        // The constant-curvature bend (LB - LA)/w estimates how far the path
        // turns; about 0.7 rad per step keeps the predictor in Newton's basin.
        let [pa, pb] = [body.a.clamp_point(), body.b.clamp_point()];
        let width = 0.5 * ((pb[0] - pa[0]).hypot(pb[1] - pa[1]) + body.tip_spacing);
        let bend = (la - lb).abs() / width;
        Feeding {
            body,
            start_a: flexible(&body.a, la),
            start_b: flexible(&body.b, lb),
            first_step: (0.7 / bend).min(1.0),
        }
    }
}

impl Potential for Feeding<'_> {
    fn dim(&self) -> usize {
        self.body.dim()
    }

    fn blocks(&self) -> Vec<usize> {
        self.body.blocks()
    }

    fn moment_scale(&self) -> f64 {
        self.body.moment_scale()
    }

    fn potential(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        self.body.potential_with(q, 0.0, 0.0, self.scale(t), ev);
    }
}

impl Constraints for Feeding<'_> {
    fn rows(&self) -> usize {
        self.body.rows()
    }

    fn row(&self, r: usize) -> Row {
        self.body.row(r)
    }

    fn constraints(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        self.body.weld_with(q, self.scale(t), ev);
    }
}

impl StaticSystem for Feeding<'_> {
    /// As [`Body`]'s: every entry written, no clear.
    fn evaluate(&self, q: &[f64], t: f64, ev: &mut Evaluation) {
        self.potential(q, t, ev);
        Constraints::constraints(self, q, t, ev);
        ev.compliance.fill(0.0);
    }

    fn side_measure(&self, q: &[f64], dq: &[f64]) -> f64 {
        self.body.side_measure(q, dq)
    }
}

/// The links grow at the rate `1 - start` along `t`: only the weld's
/// position rows move (at `g = 0` the potential does not depend on lengths).
impl Path for Feeding<'_> {
    fn path(&self, _q: &[f64], _t: f64, ev: &Evaluation, out: &mut PathTerms) {
        let dc = self.body.weld_columns(self.rate(), &ev.cos, &ev.sin, WELD_ROWS, &mut out.jacobian, None);
        out.constraints.copy_from_slice(&[dc[0], dc[1], 0.0]);
    }

    fn first_step(&self) -> f64 {
        self.first_step
    }
}
