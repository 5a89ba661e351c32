//! The climb planner: strides chosen with inverse statics, each replayed
//! through the holds-and-contacts statics behind the stride's interlock.
//!
//! A *foothold* is a cup's face flush on a surface: its centre on the
//! surface line and the face along the surface's direction (the
//! [`Scene::surface_frame`] convention: free space on the left, the cups on
//! chain B's side, to the right). One stride from a rear foothold:
//!
//! 1. **Touchdown of the front cup** (inverse statics with the rear held, no
//!    contacts): seeds on a grid of tube lengths (`[limits]` range, `grid`
//!    points a side); from every seed whose front cup is within
//!    [`SEED_DISTANCE_M`] of a surface and [`SEED_ANGLE_DEG`] of flush,
//!    Newton on the two lengths puts the cup's centre on the closest surface
//!    point (two equations, forward differences); the foothold counts if the
//!    face then lies flush within the robot file's tolerances
//!    ([`Scene::flat_on_one_edge`]).
//! 2. **push**: the rear-held body among the scene's solids at those lengths
//!    ([`stance::solve_in`]); its front cup must still be flush there and the
//!    rear cup keep its safety factor.
//! 3. **attach_front**: both holds, the front one exactly flush (the small
//!    difference is the preload); the interlock's attach rule.
//! 4. **release_rear**: the front hold alone; the interlock's release rule on
//!    the front cup's safety factor.
//! 5. **pull**: the touchdown of the rear cup with the front held (as in 1,
//!    the driving unit's cup moving), then the front-held body at those
//!    lengths among the solids.
//! 6. **attach_rear**, **release_front**: as 3 and 4 with the cups swapped.
//!
//! Every phase after the start continues from the equilibrium the one
//! before left ([`stance::solve_after`]): a push or a pull feeds the tubes
//! from where they are (through the samples on the way), an attach starts
//! from the free state and a release from the both-held one; only the start
//! is fed from the shortest length.
//!
//! A stride is rejected when a solve fails or snaps (`snap`), the tubes
//! penetrate a solid (`collision`), no touchdown exists (`reach`) or a cup
//! would hold below its minimum safety factor (`cup force`).
//!
//! The search is by strides (breadth first, a beam of [`PlanOptions::beam`]
//! stances kept per stride, ranked by the rear cup's distance to the goal,
//! then by the smallest safety factor so far, larger first): the first
//! stance whose rear cup lands within the goal's tolerance ends it, so a plan
//! has the fewest strides the beam finds. A stride must bring the rear cup at
//! least [`MIN_PROGRESS_M`] closer to the goal.

use serde::Serialize;

use super::machine::{Command, Cup, Phase, StrideMachine};
use crate::budget::Deadline;
use crate::error::InputError;
use crate::geom::{angle_difference, norm, sub, Vec2};
use crate::robot::Robot;
use crate::scene::Scene;
use crate::stance::{self, FreeCups, Held, Hold, Pose, StanceError};
use crate::statics::{Event, Solver};

/// A seed's cup must be this close to a surface (m) to start a touchdown search.
pub const SEED_DISTANCE_M: f64 = 0.03;

/// ... and this close to flush (deg).
pub const SEED_ANGLE_DEG: f64 = 25.0;

/// Seeds a touchdown search starts Newton from, those over spots nearest the goal first.
pub const SEEDS_TRIED: usize = 4;

/// Seeds tried are over spots of the surface at least this far apart (m).
pub const SEED_SPACING_M: f64 = 0.02;

/// A stride must bring the rear cup this much closer to the goal (m).
pub const MIN_PROGRESS_M: f64 = 0.005;

/// A push or a pull is checked on the way at lengths this far apart (m,
/// the tube that moves farther): both tubes move together, arriving at once.
pub const PATH_STEP_M: f64 = 0.01;

/// The motors' speed the paper drove the tubes at (m/s), for the plan's duration.
pub const TUBE_SPEED_M_PER_S: f64 = 0.02;

/// The face's tilts off flush a touchdown is laid at (deg): flush, and a
/// little either way within the usual 5 deg tolerance, for strides of a few
/// lengths.
const TILTS_DEG: [f64; 3] = [0.0, -2.5, 2.5];

/// A touchdown lays the face's lower rim this far above its surface (m): close enough
/// to seal (within the distance tolerance), clear enough that the face meets
/// the surface flat, not on one rim first.
pub const HOVER_M: f64 = 0.0005;

/// Lengths beyond the shortest (m), both tubes, from which a resting rear
/// face is laid flat; the step and the largest difference between the tubes
/// tried (m).
const RESTING_BASES_M: [f64; 11] = [0.0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09, 0.1];
const RESTING_STEP_M: f64 = 0.002;
const RESTING_DIFFERENCE_M: f64 = 0.016;
const RESTING_TRIES: usize = 6;

/// Lengths (m, both tubes) from which a front face resting on a surface is
/// laid flat when no free touchdown exists.
const FRONT_BASES_M: [f64; 5] = [0.1, 0.15, 0.2, 0.25, 0.3];

/// Step of the forward differences in the touchdown Newton (m).
const DIFFERENCE_M: f64 = 1e-5;

/// A touchdown has converged when the face's centre is this close to its
/// line (m) and its angle to its tilt (rad).
const TOUCHDOWN_TOLERANCE_M: f64 = 1e-7;

/// Newton iterations a touchdown may take.
const TOUCHDOWN_ITERATIONS: usize = 20;

/// Two touchdowns closer than this in both lengths (m) are the same.
const SAME_TOUCHDOWN_M: f64 = 1e-3;

/// A cup's face flush on a surface: its centre (m) and the surface's
/// direction there (rad, free space on the left).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Foothold {
    /// Centre of the cup's face (m).
    pub centre_m: Vec2,
    /// The surface's direction (rad).
    pub direction_rad: f64,
}

/// Where a climb should end: the rear cup's face centre within `tolerance_m` of `point_m`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Goal {
    /// The goal (m).
    pub point_m: Vec2,
    /// How close the rear cup must land (m).
    pub tolerance_m: f64,
}

/// Tuning knobs of the planner.
#[derive(Clone, Debug)]
pub struct PlanOptions {
    /// Most strides a plan may have.
    pub max_strides: usize,
    /// Stances kept per stride in the search.
    pub beam: usize,
    /// Strides kept per stance: its touchdowns are tried nearest the goal
    /// first until this many pass.
    pub candidates: usize,
    /// Seeds per side of the tube-length grid of a touchdown search.
    pub grid: usize,
    /// When the whole search stops (the plan then ends with a
    /// [`Blocking::TimeLimit`] rejection); it replaces the deadline of
    /// [`solver`](Self::solver), so a solve under way stops too.
    pub deadline: Deadline,
    /// The statics solver.
    pub solver: Solver,
}

impl Default for PlanOptions {
    fn default() -> Self {
        PlanOptions {
            max_strides: 30,
            beam: 1,
            candidates: 2,
            grid: 11,
            deadline: Deadline::none(),
            solver: Solver::default(),
        }
    }
}

/// Which constraint blocked a stride.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Blocking {
    /// No cup touchdown within the tube length range.
    Reach,
    /// A cup would hold below its minimum safety factor.
    CupForce,
    /// The tubes would penetrate a solid (or pass through one).
    Collision,
    /// A solve failed to converge or the body snapped.
    Snap,
    /// A tube would bend tighter than its smallest bending radius.
    BendRadius,
    /// Not a physical block: the search ran out of its time limit.
    TimeLimit,
    /// Not a physical block: the plan needs more strides than allowed.
    StrideLimit,
}

impl Blocking {
    /// Its name, as the JSON writes it.
    pub fn name(self) -> &'static str {
        match self {
            Blocking::Reach => "reach",
            Blocking::CupForce => "cup_force",
            Blocking::Collision => "collision",
            Blocking::Snap => "snap",
            Blocking::BendRadius => "bend_radius",
            Blocking::TimeLimit => "time_limit",
            Blocking::StrideLimit => "stride_limit",
        }
    }
}

/// Why a stride was rejected: what blocked it and the numbers.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Rejection {
    /// The constraint.
    pub blocking: Blocking,
    /// The phase it happened in.
    pub phase: Phase,
    /// What happened, with the numbers.
    pub detail: String,
    /// Where it happened when a solve found it: the tube lengths and holds
    /// of the failing state (`leech shape` solves it cold, fed from the
    /// shortest length, where the planner continued from the phase before).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub at: Option<Box<Failed>>,
}

/// The state a rejection was found at.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Failed {
    /// Tube lengths (LA, LB) (m).
    pub lengths_m: [f64; 2],
    /// The holds.
    #[serde(skip)]
    pub hold: Hold,
    /// The rear hold as `[x, y, deg]`, when the rear cup holds.
    pub rear: Option<[f64; 3]>,
    /// The front hold as `[x, y, deg]`, when the front cup holds.
    pub front: Option<[f64; 3]>,
}

impl Failed {
    fn new(lengths_m: [f64; 2], hold: Hold) -> Failed {
        let deg = |p: Pose| [p.point_m[0], p.point_m[1], p.angle_rad.to_degrees()];
        Failed { lengths_m, hold, rear: hold.rear().map(deg), front: hold.front().map(deg) }
    }
}

/// One phase's end in a plan: the equilibrium reached, continued from the
/// step before ([`stance::solve_after`]), with its lengths and holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    /// The phase that ended here.
    pub phase: Phase,
    /// The stride it belongs to (0 for the start).
    pub stride: usize,
    /// Tube lengths (LA, LB) (m).
    pub lengths_m: [f64; 2],
    /// The scene solve's result (hold, reactions, contacts).
    pub held: Held,
    /// The rear cup's safety factor when it holds.
    pub rear_safety_factor: Option<f64>,
    /// The front cup's safety factor when it holds.
    pub front_safety_factor: Option<f64>,
    /// For a push or a pull: the smallest safety factor of the holding cup
    /// on the way, at the samples between the phase's start and end
    /// ([`PATH_STEP_M`] apart); `None` for phases without tube motion.
    pub path_safety_factor: Option<f64>,
}

impl Step {
    /// Whether the solve of this step met a fold and snapped.
    pub fn snapped(&self) -> bool {
        self.held.equilibrium.events.iter().any(|e| matches!(e, Event::Snap { .. }))
    }

    /// The smallest safety factor of the cups that hold.
    pub fn safety_factor(&self) -> f64 {
        [self.rear_safety_factor, self.front_safety_factor, self.path_safety_factor]
            .into_iter()
            .flatten()
            .fold(f64::INFINITY, f64::min)
    }
}

/// Whether a climb was planned.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// The rear cup lands within the goal's tolerance.
    Reached,
    /// No sequence of strides the search tried gets there.
    Impossible,
    /// The search ran out of its time limit (or was cancelled) first: not
    /// a verdict on the climb, which more time might plan.
    Stopped,
}

/// A planned climb, or the reason there is none.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Reached, impossible, or stopped (the reason's blocking is then
    /// [`Blocking::TimeLimit`]).
    pub status: Status,
    /// For an impossible or stopped climb: what blocked the strides from the farthest stance.
    pub reason: Option<Rejection>,
    /// Strides in the plan (for an impossible climb: to the farthest stance reached).
    pub strides: usize,
    /// Every phase's end, from the start (for an impossible climb: to the farthest stance).
    pub steps: Vec<Step>,
    /// Statics solves the search made (touchdown searches and scene solves).
    pub solves: usize,
}

impl Plan {
    /// Total tube travel, both tubes (m): `sum |dLA| + |dLB|` over the phases.
    pub fn tube_travel_m(&self) -> f64 {
        self.steps.windows(2).map(|w| (0..2).map(|i| (w[1].lengths_m[i] - w[0].lengths_m[i]).abs()).sum::<f64>()).sum()
    }

    /// Time the motors run at [`TUBE_SPEED_M_PER_S`], both tubes at once (s).
    pub fn duration_s(&self) -> f64 {
        let longer = |w: &[Step]| (0..2).map(|i| (w[1].lengths_m[i] - w[0].lengths_m[i]).abs()).fold(0.0, f64::max);
        self.steps.windows(2).map(longer).sum::<f64>() / TUBE_SPEED_M_PER_S
    }

    /// The smallest safety factor of any holding cup over the plan.
    pub fn min_safety_factor(&self) -> f64 {
        self.steps.iter().map(Step::safety_factor).fold(f64::INFINITY, f64::min)
    }
}

/// What a planner needs of the world.
struct Planner<'a> {
    robot: &'a Robot,
    scene: &'a Scene,
    goal: Goal,
    options: &'a PlanOptions,
    solves: usize,
}

/// A stance the search reached: the rear cup's foothold after a stride, the
/// lengths there, and the steps so far.
#[derive(Clone)]
struct Stance {
    /// The rear cup's foothold (its face centre on the surface).
    rear: Foothold,
    /// The driving unit's pose the rear hold keeps.
    unit: Pose,
    lengths: [f64; 2],
    steps: Vec<Step>,
    strides: usize,
}

impl Stance {
    fn distance(&self, goal: &Goal) -> f64 {
        norm(sub(self.rear.centre_m, goal.point_m))
    }

    fn min_safety_factor(&self) -> f64 {
        self.steps.iter().map(Step::safety_factor).fold(f64::INFINITY, f64::min)
    }
}

/// How far a search has come, reported after each stride's expansion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Strides of the best stance so far.
    pub strides: usize,
    /// Its rear cup's distance to the goal (m).
    pub distance_m: f64,
    /// Statics solves so far.
    pub solves: usize,
}

/// Plans a climb of `robot` in `scene` from the rear cup's foothold `start`
/// (the tubes at their shortest) to `goal`.
pub fn plan(
    robot: &Robot,
    scene: &Scene,
    start: Foothold,
    goal: Goal,
    options: &PlanOptions,
) -> Result<Plan, InputError> {
    plan_with_progress(robot, scene, start, goal, options, &mut |_| {})
}

/// [`plan`], calling `progress` after every stride of the search (a
/// terminal's progress bar).
pub fn plan_with_progress(
    robot: &Robot,
    scene: &Scene,
    start: Foothold,
    goal: Goal,
    options: &PlanOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Plan, InputError> {
    let mut options = options.clone();
    options.solver.options.deadline = options.deadline.clone();
    let mut planner = Planner { robot, scene, goal, options: &options, solves: 0 };
    planner.search(start, progress)
}

impl Planner<'_> {
    fn out_of_time(&self) -> bool {
        self.options.deadline.expired()
    }

    fn search(&mut self, start: Foothold, progress: &mut dyn FnMut(Progress)) -> Result<Plan, InputError> {
        let short = self.robot.limits.tube_length_min_m;
        let unit = rear_pose(self.robot, start);
        let first = match self.step(Phase::Start, 0, [short; 2], Hold::Rear(unit), None) {
            Ok(step) => step,
            Err(reason) => return Ok(self.impossible(reason, Vec::new(), 0)),
        };
        let mut beam = vec![Stance { rear: start, unit, lengths: [short; 2], steps: vec![first], strides: 0 }];
        let mut farthest = beam[0].clone();
        let mut last_reason = None;
        let mut strides_left = true;
        for stride in 0..=self.options.max_strides {
            if let Some(plan) = self.reached(&beam) {
                return Ok(plan);
            }
            if stride == self.options.max_strides {
                strides_left = false;
                break;
            }
            let mut next = Vec::new();
            for stance in &beam {
                for child in self.strides_from(stance, &mut last_reason)? {
                    next.push(child);
                }
                if self.out_of_time() {
                    break;
                }
            }
            if next.is_empty() || self.out_of_time() {
                break;
            }
            next.sort_by(|a, b| {
                let key = |s: &Stance| (s.distance(&self.goal), -s.min_safety_factor());
                key(a).partial_cmp(&key(b)).unwrap_or(std::cmp::Ordering::Equal)
            });
            next.truncate(self.options.beam);
            if next[0].distance(&self.goal) < farthest.distance(&self.goal) {
                farthest = next[0].clone();
            }
            progress(Progress {
                strides: next[0].strides,
                distance_m: next[0].distance(&self.goal),
                solves: self.solves,
            });
            beam = next;
        }
        if let Some(plan) = self.reached(&beam) {
            return Ok(plan);
        }
        let reason = if !strides_left {
            let max = self.options.max_strides;
            Rejection {
                blocking: Blocking::StrideLimit,
                phase: Phase::ReleaseFront,
                detail: format!(
                    "the goal is more than {max} strides away (the search's limit); the last stance is {:.3} m from it",
                    beam[0].distance(&self.goal)
                ),
                at: None,
            }
        } else if self.out_of_time() {
            self.time_limit(Phase::Push)
        } else {
            last_reason.unwrap_or(Rejection {
                blocking: Blocking::Reach,
                phase: Phase::Push,
                detail: format!("no stride brings the rear cup {MIN_PROGRESS_M} m closer to the goal"),
                at: None,
            })
        };
        Ok(self.impossible(reason, farthest.steps, farthest.strides))
    }

    /// The plan of the first stance of `beam` whose rear cup is within the goal's tolerance.
    fn reached(&self, beam: &[Stance]) -> Option<Plan> {
        let done = beam.iter().find(|s| s.distance(&self.goal) <= self.goal.tolerance_m)?;
        Some(Plan {
            status: Status::Reached,
            reason: None,
            strides: done.strides,
            steps: done.steps.clone(),
            solves: self.solves,
        })
    }

    /// The rejection of a search its deadline stopped in `phase`.
    fn time_limit(&self, phase: Phase) -> Rejection {
        let halt = self.options.deadline.check().map_or_else(String::new, |h| h.to_string());
        Rejection {
            blocking: Blocking::TimeLimit,
            phase,
            detail: format!("the search stopped ({halt}) before reaching the goal"),
            at: None,
        }
    }

    fn impossible(&self, reason: Rejection, steps: Vec<Step>, strides: usize) -> Plan {
        // A solve the deadline cut short (a snap, a failed solve) proves
        // nothing about the body: past the deadline every rejection is the
        // time limit's, the one last met said beside it.
        let reason = if self.out_of_time() && reason.blocking != Blocking::TimeLimit {
            let stopped = self.time_limit(reason.phase);
            Rejection {
                detail: format!("{}; last met: {}: {}", stopped.detail, reason.blocking.name(), reason.detail),
                at: reason.at,
                ..stopped
            }
        } else {
            reason
        };
        // Running out of time is no proof that the climb cannot be made.
        let status = if reason.blocking == Blocking::TimeLimit { Status::Stopped } else { Status::Impossible };
        Plan { status, reason: Some(reason), strides, steps, solves: self.solves }
    }

    /// The stances one stride from `stance` reaches, trying its front
    /// touchdowns nearest the goal first; the last rejection in `reason`.
    fn strides_from(&mut self, stance: &Stance, reason: &mut Option<Rejection>) -> Result<Vec<Stance>, InputError> {
        let holding = Hold::Rear(stance.unit);
        let mut touchdowns = self.touchdowns(holding, Cup::Front)?;
        // A face that cannot land flush in free space (a body sagging onto a
        // floor) may be laid flat on a surface it rests on.
        touchdowns.extend(self.resting_touchdowns(holding, Cup::Front, &FRONT_BASES_M));
        if touchdowns.is_empty() {
            *reason = Some(Rejection {
                blocking: Blocking::Reach,
                phase: Phase::Push,
                detail: format!(
                    "no front touchdown within the tube lengths {}..{} m from the rear cup at ({:.3}, {:.3}) m",
                    self.robot.limits.tube_length_min_m,
                    self.robot.limits.tube_length_max_m,
                    stance.rear.centre_m[0],
                    stance.rear.centre_m[1]
                ),
                at: None,
            });
        }
        self.nearest_goal_first(&mut touchdowns);
        let mut out = Vec::new();
        for (lengths, front) in touchdowns {
            if out.len() == self.options.candidates || self.out_of_time() {
                break;
            }
            match self.stride(stance, lengths, front)? {
                Ok(child) if child.distance(&self.goal) < stance.distance(&self.goal) - MIN_PROGRESS_M => {
                    out.push(child)
                }
                Ok(_) => {
                    *reason = Some(Rejection {
                        blocking: Blocking::Reach,
                        phase: Phase::AttachRear,
                        detail: "the stride does not bring the rear cup closer to the goal".into(),
                        at: None,
                    })
                }
                Err(r) => *reason = Some(r),
            }
        }
        Ok(out)
    }

    /// One stride from `stance` with the front cup landing on `front` at `lengths`.
    fn stride(
        &mut self,
        stance: &Stance,
        lengths: [f64; 2],
        front: Foothold,
    ) -> Result<Result<Stance, Rejection>, InputError> {
        let robot = self.robot;
        let stride = stance.strides + 1;
        let mut machine = StrideMachine::new(robot.cup.min_safety_factor)?;
        let rear = stance.unit;
        let mut steps = Vec::new();
        let result = (|| {
            let now = &stance.steps.last().expect("a stance has its steps").held;
            let push = self.touch_down(Phase::Push, stride, now, lengths, Hold::Rear(rear), Cup::Front)?;
            // The cup seals where the face came to rest (its lip takes up what
            // is left of the tolerances), pressed on by the preload.
            let front_pose = pressed(
                robot,
                Pose { point_m: push.held.endpoint_m, angle_rad: push.held.plate_angle() },
                front.direction_rad,
            );
            let both = Hold::Both { rear, front: front_pose };
            let [attach, released] =
                self.hand_over(&mut machine, stride, &push.held, lengths, Cup::Front, both, Hold::Front(front_pose))?;
            let released_rear = released.held.clone();
            steps.extend([push, attach, released]);
            let mut pulls = self.touchdowns(Hold::Front(front_pose), Cup::Rear).map_err(input_rejection)?;
            let goal = self.goal.point_m;
            // A pull that lands the rear cup no nearer the goal is no stride.
            let now = stance.distance(&self.goal) - MIN_PROGRESS_M;
            pulls.retain(|(_, foothold)| norm(sub(foothold.centre_m, goal)) < now);
            self.nearest_goal_first(&mut pulls);
            // Where the released unit rests on a surface (a floor, a wall it
            // sagged onto), the face lies down among the solids instead.
            // Those touchdowns are searched after the free ones, one base at a
            // time, shortest first (the unit drawn nearest the front cup),
            // until a pull passes.
            let lo = robot.limits.tube_length_min_m;
            let bases: Vec<f64> =
                RESTING_BASES_M.iter().map(|b| lo + b).filter(|b| *b <= lengths[0].max(lengths[1])).collect();
            let mut queue: std::collections::VecDeque<_> = pulls.into();
            let mut next_base = 0;
            let mut best: Option<(f64, Foothold, Pose, [Step; 3])> = None;
            let mut last = Rejection {
                blocking: Blocking::Reach,
                phase: Phase::Pull,
                detail: "no rear touchdown within the tube length range with the front cup holding".into(),
                at: None,
            };
            loop {
                if self.out_of_time() {
                    break;
                }
                while queue.is_empty() && next_base < bases.len() {
                    queue.extend(self.resting_touchdowns(
                        Hold::Front(front_pose),
                        Cup::Rear,
                        &bases[next_base..=next_base],
                    ));
                    next_base += 1;
                }
                let Some((pulled, new_rear)) = queue.pop_front() else { break };
                let attempt = (|| {
                    let pull = self.touch_down(
                        Phase::Pull,
                        stride,
                        &released_rear,
                        pulled,
                        Hold::Front(front_pose),
                        Cup::Rear,
                    )?;
                    let unit = pressed(robot, pull.held.unit, new_rear.direction_rad);
                    let both = Hold::Both { rear: unit, front: front_pose };
                    let [attach, settled] = self.hand_over(
                        &mut machine.clone(),
                        stride,
                        &pull.held,
                        pulled,
                        Cup::Rear,
                        both,
                        Hold::Rear(unit),
                    )?;
                    Ok((new_rear, unit, [pull, attach, settled]))
                })();
                match attempt {
                    // The first pull that passes draws the unit farthest;
                    // where that overshoots the goal, longer pulls are tried
                    // too and the touchdown nearest the goal is kept.
                    Ok((new_rear, unit, three)) => {
                        let off = norm(sub(new_rear.centre_m, goal));
                        let beyond = norm(sub(new_rear.centre_m, front.centre_m)) < norm(sub(goal, front.centre_m));
                        if best.as_ref().is_none_or(|(o, ..)| off < *o) {
                            best = Some((off, new_rear, unit, three));
                        }
                        if off <= self.goal.tolerance_m || !beyond {
                            break;
                        }
                    }
                    Err(r) => last = r,
                }
            }
            match best {
                Some((_, new_rear, unit, three)) => {
                    steps.extend(three);
                    Ok((new_rear, unit))
                }
                None => Err(last),
            }
        })();
        Ok(result.map(|(new_rear, unit)| {
            let mut all = stance.steps.clone();
            all.extend(steps);
            let lengths = all.last().map_or(stance.lengths, |s| s.lengths_m);
            Stance { rear: new_rear, unit, lengths, steps: all, strides: stride }
        }))
    }

    /// The phase that brings `moving` down at `to` (lengths, m) among the
    /// solids, the tubes fed from where they are in `from`: its face must
    /// lie flush there too.
    fn touch_down(
        &mut self,
        phase: Phase,
        stride: usize,
        from: &Held,
        to: [f64; 2],
        hold: Hold,
        moving: Cup,
    ) -> Result<Step, Rejection> {
        let (on_the_way, last) = self.on_the_way(phase, from, to, hold)?;
        let mut step = self.step(phase, stride, to, hold, Some(&last))?;
        step.path_safety_factor = Some(on_the_way);
        self.flush_after(&step, moving)?;
        Ok(step)
    }

    /// The tubes moving from where they are in `now` to `to` (m, both
    /// arriving together) with `hold`, each sample fed from the last: at
    /// samples [`PATH_STEP_M`] apart between the ends, the body among the
    /// solids must not snap, penetrate or bend too tightly and the holding
    /// cup must keep its minimum safety factor; its smallest safety factor on
    /// the way (infinite without samples) and the last sample's state (`now`
    /// without samples).
    fn on_the_way(&mut self, phase: Phase, now: &Held, to: [f64; 2], hold: Hold) -> Result<(f64, Held), Rejection> {
        let from = now.lengths();
        let travel = (to[0] - from[0]).abs().max((to[1] - from[1]).abs());
        let samples = (travel / PATH_STEP_M).ceil() as usize;
        let mut smallest = f64::INFINITY;
        let mut last = now.clone();
        for k in 1..samples {
            if self.out_of_time() {
                return Err(self.time_limit(phase));
            }
            let t = k as f64 / samples as f64;
            let at = [from[0] + t * (to[0] - from[0]), from[1] + t * (to[1] - from[1])];
            let step = self.step(phase, 0, at, hold, Some(&last)).map_err(|mut r| {
                r.detail = format!("on the way from {:.4}/{:.4} m: {}", from[0], from[1], r.detail);
                r
            })?;
            smallest = smallest.min(step.safety_factor());
            last = step.held;
        }
        Ok((smallest, last))
    }

    /// Touchdowns ordered by their foothold's distance to the goal, nearest first.
    fn nearest_goal_first(&self, touchdowns: &mut [([f64; 2], Foothold)]) {
        let goal = self.goal.point_m;
        touchdowns.sort_by(|a, b| norm(sub(a.1.centre_m, goal)).total_cmp(&norm(sub(b.1.centre_m, goal))));
    }

    /// `attaching` attaches (the phase's end with both holds, `both`, from
    /// the state `from`), then the other cup releases (the end with
    /// `attaching`'s hold alone, `alone`, from the both-held state): each
    /// behind the interlock, the release judged on the attached cup's safety
    /// factor after it.
    #[allow(clippy::too_many_arguments)]
    fn hand_over(
        &mut self,
        machine: &mut StrideMachine,
        stride: usize,
        from: &Held,
        lengths: [f64; 2],
        attaching: Cup,
        both: Hold,
        alone: Hold,
    ) -> Result<[Step; 2], Rejection> {
        let (attach, release) = match attaching {
            Cup::Front => (Phase::AttachFront, Phase::ReleaseRear),
            Cup::Rear => (Phase::AttachRear, Phase::ReleaseFront),
        };
        self.guard(machine, attach, Command::Attach { cup: attaching, flush: true })?;
        let attached = self.step(attach, stride, lengths, both, Some(from))?;
        let released = self.step(release, stride, lengths, alone, Some(&attached.held))?;
        let factor = match attaching {
            Cup::Front => released.front_safety_factor,
            Cup::Rear => released.rear_safety_factor,
        };
        let command = Command::Release { cup: attaching.other(), partner_safety_factor: factor.unwrap_or(f64::NAN) };
        self.guard(machine, release, command)?;
        Ok([attached, released])
    }

    /// Applies `command` to the interlock, a refusal as a rejection.
    fn guard(&self, machine: &mut StrideMachine, phase: Phase, command: Command) -> Result<(), Rejection> {
        machine.apply(command).map(|_| ()).map_err(|e| Rejection {
            blocking: match e {
                super::StrideError::NotFlush { .. } => Blocking::Reach,
                _ => Blocking::CupForce,
            },
            phase,
            detail: e.to_string(),
            at: None,
        })
    }

    /// The phase's end among the scene's solids, continued from the state
    /// `from` the robot is in ([`stance::solve_after`]; cold without one),
    /// with the holding cups' safety factors; a failure, a snap or a
    /// penetration as a rejection.
    fn step(
        &mut self,
        phase: Phase,
        stride: usize,
        lengths: [f64; 2],
        hold: Hold,
        from: Option<&Held>,
    ) -> Result<Step, Rejection> {
        self.judged_step(phase, stride, lengths, hold, from).map_err(|mut r| {
            r.at.get_or_insert_with(|| Box::new(Failed::new(lengths, hold)));
            r
        })
    }

    /// [`Self::step`] without the rejection's state.
    fn judged_step(
        &mut self,
        phase: Phase,
        stride: usize,
        lengths: [f64; 2],
        hold: Hold,
        from: Option<&Held>,
    ) -> Result<Step, Rejection> {
        self.solves += 1;
        let (robot, scene, solver) = (self.robot, self.scene, &self.options.solver);
        let held = match from {
            Some(from) => stance::solve_after(robot, from, lengths, hold, scene, solver, FreeCups::Rest),
            None => stance::solve_among(robot, lengths, hold, scene, solver, FreeCups::Rest),
        }
        .map_err(|e| {
            let blocking = match &e {
                StanceError::Solve(s) if s.to_string().contains("through a solid") => Blocking::Collision,
                // Both cups held farther apart than the tubes reach
                // (a preload pressing a straight body's cup further).
                StanceError::OutOfReach { .. } => Blocking::Reach,
                StanceError::Input(_) => Blocking::Collision,
                _ => Blocking::Snap,
            };
            Rejection {
                blocking,
                phase,
                detail: format!("{} at lengths {:.4}/{:.4} m: {e}", hold.name(), lengths[0], lengths[1]),
                at: None,
            }
        })?;
        let (rear, front) = held.cups(self.robot).map_err(|e| Rejection {
            blocking: Blocking::CupForce,
            phase,
            detail: e.to_string(),
            at: None,
        })?;
        let step = Step {
            phase,
            stride,
            lengths_m: lengths,
            rear_safety_factor: rear.map(|c| c.verdict.safety_factor),
            front_safety_factor: front.map(|c| c.verdict.safety_factor),
            path_safety_factor: None,
            held,
        };
        if step.snapped() {
            return Err(Rejection {
                blocking: Blocking::Snap,
                phase,
                detail: "the body snapped through a fold".into(),
                at: None,
            });
        }
        if !step.held.within_stop(self.robot) {
            let radius = step.held.min_bend_radius();
            return Err(Rejection {
                blocking: Blocking::BendRadius,
                phase,
                detail: format!(
                    "a tube bends to a radius of {radius:.4} m, tighter than its smallest {} m",
                    self.robot.tube.min_bend_radius_m
                ),
                at: None,
            });
        }
        let deep = step.held.penetration_m(self.robot, self.scene);
        if !(deep <= 1e-9) {
            return Err(Rejection {
                blocking: Blocking::Collision,
                phase,
                detail: format!("the tubes penetrate a solid by {deep:.2e} m"),
                at: None,
            });
        }
        if phase != Phase::ReleaseRear && phase != Phase::ReleaseFront {
            self.holding_safe(&step, phase)?;
        }
        Ok(step)
    }

    /// Every holding cup of `step` at least at its minimum safety factor.
    fn holding_safe(&self, step: &Step, phase: Phase) -> Result<(), Rejection> {
        let minimum = self.robot.cup.min_safety_factor;
        for (cup, factor) in [(Cup::Rear, step.rear_safety_factor), (Cup::Front, step.front_safety_factor)] {
            if let Some(f) = factor.filter(|f| !(*f >= minimum)) {
                return Err(Rejection {
                    blocking: Blocking::CupForce,
                    phase,
                    detail: format!("the {cup} cup holds with safety factor {f:.3}, below the minimum {minimum}"),
                    at: None,
                });
            }
        }
        Ok(())
    }

    /// The moving `cup` of `step` lies flush on a surface (its touchdown
    /// survived the scene's contacts).
    fn flush_after(&self, step: &Step, cup: Cup) -> Result<(), Rejection> {
        let (centre, angle) = cup_face(self.robot, &step.held, cup);
        if self.flush(centre, angle) {
            Ok(())
        } else {
            Err(Rejection {
                blocking: Blocking::Reach,
                phase: step.phase,
                detail: format!(
                    "among the solids the {cup} cup no longer lies flush at ({:.4}, {:.4}) m, its face at {:.2} deg",
                    centre[0],
                    centre[1],
                    angle.to_degrees()
                ),
                at: None,
            })
        }
    }

    fn flush(&self, centre: Vec2, angle: f64) -> bool {
        flush_on(self.robot, self.scene, centre, angle)
    }

    /// The touchdowns of `moving` with the other cup held by `holding`: tube
    /// lengths and footholds (module doc, step 1).
    fn touchdowns(&mut self, holding: Hold, moving: Cup) -> Result<Vec<([f64; 2], Foothold)>, InputError> {
        let limits = &self.robot.limits;
        let (lo, hi) = (limits.tube_length_min_m, limits.tube_length_max_m);
        let n = self.options.grid.max(2);
        // Seeds near a surface and near flush, those whose face is over a
        // spot nearest the goal first (fewest strides), at most one per
        // SEED_SPACING_M of surface: neighbouring seeds lead Newton to the
        // same touchdown, so only a few start it.
        let goal = self.goal.point_m;
        let mut seeds = Vec::new();
        // Along each row of the grid every solve is warm from the last one
        // (a front hold's cold solve follows the load from zero).
        for i in 0..n {
            if self.out_of_time() {
                break;
            }
            let mut near: Option<Held> = None;
            for j in 0..n {
                let seed = [lo + (hi - lo) * i as f64 / (n - 1) as f64, lo + (hi - lo) * j as f64 / (n - 1) as f64];
                let solved = match &near {
                    Some(held) => self.face_near(held, moving, seed),
                    None => self.face_held(holding, moving, seed),
                };
                let Some((centre, angle, held)) = solved else {
                    near = None;
                    continue;
                };
                near = Some(held);
                let Some((target, direction)) = self.scene.surface_frame(centre) else { continue };
                let (distance, ..) = self.scene.signed_distance(centre);
                let off = angle_difference(angle, direction).abs();
                if distance.abs() <= SEED_DISTANCE_M && off <= SEED_ANGLE_DEG.to_radians() {
                    seeds.push((norm(sub(target, goal)), seed, target, direction));
                }
            }
        }
        seeds.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut spread: Vec<(f64, [f64; 2], Vec2, f64)> = Vec::new();
        for seed in seeds {
            if spread.len() == SEEDS_TRIED {
                break;
            }
            if spread.iter().all(|s| norm(sub(s.2, seed.2)) >= SEED_SPACING_M) {
                spread.push(seed);
            }
        }
        let mut found: Vec<([f64; 2], Foothold)> = Vec::new();
        for (_, seed, target, direction) in spread {
            for tilt in TILTS_DEG {
                let Some(lengths) = self.lay(holding, moving, seed, target, direction, tilt.to_radians()) else {
                    continue;
                };
                let same = |l: &[f64; 2]| (0..2).all(|k| (l[k] - lengths[k]).abs() < SAME_TOUCHDOWN_M);
                if found.iter().any(|(l, _)| same(l)) {
                    continue;
                }
                let Some((centre, angle, held)) = self.face_held(holding, moving, lengths) else { continue };
                if !self.flush(centre, angle) || !held.within_stop(self.robot) {
                    continue;
                }
                if let Some((on, direction)) = self.scene.surface_frame(centre) {
                    found.push((lengths, Foothold { centre_m: on, direction_rad: direction }));
                }
            }
            if self.out_of_time() {
                break;
            }
        }
        Ok(found)
    }

    /// Touchdowns of `moving` among the solids with the other cup held by
    /// `holding`, where its face comes to rest on a surface (a released unit
    /// on a floor, a front cup pressed on a wall): from each of `bases` (both
    /// tubes, m), the difference between the tubes (secant on the resting
    /// face's tilt from 0 and [`RESTING_STEP_M`], within
    /// [`RESTING_DIFFERENCE_M`] either way, at most [`RESTING_TRIES`] solves)
    /// at which the face lies flush.
    fn resting_touchdowns(&mut self, holding: Hold, moving: Cup, bases: &[f64]) -> Vec<([f64; 2], Foothold)> {
        let limits = &self.robot.limits;
        let (lo, hi) = (limits.tube_length_min_m, limits.tube_length_max_m);
        let mut found = Vec::new();
        for &base in bases {
            let at = |x: f64| [(base + x.max(0.0)).clamp(lo, hi), (base + (-x).max(0.0)).clamp(lo, hi)];
            // The resting face's tilt off its surface (rad), whether it lies flush, and the foothold.
            let rest = |planner: &mut Self, x: f64| -> Option<(f64, bool, Foothold)> {
                planner.solves += 1;
                let solved = stance::solve_among(
                    planner.robot,
                    at(x),
                    holding,
                    planner.scene,
                    &planner.options.solver,
                    FreeCups::Rest,
                );
                let held = solved.ok()?;
                let (centre, angle) = cup_face(planner.robot, &held, moving);
                let (on, direction) = planner.scene.surface_frame(centre)?;
                let foothold = Foothold { centre_m: on, direction_rad: direction };
                Some((angle_difference(angle, direction), planner.flush(centre, angle), foothold))
            };
            // Secant on the tilt from the tries at 0 and one step, within the range.
            let mut tries: Vec<(f64, f64)> = Vec::new();
            let mut x = 0.0;
            for _ in 0..RESTING_TRIES {
                let Some((tilt, flush, foothold)) = rest(self, x) else { break };
                if flush {
                    found.push((at(x), foothold));
                    break;
                }
                tries.push((x, tilt));
                x = match tries.as_slice() {
                    [.., (x0, t0), (x1, t1)] if (t1 - t0).abs() > 1e-12 => x1 - t1 * (x1 - x0) / (t1 - t0),
                    [(x0, _)] => x0 + RESTING_STEP_M,
                    _ => break,
                };
                if !(x.abs() <= RESTING_DIFFERENCE_M) {
                    break;
                }
            }
            if self.out_of_time() {
                break;
            }
        }
        found
    }

    /// The moving cup's face (centre, angle) at `lengths` in free space, with the equilibrium.
    fn face_held(&mut self, holding: Hold, moving: Cup, lengths: [f64; 2]) -> Option<(Vec2, f64, Held)> {
        self.solves += 1;
        let held = stance::solve(self.robot, lengths, holding, &self.options.solver).ok()?;
        let (centre, angle) = cup_face(self.robot, &held, moving);
        Some((centre, angle, held))
    }

    /// [`Self::face_held`] warm from `near` ([`stance::solve_near`]), with the equilibrium.
    fn face_near(&mut self, near: &Held, moving: Cup, lengths: [f64; 2]) -> Option<(Vec2, f64, Held)> {
        self.solves += 1;
        let held = stance::solve_near(self.robot, lengths, near, &self.options.solver).ok()?;
        let (centre, angle) = cup_face(self.robot, &held, moving);
        Some((centre, angle, held))
    }

    /// Newton on the two lengths from `seed` laying the moving cup's face on
    /// the line through `on` along `direction` (rad): its lower rim [`HOVER_M`]
    /// above the line and its angle `tilt` (rad) off the line's; the lengths
    /// kept within the range.
    fn lay(
        &mut self,
        holding: Hold,
        moving: Cup,
        seed: [f64; 2],
        on: Vec2,
        direction: f64,
        tilt: f64,
    ) -> Option<[f64; 2]> {
        let limits = &self.robot.limits;
        let (lo, hi) = (limits.tube_length_min_m, limits.tube_length_max_m);
        let normal = crate::geom::right_normal(direction);
        // The lower rim HOVER_M above the line.
        let height = HOVER_M + 0.5 * self.robot.cup.diameter_m * tilt.sin().abs();
        // The centre's height above the line (m), and the tilt error (rad);
        // each solve warm from the last iterate's equilibrium.
        let residual = |planner: &mut Self, near: &Held, l: [f64; 2]| -> Option<([f64; 2], Held)> {
            let (c, angle, held) = planner.face_near(near, moving, l)?;
            Some(([-crate::geom::dot(normal, sub(c, on)) - height, angle_difference(angle, direction) - tilt], held))
        };
        let (.., mut near) = self.face_held(holding, moving, seed)?;
        let mut l = seed;
        for _ in 0..TOUCHDOWN_ITERATIONS {
            if self.out_of_time() {
                return None;
            }
            let (r, held) = residual(self, &near, l)?;
            near = held;
            if r[0].abs() < TOUCHDOWN_TOLERANCE_M && r[1].abs() < TOUCHDOWN_TOLERANCE_M {
                return Some(l);
            }
            // Forward differences, stepping inwards at the range's ends.
            let mut jac = [[0.0; 2]; 2];
            for k in 0..2 {
                let h = if l[k] + DIFFERENCE_M > hi { -DIFFERENCE_M } else { DIFFERENCE_M };
                let mut lk = l;
                lk[k] += h;
                let (rk, _) = residual(self, &near, lk)?;
                jac[0][k] = (rk[0] - r[0]) / h;
                jac[1][k] = (rk[1] - r[1]) / h;
            }
            let det = jac[0][0] * jac[1][1] - jac[0][1] * jac[1][0];
            if !(det.abs() > 1e-14) {
                return None;
            }
            let d = [(-r[0] * jac[1][1] + r[1] * jac[0][1]) / det, (r[0] * jac[1][0] - r[1] * jac[0][0]) / det];
            // At most 20 mm per iteration: the map is far from linear.
            let scale = (0.02 / d[0].abs().max(d[1].abs())).min(1.0);
            let next = [(l[0] + scale * d[0]).clamp(lo, hi), (l[1] + scale * d[1]).clamp(lo, hi)];
            if next == l {
                return None;
            }
            l = next;
        }
        None
    }
}

/// A rejection for bad input met inside a stride (a robot the touchdown
/// search cannot build).
fn input_rejection(e: InputError) -> Rejection {
    Rejection { blocking: Blocking::Reach, phase: Phase::Pull, detail: e.to_string(), at: None }
}

/// Whether a cup's face (centre, angle in rad) lies flush on one edge of
/// `scene` within `robot`'s attach tolerances: where the cup may attach.
pub fn flush_on(robot: &Robot, scene: &Scene, centre: Vec2, angle: f64) -> bool {
    let cup = &robot.cup;
    scene.flat_on_one_edge(
        centre,
        angle,
        0.5 * cup.diameter_m,
        cup.attach_distance_tolerance_m,
        cup.attach_angle_tolerance_deg.to_radians(),
    )
}

/// A hold's pose where a cup came to rest on a surface along `direction`
/// (rad), pressed into it by the robot file's preload.
pub fn pressed(robot: &Robot, pose: Pose, direction: f64) -> Pose {
    let into = crate::geom::right_normal(direction);
    Pose { point_m: crate::geom::add_scaled(pose.point_m, robot.cup.preload_m, into), angle_rad: pose.angle_rad }
}

/// The driving unit's pose that puts the rear cup on `foothold`.
pub fn rear_pose(robot: &Robot, foothold: Foothold) -> Pose {
    stance::rear_pose_for_cup(robot, foothold.centre_m, foothold.direction_rad)
}

/// The face (centre, angle) of `cup` in `held`: the rear cup's along the
/// driving unit, the front cup's along the plate.
pub fn cup_face(robot: &Robot, held: &Held, cup: Cup) -> (Vec2, f64) {
    match cup {
        Cup::Rear => (held.rear_cup_m(robot), held.unit.angle_rad),
        Cup::Front => (held.front_cup_m(robot), held.plate_angle()),
    }
}
