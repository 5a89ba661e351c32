//! Feeding tubes among a scene's solids in adaptive steps: the path a
//! robot's own tubes follow, shared by the two-tube body and the single
//! clamped tube ([`Fed`]).

use super::scene_solve::{self, Pushing};
use super::StanceError;
use crate::contact::planar::{self as contact, ContactRow, Touching};
use crate::error::InputError;
use crate::hose::StopRow;
use crate::scene::Scene;
use crate::statics::{Equilibrium, SolveError, Solver};

/// Longest feeding step between contact refreshes (m): five of the
/// built-in robot's elements, short enough for Newton to stay on the
/// branch a continuous feed follows.
pub const FEED_STEP_M: f64 = 0.05;

/// Shortest feeding step (m): below it a step that still fails is reported.
pub const MIN_FEED_STEP_M: f64 = 1e-4;

/// Feeding steps at most this long (m) that the plain active set cannot
/// settle are tried again with blocking rows (`scene_solve`'s fallback):
/// longer ones are halved first, which keeps the branch a continuous feed
/// follows where it exists.
pub const FALLBACK_STEP_M: f64 = 0.005;

/// Most Newton iterations a feeding step may take on one working set (and
/// four times as many in all, contacts joining and leaving), before
/// it counts as too long a step (and is halved). Counting the active-set
/// changes against the single budget halved steps on which contacts only
/// rippled along a tube, down to the shortest, where bodies pushed head-on
/// into a wall then jammed.
const FEED_ITERATIONS: usize = 12;

/// A feeding step that took at most this many Newton iterations was easy:
/// the next may be twice as long.
const EASY_ITERATIONS: usize = 5;

/// What is fed: a family of systems along a feed, by the fraction fed.
pub(super) trait Fed {
    /// What the tubes are at one fed length (it owns the chains).
    type Shape;
    /// The system solved for a shape, borrowing it.
    type System<'s>: Touching;

    /// The largest length any tube is fed by over the whole feed (m).
    fn span(&self) -> f64;
    /// The shape `fraction` of the way (0: the start, 1: the end).
    fn shape_at(&self, fraction: f64) -> Result<Self::Shape, InputError>;
    /// The system (without contacts) of `shape`.
    fn system<'s>(&self, shape: &'s Self::Shape) -> Self::System<'s>;
    /// A state `q` of `shape` carried over to `next` (a warm start).
    fn carried(&self, next: &Self::Shape, shape: &Self::Shape, q: &[f64]) -> Vec<f64>;
}

/// The tubes fed along `fed` among `scene`'s solids (tube radius `radius`,
/// m), in steps halved when a step fails to converge, ends unstable, takes
/// more than [`FEED_ITERATIONS`] or moves the tubes through a solid unseen
/// ([`contact::swept_clear`]), and doubled after a success. A step of
/// [`MIN_FEED_STEP_M`] is the last chance: it runs to convergence and may end
/// unstable (a snap), but not pass through a solid.
pub(super) struct Feeding<'a, F> {
    pub fed: F,
    pub scene: &'a Scene,
    pub radius: f64,
    pub solver: &'a Solver,
}

/// Where a feed ends: the shape at the end, its settled equilibrium and the
/// rows it settled with: the hose's stop rows, then the contact rows (the
/// system's last rows).
pub(super) struct FedEnd<S> {
    pub shape: S,
    pub equilibrium: Equilibrium,
    pub stops: Vec<StopRow>,
    pub contacts: Vec<ContactRow>,
}

/// A step's settled solve, as the feed goes on from it.
struct Accepted {
    pushing: Vec<Pushing>,
    stops: Vec<StopRow>,
    contacts: Vec<ContactRow>,
    equilibrium: Equilibrium,
}

impl Accepted {
    fn new<S: Touching>(settled: scene_solve::Settled<S>) -> Accepted {
        Accepted {
            pushing: settled.pushing(),
            stops: settled.system.stops().to_vec(),
            contacts: settled.system.contacts().to_vec(),
            equilibrium: settled.equilibrium,
        }
    }
}

impl<F: Fed> Feeding<'_, F> {
    /// Feeds from the equilibrium `q` of `shape` (at the start) to the end;
    /// the last step settles the contacts there, so the end needs no other solve.
    pub fn run(&self, shape: F::Shape, q: Vec<f64>) -> Result<FedEnd<F::Shape>, StanceError> {
        self.run_from(shape, q, Vec::new())
    }

    /// [`Feeding::run`] from an equilibrium resting on the contacts
    /// `pushing` (a phase continuing from where the body is).
    pub fn run_from(
        &self,
        mut shape: F::Shape,
        mut q: Vec<f64>,
        mut pushing: Vec<Pushing>,
    ) -> Result<FedEnd<F::Shape>, StanceError> {
        let span = self.fed.span();
        let (mut done, mut step) = (0.0, FEED_STEP_M);
        // What the solves met on the way (a snap in the middle of the feed
        // is the feed's too, as a continuation path reports its folds).
        let mut events = Vec::new();
        // A step that needs many iterations is too long: stop it early and
        // halve it rather than finish it (the last chance runs to the end).
        let mut brief = self.solver.clone();
        brief.options.max_minimization_iterations = brief.options.max_minimization_iterations.min(FEED_ITERATIONS);
        brief.options.max_iterations = brief.options.max_iterations.min(4 * FEED_ITERATIONS);
        loop {
            // A remainder of rounding is no step of its own.
            let next_fraction = if span <= step { 1.0 } else { done + step / span };
            let next_fraction = if next_fraction > 1.0 - 1e-9 { 1.0 } else { next_fraction };
            let next = self.fed.shape_at(next_fraction)?;
            let carried = self.fed.carried(&next, &shape, &q);
            let last_chance = step <= MIN_FEED_STEP_M;
            // In a block of its own: the systems borrow both shapes, and a
            // system may hold on to its borrow until it is dropped.
            let accepted = {
                let before = self.fed.system(&shape);
                let solver = if last_chance { self.solver } else { &brief };
                let outcome = scene_solve::loaded(
                    self.fed.system(&next),
                    carried.clone(),
                    &pushing,
                    self.scene,
                    self.radius,
                    solver,
                    step <= FALLBACK_STEP_M,
                );
                // Where even the shortest step does not settle, the body
                // is followed down in short legs (`scene_solve::descended`).
                let descend = |carried| {
                    let snapped = scene_solve::descended(
                        self.fed.system(&next),
                        carried,
                        &pushing,
                        self.scene,
                        self.radius,
                        self.solver,
                    )?;
                    Ok::<_, StanceError>(Some(Accepted::new(snapped)))
                };
                match outcome {
                    Ok(settled) => {
                        let end = (&settled.system, &settled.equilibrium.q[..]);
                        let clear = contact::swept_clear((&before, &q), end, self.scene);
                        let eq = &settled.equilibrium;
                        if clear && (last_chance || eq.stable) {
                            Some(Accepted::new(settled))
                        } else if last_chance && !clear {
                            // Even the shortest step jumps through a solid:
                            // the branch ended (a fold), and the settle leapt
                            // to a distant equilibrium on a straight line. The
                            // body snaps: follow it down through free space.
                            descend(carried)?
                        } else {
                            None
                        }
                    }
                    // A deadline that ran out stops the feed.
                    Err(e @ StanceError::Solve(SolveError::Stopped { .. })) => return Err(e),
                    Err(e) if last_chance => {
                        // The shortest step does not settle (its contacts
                        // cycle): a descent in short legs may, where the
                        // settle's long steps overshoot. If it does not
                        // either, the settle's reason is the one to report.
                        descend(carried).map_err(|d| {
                            if matches!(d, StanceError::Solve(SolveError::Stopped { .. })) {
                                d
                            } else {
                                e
                            }
                        })?
                    }
                    Err(_) => None,
                }
            };
            match accepted {
                Some(Accepted { pushing: now_pushing, stops, contacts, mut equilibrium }) => {
                    events.append(&mut equilibrium.events);
                    if next_fraction >= 1.0 {
                        equilibrium.events = events;
                        return Ok(FedEnd { shape: next, equilibrium, stops, contacts });
                    }
                    if equilibrium.iterations <= EASY_ITERATIONS {
                        step = (2.0 * step).min(FEED_STEP_M);
                    }
                    (pushing, q, shape, done) = (now_pushing, equilibrium.q, next, next_fraction);
                }
                None => step = (0.5 * step).max(MIN_FEED_STEP_M),
            }
        }
    }
}
