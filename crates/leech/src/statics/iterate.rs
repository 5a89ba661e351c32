//! The state the solver carries between its stages.

use super::outcome::Event;
use super::system::{Row, RowKind};

/// Coordinates, multipliers, the active set and counters: what one solve
/// carries from stage to stage (the in-place API).
#[derive(Clone, Debug)]
pub struct Iterate {
    /// Coordinates (rad).
    pub q: Vec<f64>,
    /// Multipliers, one per constraint row (zero for inactive rows).
    pub lambda: Vec<f64>,
    /// Which rows are in the working set: every equality row, and the
    /// inequality rows that hold the system at their bound.
    pub active: Vec<bool>,
    /// Iterations spent so far.
    pub iterations: usize,
    /// Continuation steps accepted so far.
    pub steps: usize,
    /// Events met so far.
    pub events: Vec<Event>,
    /// The last converged point, while `q` has not moved since.
    pub(super) verdict: Option<Verdict>,
}

/// What the solver knows about a converged point without evaluating again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Verdict {
    /// A fingerprint of `q` when it converged: the verdict holds while it matches.
    pub fingerprint: u64,
    pub t: f64,
    pub stable: bool,
    pub energy: f64,
}

impl Iterate {
    /// A start at `q` with zero multipliers; the solver sizes them and starts
    /// with the equality rows active (inequality rows join when violated).
    pub fn new(q: Vec<f64>) -> Iterate {
        Iterate {
            q,
            lambda: Vec::new(),
            active: Vec::new(),
            iterations: 0,
            steps: 0,
            events: Vec::new(),
            verdict: None,
        }
    }

    /// A cheap fingerprint of `q` (no allocation), to tell whether it moved.
    pub(super) fn fingerprint(&self) -> u64 {
        self.q.iter().fold(0u64, |h, x| h.rotate_left(7) ^ x.to_bits())
    }

    /// The same point for the potential and rows' forces times `factor`
    /// (a body whose stiffnesses are all `factor` times larger, at no load):
    /// the multipliers and a known energy scale, the stability does not.
    pub fn scale_potential(&mut self, factor: f64) {
        for l in &mut self.lambda {
            *l *= factor;
        }
        if let Some(v) = &mut self.verdict {
            v.energy *= factor;
        }
    }

    /// Sizes the multipliers and the active set for `rows` (kept if sized).
    pub(super) fn fit_rows(&mut self, rows: &[Row]) {
        if self.lambda.len() != rows.len() {
            self.lambda = vec![0.0; rows.len()];
            self.active = rows.iter().map(|r| r.kind == RowKind::Equality).collect();
        }
    }
}
