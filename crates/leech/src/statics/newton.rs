//! Newton's method on the KKT conditions of the working set, with inertia
//! correction, Levenberg damping, a trust radius and merit-based acceptance
//! (see the module doc of [`crate::statics`]).

use super::evaluation::Evaluation;
use super::iterate::{Iterate, Verdict};
use super::outcome::StopReason;
use super::scratch::{Inertia, Scratch};
use super::system::{Row, RowKind, StaticSystem};
use super::Solver;

/// Outcome of one Newton run.
#[derive(Clone, Copy, Debug)]
pub(super) struct Newton {
    pub residual: f64,
    pub result: Result<bool, StopReason>,
}

impl Newton {
    fn failed(residual: f64, reason: StopReason) -> Newton {
        Newton { residual, result: Err(reason) }
    }

    /// Whether it converged to a stable equilibrium.
    pub fn stable(&self) -> bool {
        self.result == Ok(true)
    }
}

/// Limits of one Newton run: iterations, tolerance, and how far (rad, sup
/// norm) the iterates may wander from the starting point.
#[derive(Clone, Copy, Debug)]
pub(super) struct Budget {
    pub max_iter: usize,
    pub tolerance: f64,
    pub leash: f64,
}

pub(super) fn sup_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |a, x| a.max(x.abs()))
}

/// `out = base - J_A^T lambda` for an interleaved Jacobian of stride `m`
/// (inactive rows carry zero multipliers, so they drop out).
pub(super) fn transposed_product(base: &[f64], jac: &[f64], lambda: &[f64], out: &mut [f64]) {
    match lambda.len() {
        0 => out.copy_from_slice(base),
        // The clamped body's three weld rows: unrolled, as the solver's hot path.
        3 => transposed_product_fixed::<3>(base, jac, lambda, out),
        m => {
            for ((o, b), j) in out.iter_mut().zip(base).zip(jac.chunks_exact(m)) {
                *o = j.iter().zip(lambda).fold(*b, |acc, (a, l)| acc - a * l);
            }
        }
    }
}

/// [`transposed_product`] for `M` rows known at compile time (the same sums in the same order).
fn transposed_product_fixed<const M: usize>(base: &[f64], jac: &[f64], lambda: &[f64], out: &mut [f64]) {
    let lambda: &[f64; M] = lambda.try_into().expect("M multipliers");
    for ((o, b), j) in out.iter_mut().zip(base).zip(jac.chunks_exact(M)) {
        let mut acc = *b;
        for r in 0..M {
            acc -= j[r] * lambda[r];
        }
        *o = acc;
    }
}

/// Points and multipliers closer than this (relative to their size, at
/// least one) start the same working-set run: the ends of one run's cycle
/// met again differed by a few units of rounding (1e-15), a different start
/// by far more (0.4).
const SAME_START: f64 = 1e-12;

/// The shift (times `k`) of the least-change solves: with `H + 1e6 k I`
/// the KKT step is, to about 1e-6, the one that changes the point least
/// for a given change of the rows (`-J^T (J J^T)^-1 g`), and its dual part
/// the least-squares multipliers for a given force.
const LEAST_CHANGE_SHIFT: f64 = 1e6;

/// What a trial step found.
enum Trial {
    Accepted,
    Rejected,
    TooLong,
    /// An inactive inequality row blocks the step where it starts: it
    /// joins the working set, and the point stays.
    Joined,
}

/// What an iteration's step did.
enum Taken {
    /// The point moved, with this Levenberg shift.
    Moved(f64),
    /// A blocking row joined the working set; the point stayed.
    Joined,
}

impl Solver {
    /// The budget of a free minimization (no leash).
    pub(super) fn free_budget(&self) -> Budget {
        Budget {
            max_iter: self.options.max_minimization_iterations,
            tolerance: self.options.tolerance,
            leash: f64::INFINITY,
        }
    }

    /// The scaled sup norm of `(r, g_A)`, `r = grad V - J^T lambda` of `ev`
    /// and `g = C + c lambda` the rows' values ([`Evaluation::row_value`]).
    fn residual_norm(ev: &Evaluation, rows: &[Row], it: &Iterate, k: f64, r: &[f64]) -> f64 {
        let mut norm = sup_norm(r) / k;
        for (row, spec) in rows.iter().enumerate() {
            if it.active[row] {
                norm = norm.max((ev.row_value(row, it.lambda[row]) / spec.scale).abs());
            }
        }
        norm
    }

    /// Scaled Euclidean norm of `(grad V - J^T lambda, g_A)`, for step acceptance.
    /// `r` is `grad V - J^T lambda` of `ev`.
    fn residual_l2(ev: &Evaluation, rows: &[Row], r: &[f64], lambda: &[f64], active: &[bool], k: f64) -> f64 {
        let s = r.iter().fold(0.0, |s, ri| s + (ri / k) * (ri / k));
        Self::row_squares(s, ev, rows, lambda, active)
    }

    /// `start + sum (g_r / s_r)^2` over the active rows, `g_r` the row's
    /// value with multiplier `lambda_r`.
    fn row_squares(start: f64, ev: &Evaluation, rows: &[Row], lambda: &[f64], active: &[bool]) -> f64 {
        let terms = rows.iter().enumerate().filter(|(r, _)| active[*r]);
        terms.fold(start, |acc, (r, spec)| acc + (ev.row_value(r, lambda[r]) / spec.scale).powi(2))
    }

    /// The merit: `V/k`, plus each active compliant row's spring energy
    /// `C^2/(2 c)/k` (the compliant equilibrium minimizes `V + sum C^2/(2c)`),
    /// plus the exact penalty `rho |C_R / s|_1` of the rigid active rows `R`.
    pub(super) fn merit(ev: &Evaluation, rows: &[Row], active: &[bool], rho: f64, k: f64) -> f64 {
        let mut springs = 0.0;
        let mut penalty = 0.0;
        for (r, spec) in rows.iter().enumerate().filter(|(r, _)| active[*r]) {
            let (c, compliance) = (ev.constraints[r], ev.compliance[r]);
            if compliance > 0.0 {
                springs += c * c / (2.0 * compliance);
            } else {
                penalty += (c / spec.scale).abs();
            }
        }
        (ev.energy + springs) / k + rho * penalty
    }

    /// The merit's slope along `step` ([`Solver::merit`]) where the step,
    /// `cut` of a whole Newton step, restores that part of the rigid rows'
    /// linearization (`J dq = -cut C` there): the
    /// energy's and the springs' `(grad V + sum_c (C/c) J_c) . dq`, over `k`,
    /// minus the penalty; `descent` is `grad V . dq`.
    #[allow(clippy::too_many_arguments)]
    fn merit_slope(
        ev: &Evaluation,
        rows: &[Row],
        active: &[bool],
        step: &[f64],
        descent: f64,
        (rho, cut): (f64, f64),
        k: f64,
    ) -> f64 {
        let m = rows.len();
        let mut slope = descent;
        for (r, spec) in rows.iter().enumerate().filter(|(r, _)| active[*r]) {
            let (c, compliance) = (ev.constraints[r], ev.compliance[r]);
            if compliance > 0.0 {
                let along: f64 = step.iter().enumerate().map(|(i, d)| ev.jacobian[i * m + r] * d).sum();
                slope += c / compliance * along;
            } else {
                slope -= cut * rho * k * (c / spec.scale).abs();
            }
        }
        slope / k
    }

    /// Factors the Lagrangian Hessian of `ws.current` with multipliers
    /// `lambda`, adding the smallest shift of the sequence
    /// `first_shift k growth^i` (`i < max_shift_tries`) that makes the
    /// reduced Hessian positive definite. Returns the unshifted inertia and
    /// the shift used (infinite when none does).
    ///
    /// The search starts where the last one of this Newton run ended
    /// (`ws.shift_index`) and walks down while the next smaller
    /// shift still gives a minimum (the reduced Hessian grows with the
    /// shift, so that is the smallest), else up: the shift needed changes
    /// little from one iteration to the next, and a search from the
    /// sequence's start cost as many factorizations as the shift's place in
    /// it (six a call on the soft body lying on a floor).
    pub(super) fn factor(&self, k: f64, it: &Iterate, ws: &mut Scratch) -> (Inertia, f64) {
        let tuning = &self.options.tuning;
        Self::lagrangian(ws, &it.lambda);
        let tiny = tuning.tiny_pivot * k;
        ws.dual = 0.0;
        let mut first = ws.factor_kkt(0.0, &it.active, tiny);
        // Dependent contact rows (a rigid piece resting at three points on
        // one line) leave a zero pivot that no shift of H removes: the
        // inequality rows are then regularized in the matrix alone.
        let inequality = |r: usize| it.active[r] && ws.rows[r].kind == RowKind::Inequality;
        if tuning.block_at_rows && first == Inertia::Singular && (0..ws.rows.len()).any(inequality) {
            ws.dual = tuning.dual_regularization / k;
            first = ws.refactor_kkt(0.0, &it.active, tiny);
        }
        if first == Inertia::Minimum {
            return (first, 0.0);
        }
        if tuning.max_shift_tries == 0 {
            return (first, f64::INFINITY);
        }
        // Powers of the growth: exact for the default (8), as the repeated
        // product the search once took.
        let shift = |i: usize| tuning.first_shift * k * tuning.shift_growth.powi(i as i32);
        let minimum = |i: usize, ws: &mut Scratch| ws.refactor_kkt(shift(i), &it.active, tiny) == Inertia::Minimum;
        let mut i = ws.shift_index.min(tuning.max_shift_tries - 1);
        if minimum(i, ws) {
            while i > 0 && minimum(i - 1, ws) {
                i -= 1;
            }
            // Again after a walk down that ended on a shift too small.
            if i > 0 {
                minimum(i, ws);
            }
        } else {
            loop {
                i += 1;
                if i == tuning.max_shift_tries {
                    return (first, f64::INFINITY);
                }
                if minimum(i, ws) {
                    break;
                }
            }
        }
        ws.shift_index = i;
        (first, shift(i))
    }

    /// The Lagrangian Hessian `hess V - sum_r lambda_r hess C_r` of
    /// `ws.current` into `ws.lagrangian_*` (the constraint Hessians are diagonal).
    pub(super) fn lagrangian(ws: &mut Scratch, lambda: &[f64]) {
        let ev = &ws.current;
        if ws.multiplied {
            // The system evaluated the Lagrangian's Hessian itself.
            ws.lagrangian_diag.copy_from_slice(&ev.hessian_diag);
            ws.lagrangian_corner.copy_from_slice(&ev.hessian_corner);
            return;
        }
        transposed_product(&ev.hessian_diag, &ev.curvature, lambda, &mut ws.lagrangian_diag);
        ws.lagrangian_corner.copy_from_slice(&ev.hessian_corner);
        let (chains, free, m) = (ev.hessian_diag.len(), ev.free(), lambda.len());
        for a in 0..free {
            let curvature = &ev.curvature[(chains + a) * m..(chains + a + 1) * m];
            let entry = &mut ws.lagrangian_corner[a * free + a];
            *entry = curvature.iter().zip(lambda).fold(*entry, |acc, (c, l)| acc - c * l);
        }
    }

    fn out_of_time(&self) -> bool {
        self.options.deadline.expired()
    }

    /// Newton's method from `it` at parameter `t` on the working set, then
    /// the active-set test of the inequality rows, repeated until both hold.
    /// Leaves `ws.current` evaluated at the final point and, when converged,
    /// the KKT factors of its unshifted Lagrangian Hessian.
    pub(super) fn newton<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        budget: Budget,
        ws: &mut Scratch,
    ) -> Newton {
        it.fit_rows(&ws.rows);
        it.verdict = None;
        // Each run searches its shifts afresh: its answer depends on its start alone.
        ws.shift_index = 0;
        let inequalities = ws.rows.iter().filter(|r| r.kind == RowKind::Inequality).count();
        let most_changes = self.options.tuning.active_set_changes_per_row * inequalities;
        let mut changes = 0;
        ws.run_starts.clear();
        let mut skipped = false;
        loop {
            if it.active.iter().filter(|a| **a).count() > ws.kkt.active_capacity() {
                return Newton::failed(f64::INFINITY, StopReason::TooManyActiveRows);
            }
            // A run that starts where an earlier one did (the same working
            // set, the same point and multipliers to rounding: both ends of
            // converged runs) goes the same way: the working sets cycle, and
            // would until a limit stops them. Whole turns of the cycle that
            // no limit stops are skipped, their iterations and changes
            // counted, and the runs go on from there as they would have
            // (the soft body lying on a floor cycled through four working
            // sets 23 times, 7000 iterations, before the limit on changes).
            if !skipped && inequalities > 0 {
                let counts = (it.iterations, changes);
                if let Some((iterations, changed)) = ws.run_starts.repeated(it, ws.shift_index, SAME_START, counts) {
                    let (turn_iterations, turn_changes) = (it.iterations - iterations, changes - changed);
                    // A turn without iterations is stopped by the changes alone.
                    let left = self.options.max_iterations.saturating_sub(it.iterations);
                    let turns = ((most_changes - changes) / turn_changes)
                        .min(left.checked_div(turn_iterations).unwrap_or(usize::MAX));
                    it.iterations += turns * turn_iterations;
                    changes += turns * turn_changes;
                    skipped = true;
                }
            }
            let out = self.newton_on_working_set(sys, it, t, budget, ws);
            // A working set on which no step descends may hold a row that
            // pulls: released, the rest may descend (the active-set rule,
            // without waiting for a convergence that cannot come).
            let stuck = out.result == Err(StopReason::NoDescent) && inequalities > 0;
            if stuck && self.release_pulling(it, ws) {
                changes += 1;
                if changes > most_changes {
                    return Newton::failed(out.residual, StopReason::ActiveSetCycling);
                }
                continue;
            }
            if out.result.is_err() || inequalities == 0 || !self.update_active_set(it, ws, budget.tolerance) {
                if let Ok(stable) = out.result {
                    it.verdict = Some(Verdict { fingerprint: it.fingerprint(), t, stable, energy: ws.current.energy });
                }
                return out;
            }
            changes += 1;
            if changes > most_changes {
                return Newton::failed(out.residual, StopReason::ActiveSetCycling);
            }
        }
    }

    /// Releases the active inequality row that pulls hardest (`lambda_r < 0`),
    /// or else activates the inactive one violated most (`C_r < 0` beyond the
    /// tolerance). Returns whether the set changed. One row at a time: two
    /// violated rows of neighbouring points can be nearly parallel, and
    /// activating both at once makes the step ill-posed (large opposite forces).
    fn update_active_set(&self, it: &mut Iterate, ws: &Scratch, tolerance: f64) -> bool {
        if self.release_pulling(it, ws) {
            return true;
        }
        let inequality = |r: &usize| ws.rows[*r].kind == RowKind::Inequality;
        let rows = 0..ws.rows.len();
        let violation = |r: &usize| ws.current.constraints[*r] / ws.rows[*r].scale;
        let violated = rows.filter(inequality).filter(|r| !it.active[*r] && violation(r) < -tolerance);
        if let Some(r) = violated.min_by(|a, b| violation(a).total_cmp(&violation(b))) {
            it.active[r] = true;
            return true;
        }
        false
    }

    /// Releases the active inequality row that pulls hardest (`lambda_r < 0`);
    /// returns whether there was one.
    fn release_pulling(&self, it: &mut Iterate, ws: &Scratch) -> bool {
        let inequality = |r: &usize| ws.rows[*r].kind == RowKind::Inequality;
        let pulling = (0..ws.rows.len()).filter(inequality).filter(|r| it.active[*r] && it.lambda[*r] < 0.0);
        if let Some(r) = pulling.min_by(|a, b| it.lambda[*a].total_cmp(&it.lambda[*b])) {
            it.active[r] = false;
            it.lambda[r] = 0.0;
            return true;
        }
        false
    }

    /// Newton's method with the working set fixed.
    fn newton_on_working_set<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        budget: Budget,
        ws: &mut Scratch,
    ) -> Newton {
        let Budget { max_iter, tolerance, leash } = budget;
        let tuning = &self.options.tuning;
        let k = sys.moment_scale();
        ws.q_predicted.copy_from_slice(&it.q);
        sys.evaluate_at(&it.q, &it.lambda, t, &mut ws.current);
        self.estimate_multipliers(sys, it, t, ws);
        let mut state = Damping::default();
        let (mut iter, mut best, mut best_at) = (0, f64::INFINITY, 0);
        // After a tiny unshifted step from a minimum, the last factors still
        // give the stability verdict and a tangent good enough for a predictor.
        let mut factors_fresh = false;
        // An accepted trial leaves its residual, which is the new point's.
        let mut residual_known = false;
        loop {
            if !residual_known {
                transposed_product(&ws.current.gradient, &ws.current.jacobian, &it.lambda, &mut ws.residual);
            }
            let res = Self::residual_norm(&ws.current, &ws.rows, it, k, &ws.residual);
            if !res.is_finite() {
                return Newton::failed(res, StopReason::NonFinite);
            }
            // A residual that stalls within a few orders of the tolerance is at
            // the rounding floor of an ill-conditioned point (near a fold):
            // converged, with the residual reported as is.
            if res < 0.5 * best {
                best = res;
                best_at = iter;
            }
            let stalled = iter >= best_at + tuning.stall_iterations
                && res <= self.options.rounding_slack * tolerance
                && sup_norm(&ws.step) < tuning.stall_step;
            if res <= tolerance || stalled {
                let stable = factors_fresh || self.factor(k, it, ws).0 == Inertia::Minimum;
                return Newton { residual: res, result: Ok(stable) };
            }
            if iter >= max_iter || it.iterations >= self.options.max_iterations {
                return Newton::failed(res, StopReason::IterationLimit);
            }
            if self.out_of_time() {
                return Newton::failed(res, StopReason::TimeLimit);
            }
            iter += 1;
            it.iterations += 1;
            let (inertia, min_shift) = self.factor(k, it, ws);
            if !min_shift.is_finite() {
                return Newton::failed(res, StopReason::SingularJacobian);
            }
            match self.take_step(sys, it, t, ws, &mut state, min_shift) {
                Some(Taken::Joined) => {
                    // The same point with one more row: its value is zero
                    // and its multiplier too, so the residual stands.
                    residual_known = true;
                    factors_fresh = false;
                }
                Some(Taken::Moved(shift)) => {
                    residual_known = true;
                    // The Lagrangian's Hessian holds the multipliers too (the
                    // weld's curvature): the factors stay good only if they did
                    // not move either (a warm start begins from zero).
                    let moved = (0..ws.rows.len())
                        .filter(|r| it.active[*r])
                        .fold(0.0f64, |m, r| m.max((ws.dual_step[r] * ws.rows[r].scale / k).abs()));
                    factors_fresh = inertia == Inertia::Minimum
                        && shift == 0.0
                        && sup_norm(&ws.step) < tuning.reuse_factors_step
                        && moved < tuning.reuse_factors_step;
                }
                None => {
                    // Within a few orders of the tolerance no step can improve on
                    // rounding: that is convergence, with the residual reported as is.
                    if res <= self.options.rounding_slack * tolerance {
                        let stable = self.factor(k, it, ws).0 == Inertia::Minimum;
                        return Newton { residual: res, result: Ok(stable) };
                    }
                    if self.restore(sys, it, t, ws) {
                        (residual_known, factors_fresh) = (true, false);
                        continue;
                    }
                    // A saddle whose unstable mode the gradient does not reach
                    // (a straight column compressed past its buckling load by
                    // a compliant row: symmetric, the mode orthogonal to the
                    // residual) has no descending step: an unstable point,
                    // which the caller leaves along its most negative curvature.
                    if inertia == Inertia::Indefinite {
                        return Newton { residual: res, result: Ok(false) };
                    }
                    return Newton::failed(res, StopReason::NoDescent);
                }
            }
            if leash.is_finite() && !sys.within(&it.q, &ws.q_predicted, leash) {
                return Newton::failed(res, StopReason::LeftBranch);
            }
        }
    }

    /// Tries steps with growing Levenberg shifts from `min_shift` until one
    /// is accepted; returns the shift used, or `None` when every trial failed.
    /// On success `it` and `ws.current` hold the new point.
    fn take_step<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        ws: &mut Scratch,
        state: &mut Damping,
        min_shift: f64,
    ) -> Option<Taken> {
        let tuning = &self.options.tuning;
        let k = sys.moment_scale();
        // Levenberg-style damping on top of the inertia correction: a
        // rejected full step raises the shift (shorter steps turning towards
        // steepest descent), an accepted one lets it relax. In negative
        // curvature this walks downhill much faster than backtracking along
        // a fixed direction. Where the curvature is right, the plain Newton
        // step comes first: that keeps quadratic convergence.
        let mut shift = if min_shift == 0.0 { 0.0 } else { min_shift.max(state.damping) };
        // However large the shift, a step keeps the part that restores the
        // violated rows (the least-change correction): the trust radius
        // cannot shorten that part, so it bounds the step from below.
        state.restoring = f64::NAN;
        state.first_trial = true;
        for attempt in 0..tuning.max_trials {
            if attempt > 0 || shift != min_shift {
                ws.refactor_kkt(shift, &it.active, tuning.tiny_pivot * k);
            }
            match self.trial(sys, it, t, ws, state, min_shift, shift) {
                Trial::Accepted => {
                    state.damping = if shift > min_shift { tuning.damping_memory * shift } else { 0.0 };
                    if shift > 0.0 {
                        self.unshifted_multipliers(it, ws, k, shift);
                        // The point's Hessian holds the multipliers it was
                        // evaluated with: evaluated again with the corrected ones.
                        if ws.multiplied {
                            sys.evaluate_at(&it.q, &it.lambda, t, &mut ws.current);
                        }
                    }
                    return Some(Taken::Moved(shift));
                }
                Trial::Joined => return Some(Taken::Joined),
                Trial::TooLong if state.restoring.is_nan() => {
                    state.restoring = self.restoring_length(it, ws, k);
                    continue;
                }
                Trial::TooLong | Trial::Rejected => {}
            }
            shift = (tuning.damping_growth * shift).max(tuning.min_damping * k);
        }
        None
    }

    /// The feasibility restoration of a point where no trial step was
    /// accepted while an active row is violated: the least-change step
    /// that restores the rows' linearization, `dq_1 = -J_A^T (J_A J_A^T)^-1 g_A`
    /// (the KKT solve with a shift of `1e6 k`), with a second-order
    /// correction `dq_2` of the same form for the rows' values at
    /// `q (+) dq_1` (the same factors), taken as `q (+) (dq_1 + dq_2)` if
    /// that reduces the rows' violation `sum |g_r / s_r|` measurably;
    /// multipliers kept. Where a row is curved (a weld of frames) the
    /// merit's penalty rises along the restoring step itself (the Maratos
    /// effect), so no Levenberg shift finds a step it accepts: this one
    /// gives up energy for feasibility, and Newton goes on from there.
    /// Returns whether it moved `it` (then `ws.current` and `ws.residual`
    /// are the new point's).
    fn restore<S: StaticSystem + ?Sized>(&self, sys: &S, it: &mut Iterate, t: f64, ws: &mut Scratch) -> bool {
        let k = sys.moment_scale();
        let violation = |ev: &Evaluation, rows: &[Row], lambda: &[f64], active: &[bool]| -> f64 {
            let terms = rows.iter().enumerate().filter(|(r, _)| active[*r]);
            terms.map(|(r, spec)| (ev.row_value(r, lambda[r]) / spec.scale).abs()).sum()
        };
        let before = violation(&ws.current, &ws.rows, &it.lambda, &it.active);
        if !(before > self.options.tolerance) {
            return false;
        }
        ws.factor_kkt(LEAST_CHANGE_SHIFT * k, &it.active, self.options.tuning.tiny_pivot * k);
        Self::least_change(ws, &it.lambda, false);
        sys.retract(&it.q, &ws.step, 1.0, &mut ws.q_trial);
        sys.evaluate_at(&ws.q_trial, &it.lambda, t, &mut ws.trial);
        // The correction goes to `direction`, then joins the step.
        std::mem::swap(&mut ws.step, &mut ws.direction);
        Self::least_change(ws, &it.lambda, true);
        for (s, d) in ws.step.iter_mut().zip(&ws.direction) {
            *s += d;
        }
        sys.retract(&it.q, &ws.step, 1.0, &mut ws.q_trial);
        sys.evaluate_at(&ws.q_trial, &it.lambda, t, &mut ws.trial);
        let after = violation(&ws.trial, &ws.rows, &it.lambda, &it.active);
        if !(after < (1.0 - self.options.tuning.residual_decrease) * before) {
            return false;
        }
        std::mem::swap(&mut it.q, &mut ws.q_trial);
        std::mem::swap(&mut ws.current, &mut ws.trial);
        ws.dual_step.fill(0.0);
        transposed_product(&ws.current.gradient, &ws.current.jacobian, &it.lambda, &mut ws.residual);
        true
    }

    /// A start without multipliers (all zero) of a system whose Hessian
    /// holds them ([`StaticSystem::multipliers_in_hessian`]) starts from
    /// their least-squares estimate `lambda = (J_A J_A^T)^-1 J_A grad V`
    /// instead (the KKT solve with a shift of `1e6 k`), evaluated again.
    /// At zero multipliers that Hessian lacks the rows' curvature: a warm
    /// start at an equilibrium whose weld carries large forces looked
    /// unstable, and no step from it descends.
    fn estimate_multipliers<S: StaticSystem + ?Sized>(&self, sys: &S, it: &mut Iterate, t: f64, ws: &mut Scratch) {
        if !ws.multiplied || it.lambda.is_empty() || it.lambda.iter().any(|l| *l != 0.0) {
            return;
        }
        let k = sys.moment_scale();
        Self::lagrangian(ws, &it.lambda);
        ws.factor_kkt(LEAST_CHANGE_SHIFT * k, &it.active, self.options.tuning.tiny_pivot * k);
        ws.rhs.fill(0.0);
        ws.kkt.solve(&ws.current.gradient, &ws.rhs, &mut ws.spare, &mut ws.dual_step);
        it.lambda.copy_from_slice(&ws.dual_step);
        sys.evaluate_at(&it.q, &it.lambda, t, &mut ws.current);
    }

    /// Takes the fictitious force `shift dq` of an accepted shifted step out
    /// of its multipliers. The shifted KKT system balances
    /// `g + (H + shift) dq = J_A^T lambda`, the model `g + H dq = J_A^T lambda`:
    /// so `lambda -= (J_A J_A^T)^-1 J_A shift dq` (the KKT solve with a shift
    /// of `1e6 k`, at the new point). Where the step restores a violated row
    /// that force grows with the shift: left in, it gave multipliers of 1e9 N
    /// and a Lagrangian Hessian so indefinite that no shift corrected it
    /// (reported as a singular Jacobian). Updates `ws.residual`.
    fn unshifted_multipliers(&self, it: &mut Iterate, ws: &mut Scratch, k: f64, shift: f64) {
        ws.factor_kkt(LEAST_CHANGE_SHIFT * k, &it.active, self.options.tuning.tiny_pivot * k);
        // The old point's residual is spent: it holds the fictitious force.
        for (f, d) in ws.residual_trial.iter_mut().zip(&ws.step) {
            *f = shift * d;
        }
        ws.rhs.fill(0.0);
        ws.kkt.solve(&ws.residual_trial, &ws.rhs, &mut ws.spare, &mut ws.dual_step);
        for (l, y) in it.lambda.iter_mut().zip(&ws.dual_step) {
            *l -= y;
        }
        transposed_product(&ws.current.gradient, &ws.current.jacobian, &it.lambda, &mut ws.residual);
    }

    /// The length (rad, sup norm) of the least-change step that restores the
    /// active rows, `-J^T (J J^T)^-1 g`: the KKT step as the shift grows
    /// without bound, taken here with a shift of `1e6 k`. Leaves the factors
    /// shifted: the caller factors again for its next trial.
    fn restoring_length(&self, it: &Iterate, ws: &mut Scratch, k: f64) -> f64 {
        ws.refactor_kkt(LEAST_CHANGE_SHIFT * k, &it.active, self.options.tuning.tiny_pivot * k);
        Self::least_change(ws, &it.lambda, false);
        sup_norm(&ws.step)
    }

    /// The least-change step restoring the rows' values (with multipliers
    /// `lambda`) of `ws.current`, or of `ws.trial` when `at_trial`, into
    /// `ws.step`: the KKT solve for `(0, -g)` with the factors in `ws.kkt`
    /// (shifted by [`LEAST_CHANGE_SHIFT`]).
    fn least_change(ws: &mut Scratch, lambda: &[f64], at_trial: bool) {
        let ev = if at_trial { &ws.trial } else { &ws.current };
        for (r, rhs) in ws.rhs.iter_mut().enumerate() {
            *rhs = -ev.row_value(r, lambda[r]);
        }
        ws.spare.fill(0.0);
        ws.kkt.solve(&ws.spare, &ws.rhs, &mut ws.step, &mut ws.dual_step);
    }

    /// One trial step with the current factors (of shift `shift`): solve,
    /// evaluate, accept or not.
    #[allow(clippy::too_many_arguments)]
    fn trial<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        ws: &mut Scratch,
        state: &mut Damping,
        min_shift: f64,
        shift: f64,
    ) -> Trial {
        let tuning = &self.options.tuning;
        let k = sys.moment_scale();
        let m = ws.rows.len();
        // The step solves (H + shift I) dq + J_A^T y = -r, J_A dq - c y = -g_A
        // (y = -dlambda): the negative of the solution for (r, g_A), exactly
        // (the solve is linear and negation exact).
        for (r, rhs) in ws.rhs.iter_mut().enumerate() {
            *rhs = ws.current.row_value(r, it.lambda[r]);
        }
        ws.kkt.solve(&ws.residual, &ws.rhs, &mut ws.step, &mut ws.dual_step);
        ws.dual_step.iter_mut().for_each(|y| *y = -*y);
        let mut longest = 0.0f64;
        for d in ws.step.iter_mut() {
            *d = -*d;
            longest = longest.max(d.abs());
        }
        // Where the curvature is corrected the quadratic model is not the
        // energy: keep such steps short, so that the descent follows the
        // valley a damped motion would and cannot hop into a distant basin.
        // With inequality rows the working set can change between runs, and
        // a full Newton step across a released contact can leap far: those
        // steps are kept within the trust radius too.
        let guarded = min_shift > 0.0 || ws.rows.iter().any(|r| r.kind == RowKind::Inequality);
        // The share of the Newton step taken (cut by the radius, the
        // retraction's range or a blocking row).
        let mut whole = 1.0;
        let range = sys.step_limit();
        if longest > range {
            let cut = range / longest;
            ws.step.iter_mut().for_each(|d| *d *= cut);
            ws.dual_step.iter_mut().for_each(|y| *y *= cut);
            (longest, whole) = (range, cut);
        }
        let limit = if state.restoring.is_nan() { 0.0 } else { 2.0 * state.restoring };
        let radius = self.options.trust_radius.max(limit);
        if guarded && longest > radius {
            if min_shift > 0.0 || shift > 0.0 {
                return Trial::TooLong;
            }
            // Where the curvature is right (only working-set changes are
            // guarded), the plain Newton direction descends: cut it to the
            // radius instead of damping it, which needs no new factors.
            let cut = radius / longest;
            ws.step.iter_mut().for_each(|d| *d *= cut);
            ws.dual_step.iter_mut().for_each(|y| *y *= cut);
        }
        // The first inactive inequality row the step would cross (by its
        // linearization) stops it there and joins the working set: the
        // iterates stay on the feasible side of the rows they meet, as a
        // primal active-set method's do, instead of passing through a
        // surface and being pulled back after convergence (which cycled).
        let blocking = if tuning.block_at_rows {
            Self::blocking(&ws.current, &ws.rows, &it.active, &ws.step, self.options.tolerance)
        } else {
            None
        };
        if let Some((row, fraction)) = blocking {
            if fraction <= tuning.blocked_fraction {
                it.active[row] = true;
                it.lambda[row] = 0.0;
                return Trial::Joined;
            }
            ws.step.iter_mut().for_each(|d| *d *= fraction);
            ws.dual_step.iter_mut().for_each(|y| *y *= fraction);
            whole *= fraction;
        }
        for row in 0..m {
            ws.lambda_trial[row] = if it.active[row] { it.lambda[row] - ws.dual_step[row] } else { 0.0 };
            // The penalty follows the Newton multipliers: with a large shift
            // the dual step grows with it and would inflate the penalty
            // until no step is accepted.
            if state.first_trial {
                let scaled = (ws.lambda_trial[row] * ws.rows[row].scale / k).abs();
                state.rho = state.rho.max(2.0 * scaled + tuning.penalty_margin);
            }
        }
        state.first_trial = false;
        let phi0 = Self::merit(&ws.current, &ws.rows, &it.active, state.rho, k);
        // One pass for the energy's slope, the residual's norm and the trial point.
        let (mut descent, mut squares) = (0.0, 0.0);
        for i in 0..ws.n {
            descent += ws.current.gradient[i] * ws.step[i];
            squares += (ws.residual[i] / k) * (ws.residual[i] / k);
        }
        sys.retract(&it.q, &ws.step, 1.0, &mut ws.q_trial);
        let slope = Self::merit_slope(&ws.current, &ws.rows, &it.active, &ws.step, descent, (state.rho, whole), k);
        let r0 = Self::row_squares(squares, &ws.current, &ws.rows, &it.lambda, &it.active).sqrt();
        sys.evaluate_at(&ws.q_trial, &ws.lambda_trial, t, &mut ws.trial);
        let phi = Self::merit(&ws.trial, &ws.rows, &it.active, state.rho, k);
        transposed_product(&ws.trial.gradient, &ws.trial.jacobian, &ws.lambda_trial, &mut ws.residual_trial);
        let r_trial =
            Self::residual_l2(&ws.trial, &ws.rows, &ws.residual_trial, &ws.lambda_trial, &it.active, k).sqrt();
        // A decrease lost in rounding is no progress: accepting it would
        // spend the iteration budget on null steps.
        let measurable = phi0 - phi > tuning.measurable_decrease * phi0.abs().max(1.0);
        let armijo = slope < 0.0 && phi <= phi0 + tuning.armijo * slope && measurable;
        // Where the curvature needed correcting, only energy descent counts:
        // a falling residual may be heading for a saddle.
        let decrease = min_shift == 0.0 && r_trial <= (1.0 - tuning.residual_decrease) * r0;
        // A descent step cut short by a blocking row makes progress by the
        // row it brings in, however little the merit falls: within rounding
        // of no increase it is taken (else a row met early would stop every
        // trial, each too short to decrease measurably).
        let rounding = tuning.measurable_decrease * phi0.abs().max(1.0);
        let blocked = blocking.is_some() && slope < 0.0 && phi <= phi0 + rounding;
        // Where the curvature needed correcting only because the multipliers
        // are off (rows that just joined with none), the step that corrects
        // them barely moves the point: a falling residual at no cost in
        // merit is then no saddle being approached, and is taken.
        let dual_only = tuning.block_at_rows
            && sup_norm(&ws.step) <= tuning.reuse_factors_step
            && phi <= phi0 + rounding
            && r_trial <= (1.0 - tuning.residual_decrease) * r0;
        if phi.is_finite() && (armijo || decrease || blocked || dual_only) {
            std::mem::swap(&mut it.q, &mut ws.q_trial);
            it.lambda.copy_from_slice(&ws.lambda_trial);
            std::mem::swap(&mut ws.current, &mut ws.trial);
            std::mem::swap(&mut ws.residual, &mut ws.residual_trial);
            if let Some((row, _)) = blocking {
                it.active[row] = true;
            }
            return Trial::Accepted;
        }
        Trial::Rejected
    }

    /// The inactive inequality row, feasible now (`C_r / s_r >= -tolerance`),
    /// that the step `dq` reaches first by its linearization `C_r + J_r dq`,
    /// and the fraction of the step at which it does, if below one. Ties go
    /// to the lowest row (Bland's rule, against cycling among equals).
    fn blocking(ev: &Evaluation, rows: &[Row], active: &[bool], dq: &[f64], tolerance: f64) -> Option<(usize, f64)> {
        let m = rows.len();
        let mut first: Option<(usize, f64)> = None;
        for (r, spec) in rows.iter().enumerate() {
            if active[r] || spec.kind != RowKind::Inequality || ev.constraints[r] / spec.scale < -tolerance {
                continue;
            }
            let along: f64 = dq.iter().enumerate().map(|(i, d)| ev.jacobian[i * m + r] * d).sum();
            let value = ev.constraints[r].max(0.0);
            if value + along < 0.0 {
                let fraction = value / -along;
                if first.is_none_or(|(_, f)| fraction < f) {
                    first = Some((r, fraction));
                }
            }
        }
        first
    }
}

/// The Levenberg shift remembered between iterations, the penalty weight,
/// the length of this iteration's restoring step (NaN until needed), and
/// whether the next trial is the iteration's first.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Damping {
    damping: f64,
    rho: f64,
    restoring: f64,
    first_trial: bool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;
    use crate::statics::{Constraints, Potential};

    /// Wherever the shift search starts, it finds the smallest shift of the
    /// sequence that gives a minimum, and leaves that shift's factors.
    #[test]
    fn shift_search_finds_the_smallest_shift_from_any_start() {
        // A soft body standing straight up under full gravity: a saddle.
        let robot = Robot::builtin().with_shape_parameter(100.0).unwrap().with_base_angle(90.0).unwrap();
        let body = robot.body(0.30, 0.28).unwrap();
        let solver = Solver::default();
        let mut ws = Scratch::for_system(&body);
        let mut it = Iterate::new(vec![std::f64::consts::FRAC_PI_2; body.dim()]);
        it.fit_rows(&ws.rows);
        it.active = vec![true; body.rows()];
        body.evaluate(&it.q, 1.0, &mut ws.current);
        let k = body.moment_scale();
        let tiny = solver.options.tuning.tiny_pivot * k;
        let (n, m) = (body.dim(), body.rows());
        let (r, c) = ((0..n).map(|i| 1.0 + i as f64).collect::<Vec<_>>(), vec![1e-3; m]);
        let solved = |ws: &mut Scratch| {
            let (mut x, mut y) = (vec![0.0; n], vec![0.0; m]);
            ws.kkt.solve(&r, &c, &mut x, &mut y);
            x
        };
        let mut found = Vec::new();
        for start in [0, 3, 8, 20, 39, 100] {
            ws.shift_index = start;
            let (inertia, shift) = solver.factor(k, &it, &mut ws);
            assert_eq!(inertia, Inertia::Indefinite);
            // The factors left are the shift's.
            let left = solved(&mut ws);
            assert_eq!(ws.factor_kkt(shift, &it.active, tiny), Inertia::Minimum);
            assert_eq!(left, solved(&mut ws), "start {start}");
            found.push(shift);
        }
        assert!(found.iter().all(|s| *s == found[0]), "{found:?}");
        let smaller = found[0] / solver.options.tuning.shift_growth;
        assert!(found[0] > 0.0 && ws.factor_kkt(smaller, &it.active, tiny) != Inertia::Minimum);
    }
}
