//! Scratch space for one problem size, reused across solves (the in-place API).

use super::evaluation::{Evaluation, PathTerms};
use super::system::{Path, Row, StaticSystem};
use crate::kkt::Kkt;

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

/// The KKT factorization of the working set (active rows only).
#[derive(Clone, Debug)]
pub(super) struct KktSolver {
    kkt: Kkt,
    /// The Jacobian in the bordered solver's stride-3 layout.
    jac3: Vec<f64>,
    m: usize,
}

impl KktSolver {
    fn new(n: usize, m: usize, chains: &[usize]) -> KktSolver {
        let split = if chains.len() == 2 { chains[0] } else { n };
        KktSolver { kkt: Kkt::with_blocks(n, m, split), jac3: vec![0.0; n * 3], m }
    }

    fn border<'a>(&'a self, jac: &'a [f64]) -> &'a [f64] {
        if self.m == 3 {
            jac
        } else {
            &self.jac3
        }
    }

    /// Factors `[H + shift I, J_A^T; J_A, 0]` and reports the inertia.
    pub fn factor(
        &mut self,
        diag: &[f64],
        off: &[f64],
        shift: f64,
        jac: &[f64],
        active: &[bool],
        tiny: f64,
    ) -> Inertia {
        assert!(active.iter().all(|a| *a), "inactive rows are not supported yet");
        let border = if self.m == 3 { jac } else { &self.jac3 };
        match self.kkt.factor(diag, off, shift, border, tiny) {
            crate::kkt::Inertia::Minimum => Inertia::Minimum,
            crate::kkt::Inertia::Indefinite { .. } => Inertia::Indefinite,
            crate::kkt::Inertia::Singular => Inertia::Singular,
        }
    }

    /// Solves the factored system: `(H + shift) x + J_A^T y_A = r`, `J_A x = c_A`,
    /// `y` zero on inactive rows.
    pub fn solve(&self, jac: &[f64], r: &[f64], c: &[f64], x: &mut [f64], y: &mut [f64]) {
        self.kkt.solve(self.border(jac), r, c, x, y);
    }
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
    pub(super) lagrangian_diag: Vec<f64>,
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
}

impl Scratch {
    /// Scratch sized for `system`.
    pub fn for_system<S: StaticSystem + ?Sized>(system: &S) -> Scratch {
        let (n, m) = (system.dim(), system.rows());
        let chains = system.blocks();
        let zeros = |len: usize| vec![0.0; len];
        Scratch {
            n,
            rows: (0..m).map(|r| system.row(r)).collect(),
            current: Evaluation::new(n, m),
            trial: Evaluation::new(n, m),
            path: PathTerms::new(n, m),
            kkt: KktSolver::new(n, m, &chains),
            chains,
            residual: zeros(n),
            lagrangian_diag: zeros(n),
            step: zeros(n),
            q_trial: zeros(n),
            tangent: zeros(n),
            q_saved: zeros(n),
            q_predicted: zeros(n),
            direction: zeros(n),
            dual_step: zeros(m),
            lambda_tangent: zeros(m),
            lambda_saved: zeros(m),
            lambda_trial: zeros(m),
            rhs: zeros(m),
        }
    }

    /// Whether this scratch is sized for `system`.
    pub fn fits<S: StaticSystem + ?Sized>(&self, system: &S) -> bool {
        self.n == system.dim()
            && self.rows.len() == system.rows()
            && self.chains == system.blocks()
            && (0..self.rows.len()).all(|r| self.rows[r] == system.row(r))
    }

    /// Fills the path derivatives at the current point.
    pub(super) fn path_terms<S: Path + ?Sized>(&mut self, sys: &S, q: &[f64], t: f64) {
        self.path.clear();
        sys.path(q, t, &self.current, &mut self.path);
    }
}
