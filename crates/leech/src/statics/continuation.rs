//! Following a one-parameter family of problems `t in [from, 1]`: a tangent
//! predictor and a Newton corrector, with step control and the detection of
//! folds (snaps) and bifurcations.

use super::iterate::Iterate;
use super::newton::{sup_norm, transposed_product, Budget};
use super::outcome::{Event, SolveError, Stage, StopReason};
use super::scratch::Scratch;
use super::system::Path;
use super::Solver;

impl Solver {
    /// Tangent of the solution path `(dq/dt, dlambda/dt)` at a converged
    /// point: `ws.current` evaluated there and its unshifted factors in
    /// `ws.kkt`. Differentiating `grad V - J^T lambda = 0`, `C = 0` along `t`:
    ///
    /// ```text
    /// H q' + J^T y = -(d(grad V)/dt - (dJ/dt)^T lambda),   lambda' = -y,
    /// J q' - c y = -(dC/dt + (dc/dt) lambda)
    /// ```
    ///
    /// (a compliant row holds `C + c lambda = 0`, [`Evaluation::compliance`]).
    ///
    /// [`Evaluation::compliance`]: super::Evaluation::compliance
    pub(super) fn tangent<S: Path + ?Sized>(&self, sys: &S, it: &Iterate, t: f64, ws: &mut Scratch) {
        ws.path_terms(sys, &it.q, t);
        transposed_product(&ws.path.gradient, &ws.path.jacobian, &it.lambda, &mut ws.tangent);
        ws.tangent.iter_mut().for_each(|x| *x = -*x);
        let rates = ws.path.constraints.iter().zip(&ws.path.compliance).zip(&it.lambda);
        for (rhs, ((dc, dcompliance), lambda)) in ws.rhs.iter_mut().zip(rates) {
            *rhs = -(dc + dcompliance * lambda);
        }
        ws.kkt.solve(&ws.tangent, &ws.rhs, &mut ws.step, &mut ws.lambda_tangent);
        ws.tangent.copy_from_slice(&ws.step);
        ws.lambda_tangent.iter_mut().for_each(|x| *x = -*x);
    }

    /// Follows the family `t in [from, 1]` from a converged, stable `it`
    /// at `t = from`, ending at a stable equilibrium at `t = 1`. Returns the
    /// final scaled residual.
    pub fn continuation<S: Path + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        from: f64,
        stage: Stage,
        ws: &mut Scratch,
    ) -> Result<f64, SolveError> {
        self.continuation_through(sys, it, from, &[], stage, ws, &mut |_, _, _| {})
    }

    /// [`Solver::continuation`] that also lands on each of `stops`
    /// (ascending, in `(from, 1]`; the path goes on to `1` after the last),
    /// converged there to the final tolerance as at `t = 1`, and hands each
    /// landing to `at_stop(index, iterate, scaled residual)` before going on.
    /// The steps between stops are those of a path that ends at the stop, so
    /// with no stops this is [`Solver::continuation`] step for step. A
    /// family whose members at the stops are other problems' end points
    /// (the load path of the softest of several bodies that differ only in
    /// stiffness passes through the others' loaded states) is followed once
    /// for all of them.
    #[allow(clippy::too_many_arguments)]
    pub fn continuation_through<S: Path + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        from: f64,
        stops: &[f64],
        stage: Stage,
        ws: &mut Scratch,
        at_stop: &mut dyn FnMut(usize, &Iterate, f64),
    ) -> Result<f64, SolveError> {
        assert!(ws.fits(sys), "scratch sized for another system");
        assert!(stops.windows(2).all(|w| w[0] < w[1]), "stops ascending");
        // The stop the path is heading for (1 once the listed ones are passed).
        let mut next = 0;
        let target = |next: usize| stops.get(next).copied().unwrap_or(1.0).min(1.0);
        // Converge at the start and get factors for the first tangent.
        let mut residual = self.minimize(sys, it, from, stage, ws)?;
        let mut t = from;
        self.tangent(sys, it, t, ws);
        // The first step: what the system allows, on a stiff path shortened so
        // that the predictor turns no coordinate by more than `first_step_angle`.
        let tuning = &self.options.tuning;
        let mut dt = sys.first_step().min(1.0 - from);
        if sys.discrete_stiffness() > tuning.stiff_path {
            dt = dt.min(sys.first_turn(tuning) / sup_norm(&ws.tangent));
        }
        let mut steps = 0;
        while t < 1.0 {
            steps += 1;
            if steps > self.options.max_steps {
                return Err(self.fail(stage, it, residual, StopReason::StepLimit));
            }
            let stop = target(next);
            dt = dt.min(stop - t);
            let out = self.corrector(sys, it, t, dt, stop, ws);
            if out.stable() && sys.within(&it.q, &ws.q_predicted, self.options.jump_tolerance) {
                t = if dt >= stop - t { stop } else { t + dt };
                it.steps += 1;
                residual = out.residual;
                if t == stop && next < stops.len() {
                    at_stop(next, it, residual);
                    next += 1;
                }
                if t < 1.0 {
                    self.tangent(sys, it, t, ws);
                }
                dt *= 2.0;
                continue;
            }
            // An unstable landing counts as a failure too: halving the step
            // then brackets the fold or bifurcation to within `min_step`.
            if let Some(halt) = self.options.deadline.check() {
                return Err(SolveError::Stopped { halt, iterations: it.iterations, residual: out.residual });
            }
            it.q.copy_from_slice(&ws.q_saved);
            it.lambda.copy_from_slice(&ws.lambda_saved);
            if dt > self.options.min_step {
                dt *= 0.5;
                // Re-evaluate and re-factor at the saved point for the tangent.
                let refactor = Budget { max_iter: 0, tolerance: f64::INFINITY, leash: f64::INFINITY };
                let again = self.newton(sys, it, t, refactor, ws);
                if let Err(reason) = again.result {
                    return Err(self.fail(stage, it, again.residual, reason));
                }
                self.tangent(sys, it, t, ws);
                continue;
            }
            (t, residual) = self.cross(sys, it, t, dt, stop, stage, ws)?;
            if t == stop && next < stops.len() {
                at_stop(next, it, residual);
                next += 1;
            }
            dt = self.options.tuning.step_after_event;
            if t < 1.0 {
                self.tangent(sys, it, t, ws);
            }
        }
        Ok(residual)
    }

    /// One predictor-corrector step from `t` to `t + dt`, saving the start
    /// in `ws.q_saved`, `ws.lambda_saved` and the prediction in `ws.q_predicted`.
    fn corrector<S: Path + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        dt: f64,
        stop: f64,
        ws: &mut Scratch,
    ) -> super::newton::Newton {
        ws.q_saved.copy_from_slice(&it.q);
        ws.lambda_saved.copy_from_slice(&it.lambda);
        sys.retract(&ws.q_saved, &ws.tangent, dt, &mut it.q);
        for (l, d) in it.lambda.iter_mut().zip(&ws.lambda_tangent) {
            *l += dt * d;
        }
        ws.q_predicted.copy_from_slice(&it.q);
        let tolerance = if t + dt >= stop { self.options.tolerance } else { self.options.path_tolerance };
        let budget =
            Budget { max_iter: self.options.max_corrector_iterations, tolerance, leash: self.options.jump_tolerance };
        self.newton(sys, it, t + dt, budget, ws)
    }

    /// Still failing at the smallest step: the stable branch ends or turns
    /// unstable here. Settles from the last stable state at the new
    /// parameter, as damped dynamics would: leaving an unstable symmetric
    /// state is a pitchfork, a large jump a snap at a fold. Returns the new
    /// parameter (at most `stop`) and residual.
    #[allow(clippy::too_many_arguments)]
    fn cross<S: Path + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        at: f64,
        dt: f64,
        stop: f64,
        stage: Stage,
        ws: &mut Scratch,
    ) -> Result<(f64, f64), SolveError> {
        let t = (at + dt).min(stop);
        let (residual, escaped) = self.settle(sys, it, t, stage, ws)?;
        let jump_rad = sys.distance(&it.q, &ws.q_saved);
        // A settle that stays close was a hard step, not a snap.
        if let Some(side) = escaped {
            it.events.push(Event::Bifurcation { stage, at, side, jump_rad });
        } else if jump_rad > self.options.snap_threshold {
            it.events.push(Event::Snap { stage, at, jump_rad });
        }
        it.steps += 1;
        Ok((t, residual))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;

    /// The predictor's tangent agrees with a finite difference of converged solutions.
    #[test]
    fn tangent_matches_finite_difference_of_solutions() {
        let robot = Robot::builtin();
        let body = robot.body(0.30, 0.28).unwrap();
        let solver = Solver::default();
        let mut ws = Scratch::for_system(&body);
        let base = body.solve(&solver).unwrap();
        for t in [0.3, 0.7] {
            let mut it = Iterate::new(base.q.clone());
            solver.minimize(&body, &mut it, t, Stage::Load, &mut ws).unwrap();
            solver.tangent(&body, &it, t, &mut ws);
            let tangent = ws.tangent.clone();
            let h = 1e-6;
            let mut ahead = it.clone();
            solver.minimize(&body, &mut ahead, t + h, Stage::Load, &mut ws).unwrap();
            for i in 0..tangent.len() {
                let fd = (ahead.q[i] - it.q[i]) / h;
                assert!(
                    (fd - tangent[i]).abs() < 1e-4 * (1.0 + fd.abs()),
                    "t {t} i {i}: fd {fd} tangent {}",
                    tangent[i]
                );
            }
        }
    }
}
