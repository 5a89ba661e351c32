//! Settling at a fixed parameter, and leaving unstable equilibria along
//! their most negative curvature (the branch rule at a pitchfork).

use super::iterate::Iterate;
use super::newton::sup_norm;
use super::options::BranchRule;
use super::outcome::{Side, SolveError, Stage, StopReason};
use super::scratch::Scratch;
use super::system::StaticSystem;
use super::Solver;

impl Solver {
    /// Newton's method to a stable equilibrium at `t`, leaving an unstable one
    /// if it lands there. Returns the residual and the side it left an
    /// unstable equilibrium to, if it had to.
    pub(super) fn settle<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        stage: Stage,
        ws: &mut Scratch,
    ) -> Result<(f64, Option<Side>), SolveError> {
        let out = self.newton(sys, it, t, self.free_budget(), ws);
        match out.result {
            Err(reason) => Err(self.fail(stage, it, out.residual, reason)),
            Ok(true) => Ok((out.residual, None)),
            Ok(false) => {
                let (residual, side) = self.escape(sys, it, t, stage, ws)?;
                Ok((residual, Some(side)))
            }
        }
    }

    /// Leaves an unstable equilibrium along the most negative curvature of the
    /// reduced Hessian (shifted inverse iteration on the KKT system) to the
    /// side the [`BranchRule`] picks, and minimizes from there.
    fn escape<S: StaticSystem + ?Sized>(
        &self,
        sys: &S,
        it: &mut Iterate,
        t: f64,
        stage: Stage,
        ws: &mut Scratch,
    ) -> Result<(f64, Side), SolveError> {
        let tuning = &self.options.tuning;
        let wanted = match self.options.branch {
            BranchRule::Right => Side::Right,
            BranchRule::Left => Side::Left,
            BranchRule::Refuse => {
                return Err(self.fail(stage, it, 0.0, StopReason::UnstableRefused));
            }
        };
        self.lowest_mode(sys.moment_scale(), it, ws);
        let measure = sys.side_measure(&it.q, &ws.direction);
        if (measure < 0.0) == (wanted == Side::Right) {
            ws.direction.iter_mut().for_each(|x| *x = -*x);
        }
        for (q, v) in it.q.iter_mut().zip(&ws.direction) {
            *q += tuning.escape_kick * v;
        }
        let out = self.newton(sys, it, t, self.free_budget(), ws);
        match out.result {
            Err(reason) => Err(self.fail(stage, it, out.residual, reason)),
            Ok(false) => Err(self.fail(stage, it, out.residual, StopReason::StillUnstable)),
            Ok(true) => Ok((out.residual, wanted)),
        }
    }

    /// The direction of most negative reduced curvature into `ws.direction`
    /// (sup norm 1), by inverse iteration with a shift below every
    /// eigenvalue of the Lagrangian Hessian (Gershgorin), which makes the
    /// shifted KKT matrix's reduced block positive definite.
    fn lowest_mode(&self, k: f64, it: &Iterate, ws: &mut Scratch) {
        let tuning = &self.options.tuning;
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
            ws.direction.iter_mut().zip(&ws.step).for_each(|(v, s)| *v = s / norm);
        }
    }
}

/// A lower bound (Gershgorin) on the eigenvalues of the Lagrangian Hessian
/// in `ws` (chains, border and corner).
fn gershgorin_lower(ws: &Scratch) -> f64 {
    let ev = &ws.current;
    let (chains, free) = (ws.lagrangian_diag.len(), ev.free());
    let off = &ev.hessian_off;
    let border_row = |i: usize| ev.hessian_border[i * free..(i + 1) * free].iter().map(|x| x.abs()).sum::<f64>();
    let mut lower = f64::INFINITY;
    for i in 0..chains {
        let left = if i > 0 { off[i - 1].abs() } else { 0.0 };
        let right = if i + 1 < chains { off[i].abs() } else { 0.0 };
        lower = lower.min(ws.lagrangian_diag[i] - left - right - border_row(i));
    }
    for a in 0..free {
        let row = &ws.lagrangian_corner[a * free..(a + 1) * free];
        let others: f64 = row.iter().enumerate().filter(|(b, _)| *b != a).map(|(_, x)| x.abs()).sum();
        let column: f64 = (0..chains).map(|i| ev.hessian_border[i * free + a].abs()).sum();
        lower = lower.min(row[a] - others - column);
    }
    lower
}
