//! Solving a held body among a scene's solids: the load (or the front
//! hold's approach) applied in stages, the contact rows refreshed at each
//! until they settle.

use super::contact::{detect, penetration, ContactOptions, ContactRow};
use super::floating::{Approach, FloatingBody};
use super::{Held, StanceError};
use crate::geom::{dot, Vec2};
use crate::scene::Scene;
use crate::statics::{Constraints, Equilibrium, Iterate, Scratch, SolveError, Solver, Stage, StopReason};

/// Stages the front hold's approach is applied in.
pub const APPROACH_STAGES: usize = 16;

/// Where the contact rows stand after a settle.
pub(super) struct Settled<'a> {
    pub floating: FloatingBody<'a>,
    pub equilibrium: Equilibrium,
}

/// A contact that pushed in a solve: the material point (chain, link
/// counted from the tip, node or corner), the surface's normal and the
/// force (N). Carried from one stage or feeding step to the next, so that
/// the next solve starts with the body resting on what held it (a contact
/// dropped would let Newton first drop the body through the surface, then
/// climb back out). Links are counted from the tip because feeding adds
/// links at the clamp: the material near the tip keeps its place.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pushing {
    chain: usize,
    from_tip: usize,
    at_node: bool,
    normal: Vec2,
    force: f64,
}

impl Pushing {
    /// Whether `row` of `floating` touches the same material point on the same surface.
    fn matches(&self, floating: &FloatingBody<'_>, row: &ContactRow) -> bool {
        row.chain == self.chain
            && floating.chain_len(row.chain) == row.link + 1 + self.from_tip
            && (row.fraction >= 1.0) == self.at_node
            && dot(row.normal, self.normal) > SAME_NORMAL
    }
}

/// Normals closer than this (cosine) count as the same surface's: an edge's
/// is exact, a vertex's turns a little as the point moves around it.
const SAME_NORMAL: f64 = 0.99;

impl Settled<'_> {
    /// The contacts that push at the settled equilibrium.
    pub fn pushing(&self) -> Vec<Pushing> {
        let first = self.floating.contact_row();
        self.floating
            .contacts()
            .iter()
            .zip(&self.equilibrium.multipliers[first..])
            .filter(|(_, force)| **force > 0.0)
            .map(|(row, force)| Pushing {
                chain: row.chain,
                from_tip: self.floating.chain_len(row.chain) - 1 - row.link,
                at_node: row.fraction >= 1.0,
                normal: row.normal,
                force: *force,
            })
            .collect()
    }
}

/// Takes `floating` (without contacts) from the equilibrium `q` at `t = 0`
/// along its approach in [`APPROACH_STAGES`] stages, refreshing its contact
/// rows in `scene` at each.
pub(super) fn approached<'a>(
    floating: FloatingBody<'a>,
    q: Vec<f64>,
    scene: &Scene,
    radius: f64,
    solver: &Solver,
) -> Result<Settled<'a>, StanceError> {
    let options = ContactOptions::default();
    let mut settled = Settled { equilibrium: start(&floating, q), floating };
    let mut pushing = Vec::new();
    for stage in 1..=APPROACH_STAGES {
        let t = stage as f64 / APPROACH_STAGES as f64;
        settled = settle(settled, &pushing, t, scene, radius, &options, solver)?;
        pushing = settled.pushing();
    }
    Ok(settled)
}

/// Settles `floating` (without contacts) at full load from `q`, resting on
/// the contacts `pushing` of the last solve, with contact rows refreshed in
/// `scene` until they settle.
pub(super) fn loaded<'a>(
    floating: FloatingBody<'a>,
    q: Vec<f64>,
    pushing: &[Pushing],
    scene: &Scene,
    radius: f64,
    solver: &Solver,
) -> Result<Settled<'a>, StanceError> {
    let settled = Settled { equilibrium: start(&floating, q), floating };
    settle(settled, pushing, 1.0, scene, radius, &ContactOptions::default(), solver)
}

/// An equilibrium record for the start of a staged solve.
pub(super) fn start(floating: &FloatingBody<'_>, q: Vec<f64>) -> Equilibrium {
    let rows = crate::statics::Constraints::rows(floating);
    Equilibrium {
        q,
        multipliers: vec![0.0; rows],
        energy: 0.0,
        residual: 0.0,
        stable: true,
        iterations: 0,
        steps: 0,
        events: Vec::new(),
    }
}

/// Minimizes at `t` with contact rows detected from the current shape,
/// again until the rows stop changing and nothing penetrates.
fn settle<'a>(
    mut settled: Settled<'a>,
    pushing: &[Pushing],
    t: f64,
    scene: &Scene,
    radius: f64,
    options: &ContactOptions,
    solver: &Solver,
) -> Result<Settled<'a>, StanceError> {
    let stage = match settled.floating.approach() {
        Approach::Load => Stage::Load,
        Approach::Front(_) => Stage::WarmStart,
    };
    let mut rows = Vec::new();
    let mut iterations = settled.equilibrium.iterations;
    let mut events = std::mem::take(&mut settled.equilibrium.events);
    let mut solved = false;
    let mut pushing = pushing.to_vec();
    for _ in 0..options.max_rounds {
        detect(&settled.floating, &settled.equilibrium.q, scene, radius, options, &mut rows);
        let deep = penetration(&settled.floating, &settled.equilibrium.q, scene, radius);
        if solved && same_rows(settled.floating.contacts(), &rows) && deep <= options.penetration_tolerance {
            settled.equilibrium.iterations = iterations;
            settled.equilibrium.events = events;
            return Ok(settled);
        }
        if solved {
            pushing = settled.pushing();
        }
        let floating = settled.floating.with_contacts(rows.clone());
        let mut ws = Scratch::for_system(&floating);
        let mut it = warm_iterate(&floating, &settled.equilibrium, &pushing);
        let residual = solver.minimize(&floating, &mut it, t, stage, &mut ws)?;
        let equilibrium = solver.finish(&floating, it, residual, &mut ws);
        iterations += equilibrium.iterations.max(1);
        events.extend(equilibrium.events.iter().cloned());
        settled = Settled { floating, equilibrium };
        settled.equilibrium.iterations = iterations;
        solved = true;
    }
    Err(SolveError::NotConverged {
        stage,
        iterations,
        residual: penetration(&settled.floating, &settled.equilibrium.q, scene, radius),
        reason: StopReason::ActiveSetCycling,
    }
    .into())
}

/// A start from `previous` for `floating`'s rows: the weld's and the holds'
/// multipliers kept, and a contact row active, with its force, where one of
/// `pushing` pushed before ([`Pushing::matches`]). Newton then does not first
/// let the body fall through what holds it; violated rows join one at a time.
fn warm_iterate(floating: &FloatingBody<'_>, previous: &Equilibrium, pushing: &[Pushing]) -> Iterate {
    let mut it = Iterate::new(previous.q.clone());
    let first = floating.contact_row();
    let rows = floating.rows();
    it.lambda = vec![0.0; rows];
    it.active = vec![false; rows];
    it.active[..first].fill(true);
    it.lambda[..first].copy_from_slice(&previous.multipliers[..first]);
    for (i, row) in floating.contacts().iter().enumerate() {
        if let Some(known) = pushing.iter().find(|p| p.matches(floating, row)) {
            it.lambda[first + i] = known.force;
            it.active[first + i] = true;
        }
    }
    it
}

/// Whether two sets of rows are the same contacts (normals and offsets to rounding).
fn same_rows(a: &[ContactRow], b: &[ContactRow]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(x, y)| {
            x.chain == y.chain
                && x.link == y.link
                && (x.fraction - y.fraction).abs() < 1e-12
                && (x.normal[0] - y.normal[0]).abs() < 1e-12
                && (x.normal[1] - y.normal[1]).abs() < 1e-12
                && (x.offset - y.offset).abs() < 1e-12
        })
}

impl Held {
    /// The held body with its contacts, from a settled solve.
    pub(super) fn settled(settled: Settled<'_>) -> Held {
        let Settled { floating, equilibrium } = settled;
        Held::new(&floating, equilibrium)
    }
}
