//! The simulator: constrained accelerations by Gauss' principle, projection
//! onto the constraints, energies, rest, and the step dispatch.

use super::backward_euler::Scratch;
use super::mass::{cholesky, cholesky_solve};
use super::{Integrator, Motion, StepError};
use crate::body::Body;
use crate::cantilever::Cantilever;
use crate::chain::Chain;
use crate::kkt::{solve_small_symmetric, MAX_CONSTRAINTS};
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

/// The simulator: a system, its scratch space, and the dynamics.
pub struct Simulator<'a, S: Multibody> {
    pub(super) sys: &'a S,
    pub(super) chains: Vec<(&'a Chain, usize)>,
    pub(super) n: usize,
    pub(super) m: usize,
    pub(super) ev: Evaluation,
    pub(super) mass: Vec<Vec<f64>>,
    pub(super) raw: Vec<Vec<f64>>,
    pub(super) rhs: Vec<f64>,
    pub(super) y: Vec<f64>,
    pub(super) work: Vec<f64>,
    pub(super) scratch: Scratch,
    /// Fraction of gravity applied (1 unless a scenario ramps it).
    pub load: f64,
}

impl<'a, S: Multibody> Simulator<'a, S> {
    /// A simulator for `sys`.
    pub fn new(sys: &'a S) -> Simulator<'a, S> {
        let chains = sys.chains();
        let (n, m) = (sys.dim(), sys.constraint_count());
        Simulator {
            sys,
            mass: chains.iter().map(|(c, _)| vec![0.0; c.len() * c.len()]).collect(),
            raw: chains.iter().map(|(c, _)| vec![0.0; c.len() * c.len()]).collect(),
            chains,
            n,
            m,
            ev: Evaluation::new(n, m),
            rhs: vec![0.0; n],
            y: vec![0.0; n * MAX_CONSTRAINTS],
            work: vec![0.0; n],
            scratch: Scratch::default(),
            load: 1.0,
        }
    }

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.n
    }

    pub(super) fn evaluate(&mut self, q: &[f64]) {
        self.ev.clear();
        self.sys.evaluate(q, self.load, &mut self.ev);
    }

    /// Factors each chain's block of `M(q)` in place (Cholesky, lower
    /// triangle), `q` being the point last evaluated (its trigonometry is reused).
    pub(super) fn factor_mass(&mut self, q: &[f64]) -> Result<(), StepError> {
        debug_assert_eq!(q.len(), self.n);
        for (b, (chain, offset)) in self.chains.iter().enumerate() {
            let k = chain.len();
            let block = &mut self.mass[b];
            let range = *offset..*offset + k;
            chain.mass_matrix_from_trig(&self.ev.cos[range.clone()], &self.ev.sin[range], block);
            cholesky(block, k).map_err(|i| StepError::NonPositivePivot { index: offset + i })?;
        }
        Ok(())
    }

    /// Solves the factored block-diagonal system in place.
    pub(super) fn solve_mass(&self, x: &mut [f64]) {
        for (b, (chain, offset)) in self.chains.iter().enumerate() {
            let k = chain.len();
            cholesky_solve(&self.mass[b], k, &mut x[*offset..*offset + k]);
        }
    }

    /// `Y = M^-1 J^T` (interleaved like the Jacobian) and `S = J Y`.
    pub(super) fn schur(&mut self) -> [[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS] {
        let (n, m) = (self.n, self.m);
        let mut s = [[0.0; MAX_CONSTRAINTS]; MAX_CONSTRAINTS];
        for r in 0..m {
            for i in 0..n {
                self.work[i] = self.ev.jacobian[i * MAX_CONSTRAINTS + r];
            }
            let mut col = std::mem::take(&mut self.work);
            self.solve_mass(&mut col);
            for i in 0..n {
                self.y[i * MAX_CONSTRAINTS + r] = col[i];
            }
            self.work = col;
        }
        for a in 0..m {
            for b in 0..m {
                s[a][b] =
                    (0..n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + a] * self.y[i * MAX_CONSTRAINTS + b]).sum();
            }
        }
        s
    }

    /// Corrects `x` (already `M^-1 f`) by `Y lambda` so that `J x = target`.
    pub(super) fn enforce(
        &mut self,
        x: &mut [f64],
        target: [f64; MAX_CONSTRAINTS],
        s: &[[f64; MAX_CONSTRAINTS]; MAX_CONSTRAINTS],
    ) {
        let (n, m) = (self.n, self.m);
        if m == 0 {
            return;
        }
        let mut rhs = [0.0; MAX_CONSTRAINTS];
        for r in 0..m {
            let jx: f64 = (0..n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + r] * x[i]).sum();
            rhs[r] = target[r] - jx;
        }
        let lambda = solve_small_symmetric(s, rhs, m);
        for i in 0..n {
            for r in 0..m {
                x[i] += self.y[i * MAX_CONSTRAINTS + r] * lambda[r];
            }
        }
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
        self.factor_mass(q)?;
        let mut f = std::mem::take(&mut self.rhs);
        self.forces(v, &mut f);
        a.copy_from_slice(&f);
        self.rhs = f;
        self.solve_mass(a);
        let s = self.schur();
        let mut gamma = [0.0; MAX_CONSTRAINTS];
        for r in 0..self.m {
            gamma[r] = -(0..self.n).map(|i| self.ev.curvature[i * MAX_CONSTRAINTS + r] * v[i] * v[i]).sum::<f64>();
        }
        self.enforce(a, gamma, &s);
        Ok(())
    }

    /// Largest constraint violation at `q` (m or rad).
    pub fn violation(&mut self, q: &[f64]) -> f64 {
        self.evaluate(q);
        self.ev.constraints[..self.m].iter().fold(0.0f64, |a, c| a.max(c.abs()))
    }

    /// Projects positions onto `C = 0` and velocities onto `J v = 0` by the
    /// least (Euclidean) change, `dx = -J^T (J J^T)^-1 r`: the corrections
    /// are at the level of the integrator's drift, so the metric does not
    /// matter and this one needs no factorization. Returns the position
    /// violation left (m or rad).
    pub fn project(&mut self, motion: &mut Motion) -> Result<f64, StepError> {
        if self.m == 0 {
            return Ok(0.0);
        }
        let mut violation = f64::INFINITY;
        let mut current = false;
        for _ in 0..20 {
            violation = self.violation(&motion.q);
            current = true;
            if violation < 1e-13 {
                break;
            }
            let target = self.ev.constraints;
            self.least_change(&mut motion.q, target);
            current = false;
        }
        if violation >= 1e-10 {
            return Err(StepError::Projection { violation });
        }
        // The loop usually ends having just evaluated at the projected point.
        if !current {
            violation = self.violation(&motion.q);
        }
        let mut jv = [0.0; MAX_CONSTRAINTS];
        for r in 0..self.m {
            jv[r] = (0..self.n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + r] * motion.v[i]).sum::<f64>();
        }
        self.least_change(&mut motion.v, jv);
        Ok(violation)
    }

    /// `x -= J^T (J J^T)^-1 r` with the evaluated Jacobian.
    fn least_change(&self, x: &mut [f64], r: [f64; MAX_CONSTRAINTS]) {
        let (n, m) = (self.n, self.m);
        let jac = &self.ev.jacobian;
        let mut jjt = [[0.0; MAX_CONSTRAINTS]; MAX_CONSTRAINTS];
        for a in 0..m {
            for b in 0..m {
                jjt[a][b] = (0..n).map(|i| jac[i * MAX_CONSTRAINTS + a] * jac[i * MAX_CONSTRAINTS + b]).sum();
            }
        }
        let mu = solve_small_symmetric(&jjt, r, m);
        for i in 0..n {
            for a in 0..m {
                x[i] -= jac[i * MAX_CONSTRAINTS + a] * mu[a];
            }
        }
    }

    /// Checks that `motion` satisfies the constraints in position and velocity
    /// (to 1e-9 m, rad and rad/s): the initial state of a run must.
    pub fn check(&mut self, motion: &Motion) -> Result<(), StepError> {
        let position = self.violation(&motion.q);
        let velocity = (0..self.m)
            .map(|r| (0..self.n).map(|i| self.ev.jacobian[i * MAX_CONSTRAINTS + r] * motion.v[i]).sum::<f64>().abs())
            .fold(0.0f64, f64::max);
        let violation = position.max(velocity);
        if !(violation <= 1e-9) || motion.q.len() != self.n || motion.v.len() != self.n {
            return Err(StepError::Inconsistent { violation });
        }
        Ok(())
    }

    /// Kinetic plus potential energy (J).
    pub fn energy(&mut self, motion: &Motion) -> (f64, f64) {
        self.evaluate(&motion.q);
        let potential = self.ev.energy;
        let kinetic = self
            .chains
            .iter()
            .map(|(c, o)| c.kinetic_energy(&motion.q[*o..*o + c.len()], &motion.v[*o..*o + c.len()]))
            .sum();
        (kinetic, potential)
    }

    /// Whether the body is at rest: every rate below `rate` (rad/s) and every
    /// constrained acceleration below `100 rate` (rad/s^2), so it stays there.
    pub fn at_rest(&mut self, motion: &Motion, rate: f64) -> Result<bool, StepError> {
        if motion.v.iter().any(|v| v.abs() > rate) {
            return Ok(false);
        }
        let mut a = vec![0.0; self.n];
        self.accelerations(&motion.q, &motion.v, &mut a)?;
        Ok(a.iter().all(|x| x.abs() < 100.0 * rate))
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
