//! Settling at a fixed parameter, and leaving unstable equilibria along
//! their most negative curvature (the branch rule at a pitchfork).
//!
//! A settle is a free minimization. Where it lands on an unstable
//! equilibrium, the reduced Hessian's softest mode `v` (most negative
//! curvature, by shifted inverse iteration on the KKT matrix) is found and
//! the point kicked along it, `q (+) kick v`, to the side the
//! [`BranchRule`] picks; where no step descends (past a fold no equilibrium
//! is near: the steps stall where the gradient is least, the fold's ghost)
//! it is kicked along the same mode to the side of lower merit. Then it
//! minimizes again. Each kick is [`Tuning::escape_kick_growth`] times the
//! last (0.01, 0.03, 0.09, ... rad), at most [`Tuning::escapes`] of them: a
//! landing back where it was left is kicked harder.
//!
//! [`Tuning::escape_kick_growth`]: super::Tuning::escape_kick_growth
//! [`Tuning::escapes`]: super::Tuning::escapes

use super::iterate::Iterate;
use super::newton::sup_norm;
use super::options::BranchRule;
use super::outcome::{Side, SolveError, Stage, StopReason};
use super::scratch::Scratch;
use super::system::{RowKind, StaticSystem};
use super::Solver;

impl Solver {
    /// Newton's method to a stable equilibrium at `t`, leaving unstable
    /// landings and fold ghosts as the module doc says. Returns the
    /// residual and the side it last left an unstable equilibrium to, if it
    /// had to.
    pub(super) fn settle<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        stage: Stage,
        ws: &mut Scratch,
    ) -> Result<(f64, Option<Side>), SolveError> {
        let tuning = &self.options.tuning;
        // A kick is blind to one-sided rows: it could put the body through a
        // surface, so systems with them leave folds by their own descent.
        let may_snap = ws.rows.iter().all(|r| r.kind == RowKind::Equality);
        let mut escaped = None;
        let mut residual = f64::INFINITY;
        for attempt in 0..=tuning.escapes {
            let kick = tuning.escape_kick * tuning.escape_kick_growth.powi(attempt as i32);
            let out = self.newton(sys, it, t, self.free_budget(), ws);
            residual = out.residual;
            match out.result {
                Ok(true) => return Ok((out.residual, escaped)),
                Ok(false) => {
                    let side = self.escape(sys, it, kick, ws).map_err(|r| self.fail(stage, it, out.residual, r))?;
                    escaped = Some(side);
                }
                Err(StopReason::NoDescent) if may_snap && attempt < tuning.escapes => {
                    self.snap(sys, it, t, kick, ws).map_err(|r| self.fail(stage, it, out.residual, r))?;
                }
                Err(reason) => return Err(self.fail(stage, it, out.residual, reason)),
            }
        }
        Err(self.fail(stage, it, residual, StopReason::StillUnstable))
    }

    /// Kicks the unstable equilibrium `it` (evaluated in `ws.current`) by
    /// `kick` rad along its most negative curvature, to the side the
    /// [`BranchRule`] picks ([`StaticSystem::side_measure`]).
    fn escape<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        kick: f64,
        ws: &mut Scratch,
    ) -> Result<Side, StopReason> {
        let wanted = match self.options.branch {
            BranchRule::Right => Side::Right,
            BranchRule::Left => Side::Left,
            BranchRule::Refuse => return Err(StopReason::UnstableRefused),
        };
        self.lowest_mode(sys.moment_scale(), it, ws)?;
        let measure = sys.side_measure(&it.q, &ws.direction);
        if (measure < 0.0) == (wanted == Side::Right) {
            ws.direction.iter_mut().for_each(|x| *x = -*x);
        }
        kicked(sys, it, kick, ws);
        Ok(wanted)
    }

    /// Kicks a point past a fold (evaluated in `ws.current`), where no step
    /// descends, by `kick` rad along the reduced Hessian's softest mode, to
    /// whichever side has the lower merit (there is no branch to choose: the
    /// equilibrium left has ended).
    fn snap<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        kick: f64,
        ws: &mut Scratch,
    ) -> Result<(), StopReason> {
        let k = sys.moment_scale();
        self.lowest_mode(k, it, ws)?;
        // The penalty weight as Newton's first trial takes it.
        let tuning = &self.options.tuning;
        let largest = (0..ws.rows.len()).fold(0.0f64, |m, r| m.max((it.lambda[r] * ws.rows[r].scale / k).abs()));
        let rho = 2.0 * largest + tuning.penalty_margin;
        let mut best = (f64::INFINITY, 0.0);
        for sign in [1.0, -1.0] {
            sys.retract(&it.q, &ws.direction, sign * kick, &mut ws.q_trial);
            sys.evaluate_at(&ws.q_trial, &it.lambda, t, &mut ws.trial);
            let merit = Self::merit(&ws.trial, &ws.rows, &it.active, rho, k);
            if merit < best.0 {
                best = (merit, sign);
            }
        }
        if !best.0.is_finite() {
            return Err(StopReason::NonFinite);
        }
        kicked(sys, it, best.1 * kick, ws);
        Ok(())
    }

    /// The direction of most negative reduced curvature into `ws.direction`
    /// (sup norm 1), by inverse iteration with a shift below every
    /// eigenvalue of the Lagrangian Hessian (Gershgorin), which makes the
    /// shifted KKT matrix's reduced block positive definite.
    fn lowest_mode(&self, k: f64, it: &Iterate, ws: &mut Scratch) -> Result<(), StopReason> {
        let tuning = &self.options.tuning;
        Self::lagrangian(ws, &it.lambda);
        let lower = gershgorin_lower(ws);
        let sigma = lower - tuning.escape_gap * k;
        let tiny = tuning.tiny_pivot * k;
        ws.factor_kkt(-sigma, &it.active, tiny);
        for (i, v) in ws.direction.iter_mut().enumerate() {
            *v = 1.0 + 0.1 * (i as f64).sin();
        }
        ws.rhs.fill(0.0);
        for _ in 0..tuning.escape_iterations {
            ws.kkt.solve(&ws.direction, &ws.rhs, &mut ws.step, &mut ws.dual_step);
            let norm = sup_norm(&ws.step);
            if norm == 0.0 || !norm.is_finite() {
                return Err(StopReason::StillUnstable);
            }
            ws.direction.iter_mut().zip(&ws.step).for_each(|(v, s)| *v = s / norm);
        }
        Ok(())
    }
}

/// `it.q <- it.q (+) by ws.direction`.
fn kicked<S: StaticSystem + ?Sized>(sys: &S, it: &mut Iterate, by: f64, ws: &mut Scratch) {
    ws.q_trial.copy_from_slice(&it.q);
    sys.retract(&ws.q_trial, &ws.direction, by, &mut it.q);
}

/// A lower bound (Gershgorin) on the eigenvalues of the Lagrangian Hessian
/// in `ws` (chains of blocks of 1 or 3, border and corner).
fn gershgorin_lower(ws: &Scratch) -> f64 {
    let ev = &ws.current;
    let b = ev.block_size();
    let (chains, free) = (ws.lagrangian_diag.len() / b, ev.free());
    let (diag, off) = (&ws.lagrangian_diag, &ev.hessian_off);
    let border_row = |i: usize| ev.hessian_border[i * free..(i + 1) * free].iter().map(|x| x.abs()).sum::<f64>();
    // Row `r` of block `u`'s `b x b` entries at `at(u) + r b + c`.
    let at = |u: usize| u * b * b;
    let mut lower = f64::INFINITY;
    for i in 0..chains {
        let (u, r) = (i / b, i % b);
        let own = &diag[at(u)..at(u + 1)];
        let others: f64 = (0..b).filter(|c| *c != r).map(|c| own[r * b + c].abs()).sum();
        // The coupling with block u + 1 (row r of off block u) and with
        // block u - 1 (column r of off block u - 1).
        let right = if at(u + 1) <= off.len() { (0..b).map(|c| off[at(u) + r * b + c].abs()).sum() } else { 0.0 };
        let left = if u > 0 { (0..b).map(|c| off[at(u - 1) + c * b + r].abs()).sum() } else { 0.0 };
        lower = lower.min(own[r * b + r] - others - left - right - border_row(i));
    }
    for a in 0..free {
        let row = &ws.lagrangian_corner[a * free..(a + 1) * free];
        let others: f64 = row.iter().enumerate().filter(|(b, _)| *b != a).map(|(_, x)| x.abs()).sum();
        let column: f64 = (0..chains).map(|i| ev.hessian_border[i * free + a].abs()).sum();
        lower = lower.min(row[a] - others - column);
    }
    lower
}
