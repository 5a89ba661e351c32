//! The simulated robot's body: a [`Cups`] model backed by leech's statics,
//! so that a simulated cup seals only where the body really puts its face.
//!
//! Rules (the climb planner's, `leech::stride::plan`, so that a plan's
//! touchdowns seal in the simulation as they were planned):
//!
//! * **Lengths.** LA is L1; LB is the mean of L2 and L3 (m).
//! * **Holds.** The body is held by the cups the device says hold. A cup
//!   that starts holding is fixed where its face is at that moment: the
//!   driving unit's pose for the rear cup, the endpoint and plate for the
//!   front one, each pressed into its surface by the robot file's
//!   `cup.preload_m` (the planner's hold poses). A cup that lets go frees
//!   its end; while no cup holds, the body keeps its last holds (it lies
//!   where it was). Before any cup holds, the rear hold is the starting
//!   foothold's.
//! * **Equilibrium.** The body among the scene's solids with
//!   [`FreeCups::Rest`] (a free cup's face rests on what it meets), at the
//!   lengths and under the holds, continued from the equilibrium it was in
//!   ([`stance::solve_after`]: the tubes fed from where they were, a cup
//!   released from the both-held state, attached from the free one); fed
//!   from the shortest length ([`stance::solve_among`]) where there is none
//!   yet, or where the lengths and the holds changed at once (no single phase).
//! * **Seal.** A holding cup stays sealed. A free cup is sealed when its
//!   face lies flush on a surface within the robot file's
//!   `cup.attach_distance_tolerance_m` and `cup.attach_angle_tolerance_deg`
//!   ([`Scene::flat_on_one_edge`]); with its pump off the question does
//!   not arise and nothing is solved.
//! * **Cost.** The control loop observes every millisecond; a solve takes
//!   milliseconds to tens of them, so none runs on the device's thread:
//!   [`Cups::observe`] only hands the latest lengths, pumps and holds to the
//!   body's own solver thread, and [`Cups::sealed`] reads what that thread
//!   last found (a seal is known a solve later, well within the vacuum's
//!   build-up time). The solver keeps the last equilibrium and solves again
//!   only when a length changed by more than [`RESOLVE_M`] or the holds
//!   changed, and only when a free cup's pump runs, a hold starts, or
//!   [`BodyCups::pose`] asks.
//!
//! The model is shared: [`BodyCups`] is a handle, its clones see the same
//! body (one goes into the [`crate::sim::Sim`], a test keeps another); the
//! solver thread ends when the last clone is dropped.

use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;

use leech::geom::Vec2;
use leech::robot::Robot;
use leech::scene::Scene;
use leech::stance::{self, FreeCups, Held, Hold, Pose, StanceError};
use leech::statics::Solver;
use leech::stride::{plan, Foothold};
use leech_protocol::message::Cup;

use crate::sim::Cups;

/// A length change that calls for a new equilibrium (m).
pub const RESOLVE_M: f64 = 1e-4;

/// Where the simulated body is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyPose {
    /// Tube lengths of the equilibrium, LA and LB (m).
    pub lengths_m: [f64; 2],
    /// The driving unit's pose.
    pub unit: Pose,
    /// The endpoint (m) and the plate's angle (rad).
    pub endpoint: Pose,
    /// Centre of the rear cup's face (m).
    pub rear_cup_m: Vec2,
    /// Centre of the front cup's face (m).
    pub front_cup_m: Vec2,
    /// The holds the body is under.
    pub hold: Hold,
}

/// The simulated body as a [`Cups`] model (module doc); clones share it.
#[derive(Clone)]
pub struct BodyCups {
    shared: Arc<Shared>,
    /// Stops and joins the solver thread when the last clone goes.
    _solver: Arc<SolverThread>,
}

/// What the device's thread and the solver's thread share.
struct Shared {
    /// The model and its last equilibrium: the solver's (and `pose`'s).
    model: Mutex<Inner>,
    /// The latest observation, for the solver to take.
    latest: Mutex<Latest>,
    /// Signals a new observation, or the end.
    wake: Condvar,
    /// Whether each cup is sealed, as of the last observation solved.
    sealed: Mutex<[bool; 2]>,
}

/// An observation waiting for the solver.
#[derive(Clone, Copy)]
struct Latest {
    /// LA and LB (m), the pumps running and the cups holding.
    lengths: [f64; 2],
    pumps: [bool; 2],
    holding: [bool; 2],
    /// Whether the solver has not seen it yet.
    fresh: bool,
    /// Whether the solver thread must end.
    stop: bool,
}

/// The solver thread's handle.
struct SolverThread {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
}

impl Drop for SolverThread {
    fn drop(&mut self) {
        lock(&self.shared.latest).stop = true;
        self.shared.wake.notify_all();
        if let Some(thread) = self.thread.take() {
            // A panic in a solve is over too; the device goes on without seals.
            let _ = thread.join();
        }
    }
}

/// Locks `mutex`; a panic while it was held leaves usable data behind.
fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

struct Inner {
    robot: Robot,
    scene: Scene,
    solver: Solver,
    /// The holds the body is under.
    hold: Hold,
    /// What the device last said holds (rear, front).
    holding: [bool; 2],
    /// The last lengths observed, LA and LB (m).
    lengths: [f64; 2],
    /// The last equilibrium: lengths, holds, result.
    solved: Option<([f64; 2], Hold, Result<Held, StanceError>)>,
}

impl BodyCups {
    /// The body of `robot` in `scene`, its rear cup on `start` (the tubes'
    /// lengths come with the first observation; until then, the shortest).
    pub fn new(robot: Robot, scene: Scene, start: Foothold) -> BodyCups {
        let hold = Hold::Rear(leech::stride::plan::rear_pose(&robot, start));
        let short = robot.limits.tube_length_min_m;
        let inner = Inner {
            robot,
            scene,
            solver: Solver::default(),
            hold,
            holding: [false; 2],
            lengths: [short; 2],
            solved: None,
        };
        let latest = Latest { lengths: [short; 2], pumps: [false; 2], holding: [false; 2], fresh: false, stop: false };
        let shared = Arc::new(Shared {
            model: Mutex::new(inner),
            latest: Mutex::new(latest),
            wake: Condvar::new(),
            sealed: Mutex::new([false; 2]),
        });
        let thread = std::thread::Builder::new()
            .name("leech-sim-body".into())
            .spawn({
                let shared = Arc::clone(&shared);
                move || solve_observations(&shared)
            })
            .expect("the body's solver thread starts");
        let solver = SolverThread { shared: Arc::clone(&shared), thread: Some(thread) };
        BodyCups { shared, _solver: Arc::new(solver) }
    }

    /// The holds the body is under now.
    pub fn hold(&self) -> Hold {
        lock(&self.shared.model).hold
    }

    /// The body's equilibrium itself at the last lengths observed, under
    /// its holds (solved now if the last one is stale): what a display draws.
    pub fn held(&self) -> Result<Held, StanceError> {
        lock(&self.shared.model).held()
    }

    /// The body's equilibrium at the last lengths observed, under its holds
    /// (solved now if the last one is stale).
    pub fn pose(&self) -> Result<BodyPose, StanceError> {
        let mut inner = lock(&self.shared.model);
        let lengths = inner.lengths;
        let held = inner.held()?;
        let robot = &inner.robot;
        Ok(BodyPose {
            lengths_m: lengths,
            unit: held.unit,
            endpoint: Pose { point_m: held.endpoint_m, angle_rad: held.plate_angle() },
            rear_cup_m: held.rear_cup_m(robot),
            front_cup_m: held.front_cup_m(robot),
            hold: held.hold,
        })
    }
}

impl Inner {
    /// The equilibrium at the current lengths and holds, from the cache when
    /// it is close enough.
    fn held(&mut self) -> Result<Held, StanceError> {
        if let Some((lengths, hold, result)) = &self.solved {
            if *hold == self.hold && (0..2).all(|i| (lengths[i] - self.lengths[i]).abs() <= RESOLVE_M) {
                return result.clone();
            }
        }
        let (robot, scene, solver) = (&self.robot, &self.scene, &self.solver);
        let cold = || stance::solve_among(robot, self.lengths, self.hold, scene, solver, FreeCups::Rest);
        let result = match &self.solved {
            Some((_, _, Ok(before))) => {
                match stance::solve_after(robot, before, self.lengths, self.hold, scene, solver, FreeCups::Rest) {
                    Err(StanceError::Input(_)) => cold(),
                    continued => continued,
                }
            }
            _ => cold(),
        };
        self.solved = Some((self.lengths, self.hold, result.clone()));
        result
    }

    /// Where `cup`'s hold fixes the body now that it seals: its face where
    /// the equilibrium puts it, pressed into the surface below it.
    fn hold_pose(&mut self, cup: Cup) -> Option<Pose> {
        let held = self.held().ok()?;
        let pose = match cup {
            Cup::Rear => held.unit,
            Cup::Front => Pose { point_m: held.endpoint_m, angle_rad: held.plate_angle() },
        };
        let (centre, _) = plan::cup_face(&self.robot, &held, stride_cup(cup));
        let (_, direction) = self.scene.surface_frame(centre)?;
        Some(plan::pressed(&self.robot, pose, direction))
    }

    /// The holds after the device's cups went from `self.holding` to `holding`.
    fn update_holds(&mut self, holding: [bool; 2]) {
        let [rear, front] = holding;
        // A new hold keeps the pose the current holds already give that cup
        // (the starting foothold), else takes the face's pose now.
        let pose = |inner: &mut Inner, cup: Cup| {
            let kept = match cup {
                Cup::Rear => inner.hold.rear(),
                Cup::Front => inner.hold.front(),
            };
            kept.or_else(|| inner.hold_pose(cup))
        };
        let rear_pose = if rear { pose(self, Cup::Rear) } else { None };
        let front_pose = if front { pose(self, Cup::Front) } else { None };
        self.hold = match (rear_pose, front_pose) {
            (Some(rear), Some(front)) => Hold::Both { rear, front },
            (Some(rear), None) => Hold::Rear(rear),
            (None, Some(front)) => Hold::Front(front),
            // No cup holds (or a hold's pose could not be found): the body
            // lies where its last holds left it.
            (None, None) => self.hold,
        };
        self.holding = holding;
    }

    /// Whether the free `cup`'s face lies flush on a surface now.
    fn flush(&mut self, cup: Cup) -> bool {
        let Ok(held) = self.held() else { return false };
        let (centre, angle) = plan::cup_face(&self.robot, &held, stride_cup(cup));
        plan::flush_on(&self.robot, &self.scene, centre, angle)
    }
}

/// The planner's name of a cup on the wire.
fn stride_cup(cup: Cup) -> leech::stride::Cup {
    match cup {
        Cup::Rear => leech::stride::Cup::Rear,
        Cup::Front => leech::stride::Cup::Front,
    }
}

/// The solver thread: each new observation updates the holds and the seals.
fn solve_observations(shared: &Shared) {
    loop {
        let seen = {
            let mut latest = lock(&shared.latest);
            while !latest.fresh && !latest.stop {
                latest = shared.wake.wait(latest).unwrap_or_else(PoisonError::into_inner);
            }
            if latest.stop {
                return;
            }
            latest.fresh = false;
            *latest
        };
        let mut inner = lock(&shared.model);
        inner.lengths = seen.lengths;
        if seen.holding != inner.holding {
            inner.update_holds(seen.holding);
        }
        let mut sealed = [false; 2];
        for cup in Cup::BOTH {
            let i = cup.index();
            sealed[i] = seen.holding[i] || (seen.pumps[i] && inner.flush(cup));
        }
        drop(inner);
        *lock(&shared.sealed) = sealed;
    }
}

impl Cups for BodyCups {
    fn sealed(&self, cup: Cup, _lengths_m: [f64; 3]) -> bool {
        lock(&self.shared.sealed)[cup.index()]
    }

    fn observe(&mut self, lengths_m: [f64; 3], pumps: [bool; 2], holding: [bool; 2]) {
        let lengths = [lengths_m[0], 0.5 * (lengths_m[1] + lengths_m[2])];
        let mut latest = lock(&self.shared.latest);
        let changed = latest.lengths != lengths || latest.pumps != pumps || latest.holding != holding;
        if changed {
            (latest.lengths, latest.pumps, latest.holding, latest.fresh) = (lengths, pumps, holding, true);
            drop(latest);
            self.shared.wake.notify_one();
        }
    }
}
