//! The simulator: constrained accelerations by Gauss' principle, projection
//! onto the constraints, energies, rest, and the step dispatch.

use super::backward_euler::EulerScratch;
use super::mass::{self, Factors, Placed};
use super::midpoint::MidpointScratch;
use super::rk4::Rk4Scratch;
use super::rows;
use super::stability::PowerScratch;
use super::{Integrator, Motion, StepError};
use crate::body::Body;
use crate::cantilever::Cantilever;
use crate::chain::Chain;
use crate::linalg::{solve_symmetric, DenseLdl};
use crate::statics::{Evaluation, StaticSystem};

/// A system of chains that the simulator can move.
pub trait Multibody: StaticSystem {
    /// The chains with the offset of each one's coordinates in `q`.
    fn chains(&self) -> Vec<(&Chain, usize)>;
}

impl Multibody for Body {
    fn chains(&self) -> Vec<(&Chain, usize)> {
        vec![(self.chain_a(), 0), (self.chain_b(), self.chain_a().len())]
    }
}

impl Multibody for Cantilever {
    fn chains(&self) -> Vec<(&Chain, usize)> {
        vec![(self.chain(), 0)]
    }
}

/// The simulator: a system, its scratch space, and the dynamics. Every
/// buffer is allocated here, once: no step allocates.
pub struct Simulator<'a, S: Multibody> {
    pub(super) sys: &'a S,
    pub(super) chains: Vec<Placed<'a>>,
    pub(super) n: usize,
    pub(super) m: usize,
    pub(super) ev: Evaluation,
    pub(super) factors: Factors,
    gauss: Gauss,
    /// One chain's damper or velocity terms (n).
    work: Vec<f64>,
    /// The accelerations that [`Simulator::at_rest`] checks (n).
    rest: Vec<f64>,
    pub(super) rk4: Rk4Scratch,
    pub(super) midpoint: MidpointScratch,
    pub(super) euler: EulerScratch,
    pub(super) power: PowerScratch,
    /// Fraction of gravity applied (1 unless a scenario ramps it).
    pub load: f64,
}

/// Scratch of the constraint forces and projections, sized by the
/// constraint count `m`. Matrices with a row per coordinate are interleaved
/// like the Jacobian (entry `(i, r)` at `i * m + r`), `m x m` ones row-major.
#[derive(Clone, Debug)]
struct Gauss {
    /// `Y = A^-1 J^T` for the factored `A` (`M` or an iteration matrix).
    y: Vec<f64>,
    /// The Schur complement `S = J Y`.
    schur: Vec<f64>,
    /// `J J^T`, the projection's metric.
    normal: Vec<f64>,
    /// A target `J x = target` or a residual to remove (m).
    target: Vec<f64>,
    /// The right-hand side of a small solve, then its solution (m).
    rhs: Vec<f64>,
    /// Factors of the last small solve.
    ldl: DenseLdl,
}

impl Gauss {
    fn new(n: usize, m: usize) -> Gauss {
        Gauss {
            y: vec![0.0; n * m],
            schur: vec![0.0; m * m],
            normal: vec![0.0; m * m],
            target: vec![0.0; m],
            rhs: vec![0.0; m],
            ldl: DenseLdl::new(m),
        }
    }
}

/// Solves the small symmetric system `s x = b` (`m x m` row-major, `m` the
/// length of `b`) in place with the scratch `ldl`. Every `m x m` solve of
/// the simulator goes through here; `s` is positive definite (a Schur
/// complement of a positive definite matrix, or `J J^T` of a full-rank `J`),
/// so no pivot is near zero unless the constraints are degenerate.
fn solve_small(s: &[f64], b: &mut [f64], ldl: &mut DenseLdl) {
    solve_symmetric(s, b.len(), b, ldl, 0.0);
}

/// Most Newton iterations of the position projection.
const PROJECTION_ITERATIONS: usize = 20;

impl<'a, S: Multibody> Simulator<'a, S> {
    /// A simulator for `sys`.
    pub fn new(sys: &'a S) -> Simulator<'a, S> {
        let chains = sys.chains();
        let (n, m) = (sys.dim(), sys.rows());
        Simulator {
            sys,
            factors: Factors::new(&chains),
            chains,
            n,
            m,
            ev: Evaluation::new(n, m),
            gauss: Gauss::new(n, m),
            work: vec![0.0; n],
            rest: vec![0.0; n],
            rk4: Rk4Scratch::new(n),
            midpoint: MidpointScratch::new(n),
            euler: EulerScratch::new(n),
            power: PowerScratch::new(n),
            load: 1.0,
        }
    }

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.n
    }

    pub(super) fn evaluate(&mut self, q: &[f64]) {
        // StaticSystem::evaluate clears `ev` itself.
        self.sys.evaluate(q, self.load, &mut self.ev);
    }

    /// Factors each chain's `M` at the point last evaluated (its
    /// trigonometry is reused), O(n).
    pub(super) fn factor_mass(&mut self) -> Result<(), StepError> {
        self.factors
            .factor_mass(&self.chains, &self.ev.cos, &self.ev.sin)
            .map_err(|index| StepError::NonPositivePivot { index })
    }

    /// Solves with the factors last computed (`M` or an iteration matrix), in place.
    pub(super) fn solve(&self, x: &mut [f64]) {
        self.factors.solve(&self.chains, x);
    }

    /// `y = M x` at the point last evaluated, O(n).
    pub(super) fn mass_product(&self, x: &[f64], y: &mut [f64]) {
        mass::multiply(&self.chains, &self.ev.cos, &self.ev.sin, x, y);
    }

    /// `out = J x` (m) with the evaluated Jacobian, in one pass over its rows.
    fn jacobian_product(&self, x: &[f64], out: &mut [f64]) {
        rows::transposed_product(&self.ev.jacobian[..self.n * self.m], x, out);
    }

    /// `Y = A^-1 J^T` by one sweep of `m` right-hand sides with the factored
    /// `A`, and `S = J Y`.
    pub(super) fn schur(&mut self) {
        let (n, m) = (self.n, self.m);
        // J^T laid out row by row is the Jacobian itself.
        self.gauss.y.copy_from_slice(&self.ev.jacobian[..n * m]);
        self.factors.solve_columns(&self.chains, &mut self.gauss.y, m);
        rows::gram(&self.ev.jacobian[..n * m], &self.gauss.y, m, &mut self.gauss.schur);
    }

    /// Sets the target of [`Simulator::enforce`] to `-J x`.
    pub(super) fn target_opposite_of(&mut self, x: &[f64]) {
        let mut target = std::mem::take(&mut self.gauss.target);
        self.jacobian_product(x, &mut target);
        target.iter_mut().for_each(|t| *t = -*t);
        self.gauss.target = target;
    }

    /// Corrects `x` (already `A^-1 f`) by `Y lambda` so that `J x` reaches
    /// the target set before, with `Y` and `S` from [`Simulator::schur`].
    pub(super) fn enforce(&mut self, x: &mut [f64]) {
        let (n, m) = (self.n, self.m);
        if m == 0 {
            return;
        }
        let mut rhs = std::mem::take(&mut self.gauss.rhs);
        self.jacobian_product(x, &mut rhs);
        for (r, t) in rhs.iter_mut().zip(&self.gauss.target) {
            *r = t - *r;
        }
        solve_small(&self.gauss.schur, &mut rhs, &mut self.gauss.ldl);
        rows::add_product(&self.gauss.y[..n * m], &rhs, x);
        self.gauss.rhs = rhs;
    }

    /// Generalized forces `Q = -grad V - D v - h` at the last evaluated `q`.
    pub(super) fn forces(&mut self, v: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = -self.ev.gradient[i];
        }
        for (chain, offset) in &self.chains {
            let k = chain.len();
            let vs = &v[*offset..*offset + k];
            chain.damping_forces(vs, &mut self.work[..k]);
            for i in 0..k {
                out[offset + i] += self.work[i];
            }
            chain.velocity_terms_from_trig(
                &self.ev.cos[*offset..*offset + k],
                &self.ev.sin[*offset..*offset + k],
                vs,
                &mut self.work[..k],
            );
            for i in 0..k {
                out[offset + i] -= self.work[i];
            }
        }
    }

    /// Constrained accelerations `a(q, v)` (rad/s^2) into `a`.
    pub fn accelerations(&mut self, q: &[f64], v: &[f64], a: &mut [f64]) -> Result<(), StepError> {
        self.evaluate(q);
        self.factor_mass()?;
        self.forces(v, a);
        self.solve(a);
        self.schur();
        let m = self.m;
        for r in 0..m {
            self.gauss.target[r] = -(0..self.n).map(|i| self.ev.curvature[i * m + r] * v[i] * v[i]).sum::<f64>();
        }
        self.enforce(a);
        Ok(())
    }

    /// Largest constraint violation at `q` (m or rad); NaN if a constraint is
    /// not finite (`f64::max` alone would drop a NaN).
    pub fn violation(&mut self, q: &[f64]) -> f64 {
        self.evaluate(q);
        let c = &self.ev.constraints[..self.m];
        match super::all_finite(c) {
            true => c.iter().fold(0.0f64, |a, c| a.max(c.abs())),
            false => f64::NAN,
        }
    }

    /// Projects positions onto `C = 0` and velocities onto `J v = 0` by the
    /// least (Euclidean) change, `dx = -J^T (J J^T)^-1 r`: the corrections
    /// are at the level of the integrator's drift, so the metric does not
    /// matter and this one needs no factorization. Returns the position
    /// violation left (m or rad).
    pub fn project(&mut self, motion: &mut Motion) -> Result<f64, StepError> {
        let m = self.m;
        if m == 0 {
            return Ok(0.0);
        }
        let mut violation = f64::INFINITY;
        let mut current = false;
        let mut iterations = 0;
        for iteration in 1..=PROJECTION_ITERATIONS {
            violation = self.violation(&motion.q);
            current = true;
            if violation < 1e-13 {
                break;
            }
            self.gauss.target.copy_from_slice(&self.ev.constraints[..m]);
            self.least_change(&mut motion.q);
            iterations = iteration;
            current = false;
        }
        // Written so that a NaN violation fails too.
        if !(violation < 1e-10) {
            return Err(StepError::Projection { iterations, violation });
        }
        // The loop usually ends having just evaluated at the projected point.
        if !current {
            violation = self.violation(&motion.q);
        }
        let mut jv = std::mem::take(&mut self.gauss.target);
        self.jacobian_product(&motion.v, &mut jv);
        self.gauss.target = jv;
        self.least_change(&mut motion.v);
        Ok(violation)
    }

    /// Moves `q` toward `C = 0` by the least change, as the first Newton
    /// step of [`Simulator::project`] would, from the evaluation at `q - dq`
    /// for a small `dq` (where backward Euler stopped): `C(q) = C + J dq`
    /// and `J(q) = J` up to `O(|dq|)` relative, which changes the step by far
    /// less than the projection's tolerance, and saves the evaluation at `q`.
    /// The projection still checks the result.
    pub(super) fn least_change_from(&mut self, q: &mut [f64], dq: &[f64]) {
        if self.m == 0 {
            return;
        }
        let mut target = std::mem::take(&mut self.gauss.target);
        self.jacobian_product(dq, &mut target);
        target.iter_mut().zip(&self.ev.constraints).for_each(|(t, c)| *t += c);
        self.gauss.target = target;
        self.least_change(q);
    }

    /// `x -= J^T (J J^T)^-1 r` with the evaluated Jacobian and `r` the target.
    fn least_change(&mut self, x: &mut [f64]) {
        let (n, m) = (self.n, self.m);
        let jac = &self.ev.jacobian;
        rows::gram(&jac[..n * m], &jac[..n * m], m, &mut self.gauss.normal);
        let mu = &mut self.gauss.rhs;
        mu.copy_from_slice(&self.gauss.target);
        solve_small(&self.gauss.normal, mu, &mut self.gauss.ldl);
        // x - j mu and x + j (-mu) round alike.
        mu.iter_mut().for_each(|u| *u = -*u);
        rows::add_product(&jac[..n * m], mu, x);
    }

    /// Checks that `motion` satisfies the constraints in position and velocity
    /// (to 1e-9 m, rad and rad/s): the initial state of a run must.
    pub fn check(&mut self, motion: &Motion) -> Result<(), StepError> {
        if motion.q.len() != self.n || motion.v.len() != self.n {
            return Err(StepError::Inconsistent { violation: f64::INFINITY });
        }
        let position = self.violation(&motion.q);
        let mut jv = std::mem::take(&mut self.gauss.target);
        self.jacobian_product(&motion.v, &mut jv);
        let velocity = jv.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        self.gauss.target = jv;
        let violation = position.max(velocity);
        if !(violation <= 1e-9) {
            return Err(StepError::Inconsistent { violation });
        }
        Ok(())
    }

    /// Kinetic plus potential energy (J).
    pub fn energy(&mut self, motion: &Motion) -> (f64, f64) {
        self.evaluate(&motion.q);
        let potential = self.ev.energy;
        let (cos, sin) = (&self.ev.cos, &self.ev.sin);
        let kinetic = self
            .chains
            .iter()
            .map(|(c, o)| {
                let range = *o..o + c.len();
                c.kinetic_energy_from_trig(&cos[range.clone()], &sin[range.clone()], &motion.v[range])
            })
            .sum();
        (kinetic, potential)
    }

    /// Whether the body is at rest: every rate below `rate` (rad/s) and every
    /// constrained acceleration below `100 rate` (rad/s^2), so it stays there.
    pub fn at_rest(&mut self, motion: &Motion, rate: f64) -> Result<bool, StepError> {
        if motion.v.iter().any(|v| v.abs() > rate) {
            return Ok(false);
        }
        let mut a = std::mem::take(&mut self.rest);
        let result = self.accelerations(&motion.q, &motion.v, &mut a);
        let rest = a.iter().all(|x| x.abs() < 100.0 * rate);
        self.rest = a;
        result.map(|()| rest)
    }

    /// Integrates until [`Simulator::at_rest`] (rates below 1e-9 rad/s) or
    /// `max_time` (s), with
    /// gravity raised linearly over the first `ramp` seconds (0: all at once,
    /// as the paper; a slow ramp follows the quasi-static loading path of the
    /// static solver where a sudden load would overshoot into another
    /// equilibrium). Returns the time (s) and steps to rest, or `None`.
    pub fn run_to_rest(
        &mut self,
        motion: &mut Motion,
        dt: f64,
        integrator: Integrator,
        ramp: f64,
        max_time: f64,
    ) -> Result<Option<(f64, usize)>, StepError> {
        let mut t = 0.0;
        let mut steps = 0;
        while t < max_time {
            self.load = if ramp > 0.0 { ((t + dt) / ramp).min(1.0) } else { 1.0 };
            self.step(motion, dt, integrator)?;
            t += dt;
            steps += 1;
            if self.load == 1.0 && self.at_rest(motion, 1e-9)? {
                return Ok(Some((t, steps)));
            }
        }
        Ok(None)
    }

    /// One step of `dt` (s), projected onto the constraints.
    /// Returns the constraint violation left (m or rad).
    pub fn step(&mut self, motion: &mut Motion, dt: f64, integrator: Integrator) -> Result<f64, StepError> {
        match integrator {
            Integrator::Explicit => self.rk4(motion, dt)?,
            Integrator::Implicit => self.backward_euler(motion, dt)?,
            Integrator::Midpoint => self.midpoint(motion, dt)?,
        }
        self.project(motion)
    }
}
