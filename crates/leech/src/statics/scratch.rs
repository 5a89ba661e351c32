//! Scratch space for one problem size, reused across solves (the in-place
//! API), and a spare per thread for the solves that take none.

use std::cell::RefCell;

use super::evaluation::{Evaluation, PathTerms};
use super::iterate::Iterate;
use super::system::{Border, Path, Row, RowKind, StaticSystem};
use crate::linalg::{BorderedLdl, Pattern, MAX_BORDER};

/// What a factorization found about the KKT matrix of the working set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Inertia {
    /// Reduced Hessian positive definite: a step towards a constrained minimum.
    Minimum,
    /// Reduced Hessian indefinite.
    Indefinite,
    /// A zero pivot or a rank-deficient set of active rows.
    Singular,
}

/// The KKT factorization of the working set, on [`BorderedLdl`]: the
/// chains' banded Hessian bordered by the free coordinates (primal rows)
/// and the active constraint rows, packed in row order. Inactive rows stay
/// out of the factorization, so many candidate rows (contacts within a
/// margin) cost nothing until they act; the border's buffers are allocated
/// once for as many rows as fit ([`MAX_BORDER`]).
#[derive(Clone, Debug)]
pub(super) struct KktSolver {
    ldl: BorderedLdl,
    chains: usize,
    free: usize,
    m: usize,
    /// Border rows the factorization holds: free coordinates plus active rows.
    capacity: usize,
    /// The active rows in order: border row `free + s` is row `slots[s]`.
    slots: Vec<usize>,
    /// The assembled border `[H_cf | J_A^T]` (chains x k) and corner
    /// `[[H_ff, J_Af^T], [J_Af, -c_A]]` (k x k, `c` the rows' compliance),
    /// `k = free + active rows`; with the border the Jacobian itself, the
    /// corner is `-c_A` alone.
    border: Vec<f64>,
    corner: Vec<f64>,
    /// Right-hand side and solution of the border rows (k).
    c: Vec<f64>,
    y: Vec<f64>,
    /// The active rows and dual regularization the assembled border was
    /// made for, while it holds the current evaluation's entries
    /// ([`KktSolver::factor`] with `reuse`).
    assembled: Option<(Vec<usize>, f64)>,
    /// The active rows whose reach the factorization's pattern holds (its
    /// border rows set for them): placing them again costs a walk over the
    /// pattern's layout per factorization.
    placed: Option<Vec<usize>>,
    /// Where each row reaches each chain ([`StaticSystem::border_start`]):
    /// row `r` from block `row_starts[c * m + r]` of chain `c`; empty when
    /// every row may reach everywhere.
    row_starts: Vec<usize>,
}

impl KktSolver {
    fn new(n: usize, free: usize, m: usize, blocks: &[usize], block: usize) -> KktSolver {
        let (chains, capacity) = (n - free, (free + m).min(MAX_BORDER));
        let in_blocks: Vec<usize> = blocks.iter().map(|b| b / block).collect();
        KktSolver {
            ldl: BorderedLdl::new(&Pattern::new(block, &in_blocks, capacity, free)),
            chains,
            free,
            m,
            capacity,
            slots: Vec::with_capacity(m),
            border: vec![0.0; chains * capacity],
            corner: vec![0.0; capacity * capacity],
            c: vec![0.0; capacity],
            y: vec![0.0; capacity],
            row_starts: Vec::new(),
            assembled: None,
            placed: None,
        }
    }

    /// Reads where `system`'s border entries reach the chains: the free
    /// coordinates' starts into the factorization's pattern, the rows' into
    /// `row_starts` (placed by [`KktSolver::factor`], whose border holds
    /// the active rows only).
    fn read_reach<S: StaticSystem + ?Sized>(&mut self, system: &S) {
        self.placed = None;
        self.row_starts.clear();
        if !system.sparse_border() {
            return;
        }
        let chains = self.ldl.pattern().chains();
        for c in 0..chains {
            for a in 0..self.free {
                self.ldl.set_border_start(c, a, system.border_start(c, Border::Free(a)));
            }
        }
        self.row_starts.extend(
            (0..chains)
                .flat_map(|c| (0..self.m).map(move |r| (c, r)))
                .map(|(c, r)| system.border_start(c, Border::Row(r))),
        );
    }

    /// Whether the border's buffers hold `m` rows (with the free coordinates).
    fn holds_rows(&self, m: usize) -> bool {
        (self.free + m).min(MAX_BORDER) <= self.capacity
    }

    /// Takes `m` constraint rows from now on ([`KktSolver::holds_rows`]).
    fn set_rows(&mut self, m: usize) {
        self.m = m;
        self.slots.clear();
        (self.assembled, self.placed) = (None, None);
    }

    /// How many rows may be active at once.
    pub fn active_capacity(&self) -> usize {
        self.capacity - self.free
    }

    /// Whether the border is the Jacobian itself (no free coordinates, all rows active).
    fn direct(&self) -> bool {
        self.free == 0 && self.slots.len() == self.m
    }

    /// Assembles border and corner from the Lagrangian corner, the potential's
    /// border Hessian and the Jacobian of the active rows.
    fn assemble(&mut self, ev: &Evaluation, lagrangian_corner: &[f64], rows: &[Row], dual: f64) {
        let (f, m) = (self.free, self.m);
        let k = f + self.slots.len();
        // Every row active (a system of equalities): the Jacobian's rows
        // are the border's as they are.
        let all = self.slots.len() == m;
        for i in 0..self.chains {
            let row = &mut self.border[i * k..(i + 1) * k];
            row[..f].copy_from_slice(&ev.hessian_border[i * f..(i + 1) * f]);
            if all {
                row[f..].copy_from_slice(&ev.jacobian[i * m..(i + 1) * m]);
            } else {
                for (dst, r) in row[f..].iter_mut().zip(&self.slots) {
                    *dst = ev.jacobian[i * m + r];
                }
            }
        }
        let corner = &mut self.corner[..k * k];
        corner.fill(0.0);
        for a in 0..f {
            corner[a * k..a * k + f].copy_from_slice(&lagrangian_corner[a * f..(a + 1) * f]);
            for (s, r) in self.slots.iter().enumerate() {
                let j = ev.jacobian[(self.chains + a) * m + r];
                corner[(f + s) * k + a] = j;
                corner[a * k + f + s] = j;
            }
        }
        self.comply(ev, rows, dual);
    }

    /// A compliant row's value is `C + c lambda` and its unknown in the
    /// solve is `-dlambda`: `-c` on the corner's diagonal. An inequality row
    /// also gets the dual regularization `dual s_r^2` (`s_r` its scale): the
    /// solve's matrix only, never the residual (see [`Scratch::dual`]).
    fn comply(&mut self, ev: &Evaluation, rows: &[Row], dual: f64) {
        let k = self.free + self.slots.len();
        for (s, r) in self.slots.iter().enumerate() {
            let at = self.free + s;
            let spec = rows[*r];
            let regularized = if spec.kind == RowKind::Inequality { dual * spec.scale * spec.scale } else { 0.0 };
            self.corner[at * k + at] = -(ev.compliance[*r] + regularized);
        }
    }

    /// Factors `[H + shift I, J_A^T; J_A, -c_A]` (the free coordinates
    /// shifted too) and reports the inertia of the working set's KKT matrix.
    ///
    /// # Panics
    /// If more rows are active than [`KktSolver::active_capacity`].
    ///
    /// With `reuse`, the border assembled by the last factorization serves
    /// again if it was made for the same working set and regularization:
    /// the caller vouches that the evaluation did not change (a search over
    /// shifts, or the trials of one point).
    #[allow(clippy::too_many_arguments)]
    pub fn factor(
        &mut self,
        diag: &[f64],
        ev: &Evaluation,
        lagrangian_corner: &[f64],
        (rows, dual): (&[Row], f64),
        (shift, reuse): (f64, bool),
        active: &[bool],
        tiny: f64,
    ) -> Inertia {
        self.slots.clear();
        self.slots.extend((0..self.m).filter(|r| active[*r]));
        let k = self.free + self.slots.len();
        if self.placed.as_ref() != Some(&self.slots) {
            if !self.row_starts.is_empty() {
                for c in 0..self.ldl.pattern().chains() {
                    for (s, r) in self.slots.iter().enumerate() {
                        self.ldl.set_border_start(c, self.free + s, self.row_starts[c * self.m + r]);
                    }
                }
            }
            self.ldl.set_border_rows(k);
            self.placed.get_or_insert_with(Vec::new).clone_from(&self.slots);
        }
        let count = if self.direct() {
            self.corner[..k * k].fill(0.0);
            self.comply(ev, rows, dual);
            self.ldl.factor(diag, &ev.hessian_off, &ev.jacobian, &self.corner[..k * k], shift, tiny)
        } else {
            let same = matches!(&self.assembled, Some((slots, d)) if reuse && *slots == self.slots && *d == dual);
            if !same {
                self.assemble(ev, lagrangian_corner, rows, dual);
                let (slots, d) = self.assembled.get_or_insert_with(|| (Vec::new(), 0.0));
                slots.clone_from(&self.slots);
                *d = dual;
            }
            let border = &self.border[..self.chains * k];
            self.ldl.factor(diag, &ev.hessian_off, border, &self.corner[..k * k], shift, tiny)
        };
        // A minimum of the working set has exactly one negative eigenvalue
        // per active row (Sylvester: inertia(K) = inertia(H) + inertia(S)).
        let rows = self.slots.len();
        if count.zero > 0 || count.negative < rows {
            Inertia::Singular
        } else if count.negative == rows {
            Inertia::Minimum
        } else {
            Inertia::Indefinite
        }
    }

    /// Solves the factored system: `(H + shift) x + J_A^T y_A = r`,
    /// `J_A x - c_A y_A = c_A'` (`c'` the rows' right-hand side), `y` zero
    /// on inactive rows.
    pub fn solve(&mut self, r: &[f64], c: &[f64], x: &mut [f64], y: &mut [f64]) {
        let (n, f) = (self.chains, self.free);
        let k = f + self.slots.len();
        self.c[..f].copy_from_slice(&r[n..]);
        for (dst, row) in self.c[f..k].iter_mut().zip(&self.slots) {
            *dst = c[*row];
        }
        self.ldl.solve(&r[..n], &self.c[..k], &mut x[..n], &mut self.y[..k]);
        x[n..].copy_from_slice(&self.y[..f]);
        y.fill(0.0);
        for (value, row) in self.y[f..k].iter().zip(&self.slots) {
            y[*row] = *value;
        }
    }
}

thread_local! {
    /// The scratch [`Scratch::with_spare`] keeps between calls on this thread
    /// (taken out while in use, so nested calls each get their own).
    static SPARE: RefCell<Option<Scratch>> = const { RefCell::new(None) };
}

/// Reusable scratch space for one problem size: the in-place API.
#[derive(Clone, Debug)]
pub struct Scratch {
    pub(super) n: usize,
    pub(super) rows: Vec<Row>,
    pub(super) chains: Vec<usize>,
    pub(super) current: Evaluation,
    pub(super) trial: Evaluation,
    pub(super) path: PathTerms,
    pub(super) kkt: KktSolver,
    pub(super) residual: Vec<f64>,
    pub(super) residual_trial: Vec<f64>,
    pub(super) lagrangian_diag: Vec<f64>,
    pub(super) lagrangian_corner: Vec<f64>,
    pub(super) step: Vec<f64>,
    pub(super) q_trial: Vec<f64>,
    pub(super) tangent: Vec<f64>,
    pub(super) q_saved: Vec<f64>,
    pub(super) q_predicted: Vec<f64>,
    pub(super) direction: Vec<f64>,
    pub(super) dual_step: Vec<f64>,
    pub(super) lambda_tangent: Vec<f64>,
    pub(super) lambda_saved: Vec<f64>,
    pub(super) lambda_trial: Vec<f64>,
    pub(super) rhs: Vec<f64>,
    /// A tangent-sized buffer for solves whose primal part is not wanted.
    pub(super) spare: Vec<f64>,
    /// Whether the system's Hessian holds its rows' curvature
    /// ([`StaticSystem::multipliers_in_hessian`]).
    pub(super) multiplied: bool,
    /// The dual regularization of the inequality rows in the factorization
    /// (1/(N m)): zero unless the working set is degenerate (rows of one rigid
    /// piece resting on one surface at three points, dependent with the weld),
    /// where [`Tuning::dual_regularization`](super::Tuning::dual_regularization)
    /// over the moment scale. It enters the step's matrix, not the residual,
    /// so a converged point is exact.
    pub(super) dual: f64,
    /// Where in the sequence `first_shift k growth^i` the last
    /// inertia-correcting shift of the current Newton run was: the next
    /// search starts there (see `Solver::factor`).
    pub(super) shift_index: usize,
    /// Where the working-set runs of the current Newton run started (see
    /// `Solver::newton`): a run that starts where an earlier one did
    /// repeats the cycle between them.
    pub(super) run_starts: RunStarts,
}

/// Where the working-set runs of one Newton run started: the working set
/// and the shift search's place exactly, the point and the multipliers (a
/// run reads nothing else of what came before it: its damping starts
/// afresh), each with the iterations and working-set changes counted when
/// it started. Buffers kept between runs.
#[derive(Clone, Debug, Default)]
pub(super) struct RunStarts {
    /// The working sets and shift indices, one record of `it.active.len() + 1` words each.
    sets: Vec<usize>,
    /// The points and multipliers, one record of `q.len() + lambda.len()` each.
    states: Vec<f64>,
    /// The counts `(iterations, changes)` at each record's start.
    counts: Vec<(usize, usize)>,
}

impl RunStarts {
    /// Forgets every record (a Newton run begins).
    pub fn clear(&mut self) {
        self.sets.clear();
        self.states.clear();
        self.counts.clear();
    }

    /// The counts of the earlier run that started on the working set of
    /// `it` with shift index `shift_index`, from a point and multipliers
    /// within `within` of its (each coordinate relative to its size, at
    /// least one: rad, m or N), if one did; else
    /// records this one's with `counts`.
    pub fn repeated(
        &mut self,
        it: &Iterate,
        shift_index: usize,
        within: f64,
        counts: (usize, usize),
    ) -> Option<(usize, usize)> {
        let set = || it.active.iter().map(|a| usize::from(*a)).chain(std::iter::once(shift_index));
        let (words, values) = (it.active.len() + 1, it.q.len() + it.lambda.len());
        let records = self.sets.chunks_exact(words).zip(self.states.chunks_exact(values));
        let near = |state: &[f64]| {
            state.iter().zip(it.q.iter().chain(&it.lambda)).all(|(a, b)| (a - b).abs() <= within * a.abs().max(1.0))
        };
        if let Some(run) = records.into_iter().position(|(s, state)| s.iter().copied().eq(set()) && near(state)) {
            return Some(self.counts[run]);
        }
        self.sets.extend(set());
        self.states.extend(it.q.iter().chain(&it.lambda));
        self.counts.push(counts);
        None
    }
}

impl Scratch {
    /// Scratch sized for `system`.
    pub fn for_system<S: StaticSystem + ?Sized>(system: &S) -> Scratch {
        let (n, m, free) = (system.dim(), system.rows(), system.free());
        let chains = system.blocks();
        let block = system.block_size();
        assert!(
            block == 1 || system.multipliers_in_hessian(),
            "blocks of {block}: the rows' curvature must be in the Hessian"
        );
        let mut ws = Scratch {
            n,
            rows: Vec::new(),
            current: Evaluation::default(),
            trial: Evaluation::default(),
            path: PathTerms::default(),
            kkt: KktSolver::new(n, free, m, &chains, block),
            chains,
            residual: Vec::new(),
            residual_trial: Vec::new(),
            lagrangian_diag: Vec::new(),
            lagrangian_corner: Vec::new(),
            step: Vec::new(),
            q_trial: Vec::new(),
            tangent: Vec::new(),
            q_saved: Vec::new(),
            q_predicted: Vec::new(),
            direction: Vec::new(),
            dual_step: Vec::new(),
            lambda_tangent: Vec::new(),
            lambda_saved: Vec::new(),
            lambda_trial: Vec::new(),
            rhs: Vec::new(),
            spare: Vec::new(),
            multiplied: false,
            dual: 0.0,
            shift_index: 0,
            run_starts: RunStarts::default(),
        };
        ws.size_buffers(system);
        ws
    }

    /// Sizes this scratch for `system`, keeping its allocations where they
    /// suffice: a solve whose rows change between calls (contacts refreshed)
    /// or whose chains grow a little (tubes fed) then allocates rarely. The
    /// factorization's buffers are kept while only the number of rows changes
    /// and the border still holds them.
    pub fn refit<S: StaticSystem + ?Sized>(&mut self, system: &S) {
        if self.fits(system) {
            // Systems of one size may still differ in where their rows reach.
            self.kkt.read_reach(system);
            return;
        }
        let (n, m, free) = (system.dim(), system.rows(), system.free());
        let chains = system.blocks();
        let block = system.block_size();
        if self.n != n
            || self.kkt.free != free
            || self.chains != chains
            || self.kkt.ldl.pattern().block_size() != block
            || !self.kkt.holds_rows(m)
        {
            self.kkt = KktSolver::new(n, free, m, &chains, block);
        } else {
            self.kkt.set_rows(m);
        }
        (self.n, self.chains) = (n, chains);
        self.size_buffers(system);
    }

    /// The scratch in `slot` sized for `system` ([`Scratch::refit`]: its
    /// buffers kept where they suffice), or a new one the first time: for
    /// callers that solve a sequence of slightly different systems.
    pub fn fitted<'s, S: StaticSystem + ?Sized>(slot: &'s mut Option<Scratch>, system: &S) -> &'s mut Scratch {
        if let Some(ws) = slot.as_mut() {
            ws.refit(system);
        }
        slot.get_or_insert_with(|| Scratch::for_system(system))
    }

    /// Sizes every buffer but the factorization's for `system`.
    fn size_buffers<S: StaticSystem + ?Sized>(&mut self, system: &S) {
        let (n, m, free) = (system.dim(), system.rows(), system.free());
        let block = system.block_size();
        self.rows.clear();
        self.rows.extend((0..m).map(|r| system.row(r)));
        self.multiplied = system.multipliers_in_hessian();
        self.kkt.read_reach(system);
        self.current.resize_blocks(n, free, m, block);
        self.trial.resize_blocks(n, free, m, block);
        self.path.resize(n, m);
        for v in [
            &mut self.residual,
            &mut self.residual_trial,
            &mut self.step,
            &mut self.tangent,
            &mut self.direction,
            &mut self.spare,
        ] {
            v.resize(n, 0.0);
        }
        for v in [&mut self.q_trial, &mut self.q_saved, &mut self.q_predicted] {
            v.resize(system.point_dim(), 0.0);
        }
        self.lagrangian_diag.resize((n - free) * block, 0.0);
        self.lagrangian_corner.resize(free * free, 0.0);
        for v in [
            &mut self.dual_step,
            &mut self.lambda_tangent,
            &mut self.lambda_saved,
            &mut self.lambda_trial,
            &mut self.rhs,
        ] {
            v.resize(m, 0.0);
        }
    }

    /// Runs `solve` with scratch sized for `system`: the one the previous
    /// call on this thread kept, refitted ([`Scratch::refit`]), else a new
    /// one; kept in turn for the next call (one per thread). Solves that take
    /// no scratch use it: at thousands of links, allocating and first
    /// touching fresh scratch (page faults) cost a tenth of a solve.
    pub fn with_spare<S: StaticSystem + ?Sized, R>(system: &S, solve: impl FnOnce(&mut Scratch) -> R) -> R {
        let spare = SPARE.with(|spare| spare.borrow_mut().take());
        let mut ws = match spare {
            Some(mut ws) => {
                ws.refit(system);
                ws
            }
            None => Scratch::for_system(system),
        };
        let out = solve(&mut ws);
        SPARE.with(|spare| *spare.borrow_mut() = Some(ws));
        out
    }

    /// Whether this scratch is sized for `system`.
    pub fn fits<S: StaticSystem + ?Sized>(&self, system: &S) -> bool {
        self.n == system.dim()
            && self.q_trial.len() == system.point_dim()
            && self.kkt.free == system.free()
            && self.rows.len() == system.rows()
            && self.chains == system.blocks()
            && self.multiplied == system.multipliers_in_hessian()
            && self.kkt.ldl.pattern().block_size() == system.block_size()
            && (0..self.rows.len()).all(|r| self.rows[r] == system.row(r))
    }

    /// Factors the KKT matrix of the working set `active` at the current
    /// point with the Lagrangian Hessian in `lagrangian_*`, shifted by `shift`.
    pub(super) fn factor_kkt(&mut self, shift: f64, active: &[bool], tiny: f64) -> Inertia {
        self.factor_reusing(shift, false, active, tiny)
    }

    /// [`Scratch::factor_kkt`] again at the same evaluation and Lagrangian
    /// (another shift): the border assembled last time is kept.
    pub(super) fn refactor_kkt(&mut self, shift: f64, active: &[bool], tiny: f64) -> Inertia {
        self.factor_reusing(shift, true, active, tiny)
    }

    fn factor_reusing(&mut self, shift: f64, reuse: bool, active: &[bool], tiny: f64) -> Inertia {
        let rows = (&self.rows[..], self.dual);
        let (diag, corner) = (&self.lagrangian_diag, &self.lagrangian_corner);
        self.kkt.factor(diag, &self.current, corner, rows, (shift, reuse), active, tiny)
    }

    /// Fills the path derivatives at the current point.
    pub(super) fn path_terms<S: Path + ?Sized>(&mut self, sys: &S, q: &[f64], t: f64) {
        self.path.clear();
        sys.path(q, t, &self.current, &mut self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn iterate(q: &[f64], lambda: &[f64], active: &[bool]) -> Iterate {
        Iterate { lambda: lambda.to_vec(), active: active.to_vec(), ..Iterate::new(q.to_vec()) }
    }

    /// A start is a repeat of an earlier one only on the same working set
    /// and shift index, at a point and multipliers within rounding; the
    /// counts returned are the earlier start's.
    #[test]
    fn run_starts_find_the_same_start_to_rounding_only() {
        let mut starts = RunStarts::default();
        let first = iterate(&[0.5, -1.0], &[2.0, 0.0], &[true, false]);
        assert_eq!(starts.repeated(&first, 3, 1e-12, (10, 1)), None);
        // Another working set, shift index, or a point moved beyond rounding: new starts.
        let other_set = iterate(&[0.5, -1.0], &[2.0, 0.0], &[true, true]);
        assert_eq!(starts.repeated(&other_set, 3, 1e-12, (20, 2)), None);
        assert_eq!(starts.repeated(&first, 4, 1e-12, (30, 3)), None);
        let moved = iterate(&[0.5 + 1e-9, -1.0], &[2.0, 0.0], &[true, false]);
        assert_eq!(starts.repeated(&moved, 3, 1e-12, (40, 4)), None);
        // The first start again, a unit of rounding off in a multiplier.
        let again = iterate(&[0.5, -1.0], &[2.0 + 4e-16, 0.0], &[true, false]);
        assert_eq!(starts.repeated(&again, 3, 1e-12, (50, 5)), Some((10, 1)));
        starts.clear();
        assert_eq!(starts.repeated(&again, 3, 1e-12, (60, 6)), None);
    }
}
