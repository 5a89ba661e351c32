//! Solving a held body (or a clamped tube: any [`Touching`] system) among a
//! scene's solids: the load (or the front hold's approach) applied in
//! stages, the contact rows refreshed at each until they settle.

use super::floating::FloatingBody;
use super::{ContactForce, Held, StanceError};
use crate::contact::planar::{
    self as contact, detect, displacement, on_face, penetration, rigid_body_of, ContactOptions, ContactRow, RigidRows,
    Touching,
};
use crate::geom::dot;
use crate::hose::{self, StopRow};
use crate::scene::Scene;
use crate::statics::{Equilibrium, Event, Iterate, Scratch, SolveError, Solver, StopReason};

/// Stages the front hold's approach is applied in.
pub const APPROACH_STAGES: usize = 16;

/// Where the contact rows stand after a settle.
pub(super) struct Settled<S> {
    pub system: S,
    pub equilibrium: Equilibrium,
}

/// A contact that pushed in a solve: its row, whether it was at the chain's
/// tip, and the force (N). Carried from one stage or feeding step to the
/// next, so that the next solve starts with the body resting on what held it
/// (a contact dropped would let Newton first drop the body through the
/// surface, then climb back out).
///
/// A fed chain is meshed from the clamp (whole elements, the remainder at
/// the tip: [`Chain::new`](crate::chain::Chain::new)) and its state is
/// carried over link by link from the clamp ([`Chain::carry_over`](crate::chain::Chain::carry_over)):
/// node `j` keeps its place, and a link that grows in appears at the tip.
/// So a contact keeps its link counted from the clamp, and one at the tip
/// stays at the tip (the plate, which carries the endpoint's weight, is
/// there). Counted from the tip instead, every contact moved one node
/// towards the tip wherever a step added a link: the body started resting
/// on nodes above the floor while the nodes on it had no rows active, and
/// the soft body lying on a floor spent three quarters of its Newton
/// iterations in the steps that added a link.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pushing {
    row: ContactRow,
    at_tip: bool,
    force: f64,
}

impl Pushing {
    /// A contact that pushed on `row` of `system` with `force` (N).
    fn new<S: Touching>(system: &S, row: &ContactRow, force: f64) -> Pushing {
        // A cup's rim is no node of a chain.
        let at_tip = !on_face(row.chain) && row.fraction >= 1.0 && row.link + 1 == system.chain_len(row.chain);
        Pushing { row: *row, at_tip, force }
    }

    /// Its link in `system` (a cup's rim as it is), where the chain still reaches that far.
    fn link_in<S: Touching>(&self, system: &S) -> Option<usize> {
        if on_face(self.row.chain) {
            return Some(self.row.link);
        }
        let links = system.chain_len(self.row.chain);
        if self.at_tip {
            return Some(links - 1);
        }
        (self.row.link < links).then_some(self.row.link)
    }

    /// Whether `row` of `system` touches the same material point on the same surface.
    fn matches<S: Touching>(&self, system: &S, row: &ContactRow) -> bool {
        row.chain == self.row.chain
            && self.link_in(system) == Some(row.link)
            && (row.fraction >= 1.0) == (self.row.fraction >= 1.0)
            && dot(row.normal, self.row.normal) > SAME_NORMAL
    }

    /// Its row in `system`, where the chain still reaches that far.
    fn row_in<S: Touching>(&self, system: &S) -> Option<ContactRow> {
        Some(ContactRow { link: self.link_in(system)?, ..self.row })
    }
}

/// Normals closer than this (cosine) count as the same surface's: an edge's
/// is exact, a vertex's turns a little as the point moves around it.
const SAME_NORMAL: f64 = 0.99;

impl<S: Touching> Settled<S> {
    /// The contacts that push at the settled equilibrium.
    pub fn pushing(&self) -> Vec<Pushing> {
        pushing_rows(&self.system, &self.equilibrium)
            .map(|(row, force)| Pushing::new(&self.system, row, force))
            .collect()
    }
}

/// The contact rows of `system` that push at `equilibrium`, with their
/// normal forces (N): the multipliers above zero.
fn pushing_rows<'s, S: Touching>(
    system: &'s S,
    equilibrium: &'s Equilibrium,
) -> impl Iterator<Item = (&'s ContactRow, f64)> {
    let first = system.contact_row();
    system
        .contacts()
        .iter()
        .zip(&equilibrium.multipliers[first..])
        .filter(|(_, force)| **force > 0.0)
        .map(|(r, f)| (r, *f))
}

/// The contacts of `system` that push at `equilibrium`, where they touch;
/// `chain` names a chain for the report.
pub(super) fn contact_forces<S: Touching>(
    system: &S,
    equilibrium: &Equilibrium,
    chain: impl Fn(usize) -> &'static str,
) -> Vec<ContactForce> {
    pushing_rows(system, equilibrium)
        .map(|(c, force)| {
            // A row at a link's tip is the next node's; a cup's row is its rim.
            let at_node = c.fraction >= 1.0 && !on_face(c.chain);
            ContactForce {
                chain: chain(c.chain),
                node: if at_node { c.link + 1 } else { c.link },
                fraction: if at_node || (on_face(c.chain) && c.fraction >= 1.0) { 0.0 } else { c.fraction },
                point_m: system.contact_point(&equilibrium.q, c),
                normal: c.normal,
                force_n: force,
            }
        })
        .collect()
}

/// Takes `floating` (without contacts) from the equilibrium `q` at `t = 0`
/// along its approach in [`APPROACH_STAGES`] stages, refreshing its contact
/// rows in `scene` at each; then along the approach that follows it
/// ([`Approach::then`](super::Approach::then): a front approach's rows
/// stiffened) in as many stages.
pub(super) fn approached<'a>(
    floating: FloatingBody<'a>,
    q: Vec<f64>,
    scene: &Scene,
    radius: f64,
    solver: &Solver,
) -> Result<Settled<FloatingBody<'a>>, StanceError> {
    let options = ContactOptions::default();
    let mut settled = Settled { equilibrium: start(&floating, q), system: floating };
    let mut pushing = Vec::new();
    loop {
        for stage in 1..=APPROACH_STAGES {
            let t = stage as f64 / APPROACH_STAGES as f64;
            settled = settle(settled, &pushing, t, scene, radius, &options, solver)?;
            pushing = settled.pushing();
        }
        let Some(next) = settled.system.approach().then() else { return Ok(settled) };
        settled.system = settled.system.with_approach(next);
    }
}

/// Settles `system` (without contacts) at full load from `q`, resting on
/// the contacts `pushing` of the last solve, with contact rows refreshed in
/// `scene` until they settle.
pub(super) fn loaded<S: Touching>(
    system: S,
    q: Vec<f64>,
    pushing: &[Pushing],
    scene: &Scene,
    radius: f64,
    solver: &Solver,
    fallback: bool,
) -> Result<Settled<S>, StanceError> {
    let settled = Settled { equilibrium: start(&system, q), system };
    settle(settled, pushing, 1.0, scene, radius, &ContactOptions { fallback, ..ContactOptions::default() }, solver)
}

/// An equilibrium record for the start of a staged solve.
pub(super) fn start<S: Touching>(system: &S, q: Vec<f64>) -> Equilibrium {
    let rows = crate::statics::Constraints::rows(system);
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
/// again until the rows stop changing and nothing penetrates: first by the
/// plain active set (rows join after Newton converges), and where that does
/// not settle, again with blocking rows ([`Tuning::block_at_rows`]: a step
/// stops at the first row it would cross, which joins the working set).
/// The plain pass keeps the branch every earlier solve took where it
/// settles; the blocking one settles the bodies pushed into a surface,
/// where the plain one cycles.
///
/// [`Tuning::block_at_rows`]: crate::statics::Tuning::block_at_rows
fn settle<S: Touching>(
    settled: Settled<S>,
    pushing: &[Pushing],
    t: f64,
    scene: &Scene,
    radius: f64,
    options: &ContactOptions,
    solver: &Solver,
) -> Result<Settled<S>, StanceError> {
    if solver.options.tuning.block_at_rows || !options.fallback {
        return settle_rounds(settled, pushing, t, scene, radius, options, solver);
    }
    let again = Settled { system: settled.system.clone(), equilibrium: settled.equilibrium.clone() };
    match settle_rounds(settled, pushing, t, scene, radius, options, solver) {
        Ok(done) => Ok(done),
        // A deadline that ran out stops both passes.
        Err(e @ StanceError::Solve(SolveError::Stopped { .. })) => Err(e),
        Err(_) => {
            let mut blocking = solver.clone();
            blocking.options.tuning.block_at_rows = true;
            settle_rounds(again, pushing, t, scene, radius, options, &blocking)
        }
    }
}

/// One pass of [`settle`] with `solver` as it is.
fn settle_rounds<S: Touching>(
    mut settled: Settled<S>,
    pushing: &[Pushing],
    t: f64,
    scene: &Scene,
    radius: f64,
    options: &ContactOptions,
    solver: &Solver,
) -> Result<Settled<S>, StanceError> {
    let stage = settled.system.stage();
    // The plain pass is the staged solve as it was: the cups' faces by
    // their closest surfaces, no guards, no restarts.
    let thorough = solver.options.tuning.block_at_rows;
    let options = &ContactOptions { whole_faces: thorough, ..*options };
    let (mut rows, mut stops) = (Vec::new(), Vec::new());
    let mut iterations = settled.equilibrium.iterations;
    let mut events = std::mem::take(&mut settled.equilibrium.events);
    let mut solved = false;
    let mut pushing = pushing.to_vec();
    // Where the last solve started, when nothing penetrated there: its
    // equilibrium record, contacts that pushed, and rows.
    let mut from: Option<(Equilibrium, Vec<Pushing>, Vec<ContactRow>)> = None;
    for _ in 0..options.max_rounds {
        detect(&settled.system, &settled.equilibrium.q, scene, radius, options, &mut rows);
        if !solved {
            carry(&settled.system, &pushing, &mut rows);
        }
        // How far the last solve moved the body from a clear start: guards
        // are kept only where it moved farther than the margin (else every
        // point stayed within its rows' reach, and extra rows only cost).
        let moved = from.as_ref().map(|(start, ..)| displacement(&settled.system, &start.q, &settled.equilibrium.q));
        if solved && moved.is_some_and(|d| d > options.margin) {
            guard(&settled, &mut rows, options);
        }
        hose::detect(&settled.system, &settled.equilibrium.q, &mut stops);
        let deep = penetration(&settled.system, &settled.equilibrium.q, scene, radius);
        if solved
            && deep <= options.penetration_tolerance
            && still_settled(&settled, &rows, options)
            && stops_settled(&settled, &stops)
        {
            settled.equilibrium.iterations = iterations;
            settled.equilibrium.events = events;
            return Ok(settled);
        }
        if solved {
            pushing = settled.pushing();
        }
        if let Some((start, start_pushing, start_rows)) = from.take().filter(|_| deep > options.penetration_tolerance) {
            // The solve went through a surface it had no row for (a point
            // moved farther than the margin). Its end is no state to go on
            // from: back to its clear start, with a row for every feature
            // within the distance the points moved, so that the blocking
            // rows stop it this time (the rows only grow: no cycle).
            let wide = ContactOptions { margin: options.margin + moved.unwrap_or(0.0), ..*options };
            detect(&settled.system, &start.q, scene, radius, &wide, &mut rows);
            for row in start_rows {
                if !rows.iter().any(|r| same_row(r, &row)) {
                    rows.push(row);
                }
            }
            settled.equilibrium = Equilibrium { iterations: settled.equilibrium.iterations, ..start };
            pushing = start_pushing;
            // The joints near their stops at the start too.
            let mut near_start = Vec::new();
            hose::detect(&settled.system, &settled.equilibrium.q, &mut near_start);
            merge_stops(&mut stops, near_start);
        } else if thorough && deep <= options.penetration_tolerance {
            // Only the blocking pass goes back to a start: the plain one
            // keeps no copy of it.
            from = Some((settled.equilibrium.clone(), pushing.clone(), rows.clone()));
        }
        let system = settled.system.with_contacts(rows.clone()).with_stops(stops.clone());
        let mut it = warm_iterate(&system, &settled.equilibrium, &pushing);
        let equilibrium = Scratch::with_spare(&system, |ws| {
            let residual = solver.minimize(&system, &mut it, t, stage, ws)?;
            Ok::<_, SolveError>(solver.finish(&system, it, residual, ws))
        })?;
        iterations += equilibrium.iterations;
        events.extend(equilibrium.events.iter().cloned());
        settled = Settled { system, equilibrium };
        settled.equilibrium.iterations = iterations;
        solved = true;
    }
    Err(SolveError::NotConverged {
        stage,
        iterations,
        residual: penetration(&settled.system, &settled.equilibrium.q, scene, radius),
        reason: StopReason::ActiveSetCycling,
    }
    .into())
}

/// Adds to the fresh `rows` the rows of the contacts that pushed before
/// (`pushing`) and were not detected again. A feeding step moves the
/// material near the tip by the length fed: a contact that pushed may be out
/// of the detection's reach at the start. Its row (frozen where it touched)
/// keeps it.
fn carry<S: Touching>(system: &S, pushing: &[Pushing], rows: &mut Vec<ContactRow>) {
    let missing = pushing.iter().filter(|p| !rows.iter().any(|r| p.matches(system, r)));
    let carried: Vec<_> = missing.filter_map(|p| p.row_in(system)).collect();
    rows.extend(carried);
}

/// Longest angle step (rad, sup norm) of a descent ([`descended`]): a
/// link of the built-in robot's 10 mm moves its tip by at most 0.1 mm, and
/// the body's far end by a few millimetres, within the rows' reach.
pub const DESCENT_STEP_RAD: f64 = 0.01;

/// Newton iterations of a descent between two contact refreshes.
const DESCENT_ITERATIONS: usize = 3;

/// Rounds of a descent before it counts as lost: at [`DESCENT_STEP_RAD`] a
/// few radians of motion, far more than any snap of a held body.
const DESCENT_ROUNDS: usize = 2000;

/// Steps shorter than this (rad) that still pass through a solid end the descent.
const SHORTEST_DESCENT_STEP_RAD: f64 = 1e-6;

/// Settles `system` (without contacts) at full load from `q`, where the
/// shape it comes from (`q` carried over) is past a fold: no equilibrium
/// lies near it, and a settle jumps to a distant one on a straight path that
/// may pass through a solid. The descent follows a path instead, as damped
/// dynamics would: rounds of [`DESCENT_ITERATIONS`] Newton iterations with
/// blocking rows, every step within [`DESCENT_STEP_RAD`], the contact rows
/// detected afresh between rounds, each round's motion checked for sweeping
/// through a solid ([`contact::swept_clear`]; a round that does is taken again
/// with half the step). It ends where a round converges with its rows
/// settled, a stable equilibrium reached through free space, reported as an
/// [`Event::Snap`] at `t = 1` with the largest angle change.
///
/// [`contact::swept_clear`]: crate::contact::planar::swept_clear
pub(super) fn descended<S: Touching>(
    system: S,
    q: Vec<f64>,
    pushing: &[Pushing],
    scene: &Scene,
    radius: f64,
    solver: &Solver,
) -> Result<Settled<S>, StanceError> {
    let options = ContactOptions::default();
    let stage = system.stage();
    let start_q = q.clone();
    let mut current = Settled { equilibrium: start(&system, q), system };
    let mut pushing = pushing.to_vec();
    let (mut rows, mut stops) = (Vec::new(), Vec::new());
    let mut descent = solver.clone();
    descent.options.tuning.block_at_rows = true;
    descent.options.max_minimization_iterations = DESCENT_ITERATIONS;
    let mut step = DESCENT_STEP_RAD;
    let (mut iterations, mut converged) = (0, false);
    // Why the last leg that had to be shortened failed.
    let mut why = StopReason::SweptThroughSolid;
    for _ in 0..DESCENT_ROUNDS {
        detect(&current.system, &current.equilibrium.q, scene, radius, &options, &mut rows);
        carry(&current.system, &pushing, &mut rows);
        hose::detect(&current.system, &current.equilibrium.q, &mut stops);
        if converged && still_settled(&current, &rows, &options) && stops_settled(&current, &stops) {
            current.equilibrium.iterations = iterations;
            let jump_rad = sup_distance(&start_q, &current.equilibrium.q);
            current.equilibrium.events.push(Event::Snap { stage, at: 1.0, jump_rad });
            return Ok(current);
        }
        descent.options.trust_radius = step;
        // A copy: a leg that sweeps through a solid is taken again from here.
        let system = current.system.clone().with_contacts(rows.clone()).with_stops(stops.clone());
        let mut it = warm_iterate(&system, &current.equilibrium, &pushing);
        let leg = Scratch::with_spare(&system, |ws| descent.descend(&system, &mut it, 1.0, stage, ws));
        let (residual, verdict) = match leg {
            Ok(done) => done,
            Err(e @ SolveError::Stopped { .. }) => return Err(e.into()),
            // No trial step accepted: a shorter leg may be.
            Err(e) => {
                why = match e {
                    SolveError::NotConverged { reason, .. } => reason,
                    _ => why,
                };
                (f64::INFINITY, None)
            }
        };
        iterations += it.iterations;
        let clear = residual.is_finite()
            && contact::swept_clear((&current.system, &current.equilibrium.q[..]), (&system, &it.q[..]), scene)
            && penetration(&system, &it.q, scene, radius) <= options.penetration_tolerance;
        if !clear {
            // Too long a leg: the rows met on the way were not there, or
            // no step within it descended.
            if residual.is_finite() {
                why = StopReason::SweptThroughSolid;
            }
            step *= 0.5;
            if step < SHORTEST_DESCENT_STEP_RAD {
                break;
            }
            continue;
        }
        if verdict == Some(false) {
            // A saddle the descent stopped on: no way down that keeps the
            // path in free space is known.
            return Err(
                SolveError::NotConverged { stage, iterations, residual, reason: StopReason::StillUnstable }.into()
            );
        }
        step = (2.0 * step).min(DESCENT_STEP_RAD);
        converged = verdict == Some(true);
        let events = std::mem::take(&mut current.equilibrium.events);
        let mut equilibrium = if converged {
            // Its energy and the verdict as every settle's.
            Scratch::with_spare(&system, |ws| descent.finish(&system, it, residual, ws))
        } else {
            let multipliers = it.lambda;
            Equilibrium {
                q: it.q,
                multipliers,
                energy: f64::NAN,
                residual,
                stable: false,
                iterations,
                steps: 0,
                events: Vec::new(),
            }
        };
        (equilibrium.iterations, equilibrium.events) = (iterations, events);
        current = Settled { system, equilibrium };
        pushing = current.pushing();
    }
    let residual = current.equilibrium.residual;
    Err(SolveError::NotConverged { stage, iterations, residual, reason: why }.into())
}

/// The largest coordinate change between `a` and `b` (rad or m).
fn sup_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// A start from `previous` for `system`'s rows: the rows before the
/// contacts (the weld's and the holds') keep their multipliers, and a
/// contact row is active, with its force, where one of `pushing` pushed
/// before ([`Pushing::matches`]). Newton then does not first let the body
/// fall through what holds it; violated rows join one at a time.
fn warm_iterate<S: Touching>(system: &S, previous: &Equilibrium, pushing: &[Pushing]) -> Iterate {
    let mut it = Iterate::new(previous.q.clone());
    let own = system.stop_row();
    let rows = system.rows();
    it.lambda = vec![0.0; rows];
    it.active = vec![false; rows];
    it.active[..own].fill(true);
    it.lambda[..own].copy_from_slice(&previous.multipliers[..own]);
    // A joint at its stop starts locked, its moment coming with the first
    // step; one turned past it too (a solve that ran past a joint it had no
    // row for), which the first step takes back to the stop: the row is
    // linear.
    let mut turns = Vec::new();
    for chain in 0..system.chain_count() {
        system.joint_turns(&previous.q, chain, &mut turns);
        for (i, stop) in system.stops().iter().enumerate().filter(|(_, s)| s.chain == chain) {
            it.active[own + i] = stop.reached(turns[stop.joint]);
        }
    }
    let first = system.contact_row();
    // The faces' rows that start active, on each rigid body only where
    // independent of those before (else the Jacobian is singular).
    let mut rigid = [RigidRows::default(), RigidRows::default()];
    let mut sunk = Vec::new();
    for (i, row) in system.contacts().iter().enumerate() {
        let known = pushing.iter().find(|p| p.matches(system, row));
        if !on_face(row.chain) {
            if let Some(known) = known {
                it.lambda[first + i] = known.force;
                it.active[first + i] = true;
            }
            continue;
        }
        let x = system.contact_point(&previous.q, row);
        if let Some(known) = known {
            if rigid[rigid_body_of(row.chain)].admits(x, row.normal) {
                it.lambda[first + i] = known.force;
                it.active[first + i] = true;
            }
        } else if dot(row.normal, x) < row.offset {
            sunk.push((row.offset - dot(row.normal, x), i, x));
        }
    }
    // A free face already in a solid (a unit that hung into a floor before
    // its rows existed): held as an equality from the first step, which
    // lifts it out, deepest first; a row leaves the set if it then pulls.
    sunk.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (_, i, x) in sunk {
        let row = &system.contacts()[i];
        it.active[first + i] = rigid[rigid_body_of(row.chain)].admits(x, row.normal);
    }
    it
}

/// Whether the settled equilibrium is one for the freshly detected `rows`
/// too, so that no further solve is needed: every row that pushes is among
/// them unchanged, and none of them is violated. The rows of the settle that
/// do not push carry no force, and the new ones hold with none.
fn still_settled<S: Touching>(settled: &Settled<S>, rows: &[ContactRow], options: &ContactOptions) -> bool {
    let (system, q) = (&settled.system, &settled.equilibrium.q);
    let clear = |r: &ContactRow| dot(r.normal, system.contact_point(q, r)) - r.offset >= -options.penetration_tolerance;
    pushing_rows(system, &settled.equilibrium).all(|(p, _)| rows.iter().any(|r| same_row(p, r)))
        && rows.iter().all(clear)
}

/// Whether the settled equilibrium keeps the hose's stops for the freshly
/// detected `stops` too: every locked joint (a moment above zero) is among
/// them, and no joint is turned past its stop.
fn stops_settled<S: Touching>(settled: &Settled<S>, stops: &[StopRow]) -> bool {
    let (system, eq) = (&settled.system, &settled.equilibrium);
    hose::locked(system, &eq.multipliers).all(|(s, _)| stops.iter().any(|f| f.same_joint(s)))
        && hose::overturn(system, &eq.q, &eq.multipliers) <= hose::AT_STOP_RAD
}

/// Adds to `stops` the rows of `more` for joints it has no row for.
fn merge_stops(stops: &mut Vec<StopRow>, more: Vec<StopRow>) {
    for stop in more {
        if !stops.iter().any(|s| s.same_joint(&stop)) {
            stops.push(stop);
        }
    }
}

/// Adds to the fresh `rows` the last solve's rows that did not push and are
/// clear, where not detected again: guards. A Newton run may move a point
/// farther than the detection's margin; without its row it could then pass
/// through the surface it had just left, and the next round pull it back
/// (a two-round cycle). With the guard, the step that would cross it is
/// blocked and the row joins the working set. A row that pushed is not kept
/// unless detected again: where it touched has moved (a corner's point along
/// a link), and the fresh detection says where it is now.
fn guard<S: Touching>(settled: &Settled<S>, rows: &mut Vec<ContactRow>, options: &ContactOptions) {
    let (system, eq) = (&settled.system, &settled.equilibrium);
    let first = system.contact_row();
    for (row, force) in system.contacts().iter().zip(&eq.multipliers[first..]) {
        let clear = dot(row.normal, system.contact_point(&eq.q, row)) - row.offset >= -options.penetration_tolerance;
        if *force <= 0.0 && clear && !rows.iter().any(|r| same_row(r, row)) {
            rows.push(*row);
        }
    }
}

/// Whether two rows are the same contact (normals and offsets to rounding).
fn same_row(x: &ContactRow, y: &ContactRow) -> bool {
    x.chain == y.chain
        && x.link == y.link
        && (x.fraction - y.fraction).abs() < 1e-12
        && (x.normal[0] - y.normal[0]).abs() < 1e-12
        && (x.normal[1] - y.normal[1]).abs() < 1e-12
        && (x.offset - y.offset).abs() < 1e-12
}

impl Held {
    /// The held body with its contacts, from a settled solve.
    pub(super) fn settled(settled: Settled<FloatingBody<'_>>) -> Held {
        let Settled { system, equilibrium } = settled;
        Held::new(&system, equilibrium)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;
    use crate::stance::{Approach, Hold, Pose};

    /// Fed across a whole element (a link grows in at chain A's tip), a
    /// contact that pushed keeps its node counted from the clamp, where the
    /// carried state leaves it, and one at the tip stays at the new tip.
    #[test]
    fn a_carried_contact_keeps_its_node_from_the_clamp_and_the_tip_its_tip() {
        let robot = Robot::builtin();
        let hold = Hold::Rear(Pose::from_deg([0.0, 0.03], 0.0));
        let (short, long) = (robot.body(0.155, 0.15).unwrap(), robot.body(0.165, 0.15).unwrap());
        let before = FloatingBody::of(&robot, &short, hold, Approach::Load);
        let after = FloatingBody::of(&robot, &long, hold, Approach::Load);
        let (n, m) = (before.chain_len(0), after.chain_len(0));
        assert_eq!(m, n + 1);
        let row = |chain, link| ContactRow { chain, link, fraction: 1.0, normal: [0.0, 1.0], offset: 0.004 };
        let on = |system: &FloatingBody<'_>, chain, link| Pushing::new(system, &row(chain, link), 0.1);
        assert_eq!(on(&before, 0, 5).link_in(&after), Some(5));
        assert_eq!(on(&before, 0, n - 1).link_in(&after), Some(m - 1));
        assert!(on(&before, 0, n - 1).matches(&after, &row(0, m - 1)));
        assert!(!on(&before, 0, n - 1).matches(&after, &row(0, n - 1)));
        // Chain B did not grow: its rows are where they were.
        assert_eq!(on(&before, 1, 3).link_in(&after), Some(3));
        // Drawn back by three elements, the tip is the shorter chain's tip
        // again, and a node beyond the shorter chain has no row.
        let longer = robot.body(0.185, 0.15).unwrap();
        let drawn = FloatingBody::of(&robot, &longer, hold, Approach::Load);
        let l = drawn.chain_len(0);
        assert_eq!(l, n + 3);
        assert_eq!(on(&drawn, 0, l - 1).link_in(&before), Some(n - 1));
        assert_eq!(on(&drawn, 0, n + 1).link_in(&before), None);
    }
}
