//! Phases that continue from where the robot is: a stride's release, attach
//! and move of the tubes start from the equilibrium the robot is in, not
//! from a body fed again from the shortest length ([`super::solve_among`],
//! which stays for a cold start, where there is no state yet).
//!
//! # Rules
//!
//! From a held equilibrium `(q, lambda)` among a scene's solids (its contact
//! rows and the forces on them the warm start, [`Held::contact_rows`]):
//!
//! * **move** (the same hold, other lengths): the tubes fed from the lengths
//!   they have to the new ones ([`Feeding`], the feed's adaptive steps and
//!   sweep checks);
//! * **release** (both holds to one): the released hold's rows made
//!   compliant, a spring that softens,
//!
//!   ```text
//!   C(q) + c(s) lambda = 0,    c(s) = s / (1 - s) (L^3/EI, L^3/EI, L/EI),    s: 0 -> 1
//!   ```
//!
//!   (chain A as a cantilever, m/N and rad/(N m)), and removed at `s = 1`.
//!   At `s = 0` the both-held equilibrium is the system's own; as the cup
//!   lets go its reaction falls while the body moves, so the path stays
//!   stable where the body's own elasticity holds it (a dead load, the
//!   reaction kept and scaled down, would buckle a compressed arch at once).
//!   `s` is stepped as a feed is, over [`RELEASE_SPAN_M`] of pseudo-feed
//!   (its first step `1 / APPROACH_STAGES`), the contact rows refreshed at
//!   every step and each step's motion checked by
//!   [`swept_clear`](super::swept_clear): the driving unit's (or the
//!   endpoint's) free coordinates move from where they are and nothing
//!   tunnels; a release that cannot follow ends in a snap, reported as the
//!   feed reports one;
//! * **attach** (one hold to both): the front cup from the rear-held state,
//!   its hold's target moved from where the endpoint is (the path of
//!   [`super::attach_front`]); the rear cup from the front-held state as a
//!   release backwards, its rows stiffened, `s: 1 -> 0` (rigid rows at once
//!   would be singular where chain A lies straight between the holds).

use super::feeding::{Fed, FedEnd, Feeding, FEED_STEP_M};
use super::scene_solve::{Pushing, Settled, APPROACH_STAGES};
use super::{fed_end, front_attached, Approach, BodyFeed, FloatingBody, FreeCups, Held, Hold, StanceError};
use crate::body::Body;
use crate::contact::planar::Touching;
use crate::error::InputError;
use crate::robot::Robot;
use crate::scene::Scene;
use crate::statics::Solver;

/// The pseudo-feed a release's load falls over (m): its first step, of
/// [`FEED_STEP_M`], releases `1 / APPROACH_STAGES` of the reaction, and a
/// step that fails is halved down to [`super::MIN_FEED_STEP_M`] as a feed's.
pub const RELEASE_SPAN_M: f64 = APPROACH_STAGES as f64 * FEED_STEP_M;

/// Lengths closer than this (m) are the same: a release or an attach keeps them.
const SAME_LENGTH_M: f64 = 1e-12;

/// The phase from `from` (an equilibrium among `scene`'s solids, solved
/// with the same `cups`) to the tube lengths `lengths` (m) held by `hold`,
/// continued from `from` (module doc): a move for the same hold, a release
/// from both holds to one of them, an attach from one hold to both (the
/// lengths then those of `from`). Anything else is no phase: an input error.
pub fn solve_after(
    robot: &Robot,
    from: &Held,
    lengths: [f64; 2],
    hold: Hold,
    scene: &Scene,
    solver: &Solver,
    cups: FreeCups,
) -> Result<Held, StanceError> {
    super::check_held_unit(robot, hold, scene)?;
    let now = from.lengths();
    let same_lengths = (0..2).all(|i| (now[i] - lengths[i]).abs() <= SAME_LENGTH_M);
    match (from.hold, hold) {
        (was, next) if was == next && same_lengths => Ok(from.clone()),
        (was, next) if was == next => moved(robot, from, lengths, scene, solver, cups),
        (Hold::Both { rear, front }, next)
            if same_lengths && (next == Hold::Rear(rear) || next == Hold::Front(front)) =>
        {
            handed_over(robot, from, next, false, (scene, solver, cups))
        }
        (Hold::Rear(rear), Hold::Both { rear: r, .. }) if same_lengths && r == rear => {
            front_attached(robot, &from.body, &from.equilibrium.q, hold, scene, solver, cups)
        }
        (Hold::Front(front), Hold::Both { front: f, .. }) if same_lengths && f == front => {
            handed_over(robot, from, hold, true, (scene, solver, cups))
        }
        (was, next) => Err(InputError::Invalid {
            field: "hold".into(),
            value: format!(
                "{} at {:.4}/{:.4} m after {} at {:.4}/{:.4} m",
                next.name(),
                lengths[0],
                lengths[1],
                was.name(),
                now[0],
                now[1]
            ),
            allowed:
                "the same hold at other lengths, one of both holds released, or a cup attached at the same lengths"
                    .into(),
        }
        .into()),
    }
}

/// The contacts `held` rests on, as a feed carries them from step to step.
fn resting(robot: &Robot, held: &Held, cups: FreeCups) -> Vec<Pushing> {
    let system = system(robot, &held.body, held.hold, Approach::Load, cups)
        .with_stops(held.stop_rows.clone())
        .with_contacts(held.contact_rows.clone());
    Settled { system, equilibrium: held.equilibrium.clone() }.pushing()
}

/// The floating form of `body` held by `hold` along `approach`, its free cups as `cups` says.
fn system<'b>(robot: &Robot, body: &'b Body, hold: Hold, approach: Approach, cups: FreeCups) -> FloatingBody<'b> {
    cups.on(robot, FloatingBody::of(robot, body, hold, approach))
}

/// The tubes of `from` fed to `lengths`, its hold kept.
fn moved(
    robot: &Robot,
    from: &Held,
    lengths: [f64; 2],
    scene: &Scene,
    solver: &Solver,
    cups: FreeCups,
) -> Result<Held, StanceError> {
    let radius = 0.5 * robot.tube.outer_diameter_m;
    let fed = BodyFeed { robot, hold: from.hold, from: from.lengths(), to: lengths, cups };
    let end = Feeding { fed, scene, radius, solver }.run_from(
        from.body.clone(),
        from.equilibrium.q.clone(),
        resting(robot, from, cups),
    )?;
    Ok(fed_end(robot, end, from.hold, cups))
}

/// The hand-over from `from` to `hold` (module doc): `from` both-held and
/// released to `hold`, or, when `attach`, `from` front-held and the rear cup
/// attached too, as `hold` says (a release backwards, the rear rows
/// stiffened from none to rigid).
fn handed_over(
    robot: &Robot,
    from: &Held,
    hold: Hold,
    attach: bool,
    (scene, solver, cups): (&Scene, &Solver, FreeCups),
) -> Result<Held, StanceError> {
    let radius = 0.5 * robot.tube.outer_diameter_m;
    let (both, single) = if attach { (hold, from.hold) } else { (from.hold, hold) };
    let fed = Handover { robot, body: &from.body, both, single, attach, cups };
    let start = fed.shape_at(0.0)?;
    let end = Feeding { fed, scene, radius, solver }.run_from(
        start,
        from.equilibrium.q.clone(),
        resting(robot, from, cups),
    )?;
    let end = FedEnd { shape: end.shape.body, equilibrium: end.equilibrium, stops: end.stops, contacts: end.contacts };
    Ok(fed_end(robot, end, hold, cups))
}

/// A hand-over fed as a feed is ([`Fed`]): `body` between the holds `both`
/// and `single`, the rows of the hold `single` leaves out softening from
/// rigid to none (a release) or, when `attach`, stiffening from none to
/// rigid (module doc).
struct Handover<'a> {
    robot: &'a Robot,
    body: &'a Body,
    both: Hold,
    single: Hold,
    attach: bool,
    cups: FreeCups,
}

/// The body a fraction of the way through a release (an attach backwards).
struct Releasing {
    body: Body,
    fraction: f64,
}

impl Fed for Handover<'_> {
    type Shape = Releasing;
    type System<'s> = FloatingBody<'s>;

    fn span(&self) -> f64 {
        RELEASE_SPAN_M
    }

    fn shape_at(&self, fraction: f64) -> Result<Releasing, InputError> {
        let released = if self.attach { 1.0 - fraction } else { fraction };
        Ok(Releasing { body: self.body.clone(), fraction: released })
    }

    /// Both holds, the releasing one's rows compliant; released, its rows gone.
    fn system<'s>(&self, shape: &'s Releasing) -> FloatingBody<'s> {
        if shape.fraction >= 1.0 {
            return system(self.robot, &shape.body, self.single, Approach::Load, self.cups);
        }
        let softness = shape.fraction / (1.0 - shape.fraction);
        let approach = match self.single {
            Hold::Front(_) | Hold::FrontPivot(_) => Approach::ReleaseRear(softness),
            _ => Approach::ReleaseFront(softness),
        };
        system(self.robot, &shape.body, self.both, approach, self.cups)
    }

    /// The same body: the state as it is.
    fn carried(&self, _next: &Releasing, _shape: &Releasing, q: &[f64]) -> Vec<f64> {
        q.to_vec()
    }
}
